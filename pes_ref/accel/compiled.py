"""Compiled loops: the paper's dynamic step, the quasistatic step and their adjoints as numba
kernels (the backend ``"numba"`` of `pes_ref.core.backends.BACKENDS`; the optional
extra ``fast``).

They are an optimization of [`pes_ref.core.integrator`][pes_ref.core.integrator] (and, through it, of
[`pes_ref.core.reference`][pes_ref.core.reference]): the same sub-steps, (S1)-(S4) and (B1)-(B4), (Q1)-(Q2) and
(QB1)-(QB2) of ``docs/adjoint.md``, written per particle instead of per array. Every
floating-point operation of the NumPy path is done here in the same order on the same
operands (IEEE double, no fused multiply-add: numba's default ``fastmath=False``), so:

- the forward trajectory ``x, v, f`` is bit-identical to the NumPy path's, on the bilinear
  grid (the same per-cell coefficients,
  [`pes_ref.core.bilinear.coefficient_table`][pes_ref.core.bilinear.coefficient_table]'s: a
  population's loops and the quasistatic ones read the table, one grid's dynamic loops
  compute a cell's row from the values as they step, `_cell_coefficients`), springs
  (the minimum image by ``fmod`` as NumPy's ``np.mod`` computes it), walls, damping and the
  external force;
- every gradient but two is bit-identical too; the grid gradient is accumulated per state
  into the coefficient table's gradient (NumPy's path scatters a chunk of states at a time)
  and the mobility's is summed particle by particle (NumPy's by ``einsum``): the same sums
  in another order, within 1e-13 of their largest entry (``tests/accel/test_compiled.py``).

From `PARALLEL_MIN` particles on, the dynamic loops and [`energy`][pes_ref.accel.compiled.energy] run their
particles in blocks of `BLOCK` on [`threads`][pes_ref.accel.compiled.threads] threads (numba's thread count):
each thread calls the one compiled loop (`KERNELS`, compiled ``nogil``: it runs without
Python's lock) on its share, a run of consecutive blocks (`_spread`; the calling thread
takes the first share, a pool's threads the others). Each particle's operations are the
same in the same order on any thread, so its numbers are its own run's, bit for bit; the
grid gradient, a sum over particles, is accumulated in `LANES` lanes of consecutive blocks,
each into its own table gradient, added in lane order (an adjoint's shares are runs of
lanes): the partition is fixed by N, so no number depends on the thread count. The loops are
not compiled a second time for numba's own threads (``prange``): that compilation took
~23 s of CPU per loop pair, and the shares run no slower (docs/performance.md).

A small dynamic run (`LOOKUP_STATES`) keeps each state's grid lookup, which its adjoint
reads where the state's position is still the one looked up (`_lookups`): the lookup's
divisions and floors, most of an adjoint step's time, are then done once.

A population ([`pes_ref.core.population`][pes_ref.core.population]) runs with the grid offset of each particle
added to its cell (``Field.offsets``). The bicubic grid and the GJF step are not compiled:
[`pes_ref.core.backends.stepper`][pes_ref.core.backends.stepper] runs them on NumPy.

The kernels take every array C-contiguous float64 of a fixed dimension (absent terms as placeholders
with a flag), so each compiles once; numba caches the machine code on disk (``cache=True``: beside
this file in ``__pycache__``, or in numba's user cache directory when the package is installed
read-only, or in ``NUMBA_CACHE_DIR``). A run without a progress callback is one call; with one, a
call per `pes_ref.core.runtime.progress.EVERY` steps
([`pes_ref.core.runtime.progress.blocks`][pes_ref.core.runtime.progress.blocks]), so Ctrl-C and
progress lines come between them.
"""
from __future__ import annotations


import os
import weakref
from concurrent.futures import ThreadPoolExecutor, wait
from types import SimpleNamespace

import numpy as np
from numba import config as numba_config, get_num_threads, njit

from pes_ref.core import budget
from pes_ref.core.integrator import (Trajectory, check_finite, finish_dynamic_adjoint, finish_quasistatic_adjoint,
                                     quasistatic_velocities, reports_nonfinite, step_coefficients, trajectory_arrays)
from pes_ref.core.runtime import pages
from pes_ref.core.runtime.progress import blocks as step_blocks
from pes_ref.core.steppers import STEPPERS as NUMPY_STEPPERS, Stepper, StepParams
from pes_ref.core.terms import spring_axes

__all__ = ["STEPPERS", "simulate_dynamic", "adjoint_dynamic", "simulate_quasistatic", "adjoint_quasistatic"]

#: ``error_model="numpy"``: a division by zero gives inf or NaN as in NumPy, not an exception.
#: No reference counting (``_nrt=False``): the kernels allocate nothing, and a helper call
#: passes its arrays without an increment and decrement each. The per-particle helpers are
#: compiled functions of their own that LLVM inlines into the loops; numba's own inlining
#: (``inline="always"``) gave the same step times for more than twice the compile time.
_JIT = dict(cache=True, nogil=True, error_model="numpy", _nrt=False)


# =========================================================================== the force of one particle

@njit(**_JIT)
def _clip(u, lo, hi):
    """NumPy's ``clip`` ufunc on floats: ``min(max(u, lo), hi)``, NaN kept."""
    m = u if (u != u or u > lo) else lo
    return m if (m != m or m < hi) else hi


@njit(**_JIT)
def _mod(a, length):
    """NumPy's ``np.mod`` of floats for ``length > 0`` (``fmod``, then the sign of the divisor)."""
    m = np.fmod(a, length)
    if m != 0.0:
        if m < 0.0:
            m += length
    else:
        m = 0.0
    return m


@njit(**_JIT)
def _locate(q0, q1, g, per0, per1, clips):
    """The lookup of [`pes_ref.core.grid.Locator.bind`][pes_ref.core.grid.Locator.bind] for one point, both axes:
    ``(cell, f0, f1, s0, s1)`` (`_locate_ij` without the cell's row and column)."""
    cell, _, _, f0, f1, s0, s1 = _locate_ij(q0, q1, g, per0, per1, clips)
    return cell, f0, f1, s0, s1


@njit(**_JIT)
def _locate_ij(q0, q1, g, per0, per1, clips):
    """The lookup of [`pes_ref.core.grid.Locator.bind`][pes_ref.core.grid.Locator.bind] for one point, both axes:
    ``(cell, i0, j0, f0, f1, s0, s1)``, ``cell = i0 n1 + j0``. ``g`` holds ``lower0, lower1,
    h0, h1, n0 - 1, n1 - 1, n0 - 2, n1 - 2, n0, n1``. A periodic axis is neither clipped nor
    switched (a no-op there), a non-periodic one never wrapped (idem); a non-finite point
    gets cell 0 (row and column 0). (Within the grid ``0 <= k_d < n_d`` on each axis, as
    ``n_d >= 2``: so the row and column are ``cell // n1`` and ``cell % n1``, without the
    division.)"""
    u0 = (q0 - g[0]) / g[2]
    u1 = (q1 - g[1]) / g[3]
    s0 = 1.0
    s1 = 1.0
    uc0 = u0
    uc1 = u1
    if clips:
        if not per0:
            uc0 = _clip(u0, 0.0, g[4])
            s0 = 1.0 if u0 == uc0 else 0.0
        if not per1:
            uc1 = _clip(u1, 0.0, g[5])
            s1 = 1.0 if u1 == uc1 else 0.0
    k0 = np.floor(uc0)
    k1 = np.floor(uc1)
    if clips:
        if not per0:
            k0 = _clip(k0, -np.inf, g[6])
        if not per1:
            k1 = _clip(k1, -np.inf, g[7])
    f0 = uc0 - k0
    f1 = uc1 - k1
    if per0:
        k0 = k0 - np.floor(k0 / g[8]) * g[8]
    if per1:
        k1 = k1 - np.floor(k1 / g[9]) * g[9]
    cf = k0 * g[9] + k1
    if cf >= 0.0 and cf < g[8] * g[9]:
        return int(cf), int(k0), int(k1), f0, f1, s0, s1
    return 0, 0, 0, f0, f1, s0, s1


@njit(**_JIT)
def _spring_d(q0, q1, i, sc, wraps, swrap0, swrap1, shalf, slen):
    """Particle ``i``'s spring displacement ``q - center`` (the minimum image on a wrapped axis)."""
    d0 = q0 - sc[i, 0]
    d1 = q1 - sc[i, 1]
    if wraps:
        if swrap0:
            d0 = _mod(d0 + shalf[0], slen[0]) - shalf[0]
        if swrap1:
            d1 = _mod(d1 + shalf[1], slen[1]) - shalf[1]
    return d0, d1


@njit(**_JIT)
def _force(q0, q1, i, g, per0, per1, clips, table, offsets, son, sk, sc, wraps, swrap0, swrap1, shalf, slen,
           won, wk, wlo, whi):
    """``F(q)`` of particle ``i`` (N, 2 row): the grid's ``(A + f D) s`` from its table row,
    then ``-k delta`` of the spring, then the walls' ``k (clip(q, a, b) - q)``: the
    operations of [`ForceKernel`][pes_ref.core.forces.ForceKernel] in its order. (The arguments are
    the unpacked tuples of `_grid`, `_spring` and `_walls`: a kernel
    unpacks them once, outside its loops; ``wraps`` is its compile-time constant.)"""
    cell, f0, f1, s0, s1 = _locate(q0, q1, g, per0, per1, clips)
    return _force_at(q0, q1, i, cell, f0, f1, s0, s1, table, offsets, son, sk, sc, wraps, swrap0, swrap1, shalf,
                     slen, won, wk, wlo, whi)


@njit(**_JIT)
def _row(cell, i, offsets, rows):
    """Particle ``i``'s table row: its ``cell`` plus its grid's offset, at most the last row;
    unsigned (both are >= 0), so that numba indexes with it without its negative-index test."""
    row = cell + offsets[i]
    if row >= rows:
        row = rows - 1
    return np.uint64(row)


@njit(**_JIT)
def _force_at(q0, q1, i, cell, f0, f1, s0, s1, table, offsets, son, sk, sc, wraps, swrap0, swrap1, shalf, slen,
              won, wk, wlo, whi):
    """`_force` at the cell and fractions that `_locate` gave for ``(q0, q1)``."""
    row = _row(cell, i, offsets, table.shape[0])
    F0 = (table[row, 2] * f1 + table[row, 0]) * s0
    F1 = (table[row, 3] * f0 + table[row, 1]) * s1
    return _terms_force(q0, q1, i, F0, F1, son, sk, sc, wraps, swrap0, swrap1, shalf, slen, won, wk, wlo, whi)


@njit(**_JIT)
def _cell_nodes(values, i0, j0):
    """Cell ``(i0, j0)``'s nodes ``(i, j, ip, jp)``, the next ones wrapped, unsigned (as `_row`)."""
    ip = i0 + 1
    if ip == values.shape[0]:
        ip = 0
    jp = j0 + 1
    if jp == values.shape[1]:
        jp = 0
    return np.uint64(i0), np.uint64(j0), np.uint64(ip), np.uint64(jp)


@njit(**_JIT)
def _cell_coefficients(values, i0, j0, nih0, nih1):
    """Cell ``(i0, j0)``'s row ``(A0, A1, D0, D1)`` of `_coefficient_table`, from the
    grid's values: the same differences of the same nodes (the next ones wrapped), scaled
    by ``-1/h`` in the same order, so the same numbers bit for bit."""
    i, j, ip, jp = _cell_nodes(values, i0, j0)
    d0a = values[ip, j] - values[i, j]
    d1a = values[i, jp] - values[i, j]
    return (d0a * nih0, d1a * nih1, ((values[ip, jp] - values[i, jp]) - d0a) * nih0,
            ((values[ip, jp] - values[ip, j]) - d1a) * nih1)


@njit(**_JIT)
def _cell_d0(values, i0, j0, nih0):
    """Cell ``(i0, j0)``'s ``D0`` of `_cell_coefficients` alone (the cross term's)."""
    i, j, ip, jp = _cell_nodes(values, i0, j0)
    return ((values[ip, jp] - values[i, jp]) - (values[ip, j] - values[i, j])) * nih0


@njit(**_JIT)
def _terms_force(q0, q1, i, F0, F1, son, sk, sc, wraps, swrap0, swrap1, shalf, slen, won, wk, wlo, whi):
    """The grid's force ``(F0, F1)`` of particle ``i`` at ``(q0, q1)`` plus the spring's
    ``-k delta`` and the walls' ``k (clip(q, a, b) - q)``, in that order."""
    if son:
        d0, d1 = _spring_d(q0, q1, i, sc, wraps, swrap0, swrap1, shalf, slen)
        F0 = F0 - sk[i, 0] * d0
        F1 = F1 - sk[i, 1] * d1
    if won:
        F0 = F0 + (_clip(q0, wlo[i, 0], whi[i, 0]) - q0) * wk[i, 0]
        F1 = F1 + (_clip(q1, wlo[i, 1], whi[i, 1]) - q1) * wk[i, 1]
    return F0, F1


@njit(**_JIT)
def _vjp(q0, q1, i, w0, w1, xb0, xb1, g, per0, per1, clips, table, nih1, offsets, gtab, want_values,
         son, sk, sc, wraps, swrap0, swrap1, shalf, slen, want_k, gk, want_c, gc, walls):
    """(A6) at particle ``i``'s position for the cotangent ``w``: returns ``xbar + (dF/dx)^T w``
    (the grid's ``-Hc s0 s1 (w1, w0)``, the spring's ``-k w``, the walls' ``-k w`` where active, in
    [`ForceAdjoint`][pes_ref.core.forces.ForceAdjoint]'s order) and accumulates the grid's table
    gradient and the spring's, as wanted. The cross term ``Hc`` of a cell is its coefficient table's
    ``D0`` times ``nih1 = -1/h1``: the operations of
    [`pes_ref.core.bilinear.cross_table`][pes_ref.core.bilinear.cross_table] in its order, so the
    same number bit for bit (the forward's table serves the adjoint; no cross table is built)."""
    cell, f0, f1, s0, s1 = _locate(q0, q1, g, per0, per1, clips)
    row = _row(cell, i, offsets, table.shape[0])
    return _vjp_at(q0, q1, i, row, f0, f1, s0, s1, w0, w1, xb0, xb1, clips, table[row, 2], nih1, gtab, want_values,
                   son, sk, sc, wraps, swrap0, swrap1, shalf, slen, want_k, gk, want_c, (gc, walls))


@njit(**_JIT)
def _vjp_at(q0, q1, i, row, f0, f1, s0, s1, w0, w1, xb0, xb1, clips, d0, nih1, gtab, want_values,
            son, sk, sc, wraps, swrap0, swrap1, shalf, slen, want_k, gk, want_c, rest):
    """`_vjp` at the table row (`_row`), fractions and switches that `_locate`
    gave for ``(q0, q1)``, with the cell's ``d0`` (its coefficient table's ``D0``) (``rest``:
    ``(gc, walls)``, a tuple)."""
    gc, walls = rest
    hcs = d0 * nih1
    if clips:
        hcs = hcs * s0 * s1
    xb0 = xb0 - hcs * w1
    xb1 = xb1 - hcs * w0
    if want_values:
        wa0 = w0 * s0 if clips else w0
        wa1 = w1 * s1 if clips else w1
        gtab[row, 0] += wa0
        gtab[row, 1] += wa1
        gtab[row, 2] += wa0 * f1
        gtab[row, 3] += wa1 * f0
    if son:
        b0 = sk[i, 0] * w0
        b1 = sk[i, 1] * w1
        xb0 = xb0 - b0
        xb1 = xb1 - b1
        if want_k:
            d0, d1 = _spring_d(q0, q1, i, sc, wraps, swrap0, swrap1, shalf, slen)
            gk[i, 0] = gk[i, 0] - d0 * w0
            gk[i, 1] = gk[i, 1] - d1 * w1
        if want_c:
            gc[i, 0] = gc[i, 0] + b0
            gc[i, 1] = gc[i, 1] + b1
    won, wk, wlo, whi = walls
    if won:
        k0 = wk[i, 0] if _clip(q0, wlo[i, 0], whi[i, 0]) != q0 else 0.0
        k1 = wk[i, 1] if _clip(q1, wlo[i, 1], whi[i, 1]) != q1 else 0.0
        xb0 = xb0 - k0 * w0
        xb1 = xb1 - k1 * w1
    return xb0, xb1


@njit(**_JIT)
def _energy_at(q0, q1, w0, w1, i, i0, j0, f0, f1, per0, per1, values, m, wrapping, son, sk, sc, swrap0, swrap1,
               shalf, slen, won, hwk, wlo, whi):
    """Particle ``i``'s total energy at ``(q0, q1)`` with velocity ``(w0, w1)``, at its cell's
    row and column and fractions of `_locate_ij`:
    [`pes_ref.core.scene.energy`][pes_ref.core.scene.energy]'s operations in its order, the
    bilinear energy of [`pes_ref.core.bilinear.grid_energy`][pes_ref.core.bilinear.grid_energy],
    plus the spring's ``0.5 (k0 d0 d0 + k1 d1 d1)`` (the minimum image on the axes ``swrap``, the
    periodic ones, as [`pes_ref.core.terms.spring_delta`][pes_ref.core.terms.spring_delta];
    ``wrapping``, a caller's compile-time constant, False leaves the image out of a loop whose
    caller passes no ``swrap``), plus the walls' ``(0.5 k) (b0 b0 + a0 a0 + (b1 b1 + a1 a1))``,
    plus ``0.5 (m0 v0 v0 + m1 v1 v1)``."""
    n0 = values.shape[0]
    n1 = values.shape[1]
    i1 = i0 + 1
    j1 = j0 + 1
    if per0 and i1 == n0:
        i1 = 0
    if per1 and j1 == n1:
        j1 = 0
    if i1 >= n0:                 # a non-finite point (cell 0 of a 1-node axis never occurs)
        i1 = n0 - 1
    if j1 >= n1:
        j1 = n1 - 1
    i0, j0, i1, j1 = np.uint64(i0), np.uint64(j0), np.uint64(i1), np.uint64(j1)     # (as _row's)
    u = ((1 - f0) * (1 - f1) * values[i0, j0] + f0 * (1 - f1) * values[i1, j0]
         + (1 - f0) * f1 * values[i0, j1] + f0 * f1 * values[i1, j1])
    if son:
        d0, d1 = _spring_d(q0, q1, i, sc, wrapping, swrap0, swrap1, shalf, slen)
        u = u + 0.5 * (sk[i, 0] * d0 * d0 + sk[i, 1] * d1 * d1)
    if won:
        b0 = wlo[i, 0] - q0
        b0 = b0 if (b0 != b0 or b0 > 0.0) else 0.0
        a0 = q0 - whi[i, 0]
        a0 = a0 if (a0 != a0 or a0 > 0.0) else 0.0
        b1 = wlo[i, 1] - q1
        b1 = b1 if (b1 != b1 or b1 > 0.0) else 0.0
        a1 = q1 - whi[i, 1]
        a1 = a1 if (a1 != a1 or a1 > 0.0) else 0.0
        u = u + hwk[i] * ((b0 * b0 + a0 * a0) + (b1 * b1 + a1 * a1))
    return u + 0.5 * (m[i, 0] * w0 * w0 + m[i, 1] * w1 * w1)


# =========================================================================== the per-cell tables

@njit(**_JIT)
def _coefficient_row(values, i, ip, j, jp, nih0, nih1, out):
    """Row ``i n1 + j`` of `_coefficient_table`: cell (i, j) with its next nodes ``ip``, ``jp``."""
    d0a = values[ip, j] - values[i, j]
    d1a = values[i, jp] - values[i, j]
    row = i * values.shape[1] + j
    out[row, 0] = d0a * nih0
    out[row, 1] = d1a * nih1
    out[row, 2] = ((values[ip, jp] - values[i, jp]) - d0a) * nih0
    out[row, 3] = ((values[ip, jp] - values[ip, j]) - d1a) * nih1


@njit(**_JIT)
def _coefficient_table(values, nih0, nih1, out):
    """[`pes_ref.core.bilinear.coefficient_table`][pes_ref.core.bilinear.coefficient_table] into ``out`` (n0 n1, 4): the
    same
    differences, wrapped, then scaled by ``-1/h`` (bit-identical). Each row's cells but the
    last in a loop without the wrap (which the compiler runs on SIMD lanes), the last wrapped."""
    n0, n1 = values.shape
    for i in range(n0):
        ip = i + 1 if i + 1 < n0 else 0
        for j in range(n1 - 1):
            _coefficient_row(values, i, ip, j, j + 1, nih0, nih1, out)
        _coefficient_row(values, i, ip, n1 - 1, 0, nih0, nih1, out)


@njit(**_JIT)
def _cross_table(values, nih0, nih1, out):
    """[`pes_ref.core.bilinear.cross_table`][pes_ref.core.bilinear.cross_table] into ``out`` (n0 n1,) (bit-identical;
    the
    loops as `_coefficient_table`'s)."""
    n0, n1 = values.shape
    for i in range(n0):
        ip = i + 1 if i + 1 < n0 else 0
        for j in range(n1):
            jp = j + 1 if j + 1 < n1 else 0
            out[i * n1 + j] = (((values[ip, jp] - values[i, jp]) - (values[ip, j] - values[i, j])) * nih0) * nih1


@njit(**_JIT)
def _table_grad_row(gtabs, i, n1, nih0, nih1, terms, clear):
    """Row ``i``'s per-cell terms of
    [`pes_ref.core.bilinear.table_grad_to_values`][pes_ref.core.bilinear.table_grad_to_values] into
    ``terms`` (3, n1): ``c10 = gA0 (-1/h0) - c11``, ``c01 = gA1 (-1/h1) - c11``, ``c11 = gD0
    (-1/h0) + gD1 (-1/h1)``, of the lanes' table gradients ``gtabs`` (L, n0 n1, 4) summed in
    lane order (``((g_0 + g_1) + g_2) ...``, one lane as it is). ``clear``: every entry read
    is set to 0 (the buffers left zeroed for their next run, in the same pass)."""
    if gtabs.shape[0] == 1:
        gtab = gtabs[0]
        for j in range(n1):
            r = i * n1 + j
            d = gtab[r, 2] * nih0 + gtab[r, 3] * nih1
            terms[2, j] = d
            terms[0, j] = gtab[r, 0] * nih0 - d
            terms[1, j] = gtab[r, 1] * nih1 - d
            if clear:
                gtab[r, 0] = gtab[r, 1] = gtab[r, 2] = gtab[r, 3] = 0.0
        return
    for j in range(n1):
        r = i * n1 + j
        g0, g1, g2, g3 = gtabs[0, r, 0], gtabs[0, r, 1], gtabs[0, r, 2], gtabs[0, r, 3]
        for lane in range(1, gtabs.shape[0]):
            g0 = g0 + gtabs[lane, r, 0]
            g1 = g1 + gtabs[lane, r, 1]
            g2 = g2 + gtabs[lane, r, 2]
            g3 = g3 + gtabs[lane, r, 3]
        if clear:
            for lane in range(gtabs.shape[0]):
                gtabs[lane, r, 0] = gtabs[lane, r, 1] = gtabs[lane, r, 2] = gtabs[lane, r, 3] = 0.0
        d = g2 * nih0 + g3 * nih1
        terms[2, j] = d
        terms[0, j] = g0 * nih0 - d
        terms[1, j] = g1 * nih1 - d


@njit(**_JIT)
def _table_grad_to_values(gtabs, nih0, nih1, n0, n1, out, rows, clear):
    """[`pes_ref.core.bilinear.table_grad_to_values`][pes_ref.core.bilinear.table_grad_to_values] of the lanes' table
    gradients
    ``gtabs`` (L, n0 n1, 4) summed in lane order, into ``out`` (n0, n1): per node ``-c10 -
    c01 - c11`` of its own cell plus ``c10``, ``c01``, ``c11`` of the cells it is the other
    corner of (wrapped), in that order (bit-identical). The terms of a row of cells and of
    the row before it (``rows`` (2, 3, n1), in cache), so the table gradient is read once
    (row n0 - 1 twice: first, as row 0's wrapped neighbour, without ``clear``); each row's
    nodes but the first in a loop without the wrap, the first wrapped."""
    prev, cur = rows[0], rows[1]
    _table_grad_row(gtabs, n0 - 1, n1, nih0, nih1, prev, False)          # the row before row 0 (wrapped)
    for i in range(n0):
        _table_grad_row(gtabs, i, n1, nih0, nih1, cur, clear)
        out[i, 0] = ((((-cur[0, 0] - cur[1, 0]) - cur[2, 0]) + prev[0, 0]) + cur[1, n1 - 1]) + prev[2, n1 - 1]
        for j in range(1, n1):
            out[i, j] = ((((-cur[0, j] - cur[1, j]) - cur[2, j]) + prev[0, j]) + cur[1, j - 1]) + prev[2, j - 1]
        prev, cur = cur, prev


@njit(**_JIT)
def _cell_cross(a, b, j, jp):
    """``|((G11 - G10) - G01) + G00|`` of the cell at column ``j`` (next column ``jp``) between
    the rows ``b`` (i) and ``a`` (i + 1)."""
    return abs(((a[jp] - a[j]) - b[jp]) + b[j])


@njit(**_JIT)
def _cross_curvature_max(values, per0, per1):
    """``max over cells |((G11 - G10) - G01) + G00|`` of
    [`pes_ref.core.stability.grid_cross_curvature`][pes_ref.core.stability.grid_cross_curvature]
    (a periodic axis's last cell wrapped to node 0). Finite values give no NaN here (a
    difference that overflows is an infinity, which the next finite term keeps), so the
    maximum is the same number in any order: four running maxima over a row's cells (four
    cells at a time keep the processor's pipelines full), then the largest of the four."""
    n0, n1 = values.shape
    m0 = n0 if per0 else n0 - 1
    b0 = b1 = b2 = b3 = -np.inf
    for i in range(m0):
        a = values[i + 1 if i + 1 < n0 else 0]
        b = values[i]
        j = 0
        while j + 4 <= n1 - 1:
            d0 = _cell_cross(a, b, j, j + 1)
            d1 = _cell_cross(a, b, j + 1, j + 2)
            d2 = _cell_cross(a, b, j + 2, j + 3)
            d3 = _cell_cross(a, b, j + 3, j + 4)
            b0 = d0 if d0 > b0 else b0
            b1 = d1 if d1 > b1 else b1
            b2 = d2 if d2 > b2 else b2
            b3 = d3 if d3 > b3 else b3
            j += 4
        while j < n1 - 1:
            d0 = _cell_cross(a, b, j, j + 1)
            b0 = d0 if d0 > b0 else b0
            j += 1
        if per1:
            d0 = _cell_cross(a, b, n1 - 1, 0)
            b0 = d0 if d0 > b0 else b0
    b0 = b1 if b1 > b0 else b0
    b2 = b3 if b3 > b2 else b2
    return b2 if b2 > b0 else b0


def cross_curvature_max(values: np.ndarray, periodic) -> float:
    """`_cross_curvature_max` of one grid (n0, n1): the numerator of
    [`pes_ref.core.stability.grid_cross_curvature`][pes_ref.core.stability.grid_cross_curvature], compiled, bit for bit."""
    return _cross_curvature_max(_readonly(values), bool(periodic[0]), bool(periodic[1]))


def _stacked(values: np.ndarray, width: int) -> tuple:
    """``(out, grids, size)``: a per-cell table (``width`` columns, 0 for one) of a grid or of
    a stack of grids, one after another
    ([`pes_ref.core.grid.stacked_table`][pes_ref.core.grid.stacked_table]), the grids (K, n0, n1)
    and the cells of one."""
    grids = values.reshape((-1,) + values.shape[-2:])
    size = grids.shape[1] * grids.shape[2]
    out = np.empty((grids.shape[0] * size, width) if width else (grids.shape[0] * size,))
    return out, grids, size


def coefficient_table(values: np.ndarray, h) -> np.ndarray:
    """[`pes_ref.core.bilinear.coefficient_table`][pes_ref.core.bilinear.coefficient_table] (of each grid of a stack), compiled."""
    out, grids, size = _stacked(values, 4)
    for c, grid in enumerate(grids):
        _coefficient_table(_readonly(grid), -1.0 / h[0], -1.0 / h[1], out[c * size:(c + 1) * size])
    return out


def cross_table(values: np.ndarray, h) -> np.ndarray:
    """[`pes_ref.core.bilinear.cross_table`][pes_ref.core.bilinear.cross_table] (of each grid of a stack), compiled."""
    out, grids, size = _stacked(values, 0)
    for c, grid in enumerate(grids):
        _cross_table(_readonly(grid), -1.0 / h[0], -1.0 / h[1], out[c * size:(c + 1) * size])
    return out


def table_grad_to_values(gtab: np.ndarray, h, shape: tuple, flat: bool = True) -> np.ndarray:
    """[`pes_ref.core.bilinear.table_grad_to_values`][pes_ref.core.bilinear.table_grad_to_values] of one grid, compiled;
    flat (n0 n1,),
    or in the grid's shape (an array of its own, not a view) unless ``flat``."""
    out = np.empty(shape)
    _table_grad_to_values(_kernel_array(gtab)[None], -1.0 / h[0], -1.0 / h[1], shape[0], shape[1], out,
                          np.empty((2, 3, shape[1])), False)
    return out.reshape(-1) if flat else out


@njit(**_JIT)
def _keep(lkf, lki, n, i, q0, q1, cell, i0, j0, f0, f1, s0, s1):
    """Keep state ``n``'s lookup of particle ``i`` at ``(q0, q1)``: ``lkf[n, i] = (q0, q1, f0,
    f1)``, ``lki[n, i] = (4 cell + 2 s0 + s1, 2^32 i0 + j0)`` (the switches are 0 or 1)."""
    lkf[n, i, 0] = q0
    lkf[n, i, 1] = q1
    lkf[n, i, 2] = f0
    lkf[n, i, 3] = f1
    lki[n, i, 0] = cell * 4 + (2 if s0 != 0.0 else 0) + (1 if s1 != 0.0 else 0)
    lki[n, i, 1] = (i0 << 32) + j0


@njit(**_JIT)
def _kept(lkf, lki, n, i):
    """State ``n``'s lookup of particle ``i`` that `_keep` kept: ``(cell, i0, j0, f0, f1, s0, s1)``."""
    code = lki[n, i, 0]
    ij = lki[n, i, 1]
    return (code >> 2, ij >> 32, ij & 0xFFFFFFFF, lkf[n, i, 2], lkf[n, i, 3], 1.0 if code & 2 else 0.0,
            1.0 if code & 1 else 0.0)


def _make_kernels(wraps: bool, per0: bool, per1: bool) -> SimpleNamespace:
    """The compiled loops, with ``wraps`` a compile-time constant: True where a spring's
    minimum image is computed (a periodic axis where it pulls, or its gradient wanted). A
    loop whose body holds the ``fmod`` call of the image runs ~30% slower even where it is
    never taken, so the loops without one are compiled without it (numba caches both).

    ``per0``, ``per1``: the grid's topology (axis 0, 1 periodic), compile-time constants
    too (the ``grid`` argument's flags are not read): the lookup of every particle-state
    tests them several times, and a loop compiled for its topology, without the tests and
    the code of the other, runs ~12% faster (the same operations on the numbers).

    The dynamic loops run the particle blocks (forward) and lanes (adjoint) they are given:
    a threaded run gives each thread a run of consecutive ones (`_spread`). Every
    array they write is written per particle (``x``, ``v``, ``f``, the energy, the kept
    lookups; ``xbar``, ``vbar``, ``fbar``, ``abar``, ``cbar``, the force's, the spring's
    ``gk`` and ``gc``) or per lane (the table gradient ``gtabs[lane]``), so no two threads
    write one entry."""
    clips = not (per0 and per1)

    # ======================================================================= dynamic mode

    @njit(**_JIT)
    def _dynamic_steps(x, v, f, fext, has_fext, start, stop, blocks, a, c, inv_1pc, damped, dt, grid, spring, walls,
                       energy, lookups, direct):
        """Steps ``start .. stop - 1`` of
        [`pes_ref.core.integrator.simulate_dynamic`][pes_ref.core.integrator.simulate_dynamic], and
        from ``start = 0`` the initial force ``F_0 = F(X_0) + F_ext[0]`` first (as a step -1
        that is only (S3): one copy of the force in the loop); the particles of each block
        (``blocks[b] .. blocks[b+1] - 1``: a population's member, whose grid's table then stays
        in cache) through all the steps before the next block's (particles are independent:
        the order changes no number). ``energy`` (`_energy_terms`) on: each state's
        energy into its ``out`` as the state is made, at the state's lookup (`_energy_at`).
        ``lookups`` (`_lookups`) on: each state's position and grid lookup kept for the adjoint.
        ``direct`` ``(on, values)`` on (one grid): a cell's coefficients from the grid's values
        (`_cell_coefficients`, the table's numbers), no table."""
        g, _, _, _, table, offsets = grid          # (the topology: the closure's)
        keep, lkf, lki = lookups
        from_values, values = direct
        nih0 = -1.0 / g[2]                         # as coefficient_table's -1/h
        nih1 = -1.0 / g[3]
        son, sk, sc, swrap0, swrap1, shalf, slen = spring
        won, wk, wlo, whi = walls
        e_on, eout, em, evalues, espring, ewalls = energy
        eson, esk, esc, eswrap0, eswrap1, eshalf, eslen = espring
        ewon, ehwk, ewlo, ewhi = ewalls
        for b in range(blocks.size - 1):
            for n in range(start - 1 if start == 0 else start, stop):
                for ii in range(blocks[b + 1] - blocks[b]):
                    # unsigned: numba indexes with a signed integer through a test for a negative
                    # index (counted from the end) at every access, with an unsigned one without
                    i = np.uint64(blocks[b]) + np.uint64(ii)
                    if n >= 0:
                        # (S1) half_kick: P = V_n + a F_n (as a F_n + V_n)
                        p0 = a[i, 0] * f[n, i, 0] + v[n, i, 0]
                        p1 = a[i, 1] * f[n, i, 1] + v[n, i, 1]
                        # (S2) drift: X_{n+1} = X_n + dt P (as P dt + X_n)
                        y0 = p0 * dt + x[n, i, 0]
                        y1 = p1 * dt + x[n, i, 1]
                        x[n + 1, i, 0] = y0
                        x[n + 1, i, 1] = y1
                    else:
                        y0, y1 = x[0, i, 0], x[0, i, 1]
                        p0 = p1 = 0.0
                    # (S3) force: F_{n+1} = F(X_{n+1}) + F_ext[n+1]
                    cell, i0, j0, f0, f1, s0, s1 = _locate_ij(y0, y1, g, per0, per1, clips)
                    if keep:
                        _keep(lkf, lki, n + 1, i, y0, y1, cell, i0, j0, f0, f1, s0, s1)
                    if from_values:
                        A0, A1, D0, D1 = _cell_coefficients(values, i0, j0, nih0, nih1)
                        F0, F1 = _terms_force(y0, y1, i, (D0 * f1 + A0) * s0, (D1 * f0 + A1) * s1, son, sk, sc, wraps,
                                              swrap0, swrap1, shalf, slen, won, wk, wlo, whi)
                    else:
                        F0, F1 = _force_at(y0, y1, i, cell, f0, f1, s0, s1, table, offsets, son, sk, sc, wraps, swrap0,
                                           swrap1, shalf, slen, won, wk, wlo, whi)
                    if has_fext:
                        F0 = F0 + fext[n + 1, i, 0]
                        F1 = F1 + fext[n + 1, i, 1]
                    f[n + 1, i, 0] = F0
                    f[n + 1, i, 1] = F1
                    if n < 0:
                        w0, w1 = v[0, i, 0], v[0, i, 1]
                    else:
                        # (S4) kick: V_{n+1} = a F_{n+1} + P, damped ((a F_{n+1} + P) - c V_n) (1 / (1 + c))
                        w0 = a[i, 0] * F0 + p0
                        w1 = a[i, 1] * F1 + p1
                        if damped:
                            w0 = (w0 - c[i, 0] * v[n, i, 0]) * inv_1pc[i, 0]
                            w1 = (w1 - c[i, 1] * v[n, i, 1]) * inv_1pc[i, 1]
                        v[n + 1, i, 0] = w0
                        v[n + 1, i, 1] = w1
                    if e_on:
                        eout[n + 1, i] = _energy_at(y0, y1, w0, w1, i, i0, j0, f0, f1, per0, per1, evalues, em, wraps,
                                                    eson, esk, esc, eswrap0, eswrap1, eshalf, eslen, ewon, ehwk, ewlo,
                                                    ewhi)


    @njit(**_JIT)
    def _dynamic_adjoint_steps(x, v, f, gx, has_gx, gv, has_gv, start, stop, a, inv_1pc, minus_c, damped, dt,
                               xbar, vbar, fbar, want_abar, abar, want_cbar, cbar, want_force, gforce,
                               lanes, blocks, grid, nih1, gtabs, want_values, spring, want_k, gk, want_c, gc, walls,
                               lookups, direct):
        """Steps ``stop - 1`` down to ``start`` of
        [`pes_ref.core.integrator.adjoint_dynamic`][pes_ref.core.integrator.adjoint_dynamic],
        (B4)-(B1) and the objective's direct terms, per particle; down to ``start = 0``, then
        (B0), the adjoint of the initial force (as a step -1 that is only (B3)). The particles
        in ``lanes`` of ``blocks`` (lane ``l``: blocks ``lanes[l] .. lanes[l+1] - 1``), each lane
        with its own table gradient ``gtabs[l]`` (the caller sums them in lane order).
        ``lookups`` on: a state's grid lookup is the forward's (`_kept`) where its position
        is the one the forward looked up, else computed again (the same numbers either way).
        ``direct`` as in `_dynamic_steps`: a cell's ``D0`` from the values (`_cell_d0`)."""
        g, _, _, _, table, offsets = grid          # (the topology: the closure's)
        keep, lkf, lki = lookups
        from_values, values = direct
        nih0 = -1.0 / g[2]
        son, sk, sc, swrap0, swrap1, shalf, slen = spring
        won, wk, wlo, whi = walls
        for lane in range(lanes.size - 1):
            gtab = gtabs[lane]
            for blk in range(lanes[lane], lanes[lane + 1]):
                for n in range(stop - 1, start - 2 if start == 0 else start - 1, -1):
                    for ii in range(blocks[blk + 1] - blocks[blk]):
                        i = np.uint64(blocks[blk]) + np.uint64(ii)          # unsigned: see _dynamic_steps
                        xb0, xb1 = xbar[i, 0], xbar[i, 1]
                        vb0, vb1 = vbar[i, 0], vbar[i, 1]
                        if n >= 0:
                            # (B4) kick^T: P^ = V^_{n+1} / (1 + c); V^_n = -c P^; F^_{n+1} += a P^; a^, c^
                            if damped:
                                pb0 = vb0 * inv_1pc[i, 0]
                                pb1 = vb1 * inv_1pc[i, 1]
                                vp0 = minus_c[i, 0] * pb0
                                vp1 = minus_c[i, 1] * pb1
                            else:
                                pb0, pb1 = vb0, vb1
                                vp0 = vp1 = 0.0
                            fb0 = fbar[i, 0] + a[i, 0] * pb0
                            fb1 = fbar[i, 1] + a[i, 1] * pb1
                            if want_abar:
                                abar[i, 0] = abar[i, 0] + f[n + 1, i, 0] * pb0
                                abar[i, 1] = abar[i, 1] + f[n + 1, i, 1] * pb1
                            if want_cbar:
                                cbar[i, 0] = cbar[i, 0] - (v[n, i, 0] + v[n + 1, i, 0]) * pb0
                                cbar[i, 1] = cbar[i, 1] - (v[n, i, 1] + v[n + 1, i, 1]) * pb1
                        else:                       # (B0) is (B3) at X_0 with F^_0 = a P^ of step 0's (B1)
                            fb0, fb1 = fbar[i, 0], fbar[i, 1]
                            pb0 = pb1 = vp0 = vp1 = 0.0
                        # (B3) force^T at X_{n+1}: F_ext^[n+1] = F^_{n+1}; X^_{n+1} += -H_U F^_{n+1}
                        if want_force:
                            gforce[n + 1, i, 0] = fb0
                            gforce[n + 1, i, 1] = fb1
                        q0, q1 = x[n + 1, i, 0], x[n + 1, i, 1]
                        if keep and q0 == lkf[n + 1, i, 0] and q1 == lkf[n + 1, i, 1]:
                            cell, i0, j0, f0, f1, s0, s1 = _kept(lkf, lki, n + 1, i)
                        else:
                            cell, i0, j0, f0, f1, s0, s1 = _locate_ij(q0, q1, g, per0, per1, clips)
                        if from_values:
                            row = _row(cell, i, offsets, gtab.shape[0])
                            d0 = _cell_d0(values, i0, j0, nih0)
                        else:
                            row = _row(cell, i, offsets, table.shape[0])
                            d0 = table[row, 2]
                        xb0, xb1 = _vjp_at(q0, q1, i, row, f0, f1, s0, s1, fb0, fb1, xb0, xb1, clips, d0, nih1, gtab,
                                           want_values, son, sk, sc, wraps, swrap0, swrap1, shalf, slen, want_k, gk,
                                           want_c, (gc, walls))
                        if n < 0:
                            xbar[i, 0], xbar[i, 1] = xb0, xb1
                            continue
                        # (B2) drift^T: P^ += dt X^_{n+1} (as P^ + X^ dt)
                        pb0 = pb0 + xb0 * dt
                        pb1 = pb1 + xb1 * dt
                        # (B1) half_kick^T: V^_n += P^; F^_n = a P^; a^ += F_n P^
                        if damped:
                            vb0 = vp0 + pb0
                            vb1 = vp1 + pb1
                        else:
                            vb0, vb1 = pb0, pb1
                        fbar[i, 0] = a[i, 0] * pb0
                        fbar[i, 1] = a[i, 1] * pb1
                        if want_abar:
                            abar[i, 0] = abar[i, 0] + f[n, i, 0] * pb0
                            abar[i, 1] = abar[i, 1] + f[n, i, 1] * pb1
                        if has_gx:
                            xb0 = xb0 + gx[n, i, 0]
                            xb1 = xb1 + gx[n, i, 1]
                        if has_gv:
                            vb0 = vb0 + gv[n, i, 0]
                            vb1 = vb1 + gv[n, i, 1]
                        xbar[i, 0], xbar[i, 1] = xb0, xb1
                        vbar[i, 0], vbar[i, 1] = vb0, vb1


    # ======================================================================= quasistatic mode

    @njit(**_JIT)
    def _quasistatic_steps(x, f, fext, has_fext, start, stop, blocks, mu, grid, spring, walls):
        """Steps ``start .. stop - 1`` of
        [`pes_ref.core.integrator.simulate_quasistatic`][pes_ref.core.integrator.simulate_quasistatic], and
        up to ``stop = T`` then the final force ``F_T = F(X_T) + F_ext[T]`` (as a step T that is
        only (Q1)), a block of particles at a time (as `_dynamic_steps`)."""
        g, _, _, _, table, offsets = grid          # (the topology: the closure's)
        son, sk, sc, swrap0, swrap1, shalf, slen = spring
        won, wk, wlo, whi = walls
        T = x.shape[0] - 1
        for b in range(blocks.size - 1):
            for n in range(start, stop + 1 if stop == T else stop):
                for i in range(blocks[b], blocks[b + 1]):
                    # (Q1) force: F_n = F(X_n) + F_ext[n]
                    F0, F1 = _force(x[n, i, 0], x[n, i, 1], i, g, per0, per1, clips, table, offsets, son, sk, sc,
                                    wraps, swrap0, swrap1, shalf, slen, won, wk, wlo, whi)
                    if has_fext:
                        F0 = F0 + fext[n, i, 0]
                        F1 = F1 + fext[n, i, 1]
                    f[n, i, 0] = F0
                    f[n, i, 1] = F1
                    if n == T:
                        continue
                    # (Q2) drift: X_{n+1} = X_n + mu F_n (as mu F_n + X_n)
                    x[n + 1, i, 0] = mu[i, 0] * F0 + x[n, i, 0]
                    x[n + 1, i, 1] = mu[i, 1] * F1 + x[n, i, 1]


    @njit(**_JIT)
    def _quasistatic_adjoint_steps(x, f, gx, has_gx, start, stop, mu, xbar, want_mubar, mubar, want_force, gforce,
                                   grid, nih1, gtab, want_values, spring, want_k, gk, want_c, gc, walls):
        """Steps ``stop - 1`` down to ``start`` of [`pes_ref.core.integrator.adjoint_quasistatic`][pes_ref.core.integrator.adjoint_quasistatic]."""
        g, _, _, _, table, offsets = grid          # (the topology: the closure's)
        son, sk, sc, swrap0, swrap1, shalf, slen = spring
        won, wk, wlo, whi = walls
        for n in range(stop - 1, start - 1, -1):
            for i in range(x.shape[1]):
                xb0, xb1 = xbar[i, 0], xbar[i, 1]
                # (QB2) drift^T: F^_n = mu X^_{n+1}; mu^ += F_n X^_{n+1}
                fb0 = mu[i, 0] * xb0
                fb1 = mu[i, 1] * xb1
                if want_mubar:
                    mubar[0] += f[n, i, 0] * xb0
                    mubar[1] += f[n, i, 1] * xb1
                # (QB1) force^T at X_n
                if want_force:
                    gforce[n, i, 0] = fb0
                    gforce[n, i, 1] = fb1
                xb0, xb1 = _vjp(x[n, i, 0], x[n, i, 1], i, fb0, fb1, xb0, xb1, g, per0, per1, clips, table, nih1,
                                offsets, gtab, want_values, son, sk, sc, wraps, swrap0, swrap1, shalf, slen, want_k, gk,
                                want_c, gc, walls)
                if has_gx:
                    xb0 = xb0 + gx[n, i, 0]
                    xb1 = xb1 + gx[n, i, 1]
                xbar[i, 0], xbar[i, 1] = xb0, xb1

    return SimpleNamespace(dynamic_steps=_dynamic_steps, dynamic_adjoint_steps=_dynamic_adjoint_steps,
                           quasistatic_steps=_quasistatic_steps, quasistatic_adjoint_steps=_quasistatic_adjoint_steps)


#: The compiled loops without a spring's minimum image (False) and with it (True).
#: Keyed by ``(wraps, per0, per1)``: the minimum image and the grid's topology.
KERNELS = {(wraps, per0, per1): _make_kernels(wraps, per0, per1)
           for wraps in (False, True) for per0 in (False, True) for per1 in (False, True)}


def kernels(wraps: bool, field) -> SimpleNamespace:
    """The loops of `KERNELS` for ``wraps`` and ``field``'s topology."""
    return KERNELS[bool(wraps), bool(field.periodic[0]), bool(field.periodic[1])]


# =========================================================================== the threads of a large run

#: The worker threads of the threaded loops (`_spread`), ``{0: ThreadPoolExecutor}`` once
#: made: numba's largest thread count less one (the calling thread runs a share too). A forked
#: process forgets its parent's (whose threads it has not).
_POOL: dict = {}
os.register_at_fork(after_in_child=_POOL.clear)


def threads() -> int:
    """How many threads a threaded loop runs on: numba's thread count in the calling thread
    (``NUMBA_NUM_THREADS``, by default every core, or ``numba.set_num_threads``)."""
    return get_num_threads()


def _pool() -> ThreadPoolExecutor:
    """The pool of `_POOL`, made at its first use (its threads start at their first task)."""
    pool = _POOL.get(0)
    if pool is None:
        pool = _POOL.setdefault(0, ThreadPoolExecutor(max(1, numba_config.NUMBA_NUM_THREADS - 1),
                                                      thread_name_prefix="pes_ref-loop"))
    return pool


def _shares(starts: np.ndarray) -> np.ndarray:
    """How `_spread` shares out units (blocks, or lanes) among `threads` threads:
    the cuts ``0 = c_0 < c_1 < ... < c_k`` = the units, share ``t`` the units ``c_t .. c_{t+1} -
    1``, about as many particles in each; one share below `PARALLEL_MIN` particles.
    ``starts``: each unit's first particle, and N last."""
    units = starts.size - 1
    k = threads() if units > 1 and starts[-1] >= PARALLEL_MIN else 1
    if k <= 1:
        return np.array([0, max(units, 0)])
    inner = np.searchsorted(starts, np.arange(1, k) * (starts[-1] / k))
    return np.unique(np.concatenate(([0], inner, [units])))


def _spread(run, cuts: np.ndarray, *args) -> None:
    """``run(u0, u1, *args)`` of each share ``u0 .. u1 - 1`` of `_shares`' ``cuts``: the
    first on the calling thread, the others on `_pool`'s threads, all ended when it returns
    (an error in one is then raised). ``run`` calls a ``nogil`` kernel, so the shares run side
    by side."""
    if cuts.size <= 2:
        run(int(cuts[0]), int(cuts[-1]), *args)
        return
    pool = _pool()
    futures = [pool.submit(run, int(a), int(b), *args) for a, b in zip(cuts[1:-1], cuts[2:])]
    try:
        run(int(cuts[0]), int(cuts[1]), *args)
    finally:
        wait(futures)
    for future in futures:
        future.result()


# =========================================================================== the energy of a trajectory

@njit(**_JIT)
def _energy(x, v, m, blocks, g, per0, per1, clips, values, son, sk, sc, swrap0, swrap1, shalf, slen,
            won, hwk, wlo, whi, out):
    """The energy kernel of [`energy`][pes_ref.accel.compiled.energy]: ``out[n, i]``, `_energy_at` of each
    particle-state of the ``blocks`` (a spring's minimum image on every periodic axis); each
    entry is one particle-state's own arithmetic, written by it alone (`_spread`)."""
    for b in range(blocks.size - 1):
        for n in range(x.shape[0]):
            for i in range(blocks[b], blocks[b + 1]):
                q0 = x[n, i, 0]
                q1 = x[n, i, 1]
                _, i0, j0, f0, f1, _, _ = _locate_ij(q0, q1, g, per0, per1, clips)
                out[n, i] = _energy_at(q0, q1, v[n, i, 0], v[n, i, 1], i, i0, j0, f0, f1, per0, per1, values, m,
                                       True, son, sk, sc, swrap0, swrap1, shalf, slen, won, hwk, wlo, whi)


def _energy_terms(field, n: int, mass, out) -> tuple:
    """``(on, out, mass, values, spring, walls)``: the energy arguments of `_energy_at`
    (`_make_energy`'s kernel and the forward loop's), ``on`` False and placeholders of
    the same types when ``out`` is None. The spring's minimum image on every periodic axis
    (``spring[3:5]``), the walls' ``0.5 k`` per particle."""
    if out is None:
        return False, _NONE2, _NONE2, _NONE2_RO, _NO_SPRING, _NO_ENERGY_WALLS
    if field.spring is not None:
        wrap = [bool(p) for p in field.periodic]
        length = np.asarray(field.length, dtype=np.float64)
        spring = (True, _as(field.spring[0], n), _as(field.spring[1], n), wrap[0], wrap[1], 0.5 * length, length.copy())
    else:
        spring = _spring(field, n, False, ())
    if field.walls is not None:
        k, lo, hi = field.walls
        walls = (True, np.broadcast_to(0.5 * np.asarray(k, dtype=np.float64), (n, 1))[:, 0].copy(), _as(lo, n),
                 _as(hi, n))
    else:
        walls = _NO_ENERGY_WALLS
    return True, out, _as(mass, n), _readonly(field.values), spring, walls


def energy(field, x: np.ndarray, v: np.ndarray, mass, out=None) -> np.ndarray:
    """Total energy per state and particle, (T+1, N), into ``out`` (fresh when None):
    [`pes_ref.core.scene.energy`][pes_ref.core.scene.energy]'s numbers bit for bit (bilinear grid, one grid),
    compiled; the particles in blocks of `BLOCK` on [`threads`][pes_ref.accel.compiled.threads] threads
    from `PARALLEL_MIN` particles on."""
    x, v = _kernel_array(x), _kernel_array(v)
    T1, N = x.shape[0], x.shape[1]
    g, per0, per1, clips = _grid(field, N, _NONE2)[:4]
    out = pages.empty((T1, N)) if out is None else out
    _, out, m, values, spring, walls = _energy_terms(field, N, mass, out)
    blocks = particle_blocks(N) if N >= PARALLEL_MIN else np.array([0, N], dtype=np.intp)

    def run(b0, b1):
        _energy(x, v, m, blocks[b0:b1 + 1], g, per0, per1, clips, values, *spring, *walls, out)

    _spread(run, _shares(blocks))
    return out


def energy_wraps(field) -> bool:
    """Whether `_energy_at` takes a spring's minimum image in ``field`` (a spring and a
    periodic axis): a forward loop that computes the energy is then the one compiled with it."""
    return field.spring is not None and any(bool(p) for p in field.periodic)


# =========================================================================== the kernels' arguments

_NONE2 = np.zeros((1, 2))
_NONE3 = np.zeros((1, 1, 2))
_NONE2_RO = _NONE2.copy()
_NONE2_RO.setflags(write=False)
_NONE3_RO = _NONE3.copy()
_NONE3_RO.setflags(write=False)
_ONE_LANE = np.array([0, 1], dtype=np.intp)
_NO_TABLE = np.zeros((1, 4))
_NO_DIRECT = (False, _NONE2_RO)
_NO_SPRING = (False, _NONE2, _NONE2, False, False, np.zeros(2), np.ones(2))
_NO_ENERGY_WALLS = (False, np.zeros(1), _NONE2, _NONE2)

#: From this many particles on, the loops run their particles in blocks on `threads`
#: threads (both cores); below it, one block on the calling thread (two threads gain nothing
#: there: docs/performance.md).
PARALLEL_MIN = 1024
#: Particles per block of a threaded loop: a fixed number, so the blocks, and every sum over
#: them (the grid's and the mobility's gradients), never depend on how many threads run them.
BLOCK = 256


#: Lanes of a threaded adjoint: each sums its own copy of the grid's table gradient (the
#: copies are added in lane order at the end), so there are few, and as many whatever the
#: threads.
LANES = 4


def particle_blocks(n: int, width: int | None = None) -> np.ndarray:
    """The starts of ``n`` particles' blocks of ``width`` (`BLOCK`) and ``n`` last (intp)."""
    return np.append(np.arange(0, n, width or BLOCK), n).astype(np.intp)


def lanes_of(n: int) -> tuple:
    """``(lanes, blocks)`` of a threaded adjoint of ``n`` particles: the blocks of
    [`particle_blocks`][pes_ref.accel.compiled.particle_blocks] and `LANES` runs of consecutive
    blocks (fewer if there are fewer blocks), ``lanes[l] .. lanes[l+1] - 1``."""
    blocks = particle_blocks(n)
    nb = blocks.size - 1
    k = min(LANES, nb)
    return np.array([(l * nb) // k for l in range(k + 1)], dtype=np.intp), blocks


def parallel_blocks(field, n: int) -> np.ndarray:
    """The particle blocks of a threaded forward loop: each of `_blocks`' cut into
    pieces of at most `BLOCK` particles."""
    out = [0]
    bounds = _blocks(field, n)
    for a, b in zip(bounds[:-1], bounds[1:]):
        out.extend(range(int(a) + BLOCK, int(b), BLOCK))
        out.append(int(b))
    return np.array(out, dtype=np.intp)


def _as(a, n: int) -> np.ndarray:
    """``a`` broadcast to a fresh contiguous float64 (N, 2) (an assignment: the broadcast
    and the copy in one call, ``np.broadcast_to``'s checks without its Python layer)."""
    out = np.empty((n, 2))
    out[...] = a
    return out


def _kernel_array(a) -> np.ndarray:
    """``a`` as every kernel argument is: C-contiguous and writable (numba compiles a kernel
    again for each layout and for read-only arrays), copied only when it is not."""
    return np.require(a, dtype=np.float64, requirements=["C", "W"])


def _readonly(a) -> np.ndarray:
    """``a`` as the argument of a kernel that only reads it: a read-only C-contiguous float64
    view (a copy only when ``a`` is not C-contiguous float64), so the kernel's argument type
    is the same whether the caller's array is writable or not (the surface's values and the
    validated force are read-only) and nothing is copied to make it writable."""
    view = np.ascontiguousarray(a, dtype=np.float64).view()
    view.setflags(write=False)
    return view


def _c3(a):
    """A (T+1, N, 2) input as the kernels take it, read-only (`_readonly`; placeholder
    and False when None)."""
    return (_NONE3_RO, False) if a is None else (_readonly(a), True)


def _grid(field, n: int, table):
    """The grid's lookup constants, its stacked ``table`` and each particle's row offset."""
    shape = np.asarray(field.values.shape[-2:], dtype=np.float64)
    g = np.array([field.lower[0], field.lower[1], field.h[0], field.h[1], shape[0] - 1, shape[1] - 1,
                  shape[0] - 2, shape[1] - 2, shape[0], shape[1]], dtype=np.float64)
    per0, per1 = bool(field.periodic[0]), bool(field.periodic[1])
    offsets = np.zeros(n, dtype=np.intp) if field.offsets is None else np.array(field.offsets, dtype=np.intp)
    return g, per0, per1, not (per0 and per1), _kernel_array(table), offsets


def _spring(field, n: int, on: bool, axes):
    """``(on, k, center, wrap0, wrap1, half, length)``: the minimum image on the periodic
    axes among ``axes``."""
    if field.spring is None:
        return _NO_SPRING
    length = np.asarray(field.length, dtype=np.float64)
    wrap = [bool(field.periodic[d]) and d in axes for d in range(2)]
    return (on, _as(field.spring[0], n), _as(field.spring[1], n), wrap[0], wrap[1], 0.5 * length,
            length.copy())


def _walls(field, n: int):
    if field.walls is None:
        return False, _NONE2, _NONE2, _NONE2
    k, lo, hi = field.walls
    return True, _as(k, n), _as(lo, n), _as(hi, n)


def _blocks(field, n: int) -> np.ndarray:
    """The particle blocks of the forward kernels: a population's members (particles of one
    grid offset, contiguous), else all particles in one."""
    if field.offsets is None:
        return np.array([0, n], dtype=np.intp)
    offsets = np.asarray(field.offsets)
    return np.concatenate(([0], np.nonzero(offsets[1:] != offsets[:-1])[0] + 1, [n])).astype(np.intp)


def _wraps(spring: tuple) -> bool:
    """Whether the kernels for ``spring`` (`_spring`) compute a minimum image."""
    return bool(spring[0] and (spring[3] or spring[4]))


def _direct(field) -> tuple:
    """``(on, values)``, the ``direct`` argument of the dynamic loops: on for one grid (no
    population), whose loops then take a cell's coefficients from its values
    (`_cell_coefficients`: the table's numbers) and build no table."""
    if field.offsets is None and field.values.ndim == 2:
        return True, _readonly(field.values)
    return _NO_DIRECT


def _forward_terms(field, n: int, table: bool = True):
    """Whether the forward kernels take the minimum image (``wraps``, the key of
    [`kernels`][pes_ref.accel.compiled.kernels]) and their grid, spring and walls arguments: the spring only where the
    NumPy path builds its kernel (some nonzero ``k``), its minimum image where it pulls;
    the grid's coefficient table unless ``table`` is False (a placeholder then)."""
    grid = _grid(field, n, grid_table(field) if table else _NO_TABLE)
    axes = () if field.spring is None else spring_axes(field.spring[0])
    spring = _spring(field, n, bool(axes), axes)
    return _wraps(spring), grid, spring, _walls(field, n)


class _Adjoint:
    """The force's adjoint over stored states: the compiled kernels' arguments (the grid's
    coefficient table, whose ``D0 (-1/h1)`` is the cross term, and its table gradients, the
    spring's gradients) and ``result()``, for
    [`finish_dynamic_adjoint`][pes_ref.core.integrator.finish_dynamic_adjoint]. ``lanes``
    particle lanes ([`lanes_of`][pes_ref.accel.compiled.lanes_of]), each with its own table gradient (zeroed buffers of
    `_zeroed`), summed in lane order by ``result()`` as it maps them to the grid."""

    def __init__(self, field, xs: np.ndarray, want: frozenset, threaded: bool = False, direct=_NO_DIRECT):
        n = xs.shape[1]
        self.field, self.xs = field, xs
        self.want_values = "values" in want
        self.direct = direct                       # (a dynamic loop's: the cross term from the values, no table)
        self.grid = _grid(field, n, _NO_TABLE if direct[0] else grid_table(field))
        self.nih1 = -1.0 / field.h[1]                         # as cross_table's: (D0 (-1/h0)) (-1/h1)
        self.lanes, self.blocks = lanes_of(n) if threaded else (_ONE_LANE, np.array([0, n], dtype=np.intp))
        rows = field.values.size if direct[0] else self.grid[4].shape[0]
        self.gtabs = _zeroed((self.lanes.size - 1, rows, 4)) if self.want_values else _NONE3
        self.gtab = self.gtabs[0] if self.want_values else _NONE2
        has_spring = field.spring is not None
        self.want_k = has_spring and "spring_k" in want
        self.want_c = has_spring and "spring_center" in want
        on = has_spring and bool(spring_axes(field.spring[0]) or self.want_k or self.want_c)
        self.spring = _spring(field, n, on, (0, 1))
        wraps = self.want_k and _wraps(self.spring)                  # the image only for k's gradient
        self.kernels = kernels(wraps, field)
        self.gk = np.zeros((n, 2)) if self.want_k else _NONE2
        self.gc = np.zeros((n, 2)) if self.want_c else _NONE2
        self.walls = _walls(field, n)

    def terms(self) -> tuple:
        """The trailing arguments of the quasistatic adjoint kernel (one lane)."""
        return (self.grid, self.nih1, self.gtab, self.want_values, self.spring, self.want_k, self.gk,
                self.want_c, self.gc, self.walls)

    def lane_terms(self, l0: int, l1: int) -> tuple:
        """The trailing arguments of the dynamic adjoint kernel for the lanes ``l0 .. l1 - 1``
        (views: their bounds and table gradients)."""
        gtabs = self.gtabs[l0:l1] if self.want_values else self.gtabs
        return (self.lanes[l0:l1 + 1], self.blocks, self.grid, self.nih1, gtabs, self.want_values, self.spring,
                self.want_k, self.gk, self.want_c, self.gc, self.walls)

    def result(self) -> dict:
        """The terms' gradients; the grid's (n0, n1), its own array, from the lanes' table
        gradients summed in lane order (the same sum whatever the threads), which the same
        pass zeroes and hands back (`_give_back`). Once: the lanes are then gone."""
        out = {}
        if self.want_values:
            h, shape = self.field.h, self.field.values.shape[-2:]
            grad = np.empty(shape)
            _table_grad_to_values(self.gtabs, -1.0 / h[0], -1.0 / h[1], shape[0], shape[1], grad,
                                  np.empty((2, 3, shape[1])), True)
            _give_back(self.gtabs)
            self.gtabs = self.gtab = None
            out["values"] = grad
        if self.want_k:
            out["spring_k"] = self.gk
        if self.want_c:
            out["spring_center"] = self.gc
        return out


#: The last grid's coefficient table, ``(weakref to its values, h0, h1, table)``, or None:
#: a run's forward builds it and its adjoint (and the next run on the same grid) reads it.
#: Kept only for a values array that is read-only and owns its memory (a
#: `Surface`'s: a checked copy that nothing writes), and only
#: while that array lives (the weak reference's callback drops it).
_TABLE = [None]


def _forget(ref) -> None:
    entry = _TABLE[0]
    if entry is not None and entry[0] is ref:
        _TABLE[0] = None


def grid_table(field) -> np.ndarray:
    """[`coefficient_table`][pes_ref.accel.compiled.coefficient_table] of ``field``'s grid (or stack of grids): the one
    kept in
    `_TABLE` when it is this values array's at this spacing, else built (and kept,
    when the array is a read-only one that owns its memory)."""
    values = field.values
    h0, h1 = float(field.h[0]), float(field.h[1])
    entry = _TABLE[0]
    if entry is not None and entry[0]() is values and entry[1] == h0 and entry[2] == h1:
        return entry[3]
    table = coefficient_table(values, field.h)
    if not values.flags.writeable and values.base is None:
        _TABLE[0] = (weakref.ref(values, _forget), h0, h1, table)
    return table


#: Zeroed table-gradient buffers between runs (at most one, of at most `SPARE_BYTES`):
#: an adjoint takes one (`_zeroed`) instead of zeroing fresh memory, and hands it
#: back zeroed by the pass that reads it (`_Adjoint.result`).
_SPARE: list = []
SPARE_BYTES = 1 << 24


def _zeroed(shape: tuple) -> np.ndarray:
    """A zeroed float64 array of ``shape``: the spare buffer when it has that shape, else fresh."""
    try:
        buf = _SPARE.pop()
    except IndexError:
        return np.zeros(shape)
    return buf if buf.shape == shape else np.zeros(shape)


def _give_back(buf: np.ndarray) -> None:
    """Keep ``buf``, all zeros again, as the spare buffer (if there is none and it is small enough)."""
    if buf.nbytes <= SPARE_BYTES and not _SPARE:
        _SPARE.append(buf)


#: The grid lookups of the last dynamic forward run, ``(weakref to its x, its grid's lookup
#: key, lkf, lki)``, or None (`_lookups`): its adjoint reads them instead of looking
#: each state up again, where the state's position is still the one looked up.
_LOOKUPS = [None]
#: A run keeps its lookups up to this many particle-states ((T+1) N; LOOKUP_BYTES = 48 each,
#: which `pes_ref.core.budget.run_bytes` counts): a small run's adjoint is bound by the
#: lookup's divisions, a large one's by memory.
LOOKUP_STATES = budget.LOOKUP_STATES
_NO_LOOKUPS = (False, np.zeros((1, 1, 4)), np.zeros((1, 1, 2), dtype=np.int64))


def _drop_lookups(ref) -> None:
    entry = _LOOKUPS[0]
    if entry is not None and entry[0] is ref:
        _LOOKUPS[0] = None


def _lookup_key(field, grid) -> tuple:
    """What a state's lookup depends on besides its position: the grid's lookup constants
    and topology (not its values); None for a population (rows offset per particle)."""
    return None if field.offsets is not None else (grid[0].tobytes(), grid[1], grid[2])


def _lookups(field, x: np.ndarray, grid) -> tuple:
    """``(keep, lkf, lki)`` of a dynamic forward run over ``x`` (T+1, N, 2): arrays its loop
    fills with each state's position and lookup (`_keep`), kept in `_LOOKUPS`
    for its adjoint, when the run has at most `LOOKUP_STATES` particle-states and one
    grid; else placeholders and ``keep`` False."""
    key = _lookup_key(field, grid)
    if key is None or x.shape[0] * x.shape[1] > LOOKUP_STATES:
        return _NO_LOOKUPS
    lkf, lki = np.empty(x.shape[:2] + (4,)), np.empty(x.shape[:2] + (2,), dtype=np.int64)
    _LOOKUPS[0] = (weakref.ref(x, _drop_lookups), key, lkf, lki)
    return True, lkf, lki


def _kept_lookups(field, x: np.ndarray, grid) -> tuple:
    """The lookups (`_lookups`) of the forward run that made ``x``, on this grid's
    lookup constants and topology, or placeholders. The adjoint loop reads a state's kept
    lookup only where ``x`` holds the very position it was made at (`_kept`), so
    positions written since are looked up again."""
    entry = _LOOKUPS[0]
    if (entry is None or entry[0]() is not x or entry[1] != _lookup_key(field, grid)
            or entry[2].shape[:2] != x.shape[:2]):
        return _NO_LOOKUPS
    return True, entry[2], entry[3]


# =========================================================================== the steppers

@reports_nonfinite
def simulate_dynamic(field, x0, v0, fext, dt: float, n_steps: int, mass, damping, progress=None,
                     refuse_nonfinite: bool = True, out=None, energy=None) -> Trajectory:
    """[`pes_ref.core.integrator.simulate_dynamic`][pes_ref.core.integrator.simulate_dynamic], compiled (same arguments,
    same numbers).
    ``energy``: a C-contiguous float64 (T+1, N) array that the loop fills with each state's
    total energy as it makes the state ([`pes_ref.core.scene.energy`][pes_ref.core.scene.energy]'s numbers, bit for
    bit; one grid), or None."""
    T, N = n_steps, x0.shape[0]
    x, v, f = trajectory_arrays(T, N, out)
    x[0], v[0] = x0, v0
    if energy is not None and field.offsets is not None:
        raise ValueError("a population's energy is not computed in its forward loop")
    direct = _direct(field)
    wraps, grid, spring, walls = _forward_terms(field, N, table=not direct[0])
    energy = _energy_terms(field, N, mass, energy)
    wraps = wraps or (energy[0] and energy_wraps(field))
    ext, has_fext = _c3(fext)
    a, c = step_coefficients(dt, mass, damping, N)
    damped = c is not None
    inv_1pc = 1.0 / (1.0 + c) if damped else _NONE2
    c = c if damped else _NONE2
    blocks = parallel_blocks(field, N) if N >= PARALLEL_MIN else _blocks(field, N)
    K = kernels(wraps, field)
    lookups = _lookups(field, x, grid)

    def run(b0, b1, start, stop):
        K.dynamic_steps(x, v, f, ext, has_fext, start, stop, blocks[b0:b1 + 1], a, c, inv_1pc, damped, float(dt), grid,
                        spring, walls, energy, lookups, direct)

    shares = _shares(blocks)
    for start, stop in step_blocks(T, progress, "forward"):         # from step 0: F_0 first
        _spread(run, shares, start, stop)
    traj = Trajectory(x, v, f)
    if refuse_nonfinite:
        check_finite(traj, f"dt={dt!r}", field)
    return traj


def adjoint_dynamic(field, traj: Trajectory, dt: float, mass, damping, gx, gv, want: frozenset,
                    progress=None) -> dict:
    """[`pes_ref.core.integrator.adjoint_dynamic`][pes_ref.core.integrator.adjoint_dynamic], compiled (same arguments
    and gradients;
    the grid's summed in another order, and in the grid's shape (n0, n1))."""
    x, v, f = (_kernel_array(a) for a in traj)
    T, N = x.shape[0] - 1, x.shape[1]
    adj = _Adjoint(field, x, want, threaded=N >= PARALLEL_MIN, direct=_direct(field))
    a, c = step_coefficients(dt, mass, damping, N)
    damped = c is not None
    inv_1pc, minus_c = (1.0 / (1.0 + c), -c) if damped else (_NONE2, _NONE2)
    want_mass, want_damping = "mass" in want, "damping" in want
    want_abar, want_cbar = want_mass, want_damping or (want_mass and damped)
    abar = np.zeros((N, 2)) if want_abar else None
    cbar = np.zeros((N, 2)) if want_cbar else None
    gforce = pages.empty((T + 1, N, 2)) if "force" in want else None     # every state written
    gx_, has_gx = _c3(gx)
    gv_, has_gv = _c3(gv)
    xbar = np.zeros((N, 2)) if gx is None else gx[T].copy()
    vbar = np.zeros((N, 2)) if gv is None else gv[T].copy()
    fbar = np.zeros((N, 2))
    lookups = _kept_lookups(field, x, adj.grid)

    def run(l0, l1, start, stop):
        adj.kernels.dynamic_adjoint_steps(x, v, f, gx_, has_gx, gv_, has_gv, start, stop, a, inv_1pc, minus_c, damped,
                                          float(dt), xbar, vbar, fbar, want_abar, _or(abar), want_cbar, _or(cbar),
                                          gforce is not None, _or3(gforce), *adj.lane_terms(l0, l1), lookups,
                                          adj.direct)

    shares = _shares(adj.blocks[adj.lanes])
    for done, after in step_blocks(T, progress, "adjoint"):
        _spread(run, shares, T - after, T - done)
    return finish_dynamic_adjoint(adj, xbar, vbar, fbar, gforce, abar, cbar, a, c if damped else None, mass,
                                  want_damping, initial_force=False)      # (B0) was the loop's last


@reports_nonfinite
def simulate_quasistatic(field, x0, fext, mobility, n_steps: int, progress=None,
                         refuse_nonfinite: bool = True, out=None) -> Trajectory:
    """[`pes_ref.core.integrator.simulate_quasistatic`][pes_ref.core.integrator.simulate_quasistatic], compiled (same arguments, same numbers)."""
    T, N = n_steps, x0.shape[0]
    x, v, f = trajectory_arrays(T, N, out)
    x[0] = x0
    wraps, grid, spring, walls = _forward_terms(field, N)
    K = kernels(wraps, field)
    ext, has_fext = _c3(fext)
    mu = _as(mobility, N)
    blocks = _blocks(field, N)
    for start, stop in step_blocks(T, progress, "forward"):         # to step T: F_T last
        K.quasistatic_steps(x, f, ext, has_fext, start, stop, blocks, mu, grid, spring, walls)
    traj = Trajectory(x, quasistatic_velocities(v, out), f)
    if refuse_nonfinite:
        check_finite(traj, f"mobility={np.asarray(mobility).tolist()!r}", field)
    return traj


def adjoint_quasistatic(field, traj: Trajectory, mobility, gx, want: frozenset, progress=None) -> dict:
    """[`pes_ref.core.integrator.adjoint_quasistatic`][pes_ref.core.integrator.adjoint_quasistatic], compiled (the grid
    and mobility
    gradients summed in another order; the grid's in the grid's shape (n0, n1))."""
    x, f = _kernel_array(traj.x), _kernel_array(traj.f)
    T, N = x.shape[0] - 1, x.shape[1]
    adj = _Adjoint(field, x, want)
    gforce = pages.empty((T + 1, N, 2)) if "force" in want else None
    if gforce is not None:
        gforce[T] = 0.0                      # F_ext[T] moves nothing; the loop writes the others
    mubar = np.zeros(2) if "mobility" in want else None
    gx_, has_gx = _c3(gx)
    xbar = np.zeros((N, 2)) if gx is None else gx[T].copy()
    mu = _as(mobility, N)
    for done, after in step_blocks(T, progress, "adjoint"):
        adj.kernels.quasistatic_adjoint_steps(x, f, gx_, has_gx, T - after, T - done, mu, xbar, mubar is not None,
                                              np.zeros(2) if mubar is None else mubar, gforce is not None,
                                              _or3(gforce), *adj.terms())
    return finish_quasistatic_adjoint(adj, xbar, gforce, mubar)


def _or(a):
    return _NONE2 if a is None else a


def _or3(a):
    return _NONE3 if a is None else a


def _simulate_verlet(field, x0, v0, fext, p: StepParams):
    sink = p.energy if field.offsets is None else None           # (StepParams.energy: a population's is not)
    traj = simulate_dynamic(field, x0, v0, fext, p.dt, p.n_steps, p.mass, p.damping, p.progress, p.refuse_nonfinite,
                            p.out, None if sink is None else sink.out)
    if sink is not None:
        sink.filled = True
    return traj


def _adjoint_verlet(field, traj, p: StepParams, gx, gv, want):
    return adjoint_dynamic(field, traj, p.dt, p.mass, p.damping, gx, gv, want, p.progress)


def _simulate_quasistatic(field, x0, v0, fext, p: StepParams):
    return simulate_quasistatic(field, x0, fext, p.mobility, p.n_steps, p.progress, p.refuse_nonfinite, p.out)


def _adjoint_quasistatic(field, traj, p: StepParams, gx, gv, want):
    return adjoint_quasistatic(field, traj, p.mobility, gx, want, p.progress)


#: The compiled steppers by ``(mode, integrator)``: what `pes_ref.core.backends.BACKENDS`
#: ``"numba"`` covers (the GJF step runs on NumPy).
STEPPERS = {
    ("dynamic", "verlet"): Stepper(_simulate_verlet, _adjoint_verlet, NUMPY_STEPPERS[("dynamic", "verlet")].gradients),
    ("quasistatic", "verlet"): Stepper(_simulate_quasistatic, _adjoint_quasistatic,
                                       NUMPY_STEPPERS[("quasistatic", "verlet")].gradients),
}
