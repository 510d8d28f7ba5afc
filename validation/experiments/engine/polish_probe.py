"""Probe (issue 30): does a gradient-free search on success lift the nest past its gradient plateau?

CMA-ES over a coarse bilinear basis (m x m nodes resampled to the final grid) added to the default
plan's design; fitness = -(success share of fixed polish particles, default_rng([seed, 2**32 + 3]))
+ 0.01 * (objective on them / its value at the start); held-out success on 12345 / 9191 before and after.
    python polish_probe.py PROBLEM.toml SEED M EVALUATIONS [SIGMA (energy), default 0.02]
"""
import json
import sys
import time

import cma
import numpy as np

from pes_ref import synthesis
from pes_ref.core.scene import simulate
from pes_ref.synthesis.common.resampling import resample
from pes_ref.synthesis.engine.stages import run_stages


def main():
    path, seed, m, evals = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
    sigma = float(sys.argv[5]) if len(sys.argv) > 5 else 0.02
    problem = synthesis.load_problem(path)
    t0 = time.perf_counter()
    st = run_stages(synthesis.new_design(problem, seed=seed))
    t1 = time.perf_counter()
    base = st.values
    shape = problem.shape()
    cshape = problem.shape(m)
    eye = np.eye(cshape[0] * cshape[1])
    B = np.stack([resample(e.reshape(cshape), problem.lower, problem.upper, problem.periodic, shape).ravel()
                  for e in eye], axis=1) * problem.mask(shape).ravel()[:, None]
    batch = problem.batch(base, np.random.default_rng([seed, 2 ** 32 + 3]), 200)

    def run(coef):
        v = base + (B @ coef).reshape(shape)
        b = problem.batch(v, np.random.default_rng([seed, 2 ** 32 + 3]), 200)
        traj = simulate(b.scene, b.x0, b.v0)
        loss, _, _ = problem.objective.value_and_grad(traj.x, traj.v, problem.times())
        return problem.batch_metric(traj), loss

    s0, l0 = run(np.zeros(B.shape[1]))
    es = cma.CMAEvolutionStrategy(np.zeros(B.shape[1]), sigma, {"seed": seed + 1, "verbose": -9, "popsize": 16})
    best = (-s0 + 0.01, np.zeros(B.shape[1]))
    n = 0
    while n < evals:
        xs = es.ask()
        fs = []
        for x in xs:
            s, l = run(np.asarray(x))
            fs.append(-s + 0.01 * l / l0)
        es.tell(xs, fs)
        n += len(xs)
        i = int(np.argmin(fs))
        if fs[i] < best[0]:
            best = (fs[i], np.asarray(xs[i]))
    v = base + (B @ best[1]).reshape(shape)
    before = [r["success_fraction"] for r in synthesis.evaluate_seeds(problem, base, (12345, 9191)).values()]
    after = [r["success_fraction"] for r in synthesis.evaluate_seeds(problem, v, (12345, 9191)).values()]
    print(json.dumps({"problem": problem.name, "seed": seed, "m": m, "sigma": sigma, "evals": n, "train_success_start": s0,
                      "train_fitness_best": best[0], "before": before, "after": after,
                      "gradient_s": round(t1 - t0, 1), "polish_s": round(time.perf_counter() - t1, 1)}), flush=True)


if __name__ == "__main__":
    main()
