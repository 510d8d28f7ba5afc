"""The ``evaluate`` command of ``python -m pes_ref``: ``evaluate FILE.npz [--seed S]
[--particles N]`` prints one ``name: value`` line per figure of a saved design."""
from __future__ import annotations

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
        examples=['evaluate funnel.npz', 'evaluate osc.npz --seed 9191'])
    p.add_argument("file", metavar="FILE.npz", help="a design file written by 'design'")
    p.add_argument("--seed", type=int, default=12345, help="held-out seed (default 12345; training uses others)")
    p.add_argument("--particles", type=int, default=None, metavar="N",
                   help="held-out particles (funnel default 200; oscillator torque sweep default 50; a problem "
                        "file's: its [evaluate] particles)")
    p.set_defaults(func=_run_evaluate)


#: The library's names of what the options set, and the options (errors name the option).
FLAGS = {"n_particles": "--particles", "seed": "--seed"}


def _run_evaluate(args) -> int:
    from pes_ref.synthesis import evaluate, load_design
    from pes_ref.core.integrator import NonFiniteError
    try:
        state = load_design(input_file(args.file, "design file"))
        figures = evaluate(state.problem, state.values, seed=args.seed, n_particles=args.particles)
    except (OSError, ValueError, TypeError, NonFiniteError) as exc:
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
        print(f"{name}: {value:.6g}")
    return EXIT_OK
