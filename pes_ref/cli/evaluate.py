"""The ``evaluate`` command of ``python -m pes_ref``: ``evaluate FILE.npz [--seed S]
[--particles N]`` prints one ``name: value`` line per figure of a saved design."""
from __future__ import annotations

import time

from pes_ref.cli.common import EXIT_OK, add_command, error, input_file


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
                    "the stage it reached, its iterations and polish evaluations.",
        examples=['evaluate funnel.npz', 'evaluate osc.npz --seed 9191',
                  'evaluate funnel.npz --realized funnel_parts/device.toml'])
    p.add_argument("file", metavar="FILE.npz", help="a design file written by 'design'")
    p.add_argument("--seed", type=int, default=12345, help="held-out seed (default 12345; training uses others)")
    p.add_argument("--realized", default=None, metavar="DEVICE.toml",
                   help="also run the same held-out evaluation on this realized device (a device file written by "
                        "'realize'): its surface from the exported parts, the design's forces, at the step the "
                        "stability rule allows; each figure is followed by its realized_ line (docs/realize.md)")
    p.add_argument("--particles", type=int, default=None, metavar="N",
                   help="held-out particles (funnel default 200; oscillator torque sweep default 50; a problem "
                        "file's: its [evaluate] particles)")
    p.set_defaults(func=_run_evaluate)


#: The library's names of what the options set, and the options (errors name the option).
FLAGS = {"n_particles": "--particles", "seed": "--seed", "realized": "--realized"}


def _run_evaluate(args) -> int:
    from pes_ref.synthesis import evaluate, load_design
    from pes_ref.core.integrator import NonFiniteError
    start = time.perf_counter()
    try:
        state = load_design(input_file(args.file, "design file"))
        if args.realized is not None:
            figures = _realized(state, args)
        else:
            figures = evaluate(state.problem, state.values, seed=args.seed, n_particles=args.particles)
    except (OSError, ValueError, TypeError, ImportError, NonFiniteError) as exc:
        return error(exc, FLAGS)
    print(f"kind: {state.kind}")
    if state.kind == "problem":
        print(f"problem: {state.problem.name}")

    print(f"method: {state.method}")
    print(f"stage: {state.stage}")
    print(f"iterations: {state.iteration}")
    print(f"evaluations: {state.evaluations}")
    print(f"status: {state.status}")
    for name, value in figures.items():
        if isinstance(value, tuple):
            print(f"{name}: {value[0]:.6g}")
            print(f"realized_{name}: {value[1]:.6g}")
        else:
            print(f"{name}: {value:.6g}")
    if args.realized is not None:
        print(f"seconds: {time.perf_counter() - start:.3g}")
    return EXIT_OK


def _realized(state, args) -> dict:
    """The design's figures beside the realized device's (:func:`pes_ref.realize.evaluation.evaluate_realized`)."""
    from pes_ref.core import checks
    from pes_ref.devices.device_file import load_device
    from pes_ref.realize.evaluation import check_kind, evaluate_realized
    check_kind(state.problem)
    device = load_device(input_file(args.realized, "device file"))
    try:
        return evaluate_realized(state.problem, state.values, device, seed=args.seed, n_particles=args.particles)
    except checks.InputError as exc:
        if exc.key != "realized":
            raise
        raise ValueError(f"--realized {args.realized}: {exc}") from None
