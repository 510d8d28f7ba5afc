"""How far the sweep machinery scales: scheduler throughput and what a task sends back.

Prints, for a cluster of ``--workers`` local single-threaded workers (or ``--scheduler``):

1. tasks per second Dask sustains for tasks that do nothing (``client.map`` of ``N`` no-ops);
2. runs per second the sweep runner sustains when every run does nothing (``N`` runs of a
   sweep file through :func:`pes_ref.sweep.run_sweep` with a no-op task: the runner's own
   cost, one ``results.csv`` rewrite per run included);
3. the pickled size of one real smoke run's payload (what goes to the worker) and of its
   outcome (what comes back: status, figures per held-out seed, the design file's path).

Run: ``python validation/experiments/sweep_scale.py [--tasks N] [--runs N] [--workers N]
[--scheduler ADDRESS]`` (docs/sweeps.md, "Measured").
"""
from __future__ import annotations

import argparse
import pickle
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from pes_ref.sweep import cluster, run_sweep  # noqa: E402
from pes_ref.sweep.spec import parse_sweep  # noqa: E402
from pes_ref.sweep.task import run_task  # noqa: E402


def _nothing(x):
    return x


def _no_run(payload: dict) -> dict:
    """A task that does no design: the outcome of a run with one figure."""
    return {"id": payload["id"], "status": "ok", "error": "", "figures": {1: {"in_band_fraction": 0.5}},
            "iterations": 0, "from_iteration": 0, "wall_s": 0.0, "worker": "", "design_file": payload["design_file"]}


def dask_rate(client, n: int) -> float:
    client.gather(client.map(_nothing, range(50), pure=False))        # warm up
    t = time.perf_counter()
    client.gather(client.map(_nothing, range(n), pure=False))
    return n / (time.perf_counter() - t)


def runner_rate(client, n: int) -> float:
    sweep = parse_sweep({"kind": "funnel", "eval_seeds": [1], "seeds": list(range(n)), "base": {"smoke": True}},
                        "scale.toml")
    with tempfile.TemporaryDirectory() as out:
        t = time.perf_counter()
        report = run_sweep(sweep, out, client, task=_no_run, plot=False)
        elapsed = time.perf_counter() - t
    assert report.counts == {"ok": n}, report.counts
    return n / elapsed


def message_sizes() -> tuple:
    sweep = parse_sweep({"kind": "funnel", "eval_seeds": [12345, 12346], "base": {"smoke": True}}, "size.toml")
    with tempfile.TemporaryDirectory() as out:
        payload = {**sweep.runs[0].payload(sweep, str(Path(out) / "run.npz")), "token": "0" * 12}
        outcome = run_task(payload)
    assert outcome["status"] == "ok", outcome
    return len(pickle.dumps(payload)), len(pickle.dumps(outcome)), outcome


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument("--tasks", type=int, default=2000, help="no-op Dask tasks (default 2000)")
    ap.add_argument("--runs", type=int, default=500, help="no-op sweep runs (default 500)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--scheduler", default=None)
    args = ap.parse_args(argv)
    sent, back, outcome = message_sizes()
    print(f"one smoke run: payload {sent} bytes pickled, outcome {back} bytes pickled "
          f"({len(outcome['figures'])} held-out seeds x {len(next(iter(outcome['figures'].values())))} figures)")
    with cluster.open_client(args.scheduler, None if args.scheduler else args.workers) as client:
        n_workers = len(client.nthreads())
        print(f"{n_workers} workers: Dask, no-op tasks: {dask_rate(client, args.tasks):.0f} tasks/s over {args.tasks}")
        print(f"{n_workers} workers: sweep runner, no-op runs: {runner_rate(client, args.runs):.0f} runs/s "
              f"over {args.runs}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
