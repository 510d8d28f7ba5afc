"""Progress reports from the time-stepping loops, every few hundred steps.

A run's forward loop and its adjoint take an optional callback ``progress(phase, done,
total)`` (``phase`` is ``"forward"`` or ``"adjoint"``, ``done`` the steps finished out of
``total``). :func:`reporting` wraps a loop's iterable so that the callback is called once
before the first step, then after every :data:`EVERY` steps and after the last: the loop
body itself never checks anything, and without a callback the iterable is returned
unchanged, so a run without progress reports pays nothing.
"""
from __future__ import annotations

from itertools import islice
from typing import Callable, Iterable

__all__ = ["EVERY", "reporting"]

#: Steps between two calls of a progress callback (a callback that reads a clock reads it
#: this rarely; at ~10 us a step that is every few milliseconds).
EVERY = 256


def reporting(steps: Iterable, progress: Callable | None, phase: str, total: int) -> Iterable:
    """``steps`` as they are, calling ``progress(phase, done, total)`` at 0, every
    :data:`EVERY` steps and at ``total``; ``steps`` itself when ``progress`` is None.

    Parameters
    ----------
    steps : iterable
        One item per step, ``total`` of them.
    progress : callable or None
    phase : str
    total : int
    """
    if progress is None:
        return steps
    return _chunks(iter(steps), progress, phase, total)


def _chunks(steps, progress, phase, total):
    progress(phase, 0, total)
    for done in range(EVERY, total + EVERY, EVERY):
        yield from islice(steps, EVERY)
        progress(phase, min(done, total), total)
