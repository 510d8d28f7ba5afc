"""Energy terms beside the grid: springs and walls (docs/spec.md section 3).

Each term is a small set of pure functions over plain arrays (energy, force added into a buffer, and
the adjoint of that force), plus a frozen, validated config ([`Spring`][pes_ref.core.terms.Spring],
[`Walls`][pes_ref.core.terms.Walls]) that a [`Scene`][pes_ref.core.scene.Scene] names only when it
has the effect, plus the hot loop's kernels of the same arithmetic with buffers: a forward one
([`SpringKernel`][pes_ref.core.terms.SpringKernel], [`WallKernel`][pes_ref.core.terms.WallKernel],
each a [`TermForce`][pes_ref.core.kernels.TermForce]) and an adjoint one over the stored states
([`SpringAdjoint`][pes_ref.core.terms.SpringAdjoint],
[`WallAdjoint`][pes_ref.core.terms.WallAdjoint], each a
[`TermAdjoint`][pes_ref.core.kernels.TermAdjoint]). The force is ``-dU/dq``; the adjoints implement
``docs/adjoint.md`` eqs. (A4)-(A5).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pes_ref.core import checks
from pes_ref.core.grid import clip

__all__ = ["Spring", "Walls", "spring_delta", "spring_energy", "spring_add_force",
           "spring_force_vjp", "spring_axes", "wall_bounds", "wall_energy", "wall_add_force", "wall_force_vjp",
           "SpringKernel", "SpringAdjoint", "WallKernel", "WallAdjoint"]


# --------------------------------------------------------------------------- springs

def spring_delta(q: np.ndarray, center: np.ndarray, length: np.ndarray, periodic) -> np.ndarray:
    """Spring extension delta, shape (N, 2).

    ``delta_d = q_d - c_d`` on a non-periodic axis, the minimum image
    ``((q_d - c_d + L_d/2) mod L_d) - L_d/2`` on a periodic one (docs/spec.md section 3.1).
    """
    delta = q - center
    for d in range(2):
        if periodic[d]:
            half = 0.5 * length[d]
            delta[:, d] = np.mod(delta[:, d] + half, length[d]) - half
    return delta


def spring_energy(q, k, center, length, periodic) -> np.ndarray:
    """U = sum_d k_d/2 delta_d^2 per point, shape (N,)."""
    delta = spring_delta(q, center, length, periodic)
    return 0.5 * np.sum(k * delta * delta, axis=1)


def spring_add_force(q, k, center, length, periodic, out) -> None:
    """out += -k * delta (the spring's force, docs/spec.md section 3.1)."""
    out -= k * spring_delta(q, center, length, periodic)


def spring_force_vjp(q, k, center, length, periodic, w, xbar, want_k: bool, want_center: bool):
    """Adjoint of the spring force ``F = -k delta`` applied to ``w`` (eq. (A4)).

    Adds ``(dF/dq)^T w = -k w`` into ``xbar`` and returns ``(kbar, cbar)`` as (N, 2)
    arrays (``kbar = -delta w``, ``cbar = +k w``), or ``None`` where not wanted.
    """
    xbar -= k * w
    kbar = -spring_delta(q, center, length, periodic) * w if want_k else None
    cbar = k * w if want_center else None
    return kbar, cbar


@dataclass(frozen=True)
class Spring:
    """A linear spring per axis: U = sum_d k_d/2 delta_d^2 (docs/spec.md section 3.1).

    Parameters
    ----------
    k : array_like, broadcastable to (N, 2), >= 0
        Stiffness per axis (and optionally per particle).
    center : array_like, broadcastable to (N, 2)
        Rest position; on a periodic axis the minimum image is used.
    """

    k: np.ndarray
    center: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "k", checks.as_float_array("spring_k", self.k, broadcast_to=None, nonneg=True))
        object.__setattr__(self, "center", checks.as_float_array("spring_center", self.center))
        for name, arr in (("spring_k", self.k), ("spring_center", self.center)):
            if arr.ndim > 2 or (arr.ndim >= 1 and arr.shape[-1] not in (1, 2)):
                raise checks.InputError(name, f"{name} must broadcast to (N, 2), got shape {arr.shape}")


# --------------------------------------------------------------------------- walls

def wall_bounds(lower, upper, margin: float, walls: np.ndarray):
    """Wall positions per axis, each shape (2,): ``a_d = lower_d + w`` where the lower
    wall is enabled (else -inf), ``b_d = upper_d - w`` where the upper one is (else +inf)."""
    lo = np.where(walls[:, 0], lower + margin, -np.inf)
    hi = np.where(walls[:, 1], upper - margin, np.inf)
    return lo, hi


def wall_energy(q, k: float, lo, hi) -> np.ndarray:
    """U = k/2 (a - q)^2 below a, k/2 (q - b)^2 above b, else 0; shape (N,)."""
    below = np.maximum(lo - q, 0.0)
    above = np.maximum(q - hi, 0.0)
    return 0.5 * k * np.sum(below * below + above * above, axis=1)


def wall_add_force(q, k: float, lo, hi, out) -> None:
    """out += k (a - q)^+ - k (q - b)^+ (the walls' push back into the domain)."""
    out += k * (np.maximum(lo - q, 0.0) - np.maximum(q - hi, 0.0))


def wall_force_vjp(q, k: float, lo, hi, w, xbar) -> None:
    """Adjoint of the wall force applied to ``w`` (eq. (A5)): ``xbar += -k w`` where a
    wall is active (``q < a`` or ``q > b``), else nothing."""
    active = (q < lo) | (q > hi)
    xbar -= k * np.where(active, w, 0.0)


class WallKernel:
    """The wall force for N particles, with a buffer (the integrator's hot loop; a
    [`TermForce`][pes_ref.core.kernels.TermForce]).

    ``add_force(q, out)``, bound once here: ``out += k (clip(q, a, b) - q)``, which is
    ``k (a - q)^+ - k (q - b)^+`` since ``a < b`` (bit-identical to
    [`wall_add_force`][pes_ref.core.terms.wall_add_force]:
    one of the two terms is exactly 0): four whole-array operations per call instead of
    eight with temporaries. ``k``, ``lo`` and ``hi`` broadcast to (N, 2) (a population's
    walls differ per particle).
    """

    def __init__(self, k, lo, hi, n_particles: int):
        self.k = _per_particle(k, n_particles)
        self.lo = np.ascontiguousarray(np.broadcast_to(lo, (n_particles, 2)))
        self.hi = np.ascontiguousarray(np.broadcast_to(hi, (n_particles, 2)))
        self.buf = np.empty((n_particles, 2))
        self.add_force = self._bind()

    def _bind(self):
        clip_, sub, mul, add = clip, np.subtract, np.multiply, np.add
        lo, hi, k, buf = self.lo, self.hi, self.k, self.buf

        def add_force(q, out):
            clip_(q, lo, hi, buf)
            sub(buf, q, buf)
            mul(buf, k, buf)
            add(out, buf, out)
        return add_force


class WallAdjoint:
    """The adjoint of [`WallKernel`][pes_ref.core.terms.WallKernel] over stored states ``xs`` (T+1, N, 2) (eq. (A5);
    a [`TermAdjoint`][pes_ref.core.kernels.TermAdjoint]; the walls have no parameter gradients).

    ``force_vjp(n, w, xbar)``, bound once here and called for states in descending order
    (a backward pass): ``xbar -= k w`` where a wall is active (``clip(q, a, b) != q``). The
    factors ``k s`` with ``s = (clip(q, a, b) != q)`` are computed a chunk of states at a
    time, so that a state costs ``xbar -= (k s) w``, two operations (bit-identical to
    [`wall_force_vjp`][pes_ref.core.terms.wall_force_vjp]: s is 0 or 1 and k > 0).
    """

    #: Particle-states whose ``k s`` factors are computed at once: three whole-chunk
    #: operations instead of three per state.
    CHUNK_ELEMENTS = 1 << 14

    def __init__(self, k, lo, hi, xs: np.ndarray):
        n = xs.shape[1]
        self.k = _per_particle(k, n)
        self.lo = np.ascontiguousarray(np.broadcast_to(lo, (n, 2)))
        self.hi = np.ascontiguousarray(np.broadcast_to(hi, (n, 2)))
        self.xs = xs
        self.buf = np.empty((n, 2))
        self.force_vjp = self._bind()

    def _bind(self):
        clip_, ne, mul, sub = clip, np.not_equal, np.multiply, np.subtract
        lo, hi, k, buf, xs = self.lo, self.hi, self.k, self.buf, self.xs
        n_states, n = xs.shape[0], xs.shape[1]
        chunk = max(1, min(n_states, self.CHUNK_ELEMENTS // max(n, 1)))
        ks = np.empty((chunk,) + xs.shape[1:])
        state = [n_states]          # the chunk holds states [state[0], state[0] + chunk)

        def force_vjp(n, w, xbar):
            if n < state[0]:
                start = max(0, n + 1 - chunk)
                m = n + 1 - start
                km, q = ks[:m], xs[start:n + 1]
                clip_(q, lo, hi, km)
                ne(km, q, km)
                mul(km, k, km)
                state[0] = start
            mul(ks[n - state[0]], w, buf)
            sub(xbar, buf, xbar)
        return force_vjp

    def gradients(self) -> dict:
        """None wanted: the walls' stiffness and positions are not differentiable inputs."""
        return {}


def _per_particle(k, n_particles: int) -> np.ndarray:
    """A stiffness as the hot loop's operand: a 0-d array when it is one number, else
    contiguous (N, 2)."""
    k = np.asarray(k, dtype=np.float64)
    return k.copy() if k.ndim == 0 else np.ascontiguousarray(np.broadcast_to(k, (n_particles, 2)))


def spring_axes(k) -> tuple:
    """The axes on which a spring of stiffness ``k`` (broadcastable to (N, 2)) pulls some
    particle: those with a nonzero ``k_d``. On the others its force is ``-0 delta_d``, and
    the forward kernels compute no minimum image there (nor anything, on neither axis)."""
    k = np.asarray(k, dtype=np.float64)
    k = np.broadcast_to(k, np.broadcast_shapes(k.shape, (2,)))
    return tuple(d for d in range(2) if np.any(k[..., d]))


def _delta_into(q, center, wrap, out) -> np.ndarray:
    """[`spring_delta`][pes_ref.core.terms.spring_delta] into ``out``: ``q - c``, the minimum image on the axes of
    ``wrap``
    (``(d, L_d / 2, L_d)`` per periodic axis), the same operations."""
    np.subtract(q, center, out=out)
    for d, half, L in wrap:
        col = out[:, d]
        np.add(col, half, out=col)
        np.mod(col, L, out=col)
        np.subtract(col, half, out=col)
    return out


def _spring_arrays(k, center, length, periodic, n_particles: int, axes=(0, 1)):
    """``k`` and ``center`` as contiguous (N, 2) arrays and ``(d, L/2, L)`` of the periodic
    axes among ``axes``."""
    k = np.ascontiguousarray(np.broadcast_to(k, (n_particles, 2)))
    center = np.ascontiguousarray(np.broadcast_to(center, (n_particles, 2)))
    wrap = [(d, 0.5 * float(length[d]), float(length[d])) for d in axes if periodic[d]]
    return k, center, wrap


class SpringKernel:
    """The spring force for N particles, with buffers (the hot loop; a
    [`TermForce`][pes_ref.core.kernels.TermForce]).

    ``add_force(q, out)``, bound once here: ``out -= k delta``, the arithmetic of
    [`spring_add_force`][pes_ref.core.terms.spring_add_force] into preallocated buffers; the minimum image only on the
    periodic axes where the spring pulls ([`spring_axes`][pes_ref.core.terms.spring_axes]): on an axis whose ``k`` is 0
    everywhere ``out -= 0 delta`` changes no value, wrapped or not. Built only for a
    spring that pulls on some axis."""

    def __init__(self, k, center, length, periodic, n_particles: int):
        self.k, self.center, self.wrap = _spring_arrays(k, center, length, periodic, n_particles, spring_axes(k))
        self.delta = np.empty((n_particles, 2))
        self.buf = np.empty((n_particles, 2))
        self.add_force = self._bind()

    def _bind(self):
        mul, sub = np.multiply, np.subtract
        k, center, wrap, delta, buf = self.k, self.center, self.wrap, self.delta, self.buf

        def add_force(q, out):
            mul(k, _delta_into(q, center, wrap, delta), buf)
            sub(out, buf, out)
        return add_force


class SpringAdjoint:
    """The adjoint of [`SpringKernel`][pes_ref.core.terms.SpringKernel] over stored states ``xs`` (T+1, N, 2) (eq. (A4);
    a [`TermAdjoint`][pes_ref.core.kernels.TermAdjoint]).

    ``force_vjp(n, w, xbar)``, bound once here: ``xbar -= k w``, and as wanted
    ``spring_k += -delta w`` and ``spring_center += k w`` (N, 2), returned by
    `gradients` (the arithmetic of [`spring_force_vjp`][pes_ref.core.terms.spring_force_vjp] summed over the states).
    """

    def __init__(self, k, center, length, periodic, xs: np.ndarray, want_k: bool, want_center: bool):
        n = xs.shape[1]
        self.k, self.center, self.wrap = _spring_arrays(k, center, length, periodic, n)
        self.xs = xs
        self.grad_k = np.zeros((n, 2)) if want_k else None
        self.grad_center = np.zeros((n, 2)) if want_center else None
        self.delta = np.empty((n, 2))
        self.buf = np.empty((n, 2))
        self.force_vjp = self._bind()

    def _bind(self):
        mul, sub, add = np.multiply, np.subtract, np.add
        k, center, wrap, delta, buf, xs = self.k, self.center, self.wrap, self.delta, self.buf, self.xs
        gk, gc = self.grad_k, self.grad_center

        def force_vjp(n, w, xbar):
            mul(k, w, buf)
            sub(xbar, buf, xbar)
            if gk is not None:           # += (-delta) w, as -(delta w) exactly
                mul(_delta_into(xs[n], center, wrap, delta), w, delta)
                sub(gk, delta, gk)
            if gc is not None:
                add(gc, buf, gc)
        return force_vjp

    def gradients(self) -> dict:
        """``spring_k`` and ``spring_center`` (N, 2), those that were wanted."""
        out = {}
        if self.grad_k is not None:
            out["spring_k"] = self.grad_k
        if self.grad_center is not None:
            out["spring_center"] = self.grad_center
        return out


@dataclass(frozen=True)
class Walls:
    """Harmonic walls a margin inside the enabled edges of non-periodic axes (docs/spec.md section 3.2).

    Parameters
    ----------
    k : float > 0
        Wall stiffness ``k_w``.
    margin : float >= 0
        How far inside the edge each wall sits.
    edges : array_like of bool, shape (2, 2)
        ``edges[d, 0]`` the lower wall of axis d, ``edges[d, 1]`` the upper one.
    """

    k: float
    margin: float
    edges: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "k", checks.as_positive_float("wall_k", self.k))
        object.__setattr__(self, "margin", checks.as_nonneg_float("wall_margin", self.margin))
        object.__setattr__(self, "edges", checks.as_bool_array("walls", self.edges, shape=(2, 2)))
