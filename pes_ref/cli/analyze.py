"""The ``analyze`` command of ``python -m pes_ref``.

- ``analyze ratchet [--torque T] [--duration S] [--search-hi T] [--search-tol T] [--smoke]``
- ``analyze dartgun [--reload-force F] [--reload-time S] [--trigger-forces F1,F2,...]
  [--fire-time S] [--search-hi F] [--search-tol F] [--smoke]``

Each prints one ``name: value unit`` line per figure (:mod:`pes_ref.devices.ratchet`,
:mod:`pes_ref.devices.dartgun`), and on stderr one ``warning: ...`` line for each thing that
makes some figures mean something else than they say (a torque that overwhelms the
ratchet's barrier, a reload that did not latch). Numbers are read as text and checked
here, so a bad value is one line ``error: <message>`` on stderr and exit status 2.
"""
from __future__ import annotations

import dataclasses
import importlib
import sys

from pes_ref.core import checks
from pes_ref.cli.common import EXIT_ERROR, EXIT_OK, add_command, error  # noqa: F401

#: The ``--smoke`` presets (a smaller grid, shorter runs, coarser searches: for tests and a
#: quick look; same geometry). An option given explicitly wins; an option neither given nor
#: in the preset takes the analysis' default (``RATCHET_ANALYSIS``, ``DARTGUN_ANALYSIS`` of
#: :mod:`pes_ref.devices.ratchet` and :mod:`pes_ref.devices.dartgun`).
RATCHET_SMOKE = {"shape": (128, 128), "dt": 2e-3, "duration": "3.0", "search_tol": "0.1"}
DARTGUN_SMOKE = {"shape": (121, 81), "dt": 5e-4, "trigger_forces": "10,30", "search_tol": "2.0"}
#: The entries of a smoke preset that change the design (the rest are option texts).
DESIGN_KEYS = ("shape", "dt")
#: The analyses' names of what the options set, and the options (errors name the option).
FLAGS = {"hi": "--search-hi", "tol": "--search-tol", "duration": "--duration"}


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


def _text(value) -> str:
    """The option text that gives ``value`` exactly (``10.0,20.0`` for a tuple)."""
    return ",".join(map(repr, value)) if isinstance(value, tuple) else repr(value)


@dataclasses.dataclass(frozen=True)
class _Default:
    """An option's default: entry ``key`` of the analysis' table ``table`` in ``module``, read
    only when it is needed (the help's ``%(default)s``, a run without the option), so that
    building the parser imports no device module. An option still holding it was not given."""

    module: str
    table: str
    key: str

    def __str__(self) -> str:
        return _text(getattr(importlib.import_module(self.module), self.table)[self.key])


def add_parser(sub) -> None:
    def rd(key):
        return _Default("pes_ref.devices.ratchet", "RATCHET_ANALYSIS", key)

    def dd(key):
        return _Default("pes_ref.devices.dartgun", "DARTGUN_ANALYSIS", key)

    p = add_command(sub, "analyze", help="analyze a device on its potential energy surface (ratchet, dart gun)",
        description="Build a device's C-space from its part geometry, turn it into a potential energy "
                    "surface (eq. (1) plus its springs) and run the analyses of the paper's "
                    "'Contribution 2'. Prints one 'name: value unit' line per figure, with run times. "
                    "See docs/geometry.md.",
        examples=['analyze ratchet --smoke', 'analyze dartgun --reload-force 25 --trigger-forces 10,20'])
    dev = p.add_subparsers(dest="device", metavar="DEVICE", title="devices", help="the device to analyze")
    dev.required = True

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
    d.set_defaults(func=_run_dartgun)


def _preset(preset: dict) -> str:
    return ", ".join(f"grid={v[0]}x{v[1]}" if k == "shape" else f"{k}={v}" for k, v in preset.items())


def _options(args, defaults: dict, smoke: dict) -> dict:
    """Each option's text: given explicitly, else the smoke preset's (with --smoke), else the
    analysis' default (its entry of ``defaults``)."""
    out = {}
    for key, value in defaults.items():
        given = getattr(args, key)
        if isinstance(given, _Default):
            given = smoke[key] if args.smoke and key in smoke else _text(value)
        out[key] = given
    return out


def _run(args, defaults: dict, smoke: dict, design, analyze, parse) -> int:
    """Read the options (``parse(texts) -> analysis arguments``), run ``analyze(design, *arguments)``
    and print its report's lines; a bad value is one ``error:`` line and EXIT_ERROR."""
    try:
        values = parse(_options(args, defaults, smoke))
        if args.smoke:
            design = dataclasses.replace(design, **{k: smoke[k] for k in DESIGN_KEYS})
        report = analyze(design, *values)
    except (ValueError, TypeError) as exc:
        return error(exc, FLAGS)
    for line in report.as_lines():
        print(line)
    for line in report.warnings():
        print("warning: " + line, file=sys.stderr)
    return EXIT_OK


def _run_ratchet(args) -> int:
    from pes_ref.devices.ratchet import RATCHET_ANALYSIS, RatchetDesign, analyze_ratchet

    def parse(o):
        duration = _float("--duration", o["duration"])
        return (_float("--torque", o["torque"]), duration, _float("--search-hi", o["search_hi"]),
                _float("--search-tol", o["search_tol"]), duration)
    return _run(args, RATCHET_ANALYSIS, RATCHET_SMOKE, RatchetDesign(), analyze_ratchet, parse)


def _run_dartgun(args) -> int:
    from pes_ref.devices.dartgun import DARTGUN_ANALYSIS, DartGunDesign, analyze_dartgun

    def parse(o):
        return (_float("--reload-force", o["reload_force"]), _float("--reload-time", o["reload_time"]),
                _floats("--trigger-forces", o["trigger_forces"]), _float("--fire-time", o["fire_time"]),
                _float("--search-hi", o["search_hi"]), _float("--search-tol", o["search_tol"]))
    return _run(args, DARTGUN_ANALYSIS, DARTGUN_SMOKE, DartGunDesign(), analyze_dartgun, parse)
