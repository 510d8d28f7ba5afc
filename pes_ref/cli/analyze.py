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
import sys

from pes_ref.core import checks
from pes_ref.cli.common import EXIT_ERROR, EXIT_OK, add_command, error  # noqa: F401

#: Option defaults, and the ``--smoke`` preset (a smaller grid, shorter runs, coarser
#: searches: for tests and a quick look; same geometry). An option given explicitly wins.
RATCHET_DEFAULTS = {"torque": "1.0", "duration": "10.0", "search_hi": "2.0", "search_tol": "0.01"}
RATCHET_SMOKE = {"shape": (128, 128), "dt": 2e-3, "duration": "3.0", "search_tol": "0.1"}
DARTGUN_DEFAULTS = {"reload_force": "30.0", "reload_time": "1.0", "trigger_forces": "10,20,30,40",
                    "fire_time": "0.3", "search_hi": "40.0", "search_tol": "0.1"}
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


def add_parser(sub) -> None:
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
    r.add_argument("--torque", default=None, metavar="T", help="torque magnitude on the wheel (> 0; default 1.0)")
    r.add_argument("--duration", default=None, metavar="S",
                   help="length of each run in seconds (> 0; default 10)")
    r.add_argument("--search-hi", default=None, metavar="T",
                   help="upper end of the torque search (> 0, must advance the wheel; default 2.0)")
    r.add_argument("--search-tol", default=None, metavar="T",
                   help="bracket width at which the torque search stops (> 0; default 0.01)")
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
    d.add_argument("--reload-force", default=None, metavar="F", help="reload push on the dart (> 0; default 30)")
    d.add_argument("--reload-time", default=None, metavar="S", help="how long the reload push lasts (> 0; default 1)")
    d.add_argument("--trigger-forces", default=None, metavar="F1,F2,...",
                   help="trigger pushes (>= 0, comma-separated; default 10,20,30,40)")
    d.add_argument("--fire-time", default=None, metavar="S", help="how long the trigger push lasts (> 0; default 0.3)")
    d.add_argument("--search-hi", default=None, metavar="F",
                   help="upper end of the reload force search (> 0, must reload; default 40)")
    d.add_argument("--search-tol", default=None, metavar="F",
                   help="bracket width at which the force search stops (> 0; default 0.1)")
    d.add_argument("--smoke", action="store_true",
                   help=f"quick look: small grid, fewer runs, coarse search ({_preset(DARTGUN_SMOKE)})")
    d.set_defaults(func=_run_dartgun)


def _preset(preset: dict) -> str:
    return ", ".join(f"grid={v[0]}x{v[1]}" if k == "shape" else f"{k}={v}" for k, v in preset.items())


def _options(args, defaults: dict, smoke: dict) -> dict:
    """Each option's text: given explicitly, else the smoke preset's (with --smoke), else the default."""
    return {k: getattr(args, k) if getattr(args, k) is not None else (smoke.get(k, v) if args.smoke else v)
            for k, v in defaults.items()}


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
    from pes_ref.devices.ratchet import RatchetDesign, analyze_ratchet

    def parse(o):
        duration = _float("--duration", o["duration"])
        return (_float("--torque", o["torque"]), duration, _float("--search-hi", o["search_hi"]),
                _float("--search-tol", o["search_tol"]), duration)
    return _run(args, RATCHET_DEFAULTS, RATCHET_SMOKE, RatchetDesign(), analyze_ratchet, parse)


def _run_dartgun(args) -> int:
    from pes_ref.devices.dartgun import DartGunDesign, analyze_dartgun

    def parse(o):
        return (_float("--reload-force", o["reload_force"]), _float("--reload-time", o["reload_time"]),
                _floats("--trigger-forces", o["trigger_forces"]), _float("--fire-time", o["fire_time"]),
                _float("--search-hi", o["search_hi"]), _float("--search-tol", o["search_tol"]))
    return _run(args, DARTGUN_DEFAULTS, DARTGUN_SMOKE, DartGunDesign(), analyze_dartgun, parse)
