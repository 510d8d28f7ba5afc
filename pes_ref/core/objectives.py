"""Trajectory objectives (docs/spec.md section 6) with their derivatives with respect to each state.

``L = sum_{n=0}^{T} l_n(X_n, V_n) + R sum_ij G_ij^2``. Every objective is a small
frozen object with one method::

    value_and_grad(x, v, t) -> (value, gx, gv)

taking the trajectory's positions and velocities (T+1, N, 2) and times (T+1,), and
returning the scalar ``sum_n l_n`` with ``gx = dL/dX_n`` and ``gv = dL/dV_n`` as
(T+1, N, 2) arrays (either may be ``None``, meaning zero, so an objective that ignores
velocities costs the adjoint nothing there). A user's own objective is any object with
that method, or a function wrapped in [`Custom`][pes_ref.core.objectives.Custom]. The regularization of the
paper's eq. (7) is [`regularization`][pes_ref.core.objectives.regularization].
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from pes_ref.core import checks
from pes_ref.core.runtime import pages

__all__ = ["Funnel", "Oscillator", "OscillatorCycle", "Quadratic", "Custom", "regularization", "OBJECTIVES"]


@dataclass(frozen=True)
class Funnel:
    """The funnel cost of the paper's eq. (5): ``l_n = sum_i (X_{n,i,0} - target)^2``.

    ``when = "final"`` counts only n = T; ``"every_step"`` every n. Derivative
    ``dl_n/dX_{n,i,0} = 2 (X_{n,i,0} - target)`` (``docs/adjoint.md`` eq. (O1)).
    """

    target: float = 0.0
    when: str = "final"

    def __post_init__(self):
        object.__setattr__(self, "target", checks.as_finite_float("target", self.target))
        object.__setattr__(self, "when", checks.as_choice("when", self.when, {"final", "every_step"}))

    def value_and_grad(self, x, v, t):
        """Eq. (5) and its ``gx`` (``gv`` is None); the objective protocol of
        [`pes_ref.core.objectives`][pes_ref.core.objectives] (docs/spec.md section 6.1)."""
        gx = pages.zeros(x.shape)       # np.zeros_like would write every zero of a new array
        if self.when == "final":
            e = x[-1, :, 0] - self.target
            gx[-1, :, 0] = 2.0 * e
            return float(np.sum(e * e)), gx, None
        # every step: one (T+1, N) temporary, 2 e written straight into gx, then squared in place
        e = np.subtract(x[:, :, 0], self.target)
        np.multiply(e, 2.0, out=gx[:, :, 0])
        np.multiply(e, e, out=e)
        return float(np.sum(e)), gx, None


@dataclass(frozen=True)
class Oscillator:
    """The oscillator cost of the paper's eq. (6), summed over every step.

    ``l_n = sqrt(sum_i e_x^2 + e_v^2) / N^2`` with ``e_x = X_{n,i,0} - A cos(w t_n)``
    and ``e_v = V_{n,i,0} + A w sin(w t_n)``; where the root's argument is 0 its
    derivative is taken as 0 (eq. (O2)).
    """

    amplitude: float
    omega: float

    def __post_init__(self):
        object.__setattr__(self, "amplitude", checks.as_finite_float("amplitude", self.amplitude))
        object.__setattr__(self, "omega", checks.as_finite_float("omega", self.omega))

    def value_and_grad(self, x, v, t):
        """Eq. (6) with its ``gx`` and ``gv``; the objective protocol of
        [`pes_ref.core.objectives`][pes_ref.core.objectives] (docs/spec.md section 6.2)."""
        n_particles = x.shape[1]
        A, w = self.amplitude, self.omega
        ex = x[:, :, 0] - (A * np.cos(w * t))[:, None]
        ev = v[:, :, 0] + (A * w * np.sin(w * t))[:, None]
        s = np.sum(ex * ex + ev * ev, axis=1)                       # (T+1,)
        root = np.sqrt(s)
        scale = n_particles ** 2
        inv = np.divide(1.0, root * scale, out=np.zeros_like(root), where=root > 0)
        gx = pages.zeros(x.shape)
        gv = pages.zeros(v.shape)
        gx[:, :, 0] = ex * inv[:, None]
        gv[:, :, 0] = ev * inv[:, None]
        return float(np.sum(root) / scale), gx, gv


@dataclass(frozen=True)
class OscillatorCycle:
    """A phase-free form of eq. (6): the distance to the target ellipse, not to one moving point.

    ``l_n = sqrt(sum_i e_{n,i}^2) / N^2`` for steps with ``t_n >= settle`` (0 before), with
    ``e = r - A`` and ``r = sqrt(X_{n,i,0}^2 + (V_{n,i,0} / w)^2)`` the radius in the phase
    plane scaled by w (a dead particle, r = 0, costs A like eq. (6)'s). Its zero set is the ellipse
    ``x^2 + (v/w)^2 = A^2``: every harmonic oscillation of amplitude A and frequency w at any
    phase, so a particle that keeps the cycle costs nothing whatever its phase slip (eq. (6)
    charges a phase slip as much as a dead oscillation). Beyond the paper. Derivatives
    ``dl_n/dX = e x / (r root N^2)``, ``dl_n/dV = e v / (w^2 r root N^2)``, taken as 0 where
    the root or r is 0.
    """

    amplitude: float
    omega: float
    settle: float = 0.0

    def __post_init__(self):
        for name in ("amplitude", "omega"):
            object.__setattr__(self, name, checks.as_positive_float(name, getattr(self, name)))
        object.__setattr__(self, "settle", checks.as_finite_float("settle", self.settle))

    def value_and_grad(self, x, v, t):
        """The cycle cost with its ``gx`` and ``gv``; the objective protocol of
        [`pes_ref.core.objectives`][pes_ref.core.objectives]."""
        n_particles = x.shape[1]
        A, w = self.amplitude, self.omega
        on = (np.asarray(t) >= self.settle)[:, None]
        r = np.sqrt(x[:, :, 0] ** 2 + (v[:, :, 0] / w) ** 2)
        e = np.where(on, r - A, 0.0)
        root = np.sqrt(np.sum(e * e, axis=1))
        scale = n_particles ** 2
        inv = np.divide(1.0, root * scale, out=np.zeros_like(root), where=root > 0)
        de = np.divide(e * inv[:, None], r, out=np.zeros_like(r), where=r > 0)
        gx = pages.zeros(x.shape)
        gv = pages.zeros(v.shape)
        gx[:, :, 0] = de * x[:, :, 0]
        gv[:, :, 0] = de * v[:, :, 0] / (w * w)
        return float(np.sum(root) / scale), gx, gv


@dataclass(frozen=True)
class Quadratic:
    """A quadratic tracking cost for conformance tests (docs/spec.md section 6.3).

    ``l_n = 1/2 sum_{i,d} [wx (X - xref)^2 + wv (V - vref)^2]``; ``wx, wv, xref, vref``
    broadcastable to (T+1, N, 2). Derivatives ``wx (X - xref)``, ``wv (V - vref)`` (eq. (O3)).
    """

    wx: np.ndarray = 1.0
    wv: np.ndarray = 0.0
    xref: np.ndarray = 0.0
    vref: np.ndarray = 0.0

    def __post_init__(self):
        for name in ("wx", "wv", "xref", "vref"):
            object.__setattr__(self, name, checks.as_float_array(name, getattr(self, name)))

    def check_shape(self, shape: tuple) -> None:
        """Refuse parameters that do not broadcast to the trajectory's (T+1, N, 2)."""
        for name in ("wx", "wv", "xref", "vref"):
            checks.as_float_array(name, getattr(self, name), broadcast_to=shape)

    def value_and_grad(self, x, v, t):
        """The quadratic cost with its ``gx`` (and ``gv``, None when ``wv`` is 0 everywhere), after
        [`check_shape`][pes_ref.core.objectives.Quadratic.check_shape]; the objective protocol of
        [`pes_ref.core.objectives`][pes_ref.core.objectives] (docs/spec.md
        section 6.3)."""
        self.check_shape(x.shape)
        dx = x - self.xref
        gx = self.wx * dx
        value = 0.5 * np.sum(gx * dx)
        gv = None
        if np.any(self.wv != 0):
            dv = v - self.vref
            gv = np.broadcast_to(self.wv * dv, v.shape).copy()
            value += 0.5 * np.sum(gv * dv)
        return float(value), np.broadcast_to(gx, x.shape).copy(), gv


@dataclass(frozen=True)
class Custom:
    """A user's own objective from a function ``fn(x, v, t) -> (value, gx, gv)``.

    ``gx`` and ``gv`` are dL/dX_n and dL/dV_n of shape (T+1, N, 2), or None for zero.
    Their shapes are checked once per call.
    """

    fn: Callable
    name: str = "custom"

    def __post_init__(self):
        if not callable(self.fn):
            raise TypeError(f"Custom.fn must be callable, got {self.fn!r}")

    def value_and_grad(self, x, v, t):
        """``fn(x, v, t)``, its value checked finite and ``gx``, ``gv`` checked of the states' shape;
        the objective protocol of [`pes_ref.core.objectives`][pes_ref.core.objectives]."""
        value, gx, gv = self.fn(x, v, t)
        value = checks.as_finite_float(f"{self.name} objective value", value)
        if gx is not None:
            gx = checks.as_float_array(f"{self.name} objective gx", gx, shape=x.shape)
        if gv is not None:
            gv = checks.as_float_array(f"{self.name} objective gv", gv, shape=v.shape)
        return value, gx, gv


OBJECTIVES = {"funnel": Funnel, "oscillator": Oscillator, "quadratic": Quadratic}


def regularization(values: np.ndarray, weight: float):
    """The paper's eq. (7): ``R sum_ij G_ij^2`` and its gradient ``2 R G`` (eq. (O4))."""
    if weight == 0.0:
        return 0.0, None
    return float(weight * np.sum(values * values)), 2.0 * weight * values
