"""The whole method once, readably: the time stepping of docs/spec.md sections 2-5 and its
hand-derived adjoint, as plain NumPy functions of arrays, in the order and with the section
and equation numbers of ``docs/adjoint.md``.

The fast path ([`pes_ref.core.integrator`][pes_ref.core.integrator], [`gjf`][pes_ref.core.gjf],
[`forces`][pes_ref.core.forces], [`bilinear`][pes_ref.core.bilinear], [`bicubic`][pes_ref.core.bicubic])
computes the same numbers with per-surface tables, reusable buffers, chunked scatters
and bound closures. This module has none of those: every named sub-step is a small
function of arrays that returns new arrays, with its transpose (vector-Jacobian
product) directly beside it, in the manner of jax-md's ``momentum_step`` /
``position_step`` or of autograd registering each VJP next to its primitive. A transpose
``foo_T`` takes the cotangent of ``foo``'s output and returns the cotangents of its inputs
(``xbar`` = dL/dx).

Sections, numbered as ``docs/adjoint.md`` numbers them: the grid lookup (docs/spec.md section 2.3)
first; 1. the surface, the bilinear rule (A1)-(A3); 2. springs (A4) and walls (A5); 3. the total
force (A6); 4-5. dynamic mode, each sub-step (S1)-(S4) beside its transpose (B1)-(B4), then the
forward loop and the backward loop with (B0), (P1) and the reduction of a broadcast gradient to its
input's shape; 6. quasistatic mode, (Q1)-(Q2) and (QB1)-(QB2); 10. the Gronbech-Jensen-Farago option
(G1)-(G4) / (GB1)-(GB4), (GP1); 11. the bicubic option (C1)-(C4) / (CB1)-(CB3). Sections 7-9
(objectives, kinks, cost) have no code here: the objectives are
[`pes_ref.core.objectives`][pes_ref.core.objectives]'.
[`simulate`][pes_ref.core.reference.simulate], [`energy`][pes_ref.core.reference.energy] and
[`value_and_grad`][pes_ref.core.reference.value_and_grad] at the end take a
[`Scene`][pes_ref.core.scene.Scene] and have the signatures of the public ones (so the property
checks of [`pes_ref.testing`][pes_ref.testing] run on them too). Nothing is validated here: the
Scene was, when it was built.

Floating point. Where the fast path's order of operations is as readable as the
textbook one, this module uses it, so that most results are bit-identical:
(A1)'s ``(1-f1) a + f1 b`` is written ``a + f1 (b - a)`` with the differences scaled by
``-1/h`` first (as the fast path's coefficient table rounds it), (A2)'s cross term is
that same difference times ``-1/h0`` and ``-1/h1``, each kick adds its terms in the fast
path's order, and the undamped step is the damped one with ``gamma = 0`` (``c = 0``,
``d = 1``: bit-identical to skipping the damping operations, which the fast path does).
``tests/core/test_reference.py`` then asserts exact equality of the bilinear runs (x, v, f,
energy, loss and every gradient but ``values``, with either integrator). The grid
gradient is summed here per step by (A3) straight into the grid, while the fast path
sums per cell into its table and maps the table to the grid once: the same sum in
another order, equal to about 1e-15 relative. The bicubic option computes its cell
coefficients by matrix products (M0 G M1^T below) where the fast path uses stencils
and einsum: equal to rounding, and every number downstream differs in its last bits.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from pes_ref.core.grid import Cells
from pes_ref.core.integrator import step_coefficients
from pes_ref.core.objectives import regularization

__all__ = ["Terms", "Run", "terms_of", "lookup", "potential_energy", "force", "force_T",
           "forward", "backward", "reduce_to_shape", "simulate", "energy", "value_and_grad"]


class Terms(NamedTuple):
    """The energy terms of a scene as plain arrays (docs/spec.md sections 2-3).

    ``values`` (n0, n1); ``lower``, ``h``, ``length`` (2,); ``periodic`` (2,) bool;
    ``interpolation`` "bilinear" or "bicubic"; ``spring`` ``(k, center)`` or None;
    ``walls`` ``(k_w, a, b)`` or None, with ``a``/``b`` (2,) the lower/upper wall positions
    (``-inf``/``+inf`` where that wall is off).
    """

    values: np.ndarray
    lower: np.ndarray
    h: np.ndarray
    length: np.ndarray
    periodic: np.ndarray
    interpolation: str
    spring: tuple | None
    walls: tuple | None


def terms_of(scene) -> Terms:
    """Read a Scene's energy terms: spacing ``h_d = L_d / n_d`` on a periodic axis, else
    ``L_d / (n_d - 1)``; walls a margin inside their enabled edges (docs/spec.md sections 2-3)."""
    s = scene.surface
    periodic = np.array(s.periodic)
    n = np.array(s.values.shape, dtype=np.float64)
    h = (s.upper - s.lower) / np.where(periodic, n, n - 1.0)
    spring = None if scene.spring is None else (scene.spring.k, scene.spring.center)
    walls = None
    if scene.walls is not None:
        w = scene.walls
        walls = (w.k, np.where(w.edges[:, 0], s.lower + w.margin, -np.inf),
                 np.where(w.edges[:, 1], s.upper - w.margin, np.inf))
    return Terms(s.values, s.lower, h, s.upper - s.lower, periodic, s.interpolation, spring, walls)


# ========================================================== the grid lookup (docs/spec.md section 2.3)

# Where points fall is the core's one record of a lookup, `pes_ref.core.grid.Cells`:
# corner indices ``i0, i1`` (axis 0), ``j0, j1`` (axis 1), fractions ``f0, f1``, switches ``s0, s1``.

def lookup(terms: Terms, q: np.ndarray) -> Cells:
    """Cell, fraction, wrap and clip of points q (..., 2) (docs/spec.md section 2.3).

    ``u = (q_d - lower_d) / h_d``. Periodic axis: ``k = floor(u)``, ``f = u - k``, corners
    ``k mod n`` and ``(k + 1) mod n``, ``s = 1``. Non-periodic axis: ``uc = clip(u, 0,
    n - 1)``, ``k = min(floor(uc), n - 2)``, ``f = uc - k``, corners ``k`` and ``k + 1``,
    ``s = 1`` if ``0 <= u <= n - 1`` else 0 (outside, the surface is constant along the axis).
    """
    out = []
    for d in range(2):
        n = terms.values.shape[d]
        u = (q[..., d] - terms.lower[d]) / terms.h[d]
        if terms.periodic[d]:
            k = np.floor(u)
            f = u - k
            lo, hi, s = np.mod(k, n), np.mod(k + 1, n), np.ones_like(u)
        else:
            uc = np.clip(u, 0.0, n - 1.0)
            k = np.minimum(np.floor(uc), n - 2)
            f = uc - k
            lo, hi, s = k, k + 1, ((u >= 0.0) & (u <= n - 1.0)).astype(np.float64)
        out.append((lo.astype(np.intp), hi.astype(np.intp), f, s))
    (i0, i1, f0, s0), (j0, j1, f1, s1) = out
    return Cells(i0, i1, j0, j1, f0, f1, s0, s1)


# ======================================================== 1. the surface: the bilinear rule, (A1)-(A3)

def _corners(G: np.ndarray, c: Cells):
    """``G00 = G[i0,j0], G10 = G[i1,j0], G01 = G[i0,j1], G11 = G[i1,j1]``, each (...)."""
    return G[c.i0, c.j0], G[c.i1, c.j0], G[c.i0, c.j1], G[c.i1, c.j1]


def bilinear_energy(terms: Terms, c: Cells) -> np.ndarray:
    """E = (1-f0)(1-f1) G00 + f0(1-f1) G10 + (1-f0) f1 G01 + f0 f1 G11, shape (...) (docs/spec.md 2.4)."""
    g00, g10, g01, g11 = _corners(terms.values, c)
    f0, f1 = c.f0, c.f1
    return (1 - f0) * (1 - f1) * g00 + f0 * (1 - f1) * g10 + (1 - f0) * f1 * g01 + f0 * f1 * g11


def bilinear_force(terms: Terms, c: Cells) -> np.ndarray:
    """The grid force ``-dE/dq`` (..., 2), eq. (A1) written as ``s (A + f D)``.

    (A1)'s ``-s0/h0 [(1-f1)(G10 - G00) + f1 (G11 - G01)]`` is ``s0 (A0 + f1 D0)`` with
    ``A0 = -(G10 - G00)/h0`` and ``D0 = -((G11 - G01) - (G10 - G00))/h0`` (and the same
    with the axes swapped): affine in the other axis's fraction.
    """
    g00, g10, g01, g11 = _corners(terms.values, c)
    nih0, nih1 = -1.0 / terms.h[0], -1.0 / terms.h[1]
    A0, D0 = (g10 - g00) * nih0, ((g11 - g01) - (g10 - g00)) * nih0
    A1, D1 = (g01 - g00) * nih1, ((g11 - g10) - (g01 - g00)) * nih1
    return np.stack((c.s0 * (A0 + c.f1 * D0), c.s1 * (A1 + c.f0 * D1)), axis=-1)


def bilinear_force_T(terms: Terms, c: Cells, w: np.ndarray, xbar: np.ndarray, gvalues: np.ndarray) -> None:
    """Transpose of [`bilinear_force`][pes_ref.core.reference.bilinear_force] for the cotangent w (N, 2), accumulated in
    place.

    Position, (A2): inside a cell the Hessian is ``[[0, Hc], [Hc, 0]]`` with ``Hc = s0 s1
    (G11 - G10 - G01 + G00) / (h0 h1)``, so ``xbar += -H w = -(Hc w1, Hc w0)``.
    Grid values, (A3): with ``A = s0 w0/h0``, ``B = s1 w1/h1`` the slope's transpose
    scatters the weights below onto the four corners; the force is minus the slope.
    """
    g00, g10, g01, g11 = _corners(terms.values, c)
    hc = ((g11 - g01) - (g10 - g00)) * (-1.0 / terms.h[0]) * (-1.0 / terms.h[1]) * c.s0 * c.s1
    xbar[:, 0] -= hc * w[:, 1]
    xbar[:, 1] -= hc * w[:, 0]
    A = c.s0 * w[:, 0] / terms.h[0]
    B = c.s1 * w[:, 1] / terms.h[1]
    f0, f1 = c.f0, c.f1
    np.subtract.at(gvalues, (c.i0, c.j0), -(1 - f1) * A - (1 - f0) * B)
    np.subtract.at(gvalues, (c.i1, c.j0), (1 - f1) * A - f0 * B)
    np.subtract.at(gvalues, (c.i0, c.j1), -f1 * A + (1 - f0) * B)
    np.subtract.at(gvalues, (c.i1, c.j1), f1 * A + f0 * B)


# ====================================================================== 2. springs (A4) and walls (A5)

def spring_delta(terms: Terms, q: np.ndarray) -> np.ndarray:
    """``delta = q - c``, the minimum image ``((q - c + L/2) mod L) - L/2`` on a periodic axis."""
    delta = q - terms.spring[1]
    for d in range(2):
        if terms.periodic[d]:
            half = 0.5 * terms.length[d]
            delta[..., d] = np.mod(delta[..., d] + half, terms.length[d]) - half
    return delta


def spring_energy(terms: Terms, q: np.ndarray) -> np.ndarray:
    """``U = sum_d k_d delta_d^2 / 2``, shape (...)."""
    delta = spring_delta(terms, q)
    return 0.5 * np.sum(terms.spring[0] * delta * delta, axis=-1)


def spring_force(terms: Terms, q: np.ndarray) -> np.ndarray:
    """``F = -k delta`` (..., 2)."""
    return -(terms.spring[0] * spring_delta(terms, q))


def spring_force_T(terms: Terms, q, w, xbar, kbar, cbar) -> None:
    """(A4): ``xbar += -k w``, ``kbar += -delta w``, ``cbar += k w`` (in place)."""
    kw = terms.spring[0] * w
    xbar -= kw
    kbar += -spring_delta(terms, q) * w
    cbar += kw


def wall_energy(terms: Terms, q: np.ndarray) -> np.ndarray:
    """``U = k_w/2 [(a - q)^+]^2 + k_w/2 [(q - b)^+]^2`` summed over the axes, shape (...)."""
    k_w, a, b = terms.walls
    below, above = np.maximum(a - q, 0.0), np.maximum(q - b, 0.0)
    return 0.5 * k_w * np.sum(below * below + above * above, axis=-1)


def wall_force(terms: Terms, q: np.ndarray) -> np.ndarray:
    """``F = k_w (a - q)^+ - k_w (q - b)^+`` (..., 2)."""
    k_w, a, b = terms.walls
    return k_w * (np.maximum(a - q, 0.0) - np.maximum(q - b, 0.0))


def wall_force_T(terms: Terms, q, w, xbar) -> None:
    """(A5): ``xbar += -k_w w`` where a wall is active (q < a or q > b)."""
    k_w, a, b = terms.walls
    xbar -= k_w * np.where((q < a) | (q > b), w, 0.0)


# ============================================================================ 3. the total force, (A6)

# The grid term comes from `GRID` (end of section 11): the bilinear rule of section 1 or
# the bicubic option of section 11.

def potential_energy(terms: Terms, q: np.ndarray) -> np.ndarray:
    """``U = U_grid + U_spring + U_wall`` at points q (..., 2), shape (...) (docs/spec.md section 3)."""
    c = lookup(terms, q)
    u = GRID[terms.interpolation][0](terms, c)
    if terms.spring is not None:
        u = u + spring_energy(terms, q)
    if terms.walls is not None:
        u = u + wall_energy(terms, q)
    return u


def force(terms: Terms, q: np.ndarray, fext_n: np.ndarray) -> np.ndarray:
    """(S3)/(Q1) ``F(q) + F_ext[n]``, with ``F = -dU/dq`` (N, 2)."""
    f = GRID[terms.interpolation][1](terms, lookup(terms, q))
    if terms.spring is not None:
        f += spring_force(terms, q)
    if terms.walls is not None:
        f += wall_force(terms, q)
    return f + fext_n


def force_T(terms: Terms, q, w, xbar, acc: dict) -> np.ndarray:
    """(B3)/(B0)/(QB1), the transpose of [`force`][pes_ref.core.reference.force] for the cotangent w (N, 2), eq. (A6):
    ``xbar += -H_U(q) w`` in place, the grid's and the spring's parameter cotangents into
    ``acc``; returns ``F_ext-bar[n] = w`` (the external force enters additively)."""
    GRID[terms.interpolation][2](terms, lookup(terms, q), w, xbar, acc["values"])
    if terms.spring is not None:
        spring_force_T(terms, q, w, xbar, acc["spring_k"], acc["spring_center"])
    if terms.walls is not None:
        wall_force_T(terms, q, w, xbar)
    return w.copy()


# ======================== 4-5. dynamic mode: the sub-steps (S1)-(S4) beside their transposes (B1)-(B4)

# (S3), the force sub-step, is `force` (section 3) and its transpose (B3) `force_T`.

def coefficients(dt, mass, damping, n):
    """``a = dt/(2m)``, ``c = dt gamma/(2m)``
    ([`pes_ref.core.integrator.step_coefficients`][pes_ref.core.integrator.step_coefficients]),
    ``d = 1/(1+c)``, ``e = (1-c) d``, each (N, 2); an undamped scene has ``gamma = 0``:
    ``c = 0``, ``d = e = 1``."""
    a, c = step_coefficients(dt, mass, 0.0 if damping is None else damping, n)
    d = 1.0 / (1.0 + c)
    return a, c, d, (1.0 - c) * d


def half_kick(v, f, a):
    """(S1) ``P = V_n + a F_n``."""
    return v + a * f


def half_kick_T(pbar, f, a):
    """(B1): ``(Vbar_n, Fbar_n, abar)`` contributions ``(Pbar, a Pbar, F_n Pbar)``."""
    return pbar, a * pbar, f * pbar


def drift(x, p, dt):
    """(S2) ``X_{n+1} = X_n + dt P``."""
    return x + dt * p


def drift_T(xbar, dt):
    """(B2): ``(Xbar_n, Pbar)`` contributions ``(Xbar_{n+1}, dt Xbar_{n+1})``."""
    return xbar, dt * xbar


def kick(p, v, f_next, a, c, d):
    """(S4) ``V_{n+1} = (P - c V_n + a F_{n+1}) d``, ``d = 1/(1 + c)`` (summed as the fast path
    sums it: ``P + a F_{n+1}``, then ``- c V_n``)."""
    return (p + a * f_next - c * v) * d


def kick_T(vbar_next, v, v_next, f_next, a, c, d):
    """(B4): ``(Pbar, Vbar_n, Fbar_{n+1}, abar, cbar)`` contributions, with ``Pbar = d Vbar_{n+1}``:
    ``(Pbar, -c Pbar, a Pbar, F_{n+1} Pbar, -(V_n + V_{n+1}) Pbar)`` (``dV_{n+1}/dc = -(V_n + V_{n+1}) d``)."""
    pbar = d * vbar_next
    return pbar, -c * pbar, a * pbar, f_next * pbar, -(v + v_next) * pbar


# ============================== 4-5. dynamic mode: the forward loop; the backward loop with (B0), (P1)

class Run(NamedTuple):
    """The T+1 states: ``x``, ``v`` (zeros in quasistatic mode), ``f`` (the total force
    ``F(X_n) + F_ext[n]``), each (T+1, N, 2)."""

    x: np.ndarray
    v: np.ndarray
    f: np.ndarray


def forward_verlet(terms, x0, v0, fext, dt, mass, damping, mobility) -> Run:
    """docs/spec.md section 5.2, dynamic: (S1)-(S4) for n = 0 .. T-1 after ``F_0 = F(X_0) + F_ext[0]``."""
    a, c, d, _ = coefficients(dt, mass, damping, x0.shape[0])
    x, v, f = [x0], [v0], [force(terms, x0, fext[0])]
    for n in range(fext.shape[0] - 1):
        p = half_kick(v[n], f[n], a)                      # (S1)
        x.append(drift(x[n], p, dt))                      # (S2)
        f.append(force(terms, x[n + 1], fext[n + 1]))     # (S3)
        v.append(kick(p, v[n], f[n + 1], a, c, d))        # (S4)
    return Run(np.array(x), np.array(v), np.array(f))


def _accumulators(terms: Terms, n: int) -> dict:
    """Zeroed parameter cotangents that [`force_T`][pes_ref.core.reference.force_T] sums into."""
    acc = {"values": np.zeros(terms.values.shape)}
    if terms.spring is not None:
        acc["spring_k"], acc["spring_center"] = np.zeros((n, 2)), np.zeros((n, 2))
    return acc


class BackwardStart(NamedTuple):
    """What both dynamic backward loops (sections 5 and 10) start from."""

    run: Run            # the forward states x, v, f, each (T+1, N, 2)
    T: int              # the number of steps
    a: np.ndarray       # the step's coefficients (`coefficients`), each (N, 2)
    c: np.ndarray
    d: np.ndarray
    e: np.ndarray
    acc: dict           # the grid's and the spring's parameter cotangents (`_accumulators`)
    gforce: np.ndarray  # F_ext-bar[n], (T+1, N, 2), zeros until each step's (B3) fills it
    xbar: np.ndarray    # Xbar = dl_T/dX_T
    vbar: np.ndarray    # Vbar = dl_T/dV_T
    fbar: np.ndarray    # Fbar = 0


def _backward_start(terms, run, gx, gv, dt, mass, damping) -> BackwardStart:
    """Section 5's start: ``Xbar = gx[T]``, ``Vbar = gv[T]``, ``Fbar = 0``, with the run's
    coefficients and zeroed accumulators."""
    T, N = run.x.shape[0] - 1, run.x.shape[1]
    a, c, d, e = coefficients(dt, mass, damping, N)
    return BackwardStart(run, T, a, c, d, e, _accumulators(terms, N), np.zeros(run.f.shape),
                         gx[T].copy(), gv[T].copy(), np.zeros((N, 2)))


def backward_verlet(terms, run, gx, gv, dt, mass, damping, mobility) -> dict:
    """Section 5 of ``docs/adjoint.md``: from ``Xbar = dl_T/dX_T``, ``Vbar = dl_T/dV_T``,
    ``Fbar = 0``, for n = T-1 .. 0 the transposes (B4), (B3), (B2), (B1) and the objective's
    direct terms; then (B0) and (P1)."""
    s = _backward_start(terms, run, gx, gv, dt, mass, damping)
    (x, v, f), a, c, d = s.run, s.a, s.c, s.d
    xbar, vbar, fbar = s.xbar, s.vbar, s.fbar
    abar, cbar = np.zeros(a.shape), np.zeros(a.shape)                                      # dL/da, dL/dc
    for n in range(s.T - 1, -1, -1):
        pbar, vbar, fbar_k, abar_k, cbar_k = kick_T(vbar, v[n], v[n + 1], f[n + 1], a, c, d)   # (B4)
        fbar = fbar + fbar_k
        abar = abar + abar_k
        cbar = cbar + cbar_k
        s.gforce[n + 1] = force_T(terms, x[n + 1], fbar, xbar, s.acc)                         # (B3)
        xbar, pbar_k = drift_T(xbar, dt)                                                       # (B2)
        pbar = pbar + pbar_k
        vbar_k, fbar, abar_k = half_kick_T(pbar, f[n], a)                                      # (B1)
        vbar = vbar + vbar_k
        abar = abar + abar_k
        xbar = xbar + gx[n]
        vbar = vbar + gv[n]
    s.gforce[0] = force_T(terms, x[0], fbar, xbar, s.acc)                                      # (B0)
    gmass, gdamping = mass_damping_T(abar, cbar, a, c, mass)                                   # (P1)
    return dict(s.acc, x0=xbar, v0=vbar, force=s.gforce, mass=gmass, damping=gdamping)


def mass_damping_T(abar, cbar, a, c, mass):
    """(P1): ``dL/dm = -(abar a + cbar c)/m``, ``dL/dgamma = cbar a``, each (N, 2)."""
    return (-abar * a - cbar * c) / np.broadcast_to(mass, a.shape), cbar * a


def reduce_to_shape(g: np.ndarray, shape: tuple) -> np.ndarray:
    """The transpose of ``np.broadcast_to(input, g.shape)``: sum the leading axes that
    broadcasting added, then (keeping them) the axes where the input has length 1."""
    g = g.sum(axis=tuple(range(g.ndim - len(shape))))
    g = g.sum(axis=tuple(i for i, s in enumerate(shape) if s == 1 and g.shape[i] != 1), keepdims=True)
    return g.reshape(shape)


# ====================================================== 6. quasistatic mode: (Q1)-(Q2) and (QB1)-(QB2)

# (Q1), the force sub-step, is `force` (section 3) and its transpose (QB1) `force_T`.

def qs_drift(x, f, mu):
    """(Q2) ``X_{n+1} = X_n + mu F_n``."""
    return x + mu * f


def qs_drift_T(xbar, f, mu):
    """(QB2): ``(Xbar_n, Fbar_n, mubar)`` contributions ``(Xbar_{n+1}, mu Xbar_{n+1}, sum_i F_n Xbar_{n+1})``."""
    return xbar, mu * xbar, np.einsum("id,id->d", f, xbar)


def forward_quasistatic(terms, x0, v0, fext, dt, mass, damping, mobility) -> Run:
    """docs/spec.md section 5.3, quasistatic: (Q1)-(Q2) for n = 0 .. T-1, then ``F_T`` (it moves nothing)."""
    x, f = [x0], []
    for n in range(fext.shape[0] - 1):
        f.append(force(terms, x[n], fext[n]))             # (Q1)
        x.append(qs_drift(x[n], f[n], mobility))          # (Q2)
    f.append(force(terms, x[-1], fext[-1]))
    return Run(np.array(x), np.zeros((len(x),) + x0.shape), np.array(f))


def backward_quasistatic(terms, run, gx, gv, dt, mass, damping, mobility) -> dict:
    """Section 6 of ``docs/adjoint.md``: from ``Xbar = dl_T/dX_T``, for n = T-1 .. 0 (QB2),
    (QB1) and the objective's direct term. ``F_ext[T]`` moves nothing: its cotangent is 0."""
    x, _, f = run
    T, N = x.shape[0] - 1, x.shape[1]
    acc = _accumulators(terms, N)
    gforce, mubar = np.zeros(f.shape), np.zeros(2)
    mu = np.broadcast_to(mobility, (N, 2))
    xbar = gx[T].copy()
    for n in range(T - 1, -1, -1):
        xbar, fbar, mubar_k = qs_drift_T(xbar, f[n], mu)                                       # (QB2)
        mubar = mubar + mubar_k
        gforce[n] = force_T(terms, x[n], fbar, xbar, acc)                                     # (QB1)
        xbar = xbar + gx[n]
    return dict(acc, x0=xbar, force=gforce, mobility=mubar)


# ============================================ 10. option: the GJF step, (G1)-(G4) / (GB1)-(GB4), (GP1)

def gjf_drift(x, p, dt, d):
    """(G2) ``X_{n+1} = X_n + dt d P``."""
    return x + (dt * d) * p


def gjf_drift_T(xbar, p, dt, d):
    """(GB2): ``(Xbar_n, Pbar, dbar)`` contributions ``(Xbar_{n+1}, dt d Xbar_{n+1}, dt P Xbar_{n+1})``."""
    return xbar, (dt * d) * xbar, dt * p * xbar


def gjf_kick(p, f_next, a, e):
    """(G4) ``V_{n+1} = e P + a F_{n+1}``, ``e = (1 - c) d``."""
    return a * f_next + e * p


def gjf_kick_T(vbar_next, p, f_next, a, e):
    """(GB4): ``(Pbar, Fbar_{n+1}, abar, ebar)`` contributions ``(e Vbar, a Vbar, F_{n+1} Vbar, P Vbar)``."""
    return e * vbar_next, a * vbar_next, f_next * vbar_next, p * vbar_next


def forward_gjf(terms, x0, v0, fext, dt, mass, damping, mobility) -> Run:
    """The GJF option: (G1)-(G4) for n = 0 .. T-1 after ``F_0``."""
    a, _, d, e = coefficients(dt, mass, damping, x0.shape[0])
    x, v, f = [x0], [v0], [force(terms, x0, fext[0])]
    for n in range(fext.shape[0] - 1):
        p = half_kick(v[n], f[n], a)                      # (G1)
        x.append(gjf_drift(x[n], p, dt, d))               # (G2)
        f.append(force(terms, x[n + 1], fext[n + 1]))     # (G3)
        v.append(gjf_kick(p, f[n + 1], a, e))             # (G4)
    return Run(np.array(x), np.array(v), np.array(f))


def backward_gjf(terms, run, gx, gv, dt, mass, damping, mobility) -> dict:
    """Section 10 of ``docs/adjoint.md``: for n = T-1 .. 0, (GB4), (GB3), (GB2), (GB1) (P
    recomputed by (G1)); ``sbar = dbar + 2 ebar`` is summed as it comes; then (GP1)
    ``cbar = -d^2 sbar``, (B0) and (P1)."""
    s = _backward_start(terms, run, gx, gv, dt, mass, damping)
    (x, v, f), a, c, d, e = s.run, s.a, s.c, s.d, s.e
    xbar, vbar, fbar = s.xbar, s.vbar, s.fbar
    abar, sbar = np.zeros(a.shape), np.zeros(a.shape)                                      # dL/da, dbar + 2 ebar
    for n in range(s.T - 1, -1, -1):
        p = half_kick(v[n], f[n], a)                                                           # (G1)
        pbar, fbar_k, abar_k, ebar_k = gjf_kick_T(vbar, p, f[n + 1], a, e)                     # (GB4)
        fbar = fbar + fbar_k
        abar = abar + abar_k
        sbar = sbar + 2.0 * ebar_k
        s.gforce[n + 1] = force_T(terms, x[n + 1], fbar, xbar, s.acc)                         # (GB3)
        xbar, pbar_k, dbar_k = gjf_drift_T(xbar, p, dt, d)                                     # (GB2)
        pbar = pbar + pbar_k
        sbar = sbar + dbar_k
        vbar, fbar, abar_k = half_kick_T(pbar, f[n], a)                                        # (GB1)
        abar = abar + abar_k
        xbar = xbar + gx[n]
        vbar = vbar + gv[n]
    s.gforce[0] = force_T(terms, x[0], fbar, xbar, s.acc)                                      # (B0)
    gmass, gdamping = mass_damping_T(abar, -(d * d) * sbar, a, c, mass)                       # (GP1), (P1)
    return dict(s.acc, x0=xbar, v0=vbar, force=s.gforce, mass=gmass, damping=gdamping)


# ============================================ 11. option: the bicubic surface, (C1)-(C4) / (CB1)-(CB3)

#: K of (C1): Catmull-Rom power coefficients (rows f^0..f^3) from the nodes c-1 .. c+2.
CATMULL_ROM = 0.5 * np.array([[0.0, 2.0, 0.0, 0.0], [-1.0, 0.0, 1.0, 0.0],
                              [2.0, -5.0, 4.0, -1.0], [-1.0, 3.0, -3.0, 1.0]])


def _cell_map(n: int, periodic: bool) -> np.ndarray:
    """(C1) along one axis as a matrix M (4 m, n): row ``4 c + k`` gives the coefficient of
    ``f^k`` on cell c as a combination of the n nodes. The extended nodes -1 .. m+1 wrap
    (periodic) or are the ghosts ``3 g0 - 3 g1 + g2`` (``2 g0 - g1`` with 2 nodes), mirrored."""
    eye = np.eye(n)
    if periodic:
        ext = eye[np.arange(-1, n + 2) % n]
    else:
        wts = (3.0, -3.0, 1.0) if n >= 3 else (2.0, -1.0)
        low = sum(wt * eye[i] for i, wt in enumerate(wts))
        high = sum(wt * eye[n - 1 - i] for i, wt in enumerate(wts))
        ext = np.vstack((low, eye, high))
    return np.vstack([CATMULL_ROM @ ext[cell:cell + 4] for cell in range(ext.shape[0] - 3)])


def _cell_maps(terms: Terms):
    return (_cell_map(terms.values.shape[0], bool(terms.periodic[0])),
            _cell_map(terms.values.shape[1], bool(terms.periodic[1])))


def cell_coefficients(terms: Terms) -> np.ndarray:
    """(C1) ``A[c0, c1] = K E_ext[c0-1..c0+2, c1-1..c1+2] K^T`` for every cell, as
    ``M0 G M1^T``; shape (m0, m1, 4, 4), entry ``[.., k, l]`` the coefficient of ``f0^k f1^l``."""
    M0, M1 = _cell_maps(terms)
    return (M0 @ terms.values @ M1.T).reshape(M0.shape[0] // 4, 4, M1.shape[0] // 4, 4).transpose(0, 2, 1, 3)


def cell_coefficients_T(terms: Terms, abar: np.ndarray) -> np.ndarray:
    """(CB3), the transpose of [`cell_coefficients`][pes_ref.core.reference.cell_coefficients]: ``Gbar = M0^T Abar M1`` (n0, n1)."""
    M0, M1 = _cell_maps(terms)
    return M0.T @ abar.transpose(0, 2, 1, 3).reshape(M0.shape[0], M1.shape[0]) @ M1


def _powers(f: np.ndarray):
    """``p = (1, f, f^2, f^3)`` and its first and second derivatives in f, each (..., 4)."""
    one, zero = np.ones_like(f), np.zeros_like(f)
    return (np.stack((one, f, f * f, f * f * f), axis=-1), np.stack((zero, one, 2 * f, 3 * f * f), axis=-1),
            np.stack((zero, zero, 2 * one, 6 * f), axis=-1))


def _form(p, A, q):
    """``p^T A q`` per point: (..., 4), (..., 4, 4), (..., 4) -> (...)."""
    return np.einsum("...k,...kl,...l->...", p, A, q)


def bicubic_energy(terms: Terms, c: Cells) -> np.ndarray:
    """(C2) ``E = p(f0)^T A p(f1)``, shape (...)."""
    A = cell_coefficients(terms)[c.i0, c.j0]
    return _form(_powers(c.f0)[0], A, _powers(c.f1)[0])


def bicubic_force(terms: Terms, c: Cells) -> np.ndarray:
    """Minus (C3): ``-(s0/h0 p'(f0)^T A p(f1), s1/h1 p(f0)^T A p'(f1))``, shape (..., 2)."""
    A = cell_coefficients(terms)[c.i0, c.j0]
    (p0, d0, _), (p1, d1, _) = _powers(c.f0), _powers(c.f1)
    h = terms.h
    return -np.stack((c.s0 / h[0] * _form(d0, A, p1), c.s1 / h[1] * _form(p0, A, d1)), axis=-1)


def bicubic_hessian(terms: Terms, c: Cells, A: np.ndarray):
    """(C4) ``H00, H01 (= H10), H11`` per point, each (N,), for the points' cell coefficients ``A``."""
    (p0, d0, dd0), (p1, d1, dd1) = _powers(c.f0), _powers(c.f1)
    h = terms.h
    h00 = c.s0 / (h[0] * h[0]) * _form(dd0, A, p1)
    h01 = c.s0 * c.s1 / (h[0] * h[1]) * _form(d0, A, d1)
    h11 = c.s1 / (h[1] * h[1]) * _form(p0, A, dd1)
    return h00, h01, h11


def bicubic_force_T(terms: Terms, c: Cells, w: np.ndarray, xbar: np.ndarray, gvalues: np.ndarray) -> None:
    """Transpose of [`bicubic_force`][pes_ref.core.reference.bicubic_force] for the cotangent w (N, 2), accumulated in
    place:
    (CB1) ``xbar += -H w`` with H by (C4); (CB2) the slope's transpose onto the cell
    coefficients, ``Abar``; (CB3) ``Abar`` onto the grid values, ``gvalues += -(d slope/dG)^T w``."""
    A = cell_coefficients(terms)[c.i0, c.j0]
    h00, h01, h11 = bicubic_hessian(terms, c, A)
    xbar -= np.stack((h00 * w[:, 0] + h01 * w[:, 1], h01 * w[:, 0] + h11 * w[:, 1]), axis=1)   # (CB1)
    (p0, d0, _), (p1, d1, _) = _powers(c.f0), _powers(c.f1)
    h = terms.h
    alpha = (c.s0 * w[:, 0] / h[0])[:, None, None]
    beta = (c.s1 * w[:, 1] / h[1])[:, None, None]
    abar = np.zeros(cell_coefficients(terms).shape)
    np.add.at(abar, (c.i0, c.j0),                                                               # (CB2)
              alpha * d0[:, :, None] * p1[:, None, :] + beta * p0[:, :, None] * d1[:, None, :])
    gvalues -= cell_coefficients_T(terms, abar)                                                 # (CB3)


#: The grid term by interpolation: (energy, force, force_T).
GRID = {"bilinear": (bilinear_energy, bilinear_force, bilinear_force_T),
        "bicubic": (bicubic_energy, bicubic_force, bicubic_force_T)}


# ============= the scene interface: the loops by mode and integrator; simulate, energy, value_and_grad

#: (forward, backward) by mode and integrator.
STEPPERS = {("dynamic", "verlet"): (forward_verlet, backward_verlet),
            ("dynamic", "gjf"): (forward_gjf, backward_gjf),
            ("quasistatic", "verlet"): (forward_quasistatic, backward_quasistatic)}


def forward(terms, x0, v0, fext, stepper, **params) -> Run:
    """The forward loop of ``stepper`` (a key of `STEPPERS`); ``params`` are
    ``dt, mass, damping, mobility``."""
    return STEPPERS[stepper][0](terms, x0, v0, fext, **params)


def backward(terms, run, gx, gv, stepper, **params) -> dict:
    """The backward loop of ``stepper`` for the objective's direct derivatives ``gx, gv``
    (T+1, N, 2): the raw gradients (per particle, before [`reduce_to_shape`][pes_ref.core.reference.reduce_to_shape])."""
    return STEPPERS[stepper][1](terms, run, gx, gv, **params)


def _setup(scene, x0, v0, fext):
    """Plain arrays of a Scene and an initial state; ``fext`` "scene" (the schedule its
    effects realize), None (none) or an array; a missing force is zeros."""
    x0 = np.array(x0, dtype=np.float64)
    v0 = np.zeros(x0.shape) if v0 is None else np.array(v0, dtype=np.float64)
    if isinstance(fext, str):
        fext = scene.schedule(x0.shape[0])
    fext = np.zeros((scene.n_steps + 1,) + x0.shape) if fext is None else np.asarray(fext, dtype=np.float64)
    params = dict(dt=scene.dt, mass=scene.mass, damping=scene.damping, mobility=scene.mobility)
    stepper = (scene.mode, scene.integrator)
    return terms_of(scene), x0, v0, fext, stepper, params


def simulate(scene, x0, v0=None, *, fext="scene") -> Run:
    """[`pes_ref.simulate`][pes_ref.core.scene.simulate], by the reference."""
    terms, x0, v0, fext, stepper, params = _setup(scene, x0, v0, fext)
    return forward(terms, x0, v0, fext, stepper, **params)


def energy(scene, run) -> np.ndarray:
    """[`pes_ref.energy`][pes_ref.core.scene.energy]: ``U(X_n) + sum_d m_d V_d^2 / 2`` per state and particle, (T+1, N)."""
    return potential_energy(terms_of(scene), run.x) + 0.5 * np.sum(scene.mass * run.v * run.v, axis=-1)


def value_and_grad(scene, x0, v0, objective, *, regularization_weight: float = 0.0, wrt=None, fext="scene"):
    """[`pes_ref.value_and_grad`][pes_ref.core.scene.value_and_grad], by the reference: ``(loss, grads, run)``, every
    gradient the scene has (or those named by ``wrt``), each shaped like its input."""
    terms, x0, v0, fext, stepper, params = _setup(scene, x0, v0, fext)
    run = forward(terms, x0, v0, fext, stepper, **params)
    times = scene.t0 + scene.dt * np.arange(scene.n_steps + 1, dtype=np.float64)
    loss, gx, gv = objective.value_and_grad(run.x, run.v, times)
    gx = np.zeros(run.x.shape) if gx is None else gx
    gv = np.zeros(run.v.shape) if gv is None else gv
    grads = backward(terms, run, gx, gv, stepper, **params)
    r_value, r_grad = regularization(scene.surface.values, float(regularization_weight))   # (O4) R sum G^2
    if r_grad is not None:
        loss = loss + r_value
        grads["values"] = grads["values"] + r_grad
    inputs = {"mass": scene.mass, "damping": 0.0 if scene.damping is None else scene.damping}
    if scene.spring is not None:
        inputs.update(spring_k=scene.spring.k, spring_center=scene.spring.center)
    for name, value in inputs.items():
        if name in grads:
            grads[name] = reduce_to_shape(grads[name], np.shape(value))
    if wrt is not None:
        grads = {name: grads[name] for name in ((wrt,) if isinstance(wrt, str) else wrt)}
    return loss, grads, run
