"""The grid potential energy surface: lookup, bilinear energy, slope and their adjoints.

SPEC section 1; paper section "Simulating potential energy surfaces". A surface is a
grid of energy values ``G`` of shape (n0, n1) on a plane, a cylinder (one axis
periodic) or a torus (both periodic). Axis 0 of ``G`` is coordinate q0, axis 1 is q1.

Spacing ``h_d`` is ``L_d / n_d`` on a periodic axis (node ``n_d`` is node 0 again) and
``L_d / (n_d - 1)`` on a non-periodic one (the last node sits on ``upper_d``), with
``L_d = upper_d - lower_d``.

State positions are never wrapped; only the lookup wraps (:func:`locate`). Outside a
non-periodic axis the surface is extended as a constant along that axis, so its slope
along that axis is zero there (the switch ``s_d`` below).

The functions here are pure and vectorized over N points; they trust their inputs.
:class:`Surface` is the validated, frozen wrapper that the public API hands around.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from . import checks

__all__ = ["Surface", "Cells", "spacing", "locate", "grid_energy", "grid_slope",
           "grid_slope_vjp_q", "grid_slope_vjp_values", "wrap"]


class Cells(NamedTuple):
    """Where N points fall on the grid (SPEC section 1).

    ``i0, i1`` are the node indices along axis 0 (``j0, j1`` along axis 1), ``f0, f1``
    the fractions inside the cell, ``s0, s1`` the in-range switches (1.0 inside a
    non-periodic axis's span or on a periodic axis, else 0.0). All have shape (N,).
    """

    i0: np.ndarray
    i1: np.ndarray
    j0: np.ndarray
    j1: np.ndarray
    f0: np.ndarray
    f1: np.ndarray
    s0: np.ndarray
    s1: np.ndarray


def spacing(lower: np.ndarray, upper: np.ndarray, shape: tuple, periodic: np.ndarray) -> np.ndarray:
    """Node spacing per axis, shape (2,).

    ``h_d = L_d / n_d`` if axis d is periodic else ``L_d / (n_d - 1)``.
    """
    n = np.asarray(shape, dtype=np.float64)
    return (upper - lower) / np.where(periodic, n, n - 1.0)


def _locate_axis(q: np.ndarray, lower: float, h: float, n: int, periodic: bool):
    """Cell, fraction and switch along one axis (SPEC section 1, 'Cell and fraction')."""
    u = (q - lower) / h
    if periodic:
        k = np.floor(u)
        f = u - k
        i0 = np.mod(k, n).astype(np.intp)
        i1 = i0 + 1
        i1[i1 == n] = 0
        s = np.ones_like(u)
    else:
        uc = np.clip(u, 0.0, n - 1.0)
        i0 = np.minimum(np.floor(uc), n - 2).astype(np.intp)
        f = uc - i0
        i1 = i0 + 1
        s = ((u >= 0.0) & (u <= n - 1.0)).astype(np.float64)
    return i0, i1, f, s


def locate(q: np.ndarray, lower: np.ndarray, h: np.ndarray, shape: tuple, periodic) -> Cells:
    """Locate N points on the grid.

    Parameters
    ----------
    q : ndarray, shape (N, 2)
        Unwrapped positions.
    lower, h : ndarray, shape (2,)
        Lower corner and node spacing.
    shape : (n0, n1)
        Grid shape.
    periodic : sequence of 2 bool

    Returns
    -------
    Cells
    """
    i0, i1, f0, s0 = _locate_axis(q[:, 0], lower[0], h[0], shape[0], bool(periodic[0]))
    j0, j1, f1, s1 = _locate_axis(q[:, 1], lower[1], h[1], shape[1], bool(periodic[1]))
    return Cells(i0, i1, j0, j1, f0, f1, s0, s1)


def grid_energy(values: np.ndarray, c: Cells) -> np.ndarray:
    """Bilinear energy at the located points, shape (N,).

    E = (1-f0)(1-f1) G[i0,j0] + f0(1-f1) G[i1,j0] + (1-f0) f1 G[i0,j1] + f0 f1 G[i1,j1]
    (SPEC section 1; the paper's bilinear interpolation).
    """
    g00 = values[c.i0, c.j0]
    g10 = values[c.i1, c.j0]
    g01 = values[c.i0, c.j1]
    g11 = values[c.i1, c.j1]
    return (1 - c.f0) * (1 - c.f1) * g00 + c.f0 * (1 - c.f1) * g10 + (1 - c.f0) * c.f1 * g01 + c.f0 * c.f1 * g11


def grid_slope(values: np.ndarray, h: np.ndarray, c: Cells, out: np.ndarray | None = None) -> np.ndarray:
    """Slope dE/dq of the bilinear surface, shape (N, 2).

    dE/dq0 = s0/h0 [(1-f1)(G[i1,j0]-G[i0,j0]) + f1 (G[i1,j1]-G[i0,j1])]
    dE/dq1 = s1/h1 [(1-f0)(G[i0,j1]-G[i0,j0]) + f0 (G[i1,j1]-G[i1,j0])]
    (SPEC section 1; ``docs/adjoint.md`` eq. (A1)).
    """
    g00 = values[c.i0, c.j0]
    g10 = values[c.i1, c.j0]
    g01 = values[c.i0, c.j1]
    g11 = values[c.i1, c.j1]
    if out is None:
        out = np.empty((c.f0.shape[0], 2))
    out[:, 0] = (c.s0 / h[0]) * ((1 - c.f1) * (g10 - g00) + c.f1 * (g11 - g01))
    out[:, 1] = (c.s1 / h[1]) * ((1 - c.f0) * (g01 - g00) + c.f0 * (g11 - g10))
    return out


def grid_slope_vjp_q(values: np.ndarray, h: np.ndarray, c: Cells, w: np.ndarray) -> np.ndarray:
    """Hessian-vector product ``H(q) w`` of the bilinear surface, shape (N, 2).

    Inside a cell the bilinear energy has zero second derivative along each axis and
    the constant cross term ``Hc = s0 s1 /(h0 h1) (G11 - G10 - G01 + G00)``, so
    ``H w = (Hc w1, Hc w0)`` (``docs/adjoint.md`` eq. (A2)). This is the transpose
    of the slope's Jacobian with respect to q, applied to ``w``.
    """
    g00 = values[c.i0, c.j0]
    g10 = values[c.i1, c.j0]
    g01 = values[c.i0, c.j1]
    g11 = values[c.i1, c.j1]
    hc = (c.s0 * c.s1 / (h[0] * h[1])) * (g11 - g10 - g01 + g00)
    out = np.empty_like(w)
    out[:, 0] = hc * w[:, 1]
    out[:, 1] = hc * w[:, 0]
    return out


def grid_slope_vjp_values(h: np.ndarray, c: Cells, w: np.ndarray, n1: int, size: int) -> np.ndarray:
    """Transpose of the slope's Jacobian with respect to the grid values, applied to ``w``.

    Returns the flat (n0*n1,) array ``sum_points sum_d w_d d(slope_d)/dG``
    (``docs/adjoint.md`` eq. (A3)): with ``a = s0 w0 / h0`` and ``b = s1 w1 / h1``,

        G[i0,j0]: -(1-f1) a - (1-f0) b        G[i1,j0]: +(1-f1) a - f0 b
        G[i0,j1]: -f1 a + (1-f0) b            G[i1,j1]: +f1 a + f0 b
    """
    a = c.s0 * w[:, 0] / h[0]
    b = c.s1 * w[:, 1] / h[1]
    idx = np.concatenate((c.i0 * n1 + c.j0, c.i1 * n1 + c.j0, c.i0 * n1 + c.j1, c.i1 * n1 + c.j1))
    wts = np.concatenate((
        -(1 - c.f1) * a - (1 - c.f0) * b,
        (1 - c.f1) * a - c.f0 * b,
        -c.f1 * a + (1 - c.f0) * b,
        c.f1 * a + c.f0 * b,
    ))
    return np.bincount(idx, weights=wts, minlength=size)


def wrap(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, periodic) -> np.ndarray:
    """Positions with periodic axes wrapped into [lower, upper), for display only."""
    q = np.array(q, dtype=np.float64, copy=True)
    for d in range(2):
        if periodic[d]:
            L = upper[d] - lower[d]
            q[..., d] = lower[d] + np.mod(q[..., d] - lower[d], L)
    return q


@dataclass(frozen=True)
class Surface:
    """A validated grid potential energy surface (SPEC section 1).

    Parameters
    ----------
    values : array_like, shape (n0, n1), n0, n1 >= 2
        Energy at the grid nodes; axis 0 is q0, axis 1 is q1.
    lower, upper : array_like, shape (2,)
        The domain's corners, ``upper > lower`` on both axes.
    periodic : sequence of 2 bool
        (False, False) plane, one True a cylinder, (True, True) a torus.
    """

    values: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    periodic: tuple

    def __post_init__(self):
        values = checks.as_float_array("values", self.values, ndim=2)
        if values.shape[0] < 2 or values.shape[1] < 2:
            raise ValueError(f"values must have at least 2 nodes per axis, got shape {values.shape}")
        lower = checks.as_float_array("lower", self.lower, shape=(2,))
        upper = checks.as_float_array("upper", self.upper, shape=(2,))
        if not np.all(upper > lower):
            raise ValueError(f"upper must be > lower on both axes, got lower={lower.tolist()}, upper={upper.tolist()}")
        periodic = tuple(bool(p) for p in checks.as_bool_array("periodic", self.periodic, shape=(2,)))
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "lower", lower)
        object.__setattr__(self, "upper", upper)
        object.__setattr__(self, "periodic", periodic)

    @property
    def shape(self) -> tuple:
        return self.values.shape

    @property
    def spacing(self) -> np.ndarray:
        """Node spacing h, shape (2,)."""
        return spacing(self.lower, self.upper, self.values.shape, np.array(self.periodic))

    @property
    def length(self) -> np.ndarray:
        """Domain length L = upper - lower, shape (2,)."""
        return self.upper - self.lower

    @property
    def topology(self) -> str:
        return {0: "plane", 1: "cylinder", 2: "torus"}[sum(self.periodic)]

    def nodes(self, axis: int) -> np.ndarray:
        """Coordinates of the nodes along ``axis``."""
        return self.lower[axis] + self.spacing[axis] * np.arange(self.values.shape[axis])

    def locate(self, q) -> Cells:
        q = checks.as_float_array("q", q, shape=(None, 2))
        return locate(q, self.lower, self.spacing, self.values.shape, self.periodic)

    def energy(self, q) -> np.ndarray:
        """Bilinear energy at points ``q`` of shape (N, 2); returns (N,)."""
        return grid_energy(self.values, self.locate(q))

    def slope(self, q) -> np.ndarray:
        """dE/dq at points ``q`` of shape (N, 2); returns (N, 2)."""
        return grid_slope(self.values, self.spacing, self.locate(q))

    def wrap(self, q) -> np.ndarray:
        """Positions wrapped into the domain on periodic axes (display only)."""
        return wrap(q, self.lower, self.upper, self.periodic)
