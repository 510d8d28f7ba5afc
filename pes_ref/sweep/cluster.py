"""Where a sweep runs: a Dask ``LocalCluster`` on this machine, or an existing cluster.

Dask is the optional extra ``sweep`` (``pip install 'pes_ref[sweep]'``):
[`require_dask`][pes_ref.sweep.cluster.require_dask]
says so in one line when it is missing. [`open_client`][pes_ref.sweep.cluster.open_client] yields a
``distributed.Client``: connected to ``scheduler`` when one is given, else to a new
``LocalCluster`` with one single-threaded worker process per core (``OMP_NUM_THREADS=1``
and friends in the workers, so that NumPy does not oversubscribe the cores), its
dashboard on a free port of 127.0.0.1, and a scheduler that gives up on a task at the first worker that dies while
running it (the sweep then retries it once itself, see [`pes_ref.sweep.runner`][pes_ref.sweep.runner]).
Local workers ignore SIGINT: Ctrl-C in the terminal reaches the whole process group, and
it is the sweep's to handle (it asks the running designs to save and stop).
"""
from __future__ import annotations

import contextlib
import logging
import os

from pes_ref.core.runtime.extras import require
from pes_ref.core.runtime.signals import ignore_interrupts

__all__ = ["require_dask", "open_client", "local_cluster", "NEEDS", "WORKER_ENV"]

#: What a missing extra's one line says needs it.
NEEDS = "the sweep command"
#: Environment of every local worker process: one thread each for the numerical libraries.
WORKER_ENV = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
#: Scheduler settings of a local cluster: a task whose worker dies is not run again by Dask (the
#: sweep retries it once on another worker), and a worker gets one task at a time.
LOCAL_SCHEDULER_CONFIG = {"distributed.scheduler.allowed-failures": 0,
                          "distributed.scheduler.worker-saturation": 1.0}


def require_dask() -> None:
    """Raise a [`MissingExtraError`][pes_ref.core.runtime.extras.MissingExtraError] (an ``ImportError``)
    with the pip line when Dask's ``distributed`` is not installed."""
    require("distributed", "sweep", NEEDS)


def _local_worker_setup(client) -> None:
    """Make the local workers, present and restarted, ignore SIGINT
    ([`pes_ref.core.runtime.signals.ignore_interrupts`][pes_ref.core.runtime.signals.ignore_interrupts], run in each worker's main thread)."""
    from distributed import WorkerPlugin

    class IgnoreSigint(WorkerPlugin):
        name = "pes_ref-ignore-sigint"

        def setup(self, worker):
            ignore_interrupts()

    client.register_plugin(IgnoreSigint())


def local_cluster(n_workers: int | None = None):
    """A ``LocalCluster`` of ``n_workers`` single-threaded worker processes (default: one per core)."""
    import dask
    from distributed import LocalCluster

    n = (os.cpu_count() or 1) if n_workers is None else n_workers
    if n < 1:
        raise ValueError(f"workers must be >= 1, got {n_workers!r}")
    with dask.config.set(LOCAL_SCHEDULER_CONFIG):
        return LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address="127.0.0.1:0",
                            env=WORKER_ENV, silence_logs=logging.CRITICAL)


@contextlib.contextmanager
def open_client(scheduler: str | None = None, n_workers: int | None = None):
    """A ``distributed.Client`` for a sweep; closes what it opened on exit.

    Parameters
    ----------
    scheduler : str, optional
        Address of a running scheduler (``tcp://host:8786``); none starts a local cluster.
    n_workers : int, optional
        Worker processes of the local cluster (default: one per core); refused with ``scheduler``.
    """
    require_dask()
    from distributed import Client

    if scheduler is not None:
        if n_workers is not None:
            raise ValueError(f"workers {n_workers}: the number of workers is the cluster's own when a "
                             f"scheduler ({scheduler}) is given")
        with Client(scheduler, timeout="10s") as client:
            yield client
        return
    with local_cluster(n_workers) as cluster, Client(cluster) as client:
        _local_worker_setup(client)
        yield client
