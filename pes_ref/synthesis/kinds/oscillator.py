"""The oscillator of the paper's Figs. 8-11: particles held to a target cycle along q0 while q1 turns.

Its design metric is the relative amplitude error over the batch's last simulated period; it
trains on one of `OSCILLATOR_COSTS` (prescribed-gait shooting by default, the paper's
eq. (6), its phase-free form, or eq. (6) then the phase-free form:
[`PhaseThenCycle`][pes_ref.synthesis.kinds.oscillator.PhaseThenCycle]).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from pes_ref.core import checks
from pes_ref.core.effects import PerParticle
from pes_ref.core.integrator import Trajectory
from pes_ref.core.objectives import Oscillator, OscillatorCycle
from pes_ref.core.scene import Scene
from pes_ref.core.surface import Surface
from pes_ref.core.terms import Spring, Walls
from pes_ref.synthesis.kinds.gait import GaitShooting, GaitStarts, sample_gait_starts
from pes_ref.synthesis.common.problems import Batch, _check_fields, _Problem

__all__ = ["OscillatorProblem", "PhaseThenCycle", "OSCILLATOR_COSTS"]


@dataclass(frozen=True)
class OscillatorProblem(_Problem):
    """The oscillator of the paper's Figs. 8-11 on the cylinder ``[-q0_extent, q0_extent] x [0, 2 pi)``.

    q1 (an angle) is periodic. A linear spring ``spring_k`` pulls q0 to 0 (natural
    frequency ``sqrt(spring_k / mass)``); damping ``damping0`` along q0 is much lower than
    ``damping1`` along q1; each particle feels a constant torque ``-tau`` along q1 with
    ``tau`` uniform in ``[torque_min, torque_max]``. Walls stand ``wall_margin`` inside the
    q0 edges. The held-out evaluation ([`pes_ref.synthesis.kinds.analysis`][pes_ref.synthesis.kinds.analysis]) starts particles at
    rest and always measures against ``amplitude`` and ``omega``.

    ``cost`` names the objective it trains on (`OSCILLATOR_COSTS`; each named training
    plan of ``design oscillator --plan``, `pes_ref.synthesis.common.plans.OSCILLATOR_PLANS`,
    sets it):

    - ``"gait"`` (the default): prescribed-gait multiple shooting. Each batch starts on the
      target cycle and on a gait of q1 advancing ``gait_delta`` per period
      ([`pes_ref.synthesis.kinds.gait.sample_gait_starts`][pes_ref.synthesis.kinds.gait.sample_gait_starts]), runs
      ``shooting_periods`` target
      periods and is charged [`pes_ref.synthesis.kinds.gait.GaitShooting`][pes_ref.synthesis.kinds.gait.GaitShooting] with weights
      ``gait_w0``, ``gait_w1`` and a dead zone of ``gait_dead_zone * gait_delta`` on q1.
    - ``"eq6"`` (the paper's): particles start at rest at ``q1 = 0``,
      ``q0 = amplitude (1 + kick) + start_noise * normal``, and eq. (6) is summed over every step of
      ``n_steps``; ``"cycle"``
      ([`pes_ref.core.objectives.OscillatorCycle`][pes_ref.core.objectives.OscillatorCycle], the
      phase-free distance to the target ellipse, counted from ``settle_periods`` periods on) and
      ``"phase_then_cycle"`` ([`PhaseThenCycle`][pes_ref.synthesis.kinds.oscillator.PhaseThenCycle]:
      eq. (6) before ``settle_periods``, the cycle cost after) start the same way. ``stratified``
      draws one torque per equal slice of the range; ``spread_share`` of each batch starts at rest
      anywhere in ``[-1.5 A, 1.5 A] x [0, 2 pi)`` like the 5 x 5 grid.

    Every cost aims at ``amplitude * target_scale`` (the eq. (6) designs' cycles fall short of
    their training target, so aiming above A lands them nearer A) and adds eq. (7) with
    weight ``regularization``.
    """

    kind: ClassVar[str] = "oscillator"
    #: The name of `batch_metric` in progress lines and summaries.
    metric_name: ClassVar[str] = "amp_err"
    grid0: int = 32
    grid1: int = 32
    q0_extent: float = 2.5
    amplitude: float = 1.0
    omega: float = 1.0
    spring_k: float = 1.0
    mass: float = 1.0
    damping0: float = 0.05
    damping1: float = 2.0
    torque_min: float = 0.5
    torque_max: float = 1.0
    kick: float = 0.2
    start_noise: float = 0.05
    dt: float = 0.05
    n_steps: int = 500
    eval_periods: int = 15
    wall_k: float = 100.0
    wall_margin: float = 0.05
    init_scale: float = 1e-3
    regularization: float = 0.0
    cost: str = "gait"
    settle_periods: float = 0.0
    target_scale: float = 1.0
    spread_share: float = 0.0
    stratified: bool = False
    gait_delta: float = math.pi / 2
    gait_w0: float = 30.0
    gait_w1: float = 1.0
    gait_dead_zone: float = 0.25
    shooting_periods: float = 1.0

    def __post_init__(self):
        _check_fields(self)
        checks.as_choice("cost", self.cost, set(OSCILLATOR_COSTS))
        if self.spread_share > 1.0:
            raise checks.InputError("spread_share", f"spread_share must be in [0, 1], got {self.spread_share!r}")
        if self.torque_max < self.torque_min:
            raise checks.InputError("torque_max", f"torque_max must be >= torque_min = {self.torque_min!r}, got "
                                                  f"{self.torque_max!r}", names=("torque_max", "torque_min"))
        if self.cost in _BATCHES and (self.spread_share or self.stratified):
            raise ValueError(f"spread_share and stratified shape the paper's starts; cost {self.cost!r} draws its own "
                             f"(got spread_share={self.spread_share!r}, stratified={self.stratified!r})")

    @property
    def lower(self):
        """The domain's lower corner ``(-q0_extent, 0)`` (C-space length, radians)."""
        return (-self.q0_extent, 0.0)

    @property
    def upper(self):
        """The domain's upper corner ``(q0_extent, 2 pi)`` (C-space length, radians)."""
        return (self.q0_extent, 2 * math.pi)

    periodic = (False, True)

    @property
    def period(self) -> float:
        """The target period ``2 pi / omega`` (seconds)."""
        return 2 * math.pi / self.omega

    def shape(self, grid: int | None = None) -> tuple:
        """The grid shape ``(grid0, grid1)``, or for a ``grid`` given (a stage's) ``grid`` nodes along
        axis 0 and axis 1 in the same proportion (at least 4)."""
        if grid is None:
            return (self.grid0, self.grid1)
        return (grid, max(4, round(grid * self.grid1 / self.grid0)))

    def scene(self, values, effects=(), n_steps: int | None = None) -> Scene:
        """The scene on grid ``values`` with ``effects``, ``n_steps`` steps (the problem's own when None):
        the problem's masses, damping, spring along q0 and walls at the q0 edges."""
        return Scene(Surface(values, self.lower, self.upper, self.periodic), dt=self.dt,
                     n_steps=self.n_steps if n_steps is None else n_steps,
                     mass=self.mass, damping=(self.damping0, self.damping1),
                     spring=Spring(k=(self.spring_k, 0.0), center=(0.0, 0.0)),
                     walls=Walls(k=self.wall_k, margin=self.wall_margin, edges=[[True, True], [False, False]]),
                     effects=tuple(effects))

    def objective(self):
        """The training cost named by ``cost`` (`OSCILLATOR_COSTS`), aimed at ``amplitude * target_scale``.

        The gait cost depends on each batch's starts: it is ``batch(...).objective``.
        """
        if self.cost not in _COST_BUILDERS:
            raise ValueError(f"cost {self.cost!r} is built per batch from its starts: use batch(...).objective")
        return _COST_BUILDERS[self.cost](self)

    def eq6_cost(self) -> Oscillator:
        """Eq. (6) aimed at ``amplitude * target_scale``."""
        return Oscillator(amplitude=self.amplitude * self.target_scale, omega=self.omega)

    def cycle_cost(self) -> OscillatorCycle:
        """The phase-free cycle cost aimed at ``amplitude * target_scale``, from ``settle_periods`` on."""
        return OscillatorCycle(amplitude=self.amplitude * self.target_scale, omega=self.omega,
                               settle=self.settle_periods * self.period)

    def gait_cost(self, starts: GaitStarts) -> GaitShooting:
        """The gait cost of a batch drawn by [`pes_ref.synthesis.kinds.gait.sample_gait_starts`][pes_ref.synthesis.kinds.gait.sample_gait_starts]."""
        return GaitShooting(amplitude=self.amplitude * self.target_scale, omega=self.omega, delta=self.gait_delta,
                            theta=starts.theta, q1_start=starts.q1_start, w0=self.gait_w0, w1=self.gait_w1,
                            dead_zone=self.gait_dead_zone * self.gait_delta)

    @property
    def shooting_steps(self) -> int:
        """Steps of a gait-shooting run: ``ceil(shooting_periods * period / dt)``."""
        return self.steps_for(self.shooting_periods)

    def torque_effect(self, torques) -> PerParticle:
        """A constant torque ``-torques[i]`` along q1 on particle ``i`` (a
        [`PerParticle`][pes_ref.core.effects.PerParticle] effect)."""
        torques = np.asarray(torques, dtype=np.float64)
        return PerParticle(np.stack([np.zeros_like(torques), -torques], axis=1))

    def torque_scene(self, values, torques, periods: float) -> Scene:
        """The scene on grid ``values`` with one torque per particle, ``periods`` target periods long."""
        return self.scene(np.asarray(values, dtype=np.float64), (self.torque_effect(torques),),
                          self.steps_for(periods))

    def steps_for(self, periods: float) -> int:
        """The steps of a run of ``periods`` target periods."""
        return int(math.ceil(periods * self.period / self.dt))

    def batch(self, values, rng, n_particles: int, n_steps: int | None = None) -> Batch:
        """The cost's training batch: the gait's starts for ``"gait"``, the paper's for the others.

        ``n_steps`` (default: ``shooting_steps`` for the gait, ``n_steps`` for the others)
        sets the runs' length.
        """
        return _BATCHES.get(self.cost, OscillatorProblem.rest_batch)(self, values, rng, n_particles, n_steps)

    def gait_batch(self, values, rng, n_particles: int, n_steps: int | None = None) -> Batch:
        """Starts on the target cycle and on the gait ([`pes_ref.synthesis.kinds.gait.sample_gait_starts`][pes_ref.synthesis.kinds.gait.sample_gait_starts])."""
        starts = sample_gait_starts(self, rng, n_particles, self.gait_delta, self.amplitude * self.target_scale)
        scene = self.scene(values, (self.torque_effect(starts.torques),),
                           self.shooting_steps if n_steps is None else n_steps)
        return Batch(starts.x0, starts.v0, scene, self.gait_cost(starts))

    def rest_batch(self, values, rng, n_particles: int, n_steps: int | None = None) -> Batch:
        """The paper's starts: beyond the target amplitude plus noise at q1 = 0, at rest, torques uniform."""
        q0 = self.amplitude * (1.0 + self.kick) + self.start_noise * rng.standard_normal(n_particles)
        x0 = np.stack([q0, np.zeros(n_particles)], axis=1)
        torques = rng.uniform(self.torque_min, self.torque_max, n_particles)
        if self.stratified:          # one torque per equal slice of [min, max]: the whole range every batch
            u = (np.arange(n_particles) + rng.uniform(size=n_particles)) / n_particles
            torques = self.torque_min + (self.torque_max - self.torque_min) * u
        m = int(round(self.spread_share * n_particles))
        if m:                        # the last m start at rest anywhere, like the 5 x 5 grid of Figs. 10-11
            x0[-m:, 0] = rng.uniform(-1.5 * self.amplitude, 1.5 * self.amplitude, m)
            x0[-m:, 1] = rng.uniform(self.lower[1], self.upper[1], m)
        return Batch(x0, np.zeros_like(x0), self.scene(values, (self.torque_effect(torques),), n_steps),
                     self.objective())

    def batch_metric(self, traj: Trajectory) -> float:
        """Relative error of the batch's mean amplitude over its last simulated period."""
        steps = max(2, int(round(self.period / self.dt)))
        q0 = traj.x[-steps:, :, 0]
        amp = 0.5 * (q0.max(axis=0) - q0.min(axis=0))
        return float(abs(np.mean(amp) - self.amplitude) / self.amplitude)


@dataclass(frozen=True)
class PhaseThenCycle:
    """Eq. (6) on the steps before ``cycle.settle``, the phase-free
    [`OscillatorCycle`][pes_ref.core.objectives.OscillatorCycle] from then on.

    Early on every particle is still near the reference's phase (all start at rest near
    ``q0 = A (1 + kick)``, the reference's phase 0), so eq. (6) is a well-aimed signal there;
    later it would charge a phase slip, which the cycle cost does not.
    """

    eq6: Oscillator
    cycle: OscillatorCycle

    def value_and_grad(self, x, v, t):
        """The two costs summed, with their ``gx`` and ``gv``; the objective protocol of
        [`pes_ref.core.objectives`][pes_ref.core.objectives]."""
        k = int(np.searchsorted(np.asarray(t), self.cycle.settle, side="left"))   # steps with t < settle
        value, gx, gv = self.cycle.value_and_grad(x, v, t)
        if k:
            v6, gx6, gv6 = self.eq6.value_and_grad(x[:k], v[:k], t[:k])
            value += v6
            gx[:k] += gx6
            gv[:k] += gv6
        return value, gx, gv


#: The oscillator's training costs by name (``OscillatorProblem.cost``): the paper's eq. (6), its
#: phase-free form (``OscillatorCycle``) and eq. (6) then the phase-free form (`PhaseThenCycle`).
_COST_BUILDERS = {
    "eq6": OscillatorProblem.eq6_cost,
    "cycle": OscillatorProblem.cycle_cost,
    "phase_then_cycle": lambda problem: PhaseThenCycle(problem.eq6_cost(), problem.cycle_cost()),
}
#: The oscillator's batch samplers by cost, where a cost has its own (the others use ``rest_batch``).
_BATCHES = {"gait": OscillatorProblem.gait_batch}
#: The names of the oscillator's training costs: prescribed-gait shooting first (the default), then
#: those built without a batch.
OSCILLATOR_COSTS = ("gait",) + tuple(_COST_BUILDERS)
