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

from pes_ref.core import checks

__all__ = ["Surface", "Cells", "Locator", "spacing", "locate", "grid_energy", "grid_slope",
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


class Located(NamedTuple):
    """Cells of points of shape (..., 2) as the hot loop uses them (see :class:`Locator`).

    ``cell`` (...,) intp is the flat index ``i0 * n1 + j0`` of the cell's lower corner;
    ``f`` (..., 2) the fractions (f0, f1); ``inside`` (..., 2) the switches s0, s1 as
    0.0 / 1.0 (a float mask multiplies ~2x faster than a bool one), or None on a torus
    (all ones there).
    """

    cell: np.ndarray
    f: np.ndarray
    inside: np.ndarray | None


try:   # the clip ufunc itself: one pass for both bounds, without np.clip's Python wrapper
    from numpy._core.umath import clip as _clip
except ImportError:  # NumPy < 2
    from numpy.core.umath import clip as _clip


_MINUS_INF = np.array(-np.inf)


def _per_axis(c: np.ndarray, lead: tuple):
    """A per-axis constant (2,) as an operand for (..., 2) arrays: a 0-d array when both
    axes agree, else tiled to ``lead + (2,)``. (NumPy broadcasts a (2,) operand with an
    inner loop of length 2, several times slower than a scalar or a same-shaped array;
    and a 0-d array skips the conversion a Python float costs on every call.)"""
    if c[0] == c[1]:
        return np.array(c[0], dtype=np.float64)
    return np.ascontiguousarray(np.broadcast_to(c, tuple(lead) + (2,)))


class Locator:
    """Both axes of :func:`locate` at once, into flat cell indices, with reusable buffers.

    Same arithmetic as :func:`locate` (the same cells and bit-identical fractions),
    written as a few whole-array operations on (..., 2) arrays instead of one pass per
    axis: ``u = (q - lower) / h``; ``uc = clip(u, lo_d, hi_d)`` with ``(0, n_d - 1)`` on a
    non-periodic axis and ``(-inf, inf)`` (a no-op) on a periodic one; ``k = min(floor(uc),
    kmax_d)`` with ``kmax_d = n_d - 2`` or ``inf``; ``f = uc - k``; ``i = k - n_d floor(k /
    n_d)`` (``k mod n_d``, exact for the integers ``|k| < 2**52``; the identity on a
    non-periodic axis, where ``0 <= k <= n_d - 2``); ``cell = i0 n1 + i1``; ``s = (u == uc)``.
    Operations that are no-ops for the topology are skipped: a torus never clips, a plane
    never wraps.

    A non-finite position gives a garbage cell index; callers gather with
    ``mode="clip"`` so that it never fails, and check the finiteness of the trajectory
    afterwards (the force there is NaN anyway).
    """

    def __init__(self, lower: np.ndarray, h: np.ndarray, shape: tuple, periodic):
        per = np.array([bool(p) for p in periodic])
        n = np.asarray(shape, dtype=np.float64)
        self.shape = tuple(int(m) for m in shape)
        self.size = self.shape[0] * self.shape[1]
        self.consts = dict(lower=np.asarray(lower, dtype=np.float64), h=np.asarray(h, dtype=np.float64),
                           clip_lo=np.where(per, -np.inf, 0.0), clip_hi=np.where(per, np.inf, n - 1.0),
                           kmax=np.where(per, np.inf, n - 2.0), n=n)
        self.n1 = np.array(float(shape[1]))
        self.clips = not per.all()      # some axis is non-periodic: clip and switch
        self.wraps = bool(per.any())    # some axis is periodic: k mod n

    def buffers(self, lead: tuple) -> dict:
        """Work arrays (and per-axis constants) for points of shape ``lead + (2,)``."""
        lead = tuple(lead)
        buf = {name: _per_axis(c, lead) for name, c in self.consts.items()}
        buf.update(u=np.empty(lead + (2,)), k=np.empty(lead + (2,)), f=np.empty(lead + (2,)),
                   cellf=np.empty(lead), cell=np.empty(lead, dtype=np.intp))
        buf["k0"], buf["k1"] = buf["k"][..., 0], buf["k"][..., 1]
        if self.clips:
            buf.update(uc=np.empty(lead + (2,)), inside=np.empty(lead + (2,)))
        if self.wraps:
            buf["q"] = np.empty(lead + (2,))
        return buf

    @staticmethod
    def head(buf: dict, m: int) -> dict:
        """The first ``m`` rows (along the leading axis) of buffers from :meth:`buffers`."""
        out = {name: (a[:m] if isinstance(a, np.ndarray) and a.ndim else a) for name, a in buf.items()}
        out["k0"], out["k1"] = out["k"][..., 0], out["k"][..., 1]
        return out

    def bind(self, buf: dict):
        """``locate_into(x)``: :meth:`locate` into the buffers ``buf`` (from :meth:`buffers`)
        with everything bound once, for a hot loop that calls it every step.

        The same operations (bit-identical cells, fractions and switches, read from
        ``buf["cell"]``, ``buf["f"]``, ``buf["inside"]``), but the buffers, constants and
        ufuncs are closure locals (no dict lookup or attribute access per call), the
        ufuncs get their output positionally, and ``k0 n1 + k1`` is added straight into the
        integer cell index (one call instead of an addition and a cast copy)."""
        sub, div, mul, add, eq, floor = np.subtract, np.divide, np.multiply, np.add, np.equal, np.floor
        clip, minus_inf, n1 = _clip, _MINUS_INF, self.n1
        u, k, f, cellf, cell = buf["u"], buf["k"], buf["f"], buf["cellf"], buf["cell"]
        k0, k1, lower, h = buf["k0"], buf["k1"], buf["lower"], buf["h"]
        clips, wraps = self.clips, self.wraps
        uc = buf["uc"] if clips else u
        inside, lo, hi, kmax = (buf["inside"], buf["clip_lo"], buf["clip_hi"], buf["kmax"]) if clips else (None,) * 4
        q, n = (buf["q"], buf["n"]) if wraps else (None, None)

        if clips and not wraps:           # a plane: the common case, without branches
            def locate_into(x):
                sub(x, lower, u)
                div(u, h, u)
                clip(u, lo, hi, uc)
                eq(u, uc, inside)
                floor(uc, k)
                clip(k, minus_inf, kmax, k)
                sub(uc, k, f)
                mul(k0, n1, cellf)
                add(cellf, k1, cell, casting="unsafe")
            return locate_into

        def locate_into(x):
            sub(x, lower, u)
            div(u, h, u)
            if clips:
                clip(u, lo, hi, uc)
                eq(u, uc, inside)
            floor(uc, k)
            if clips:
                clip(k, minus_inf, kmax, k)
            sub(uc, k, f)
            if wraps:
                div(k, n, q)
                floor(q, q)
                mul(q, n, q)
                sub(k, q, k)
            mul(k0, n1, cellf)
            add(cellf, k1, cell, casting="unsafe")
        return locate_into

    def locate(self, x: np.ndarray, buf: dict | None = None) -> Located:
        """Locate points ``x`` (..., 2); ``buf`` from :meth:`buffers` (allocated if None)."""
        if buf is None:
            buf = self.buffers(x.shape[:-1])
        u, k, f = buf["u"], buf["k"], buf["f"]
        np.subtract(x, buf["lower"], out=u)
        np.divide(u, buf["h"], out=u)
        uc, inside = u, None
        if self.clips:
            uc, inside = buf["uc"], buf["inside"]
            _clip(u, buf["clip_lo"], buf["clip_hi"], out=uc)
            np.equal(u, uc, out=inside)
        np.floor(uc, out=k)
        if self.clips:
            _clip(k, _MINUS_INF, buf["kmax"], out=k)
        np.subtract(uc, k, out=f)
        if self.wraps:
            q, n = buf["q"], buf["n"]
            np.divide(k, n, out=q)
            np.floor(q, out=q)
            np.multiply(q, n, out=q)
            np.subtract(k, q, out=k)
        cellf = buf["cellf"]
        np.multiply(buf["k0"], self.n1, out=cellf)
        np.add(cellf, buf["k1"], out=cellf)
        np.copyto(buf["cell"], cellf, casting="unsafe")
        return Located(buf["cell"], f, inside)


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
    interpolation : {"bilinear", "bicubic"}
        "bilinear" (default) is SPEC section 1, the paper's rule; "bicubic" the C1
        Catmull-Rom option of :mod:`pes_ref.core.bicubic` (``docs/variants.md``).
    """

    values: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    periodic: tuple
    interpolation: str = "bilinear"

    def __post_init__(self):
        values = checks.as_float_array("values", self.values, ndim=2)
        if values.shape[0] < 2 or values.shape[1] < 2:
            raise checks.InputError("values", f"values must have at least 2 nodes per axis, got shape {values.shape}")
        lower = checks.as_float_array("lower", self.lower, shape=(2,))
        upper = checks.as_float_array("upper", self.upper, shape=(2,))
        if not np.all(upper > lower):
            raise checks.InputError("upper", f"upper must be > lower on both axes, got lower={lower.tolist()}, "
                                             f"upper={upper.tolist()}")
        periodic = tuple(bool(p) for p in checks.as_bool_array("periodic", self.periodic, shape=(2,)))
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "lower", lower)
        object.__setattr__(self, "upper", upper)
        object.__setattr__(self, "periodic", periodic)
        object.__setattr__(self, "interpolation",
                           checks.as_choice("interpolation", self.interpolation, {"bilinear", "bicubic"}))

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
        """Energy at points ``q`` of shape (N, 2) by the surface's interpolation; returns (N,)."""
        if self.interpolation == "bicubic":
            from . import bicubic   # bicubic imports this module
            q = checks.as_float_array("q", q, shape=(None, 2))
            return bicubic.point_energy(self.values, self.lower, self.spacing, self.periodic, q)
        return grid_energy(self.values, self.locate(q))

    def slope(self, q) -> np.ndarray:
        """dE/dq at points ``q`` of shape (N, 2) by the surface's interpolation; returns (N, 2)."""
        if self.interpolation == "bicubic":
            from pes_ref.core import bicubic
            q = checks.as_float_array("q", q, shape=(None, 2))
            out = bicubic.point_force(self.values, self.lower, self.spacing, self.periodic, q, np.empty(q.shape))
            return np.negative(out, out=out)
        return grid_slope(self.values, self.spacing, self.locate(q))

    def wrap(self, q) -> np.ndarray:
        """Positions wrapped into the domain on periodic axes (display only)."""
        return wrap(q, self.lower, self.upper, self.periodic)
