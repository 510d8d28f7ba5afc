"""The ``analyze`` command of ``python -m pes_ref``.

- ``analyze DEVICE.toml --drive AXIS --load VALUE [--mode quasistatic|dynamic] [--cycles K]
  [--start Q0,Q1] [--threshold T] [--shape N0,N1] [--json FILE] [--plot FILE] [--out DIR] [--force] [--engine E]``:
  the drive analysis of any device file ([`pes_ref.devices.drive`][pes_ref.devices.drive], ``docs/devices.md``)
- ``analyze ratchet [--torque T] [--duration S] [--search-hi T] [--search-tol T] [--smoke] [--engine E]``
- ``analyze dartgun [--reload-force F] [--reload-time S] [--trigger-forces F1,F2,...]
  [--fire-time S] [--search-hi F] [--search-tol F] [--smoke] [--engine E]``

Each takes ``--engine surface|rigid|both`` (`pes_ref.rigid.engines.ENGINES`; default
``surface``): the rigid engine runs the same analysis with the parts in rigid contact and
adds its ``engine``, ``restitution`` and ``friction``; ``both`` runs both and prints a line
both engines print the same once, any other as ``name[surface]``, ``name[rigid]`` and
``name[rigid-surface]`` ([`pes_ref.rigid.engines.side_by_side`][pes_ref.rigid.engines.side_by_side]). Each prints one
``name: value unit`` line per figure ([`pes_ref.devices.ratchet`][pes_ref.devices.ratchet],
[`pes_ref.devices.dartgun`][pes_ref.devices.dartgun]), and on stderr one ``warning: ...`` line for each thing that
makes some figures mean something else than they say (a torque that overwhelms the
ratchet's barrier, a reload that did not latch, a device file whose free channels are
narrower than eq. (1)'s reach or than its grid resolves: [`pes_ref.devices.clearance`][pes_ref.devices.clearance];
a dynamic drive on the surface of an output in free play that rigid parts would coast across:
[`pes_ref.rigid.play`][pes_ref.rigid.play]).
Numbers are read as text and checked here, so a bad value is one line ``error: <message>``
on stderr and exit status 2; so is a bad device file (naming its key), a device file's drive
that has nowhere to go (no free configuration, a start inside blocked space) and a missing
optional extra (with its pip line). Every output file is checked
before anything is computed and written atomically; an existing one is kept unless ``--force``.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import sys

from pes_ref.core import checks
from pes_ref.cli.common import (EXIT_OK, LazyDefault, add_command, error, option_text, output_file,
                                output_folder)

#: The ``--smoke`` presets (a smaller grid, shorter runs, coarser searches: for tests and a
#: quick look; same geometry). An option given explicitly wins; an option neither given nor
#: in the preset takes the analysis' default (``RATCHET_ANALYSIS``, ``DARTGUN_ANALYSIS`` of
#: `pes_ref.devices.ratchet` and `pes_ref.devices.dartgun`).
RATCHET_SMOKE = {"shape": (128, 128), "dt": 2e-3, "duration": "3.0", "search_tol": "0.1"}
DARTGUN_SMOKE = {"shape": (121, 81), "dt": 5e-4, "trigger_forces": "10,30", "search_tol": "2.0"}
#: The entries of a smoke preset that change the design (the rest are option texts).
DESIGN_KEYS = ("shape", "dt")
#: The analyses' names of what the options set, and the options (errors name the option).
FLAGS = {"hi": "--search-hi", "tol": "--search-tol", "duration": "--duration", "engine": "--engine", "torque": "--torque"}


def _float(option: str, text: str, check=checks.as_positive_float) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{option} must be a number, got {text!r}") from None
    return check(option, value)


def _floats(option: str, text: str) -> list:
    parts = [p.strip() for p in text.split(",")]
    if "" in parts:
        raise ValueError(f"{option} must be a comma-separated list of numbers, got {text!r} (an empty entry)")
    return [_float(option, p, checks.as_nonneg_float) for p in parts]




#: A word that argparse takes for a value although it starts with '-': a negative number, or a
#: comma-separated list that starts with one (``--start -0.1,0.3``, ``--load -1e-3``); argparse's own
#: test takes only plain negative numbers, and would read ``-0.1,0.3`` as an unknown option.
NEGATIVE_VALUE = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?(,.*)?$")

#: The name under which a device file's parser is registered (any other word ending in .toml goes to it).
FILE_CHOICE = "DEVICE.toml"
#: The example device files (in the repository, beside docs/devices.md).
CAM = "examples/devices/cam_follower.toml"


class _Devices(dict):
    """The parsers of ``analyze`` by device name, which also hold every word ending in .toml."""

    def __contains__(self, name) -> bool:
        return super().__contains__(name) or (isinstance(name, str) and name.endswith(".toml")
                                              and name != FILE_CHOICE)


class _DeviceChoice(argparse._SubParsersAction):
    """The devices of ``analyze``: a shipped one by name, or a device file (a word ending in .toml)."""

    def __init__(self, *args, **kw):
        super().__init__(*args, **kw)
        self._name_parser_map = self.choices = _Devices()

    def __call__(self, parser, namespace, values, option_string=None):
        if values and not dict.__contains__(self._name_parser_map, values[0]) and values[0].endswith(".toml"):
            namespace.device_file = values[0]
            values = [FILE_CHOICE, *values[1:]]
        super().__call__(parser, namespace, values, option_string)


def add_parser(sub) -> None:
    def rd(key):
        return LazyDefault("pes_ref.devices.ratchet", "RATCHET_ANALYSIS", key)

    def dd(key):
        return LazyDefault("pes_ref.devices.dartgun", "DARTGUN_ANALYSIS", key)

    p = add_command(sub, "analyze", help="analyze a device on its potential energy surface (any device file, "
                                         "ratchet, dart gun)",
        description="Build a device's C-space from its part geometry, turn it into a potential energy "
                    "surface (eq. (1) plus its springs) and analyze it: the drive analysis of any device file "
                    "(DEVICE.toml, docs/devices.md), or the paper's 'Contribution 2' analyses of the shipped "
                    "ratchet and dart gun. Prints one 'name: value unit' line per figure, with run times. "
                    "See docs/devices.md and docs/geometry.md.",
        examples=[f'analyze {CAM} --drive 0 --load 0.5', 'analyze ratchet --smoke',
                  'analyze dartgun --reload-force 25 --trigger-forces 10,20'])
    p.register("action", "parsers", _DeviceChoice)
    dev = p.add_subparsers(dest="device", metavar="DEVICE", title="devices",
                           help="a device file (DEVICE.toml) or a shipped device (ratchet, dartgun)")
    dev.required = True

    f = add_command(
        dev, FILE_CHOICE, help="any device file: drive one axis with a constant load, follow the other",
        description="Reads the device file (docs/devices.md), builds its C-space and surface, then applies "
                    "a constant force or torque --load on the axis --drive and follows the other axis, "
                    "quasistatically or dynamically, for --cycles turns of a periodic input (to the grid's "
                    "edge for a translation). Prints input_travel, the output's advance over it, each full "
                    "cycle's (advance_per_cycle_each) and the last one's (advance_per_cycle), moving_fraction, "
                    "max_ratio and whether it jammed (and where), then a warning for each free channel the "
                    "surface cannot be trusted in, and, in dynamic mode, for an output in free play that rigid "
                    "parts would coast across (docs/rigid.md, Play); writes the motion law to "
                    "DIR/motion_law.csv (--out), the figures to --json and a plot of the C-space with the "
                    "path beside the motion law to --plot. --engine rigid runs the parts in rigid contact "
                    "instead (pymunk), --engine both runs both side by side (docs/rigid.md). When the drive "
                    "on the surface stalls, a line says whether the rigid parts pass there (stall: "
                    "resolution) or stop too (stall: jam).",
        examples=[f"analyze {CAM} --drive 0 --load 0.5 --shape 96,64",
                  f"analyze {CAM} --drive 0 --load 0.5 --mode dynamic --out cam --plot cam.png",
                  f"analyze {CAM} --drive 0 --load 0.5 --engine both --out cam --plot cam.png"])
    f._negative_number_matcher = NEGATIVE_VALUE  # --start -0.1,0.3 is a value, not an option
    f.add_argument("--drive", required=True, metavar="AXIS", help="the driven axis (the input): 0 or 1")
    f.add_argument("--load", required=True, metavar="VALUE",
                   help="constant force (translation) or torque (rotation) on the input; its sign is the direction")
    f.add_argument("--mode", default="quasistatic", choices=("quasistatic", "dynamic"),
                   help="quasistatic: steps along the net force; dynamic: the device's masses, damping and dt")
    f.add_argument("--cycles", default=None, metavar="K",
                   help="full turns of a periodic input (integer >= 1; default 2: the first holds the start's "
                        "transient, and advance_per_cycle, moving_fraction and max_ratio are the later turns'); not "
                        "for a translation, which travels to the grid's edge")
    f.add_argument("--start", default=None, metavar="Q0,Q1",
                   help="where the drive starts, a free configuration (default: the file's [start]); "
                        "a negative first number is fine: --start -0.1,0.3")
    f.add_argument("--threshold", default="0.05", metavar="T",
                   help="|dq_out/dq_in| above which the output counts as moving (> 0)")
    f.add_argument("--shape", default=None, metavar="N0,N1",
                   help="the C-space grid instead of the file's [cspace] shape (integers >= 2), e.g. for a quick look")
    f.add_argument("--json", default=None, metavar="FILE", help="write the figures to FILE as JSON")
    f.add_argument("--plot", default=None, metavar="FILE",
                   help="draw the C-space with the path and the motion law side by side (PNG, PDF or SVG)")
    f.add_argument("--out", default=None, metavar="DIR",
                   help="write DIR/motion_law.csv (columns q_in,q_out; on both engines q_in,q_out_surface,q_out_rigid)")
    f.add_argument("--force", action="store_true", help="overwrite output files that exist (default: refuse)")
    _engine_flag(f)
    f.set_defaults(func=_run_file)

    r = add_command(
        dev, "ratchet", help="ratchet and pawl on a torus: direction selectivity, smallest advancing torque",
        description="A toothed wheel (angle q0) and a pawl held into its teeth by a torsion spring "
                    "(angle q1) on a torus. Runs +torque and -torque from the engaged rest state and "
                    "prints the net rotation of each, then finds the smallest torque that advances the "
                    "wheel by one tooth within --duration by bisection.",
        examples=["analyze ratchet --smoke", "analyze ratchet --torque 0.5 --duration 5"])
    r.add_argument("--torque", default=rd("torque"), metavar="T",
                   help="torque magnitude on the wheel (> 0; default %(default)s)")
    r.add_argument("--duration", default=rd("duration"), metavar="S",
                   help="length of each run in seconds (> 0; default %(default)s)")
    r.add_argument("--search-hi", default=rd("search_hi"), metavar="T",
                   help="upper end of the torque search (> 0, must advance the wheel; default %(default)s)")
    r.add_argument("--search-tol", default=rd("search_tol"), metavar="T",
                   help="bracket width at which the torque search stops (> 0; default %(default)s)")
    r.add_argument("--smoke", action="store_true",
                   help=f"quick look: small grid, short runs, coarse search ({_preset(RATCHET_SMOKE)})")
    _engine_flag(r)
    r.set_defaults(func=_run_ratchet)

    d = add_command(
        dev, "dartgun", help="the paper's dart gun (Figs. 2-4) on a plane: reload, fire, exit speed, device size",
        description="A dart (q0, pushed back = +) with a notch and its spring, and a trigger tooth (q1) with "
                    "its spring, on a plane. Reloads with --reload-force for --reload-time and says whether "
                    "the dart latched; finds the smallest force that reloads by bisection; fires from the "
                    "latched equilibrium with each --trigger-forces value for --fire-time and prints the "
                    "dart's exit speed; prints the bounding boxes of the reload and fire trajectories.",
        examples=["analyze dartgun --smoke", "analyze dartgun --reload-force 25 --trigger-forces 10,20"])
    d.add_argument("--reload-force", default=dd("reload_force"), metavar="F",
                   help="reload push on the dart (> 0; default %(default)s)")
    d.add_argument("--reload-time", default=dd("reload_time"), metavar="S",
                   help="how long the reload push lasts (> 0; default %(default)s)")
    d.add_argument("--trigger-forces", default=dd("trigger_forces"), metavar="F1,F2,...",
                   help="trigger pushes (>= 0, comma-separated; default %(default)s)")
    d.add_argument("--fire-time", default=dd("fire_time"), metavar="S",
                   help="how long the trigger push lasts (> 0; default %(default)s)")
    d.add_argument("--search-hi", default=dd("search_hi"), metavar="F",
                   help="upper end of the reload force search (> 0, must reload; default %(default)s)")
    d.add_argument("--search-tol", default=dd("search_tol"), metavar="F",
                   help="bracket width at which the force search stops (> 0; default %(default)s)")
    d.add_argument("--smoke", action="store_true",
                   help=f"quick look: small grid, fewer runs, coarse search ({_preset(DARTGUN_SMOKE)})")
    _engine_flag(d)
    d.set_defaults(func=_run_dartgun)


def _preset(preset: dict) -> str:
    return ", ".join(f"grid={v[0]}x{v[1]}" if k == "shape" else f"{k}={v}" for k, v in preset.items())


def _options(args, defaults: dict, smoke: dict) -> dict:
    """Each option's text: given explicitly, else the smoke preset's (with --smoke), else the
    analysis' default (its entry of ``defaults``)."""
    out = {}
    for key, value in defaults.items():
        given = getattr(args, key)
        if isinstance(given, LazyDefault):
            given = smoke[key] if args.smoke and key in smoke else option_text(value)
        out[key] = given
    return out


def _run(args, defaults: dict, smoke: dict, design, analyze, parse) -> int:
    """Read the options (``parse(texts) -> analysis arguments``), run ``analyze(design(), *arguments)``
    and print its report's lines; a bad value is one ``error:`` line and EXIT_ERROR."""
    try:
        values = parse(_options(args, defaults, smoke))
        names = _engines(args)
        device = design()
        if args.smoke:
            device = device.replace(**{k: smoke[k] for k in DESIGN_KEYS})
        reports = {name: _analysis_on(name, analyze, device, values) for name in names}
    except (ValueError, TypeError, ImportError) as exc:
        return error(exc, FLAGS)
    for line in _report_lines(device, reports):
        print(line)
    for name, report in reports.items():
        for line in report.warnings():
            print("warning: " + (f"[{name}] " if len(reports) > 1 else "") + line, file=sys.stderr)
    return EXIT_OK


def _engine_flag(parser) -> None:
    parser.add_argument("--engine", default="surface", metavar="NAME",
                        help="surface (the potential energy surface, default), rigid (the parts in rigid contact, "
                             "pymunk: pip install 'pes_ref[rigid]') or both (side by side, with their difference)")


def _engines(args) -> tuple:
    """The engines ``--engine`` names, their extras checked (before anything is computed)."""
    from pes_ref.rigid.engines import engine_names, require_engines
    names = engine_names(args.engine)
    require_engines(names)
    return names


def _analysis_on(name: str, analyze, device, values):
    """A shipped device's analysis on engine ``name`` (the surface's as it always ran)."""
    from pes_ref.rigid.engines import ENGINES
    hook = ENGINES[name].hook()
    return analyze(device, *values) if hook is None else analyze(device, *values, run=hook)


def _report_lines(device, reports: dict) -> list:
    """The reports' lines: one engine's with its facts (the rigid engine's contact), two side by side."""
    from pes_ref.rigid.engines import side_by_side, stated_lines
    lines = {name: report.as_lines() + stated_lines(device, name) for name, report in reports.items()}
    return next(iter(lines.values())) if len(lines) == 1 else side_by_side(lines)


def _run_ratchet(args) -> int:
    from pes_ref.devices.ratchet import RATCHET_ANALYSIS, analyze_ratchet, ratchet_device

    def parse(o):
        duration = _float("--duration", o["duration"])
        return (_float("--torque", o["torque"]), duration, _float("--search-hi", o["search_hi"]),
                _float("--search-tol", o["search_tol"]), duration)
    return _run(args, RATCHET_ANALYSIS, RATCHET_SMOKE, ratchet_device, analyze_ratchet, parse)


def _run_dartgun(args) -> int:
    from pes_ref.devices.dartgun import DARTGUN_ANALYSIS, analyze_dartgun, dartgun_device

    def parse(o):
        return (_float("--reload-force", o["reload_force"]), _float("--reload-time", o["reload_time"]),
                _floats("--trigger-forces", o["trigger_forces"]), _float("--fire-time", o["fire_time"]),
                _float("--search-hi", o["search_hi"]), _float("--search-tol", o["search_tol"]))
    return _run(args, DARTGUN_ANALYSIS, DARTGUN_SMOKE, dartgun_device, analyze_dartgun, parse)


# =========================================================================== any device file

#: The plot formats --plot writes (by the file's extension).
PLOT_FORMATS = ("png", "pdf", "svg")
#: The analyses' names of what the options set (errors name the option).
DRIVE_FLAGS = {"axis": "--drive", "load": "--load", "cycles": "--cycles", "start": "--start",
               "threshold": "--threshold", "mode": "--mode", "engine": "--engine", "x0": "--start"}


def _pair(option: str, text: str, cast=float) -> tuple:
    parts = text.split(",")
    if len(parts) != 2:
        raise ValueError(f"{option} must be two comma-separated numbers, got {text!r}")
    try:
        return tuple(cast(p.strip()) for p in parts)
    except ValueError:
        raise ValueError(f"{option} must be two comma-separated {'integers' if cast is int else 'numbers'}, "
                         f"got {text!r}") from None


def _integer(option: str, text: str, least: int) -> int:
    try:
        value = int(text)
    except ValueError:
        raise ValueError(f"{option} must be an integer >= {least}, got {text!r}") from None
    if value < least:
        raise ValueError(f"{option} must be an integer >= {least}, got {value}")
    return value


def _clashes(args) -> None:
    """Refuse two outputs on one path (``--out law --json law``, ``--json a.png --plot a.png``,
    ``--json`` on the motion law ``--out`` writes): one would overwrite the other, or fail after
    the drive. Named by their flags, before anything is computed or checked on disk."""
    paths = []                                    # (flag and its value, what it writes there, path)
    for flag, value in (("--json", args.json), ("--plot", args.plot)):
        if value is not None:
            paths.append((f"{flag} {value}", "", value))
    if args.out is not None:
        paths.append((f"--out {args.out}", " (its folder)", args.out))
        paths.append((f"--out {args.out}", f" (its {os.path.join(args.out, 'motion_law.csv')})",
                      os.path.join(args.out, "motion_law.csv")))
    seen = {}
    for name, what, path in paths:
        key = os.path.normcase(os.path.realpath(path))
        if key in seen and seen[key][0] != name:
            first, first_what = seen[key]
            raise ValueError(f"{first}{first_what} and {name}{what} name the same path: give each output a path "
                             f"of its own")
        seen.setdefault(key, (name, what))


def _outputs(args) -> dict:
    """Every output path, checked before anything is computed."""
    _clashes(args)
    out = {}
    if args.json is not None:
        out["json"] = output_file(args.json, "JSON", force=args.force)
    if args.plot is not None:
        ext = os.path.splitext(args.plot)[1].lower().lstrip(".")
        if ext not in PLOT_FORMATS:
            raise ValueError(f"--plot {args.plot}: the file's extension must be one of "
                             f"{', '.join('.' + f for f in PLOT_FORMATS)}")
        out["plot"] = output_file(args.plot, "plot", force=args.force)
    if args.out is not None:
        output_folder(args.out)                 # made, if it does not exist, when the results are written
        csv = os.path.join(args.out, "motion_law.csv")
        out["csv"] = output_file(csv, "motion law", force=args.force) if os.path.isdir(args.out) else csv
    return out


def _write(path: str, data: bytes, force: bool, what: str) -> None:
    from pes_ref.core.runtime.files import atomic_file
    with atomic_file(path, overwrite=force, what=what) as fh:
        fh.write(data)


def _reshaped(device, shape: tuple, path: str, text: str):
    """The device on the grid ``--shape`` gives; a grid the file's keys do not fit (a tolerance or
    r_c finer than it allows) is refused naming --shape, the file and the key."""
    from pes_ref.devices.device_file import FILE_KEYS
    try:
        return device.replace(shape=shape)
    except checks.InputError as exc:
        key = FILE_KEYS.get(exc.key, exc.key)
        raise ValueError(f"--shape {text}: {path}: {key}: {' '.join(str(exc).split())}") from None


def _in_file_words(exc, path: str, given, start) -> ValueError:
    """A refusal of the drive in the command's words: a start that came from the device file
    names the file and its key ``start.q`` (one from --start names the flag, by DRIVE_FLAGS); a
    C-space with no free configuration names the file."""
    text = " ".join(str(exc).split())
    if exc.key == "cspace":
        return ValueError(f"{path}: {text}")
    if exc.key != "start":
        return exc
    where = f"[{start[0]:g}, {start[1]:g}]"
    if given is not None:
        if text.startswith("start q = ["):
            return ValueError(f"--start {given}" + text[text.index("]") + 1:])
        return exc
    if text.startswith("start q = ["):
        return ValueError(f"{path}: start.q" + text[len("start q"):] + " (or start elsewhere with --start)")
    return ValueError(f"{path}: start.q = {where}: " + text[len("start "):] + " (or start elsewhere with --start)")


def _run_file(args) -> int:
    from pes_ref.core.runtime.progress import ShareLines
    from pes_ref.devices.clearance import check_clearance
    from pes_ref.devices.drive import check_drive, check_free
    from pes_ref.rigid.report import DriveReport, drive_on
    from pes_ref.devices.device_file import load_device
    path = args.device_file if getattr(args, "device_file", None) else args.device
    try:
        axis = _integer("--drive", args.drive, 0)
        if axis > 1:
            raise ValueError(f"--drive must be 0 or 1, got {axis}")
        load = _float("--load", args.load, checks.as_finite_float)
        if load == 0.0:
            raise ValueError("--load must be non-zero (its sign is the direction of travel), got 0")
        cycles = None if args.cycles is None else _integer("--cycles", args.cycles, 1)
        start = None if args.start is None else _pair("--start", args.start)
        threshold = _float("--threshold", args.threshold)
        shape = None if args.shape is None else _pair("--shape", args.shape, int)
        if shape is not None and min(shape) < 2:
            raise ValueError(f"--shape must be two integers >= 2, got {args.shape!r}")
        outputs = _outputs(args)
        names = _engines(args)
        device = load_device(path)
        if shape is not None:
            device = _reshaped(device, shape, path, args.shape)
        try:
            start = check_drive(device, axis, load, args.mode, cycles, start, threshold)[4]  # before computing
            progress = ShareLines(os.path.basename(path))
            try:
                device.blocked(progress)
                check_free(device, start)      # before the boundary and the distance: a refusal computes little
                cs = device.cspace(progress)
                report = DriveReport(device, drive_on(names, device, axis, load, args.mode, cycles, start,
                                                      threshold, progress))
            finally:
                progress.lines.end()    # the last progress line stays, whole, before anything else is printed
        except checks.InputError as exc:
            raise _in_file_words(exc, path, args.start, device.start) from None
    except (ValueError, TypeError, OSError, ImportError) as exc:
        return error(exc, DRIVE_FLAGS)
    results = report.results
    result = next(iter(results.values()))
    for line in report.lines():
        print(line)
    for text in device.angle_warnings():
        print(f"warning: {path}: {text}", file=sys.stderr)
    for finding in check_clearance(device, cs):
        text = finding.message if args.shape is None else \
            finding.message.replace(f"[cspace] shape = {list(device.shape)}", f"--shape {args.shape}") \
                           .replace("[cspace] shape", "--shape")
        print(f"warning: {path}: {text}", file=sys.stderr)
    for text in report.warnings():
        print(f"warning: {path}: {text}", file=sys.stderr)
    try:
        if "csv" in outputs:
            os.makedirs(args.out, exist_ok=True)
            _write(outputs["csv"], report.csv(), args.force, "motion law")
        if "json" in outputs:
            summary = report.summary()
            _write(outputs["json"], (json.dumps(summary, indent=2) + "\n").encode(), args.force, "JSON")
        if "plot" in outputs:
            import io
            from pes_ref.devices.plots import drive_figure, engines_figure
            import matplotlib.pyplot as plt
            fig = drive_figure(device, result) if len(results) == 1 else engines_figure(device, results)
            buf = io.BytesIO()
            try:
                fig.savefig(buf, format=os.path.splitext(outputs["plot"])[1].lower().lstrip("."), dpi=120)
            finally:
                plt.close(fig)
            _write(outputs["plot"], buf.getvalue(), args.force, "plot")
    except (OSError, ValueError) as exc:
        return error(exc)
    for key, label in (("csv", "motion law"), ("json", "figures"), ("plot", "plot")):
        if key in outputs:
            print(f"wrote {outputs[key]} ({label})", file=sys.stderr)
    return EXIT_OK


