"""External force effects and the schedule they build (docs/spec.md section 4).

A scene lists the effects that push its particles; [`build_schedule`][pes_ref.core.effects.build_schedule] turns that
list into the realized external force ``F_ext`` of shape (T+1, N, 2), entry ``n``
acting at ``t_n = t0 + n dt``. A scene with no effect has no schedule at all
(``None``) and the integrator then adds nothing. Noise is drawn once, here, from
``numpy.random.default_rng(seed)``; the realized schedule is what the oracle records.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pes_ref.core import checks
from pes_ref.core.runtime import pages

__all__ = ["Constant", "PerParticle", "Window", "Noise", "Schedule", "build_schedule", "step_times", "all_zero"]


def step_times(n_steps: int, dt: float, t0: float = 0.0) -> np.ndarray:
    """Times t_n = t0 + n dt, n = 0..T, shape (T+1,)."""
    return t0 + dt * np.arange(n_steps + 1, dtype=np.float64)


@dataclass(frozen=True)
class Constant:
    """The same force on every particle at every step; ``force`` shape (2,)."""

    force: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "force", checks.as_float_array("Constant.force", self.force, shape=(2,)))

    def add_to(self, sched: np.ndarray, times: np.ndarray) -> None:
        """Add the force to every step and particle of ``sched`` (T+1, N, 2) in place; the effect
        protocol of [`build_schedule`][pes_ref.core.effects.build_schedule] (docs/spec.md section 4)."""
        sched += self.force

    def is_zero(self) -> bool:
        """Whether the force is 0 (the effect protocol of [`all_zero`][pes_ref.core.effects.all_zero])."""
        return not self.force.any()


@dataclass(frozen=True)
class PerParticle:
    """A constant force per particle; ``force`` shape (N, 2)."""

    force: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "force", checks.as_float_array("PerParticle.force", self.force, shape=(None, 2)))

    def add_to(self, sched, times) -> None:
        """Add each particle's force at every step of ``sched`` (T+1, N, 2) in place, refusing a
        ``force`` not of N rows; the effect protocol of [`build_schedule`][pes_ref.core.effects.build_schedule] (docs/spec.md section 4)."""
        if self.force.shape[0] != sched.shape[1]:
            raise ValueError(
                f"PerParticle.force must have shape ({sched.shape[1]}, 2) for {sched.shape[1]} particles, "
                f"got {self.force.shape}")
        sched += self.force

    def is_zero(self) -> bool:
        """Whether every particle's force is 0 (the effect protocol of [`all_zero`][pes_ref.core.effects.all_zero])."""
        return not self.force.any()


@dataclass(frozen=True)
class Noise:
    """Gaussian force noise, independent per step, particle and axis.

    ``std`` (2,) >= 0 is the per-axis standard deviation; the draws are
    ``default_rng(seed).standard_normal((T+1, N, 2)) * std``.
    """

    std: np.ndarray
    seed: int

    def __post_init__(self):
        object.__setattr__(self, "std", checks.as_float_array("Noise.std", self.std, shape=(2,), nonneg=True))
        object.__setattr__(self, "seed", checks.as_nonneg_int("Noise.seed", self.seed))

    def add_to(self, sched, times) -> None:
        """Add the draws ``default_rng(seed).standard_normal((T+1, N, 2)) * std`` to ``sched`` in place;
        the effect protocol of [`build_schedule`][pes_ref.core.effects.build_schedule] (docs/spec.md section 4)."""
        sched += np.random.default_rng(self.seed).standard_normal(sched.shape) * self.std

    def is_zero(self) -> bool:
        """Whether ``std`` is 0 on both axes (the effect protocol of [`all_zero`][pes_ref.core.effects.all_zero])."""
        return not self.std.any()


@dataclass(frozen=True)
class Window:
    """Another effect, on only for ``t_start <= t_n < t_end``."""

    effect: object
    t_start: float
    t_end: float

    def __post_init__(self):
        if not hasattr(self.effect, "add_to"):
            raise TypeError(f"Window.effect must be an effect (Constant, PerParticle, Noise, ...), got {self.effect!r}")
        object.__setattr__(self, "t_start", checks.as_finite_float("Window.t_start", self.t_start))
        object.__setattr__(self, "t_end", checks.as_finite_float("Window.t_end", self.t_end))
        if not self.t_end > self.t_start:
            raise ValueError(f"Window.t_end must be > t_start, got [{self.t_start}, {self.t_end})")

    def add_to(self, sched, times) -> None:
        """Add the inner effect's force to ``sched`` (T+1, N, 2) at the steps whose ``times`` are in
        ``[t_start, t_end)``; the effect protocol of [`build_schedule`][pes_ref.core.effects.build_schedule] (docs/spec.md section 4)."""
        inner = np.zeros(sched.shape)
        self.effect.add_to(inner, times)
        on = (times >= self.t_start) & (times < self.t_end)
        sched[on] += inner[on]

    def is_zero(self) -> bool:
        """Whether the inner effect is zero (the effect protocol of [`all_zero`][pes_ref.core.effects.all_zero])."""
        return self.effect.is_zero()


@dataclass(frozen=True)
class Schedule:
    """An explicit, realized schedule of shape (T+1, N, 2) (what an oracle case stores)."""

    force: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "force", checks.as_float_array("force", self.force, ndim=3))
        if self.force.shape[-1] != 2:
            raise ValueError(f"force must have shape (T+1, N, 2), got {self.force.shape}")

    def add_to(self, sched, times) -> None:
        """Add the stored schedule to ``sched`` in place, refusing one of another shape; the effect
        protocol of [`build_schedule`][pes_ref.core.effects.build_schedule] (docs/spec.md section 4)."""
        if self.force.shape != sched.shape:
            raise ValueError(f"force must have shape {sched.shape} (T+1, N, 2), got {self.force.shape}")
        sched += self.force

    def is_zero(self) -> bool:
        """Whether the stored force is 0 everywhere (the effect protocol of [`all_zero`][pes_ref.core.effects.all_zero])."""
        return not self.force.any()


def all_zero(effects) -> bool:
    """Whether every effect of ``effects`` pushes with 0 everywhere (each one's ``is_zero``;
    an effect without that method counts as not zero): then a run needs no external force
    at all, and nothing is drawn or realized."""
    return all(getattr(effect, "is_zero", lambda: False)() for effect in effects)


def build_schedule(effects, n_particles: int, n_steps: int, dt: float, t0: float = 0.0, out=None):
    """Realize the external force schedule of a list of effects.

    Parameters
    ----------
    effects : sequence of effects
    n_particles, n_steps : int
    dt, t0 : float
    out : ndarray (T+1, N, 2), optional
        Where to realize it (a view of a population's schedule), instead of a fresh array.

    Returns
    -------
    ndarray, shape (T+1, N, 2), or None when ``effects`` is empty
        ``F_ext[n]`` acts at ``t_n = t0 + n dt`` (docs/spec.md section 4).
    """
    if not effects:
        return None
    if out is None:
        sched = pages.zeros((n_steps + 1, n_particles, 2))
    else:
        sched = out
        sched.fill(0.0)
    times = step_times(n_steps, dt, t0)
    for effect in effects:
        effect.add_to(sched, times)
    return sched
