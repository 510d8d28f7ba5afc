"""Energy terms beside the grid: springs and walls (SPEC section 2).

Each term is a small set of pure functions over plain arrays (energy, force added into
a buffer, and the adjoint of that force), plus a frozen, validated config
(:class:`Spring`, :class:`Walls`) that a :class:`~pes_ref.core.scene.Scene` names only when it
has the effect. The force is ``-dU/dq``; the adjoint functions implement
``docs/adjoint.md`` eqs. (A4)-(A5).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pes_ref.core import checks
from pes_ref.core.surface import _clip

__all__ = ["Spring", "Walls", "spring_delta", "spring_energy", "spring_add_force",
           "spring_force_vjp", "wall_bounds", "wall_energy", "wall_add_force", "wall_force_vjp",
           "SpringKernel", "WallKernel"]


# --------------------------------------------------------------------------- springs

def spring_delta(q: np.ndarray, center: np.ndarray, length: np.ndarray, periodic) -> np.ndarray:
    """Spring extension delta, shape (N, 2).

    ``delta_d = q_d - c_d`` on a non-periodic axis, the minimum image
    ``((q_d - c_d + L_d/2) mod L_d) - L_d/2`` on a periodic one (SPEC section 2).
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
    """out += -k * delta (the spring's force, SPEC section 2)."""
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
    """A linear spring per axis: U = sum_d k_d/2 delta_d^2 (SPEC section 2).

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
    """The wall force and its adjoint for N particles, with buffers (the integrator's hot loop).

    ``k (a - q)^+ - k (q - b)^+ = k (clip(q, a, b) - q)`` since ``a < b`` (bit-identical
    to :func:`wall_add_force`: one of the two terms is exactly 0), and the wall is active
    where ``clip(q, a, b) != q``: four whole-array operations per call instead of eight
    with temporaries.
    """

    def __init__(self, k: float, lo, hi, n_particles: int):
        self.k = np.array(float(k))
        self.lo = np.ascontiguousarray(np.broadcast_to(lo, (n_particles, 2)))
        self.hi = np.ascontiguousarray(np.broadcast_to(hi, (n_particles, 2)))
        self.buf = np.empty((n_particles, 2))
        self.mask = np.empty((n_particles, 2))      # 0.0 / 1.0: a float mask multiplies faster

    def add_force(self, q, out) -> None:
        """out += k (clip(q, a, b) - q)."""
        buf = self.buf
        _clip(q, self.lo, self.hi, out=buf)
        np.subtract(buf, q, out=buf)
        np.multiply(buf, self.k, out=buf)
        np.add(out, buf, out=out)

    def bind_add_force(self):
        """:meth:`add_force` as a closure over the buffers (for the hot loop)."""
        clip, sub, mul, add = _clip, np.subtract, np.multiply, np.add
        lo, hi, k, buf = self.lo, self.hi, self.k, self.buf

        def add_force(q, out):
            clip(q, lo, hi, buf)
            sub(buf, q, buf)
            mul(buf, k, buf)
            add(out, buf, out)
        return add_force

    #: States whose ``k (clip(q, a, b) != q)`` factors :meth:`bind_force_vjp` computes at once
    #: (in particle-states): three whole-chunk operations instead of three per state.
    CHUNK_ELEMENTS = 1 << 14

    def bind_force_vjp(self, xs: np.ndarray):
        """``force_vjp(n, w, xbar)`` for the stored states ``xs`` (T+1, N, 2), called for
        states in descending order (a backward pass): the factors ``k s`` with ``s = (clip(q,
        a, b) != q)`` are computed a chunk of states at a time, so that a state costs
        ``xbar -= (k s) w``, two operations (bit-identical to :meth:`force_vjp` up to the
        sign of a zero: s is 0 or 1)."""
        clip, ne, mul, sub = _clip, np.not_equal, np.multiply, np.subtract
        lo, hi, k, buf = self.lo, self.hi, self.k, self.buf
        n_states, n = xs.shape[0], xs.shape[1]
        chunk = max(1, min(n_states, self.CHUNK_ELEMENTS // max(n, 1)))
        ks = np.empty((chunk,) + xs.shape[1:])
        state = [n_states]          # the chunk holds states [state[0], state[0] + chunk)

        def force_vjp(n, w, xbar):
            if n < state[0]:
                start = max(0, n + 1 - chunk)
                m = n + 1 - start
                km, q = ks[:m], xs[start:n + 1]
                clip(q, lo, hi, km)
                ne(km, q, km)
                mul(km, k, km)
                state[0] = start
            mul(ks[n - state[0]], w, buf)
            sub(xbar, buf, xbar)
        return force_vjp

    def force_vjp(self, q, w, xbar) -> None:
        """xbar -= k w where a wall is active (eq. (A5))."""
        buf = self.buf
        _clip(q, self.lo, self.hi, out=buf)
        np.not_equal(buf, q, out=self.mask)
        np.multiply(w, self.mask, out=buf)
        np.multiply(buf, self.k, out=buf)
        np.subtract(xbar, buf, out=xbar)


class SpringKernel:
    """The spring force and its adjoint for N particles, with buffers (the hot loop).

    Same arithmetic as :func:`spring_add_force` / :func:`spring_force_vjp`, into
    preallocated buffers; the minimum image only on periodic axes."""

    def __init__(self, k, center, length, periodic, n_particles: int):
        self.k = np.ascontiguousarray(np.broadcast_to(k, (n_particles, 2)))
        self.center = np.ascontiguousarray(np.broadcast_to(center, (n_particles, 2)))
        self.wrap = [(d, 0.5 * float(length[d]), float(length[d])) for d in range(2) if periodic[d]]
        self.delta = np.empty((n_particles, 2))
        self.buf = np.empty((n_particles, 2))

    def _delta(self, q) -> np.ndarray:
        delta = self.delta
        np.subtract(q, self.center, out=delta)
        for d, half, L in self.wrap:
            col = delta[:, d]
            np.add(col, half, out=col)
            np.mod(col, L, out=col)
            np.subtract(col, half, out=col)
        return delta

    def add_force(self, q, out) -> None:
        """out -= k delta."""
        np.multiply(self.k, self._delta(q), out=self.buf)
        np.subtract(out, self.buf, out=out)

    def force_vjp(self, q, w, xbar, want_k: bool, want_center: bool):
        """xbar -= k w; returns (kbar, cbar) = (-delta w, k w) where wanted (eq. (A4))."""
        np.multiply(self.k, w, out=self.buf)
        np.subtract(xbar, self.buf, out=xbar)
        kbar = -self._delta(q) * w if want_k else None
        cbar = self.buf.copy() if want_center else None
        return kbar, cbar


@dataclass(frozen=True)
class Walls:
    """Harmonic walls a margin inside the enabled edges of non-periodic axes (SPEC section 2).

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
