"""The ``realize`` command of ``python -m pes_ref``: ``realize DESIGN.npz --as contact --out DIR
[--rule level-set|visited|value] [--level E] [--pin-radius R] [--rim W] [--thickness T]
[--drum-radius R] [--force]``.

It turns a saved design into parts (:mod:`pes_ref.realize`, ``docs/realize.md``), writes
``DIR/device.toml`` and the follower's files (:data:`pes_ref.realize.files.CONTACT_FILES`: a plane's
``plate.dxf``, ``plate.stl``, ``base.stl``; a cylinder's ``drum.dxf``, ``drum.stl``; both
``pin.stl`` and ``parts.png``; each checked before anything is written, an existing one kept
unless ``--force``; the set made whole in a staging folder, ``device.toml`` written last),
then reads every file back and prints one ``name: value`` line per figure of the check: the
blocked share of the C-space the device file's parts give against the design's, the part's
area from the DXF against the device file's, and the STL meshes' watertightness and volume.

``realize DESIGN.npz --as heightfield --out DIR [--g G] [--base B] [--seed S] [--particles N]
[--steps N] [--force]`` writes ``DIR/heightfield.stl``, reads it back and prints the held-out
figures of the design's particle, the rolling ball and the ball in MuJoCo
(:func:`pes_ref.realize.heightfield.heightfield_check`; without the extra ``mujoco``, one
``mujoco: not run: ...`` line with its pip line).
"""
from __future__ import annotations

import os
import sys
import time

from pes_ref.cli.common import EXIT_OK, LazyDefault, add_command, error, input_file, output_file, output_folder

#: The library's names of what the options set, and the options (errors name the option).
FLAGS = {"pin_radius": "--pin-radius", "rim": "--rim", "thickness": "--thickness", "level": "--level",
         "drum_radius": "--drum-radius", "clearance": "--clearance", "restitution": "--restitution",
         "as": "--as", "rule": "--rule", "g": "--g", "base": "--base", "seed": "--seed", "n_particles": "--particles",
         "n_steps": "--steps"}
#: Each realization's own options (``dest``, flag): given with the other, they are refused.
OPTIONS = {"contact": (("rule", "--rule"), ("level", "--level"), ("pin_radius", "--pin-radius"), ("rim", "--rim"),
                       ("thickness", "--thickness"), ("drum_radius", "--drum-radius"), ("clearance", "--clearance"),
                       ("restitution", "--restitution")),
           "heightfield": (("g", "--g"), ("base", "--base"), ("steps", "--steps"))}


def _default(key: str) -> LazyDefault:
    """``key``'s default, :data:`pes_ref.realize.contact.CONTACT_DEFAULTS` (read when needed)."""
    return LazyDefault("pes_ref.realize.contact", "CONTACT_DEFAULTS", key)


def _hf_default(key: str) -> LazyDefault:
    """``key``'s default, :data:`pes_ref.realize.heightfield.HEIGHTFIELD_DEFAULTS` (read when needed)."""
    return LazyDefault("pes_ref.realize.heightfield", "HEIGHTFIELD_DEFAULTS", key)


def add_parser(sub) -> None:
    p = add_command(sub, "realize", help="turn a saved design into parts: a device file, DXF, STL and a drawing",
        description="Realize a saved design by contact (--as contact): its blocked region (the design energy above "
                    "a contact level chosen by --rule) becomes a plate with cut-outs and a pin (a plane design), or "
                    "the walls of a drum cam of radius --drum-radius and a pin moving along the drum's axis (a "
                    "cylinder design, the oscillator). Writes "
                    "DIR/device.toml (the device-file format: analyze and evaluate --realized read it), "
                    "DIR/plate.dxf, DIR/plate.stl, DIR/base.stl (the slab the plate's pieces stand on), or DIR/drum.dxf "
                    "(the walls unrolled) and DIR/drum.stl, then DIR/pin.stl and DIR/parts.png, reads them back and prints "
                    "the check: blocked shares, the plate's area from the DXF, the meshes' watertightness. "
                    "--as heightfield writes DIR/heightfield.stl, a plate whose top is h = E / (m g), reads it back "
                    "and runs the held-out particles as rolling balls on it (7/5 the mass; with and without the "
                    "slope's shortening of the force) and as balls on a MuJoCo heightfield (the optional extra "
                    "'mujoco'; without it that line says how to install it): max_slope and the in-band fractions. "
                    "Needs the optional extra 'realize' (pip install 'pes_ref[realize]'). docs/realize.md.",
        examples=["realize funnel.npz --as contact --out funnel_parts",
                  "realize osc.npz --as contact --drum-radius 1 --out osc_drum",
                  "realize funnel.npz --as heightfield --out funnel_plate"])
    p.add_argument("file", metavar="DESIGN.npz", help="a design file written by 'design'")
    p.add_argument("--as", dest="as_", choices=tuple(REALIZATIONS), required=True,
                   help="the realization: 'contact' (rigid parts and eq. (1)) or 'heightfield' (a plate whose top "
                        "is the energy, for a rolling ball)")
    p.add_argument("--out", required=True, metavar="DIR", help="folder to write into (made if missing)")
    p.add_argument("--rule", default=None, choices=("level-set", "visited", "value"),
                   help="how the contact level is chosen (default: 'level-set' for a design made realizable, "
                        "else 'visited')")
    p.add_argument("--level", type=float, default=None, metavar="E", help="the contact level of --rule value")
    p.add_argument("--pin-radius", type=float, default=_default("pin_radius"), metavar="R",
                   help="the pin's radius (C-space length)")
    p.add_argument("--clearance", type=float, default=None, metavar="C",
                   help="make the pin C larger than the plate (or drum) is cut for: the parts' blocked region grows "
                        "by C, so a rigid pin stands off the walls as eq. (1) holds a particle off them (C-space "
                        "length; default: the problem file's [surface.contact] clearance, else 0)")
    p.add_argument("--restitution", type=float, default=None, metavar="E",
                   help="the parts' coefficient of restitution in [0, 1], written to the device file's [rigid] "
                        "table (the rigid engine's; default: the problem file's [surface.contact] restitution, "
                        "else left out: inelastic)")
    p.add_argument("--rim", type=float, default=_default("rim"), metavar="W",
                   help="the plate's rim beyond its cut-out (C-space length)")
    p.add_argument("--thickness", type=float, default=_default("thickness"), metavar="T",
                   help="the plate's and the pin's height in the STL files (C-space length)")
    p.add_argument("--drum-radius", type=float, default=_default("drum_radius"), metavar="R",
                   help="a cylinder design's drum radius (C-space length; the unrolled groove's arc length is R q1)")
    p.add_argument("--g", type=float, default=_hf_default("g"), metavar="G",
                   help="heightfield: gravity, length / time^2 in the design's units (h = E / (m g))")
    p.add_argument("--base", type=float, default=_hf_default("base"), metavar="B",
                   help="heightfield: the plate's thickness below its lowest point (length)")
    p.add_argument("--seed", type=int, default=None, metavar="S",
                   help="the held-out seed of the check (default 12345): contact, the design's held-out evaluation "
                        "on the parts under eq. (1) and in rigid contact (the kind's headline figure); heightfield, "
                        "the rolling-ball check")
    p.add_argument("--particles", type=int, default=None, metavar="N",
                   help="held-out particles of the check (default: the design's held-out evaluation's; heightfield "
                        "200)")
    p.add_argument("--steps", type=int, default=None, metavar="N",
                   help="heightfield: the check's horizon in steps of the design's dt, for the design's particle and "
                        "every ball alike (default the design's own, 350 for the funnel)")
    p.add_argument("--force", action="store_true", help="overwrite existing files in DIR")
    p.set_defaults(func=_run_realize)


def _outputs(args, files: dict) -> dict:
    """Every output path, checked before anything is computed."""
    output_folder(args.out)
    out = {}
    for key, (name, what) in files.items():
        path = os.path.join(args.out, name)
        out[key] = output_file(path, what, force=args.force) if os.path.isdir(args.out) else path
    return out


def _contact_files(state) -> dict:
    """The files of the follower that realizes the design's topology (known before anything is computed)."""
    from pes_ref.realize.files import CONTACT_FILES
    from pes_ref.realize.followers import follower_for
    return CONTACT_FILES[follower_for(state.problem.periodic).name]


def _heightfield_files(state) -> dict:
    from pes_ref.realize.files import HEIGHTFIELD_FILES
    return HEIGHTFIELD_FILES


def _value(option):
    """An option's value: the library's default where it was not given."""
    return option.value() if isinstance(option, LazyDefault) else option


def _refuse_others(args) -> None:
    """An option of the other realization, given, is refused (one line naming both)."""
    for kind, options in OPTIONS.items():
        if kind == args.as_:
            continue
        for dest, flag in options:
            value = getattr(args, dest)
            if value is not None and not isinstance(value, LazyDefault):
                raise ValueError(f"{flag} goes with --as {kind}, not --as {args.as_}")


def _run_realize(args) -> int:
    start = time.perf_counter()
    try:
        from pes_ref.realize.extra import require_realize
        require_realize()
        from pes_ref.synthesis import load_design
        _refuse_others(args)
        state = load_design(input_file(args.file, "design file"))
        prepare, write, files_of = REALIZATIONS[args.as_]
        files = files_of(state)
        outputs = _outputs(args, files)
        job = prepare(state, args)
    except (ValueError, TypeError, OSError, ImportError) as exc:
        return error(exc, FLAGS)
    try:
        lines = write(job, state, outputs, args)
    except (ValueError, OSError) as exc:
        return error(exc, FLAGS)
    for line in lines:
        print(line)
    print(f"seconds: {time.perf_counter() - start:.3g}")
    for key, path in outputs.items():
        print(f"wrote {path} ({files[key][1]})", file=sys.stderr)
    return EXIT_OK


def _figure_lines(figures: dict) -> list:
    return [f"{key}: {value:.6g}" if isinstance(value, float) else f"{key}: {value}" for key, value in figures.items()]


# --------------------------------------------------------------------------- contact

def _prepare_contact(state, args):
    from pes_ref.realize.contact import realize_contact
    if (args.level is not None) != (args.rule == "value"):
        raise ValueError(f"--level E goes with --rule value (the contact level given), got --level {args.level} "
                         f"and --rule {args.rule}")
    name = os.path.splitext(os.path.basename(args.file))[0]
    drum_radius = None if isinstance(args.drum_radius, LazyDefault) else args.drum_radius
    return realize_contact(state.problem, state.values, args.rule, args.level, name=name,
                           pin_radius=_value(args.pin_radius), rim=_value(args.rim), thickness=_value(args.thickness),
                           drum_radius=drum_radius, clearance=args.clearance, restitution=args.restitution)


def _write_contact(real, state, outputs: dict, args) -> list:
    from pes_ref.devices.device_file import load_device
    from pes_ref.realize.evaluation import headline_scores
    from pes_ref.realize.files import check_contact, write_contact
    write_contact(real, state.problem, state.values, outputs, args.force)
    region = real.region
    lines = [f"rule: {region.rule}", f"level: {region.level:.6g}", f"blocked_share: {region.blocked_share:.6g}"]
    lines += [f"neighbour: {label}: level {level:.6g}, blocked_share {share:.6g}, changed_share {changed:.6g}"
              for label, level, share, changed in real.sensitivity]
    lines += [f"lost: {line}" for line in real.lost]
    scores = headline_scores(state.problem, state.values, load_device(outputs["device"]),
                             12345 if args.seed is None else args.seed, args.particles)
    return lines + _figure_lines(check_contact(real, outputs)) + _figure_lines(scores)


# --------------------------------------------------------------------------- heightfield

def _prepare_heightfield(state, args):
    from pes_ref.core import budget, checks
    from pes_ref.realize.heightfield import check_base, check_heightfield_kind, heightfield
    check_heightfield_kind(state.problem)
    seed = checks.as_nonneg_int("seed", 12345 if args.seed is None else args.seed)
    n = checks.as_positive_int("n_particles", 200 if args.particles is None else args.particles)
    steps = state.problem.n_steps if args.steps is None else checks.as_positive_int("n_steps", args.steps)
    budget.check_memory(steps, n, "simulate", particles="n_particles", fixed_steps=True, runs=4,
                        length=f"a held-out run of {steps} steps")
    hf = heightfield(state.problem, state.values, _value(args.g))
    return hf, check_base(hf, _value(args.base)), seed, n, None if args.steps is None else steps


def _write_heightfield(job, state, outputs: dict, args) -> list:
    """The plate written, read back, and the rolling-ball check on the heights read back."""
    from pes_ref.realize.files import write_heightfield
    from pes_ref.realize.heightfield import heightfield_check
    hf, base, seed, n, n_steps = job
    read_back, figures = write_heightfield(hf, base, outputs["stl"], args.force)
    figures.update(seed=seed, particles=n)
    figures.update(heightfield_check(state.problem, state.values, read_back, seed, n, n_steps))
    return _figure_lines(figures)


#: The realizations: --as NAME -> (prepare(state, args) -> job, write(job, state, outputs, args) -> lines,
#: files(state) -> the files it writes, known before anything is computed).
REALIZATIONS = {"contact": (_prepare_contact, _write_contact, _contact_files),
                "heightfield": (_prepare_heightfield, _write_heightfield, _heightfield_files)}
