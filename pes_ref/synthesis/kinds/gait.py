"""Prescribed-gait multiple shooting for the oscillator: the cost and the starts.

Every training particle starts *on* the target cycle at a random phase ``theta``, on a random tooth
``k`` of a prescribed gait of q1 (an advance of ``delta`` per target period, like an escapement's
tooth), with a random torque from the whole range
([`sample_gait_starts`][pes_ref.synthesis.kinds.gait.sample_gait_starts]). It runs for one target
period and is charged [`GaitShooting`][pes_ref.synthesis.kinds.gait.GaitShooting], the distance to
where the gait says it should be. Each run is short, so its gradient through the adjoint is
informative (over several periods of chaotic motion it is not), and tying q1 to the phase breaks the
q1 symmetry that makes on-cycle starts with a random q1 pure noise.

The plan that optimizes it (Adam, 16 x 16 then 32 x 32) is ``OSCILLATOR_PLANS["gait"]``
in [`pes_ref.synthesis.common.plans`][pes_ref.synthesis.common.plans]; ``docs/synthesis.md`` ("The oscillator") has the formulas
and the measurements.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from pes_ref.core import checks

__all__ = ["GaitShooting", "GaitStarts", "sample_gait_starts", "gait_teeth"]


@dataclass(frozen=True, eq=False)
class GaitShooting:
    """Distance of each particle from its prescribed gait, averaged over steps and particles.

    Particle ``i`` is meant to follow the target cycle from phase ``theta_i`` with q1 on a
    gait that advances ``-delta`` per target period (q1 runs down under the torque):
    ``phi = theta_i + w t_n``, ``q1ref = q1_start_i - delta w t_n / (2 pi)``, and

    ``l_{n,i} = w0 [(X0 - A cos phi)^2 + ((V0 + A w sin phi) / w)^2] + w1 dz(X1 - q1ref)^2``

    with ``dz(d) = d - clip(d, -h, h)`` a dead zone of half-width ``h`` (``dead_zone``;
    ``delta / 4`` lets an escapement's stop-and-go cost nothing). The value is the mean of
    ``l`` over the ``T + 1`` states and ``N`` particles; ``value_and_grad(x, v, t)`` follows
    [`pes_ref.core.objectives`][pes_ref.core.objectives] and returns ``(value, dL/dX, dL/dV)``, each (T+1, N, 2).

    Parameters
    ----------
    amplitude, omega : float
        The target cycle ``A``, ``w`` (``omega > 0``).
    delta : float
        The gait's advance of q1 per target period (rad).
    theta, q1_start : (N,) arrays
        Each particle's phase and gait q1 at ``t = 0``
        ([`sample_gait_starts`][pes_ref.synthesis.kinds.gait.sample_gait_starts]).
    w0, w1 : float
        Weights of the cycle and gait terms.
    dead_zone : float
        Half-width ``h`` of the dead zone on q1.
    """

    amplitude: float
    omega: float
    delta: float
    theta: np.ndarray
    q1_start: np.ndarray
    w0: float = 30.0
    w1: float = 1.0
    dead_zone: float = math.pi / 8

    def __post_init__(self):
        theta = checks.as_float_array("theta", self.theta, ndim=1)
        q1_start = checks.as_float_array("q1_start", self.q1_start, ndim=1)
        if theta.shape != q1_start.shape:
            raise ValueError(f"theta and q1_start must have the same length, got {theta.size} and {q1_start.size}")
        object.__setattr__(self, "theta", theta)
        object.__setattr__(self, "q1_start", q1_start)
        object.__setattr__(self, "omega", checks.as_positive_float("omega", self.omega))
        object.__setattr__(self, "amplitude", checks.as_finite_float("amplitude", self.amplitude))
        object.__setattr__(self, "delta", checks.as_finite_float("delta", self.delta))
        for name in ("w0", "w1", "dead_zone"):
            object.__setattr__(self, name, checks.as_nonneg_float(name, getattr(self, name)))

    def reference(self, t):
        """``(phi, q1ref)``, each (T+1, N), at the times ``t`` (T+1,)."""
        t = np.asarray(t, dtype=np.float64)[:, None]
        phi = self.theta[None, :] + self.omega * t
        q1ref = self.q1_start[None, :] - self.delta * self.omega * t / (2 * math.pi)
        return phi, q1ref

    def value_and_grad(self, x, v, t):
        """The mean gait distance with its ``gx`` and ``gv``; the objective protocol of
        [`pes_ref.core.objectives`][pes_ref.core.objectives]; refuses a run of another particle count than ``theta``'s."""
        n_states, n = x.shape[0], x.shape[1]
        if n != self.theta.size:
            raise ValueError(f"the gait cost was built for {self.theta.size} particles, the run has {n}")
        A, w, h = self.amplitude, self.omega, self.dead_zone
        phi, q1ref = self.reference(t)
        ex = x[:, :, 0] - A * np.cos(phi)
        ev = (v[:, :, 0] + A * w * np.sin(phi)) / w
        d = x[:, :, 1] - q1ref
        z = d - np.clip(d, -h, h)
        scale = 1.0 / (n_states * n)
        value = scale * (self.w0 * np.sum(ex * ex + ev * ev) + self.w1 * np.sum(z * z))
        gx = np.empty(x.shape)        # both columns written below
        gv = np.zeros(v.shape)
        gx[:, :, 0] = 2.0 * scale * self.w0 * ex
        gx[:, :, 1] = 2.0 * scale * self.w1 * z
        gv[:, :, 0] = 2.0 * scale * self.w0 * ev / w
        return float(value), gx, gv


class GaitStarts(NamedTuple):
    """Shooting starts: positions and velocities (N, 2), torques (N,), phases (N,), gait q1 at t = 0 (N,)."""

    x0: np.ndarray
    v0: np.ndarray
    torques: np.ndarray
    theta: np.ndarray
    q1_start: np.ndarray


def gait_teeth(delta: float) -> int:
    """Teeth per turn of q1 of a gait advancing ``delta`` per period: ``round(2 pi / delta)``, at least 1."""
    return max(1, int(round(2 * math.pi / delta)))


def sample_gait_starts(problem, rng: np.random.Generator, n: int, delta: float,
                       amplitude: float | None = None) -> GaitStarts:
    """``n`` particles on the target cycle and on the prescribed gait, at rest nowhere.

    ``theta`` uniform in ``[0, 2 pi)``, tooth ``k`` uniform in ``0 .. gait_teeth(delta) - 1``,
    torque uniform in ``[problem.torque_min, problem.torque_max]`` (drawn in that order from
    ``rng``); then ``q0 = A cos theta``, ``v0 = -A w sin theta``,
    ``q1 = -k delta - delta theta / 2 pi``, ``v1 = -delta w / 2 pi``, with ``A`` the
    ``amplitude`` (default ``problem.amplitude``) and ``w = problem.omega``.
    """
    A = problem.amplitude if amplitude is None else amplitude
    w = problem.omega
    theta = rng.uniform(0.0, 2 * math.pi, n)
    k = rng.integers(0, gait_teeth(delta), n)
    torques = rng.uniform(problem.torque_min, problem.torque_max, n)
    q1 = -k * delta - delta * theta / (2 * math.pi)
    x0 = np.stack([A * np.cos(theta), q1], axis=1)
    v0 = np.stack([-A * w * np.sin(theta), np.full(n, -delta * w / (2 * math.pi))], axis=1)
    return GaitStarts(x0, v0, torques, theta, q1)
