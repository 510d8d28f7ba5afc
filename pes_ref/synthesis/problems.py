"""The paper's two design problems: the funnel (Figs. 6-7) and the oscillator (Figs. 8-11).

A *problem* is a frozen dataclass holding the physics of one scene (domain, forces,
damping, objective, particle sampler) at a final grid resolution; :data:`pes_ref.synthesis.kinds.KINDS`
holds them as kinds of design. Each problem draws a training batch (:meth:`batch`) from a generator it is
given, with the objective that scores it (the oscillator's gait cost depends on the batch's
starts), and scores a batch's trajectory with its design metric (:meth:`batch_metric`): the
funnel's share of the batch that exits within :data:`IN_BAND_SHARE` of the domain width
from the target; the oscillator's relative amplitude error over the batch's last simulated
period. How a problem is optimized is a plan (:mod:`pes_ref.synthesis.plans`); see
``docs/synthesis.md`` for the choices the paper leaves open.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import numpy as np

from pes_ref.core import checks
from pes_ref.core.effects import Constant, Noise, PerParticle
from pes_ref.core.integrator import Trajectory
from pes_ref.core.objectives import Funnel, Oscillator, OscillatorCycle
from pes_ref.core.scene import Scene
from pes_ref.core.surface import Surface
from pes_ref.core.terms import Spring, Walls
from pes_ref.synthesis.exits import FunnelExit, exit_steps
from pes_ref.synthesis.gait import GaitShooting, GaitStarts, sample_gait_starts
from pes_ref.synthesis.level_set import LevelSet
from pes_ref.synthesis.resampling import resample, resample_vjp

__all__ = ["FunnelProblem", "OscillatorProblem", "PhaseThenCycle", "Batch", "OSCILLATOR_COSTS",
           "IN_BAND_SHARE", "exit_positions", "FUNNEL_OBJECTIVES"]

#: A funnel particle is "in band" when its exit |q0 - target| is below this share of the width.
IN_BAND_SHARE = 0.10


class Batch(NamedTuple):
    """One iteration's particles: starts (N, 2), velocities (N, 2), the scene with their effects,
    the objective that scores their trajectory, and what the grid values cost beyond the
    problem's eq. (7) (``grid_cost(values) -> (value, dL/dG or None)``; None: nothing)."""

    x0: np.ndarray
    v0: np.ndarray
    scene: Scene
    objective: object
    grid_cost: object = None


class _Problem:
    """What both problems share: the initial grid, the flat surface, the design mask, and
    how the grid values become the surface (the values themselves, unless the problem's
    :attr:`level_set` makes them a shape: :mod:`pes_ref.synthesis.level_set`)."""

    #: None: the grid values are the surface's energies.
    level_set = None

    def surface_values(self, values) -> np.ndarray:
        """The surface's grid values of design ``values``: the values, or with a level set
        eq. (1) of their shape on the problem's own grid (:meth:`shape`)."""
        if self.level_set is None:
            return values
        fine = resample(values, self.lower, self.upper, self.periodic, self.shape())
        return self.level_set.energy(fine, self.lower, self.upper, self.periodic)

    def values_grad(self, values, grad_surface) -> np.ndarray:
        """dL/d(design values) from dL/d(surface values) (:meth:`surface_values` transposed)."""
        if self.level_set is None:
            return grad_surface
        fine = resample(values, self.lower, self.upper, self.periodic, self.shape())
        grad = self.level_set.vjp(fine, grad_surface, self.lower, self.upper, self.periodic)
        return resample_vjp(grad, np.shape(values), self.periodic)

    def mask(self, shape: tuple) -> np.ndarray:
        """1.0 where a grid value is designed (everywhere unless a problem holds some at zero)."""
        return np.ones(shape)

    def initial_values(self, rng, shape: tuple) -> np.ndarray:
        """Small random values (std ``init_scale``) to break symmetry, zero where held."""
        return rng.standard_normal(shape) * self.init_scale * self.mask(shape)

    def flat_values(self, shape: tuple | None = None) -> np.ndarray:
        """The flat starting surface: zeros."""
        return np.zeros(self.shape() if shape is None else shape)

    def plain(self):
        """This problem with its grid values the surface's energies (a realizable design's level
        set turned off): what runs a surface given as energies, such as a realized device's."""
        return self


@dataclass(frozen=True)
class FunnelProblem(_Problem):
    """The funnel of the paper's Figs. 6-7 on the plane ``[-width/2, width/2] x [0, height]``.

    Particles start at uniform random q0 across the top, ``start_depth`` below it, inside
    a strip of depth ``start_zone`` held at zero energy; a constant force ``-force`` along
    q1 plus Gaussian noise of std ``noise`` per step and axis push them down; walls of
    stiffness ``wall_k`` stand ``wall_margin`` inside the two side edges (q0). The
    objective is eq. (5) with weight-``regularization`` eq. (7) added, charged where it is
    chosen by ``when`` (:data:`FUNNEL_OBJECTIVES`): ``"exit"`` (the default) at the q0 where
    each particle leaves the domain (:class:`pes_ref.synthesis.exits.FunnelExit`), ``"final"``
    at the last step, ``"every_step"`` summed over every step. A strip of depth ``exit_zone``
    at the bottom is held at zero energy (0 by default: none). ``"final"`` needs one
    (docs/synthesis.md measures it with ``exit_zone = 0.05``): the surface extends as a constant beyond
    the bottom edge, so without it a design charged at the last step can keep steering
    particles after they leave the domain. Grid axis 0 is q0, axis 1 is q1; ``grid`` nodes
    per axis. ``linger`` weighs a term of the exit cost on the time particles spend above the
    exit edge (:class:`pes_ref.synthesis.exits.FunnelExit`).

    ``realizable`` makes the design realizable as designed (``docs/realize.md``): the grid
    values become a level set (:class:`pes_ref.synthesis.level_set.LevelSet`), the shape
    ``{values + contact_r_c < 0}``, and the surface is eq. (1) with strength ``contact_v``,
    cut-off ``contact_r_c`` and cap ``contact_r_min`` of the exact distance to that shape, on
    the ``grid`` x ``grid`` surface whatever the stage's grid of values. The shape starts as
    ``init_shape`` (:data:`INIT_SHAPES`): two strips ``init_strip`` wide along the walled sides
    (``"strips"``), or a V whose gap at the exit edge is ``2 init_gap`` wide (``"vee"``).
    """

    kind: ClassVar[str] = "funnel"
    #: The name of :meth:`batch_metric` in progress lines and summaries.
    metric_name: ClassVar[str] = "in_band"
    grid: int = 200
    width: float = 2.0
    height: float = 2.0
    start_zone: float = 0.3
    exit_zone: float = 0.0
    start_depth: float = 0.1
    force: float = 1.0
    noise: float = 0.3
    damping: float = 1.0
    dt: float = 0.01
    n_steps: int = 350
    target: float = 0.0
    wall_k: float = 1000.0
    wall_margin: float = 0.02
    init_scale: float = 1e-3
    when: str = "exit"
    regularization: float = 0.0
    linger: float = 0.0
    realizable: bool = False
    contact_v: float = 1.08e-4
    contact_r_c: float = 0.06
    contact_r_min: float = 0.02
    init_strip: float = 0.03
    init_shape: str = "strips"
    init_gap: float = 0.15

    def __post_init__(self):
        _check_fields(self)
        checks.as_choice("when", self.when, set(FUNNEL_OBJECTIVES))
        if self.linger and self.when != "exit":
            raise checks.InputError("linger", f"linger is a term of the exit cost (when = 'exit'), got when = "
                                              f"{self.when!r}", names=("linger", "when"))
        if not isinstance(self.realizable, bool):
            raise checks.InputTypeError("realizable", f"realizable must be true or false, got {self.realizable!r}")
        checks.as_choice("init_shape", self.init_shape, set(INIT_SHAPES))
        checks.as_positive_float("init_gap", self.init_gap)
        checks.as_nonneg_float("init_strip", self.init_strip)
        if self.realizable:
            object.__setattr__(self, "level_set", LevelSet(self.contact_v, self.contact_r_c, self.contact_r_min))

    def plain(self) -> "FunnelProblem":
        """This problem with ``realizable`` off (itself when it is off): the grid values are the surface's
        energies (a realized device's surface)."""
        return dataclasses.replace(self, realizable=False) if self.realizable else self

    # ------------------------------------------------------------------ geometry
    @property
    def lower(self):
        """The domain's lower corner ``(-width / 2, 0)`` (C-space length)."""
        return (-self.width / 2, 0.0)

    @property
    def upper(self):
        """The domain's upper corner ``(width / 2, height)`` (C-space length)."""
        return (self.width / 2, self.height)

    periodic = (False, False)

    def shape(self, grid: int | None = None) -> tuple:
        """The grid shape ``(n, n)``: n the problem's ``grid``, or the ``grid`` given (a stage's)."""
        n = self.grid if grid is None else grid
        return (n, n)

    def initial_values(self, rng, shape: tuple) -> np.ndarray:
        """Small random values (std ``init_scale``); with ``realizable``, the starting shape
        ``init_shape`` (:data:`INIT_SHAPES`) below the start strip (a level set's shape only
        moves where its contour is: the walls grow from it)."""
        if not self.realizable:
            return super().initial_values(rng, shape)
        q0 = np.linspace(self.lower[0], self.upper[0], shape[0])[:, None]
        q1 = np.linspace(self.lower[1], self.upper[1], shape[1])[None, :]
        free = np.broadcast_to(INIT_SHAPES[self.init_shape](self, q0, q1), shape)
        return self.level_set.from_distance(free) * self.mask(shape)

    def mask(self, shape: tuple) -> np.ndarray:
        """1.0 where a grid value is designed, 0.0 in the start and exit strips held at zero energy."""
        q1 = np.linspace(self.lower[1], self.upper[1], shape[1])
        free = ((q1 < self.height - self.start_zone) & (q1 >= self.exit_zone)).astype(np.float64)
        return np.broadcast_to(free[None, :], shape).copy()

    def scene(self, values, effects=()) -> Scene:
        """The design's scene on grid ``values`` with the given per-batch effects."""
        return Scene(Surface(self.surface_values(values), self.lower, self.upper, self.periodic), dt=self.dt,
                     n_steps=self.n_steps, damping=(self.damping, self.damping),
                     walls=Walls(k=self.wall_k, margin=self.wall_margin, edges=[[True, True], [False, False]]),
                     effects=tuple(effects))

    def objective(self):
        """Eq. (5) charged where ``when`` says (:data:`FUNNEL_OBJECTIVES`)."""
        return FUNNEL_OBJECTIVES[self.when](self)

    def batch(self, values, rng, n_particles: int, n_steps: int | None = None) -> Batch:
        """Particles uniformly across the top, constant downward force plus seeded noise."""
        half = self.width / 2 - self.wall_margin
        q0 = rng.uniform(-half, half, n_particles)
        x0 = np.stack([q0, np.full(n_particles, self.height - self.start_depth)], axis=1)
        effects = (Constant((0.0, -self.force)),
                   Noise(std=(self.noise, self.noise), seed=int(rng.integers(2 ** 63 - 1))))
        scene = self.scene(values, effects)
        if n_steps is not None:
            scene = dataclasses.replace(scene, n_steps=n_steps)
        return Batch(x0, np.zeros_like(x0), scene, self.objective())

    def batch_metric(self, traj: Trajectory) -> float:
        """Share of the batch whose exit |q0 - target| < 10% of the width."""
        return float(np.mean(self.in_band(exit_positions(self, traj))))

    def in_band(self, exits: np.ndarray) -> np.ndarray:
        """Where an exit q0 is within :data:`IN_BAND_SHARE` of the width from the target (False for NaN)."""
        with np.errstate(invalid="ignore"):
            return np.abs(exits - self.target) < IN_BAND_SHARE * self.width


def _strips(p: FunnelProblem, q0, q1):
    """Two strips ``init_strip`` wide along the walled sides: the signed distance (> 0 free)."""
    return p.width / 2 - p.init_strip - np.abs(q0) + 0.0 * q1


def _vee(p: FunnelProblem, q0, q1):
    """A V: free within ``|q0| < init_gap + (width/2 - init_gap) q1 / h`` (``h`` the height below
    the start strip), blocked outside; the signed distance to its two straight walls."""
    h = p.height - p.start_zone
    slope = (p.width / 2 - p.init_gap) / h
    return (p.init_gap + slope * q1 - np.abs(q0)) / np.hypot(1.0, slope)


#: The starting shapes of a realizable funnel: name -> signed distance (> 0 free) on the nodes.
INIT_SHAPES = {"strips": _strips, "vee": _vee}


def exit_positions(problem: FunnelProblem, traj: Trajectory) -> np.ndarray:
    """q0 at the first state at or below the bottom edge (q1 <= 0), NaN if a path never gets there."""
    step, exited = exit_steps(traj.x, problem.lower[1])
    exits = traj.x[step, np.arange(traj.x.shape[1]), 0]
    return np.where(exited, exits, np.nan)


#: The funnel's objective for each ``when``: eq. (5) at each particle's exit (the default), at
#: the final step, or summed over every step (:class:`pes_ref.core.objectives.Funnel`).
FUNNEL_OBJECTIVES = {
    "exit": lambda p: FunnelExit(target=p.target, level=p.lower[1], linger=p.linger),
    "final": lambda p: Funnel(target=p.target, when="final"),
    "every_step": lambda p: Funnel(target=p.target, when="every_step"),
}


@dataclass(frozen=True)
class OscillatorProblem(_Problem):
    """The oscillator of the paper's Figs. 8-11 on the cylinder ``[-q0_extent, q0_extent] x [0, 2 pi)``.

    q1 (an angle) is periodic. A linear spring ``spring_k`` pulls q0 to 0 (natural
    frequency ``sqrt(spring_k / mass)``); damping ``damping0`` along q0 is much lower than
    ``damping1`` along q1; each particle feels a constant torque ``-tau`` along q1 with
    ``tau`` uniform in ``[torque_min, torque_max]``. Walls stand ``wall_margin`` inside the
    q0 edges. The held-out evaluation (:mod:`pes_ref.synthesis.analysis`) starts particles at
    rest and always measures against ``amplitude`` and ``omega``.

    ``cost`` names the objective it trains on (:data:`OSCILLATOR_COSTS`; each named training
    plan of ``design oscillator --plan``, :data:`pes_ref.synthesis.plans.OSCILLATOR_PLANS`,
    sets it):

    - ``"gait"`` (the default): prescribed-gait multiple shooting. Each batch starts on the
      target cycle and on a gait of q1 advancing ``gait_delta`` per period
      (:func:`pes_ref.synthesis.gait.sample_gait_starts`), runs ``shooting_periods`` target
      periods and is charged :class:`pes_ref.synthesis.gait.GaitShooting` with weights
      ``gait_w0``, ``gait_w1`` and a dead zone of ``gait_dead_zone * gait_delta`` on q1.
    - ``"eq6"`` (the paper's): particles start at rest at ``q1 = 0``,
      ``q0 = amplitude (1 + kick) + start_noise * normal``, and eq. (6) is summed over every
      step of ``n_steps``; ``"cycle"`` (:class:`pes_ref.core.objectives.OscillatorCycle`, the
      phase-free distance to the target ellipse, counted from ``settle_periods`` periods on)
      and ``"phase_then_cycle"`` (:class:`PhaseThenCycle`: eq. (6) before ``settle_periods``,
      the cycle cost after) start the same way. ``stratified`` draws one torque per equal
      slice of the range; ``spread_share`` of each batch starts at rest anywhere in
      ``[-1.5 A, 1.5 A] x [0, 2 pi)`` like the 5 x 5 grid.

    Every cost aims at ``amplitude * target_scale`` (the eq. (6) designs' cycles fall short of
    their training target, so aiming above A lands them nearer A) and adds eq. (7) with
    weight ``regularization``.
    """

    kind: ClassVar[str] = "oscillator"
    #: The name of :meth:`batch_metric` in progress lines and summaries.
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
        """The training cost named by ``cost`` (:data:`OSCILLATOR_COSTS`), aimed at ``amplitude * target_scale``.

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
        """The gait cost of a batch drawn by :func:`pes_ref.synthesis.gait.sample_gait_starts`."""
        return GaitShooting(amplitude=self.amplitude * self.target_scale, omega=self.omega, delta=self.gait_delta,
                            theta=starts.theta, q1_start=starts.q1_start, w0=self.gait_w0, w1=self.gait_w1,
                            dead_zone=self.gait_dead_zone * self.gait_delta)

    @property
    def shooting_steps(self) -> int:
        """Steps of a gait-shooting run: ``ceil(shooting_periods * period / dt)``."""
        return self.steps_for(self.shooting_periods)

    def torque_effect(self, torques) -> PerParticle:
        """A constant torque ``-torques[i]`` along q1 on particle ``i`` (a
        :class:`~pes_ref.core.effects.PerParticle` effect)."""
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
        """Starts on the target cycle and on the gait (:func:`pes_ref.synthesis.gait.sample_gait_starts`)."""
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
    """Eq. (6) on the steps before ``cycle.settle``, the phase-free :class:`OscillatorCycle` from then on.

    Early on every particle is still near the reference's phase (all start at rest near
    ``q0 = A (1 + kick)``, the reference's phase 0), so eq. (6) is a well-aimed signal there;
    later it would charge a phase slip, which the cycle cost does not.
    """

    eq6: Oscillator
    cycle: OscillatorCycle

    def value_and_grad(self, x, v, t):
        """The two costs summed, with their ``gx`` and ``gv``; the objective protocol of
        :mod:`pes_ref.core.objectives`."""
        k = int(np.searchsorted(np.asarray(t), self.cycle.settle, side="left"))   # steps with t < settle
        value, gx, gv = self.cycle.value_and_grad(x, v, t)
        if k:
            v6, gx6, gv6 = self.eq6.value_and_grad(x[:k], v[:k], t[:k])
            value += v6
            gx[:k] += gx6
            gv[:k] += gv6
        return value, gx, gv


#: The oscillator's training costs by name (``OscillatorProblem.cost``): the paper's eq. (6), its
#: phase-free form (``OscillatorCycle``) and eq. (6) then the phase-free form (:class:`PhaseThenCycle`).
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


#: The fields that count grid nodes along an axis (a surface needs 2 at least).
_GRID_FIELDS = ("grid", "grid0", "grid1")
#: The float fields that must be > 0: lengths of the domain, the step, masses, stiffnesses,
#: the target cycle and the gait (each is divided by, or a zero makes the scene meaningless).
_POSITIVE_FIELDS = ("width", "height", "dt", "wall_k", "q0_extent", "amplitude", "omega", "mass", "gait_delta",
                    "shooting_periods", "contact_v", "contact_r_c", "contact_r_min")


def _check_fields(problem) -> None:
    """Validate every numeric field: ints > 0 (grid node counts >= 2), floats finite and
    >= 0 (> 0 for :data:`_POSITIVE_FIELDS`; ``target`` any finite)."""
    for f in dataclasses.fields(problem):
        val = getattr(problem, f.name)
        if isinstance(f.default, bool) or isinstance(f.default, str):
            continue
        if f.name in _GRID_FIELDS:
            object.__setattr__(problem, f.name, checks.as_int_at_least(f.name, val, 2))
        elif isinstance(f.default, int):
            object.__setattr__(problem, f.name, checks.as_positive_int(f.name, val))
        elif f.name == "target":
            object.__setattr__(problem, f.name, checks.as_finite_float(f.name, val))
        elif f.name in _POSITIVE_FIELDS:
            object.__setattr__(problem, f.name, checks.as_positive_float(f.name, val))
        else:
            object.__setattr__(problem, f.name, checks.as_nonneg_float(f.name, val))

