"""The ``realize`` command of ``python -m pes_ref``: ``realize DESIGN.npz --as contact --out DIR
[--rule level-set|visited|value] [--level E] [--pin-radius R] [--rim W] [--thickness T]
[--drum-radius R] [--force]``.

It turns a saved design into parts (:mod:`pes_ref.realize`, ``docs/realize.md``), writes
``DIR/device.toml`` and the follower's files (:data:`CONTACT_FILES`: a plane's
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

import io
import os
import sys
import time

from pes_ref.cli.common import EXIT_OK, LazyDefault, add_command, error, input_file, output_file, output_folder

#: The files each realization writes into ``--out``, and what each is (for refusals).
HEIGHTFIELD_FILES = {"stl": ("heightfield.stl", "STL")}
#: A contact realization's files, per follower (:data:`pes_ref.realize.followers.FOLLOWERS`' names).
CONTACT_FILES = {
    "pin-in-plate": {"device": ("device.toml", "device"), "dxf": ("plate.dxf", "DXF"),
                     "plate_stl": ("plate.stl", "STL"), "base_stl": ("base.stl", "STL"), "pin_stl": ("pin.stl", "STL"),
                     "png": ("parts.png", "drawing")},
    "drum-cam": {"device": ("device.toml", "device"), "dxf": ("drum.dxf", "DXF"), "drum_stl": ("drum.stl", "STL"),
                 "pin_stl": ("pin.stl", "STL"), "png": ("parts.png", "drawing")},
}
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
    from pes_ref.realize.followers import follower_for
    return CONTACT_FILES[follower_for(state.problem.periodic).name]


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
    _write(real, state, outputs, args.force)
    region = real.region
    lines = [f"rule: {region.rule}", f"level: {region.level:.6g}", f"blocked_share: {region.blocked_share:.6g}"]
    lines += [f"neighbour: {label}: level {level:.6g}, blocked_share {share:.6g}, changed_share {changed:.6g}"
              for label, level, share, changed in real.sensitivity]
    lines += [f"lost: {line}" for line in real.lost]
    return lines + _figure_lines(_check(real, outputs)) + _figure_lines(_scores(state, outputs["device"], args))


def _write(real, state, outputs: dict, force: bool) -> None:
    """The files as one set: the drawings and meshes made whole in a staging folder inside
    ``--out`` and moved into place (:func:`pes_ref.core.runtime.files.move_into`), then the set's
    index, ``device.toml``, written last and atomically; a stop part-way leaves no half file."""
    import shutil
    import tempfile
    from pes_ref.core.runtime.files import move_into
    from pes_ref.realize import exports
    from pes_ref.realize.drawing import parts_figure
    from pes_ref.realize.evaluation import held_out_positions
    from pes_ref.realize.regions import VISITED_SEED
    folder = os.path.dirname(outputs["device"]) or "."
    os.makedirs(folder, exist_ok=True)
    staging = tempfile.mkdtemp(prefix=".realize-", dir=folder)
    try:
        staged = {key: os.path.join(staging, os.path.basename(path)) for key, path in outputs.items()}
        exports.write_dxf(staged["dxf"], real.parts.plate, False)
        for key, mesh in MESHES[real.parts.follower][0](real).items():
            exports.write_stl(staged[key], mesh, False)
        path = held_out_positions(state.problem, state.values, VISITED_SEED, n_particles=1)[:, 0, :]
        buf = io.BytesIO()
        parts_figure(real, path).savefig(buf, format="png", dpi=110)
        exports.write_bytes(staged["png"], buf.getvalue(), False, "drawing")
        move_into([staged[key] for key in outputs if key != "device"], folder)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    header = f"{real.device['description']}\nwritten by pes_ref realize (docs/realize.md)"
    exports.write_text(outputs["device"], exports.device_text(real.device, header), force, "device")


def _plate_meshes(real) -> dict:
    from pes_ref.realize import exports
    plate, t = real.parts.plate, real.thickness
    return {"plate_stl": exports.plate_mesh(plate, t), "base_stl": exports.base_mesh(plate, t),
            "pin_stl": exports.pin_mesh(real.parts.pin_made, t)}


def _drum_meshes(real) -> dict:
    from pes_ref.realize import exports
    parts, t = real.parts, real.thickness
    return {"drum_stl": exports.drum_mesh(parts.plate, parts.motion["radius"], t, _drum_cell(real)),
            "pin_stl": exports.pin_mesh(parts.pin_made, t)}


def _drum_cell(real) -> float:
    """The drum STL's node spacing: a quarter of the design grid's finer spacing on the drum's surface."""
    return float(min(real.region.spacing * [1.0, real.parts.motion["radius"]])) / 4.0


#: Per follower: its meshes (realization -> {output key: mesh}) and the volume the first
#: mesh should have, from the part read back from the DXF (realization, part -> (name, volume)).
MESHES = {
    "pin-in-plate": (_plate_meshes, lambda real, part: ("plate_volume_expected", float(part.area * real.thickness))),
    "drum-cam": (_drum_meshes, lambda real, part: ("drum_volume_expected", _drum_volume(real, part))),
}


def _drum_volume(real, part) -> float:
    from pes_ref.realize import exports
    return exports.drum_volume(part, real.parts.motion["radius"], real.thickness)


def _scores(state, device_path: str, args) -> dict:
    """The design's headline figure on held-out seed ``--seed`` beside the parts' under eq. (1)
    (``realized_``) and in rigid contact (``rigid_``; not run without pymunk, said with its
    pip line): :func:`pes_ref.realize.evaluation.evaluate_realized`."""
    from pes_ref.devices.device_file import load_device
    from pes_ref.devices.geometry import MissingExtraError
    from pes_ref.realize.evaluation import ENGINES, evaluate_realized
    from pes_ref.rigid import require_pymunk
    from pes_ref.synthesis import kind_of
    seed = 12345 if args.seed is None else args.seed
    try:
        require_pymunk()
        engines, missing = ("surface", "rigid"), None
    except MissingExtraError as exc:
        engines, missing = ("surface",), str(exc)
    figures = evaluate_realized(state.problem, state.values, load_device(device_path), seed=seed,
                                n_particles=args.particles, engines=engines)
    name = kind_of(state.problem).headline
    out = {"score_seed": seed, "score_particles": int(figures["particles"][0]), name: figures[name][0]}
    out.update({ENGINES[e].prefix + name: x for e, x in zip(engines, figures[name][1:])})
    if missing is not None:
        out[ENGINES["rigid"].prefix + name] = f"not run ({missing})"
    return out


def _check(real, outputs: dict) -> dict:
    """Every file read back: the device's C-space, the DXF's part, the meshes."""
    from pes_ref.devices.device_file import load_device
    from pes_ref.realize import exports
    device = load_device(outputs["device"])
    part = exports.read_dxf_plate(outputs["dxf"])
    file_part = device.parts[1].geometry(device.grid.tolerance)
    name = real.parts.part_name
    out = {"device_blocked_share": float(device.cspace().blocked.mean()),
           f"{name}_area_dxf": float(part.area), f"{name}_area_device": float(file_part.area)}
    for key in outputs:
        if key.endswith("_stl"):
            mesh = exports.read_stl(outputs[key])
            out[f"{key[:-4]}_watertight"] = bool(mesh.is_watertight)
            out[f"{key[:-4]}_volume"] = float(mesh.volume)
    expected, volume = MESHES[real.parts.follower][1](real, part)
    out[expected] = volume
    return out


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
    import numpy as np
    from pes_ref.realize import exports
    from pes_ref.realize.heightfield import HeightField, heightfield_check, heightfield_mesh, heights_from_mesh
    hf, base, seed, n, n_steps = job
    mesh = heightfield_mesh(hf, base)
    os.makedirs(args.out, exist_ok=True)
    exports.write_stl(outputs["stl"], mesh, args.force)
    mesh = exports.read_stl(outputs["stl"])
    heights = heights_from_mesh(mesh, hf)
    slope = hf.slope()
    figures = {"g": hf.g, "height_range": float(np.ptp(hf.heights)), "max_slope": float(slope.max()),
               "slope_share_over_0.1": float(np.mean(slope > 0.1)), "watertight": bool(mesh.is_watertight),
               "volume": float(mesh.volume), "height_error": float(np.max(np.abs(heights - hf.heights))),
               "seed": seed, "particles": n}
    read_back = HeightField(heights, hf.lower, hf.upper, hf.mass, hf.g)
    figures.update(heightfield_check(state.problem, state.values, read_back, seed, n, n_steps))
    return _figure_lines(figures)


#: The realizations: --as NAME -> (prepare(state, args) -> job, write(job, state, outputs, args) -> lines,
#: files(state) -> the files it writes, known before anything is computed).
REALIZATIONS = {"contact": (_prepare_contact, _write_contact, _contact_files),
                "heightfield": (_prepare_heightfield, _write_heightfield, lambda state: HEIGHTFIELD_FILES)}
