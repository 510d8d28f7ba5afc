"""Populations: independent candidates of one design stage, evaluated on the sweep's cluster.

A design stage that scores independent candidates (a polish stage trying perturbed grids,
say) can hand them to the same Dask cluster as the sweep::

    from pes_ref.sweep.populations import client_map, task_client

    with task_client() as client:          # the worker's client inside a sweep task, else None
        scores = client_map(client, score, candidates)

With ``client=None`` :func:`client_map` is a plain ``map`` in this process, so the stage
runs unchanged without Dask. Inside a task, :func:`task_client` yields Dask's
``worker_client``, which hands the task's thread back to the worker while it waits, so a
single-threaded worker runs the candidates instead of deadlocking.
"""
from __future__ import annotations

import contextlib
from typing import Callable, Iterable

__all__ = ["client_map", "task_client"]


def client_map(client, fn: Callable, items: Iterable) -> list:
    """``[fn(item) for item in items]``, one task per item on ``client`` when one is given.

    Results come back in the order of ``items``; the first exception of a task is raised
    here. ``fn`` and the items must be picklable when ``client`` is not None.
    """
    items = list(items)
    if client is None:
        return [fn(item) for item in items]
    return client.gather(client.map(fn, items, pure=False))


@contextlib.contextmanager
def task_client():
    """The client of the Dask worker running this code (seceded while used), else None."""
    try:
        from distributed import get_worker, worker_client
        get_worker()
    except (ImportError, ValueError):
        yield None
        return
    with worker_client() as client:
        yield client
