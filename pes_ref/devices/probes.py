"""The probe the device analyses share: how hard a device must be pushed.

:func:`threshold_search` finds the smallest push for which a monotone test passes (the
ratchet's smallest advancing torque, the dart gun's smallest reload force), running each
round's candidates as one batch of particles. (The stiffest barrier on a device's grid,
which sets its stable step, is :func:`pes_ref.core.stability.grid_stiffness`.)
"""
from __future__ import annotations

import numpy as np

from pes_ref.core import checks

__all__ = ["threshold_search"]


def threshold_search(passes, lo: float, hi: float, tol: float, batch: int = 7) -> float:
    """Smallest value in [lo, hi] for which the monotone test ``passes`` holds, to within tol.

    Bisection generalized to ``batch`` interior points per round (each round evaluates
    ``passes(values) -> bool array`` once, so a simulator can run them as one batch of
    particles): the bracket shrinks by ``batch + 1`` per round. Returns ``hi`` when the
    test fails everywhere below it; ``passes(hi)`` must hold (else a ValueError).
    """
    lo, hi, tol = float(lo), float(hi), checks.as_positive_float("tol", tol)
    if not bool(np.asarray(passes(np.array([hi])))[0]):
        raise checks.InputError("hi", f"hi = {hi:g} is too low: the test fails at the upper end of the search; "
                                      f"raise hi")
    while hi - lo > tol:
        vals = np.linspace(lo, hi, batch + 2)[1:-1]
        ok = np.asarray(passes(vals), dtype=bool)
        if ok.any():
            k = int(np.argmax(ok))
            hi = vals[k]
            lo = vals[k - 1] if k > 0 else lo
        else:
            lo = vals[-1]
    return hi
