"""Do long rollouts' design gradients explode, or turn chaotic? Measured, per problem.

    python validation/experiments/engine/gradient_norms.py [--smoke]

For each problem (the examples and the engine's problems, each without ``[train]``: the
default plan) and two grids, the initial one (iteration 0) and the default plan's design of
seed 0, the design gradient dL/dG of one iteration's batch is computed on the problem's
final grid for 8 batch draws (``design_gradient``, iterations 0-7), at the full horizon and at
half of it (``n_steps``), and again with the grid perturbed by 1e-6 and by 5e-3 times its range
(one fixed normal draw each; 5e-3 is about one step of the default plan, lr 0.005, on a grid
of range 1). Printed per row: the median gradient norm over the draws, the largest over the
median (an exploding gradient shows as a few huge draws), and for each perturbation the
median and smallest cosine between a draw's gradient and the perturbed grid's (a chaotic
rollout's gradient turns with a perturbation below what the optimizer does: cosine well
below 1). A horizon that ends before every success test's time has no surrogate to charge:
its gradient is 0. One JSON line
per row goes to ``logs/gradient_norms.jsonl``; the table is docs/problems.md's ("Are the
gradients chaotic?").
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
PROBLEMS = [ROOT / "examples" / "problems" / f"{name}.toml" for name in ("nest", "offcentre_funnel", "sorter")] + \
           [HERE / f"{name}.toml" for name in ("latch_default", "nest", "funnel_off")]
DRAWS = 8
PERTURBATIONS = (1e-6, 5e-3)


def _without_train(path: Path):
    from pes_ref import synthesis
    problem = synthesis.load_problem(path)
    if "train" in problem.data:
        data = {k: v for k, v in problem.data.items() if k != "train"}
        problem = synthesis.parse_problem(data, str(path))
    return problem


def _row(problem, values, label: str, horizon: float, rng) -> dict:
    from pes_ref import synthesis
    steps = max(1, int(round(horizon * problem.n_steps)))
    noise = (float(np.ptp(values)) or 1.0) * rng.standard_normal(values.shape) * problem.mask(values.shape)
    norms, cosines = [], {size: [] for size in PERTURBATIONS}
    for it in range(DRAWS):
        g = synthesis.design_gradient(problem, values, seed=0, iteration=it, n_particles=128, n_steps=steps).grad
        n = np.linalg.norm(g)
        norms.append(n)
        for size in PERTURBATIONS:
            h = synthesis.design_gradient(problem, values + size * noise, seed=0, iteration=it, n_particles=128,
                                          n_steps=steps).grad
            m = np.linalg.norm(h)
            cosines[size].append(float(np.vdot(g, h) / (n * m)) if n and m else float("nan"))
    norms = np.asarray(norms)
    med = float(np.median(norms))
    row = {"problem": problem.name, "grid": label, "horizon": horizon, "steps": steps, "median_norm": med,
           "max_over_median": float(norms.max() / med) if med else float("nan")}
    for size, cos in cosines.items():
        cos = np.asarray(cos)
        finite = cos[np.isfinite(cos)]
        row[f"cosine_median@{size:g}"] = float(np.median(finite)) if finite.size else float("nan")
        row[f"cosine_min@{size:g}"] = float(np.min(finite)) if finite.size else float("nan")
    return row


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="two problems, a few iterations (for a quick look)")
    args = parser.parse_args(argv)
    from pes_ref import synthesis
    paths = PROBLEMS[:2] if args.smoke else PROBLEMS
    out = HERE / "logs" / ("gradient_norms_smoke.jsonl" if args.smoke else "gradient_norms.jsonl")
    rows = []
    for path in paths:
        problem = _without_train(path)
        t0 = time.perf_counter()
        inputs = synthesis.design_inputs(problem, {"iterations": 10} if args.smoke else {})
        design = synthesis.run_stages(synthesis.start_design(inputs, seed=0))
        grids = {"initial": synthesis.start_design(inputs, seed=0).values, "designed": design.values}
        for label, values in grids.items():
            if values.shape != problem.shape():
                values = synthesis.resample(values, problem.lower, problem.upper, problem.periodic, problem.shape())
            for horizon in (0.5, 1.0):
                row = _row(problem, values, label, horizon, np.random.default_rng(7))
                rows.append(row)
                cos = ", ".join(f"cosine@{s:g} {row[f'cosine_median@{s:g}']:.4f} (min {row[f'cosine_min@{s:g}']:.4f})"
                                for s in PERTURBATIONS)
                print(f"{row['problem']:18s} {label:8s} horizon {horizon:.1f} ({row['steps']:4d} steps): |g| median "
                      f"{row['median_norm']:.3g}, max/median {row['max_over_median']:.2f}, {cos}", flush=True)
        print(f"  ({time.perf_counter() - t0:.0f} s)", flush=True)
    out.write_text("".join(json.dumps(r) + "\n" for r in rows))
    print(f"wrote {out.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
