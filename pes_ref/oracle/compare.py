"""Comparing arrays: the one relative error, and a result against the reference by the
contract's tolerances.

[`relative_error`][pes_ref.oracle.compare.relative_error] is ``max |got - want| / scale``, one
number per compared array: by default one scale for the whole array, its largest ``|want|`` (how
finite differences, rounding and the benchmark's autodiff backends are judged); the contract gives
every entry its own scale instead.

The contract: ``|got - want| <= atol + rtol |want|`` per entry: trajectory keys (``x``, ``v``,
``energy``, ``loss``) use ``TRAJ_RTOL``/``TRAJ_ATOL``; gradients use ``GRAD_RTOL`` and
``GRAD_ATOL * max|want|`` (the largest entry of that gradient, or 1 for an all-zero
one) ([`pes_ref.oracle.tolerances`][pes_ref.oracle.tolerances]). The single number per array is the relative
error with the scale ``atol/rtol + |want|`` per entry ([`array_error`][pes_ref.oracle.compare.array_error]); the array
passes when it is ``<= rtol``.

Used by the generator's check of regenerated vectors
([`pes_ref.oracle.conformance.generate`][pes_ref.oracle.conformance.generate]) and by the conformance checks that other
implementations run ([`pes_ref.testing.conformance`][pes_ref.testing.conformance]).
"""
from __future__ import annotations

import numpy as np

from pes_ref.oracle.case import TRAJECTORY_KEYS
from pes_ref.oracle.tolerances import GRAD_ATOL, GRAD_RTOL, TRAJ_ATOL, TRAJ_RTOL

__all__ = ["relative_error", "array_error", "passes", "compare_results"]

# The result's TRAJECTORY_KEYS are compared with the trajectory tolerances; every
# ``grad_*`` key uses the gradient ones.


#: The scale of an all-zero ``want``: any difference from it is then enormous, none is 0.
_TINY = 1e-300


def relative_error(got, want, scale=None) -> float:
    """``max |got - want| / scale``: how far ``got`` is from ``want``, one number per array.

    Parameters
    ----------
    got, want : array_like
        Broadcastable to each other.
    scale : float or array_like, optional
        What a difference is measured against, one number or one per entry; default
        the largest ``|want|`` (``1e-300`` for an all-zero ``want``), so that entries near
        zero are judged against the array's largest entry, as rounding errors are.

    Returns
    -------
    float
        0 for empty arrays.
    """
    got = np.asarray(got, dtype=np.float64)
    want = np.asarray(want, dtype=np.float64)
    if scale is None:
        scale = max(float(np.max(np.abs(want), initial=0.0)), _TINY)
    return float(np.max(np.abs(got - want) / scale, initial=0.0))


def _tolerance(name: str, want: np.ndarray):
    if name in TRAJECTORY_KEYS:
        return TRAJ_RTOL, TRAJ_ATOL
    scale = float(np.max(np.abs(want), initial=0.0))
    return GRAD_RTOL, GRAD_ATOL * (scale if scale > 0 else 1.0)


def array_error(name: str, got, want) -> float:
    """The normalized error of array ``name``: [`relative_error`][pes_ref.oracle.compare.relative_error] with the scale
    ``atol/rtol + |want|`` per entry, ``max |got - want| / (atol/rtol + |want|)``
    (``inf`` when ``got`` is not a real array of ``want``'s shape, or holds NaN/inf)."""
    want = np.asarray(want, dtype=np.float64)
    try:
        got = np.asarray(got, dtype=np.float64)
    except (TypeError, ValueError):
        return float("inf")
    if got.shape != want.shape or not np.all(np.isfinite(got)):
        return float("inf")
    if want.size == 0:
        return 0.0
    rtol, atol = _tolerance(name, want)
    return relative_error(got, want, atol / rtol + np.abs(want))


def passes(name: str, error: float) -> bool:
    """Whether a normalized error of array ``name`` is within the contract."""
    return error <= (TRAJ_RTOL if name in TRAJECTORY_KEYS else GRAD_RTOL)


def compare_results(got, want, names=None) -> dict:
    """Normalized error of each array of ``want`` (or of ``names``) in ``got``.

    Parameters
    ----------
    got, want : mapping of str -> array_like
        Results (``want`` the reference).
    names : iterable of str, optional
        The keys to compare; default every key of ``want``.

    Returns
    -------
    dict of str -> float
        [`array_error`][pes_ref.oracle.compare.array_error] per key (``inf`` when ``got`` lacks the key); within the
        contract when [`passes`][pes_ref.oracle.compare.passes].
    """
    names = list(want) if names is None else list(names)
    return {k: (array_error(k, got[k], want[k]) if k in got else float("inf")) for k in names}
