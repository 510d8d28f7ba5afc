"""A multiplier per success test that grows while the test fails (augmented-Lagrangian-like
weights), on the default plan: issue 41 item 2, measured, not adopted (docs/problems.md,
"Phases, classes and timing windows").

``python multipliers.py PROBLEM.toml SEED RHO MODE`` designs a problem file without
``[[objective]]`` on its default plan, but at each validation (every ``validate_every``
iterations, on the plan's validation particles) it sets the weight of each test's surrogate
from that test's validation share ``s_i``: ``MODE = add``: ``w_i += RHO (1 - s_i)``; ``mul``:
``w_i *= 1 + RHO (1 - s_i)`` (``RHO = 0``: the default plan itself, bit for bit). It keeps the
best validated grid and stops at the plan's target, as the default plan does, and prints the
held-out success on seeds 12345 and 9191.
"""
import dataclasses
import sys
import time

import numpy as np

from pes_ref import synthesis
from pes_ref.core.scene import simulate
from pes_ref.synthesis import load_problem
from pes_ref.synthesis.problem.objective_terms import TermSum
from pes_ref.synthesis.problem.success import passes_all
from pes_ref.synthesis.common.validation import VALIDATION_STREAM, on_grid


class Weighted:
    """A state term times ``w``."""

    def __init__(self, term, w):
        self.term, self.w = term, w

    def value_and_grad(self, x, v, t):
        val, gx, gv = self.term.value_and_grad(x, v, t)
        return self.w * val, None if gx is None else self.w * gx, None if gv is None else self.w * gv


def validate(problem, values, seed, n):
    """The validation success and each test's share on the run's validation particles."""
    final = on_grid(problem, values, problem.shape())
    batch = problem.batch(final, np.random.default_rng([seed, VALIDATION_STREAM]), n)
    traj = simulate(batch.scene, batch.x0, batch.v0)
    every, each = passes_all([t for _, t in problem.tests], traj.x, traj.v, problem.times(traj.x.shape[0] - 1))
    return float(np.mean(every)), np.array([np.mean(e) for e in each]), final


def main(path, seed, rho, mode):
    problem = load_problem(path)
    base = problem.plan
    terms = list(problem.terms)
    weights = np.ones(len(terms))
    state = synthesis.new_design(problem, seed=seed, plan=dataclasses.replace(base, validate_every=0, target=None))
    best, k, t0 = (-1.0, None, 0), 0, time.perf_counter()
    while True:
        success, each, final = validate(problem, state.values, seed, base.validation_particles)
        if success > best[0]:
            best = (success, final.copy(), k)
        if success >= base.target or k >= base.iterations:
            break
        weights = weights + rho * (1.0 - each) if mode == "add" else weights * (1.0 + rho * (1.0 - each))
        problem.objective = TermSum([Weighted(t, w) for t, w in zip(terms, weights)])
        k = min(k + base.validate_every, base.iterations)
        state = synthesis.run_design(state, k)      # a plan without validation: its values stay the last
        state.status = "running"
    wall = time.perf_counter() - t0
    held = [synthesis.evaluate(problem, best[1], seed=s)["success_fraction"] for s in (12345, 9191)]
    print(f"{problem.name} seed {seed} rho {rho:g} {mode}: held-out {held[0]:.3f} / {held[1]:.3f}, best validation "
          f"{best[0]:.3f} at iteration {best[2]}, stopped at {k}, weights {np.round(weights, 2).tolist()}, {wall:.1f} s")


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), sys.argv[4])
