"""The bilinear rule of docs/spec.md section 2 (the paper's): energy, slope, force and their adjoints,
pointwise and as the hot loop computes them.

On the cell whose lower corner is node (i, j) (located by [`pes_ref.core.grid`][pes_ref.core.grid]), with
corners ``g00 = G[i, j]``, ``g10 = G[i+1, j]``, ``g01 = G[i, j+1]``, ``g11 = G[i+1, j+1]``
(indices wrapped on a periodic axis), fractions ``f0, f1`` and switches ``s0, s1``::

    E = (1-f0)(1-f1) g00 + f0(1-f1) g10 + (1-f0) f1 g01 + f0 f1 g11

The textbook functions ([`grid_energy`][pes_ref.core.bilinear.grid_energy],
[`grid_slope`][pes_ref.core.bilinear.grid_slope], [`grid_slope_vjp_q`][pes_ref.core.bilinear.grid_slope_vjp_q],
[`grid_slope_vjp_values`][pes_ref.core.bilinear.grid_slope_vjp_values]; ``docs/adjoint.md`` eqs. (A1)-(A3)) take located
[`Cells`][pes_ref.core.grid.Cells]. The force of the bilinear energy is affine in the
fractions::

    F0 = s0 (A0 + f1 D0),   A0 = -(g10 - g00) / h0,   D0 = -((g11 - g01) - (g10 - g00)) / h0
    F1 = s1 (A1 + f0 D1),   A1 = -(g01 - g00) / h1,   D1 = -((g11 - g10) - (g01 - g00)) / h1

and its Hessian has only the constant cross term ``Hc = s0 s1 (g11 - g10 - g01 + g00) / (h0 h1)``
(eq. (A2)). [`coefficient_table`][pes_ref.core.bilinear.coefficient_table] computes ``[A0, A1, D0,
D1]`` for every cell once per surface, so a step of the hot loop
([`BilinearForce`][pes_ref.core.bilinear.BilinearForce], ``docs/performance.md``) gathers one row of
4 numbers per particle instead of 4 corners and recomputing their differences. Its numbers equal
those of [`grid_slope`][pes_ref.core.bilinear.grid_slope] up to rounding (a few ulp; the formula is
regrouped); [`point_force`][pes_ref.core.bilinear.point_force] computes them without a table,
bit-identical to the kernel.

The adjoint ([`BilinearAdjoint`][pes_ref.core.bilinear.BilinearAdjoint]) relocates a whole chunk of
stored states at once, does only ``xbar -= Hc (w1, w0)`` per step, and scatters the grid gradient
once per chunk (``np.bincount`` or ``np.add.at``) into the coefficient table's gradient, mapped to
the grid values once at the end
([`table_grad_to_values`][pes_ref.core.bilinear.table_grad_to_values]).

The point functions (``point_*``) and the kernels are this rule's entry in
`pes_ref.core.interpolations.INTERPOLATIONS`.
"""
from __future__ import annotations

import math
import weakref

import numpy as np

from pes_ref.core.grid import Cells, Located, Locator, locate, stacked_table

__all__ = ["grid_energy", "grid_slope", "grid_slope_vjp_q", "grid_slope_vjp_values",
           "point_energy", "point_slope", "point_force", "point_force_vjp",
           "coefficient_table", "cross_table", "table_grad_to_values",
           "BilinearForce", "BilinearForce1", "BilinearAdjoint", "forward_kernel", "CHUNK_ELEMENTS"]

#: Particle-states per chunk of the adjoint's scatter of the grid gradient: large, since
#: scattering into a cache-cold table costs ~3x more per element in small batches; the
#: chunk's buffers (~100 bytes per particle-state, ~7 MB) stay small beside a trajectory.
CHUNK_ELEMENTS = 1 << 16
#: Particle-states per batched lookup inside a chunk: its ~10 temporaries then stay in a
#: core's L2 cache (one lookup of 65536 points is ~1.5x slower per point than 16 of 4096).
LOOKUP_ELEMENTS = 1 << 12


# =========================================================================== on located cells

def grid_energy(values: np.ndarray, c: Cells) -> np.ndarray:
    """Bilinear energy at the located points, shape (N,).

    E = (1-f0)(1-f1) G[i0,j0] + f0(1-f1) G[i1,j0] + (1-f0) f1 G[i0,j1] + f0 f1 G[i1,j1]
    (docs/spec.md section 2.4; the paper's bilinear interpolation).
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
    (docs/spec.md section 2.4; ``docs/adjoint.md`` eq. (A1)).
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


# =========================================================================== per-cell tables

def _coefficients(g00, g10, g01, g11, h: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``out[..., :] = [A0, A1, D0, D1]`` from the corner values of single cells (see the
    module docstring); the same operations as
    [`coefficient_table`][pes_ref.core.bilinear.coefficient_table], so the forces of both are
    bit-identical."""
    nih0, nih1 = -1.0 / h[0], -1.0 / h[1]
    d0a, d0b = g10 - g00, g11 - g01
    d1a, d1b = g01 - g00, g11 - g10
    np.multiply(d0a, nih0, out=out[..., 0])
    np.multiply(d1a, nih1, out=out[..., 1])
    np.multiply(d0b - d0a, nih0, out=out[..., 2])
    np.multiply(d1b - d1a, nih1, out=out[..., 3])
    return out


def _diff_wrapped(a: np.ndarray, axis: int, out: np.ndarray) -> None:
    """``out[k] = a[k+1] - a[k]`` along ``axis``, with ``a[n]`` taken as ``a[0]``."""
    a, out = np.moveaxis(a, axis, 0), np.moveaxis(out, axis, 0)
    np.subtract(a[1:], a[:-1], out=out[:-1])
    np.subtract(a[:1], a[-1:], out=out[-1:])


def coefficient_table(values: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Per-cell force coefficients, shape (n0 * n1, 4), row ``i * n1 + j`` = ``[A0, A1, D0, D1]``.

    Built in place from differences (``d0a(i, j) = g10 - g00``, and ``g11 - g01`` is
    ``d0a(i, j+1)``), without temporaries; indices wrap (the wrapped last row or column
    of a non-periodic axis is never looked up)."""
    t = np.empty(values.shape + (4,))
    d0a, d1a, D0, D1 = (t[..., i] for i in range(4))
    _diff_wrapped(values, 0, d0a)             # g10 - g00
    _diff_wrapped(values, 1, d1a)             # g01 - g00
    _diff_wrapped(d0a, 1, D0)                 # (g11 - g01) - (g10 - g00)
    _diff_wrapped(d1a, 0, D1)                 # (g11 - g10) - (g01 - g00)
    nih0, nih1 = -1.0 / h[0], -1.0 / h[1]
    for col, nih in ((d0a, nih0), (d1a, nih1), (D0, nih0), (D1, nih1)):
        np.multiply(col, nih, out=col)
    return t.reshape(-1, 4)


def cross_table(values: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Per-cell Hessian cross term ``(g11 - g10 - g01 + g00) / (h0 h1)``, shape (n0 * n1,):
    the table's ``D0`` times ``-1 / h1``, computed the same way (without the rest of the table)."""
    d0a = np.empty(values.shape)
    _diff_wrapped(values, 0, d0a)
    out = np.empty(values.shape)
    _diff_wrapped(d0a, 1, out)
    np.multiply(out, -1.0 / h[0], out=out)
    np.multiply(out, -1.0 / h[1], out=out)
    return out.reshape(-1)


def table_grad_to_values(gtab: np.ndarray, h: np.ndarray, shape: tuple) -> np.ndarray:
    """Chain a gradient with respect to the table ``[A0, A1, D0, D1]`` (n0*n1, 4) (the
    layout of [`coefficient_table`][pes_ref.core.bilinear.coefficient_table]; overwritten) to the
    grid values; returns the flat (n0*n1,) gradient (the transpose of
    [`coefficient_table`][pes_ref.core.bilinear.coefficient_table], a 2x2 stencil per cell).

    Per cell, with ``a_d = -gA_d / h_d`` and ``d_d = -gD_d / h_d``, the corners receive
    ``g00: d0 + d1 - a0 - a1``, ``g10: a0 - d0 - d1``, ``g01: a1 - d0 - d1``, ``g11: d0 + d1``.
    """
    a0, a1, d0, d1 = (gtab[:, i].reshape(shape) for i in range(4))
    np.multiply(a0, -1.0 / h[0], out=a0)
    np.multiply(a1, -1.0 / h[1], out=a1)
    np.multiply(d0, -1.0 / h[0], out=d0)
    np.multiply(d1, -1.0 / h[1], out=d1)
    c11 = np.add(d0, d1, out=d0)                       # d0 + d1
    c10 = np.subtract(a0, c11, out=a0)                 # a0 - (d0 + d1)
    c01 = np.subtract(a1, c11, out=a1)                 # a1 - (d0 + d1)
    out = np.negative(c10)
    out -= c01
    out -= c11                                         # c00 = -c10 - c01 - c11
    out[1:] += c10[:-1]                                # node (i+1, j) of cell (i, j), wrapped
    out[:1] += c10[-1:]
    out[:, 1:] += c01[:, :-1]
    out[:, :1] += c01[:, -1:]
    c11 = np.roll(c11, 1, axis=0)
    out[:, 1:] += c11[:, :-1]
    out[:, :1] += c11[:, -1:]
    return out.reshape(-1)


# =========================================================================== one-off calls

def point_energy(values: np.ndarray, lower: np.ndarray, h: np.ndarray, periodic, x: np.ndarray) -> np.ndarray:
    """The bilinear grid energy at points x (N, 2), shape (N,) ([`grid_energy`][pes_ref.core.bilinear.grid_energy])."""
    return grid_energy(values, locate(x, lower, h, values.shape, periodic))


def point_slope(values: np.ndarray, lower: np.ndarray, h: np.ndarray, periodic, x: np.ndarray) -> np.ndarray:
    """The bilinear slope dE/dx at points x (N, 2), shape (N, 2) ([`grid_slope`][pes_ref.core.bilinear.grid_slope])."""
    return grid_slope(values, h, locate(x, lower, h, values.shape, periodic))


def point_force(values: np.ndarray, lower: np.ndarray, h: np.ndarray, periodic, x: np.ndarray,
                out: np.ndarray) -> np.ndarray:
    """Grid force ``-dE/dx`` at points x (N, 2) into ``out``, without a table (for one-off
    calls such as [`pes_ref.core.forces.force`][pes_ref.core.forces.force]); bit-identical to [`BilinearForce`][pes_ref.core.bilinear.BilinearForce]."""
    c = locate(x, lower, h, values.shape, periodic)
    coef = _coefficients(values[c.i0, c.j0], values[c.i1, c.j0], values[c.i0, c.j1], values[c.i1, c.j1],
                         h, np.empty(x.shape[:1] + (4,)))
    np.multiply(coef[:, 2], c.f1, out=out[:, 0])
    np.multiply(coef[:, 3], c.f0, out=out[:, 1])
    out += coef[:, :2]
    out[:, 0] *= c.s0
    out[:, 1] *= c.s1
    return out


def point_force_vjp(values: np.ndarray, lower: np.ndarray, h: np.ndarray, periodic, x: np.ndarray,
                    w: np.ndarray, xbar: np.ndarray, gvalues) -> None:
    """Adjoint of [`point_force`][pes_ref.core.bilinear.point_force] at x for the cotangent ``w``: ``xbar -= H w`` and,
    if
    ``gvalues`` (flat n0*n1) is given, ``gvalues -= (d slope/dG)^T w`` (eqs. (A2)-(A3))."""
    cells = locate(x, lower, h, values.shape, periodic)
    xbar -= grid_slope_vjp_q(values, h, cells, w)
    if gvalues is not None:
        gvalues -= grid_slope_vjp_values(h, cells, w, values.shape[1], values.size)


# =========================================================================== the hot loop

class BilinearForce:
    """The grid force for N particles at a time, with its table and buffers (the forward
    hot loop; a [`GridForce`][pes_ref.core.kernels.GridForce]).

    ``call(x, out)``, bound once here: the [`Locator`][pes_ref.core.grid.Locator] operations,
    one ``take`` of the (N, 4) coefficient rows, ``F0 = A0 + f1 D0`` and ``F1 = A1 + f0 D1``
    on columns and ``out = F s`` (a copy on a torus): 16 NumPy calls on a plane. Nothing is
    allocated. (Columns, not (N, 2) arrays with a swapped view: NumPy runs an operation on
    reversed or non-contiguous (N, 2) views with an inner loop of length 2, several times
    slower.)
    """

    def __init__(self, field, n_particles: int):
        self.locator = Locator(field.lower, field.h, field.values.shape[-2:], field.periodic)
        self.table = stacked_table(lambda v: coefficient_table(v, field.h), field.values)
        self.offsets = field.offsets
        self.buf = self.locator.buffers((n_particles,))
        self.coef = np.empty((n_particles, 4))
        self.call = self._bind()

    def _bind(self):
        """The call as a closure over its buffers (no attribute lookups per step). The
        force is built in a buffer of its own (whose column views are made once) and
        written to ``out`` by the switches' multiplication (a copy on a torus). In a
        population each particle's grid offset is added to the cell it is in (one call)."""
        locate_into = self.locator.bind(self.buf)
        take, cell, coef, offsets = self.table.take, self.buf["cell"], self.coef, self.offsets
        A0, A1, D0, D1 = (coef[:, i] for i in range(4))
        f0, f1 = self.buf["f"][:, 0], self.buf["f"][:, 1]
        mul, add, copyto = np.multiply, np.add, np.copyto
        inside = self.buf["inside"] if self.locator.clips else None
        F = np.empty(coef.shape[:1] + (2,))
        F0, F1 = F[:, 0], F[:, 1]

        def call(x, out):
            locate_into(x)
            if offsets is not None:
                add(cell, offsets, cell)
            take(cell, 0, coef, "clip")
            mul(D0, f1, F0)
            add(F0, A0, F0)
            mul(D1, f0, F1)
            add(F1, A1, F1)
            if inside is None:
                copyto(out, F)
            else:
                mul(F, inside, out)
            return out
        return call


class BilinearForce1:
    """[`BilinearForce`][pes_ref.core.bilinear.BilinearForce] for one particle, in Python floats.

    At N = 1 each NumPy call costs about a microsecond whatever it computes, and the
    vectorized lookup takes ~16 of them; the same operations on Python floats
    ([`bind_scalar`][pes_ref.core.grid.Locator.bind_scalar], then the table row) take a few
    microseconds and give bit-identical forces. A non-finite position gives a NaN force.
    """

    def __init__(self, field, n_particles: int = 1):
        self.locator = Locator(field.lower, field.h, field.values.shape, field.periodic)
        self.table = coefficient_table(field.values, field.h)
        self.call = self._bind()

    def _bind(self):
        locate1, rows, nan = self.locator.bind_scalar(), self.table, math.nan

        def call(x, out):
            loc = locate1(x)
            if loc is None:
                out.fill(nan)
                return out
            cell, fr0, fr1, s0, s1 = loc
            a0, a1, d0, d1 = rows[cell].tolist()
            out[0, 0] = (d0 * fr1 + a0) * s0
            out[0, 1] = (d1 * fr0 + a1) * s1
            return out
        return call


class BilinearAdjoint:
    """The adjoint of [`BilinearForce`][pes_ref.core.bilinear.BilinearForce] over a stored trajectory (eqs. (A2)-(A3); a
    [`GridAdjoint`][pes_ref.core.kernels.GridAdjoint]).

    Call ``vjp(n, w, xbar)`` (bound once here) for states in descending order (as a
    backward pass does): ``xbar += (dF/dx)^T w = -H(x_n) w``, and ``w`` is recorded for the
    grid gradient, returned by [`values_grad`][pes_ref.core.bilinear.BilinearAdjoint.values_grad]. States
    are located a chunk at a time (``CHUNK_ELEMENTS // N`` states at once), with the
    cross term ``Hc s0 s1`` gathered for the whole chunk; per state only
    ``xbar -= Hc s0 s1 (w1, w0)`` remains, plus a copy of ``w`` when the grid gradient
    is wanted. At the end of a chunk the grid gradient is scattered per table column
    over the chunk's cells (`_flush`).
    """

    def __init__(self, field, xs: np.ndarray, want_values: bool):
        self.field, self.xs = field, xs
        n_states, n = xs.shape[0], xs.shape[1]
        loc = self.locator = Locator(field.lower, field.h, field.values.shape, field.periodic)
        self.cross = cross_table(field.values, field.h)
        self.chunk = B = max(1, min(n_states, CHUNK_ELEMENTS // max(n, 1)))
        self.sub = max(1, min(B, LOOKUP_ELEMENTS // max(n, 1)))
        self.want_values = want_values
        # allocated once: a fresh large array per chunk would cost its page faults
        self.temps = loc.buffers((self.sub, n))
        self.cell = np.empty((B, n), dtype=np.intp)
        self.f = np.empty((B, n, 2))
        self.inside = np.empty((B, n, 2)) if loc.clips else None
        self.hcs_buf = np.empty((B, n))
        self.gtab = self.w = self.wts = self.idx = None
        if want_values:
            self.gtab = np.zeros((loc.size, 4))
            self.w = np.empty((B, n, 2))
            self.wts = np.empty((4, B * n))
            self.idx = np.empty(B * n, dtype=np.intp)
        self.tmp = np.empty(n)
        self.lo = n_states            # states [lo, hi) are located
        self.hi = n_states
        self.located = None
        self.hcs = self.hcs_buf[:0]
        self._chunk = [self.lo, self.hcs]   # lo and hcs, as vjp reads them
        self.vjp = self._bind()

    def _load(self, n: int) -> None:
        """Locate the chunk of states ending at ``n``, ``sub`` states per lookup (the
        lookup's temporaries stay in cache), into the chunk's cells, fractions, switches
        and cross terms ``Hc s0 s1``."""
        self._flush()
        self.hi = n + 1
        self.lo = max(0, self.hi - self.chunk)
        m = self.hi - self.lo
        for r0 in range(0, m, self.sub):
            r1 = min(m, r0 + self.sub)
            tb = self.temps if r1 - r0 == self.sub else self.locator.head(self.temps, r1 - r0)
            tb = dict(tb, cell=self.cell[r0:r1], f=self.f[r0:r1],
                      inside=None if self.inside is None else self.inside[r0:r1])
            c = self.locator.locate(self.xs[self.lo + r0:self.lo + r1], tb)
            hcs = self.cross.take(c.cell, mode="clip", out=self.hcs_buf[r0:r1])
            if c.inside is not None:
                np.multiply(hcs, c.inside[..., 0], out=hcs)
                np.multiply(hcs, c.inside[..., 1], out=hcs)
        self.hcs = self.hcs_buf[:m]
        self._chunk[:] = self.lo, self.hcs
        self.located = Located(self.cell[:m], self.f[:m], None if self.inside is None else self.inside[:m])

    def _flush(self) -> None:
        """Scatter the gradient of the located chunk into the table's gradient, per table
        column (weights ``s0 w0, s1 w1, s0 w0 f1, s1 w1 f0``): ``np.add.at``, which costs
        nothing per grid node, or ``np.bincount`` once a chunk holds more elements than
        the grid has nodes (then its grid-sized output is amortized)."""
        if self.located is None or not self.want_values:
            return
        c, m = self.located, self.hi - self.lo
        n_el = m * self.xs.shape[1]
        w = self.w[:m].reshape(n_el, 2)
        wa0, wa1, wd0, wd1 = self.wts[:, :n_el]
        f = c.f.reshape(n_el, 2)
        if c.inside is not None:
            ins = c.inside.reshape(n_el, 2)
            np.multiply(w[:, 0], ins[:, 0], out=wa0)
            np.multiply(w[:, 1], ins[:, 1], out=wa1)
        else:
            wa0[...], wa1[...] = w[:, 0], w[:, 1]
        np.multiply(wa0, f[:, 1], out=wd0)
        np.multiply(wa1, f[:, 0], out=wd1)
        cell = c.cell.reshape(n_el)
        size = self.locator.size
        if n_el >= size:
            for col in range(4):
                self.gtab[:, col] += np.bincount(cell, weights=self.wts[col, :n_el], minlength=size)
        else:
            # gtab rows are cells, so a particle's four updates share a cache line
            idx = np.multiply(cell, 4, out=self.idx[:n_el])
            flat = self.gtab.reshape(-1)
            for col in range(4):
                np.add.at(flat[col:], idx, self.wts[col, :n_el])
        self.located = None

    def _bind(self):
        """``vjp`` as a closure (bound once; no attribute lookups per step). The column
        views of ``w`` and ``xbar`` are kept while the caller passes the same buffers, as a
        backward pass does. The closure holds its object by a weak reference (it loads a new
        chunk through it): no reference cycle keeps the grid-sized tables alive after a
        backward pass, until the cyclic collector happens to run."""
        mul, sub, copyto = np.multiply, np.subtract, np.copyto
        tmp, wbuf, want_values, chunk = self.tmp, self.w, self.want_values, self._chunk
        owner = weakref.ref(self)
        views = [None, None, None, None, None, None]     # w, w0, w1, xbar, x0, x1

        def vjp(n, w, xbar):
            if n < chunk[0]:
                owner()._load(n)
            b = n - chunk[0]
            if want_values:
                copyto(wbuf[b], w)
            if w is not views[0]:
                views[0:3] = w, w[:, 0], w[:, 1]
            if xbar is not views[3]:
                views[3:6] = xbar, xbar[:, 0], xbar[:, 1]
            _, w0, w1, _, x0, x1 = views
            hcs = chunk[1][b]
            mul(hcs, w1, tmp)
            sub(x0, tmp, x0)
            mul(hcs, w0, tmp)
            sub(x1, tmp, x1)
        return vjp

    def values_grad(self) -> np.ndarray | None:
        """The accumulated ``sum_n (dF(x_n)/dG)^T w_n``, flat (n0*n1,), or None if not wanted."""
        if not self.want_values:
            return None
        self._flush()
        return table_grad_to_values(self.gtab, self.field.h, self.field.values.shape)


def forward_kernel(field, n_particles: int):
    """The forward grid force for ``n_particles`` (a [`GridForce`][pes_ref.core.kernels.GridForce]):
    [`BilinearForce1`][pes_ref.core.bilinear.BilinearForce1] for one particle on one grid, else
    [`BilinearForce`][pes_ref.core.bilinear.BilinearForce]
    (bit-identical)."""
    return (BilinearForce1 if n_particles == 1 and field.offsets is None else BilinearForce)(field, n_particles)
