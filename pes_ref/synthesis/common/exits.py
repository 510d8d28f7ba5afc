"""Where a funnel particle leaves the domain, and eq. (5) charged there.

A particle *exits* at the first state at or below the bottom edge ``q1 <= level``
([`exit_steps`][pes_ref.synthesis.common.exits.exit_steps]). The held-out evaluation measures its q0 there (`exit_positions`,
``in_band_fraction``), and [`FunnelExit`][pes_ref.synthesis.common.exits.FunnelExit] trains on the same quantity: the paper's
eq. (5), ``sum_i (x_i - x_0)^2``, with ``x_i`` read as the q0 at which particle ``i``
leaves the domain ("x_0 is the desired x value of particles exiting the domain"), not its
q0 at the end of the run, after it has coasted on below the edge. ``docs/synthesis.md``
(decision 8 and "The funnel") has the reasons and the measurements.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pes_ref.core import checks

__all__ = ["exit_steps", "FunnelExit"]


def exit_steps(x: np.ndarray, level: float, axis: int = 1, side: str = "lower") -> tuple[np.ndarray, np.ndarray]:
    """Each particle's exit step and whether it exits.

    ``x`` is a trajectory's positions (T+1, N, 2). Returns ``(step, exited)``, both (N,):
    ``step[i]`` is the first n with ``x[n, i, axis] <= level`` (``side="lower"``, the
    funnel's bottom edge by default) or ``>= level`` (``side="upper"``) when ``exited[i]``,
    else T (the last state).
    """
    q = x[:, :, axis]
    past = q <= level if side == "lower" else q >= level
    exited = past.any(axis=0)
    return np.where(exited, np.argmax(past, axis=0), x.shape[0] - 1), exited


@dataclass(frozen=True)
class FunnelExit:
    """Eq. (5) at each particle's exit: ``L = sum_i (X_{n_i, i, 0} - target)^2``.

    ``n_i`` is particle ``i``'s exit step ([`exit_steps`][pes_ref.synthesis.common.exits.exit_steps] at ``level``), or the last
    state T if it never exits, where the cost is eq. (5) at the final step. The exit step
    is piecewise constant in the grid values, so away from the values where some ``n_i``
    changes (a particle crossing ``level`` exactly on a step) the derivative is
    ``dL/dX_{n_i, i, 0} = 2 (X_{n_i, i, 0} - target)`` and zero at every other state.

    ``linger`` (>= 0, default 0) adds ``linger sum_i sum_{n <= n_i} (X_{n, i, 1} - level) dt``,
    the time each particle spends above the exit edge weighted by its height: a particle
    held on a ledge costs more the longer it stays. Eq. (5) at the final step alone pays a
    design for moving a held particle toward the target (a pocket drifts to the middle),
    which walls, unlike gentle slopes, easily do; this term pays it for letting the particle
    go (``docs/realize.md``). Its derivative is ``linger dt`` on ``X_{n, i, 1}`` for
    ``n <= n_i`` (``dt`` the spacing of ``t``).
    ``value_and_grad(x, v, t)`` follows [`pes_ref.core.objectives`][pes_ref.core.objectives].
    """

    target: float = 0.0
    level: float = 0.0
    linger: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "target", checks.as_finite_float("target", self.target))
        object.__setattr__(self, "level", checks.as_finite_float("level", self.level))
        object.__setattr__(self, "linger", checks.as_nonneg_float("linger", self.linger))

    def value_and_grad(self, x, v, t):
        """The exit cost and its ``gx`` (``gv`` is None); the objective protocol of
        [`pes_ref.core.objectives`][pes_ref.core.objectives]."""
        step, _ = exit_steps(x, self.level)
        particle = np.arange(x.shape[1])
        e = x[step, particle, 0] - self.target
        gx = np.zeros(x.shape)
        gx[step, particle, 0] = 2.0 * e
        value = float(np.sum(e * e))
        if self.linger:
            dt = float(t[1] - t[0]) if len(t) > 1 else 0.0
            live = np.arange(x.shape[0])[:, None] <= step[None, :]
            value += self.linger * dt * float(np.sum((x[:, :, 1] - self.level) * live))
            gx[:, :, 1] += self.linger * dt * live
        return value, gx, None
