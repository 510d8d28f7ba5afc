"""The ``evaluate`` command of ``python -m pes_ref``: ``evaluate FILE.npz [--seed S]
[--particles N]`` prints one ``name: value`` line per figure of a saved design; ``--json``
writes the same lines as JSON, ``--plot`` draws the held-out paths on the surface."""
from __future__ import annotations

import json
import math
import os
import sys
import time

from pes_ref.cli.common import EXIT_OK, LazyDefault, add_command, error, input_file, output_file, output_folder
from pes_ref.cli.files import expect


def add_parser(sub) -> None:
    p = add_command(sub, "evaluate", help="evaluate a saved design on held-out particles",
        description="Simulate held-out particles (a new seed) on a saved design and print one 'name: value' "
                    "line per figure. Funnel: in_band_fraction (exit |q0 - target| < 10% of the width), "
                    "exit_spread, exited_fraction, and the same on the flat starting surface (flat_*). "
                    "Oscillator: captured_fraction (torque sweep plus 5 x 5 starts at rest with the maximum "
                    "torque), sweep_ and grid_captured_fraction, amplitude_error and period_error (relative, "
                    "worst over the captured particles) and their medians, the q1 advance per period of the "
                    "captured sweep (min, median, max) beside the gait's, and flat_captured_fraction. A problem "
                    "file's design (docs/problems.md): success_fraction (the share passing every "
                    "[[evaluate.success]] test), success_NAME per test, objective_NAME per objective term, "
                    "scenario_NAME_success_fraction per [[evaluate.scenario]], flat_success_fraction. The "
                    "header lines name the design's kind (and problem), method (gradient, or gradient+polish), "
                    "the stage it reached, its iterations, the iteration whose grid it scores (grid_iteration: "
                    "a validated run delivers its best validated grid, maybe an earlier one), the starts a "
                    "population screened and the iterations they ran together (screened_starts, "
                    "screened_iterations; 0 without one) and polish evaluations. --json FILE writes the same header facts and figures (with the seed and the "
                    "particles) as one JSON object; a figure that "
                    "is NaN (nothing to measure, e.g. amplitude_error when no particle is captured) is written as "
                    "null, so the file is valid JSON. --plot DIR draws the held-out paths on the design's surface, "
                    "green where a particle passed and red where it did not, one panel per test (docs/synthesis.md, "
                    "\"Command line\"). An output file that exists is refused, before anything is computed, "
                    "unless --force.",
        examples=['evaluate funnel.npz', 'evaluate osc.npz --seed 9191 --json osc.json --plot plots',
                  'evaluate funnel.npz --realized funnel_parts/device.toml'])
    p.add_argument("file", metavar="FILE.npz", help="a design file written by 'design'")
    p.add_argument("--seed", type=int, default=LazyDefault("pes_ref.synthesis.kinds.registry", "HELD_OUT", "seed"),
                   help="held-out seed (default %(default)s; training uses others)")
    p.add_argument("--realized", default=None, metavar="DEVICE.toml",
                   help="also run the same held-out evaluation on this realized device (a device file written by "
                        "'realize'): its surface from the exported parts, the design's forces, at the step the "
                        "stability rule allows; each figure is followed by its realized_ line (docs/realize.md)")
    p.add_argument("--engine", default="surface", metavar="ENGINE",
                   help="with --realized: what runs the realized device: 'surface' (default: eq. (1) of the distance "
                        "to its parts, realized_ lines), 'rigid' (the parts in rigid contact, pymunk: rigid_ lines; "
                        "pip install 'pes_ref[rigid]') or 'both' (both, and rigid_minus_realized_ lines)")
    p.add_argument("--particles", type=int, default=None, metavar="N",
                   help="held-out particles (funnel default 200; oscillator torque sweep default 50; a problem "
                        "file's: its [evaluate] particles)")
    p.add_argument("--json", default=None, metavar="FILE",
                   help="also write the header facts (kind, problem, method, stage, iterations, grid_iteration, "
                        "screened_starts, screened_iterations, evaluations, status, "
                        "seed, particles) and every figure to FILE as one JSON object; NaN is written as null")
    p.add_argument("--plot", default=None, metavar="DIR",
                   help="also draw the held-out paths on the design's surface into DIR/NAME_paths.png (NAME: the "
                        "design file's, DIR made if missing): green passed, red failed; funnel: exit in the band; "
                        "oscillator: captured (torque sweep, grid of starts); a problem file's: one panel per "
                        "success test and one for all of them")
    p.add_argument("--force", action="store_true", help="overwrite output files that exist (default: refuse); with "
                   "--realized, evaluate on parts made from another design (default: refused, by the design's hash "
                   "in the device file's [realized] table)")
    p.set_defaults(func=_run_evaluate)


#: The library's names of what the options set, and the options (errors name the option).
FLAGS = {"n_particles": "--particles", "seed": "--seed", "realized": "--realized", "engine": "--engine"}
#: ``--engine NAME`` -> the engines (`pes_ref.rigid.engines.ENGINES`) that run the realized device.
ENGINE_CHOICES = {"surface": ("surface",), "rigid": ("rigid",), "both": ("surface", "rigid")}
#: The figures that are no measure of the device (no difference line under ``--engine both``).
_NO_DIFFERENCE = ("dt", "n_steps", "particles", "starts_blocked", "starts_run")


def _run_evaluate(args) -> int:
    from pes_ref.synthesis import evaluate, load_design
    from pes_ref.core.integrator import NonFiniteError
    start = time.perf_counter()
    if isinstance(args.seed, LazyDefault):
        args.seed = args.seed.value()
    try:
        state = load_design(expect(args.file, "design"))
        engines = _engines(args)
        outputs = _outputs(args)                   # refused before anything is computed
        if args.realized is not None:
            figures = _realized(state, args)
        else:
            figures = evaluate(state.problem, state.values, seed=args.seed, n_particles=args.particles)
        picture = _picture(state, args) if "plot" in outputs else None
    except (OSError, ValueError, TypeError, ImportError, NonFiniteError) as exc:
        return error(exc, FLAGS)
    lines = _lines(state, figures, engines)
    for name, value in lines:
        print(f"{name}: {value:.6g}" if isinstance(value, float) else f"{name}: {value}")
    if args.realized is not None:
        print(f"seconds: {time.perf_counter() - start:.3g}")
    try:
        if "json" in outputs:
            _write(outputs["json"], _json(args, lines), args.force, "JSON")
        if picture is not None:
            os.makedirs(args.plot, exist_ok=True)
            _write(outputs["plot"], picture, args.force, "plot")
    except OSError as exc:
        return error(exc)
    for key, label in (("json", "figures"), ("plot", "held-out paths")):
        if key in outputs:
            print(f"wrote {outputs[key]} ({label})", file=sys.stderr)
    return EXIT_OK


def _engines(args) -> tuple:
    """The realized engines ``--engine`` names (one line naming the flag and its value when refused)."""
    if args.engine not in ENGINE_CHOICES:
        raise ValueError(f"--engine {args.engine!r}: expected one of {', '.join(ENGINE_CHOICES)}")
    if args.realized is None and args.engine != "surface":
        raise ValueError(f"--engine {args.engine} runs a realized device's parts: it needs --realized DEVICE.toml")
    return ENGINE_CHOICES[args.engine]


def _lines(state, figures: dict, engines: tuple = ("surface",)) -> list:
    """The ``(name, value)`` of every line, in order: the header facts, then the figures (a
    realized figure's line per engine after its own: ``realized_`` for the surface model,
    ``rigid_`` for the rigid engine, and with both ``rigid_minus_realized_``). The printed
    lines and the JSON both come from this list."""
    lines = [("kind", state.kind)]
    if hasattr(state.problem, "name"):                  # a problem file's design: its problem's name
        lines.append(("problem", state.problem.name))
    lines += [("method", state.method), ("stage", state.stage), ("iterations", state.iteration),
              ("grid_iteration", state.grid_iteration), ("screened_starts", state.screened["starts"]),
              ("screened_iterations", state.screened["iterations"]), ("evaluations", state.evaluations),
              ("status", state.status)]
    for name, value in figures.items():
        if isinstance(value, tuple):
            from pes_ref.rigid.engines import ENGINES
            prefixes = [ENGINES[engine].prefix for engine in engines]
            lines += [(name, float(value[0]))] + [(prefix + name, float(x)) for prefix, x in zip(prefixes, value[1:])]
            if len(value) == 3 and name not in _NO_DIFFERENCE:
                lines.append((f"{prefixes[1]}minus_{prefixes[0]}{name}", float(value[2]) - float(value[1])))
        else:
            lines.append((name, float(value)))
    return lines


#: The header facts of ``evaluate --json`` (beside them: ``seed``, ``particles`` and the ``figures``).
_HEADER = ("kind", "problem", "method", "stage", "iterations", "grid_iteration", "screened_starts",
           "screened_iterations", "evaluations", "status")


def _json(args, lines: list) -> bytes:
    """The JSON of ``--json``: the design file, the header facts, the held-out seed and
    particles, and every figure by name; a NaN or infinite figure is null (JSON has no NaN)."""
    facts = dict(lines)
    figures = {name: (value if math.isfinite(value) else None) for name, value in lines
               if isinstance(value, float)}
    data = {"design": args.file, **{key: facts.get(key) for key in _HEADER}, "seed": args.seed,
            "particles": int(facts["particles"]), "realized": args.realized,
            "engine": args.engine if args.realized is not None else None, "figures": figures}
    return (json.dumps(data, indent=2, allow_nan=False) + "\n").encode()


def _outputs(args) -> dict:
    """Every output path, checked before anything is computed (the refusal names the flag)."""
    out = {}
    try:
        if args.json is not None:
            out["json"] = output_file(args.json, "JSON", force=args.force)
    except OSError as exc:
        raise type(exc)(f"--json {args.json}: {exc}") from None
    try:
        if args.plot is not None:
            output_folder(args.plot)                # made, if it does not exist, when the plot is written
            name = os.path.join(args.plot, f"{_stem(args.file)}_paths.png")
            out["plot"] = output_file(name, "plot", force=args.force) if os.path.isdir(args.plot) else name
    except OSError as exc:
        raise type(exc)(f"--plot {args.plot}: {exc}") from None
    return out


def _stem(path: str) -> str:
    name = os.path.basename(path)
    return name[:-4] if name.endswith(".npz") else name


def _picture(state, args) -> bytes:
    """The PNG of ``--plot``: the held-out panels of the design ([`pes_ref.synthesis.kinds.registry.held_out_panels`][pes_ref.synthesis.kinds.registry.held_out_panels])."""
    import io
    from pes_ref.synthesis import held_out_panels
    from pes_ref.synthesis.kinds.plots import paths_figure
    panels = held_out_panels(state.problem, state.values, seed=args.seed, n_particles=args.particles)
    name = getattr(state.problem, "name", state.kind)             # a problem file's problem by its name
    title = (f"{os.path.basename(args.file)}: {name}, {state.method} to iteration {state.iteration}; "
             f"held-out seed {args.seed}")
    buf = io.BytesIO()
    paths_figure(state.problem, state.values, panels, title).savefig(buf, format="png", dpi=100)
    return buf.getvalue()


def _write(path: str, data: bytes, force: bool, what: str) -> None:
    from pes_ref.core.runtime.files import atomic_file
    with atomic_file(path, overwrite=force, what=what) as fh:
        fh.write(data)


def _realized(state, args) -> dict:
    """The design's figures beside the realized device's ([`pes_ref.realize.evaluation.evaluate_realized`][pes_ref.realize.evaluation.evaluate_realized])."""
    from pes_ref.core import checks
    from pes_ref.devices.device_file import load_device
    from pes_ref.realize.evaluation import check_design, evaluate_realized
    device = load_device(input_file(args.realized, "device file"))
    try:
        if not args.force:
            check_design(state.problem, state.values, device)
        return evaluate_realized(state.problem, state.values, device, seed=args.seed, n_particles=args.particles,
                                 engines=ENGINE_CHOICES[args.engine])
    except checks.InputError as exc:
        if exc.key != "realized":
            raise
        raise ValueError(f"--realized {args.realized}: {exc}") from None
