"""Sweeps: many design runs from one TOML file, run as Dask tasks on one machine or a cluster.

The package behind ``python -m pes_ref sweep``, one idea per module:

- [`.options`][pes_ref.sweep.options]: design options (the ``design`` command's flags) to a problem and a plan;
- [`.spec`][pes_ref.sweep.spec]: a sweep file read and checked into its runs;
- [`.task`][pes_ref.sweep.task]: one run on a worker: design (resumable from its design file), then evaluate;
- [`.runner`][pes_ref.sweep.runner]: the runs as Dask tasks: retries, resume, interruption, progress;
- [`.results`][pes_ref.sweep.results]: ``results.csv`` and ``summary.png``;
- [`.cluster`][pes_ref.sweep.cluster]: a local cluster or an existing scheduler.

Dask (``pip install 'pes_ref[sweep]'``) is imported only where a cluster is used; this
package imports without it. See ``docs/sweeps.md``.
"""
from pes_ref.sweep.runner import SweepReport, run_sweep
from pes_ref.sweep.spec import Run, Sweep, SweepFileError, load_sweep

__all__ = ["load_sweep", "Sweep", "Run", "SweepFileError", "run_sweep", "SweepReport"]
