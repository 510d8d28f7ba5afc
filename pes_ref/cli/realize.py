"""The ``realize`` command of ``python -m pes_ref``: ``realize DESIGN.npz --as contact --out DIR
[--rule level-set|visited|value] [--level E] [--pin-radius R] [--rim W] [--thickness T]
[--drum-radius R] [--force]``.

It turns a saved design into parts ([`pes_ref.realize`][pes_ref.realize], ``docs/realize.md``), writes
``DIR/device.toml`` and the follower's files (`pes_ref.realize.files.CONTACT_FILES`: a plane's
``plate.dxf``, ``plate.stl``, ``base.stl``; a cylinder's ``drum.dxf``, ``drum.stl``; both
``pin.stl`` and ``parts.png``; each checked before anything is written, an existing one kept
unless ``--force``; the set made whole in a staging folder, ``device.toml`` written last),
then reads every file back and prints one ``name: value`` line per figure of the check: the
blocked share of the C-space the device file's parts give against the design's, the part's
area from the DXF against the device file's, and the STL meshes' watertightness and volume.

``realize DESIGN.npz --as heightfield --out DIR [--g G] [--base B] [--seed S] [--particles N]
[--steps N] [--force]`` writes ``DIR/heightfield.stl``, reads it back and prints the held-out
figures of the design's particle, the rolling ball and the ball in MuJoCo
([`pes_ref.realize.heightfield.heightfield_check`][pes_ref.realize.heightfield.heightfield_check];
without the extra ``mujoco``, one ``mujoco: not run: ...`` line with its pip line).
"""
from __future__ import annotations

import os
import sys
import time

from pes_ref.cli.common import EXIT_OK, LazyChoices, LazyDefault, add_command, error, output_file, output_folder
from pes_ref.cli.files import expect

#: The library's names of what the options set, and the options (errors name the option).
FLAGS = {"pin_radius": "--pin-radius", "rim": "--rim", "thickness": "--thickness", "level": "--level",
         "drum_radius": "--drum-radius", "clearance": "--clearance", "restitution": "--restitution", "units": "--units",
         "as": "--as", "rule": "--rule", "g": "--g", "base": "--base", "seed": "--seed", "n_particles": "--particles",
         "n_steps": "--steps"}
#: The options' destinations, by library name.
DESTS = {name: flag[2:].replace("-", "_") for name, flag in FLAGS.items() if name != "as"}


def _default(key: str) -> LazyDefault:
    """``key``'s default, `pes_ref.realize.contact.CONTACT_DEFAULTS` (read when needed)."""
    return LazyDefault("pes_ref.realize.contact", "CONTACT_DEFAULTS", key)


def _hf_default(key: str) -> LazyDefault:
    """``key``'s default, `pes_ref.realize.heightfield.HEIGHTFIELD_DEFAULTS` (read when needed)."""
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
    p.add_argument("--as", dest="as_", choices=LazyChoices("pes_ref.realize.realizations", "REALIZATIONS"), required=True,
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
    p.add_argument("--units", default=_default("units"), metavar="UNIT",
                   help="what one C-space length unit is in the DXF drawing: mm, cm, m, in or ft (its $INSUNITS)")
    p.add_argument("--drum-radius", type=float, default=_default("drum_radius"), metavar="R",
                   help="a cylinder design's drum radius (C-space length; the unrolled groove's arc length is R q1)")
    p.add_argument("--g", type=float, default=_hf_default("g"), metavar="G",
                   help="heightfield: gravity, length / time^2 in the design's units (h = E / (m g))")
    p.add_argument("--base", type=float, default=_hf_default("base"), metavar="B",
                   help="heightfield: the plate's thickness below its lowest point (length)")
    p.add_argument("--seed", type=int, default=None, metavar="S",
                   help="the held-out seed of the check (default: the held-out seed of evaluate): contact, the design's held-out evaluation "
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


def _run_realize(args) -> int:
    start = time.perf_counter()
    options = {name: getattr(args, dest) for name, dest in DESTS.items()}
    options = {name: None if isinstance(value, LazyDefault) else value for name, value in options.items()}
    try:
        from pes_ref.realize.extra import require_realize
        require_realize()
        from pes_ref.realize.realizations import check_options, realize
        from pes_ref.synthesis import load_design
        realization = check_options(args.as_, options)
        state = load_design(expect(args.file, "design"))
        files = realization.files(state.problem)
        output_folder(args.out)
        paths = {key: os.path.join(args.out, name) for key, (name, _) in files.items()}
        if os.path.isdir(args.out):  # a folder made later holds nothing to keep
            paths = {key: output_file(path, files[key][1], force=args.force) for key, path in paths.items()}
        name = os.path.splitext(os.path.basename(args.file))[0]
        report = realize(state, args.as_, paths, options, name=name, force=args.force)
    except (ValueError, TypeError, OSError, ImportError) as exc:
        return error(exc, FLAGS)
    for key, value in report:
        print(f"{key}: {value:.6g}" if isinstance(value, float) else f"{key}: {value}")
    print(f"seconds: {time.perf_counter() - start:.3g}")
    for key, path in paths.items():
        print(f"wrote {path} ({files[key][1]})", file=sys.stderr)
    return EXIT_OK
