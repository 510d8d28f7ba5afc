"""Resampling a grid of values to another shape over the same domain (coarse-to-fine stages)."""
from __future__ import annotations

import numpy as np

__all__ = ["resample", "resample_vjp"]


def _axis_weights(n_old: int, n_new: int, periodic: bool):
    """Linear interpolation from n_old nodes to n_new nodes on one axis: (i0, i1, f)."""
    if periodic:
        u = np.arange(n_new) * (n_old / n_new)
        i0 = np.floor(u).astype(np.intp)
        f = u - i0
        i0 %= n_old
        return i0, (i0 + 1) % n_old, f
    u = np.linspace(0.0, n_old - 1.0, n_new)
    i0 = np.minimum(np.floor(u), n_old - 2).astype(np.intp)
    return i0, i0 + 1, u - i0


def resample(values, lower, upper, periodic, shape) -> np.ndarray:
    """Bilinear resampling of a grid to a new shape over the same domain (coarse-to-fine).

    Node ``k`` of the new grid on axis d sits at ``lower_d + k h'_d`` and takes the
    bilinear value of the old surface there (exact where old and new nodes coincide).
    """
    out = np.asarray(values, dtype=np.float64)
    for d in range(2):
        i0, i1, f = _axis_weights(out.shape[d], shape[d], bool(periodic[d]))
        a, b = np.take(out, i0, axis=d), np.take(out, i1, axis=d)
        fb = f[:, None] if d == 0 else f[None, :]
        out = a * (1.0 - fb) + b * fb
    return out


def resample_vjp(grad, shape_old, periodic) -> np.ndarray:
    """The transpose of [`resample`][pes_ref.synthesis.common.resampling.resample] from ``shape_old``: the gradient with
    respect to the
    old grid's values of a function of the resampled ones, given its gradient ``grad`` there."""
    out = np.asarray(grad, dtype=np.float64)
    for d in (1, 0):
        i0, i1, f = _axis_weights(shape_old[d], out.shape[d], bool(periodic[d]))
        moved = np.moveaxis(out, d, 0)
        acc = np.zeros((shape_old[d],) + moved.shape[1:])
        fb = f.reshape((-1,) + (1,) * (moved.ndim - 1))
        np.add.at(acc, i0, moved * (1.0 - fb))
        np.add.at(acc, i1, moved * fb)
        out = np.moveaxis(acc, 0, d)
    return out
