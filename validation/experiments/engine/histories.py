"""Issue 41 item 3: the default plan's run of a problem file, with its whole loss and validation
history, for judging a population of starts offline (population.py).

    python histories.py PROBLEM.toml SEED [SEED ...]

prints one JSON line per design seed: problem, seed, held-out success on seeds 12345 and 9191 (the
run's, and each scenario's), the iterations run, the wall seconds, the loss per iteration and the
validation success per validation.
"""
import json
import sys
import time

from pes_ref import synthesis
from pes_ref.synthesis.kinds.registry import HELD_OUT
from pes_ref.synthesis.engine.stages import run_stages


def main():
    path, *seeds = sys.argv[1:]
    problem = synthesis.load_problem(path)
    for seed in map(int, seeds):
        t0 = time.perf_counter()
        state = run_stages(synthesis.new_design(problem, seed=seed))
        wall = time.perf_counter() - t0
        res = list(synthesis.evaluate_seeds(state.problem, state.values, (HELD_OUT["seed"], HELD_OUT["second"])).values())
        print(json.dumps({"problem": problem.name, "seed": seed, "success": [r["success_fraction"] for r in res],
                          "scenarios": {k[len("scenario_"):-len("_success_fraction")]: [r[k] for r in res]
                                        for k in res[0] if k.startswith("scenario_")
                                        and k.endswith("_success_fraction")},
                          "iterations": state.iteration, "status": state.status, "wall_s": round(wall, 1),
                          "loss": [round(x, 4) for x in state.history["loss"]],
                          "validation": [state.validation["iteration"], state.validation["success"]]}), flush=True)


if __name__ == "__main__":
    main()
