"""A C1 interpolation of the grid (an accuracy option beside the paper's bilinear rule).

The surface is the tensor product of two one-dimensional Catmull-Rom splines (Keys'
cubic convolution with a = -1/2; equivalently the cubic Hermite interpolant whose node
slopes are central differences): inside cell (c0, c1) with fractions (f0, f1),

    E(f0, f1) = sum_{k,l=0..3} A[c0, c1, k, l] f0^k f1^l                       (C2)

whose 16 coefficients are a linear map of the 4 x 4 nodes around the cell,

    A[c0, c1] = K E_ext[c0-1 .. c0+2, c1-1 .. c1+2] K^T,                          (C1)

    K = 1/2 [[ 0,  2,  0,  0],        rows: powers f^0 .. f^3
             [-1,  0,  1,  0],        columns: nodes c-1, c, c+1, c+2
             [ 2, -5,  4, -1],
             [-1,  3, -3,  1]]

``E_ext`` is the grid extended by one node on each side (two after, on a periodic
axis): a periodic axis wraps; a non-periodic axis gets ghost nodes extrapolated by the
quadratic through its last three nodes, ``G[-1] = 3 G[0] - 3 G[1] + G[2]`` (by the line
through the last two when the axis has only 2 nodes). The node slope there is then the
second-order one-sided difference ``(-3 G[0] + 4 G[1] - G[2]) / (2h)``, and the surface
reproduces every polynomial of degree <= 2 per axis exactly, up to the edges
(``docs/variants.md``).

Cells, fractions and the in-range switches are those of the bilinear rule
([`pes_ref.core.grid`][pes_ref.core.grid], docs/spec.md section 2): outside a non-periodic axis the surface
is constant along it and its slope along it is 0. The surface is C1 (value and slope
continuous across cell edges), so the force no longer jumps at cell edges; its Hessian
still does. Equation numbers refer to section 11 of ``docs/adjoint.md``.

The functions are pure and vectorized over N points; the coefficient table
([`cell_coefficients`][pes_ref.core.bicubic.cell_coefficients]) depends on the grid only and is computed once per run.
The
point functions (``point_*``) and the kernels ([`BicubicForce`][pes_ref.core.bicubic.BicubicForce],
[`BicubicAdjoint`][pes_ref.core.bicubic.BicubicAdjoint]) are this rule's entry in
`pes_ref.core.interpolations.INTERPOLATIONS`.
"""
from __future__ import annotations

import numpy as np

from pes_ref.core.grid import Cells, Located, Locator, stacked_table

__all__ = ["CATMULL_ROM", "cell_coefficients", "cell_coefficients_vjp", "grid_energy", "grid_slope",
           "grid_slope_vjp_q", "grid_slope_vjp_coefficients", "grid_slope_vjp_values", "slope_table",
           "hessian_table", "point_energy",
           "point_slope", "point_force", "point_force_vjp", "BicubicForce", "BicubicAdjoint"]

#: K of (C1): the Catmull-Rom cubic's power coefficients (rows f^0..f^3) from nodes c-1..c+2.
CATMULL_ROM = 0.5 * np.array([[0.0, 2.0, 0.0, 0.0],
                              [-1.0, 0.0, 1.0, 0.0],
                              [2.0, -5.0, 4.0, -1.0],
                              [-1.0, 3.0, -3.0, 1.0]])
CATMULL_ROM.setflags(write=False)


def _ghost_weights(n: int) -> tuple:
    """The extrapolation of a ghost node from the edge nodes (edge node first)."""
    return (3.0, -3.0, 1.0) if n >= 3 else (2.0, -1.0)


def _extend(g: np.ndarray, axis: int, periodic: bool) -> np.ndarray:
    """The grid extended along ``axis`` to the nodes -1 .. m+1 that the cells' stencils
    read (m = number of cells: n periodic, n - 1 not), shape n_cells + 3 along ``axis``."""
    g = np.moveaxis(g, axis, 0)
    n = g.shape[0]
    if periodic:
        ext = g[np.arange(-1, n + 2) % n]
    else:
        wts = _ghost_weights(n)
        lo = sum(w * g[i] for i, w in enumerate(wts))
        hi = sum(w * g[n - 1 - i] for i, w in enumerate(wts))
        ext = np.concatenate((lo[None], g, hi[None]))
    return np.moveaxis(ext, 0, axis)


def _extend_vjp(ebar: np.ndarray, axis: int, periodic: bool, n: int) -> np.ndarray:
    """Transpose of `_extend`: fold the extended cotangent back onto the n nodes (CB3)."""
    ebar = np.moveaxis(ebar, axis, 0)
    if periodic:
        gbar = np.zeros((n,) + ebar.shape[1:])
        np.add.at(gbar, np.arange(-1, n + 2) % n, ebar)
    else:
        gbar = ebar[1:-1].copy()
        for i, w in enumerate(_ghost_weights(n)):
            gbar[i] += w * ebar[0]
            gbar[n - 1 - i] += w * ebar[-1]
    return np.moveaxis(gbar, 0, axis)


def _stencil(e: np.ndarray, axis: int) -> np.ndarray:
    """Apply K along ``axis`` (length m + 3 -> m cells), adding a power axis of length 4 last."""
    e = np.moveaxis(e, axis, 0)
    m = e.shape[0] - 3
    windows = np.stack([e[r:r + m] for r in range(4)], axis=-1)     # (m, ..., 4 nodes)
    return np.moveaxis(windows @ CATMULL_ROM.T, 0, axis)            # (m, ..., 4 powers)


def _stencil_vjp(bbar: np.ndarray, axis: int) -> np.ndarray:
    """Transpose of `_stencil` (power axis last -> extended nodes along ``axis``)."""
    wbar = np.moveaxis(bbar @ CATMULL_ROM, axis, 0)                 # (m, ..., 4 nodes)
    m = wbar.shape[0]
    ebar = np.zeros((m + 3,) + wbar.shape[1:-1])
    for r in range(4):
        ebar[r:r + m] += wbar[..., r]
    return np.moveaxis(ebar, 0, axis)


def cell_coefficients(values: np.ndarray, periodic) -> np.ndarray:
    """The 16 power coefficients of every cell, (C1): shape (n0, n1, 16), entry ``4 k + l``
    the coefficient of ``f0^k f1^l`` of the cell whose lower corner is node (i, j).

    A linear map of ``values`` (n0, n1): extend both axes, then apply K along each. On
    a non-periodic axis the last node starts no cell; its row (column) is zero, so the
    table is indexed like the grid (flat cell ``i n1 + j``, as [`Locator`][pes_ref.core.grid.Locator]).
    """
    n0, n1 = values.shape
    e = _extend(_extend(values, 0, bool(periodic[0])), 1, bool(periodic[1]))
    a = _stencil(_stencil(e, 0), 1)                      # (m0, m1, 4k, 4l)
    out = np.zeros((n0, n1, 16))
    out[:a.shape[0], :a.shape[1]] = a.reshape(a.shape[0], a.shape[1], 16)
    return out


def cell_coefficients_vjp(abar: np.ndarray, periodic) -> np.ndarray:
    """Transpose of [`cell_coefficients`][pes_ref.core.bicubic.cell_coefficients], (CB3): a cotangent (n0, n1, 16) on
    the
    coefficients to the flat (n0*n1,) cotangent on the grid values."""
    n0, n1 = abar.shape[:2]
    m0, m1 = (n0 if periodic[0] else n0 - 1), (n1 if periodic[1] else n1 - 1)
    bbar = _stencil_vjp(abar[:m0, :m1].reshape(m0, m1, 4, 4), 1)
    ebar = _stencil_vjp(bbar, 0)
    return _extend_vjp(_extend_vjp(ebar, 1, bool(periodic[1]), n1), 0, bool(periodic[0]), n0).reshape(-1)


# --------------------------------------------------------------------------- per point

def _powers(f: np.ndarray):
    """``(1, f, f^2, f^3)`` and its derivative in f, each (N, 4)."""
    p = np.empty(f.shape + (4,))
    d = np.empty(f.shape + (4,))
    p[..., 0] = 1.0
    p[..., 1] = f
    np.multiply(f, f, out=p[..., 2])
    np.multiply(p[..., 2], f, out=p[..., 3])
    d[..., 0] = 0.0
    d[..., 1] = 1.0
    np.multiply(f, 2.0, out=d[..., 2])
    np.multiply(p[..., 2], 3.0, out=d[..., 3])
    return p, d


def _monomials(f0: np.ndarray, f1: np.ndarray) -> np.ndarray:
    """``f0^k f1^l`` at entry ``4 k + l``, shape (N, 16)."""
    return _monomials_into(np.stack((f0, f1), axis=-1), *_monomial_buffers(f0.shape[0]))


def _monomial_buffers(n: int):
    """Work arrays of `_monomials_into` for n points: powers (n, 2, 4), monomials (n, 16)."""
    p = np.empty((n, 2, 4))
    p[:, :, 0] = 1.0
    return p, np.empty((n, 16))


def _monomials_into(f: np.ndarray, p: np.ndarray, m: np.ndarray) -> np.ndarray:
    """The monomials of fractions ``f`` (n, 2) into ``m`` (n, 16), via the powers ``p``."""
    p[:, :, 1] = f
    np.multiply(f, f, out=p[:, :, 2])
    np.multiply(p[:, :, 2], f, out=p[:, :, 3])
    np.multiply(p[:, 0, :, None], p[:, 1, None, :], out=m.reshape(-1, 4, 4))
    return m


_POWER = np.array([1.0, 2.0, 3.0])


def _derivative(a: np.ndarray, axis: int) -> np.ndarray:
    """The power rule on coefficient arrays (..., 4, 4): the coefficients of d/df_axis."""
    out = np.zeros_like(a)
    if axis == 0:
        out[..., :3, :] = a[..., 1:, :] * _POWER[:, None]
    else:
        out[..., :, :3] = a[..., :, 1:] * _POWER
    return out


def slope_table(coef: np.ndarray, h: np.ndarray) -> np.ndarray:
    """(C3) as coefficient rows: ``[dA/df0 / h0, dA/df1 / h1]``, shape coef.shape[:-1] + (2, 16);
    the slope of a point inside the span is the rows dotted with its monomials."""
    a = coef.reshape(coef.shape[:-1] + (4, 4))
    return np.stack((_derivative(a, 0) / h[0], _derivative(a, 1) / h[1]), axis=-3).reshape(coef.shape[:-1] + (2, 16))


def hessian_table(coef: np.ndarray, h: np.ndarray) -> np.ndarray:
    """(C4) as coefficient rows ``[H00, H01, H11]`` (without the switches), shape coef.shape[:-1] + (3, 16)."""
    a = coef.reshape(coef.shape[:-1] + (4, 4))
    d0 = _derivative(a, 0)
    rows = (_derivative(d0, 0) / (h[0] * h[0]), _derivative(d0, 1) / (h[0] * h[1]),
            _derivative(_derivative(a, 1), 1) / (h[1] * h[1]))
    return np.stack(rows, axis=-3).reshape(coef.shape[:-1] + (3, 16))


def _rows_dot(rows: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Per point, coefficient rows (N, r, 16) dotted with monomials (N, 16): (N, r)."""
    return np.einsum("nrj,nj->nr", rows, m)


def _energy(a, f0, f1):
    """(C2) from gathered coefficients a (N, 16) and fractions (N,)."""
    return np.einsum("nj,nj->n", a, _monomials(f0, f1))


def _slope(rows, f0, f1, s0, s1, out):
    """(C3) from gathered slope rows (N, 2, 16) into ``out`` (N, 2); ``s0, s1`` the switches (arrays, or 1.0)."""
    np.einsum("nrj,nj->nr", rows, _monomials(f0, f1), out=out)
    out[:, 0] *= s0
    out[:, 1] *= s1
    return out


def _hessian_times(rows, f0, f1, s0, s1, w):
    """(C4): ``H w`` (N, 2) from gathered Hessian rows (N, 3, 16), times the switches
    (H00 s0, H01 s0 s1, H11 s1; s^2 = s for a 0/1 switch)."""
    hh = _rows_dot(rows, _monomials(f0, f1))
    h00, h01, h11 = hh[:, 0] * s0, hh[:, 1] * (s0 * s1), hh[:, 2] * s1
    out = np.empty_like(w)
    out[:, 0] = h00 * w[:, 0] + h01 * w[:, 1]
    out[:, 1] = h01 * w[:, 0] + h11 * w[:, 1]
    return out


def _coefficient_weights(f0, f1, s0, s1, h, w):
    """(CB2) per point, (N, 16): d(w . slope)/dA_kl = (s0 w0/h0) k f0^(k-1) f1^l + (s1 w1/h1) f0^k l f1^(l-1)."""
    p0, d0 = _powers(f0)
    p1, d1 = _powers(f1)
    a = (s0 / h[0]) * w[:, 0]
    b = (s1 / h[1]) * w[:, 1]
    return ((a[:, None] * d0)[:, :, None] * p1[:, None, :]
            + (b[:, None] * p0)[:, :, None] * d1[:, None, :]).reshape(-1, 16)


def _scatter(cell: np.ndarray, weights: np.ndarray, size: int) -> np.ndarray:
    """``sum`` of per-point (.., 16) weights into the flat (size, 16) table by cell, one ``np.bincount``."""
    idx = (cell.reshape(-1, 1) * 16 + np.arange(16)).reshape(-1)
    return np.bincount(idx, weights=weights.reshape(-1), minlength=size * 16).reshape(size, 16)


# --------------------------------------------------------------------------- pure functions on Cells

def grid_energy(coef: np.ndarray, c: Cells) -> np.ndarray:
    """Bicubic energy (C2) at points located by [`pes_ref.core.grid.locate`][pes_ref.core.grid.locate], shape (N,)."""
    return _energy(coef[c.i0, c.j0], c.f0, c.f1)


def grid_slope(coef: np.ndarray, h: np.ndarray, c: Cells, out: np.ndarray | None = None) -> np.ndarray:
    """Slope dE/dq of the bicubic surface, shape (N, 2), (C3):

    dE/dq0 = s0/h0 sum_kl k A_kl f0^(k-1) f1^l,   dE/dq1 = s1/h1 sum_kl l A_kl f0^k f1^(l-1).
    """
    out = np.empty((c.f0.shape[0], 2)) if out is None else out
    return _slope(slope_table(coef[c.i0, c.j0], h), c.f0, c.f1, c.s0, c.s1, out)


def grid_slope_vjp_q(coef: np.ndarray, h: np.ndarray, c: Cells, w: np.ndarray) -> np.ndarray:
    """Hessian-vector product ``H(q) w`` of the bicubic surface, shape (N, 2), (C4). H is
    symmetric, so this is also the transpose of the slope's Jacobian in q applied to ``w``."""
    return _hessian_times(hessian_table(coef[c.i0, c.j0], h), c.f0, c.f1, c.s0, c.s1, w)


def grid_slope_vjp_coefficients(h: np.ndarray, c: Cells, w: np.ndarray, shape: tuple) -> np.ndarray:
    """Transpose of the slope's Jacobian with respect to the cell coefficients, (CB2),
    summed over the points with ``np.bincount``; shape (n0, n1, 16)."""
    wts = _coefficient_weights(c.f0, c.f1, c.s0, c.s1, h, w)
    return _scatter(c.i0 * shape[1] + c.j0, wts, shape[0] * shape[1]).reshape(shape + (16,))


def grid_slope_vjp_values(h: np.ndarray, c: Cells, w: np.ndarray, shape: tuple, periodic) -> np.ndarray:
    """Transpose of the slope's Jacobian with respect to the grid values applied to ``w``:
    (CB2) then (CB3). Returns the flat (n0*n1,) array, as
    [`pes_ref.core.bilinear.grid_slope_vjp_values`][pes_ref.core.bilinear.grid_slope_vjp_values] does for the bilinear rule."""
    return cell_coefficients_vjp(grid_slope_vjp_coefficients(h, c, w, tuple(shape)), periodic)


# --------------------------------------------------------------------------- the force path

def _switches(loc):
    """s0, s1 from a [`Located`][pes_ref.core.grid.Located] (1.0 on a torus)."""
    if loc.inside is None:
        return 1.0, 1.0
    return loc.inside[..., 0], loc.inside[..., 1]


def point_energy(values, lower, h, periodic, x) -> np.ndarray:
    """The bicubic grid energy at points x (N, 2), shape (N,) (one-off calls: builds the table)."""
    coef = cell_coefficients(values, periodic).reshape(-1, 16)
    loc = Locator(lower, h, values.shape, periodic).locate(x)
    return _energy(coef[loc.cell], loc.f[:, 0], loc.f[:, 1])


def point_slope(values, lower, h, periodic, x) -> np.ndarray:
    """The bicubic slope dE/dx at points x (N, 2), shape (N, 2): minus [`point_force`][pes_ref.core.bicubic.point_force]."""
    out = point_force(values, lower, h, periodic, x, np.empty(x.shape))
    return np.negative(out, out=out)


def point_force(values, lower, h, periodic, x, out) -> np.ndarray:
    """The bicubic grid force ``-dE/dx`` at points x (N, 2) into ``out`` (one-off calls)."""
    return BicubicForce.from_grid(values, lower, h, periodic, x.shape[0]).call(x, out)


def point_force_vjp(values, lower, h, periodic, x, w, xbar, gvalues) -> None:
    """Adjoint of [`point_force`][pes_ref.core.bicubic.point_force] at x for the cotangent ``w``: ``xbar -= H w`` and,
    if ``gvalues`` (flat n0*n1) is given, ``gvalues -= (d slope/dG)^T w`` ((CB1) with H by (C4), (CB2)-(CB3))."""
    adj = BicubicAdjoint.from_grid(values, lower, h, periodic, x[None], gvalues is not None)
    adj.vjp(0, w, xbar)
    if gvalues is not None:
        gvalues += adj.values_grad()


class BicubicForce:
    """The bicubic grid force for N particles at a time, its slope table (C3) built once
    (the forward hot loop; a [`GridForce`][pes_ref.core.kernels.GridForce]).

    ``call(x, out)``, bound once here: locate, one ``np.take`` of the (N, 2, 16) slope
    rows, the (N, 16) monomials, one batched matmul, the switches."""

    def __init__(self, field, n_particles: int):
        self._setup(field.values, field.lower, field.h, field.periodic, n_particles, field.offsets)

    @classmethod
    def from_grid(cls, values, lower, h, periodic, n_particles: int) -> "BicubicForce":
        """The force for ``n_particles`` from a grid's arrays (``values``, ``lower``, spacing ``h``,
        ``periodic``) rather than a field: one-off calls ([`point_force`][pes_ref.core.bicubic.point_force])."""
        self = cls.__new__(cls)
        self._setup(values, lower, h, periodic, n_particles)
        return self

    def _setup(self, values, lower, h, periodic, n_particles, offsets=None):
        self.locator = Locator(lower, h, values.shape[-2:], periodic)
        self.table = stacked_table(lambda v: -slope_table(cell_coefficients(v, periodic), h).reshape(-1, 2, 16),
                                   values)
        self.offsets = offsets
        self.buf = self.locator.buffers((n_particles,))
        self.rows = np.empty((n_particles, 2, 16))
        self.powers, self.monomials = _monomial_buffers(n_particles)
        self.call = self._bind()

    def _bind(self):
        locate_into, table, rows, powers, monomials = (self.locator.bind(self.buf), self.table, self.rows,
                                                       self.powers, self.monomials)
        cell, f, offsets = self.buf["cell"], self.buf["f"], self.offsets
        inside = self.buf["inside"] if self.locator.clips else None

        def call(x, out):
            locate_into(x)
            if offsets is not None:          # a population: each particle's grid
                np.add(cell, offsets, out=cell)
            np.take(table, cell, axis=0, out=rows, mode="clip")
            np.einsum("nrj,nj->nr", rows, _monomials_into(f, powers, monomials), out=out)
            if inside is not None:
                np.multiply(out, inside, out=out)
            return out
        return call


class BicubicAdjoint:
    """The adjoint of [`BicubicForce`][pes_ref.core.bicubic.BicubicForce] over stored states ``xs`` (T+1, N, 2),
    (CB1)-(CB3)
    (a [`GridAdjoint`][pes_ref.core.kernels.GridAdjoint]).

    ``vjp(n, w, xbar)`` (states in descending order) does ``xbar -= H(x_n) w`` and keeps
    the coefficient weights of ``w``; they are scattered into the table's gradient with
    one ``np.bincount`` per ``CHUNK`` states, and mapped to the grid values once, by
    [`values_grad`][pes_ref.core.bicubic.BicubicAdjoint.values_grad] (the map (C1) is linear and the same at every
    step).
    """

    #: States whose coefficient weights are scattered together.
    CHUNK = 64

    def __init__(self, field, xs: np.ndarray, want_values: bool):
        self._setup(field.values, field.lower, field.h, field.periodic, xs, want_values)

    @classmethod
    def from_grid(cls, values, lower, h, periodic, xs, want_values: bool) -> "BicubicAdjoint":
        """The adjoint over ``xs`` from a grid's arrays (``values``, ``lower``, spacing ``h``,
        ``periodic``) rather than a field: one-off calls ([`point_force_vjp`][pes_ref.core.bicubic.point_force_vjp])."""
        self = cls.__new__(cls)
        self._setup(values, lower, h, periodic, xs, want_values)
        return self

    def _setup(self, values, lower, h, periodic, xs, want_values):
        self.xs, self.h, self.shape, self.periodic = xs, h, values.shape, periodic
        self.locator = Locator(lower, h, values.shape, periodic)
        self.table = hessian_table(cell_coefficients(values, periodic), h).reshape(-1, 3, 16)
        self.want_values = want_values
        self.gtab = np.zeros((self.locator.size, 16)) if want_values else None
        self.pending = []
        buf = self.locator.buffers(xs.shape[1:2])
        self.locate_into = self.locator.bind(buf)
        self.located = Located(buf["cell"], buf["f"], buf["inside"] if self.locator.clips else None)

    def vjp(self, n: int, w: np.ndarray, xbar: np.ndarray) -> None:
        """(CB1) ``xbar -= H(x_n) w`` with H by (C4), and the coefficient weights of ``w`` kept (CB2)."""
        self.locate_into(self.xs[n])
        loc = self.located
        f0, f1 = loc.f[:, 0], loc.f[:, 1]
        s0, s1 = _switches(loc)
        xbar -= _hessian_times(np.take(self.table, loc.cell, axis=0, mode="clip"), f0, f1, s0, s1, w)
        if self.want_values:
            self.pending.append((loc.cell.copy(), _coefficient_weights(f0, f1, s0, s1, self.h, w)))
            if len(self.pending) >= self.CHUNK:
                self._flush()

    def _flush(self) -> None:
        if self.pending:
            cells, wts = zip(*self.pending)
            self.gtab -= _scatter(np.concatenate(cells), np.concatenate(wts), self.locator.size)
            self.pending = []

    def values_grad(self):
        """The accumulated ``sum_n (dF(x_n)/dG)^T w_n``, flat (n0*n1,), or None if not wanted."""
        if not self.want_values:
            return None
        self._flush()
        return cell_coefficients_vjp(self.gtab.reshape(self.shape + (16,)), self.periodic)
