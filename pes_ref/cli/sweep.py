"""The ``sweep`` command of ``python -m pes_ref``.

- ``sweep SWEEP.toml [--out DIR] [--scheduler ADDRESS] [--workers N] [--progress SECONDS] [--quiet]``:
  run every design of a sweep file ([`pes_ref.sweep.spec`][pes_ref.sweep.spec]) as Dask tasks, on a local
  cluster (one single-threaded worker process per core) or on the cluster of
  ``--scheduler``; write ``DIR/results.csv`` and ``DIR/summary.png``. A progress line
  goes to stderr; the closing table (one line per run) to stdout. Running it again skips
  the finished runs and resumes the others from their design files; Ctrl-C saves the
  running designs and exits. Exit 1 when a run failed twice, 2 for a bad file or no Dask.

Needs the optional extra ``sweep`` (Dask distributed). See ``docs/sweeps.md``.
"""
from __future__ import annotations

import math
import os
import sys

from pes_ref.cli.common import EXIT_FAIL, EXIT_OK, add_command, error, input_file

#: Default output folder: ``sweeps/<the sweep file's stem>``.
DEFAULT_OUT_ROOT = "sweeps"


def add_parser(sub) -> None:
    p = add_command(
        sub, "sweep", help="run the design runs of a sweep file on a local or remote Dask cluster",
        description="Run every design of SWEEP.toml (a device kind, base options, a grid or list of option "
                    "values, run seeds, held-out evaluation seeds; docs/sweeps.md) as one Dask task each: "
                    "design, then evaluate on every held-out seed. Writes DIR/results.csv (one row per run) "
                    "and DIR/summary.png, and the design files in DIR/runs/. Running it again skips finished "
                    "runs and resumes interrupted ones; a failed run is retried once on another worker. "
                    "Needs the extra: pip install 'pes_ref[sweep]'.",
        examples=["sweep validation/experiments/sweep_funnel_lr.toml --workers 2",
                  "sweep validation/experiments/oscillator_seeds.toml --scheduler tcp://127.0.0.1:8786 --out osc"])
    p.add_argument("file", metavar="SWEEP.toml", help="the sweep file (TOML; docs/sweeps.md)")
    p.add_argument("--out", default=None, metavar="DIR", help="output folder (default sweeps/<file stem>)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="connect to this running Dask scheduler (e.g. tcp://host:8786) instead of a local cluster")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="worker processes of the local cluster (default: one per core)")
    p.add_argument("--progress", type=float, default=2.0, metavar="SECONDS", help="progress line period in seconds")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=_run_sweep)


def _run_sweep(args) -> int:
    from pes_ref.sweep.cluster import open_client, require_dask
    from pes_ref.sweep.runner import run_sweep
    from pes_ref.sweep.spec import load_sweep
    try:
        if not args.progress > 0:
            raise ValueError(f"--progress must be > 0 seconds, got {args.progress}")
        if args.workers is not None and args.workers < 1:
            raise ValueError(f"--workers must be >= 1, got {args.workers}")
        if args.workers is not None and args.scheduler is not None:
            raise ValueError(f"--workers {args.workers}: a cluster given by --scheduler has its own workers")
        sweep = load_sweep(input_file(args.file, "sweep file"))
        require_dask()
    except (ImportError, OSError, ValueError) as exc:
        return error(exc)
    out = args.out if args.out is not None else os.path.join(DEFAULT_OUT_ROOT, sweep.name)

    from pes_ref.core.runtime.progress import ProgressWriter, clock_time

    lines = ProgressWriter()            # in place at a terminal, plain lines elsewhere

    def progress(p):
        if not args.quiet:
            lines.show(p)

    try:
        with open_client(args.scheduler, args.workers) as client:
            n_workers = len(client.nthreads())
            where = args.scheduler or "a local cluster"
            print(f"sweep {sweep.name}: {len(sweep.runs)} {sweep.kind} runs on {n_workers} workers ({where}); "
                  f"results in {out}", file=sys.stderr, flush=True)
            report = run_sweep(sweep, out, client, progress=progress, progress_every=args.progress)
    except (OSError, ValueError) as exc:
        lines.end()
        return error(exc)
    finally:
        lines.end()                     # the last progress line stays, whole, before the table
    print(_table(sweep, report.rows))
    counts = report.counts
    print(f"{len(report.rows)} runs: {counts.get('ok', 0)} ok, {counts.get('failed', 0)} failed, "
          f"{counts.get('interrupted', 0)} interrupted; {len(report.skipped)} finished earlier and skipped, "
          f"{len(report.retried)} retried; {clock_time(report.elapsed)} on {n_workers} workers; "
          f"wrote {report.csv_path}" + (f", {report.plot_path}" if report.plot_path else ""))
    if report.interrupted:
        print(f"interrupted; resume with: python -m pes_ref sweep {args.file} --out {out}", file=sys.stderr)
    return EXIT_FAIL if counts.get("failed", 0) else EXIT_OK


def _cell(value) -> str:
    try:
        x = float(value)
    except (TypeError, ValueError):
        return str(value)
    if isinstance(value, bool) or (isinstance(value, str) and not value.strip()):
        return str(value)
    return f"{x:.4g}" if math.isfinite(x) else str(x)


def _table(sweep, rows) -> str:
    """One line per run: swept options, seed, status, the headline figure, wall time, worker, error."""
    from pes_ref.synthesis import kind_named
    headline = kind_named(sweep.kind).headline
    cols = [*sweep.swept, "seed", "status", headline, "wall_s", "worker"]
    lines = [[c for c in cols] + ["error"]]
    for row in rows:
        cells = [_cell(row.get(c, "")) for c in cols[:-1]] + [str(row.get("worker", "")).replace("tcp://", "")]
        lines.append(cells + [str(row.get("error", ""))[:60]])
    widths = [max(len(line[i]) for line in lines) for i in range(len(cols))]
    return "\n".join(("  ".join(cell.ljust(w) for cell, w in zip(line, widths)) + "  " + line[-1]).rstrip()
                     for line in lines)
