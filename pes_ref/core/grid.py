"""The grid lookup: which cell a point is in, where inside it, and whether it is in range.

docs/spec.md section 2.3, 'Lookup: cell, fraction, switch'. A grid of shape (n0, n1) spans ``lower`` to
``upper`` on a plane, a cylinder (one axis periodic) or a torus (both periodic); axis 0
is coordinate q0, axis 1 is q1. The node spacing ``h_d`` is ``L_d / n_d`` on a periodic
axis (node ``n_d`` is node 0 again) and ``L_d / (n_d - 1)`` on a non-periodic one (the last
node sits on ``upper_d``), with ``L_d = upper_d - lower_d``.

Per axis, with ``u = (q - lower) / h``:

- periodic: ``k = floor(u)``, ``f = u - k``, node ``i0 = k mod n``, ``i1 = i0 + 1`` wrapped,
  switch ``s = 1``;
- non-periodic: ``uc = clip(u, 0, n - 1)``, ``i0 = min(floor(uc), n - 2)``, ``f = uc - i0``,
  ``i1 = i0 + 1``, switch ``s = 1`` if ``0 <= u <= n - 1`` else 0 (outside the span the
  surface is extended as a constant along that axis, so its slope there is zero).

State positions are never wrapped; only the lookup wraps ([`wrap`][pes_ref.core.grid.wrap] is for display).

There is one implementation of this arithmetic, [`Locator.bind`][pes_ref.core.grid.Locator.bind]
(both axes at once, into reusable buffers: the hot loop's lookup);
[`Locator.locate`][pes_ref.core.grid.Locator.locate] and [`locate`][pes_ref.core.grid.locate] are
views of its result, and [`Locator.bind_scalar`][pes_ref.core.grid.Locator.bind_scalar] is the same
operations on Python floats for a single particle. The functions here trust their inputs.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

__all__ = ["Cells", "Located", "Locator", "spacing", "locate", "wrap", "clip", "stacked_table"]

try:   # the clip ufunc itself: one pass for both bounds, without np.clip's Python wrapper
    from numpy._core.umath import clip
except ImportError:  # NumPy < 2
    from numpy.core.umath import clip

_MINUS_INF = np.array(-np.inf)


class Cells(NamedTuple):
    """Where N points fall on the grid, per axis (docs/spec.md section 2.3).

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


class Located(NamedTuple):
    """Cells of points of shape (..., 2) as the hot loop uses them (see [`Locator`][pes_ref.core.grid.Locator]).

    ``cell`` (...,) intp is the flat index ``i0 * n1 + j0`` of the cell's lower corner;
    ``f`` (..., 2) the fractions (f0, f1); ``inside`` (..., 2) the switches s0, s1 as
    0.0 / 1.0 (a float mask multiplies ~2x faster than a bool one), or None on a torus
    (all ones there).
    """

    cell: np.ndarray
    f: np.ndarray
    inside: np.ndarray | None


def spacing(lower: np.ndarray, upper: np.ndarray, shape: tuple, periodic: np.ndarray) -> np.ndarray:
    """Node spacing per axis, shape (2,).

    ``h_d = L_d / n_d`` if axis d is periodic else ``L_d / (n_d - 1)``.
    """
    n = np.asarray(shape, dtype=np.float64)
    return (upper - lower) / np.where(periodic, n, n - 1.0)


def _per_axis(c: np.ndarray, lead: tuple):
    """A per-axis constant (2,) as an operand for (..., 2) arrays: a 0-d array when both
    axes agree, else tiled to ``lead + (2,)``. (NumPy broadcasts a (2,) operand with an
    inner loop of length 2, several times slower than a scalar or a same-shaped array;
    and a 0-d array skips the conversion a Python float costs on every call.)"""
    if c[0] == c[1]:
        return np.array(c[0], dtype=np.float64)
    return np.ascontiguousarray(np.broadcast_to(c, tuple(lead) + (2,)))


class Locator:
    """The lookup of docs/spec.md section 2.3 for both axes at once, into flat cell indices, with
    reusable buffers.

    Written as a few whole-array operations on (..., 2) arrays: ``u = (q - lower) / h``;
    ``uc = clip(u, lo_d, hi_d)`` with ``(0, n_d - 1)`` on a non-periodic axis and ``(-inf,
    inf)`` (a no-op) on a periodic one; ``k = min(floor(uc), kmax_d)`` with ``kmax_d = n_d -
    2`` or ``inf``; ``f = uc - k``; ``i = k - n_d floor(k / n_d)`` (``k mod n_d``, exact for
    the integers ``|k| < 2**52``; the identity on a non-periodic axis, where ``0 <= k <=
    n_d - 2``); ``cell = i0 n1 + i1``; ``s = (u == uc)``. Operations that are no-ops for the
    topology are skipped: a torus never clips, a plane never wraps.

    A non-finite position gives a garbage cell index; callers gather with
    ``mode="clip"`` so that it never fails, and check the finiteness of the trajectory
    afterwards (the force there is NaN anyway).

    Parameters
    ----------
    lower, h : array_like, shape (2,)
        Lower corner and node spacing ([`spacing`][pes_ref.core.grid.spacing]).
    shape : (n0, n1)
        Grid shape.
    periodic : sequence of 2 bool
    """

    def __init__(self, lower, h, shape: tuple, periodic):
        per = np.array([bool(p) for p in periodic])
        n = np.asarray(shape, dtype=np.float64)
        self.shape = tuple(int(m) for m in shape)
        self.size = self.shape[0] * self.shape[1]
        self.periodic = tuple(bool(p) for p in per)
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
        """The first ``m`` rows (along the leading axis) of buffers from [`buffers`][pes_ref.core.grid.Locator.buffers]."""
        out = {name: (a[:m] if isinstance(a, np.ndarray) and a.ndim else a) for name, a in buf.items()}
        out["k0"], out["k1"] = out["k"][..., 0], out["k"][..., 1]
        return out

    def bind(self, buf: dict):
        """``locate_into(x)``: the lookup of points ``x`` (``lead + (2,)``) into the buffers
        ``buf`` (from [`buffers`][pes_ref.core.grid.Locator.buffers]), read from ``buf["cell"]``, ``buf["f"]`` and
        ``buf["inside"]``; for a hot loop that calls it every step.

        The buffers, constants and ufuncs are closure locals (no dict lookup or attribute
        access per call), the ufuncs get their output positionally, and ``k0 n1 + k1`` is
        added straight into the integer cell index (one call instead of an addition and a
        cast copy). Nothing is allocated."""
        sub, div, mul, add, eq, floor = np.subtract, np.divide, np.multiply, np.add, np.equal, np.floor
        clip_, minus_inf, n1 = clip, _MINUS_INF, self.n1
        u, k, f, cellf, cell = buf["u"], buf["k"], buf["f"], buf["cellf"], buf["cell"]
        k0, k1, lower, h = buf["k0"], buf["k1"], buf["lower"], buf["h"]
        clips, wraps = self.clips, self.wraps
        uc = buf["uc"] if clips else u
        inside, lo, hi, kmax = (buf["inside"], buf["clip_lo"], buf["clip_hi"], buf["kmax"]) if clips else (None,) * 4
        q, n = (buf["q"], buf["n"]) if wraps else (None, None)

        def locate_into(x):
            sub(x, lower, u)
            div(u, h, u)
            if clips:
                clip_(u, lo, hi, uc)
                eq(u, uc, inside)
                floor(uc, k)
                clip_(k, minus_inf, kmax, k)
            else:
                floor(u, k)
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
        """Locate points ``x`` (..., 2) by [`bind`][pes_ref.core.grid.Locator.bind]; ``buf`` from
        [`buffers`][pes_ref.core.grid.Locator.buffers]
        (allocated if None). For one-off calls: a hot loop binds once."""
        if buf is None:
            buf = self.buffers(x.shape[:-1])
        self.bind(buf)(x)
        return Located(buf["cell"], buf["f"], buf["inside"] if self.clips else None)

    def cells(self, x: np.ndarray) -> Cells:
        """Locate points ``x`` (N, 2) as per-axis [`Cells`][pes_ref.core.grid.Cells] (the form of the
        textbook functions): the nodes ``i0, j0`` are [`locate`][pes_ref.core.grid.locate]'s ``k``, ``i1, j1`` the
        next nodes (wrapped on a periodic axis)."""
        buf = self.buffers(x.shape[:-1])
        loc = self.locate(x, buf)
        nodes = []
        for d in range(2):
            i0 = buf["k"][..., d].astype(np.intp)
            i1 = i0 + 1
            if self.periodic[d]:
                i1[i1 == self.shape[d]] = 0
            nodes += [i0, i1]
        s = (loc.inside[..., 0], loc.inside[..., 1]) if loc.inside is not None else (np.ones(x.shape[:-1]),) * 2
        return Cells(*nodes, loc.f[..., 0], loc.f[..., 1], *s)

    def bind_scalar(self):
        """``locate1(x) -> (cell, f0, f1, s0, s1)`` for a single point ``x`` (1, 2), in
        Python floats (``cell`` an int), or None when ``x`` is not finite.

        The operations of [`bind`][pes_ref.core.grid.Locator.bind] in the same order on Python floats (IEEE double,
        correctly rounded like NumPy's), so the cells, fractions and switches are
        bit-identical: at N = 1 each NumPy call costs about a microsecond whatever it
        computes, and this takes a few for the whole lookup."""
        c = self.consts
        (lower0, h0, lo0, hi0, kmax0, n0), (lower1, h1, lo1, hi1, kmax1, n1) = (
            tuple(float(c[name][d]) for name in ("lower", "h", "clip_lo", "clip_hi", "kmax", "n")) for d in range(2))
        clips, wraps, nn1 = self.clips, self.wraps, float(self.n1)
        floor, isfinite = math.floor, math.isfinite

        def locate1(x):       # the two axes written out: no per-axis loop or lists
            u0 = (x.item(0) - lower0) / h0
            u1 = (x.item(1) - lower1) / h1
            if not (isfinite(u0) and isfinite(u1)):
                return None
            uc0, uc1, s0, s1 = u0, u1, 1.0, 1.0
            if clips:
                uc0 = lo0 if u0 < lo0 else (hi0 if u0 > hi0 else u0)
                uc1 = lo1 if u1 < lo1 else (hi1 if u1 > hi1 else u1)
                s0 = 1.0 if u0 == uc0 else 0.0
                s1 = 1.0 if u1 == uc1 else 0.0
            k0, k1 = float(floor(uc0)), float(floor(uc1))
            if clips:
                k0 = kmax0 if k0 > kmax0 else k0
                k1 = kmax1 if k1 > kmax1 else k1
            f0, f1 = uc0 - k0, uc1 - k1
            if wraps:           # k mod n exactly (Python's floored %), as bind's formula is for |k| < 2**52
                k0 = k0 % n0
                k1 = k1 % n1
            return int(k0 * nn1 + k1), f0, f1, s0, s1
        return locate1


def stacked_table(table, values: np.ndarray) -> np.ndarray:
    """A per-cell table of a grid (n0, n1), or of a stack of grids (K, n0, n1) one after
    another: ``table(values)`` of each grid (rows ``i * n1 + j``), concatenated, so that
    grid ``c``'s cells are the rows ``c n0 n1 + i n1 + j`` (a population's tables: each
    particle's lookup adds its grid's offset ``c n0 n1`` to the cell it finds)."""
    if values.ndim == 2:
        return table(values)
    return np.concatenate([table(v) for v in values])


def locate(q: np.ndarray, lower: np.ndarray, h: np.ndarray, shape: tuple, periodic) -> Cells:
    """Locate N points on the grid, per axis.

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
    return Locator(lower, h, shape, periodic).cells(q)


def wrap(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, periodic) -> np.ndarray:
    """Positions with periodic axes wrapped into [lower, upper), for display only."""
    q = np.array(q, dtype=np.float64, copy=True)
    for d in range(2):
        if periodic[d]:
            L = upper[d] - lower[d]
            q[..., d] = lower[d] + np.mod(q[..., d] - lower[d], L)
    return q
