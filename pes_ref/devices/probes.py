"""The probes the device analyses share: how hard a device must be pushed.

[`threshold_search`][pes_ref.devices.probes.threshold_search] finds the smallest push for which a
monotone test passes (the ratchet's smallest advancing torque, the dart gun's smallest reload
force), running each round's candidates as one batch of particles.
[`steepest_slope`][pes_ref.devices.probes.steepest_slope] is the largest push a grid can hold back
at all. (The stiffest barrier on a device's grid, which sets its stable step, is
[`pes_ref.core.stability.grid_stiffness`][pes_ref.core.stability.grid_stiffness].)
"""
from __future__ import annotations

import numpy as np

from pes_ref.core import checks

__all__ = ["threshold_search", "steepest_slope", "RESOLUTION"]

#: The narrowest bracket a search may ask for, relative to its upper end: float64 resolves
#: about 2e-16 of a value, so a bracket much narrower than this cannot shrink further.
RESOLUTION = 1e-12


def threshold_search(passes, lo: float, hi: float, tol: float, batch: int = 7) -> float:
    """Smallest value in [lo, hi] for which the monotone test ``passes`` holds, to within tol.

    Bisection generalized to ``batch`` interior points per round (each round evaluates
    ``passes(values) -> bool array`` once, so a simulator can run them as one batch of
    particles): the bracket shrinks by ``batch + 1`` per round. Returns ``hi`` when the
    test fails everywhere below it; ``passes(hi)`` must hold (else a ValueError). A ``tol``
    below `RESOLUTION` times ``hi`` is refused (a ValueError naming ``tol``): the bracket
    could never shrink to it.
    """
    lo, hi, tol = float(lo), float(hi), checks.as_positive_float("tol", tol)
    if tol < RESOLUTION * abs(hi):
        raise checks.InputError("tol", f"tol = {tol:g} is finer than float64 can resolve a search up to hi = {hi:g}; "
                                       f"use tol >= {RESOLUTION * abs(hi):.3g} ({RESOLUTION:g} x hi)",
                                names=("tol", "hi"))
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


def steepest_slope(surface, axis: int) -> float:
    """The largest ``|dE/dq_axis|`` between neighbouring nodes of the grid of ``surface``
    (across the seam of a periodic axis too): the largest constant push along ``axis``
    that any barrier of the grid can hold back. A larger push moves a particle whatever
    the grid holds."""
    values = surface.values
    if surface.periodic[axis]:
        values = np.concatenate([values, np.take(values, [0], axis=axis)], axis=axis)
    return float(np.max(np.abs(np.diff(values, axis=axis)))) / float(surface.spacing[axis])
