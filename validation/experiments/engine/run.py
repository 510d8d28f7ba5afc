"""Issue 30 item 3: design a problem file with a named plan, evaluate it on held-out seeds 12345 and 9191.

    python validation/experiments/engine/run.py PROBLEM.toml MECHANISM SEED [SEED ...]

prints one JSON line per seed: problem, mechanism, seed, held-out successes (the run's, and each scenario's),
flat, wall and CPU seconds of the design, the load average at its end.
"""
import json
import os
import sys
import time

from pes_ref import synthesis
from pes_ref.synthesis.kinds.registry import HELD_OUT as _HELD

HELD_OUT = (_HELD["seed"], _HELD["second"])


def main():
    path, mech, *seeds = sys.argv[1:]
    problem = synthesis.load_problem(path)
    import mechanisms
    for seed in map(int, seeds):
        t0, c0 = time.perf_counter(), time.process_time()
        state = mechanisms.MECHANISMS[mech](problem, seed)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        res = list(synthesis.evaluate_seeds(state.problem, state.values, HELD_OUT).values())
        print(json.dumps({"problem": problem.name, "mechanism": mech, "seed": seed,
                          "success": [r["success_fraction"] for r in res],
                          "scenarios": {k[len("scenario_"):-len("_success_fraction")]: [r[k] for r in res]
                                        for k in res[0] if k.startswith("scenario_") and k.endswith("_success_fraction")},
                          "flat": res[0].get("flat_success_fraction"), "iterations": state.iteration,
                          "status": state.status, "wall_s": round(wall, 1), "cpu_s": round(cpu, 1),
                          "load": round(os.getloadavg()[0], 1)}), flush=True)


if __name__ == "__main__":
    sys.path.insert(0, __file__.rsplit("/", 1)[0])
    main()
