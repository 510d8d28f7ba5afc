"""The paper's two design problems, the funnel (Figs. 6-7) and the oscillator (Figs. 8-11).

A *problem* is a frozen dataclass holding the physics of one scene (domain, forces,
damping, objective, particle sampler) at a final grid resolution; a *plan*
(:class:`Plan`) holds how it is optimized (optimizer, learning rate, coarse-to-fine grid
stages, particles per iteration); a :class:`DesignState` is one run in progress (grid
values, optimizer state, iteration, loss history), which :mod:`pes_ref.synthesis.design_file`
saves and loads.

Iteration ``k`` of a run with seed ``s`` draws its particles (start positions, noise,
torques) from ``numpy.random.default_rng([s, k])`` only, so a run stopped after ``k``
iterations and resumed gives bit-identical values to one that never stopped.

Design metric per iteration: the funnel's share of the batch that exits within 10% of
the domain width from the target; the oscillator's relative amplitude error over the
batch's last simulated period. Evaluation on held-out particles: :func:`evaluate`.
See ``docs/synthesis.md`` for the choices the paper leaves open.
"""
from __future__ import annotations

import dataclasses
import math
import signal
import threading
import time
from dataclasses import dataclass
from typing import Callable, ClassVar, NamedTuple

import numpy as np

from pes_ref.core import checks
from pes_ref.core.effects import Constant, Noise, PerParticle
from pes_ref.core.integrator import NonFiniteError, Trajectory
from pes_ref.core.objectives import Funnel, Oscillator, OscillatorCycle
from pes_ref.synthesis.optimizers import make_optimizer
from pes_ref.core.scene import Scene, simulate, value_and_grad
from pes_ref.core.surface import Surface
from pes_ref.core.terms import Spring, Walls

__all__ = ["FunnelProblem", "OscillatorProblem", "Plan", "DesignState", "Progress", "PROBLEMS",
           "new_design", "run_design", "design_gradient", "resample", "evaluate",
           "funnel_paths", "exit_positions", "oscillator_torque_sweep", "oscillator_grid_starts",
           "phase_space", "cycle_figures", "DEFAULT_PLANS", "PhaseThenCycle", "OSCILLATOR_COSTS",
           "OSCILLATOR_OBJECTIVES", "DEFAULT_OSCILLATOR_OBJECTIVE", "escapement_values"]

#: A funnel particle is "in band" when its exit |q0 - target| is below this share of the width (issue 4).
IN_BAND_SHARE = 0.10
#: Oscillator cycle test: a held-out particle "reaches the cycle" when, over the analysis window
#: after the transient, its amplitude and period are within this relative error of the targets ...
CYCLE_TOLERANCE = 0.25
#: ... and its amplitude changes by less than this share of the target amplitude between the
#: first and the last period of the window (a sustained, not a decaying, oscillation).
CYCLE_DRIFT = 0.05
#: Periods at the end of an oscillator evaluation run that are analysed (the rest is transient).
ANALYSIS_PERIODS = 3


class Batch(NamedTuple):
    """One iteration's particles: starts (N, 2), velocities (N, 2) and the scene with their effects."""

    x0: np.ndarray
    v0: np.ndarray
    scene: Scene


# =========================================================================== problems

class _Problem:
    """What both problems share: the initial grid, the flat surface, the design mask."""

    def mask(self, shape: tuple) -> np.ndarray:
        """1.0 where a grid value is designed (everywhere unless a problem holds some at zero)."""
        return np.ones(shape)

    def initial_values(self, rng, shape: tuple) -> np.ndarray:
        """Small random values (std ``init_scale``) to break symmetry, zero where held."""
        return rng.standard_normal(shape) * self.init_scale * self.mask(shape)

    def flat_values(self, shape: tuple | None = None) -> np.ndarray:
        """The flat starting surface: zeros."""
        return np.zeros(self.shape() if shape is None else shape)


@dataclass(frozen=True)
class FunnelProblem(_Problem):
    """The funnel of the paper's Figs. 6-7 on the plane ``[-width/2, width/2] x [0, height]``.

    Particles start at uniform random q0 across the top, ``start_depth`` below it, inside
    a strip of depth ``start_zone`` held at zero energy; a strip of depth ``exit_zone`` at
    the bottom is held at zero too, so that the surface, which extends as a constant
    beyond the bottom edge, cannot keep steering particles after they exit; a constant force ``-force`` along
    q1 plus Gaussian noise of std ``noise`` per step and axis push them down; walls of
    stiffness ``wall_k`` stand ``wall_margin`` inside the two side edges (q0). The
    objective is eq. (5), ``sum_i (q0_i - target)^2`` at the final step (``when =
    "final"``) or summed over every step (``"every_step"``), plus eq. (7) with weight
    ``regularization``. Grid axis 0 is q0, axis 1 is q1; ``grid`` nodes per axis.
    """

    kind: ClassVar[str] = "funnel"
    grid: int = 200
    width: float = 2.0
    height: float = 2.0
    start_zone: float = 0.3
    exit_zone: float = 0.05
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
    when: str = "final"
    regularization: float = 0.0

    def __post_init__(self):
        _check_fields(self)
        checks.as_choice("when", self.when, {"final", "every_step"})

    # ------------------------------------------------------------------ geometry
    @property
    def lower(self):
        return (-self.width / 2, 0.0)

    @property
    def upper(self):
        return (self.width / 2, self.height)

    periodic = (False, False)

    def shape(self, grid: int | None = None) -> tuple:
        n = self.grid if grid is None else grid
        return (n, n)

    def mask(self, shape: tuple) -> np.ndarray:
        """1.0 where a grid value is designed, 0.0 in the start and exit strips held at zero energy."""
        q1 = np.linspace(self.lower[1], self.upper[1], shape[1])
        free = ((q1 < self.height - self.start_zone) & (q1 >= self.exit_zone)).astype(np.float64)
        return np.broadcast_to(free[None, :], shape).copy()

    def scene(self, values, effects=()) -> Scene:
        """The design's scene on grid ``values`` with the given per-batch effects."""
        return Scene(Surface(values, self.lower, self.upper, self.periodic), dt=self.dt, n_steps=self.n_steps,
                     damping=(self.damping, self.damping),
                     walls=Walls(k=self.wall_k, margin=self.wall_margin, edges=[[True, True], [False, False]]),
                     effects=tuple(effects))

    def objective(self):
        return Funnel(target=self.target, when=self.when)

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
        return Batch(x0, np.zeros_like(x0), scene)

    def batch_metric(self, traj: Trajectory) -> float:
        """Share of the batch whose exit |q0 - target| < 10% of the width."""
        return float(np.mean(self.in_band(exit_positions(self, traj))))

    def in_band(self, exits: np.ndarray) -> np.ndarray:
        with np.errstate(invalid="ignore"):
            return np.abs(exits - self.target) < IN_BAND_SHARE * self.width


@dataclass(frozen=True)
class OscillatorProblem(_Problem):
    """The oscillator of the paper's Figs. 8-11 on the cylinder ``[-q0_extent, q0_extent] x [0, 2 pi)``.

    q1 (an angle) is periodic. A linear spring ``spring_k`` pulls q0 to 0 (natural
    frequency ``sqrt(spring_k / mass)``); damping ``damping0`` along q0 is much lower than
    ``damping1`` along q1; each particle feels a constant torque ``-tau`` along q1 with
    ``tau`` uniform in ``[torque_min, torque_max]``. Particles start at rest at
    ``q1 = 0``, ``q0 = amplitude (1 + kick) + start_noise * normal``. The objective is
    eq. (6) summed over every step with target ``amplitude`` and ``omega``, plus eq. (7)
    with weight ``regularization``. Walls stand ``wall_margin`` inside the q0 edges.

    Training choices beyond the paper (the held-out evaluation always uses ``amplitude``):
    ``target_scale`` multiplies the amplitude the training cost aims at (the designs' cycles
    fall short of their training target, so aiming above A lands them nearer A); ``cost``
    is ``"eq6"`` (the paper's), ``"cycle"`` (:class:`pes_ref.core.objectives.OscillatorCycle`, the
    phase-free distance to the target ellipse, counted from ``settle_periods`` periods on)
    or ``"phase_then_cycle"`` (:class:`PhaseThenCycle`: eq. (6) before ``settle_periods``,
    the cycle cost after); ``stratified`` draws one torque per equal slice of the range;
    ``spread_share`` of each batch starts at rest anywhere in ``[-1.5 A, 1.5 A] x [0, 2 pi)``
    like the 5 x 5 grid. :data:`OSCILLATOR_OBJECTIVES` holds the named settings.
    """

    kind: ClassVar[str] = "oscillator"
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
    regularization: float = 1e-4
    cost: str = "eq6"
    settle_periods: float = 0.0
    target_scale: float = 1.4
    spread_share: float = 0.0
    stratified: bool = False

    def __post_init__(self):
        _check_fields(self)
        checks.as_choice("cost", self.cost, set(OSCILLATOR_COSTS))
        if self.spread_share > 1.0:
            raise ValueError(f"spread_share must be in [0, 1], got {self.spread_share!r}")

    @property
    def lower(self):
        return (-self.q0_extent, 0.0)

    @property
    def upper(self):
        return (self.q0_extent, 2 * math.pi)

    periodic = (False, True)

    @property
    def period(self) -> float:
        return 2 * math.pi / self.omega

    def shape(self, grid: int | None = None) -> tuple:
        if grid is None:
            return (self.grid0, self.grid1)
        return (grid, max(4, round(grid * self.grid1 / self.grid0)))

    def scene(self, values, effects=(), n_steps: int | None = None) -> Scene:
        return Scene(Surface(values, self.lower, self.upper, self.periodic), dt=self.dt,
                     n_steps=self.n_steps if n_steps is None else n_steps,
                     mass=self.mass, damping=(self.damping0, self.damping1),
                     spring=Spring(k=(self.spring_k, 0.0), center=(0.0, 0.0)),
                     walls=Walls(k=self.wall_k, margin=self.wall_margin, edges=[[True, True], [False, False]]),
                     effects=tuple(effects))

    def objective(self):
        amp = self.amplitude * self.target_scale
        eq6 = Oscillator(amplitude=amp, omega=self.omega)
        if self.cost == "eq6":
            return eq6
        cycle = OscillatorCycle(amplitude=amp, omega=self.omega, settle=self.settle_periods * self.period)
        return cycle if self.cost == "cycle" else PhaseThenCycle(eq6, cycle)

    def torque_effect(self, torques) -> PerParticle:
        torques = np.asarray(torques, dtype=np.float64)
        return PerParticle(np.stack([np.zeros_like(torques), -torques], axis=1))

    def batch(self, values, rng, n_particles: int, n_steps: int | None = None) -> Batch:
        """Starts beyond the target amplitude plus noise at q1 = 0, torques uniform in the range."""
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
        return Batch(x0, np.zeros_like(x0), self.scene(values, (self.torque_effect(torques),), n_steps))

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
        k = int(np.searchsorted(np.asarray(t), self.cycle.settle, side="left"))   # steps with t < settle
        value, gx, gv = self.cycle.value_and_grad(x, v, t)
        if k:
            v6, gx6, gv6 = self.eq6.value_and_grad(x[:k], v[:k], t[:k])
            value += v6
            gx[:k] += gx6
            gv[:k] += gv6
        return value, gx, gv


PROBLEMS = {"funnel": FunnelProblem, "oscillator": OscillatorProblem}
#: The oscillator's training costs: the paper's eq. (6), its phase-free form (``OscillatorCycle``) and
#: eq. (6) then the phase-free form (:class:`PhaseThenCycle`).
OSCILLATOR_COSTS = ("eq6", "cycle", "phase_then_cycle")


def _check_fields(problem) -> None:
    """Validate every numeric field: ints > 0, floats finite and >= 0 (``target`` any finite)."""
    for f in dataclasses.fields(problem):
        val = getattr(problem, f.name)
        if isinstance(f.default, bool) or isinstance(f.default, str):
            continue
        if isinstance(f.default, int):
            object.__setattr__(problem, f.name, checks.as_positive_int(f.name, val))
        elif f.name == "target":
            object.__setattr__(problem, f.name, checks.as_finite_float(f.name, val))
        else:
            object.__setattr__(problem, f.name, checks.as_nonneg_float(f.name, val))


# =========================================================================== plans

@dataclass(frozen=True)
class Plan:
    """How a problem is optimized.

    Parameters
    ----------
    iterations : int
        Default total iteration count of a run.
    optimizer : {"rmsprop", "adam"}
    lr : float
        Learning rate at iteration 0; decays geometrically to ``lr_final`` at iteration
        ``decay_iterations`` and stays there (``lr_final = lr``: constant). The schedule does
        not depend on ``iterations``, so a run stopped early and resumed with another total
        follows the same learning rates.
    lr_final : float
    decay_iterations : int
    clip : float or None
        Gradient-norm clipping.
    stages : tuple of (start_iteration, grid) or (start_iteration, grid, n_steps)
        Coarse-to-fine: from ``start_iteration`` on, the grid has ``grid`` nodes along axis
        0 (the problem's own grid when ``grid`` is 0) and the training runs have ``n_steps``
        steps (the problem's own when 0 or omitted: a short horizon early is cheaper and
        its gradient less chaotic). The values are resampled bilinearly
        (:func:`resample`) and the optimizer's moments reset at each change. The learning
        rate of a stage is multiplied by ``(first stage's grid / this stage's grid)``: RMSprop
        moves every node by about ``lr`` whatever its gradient's size, so on a grid ``r``
        times finer the same ``lr`` would roughen the surface ``r`` times more per cell.
    n_particles : int
        Particles per iteration.
    """

    iterations: int = 300
    optimizer: str = "rmsprop"
    lr: float = 0.01
    lr_final: float = 0.01
    decay_iterations: int = 300
    clip: float | None = None
    stages: tuple = ((0, 0),)
    n_particles: int = 64

    def __post_init__(self):
        checks.as_positive_int("iterations", self.iterations)
        checks.as_choice("optimizer", self.optimizer, {"rmsprop", "adam"})
        checks.as_positive_float("lr", self.lr)
        checks.as_positive_float("lr_final", self.lr_final)
        checks.as_positive_int("decay_iterations", self.decay_iterations)
        if self.clip is not None:
            checks.as_positive_float("clip", self.clip)
        checks.as_positive_int("n_particles", self.n_particles)
        stages = tuple(tuple(int(x) for x in st) + (0,) * (3 - len(st)) for st in self.stages)
        if any(len(st) != 3 or min(st) < 0 for st in stages):
            raise ValueError(f"stages must be (start_iteration, grid[, n_steps]) tuples >= 0, got {self.stages!r}")
        if not stages or stages[0][0] != 0 or any(b[0] <= a[0] for a, b in zip(stages, stages[1:])):
            raise ValueError(f"stages must start at iteration 0 and increase, got {self.stages!r}")
        object.__setattr__(self, "stages", stages)

    def stage_at(self, iteration: int) -> tuple:
        return [st for st in self.stages if st[0] <= iteration][-1]

    def grid_at(self, iteration: int, problem) -> tuple:
        return problem.shape(self.stage_at(iteration)[1] or None)

    def steps_at(self, iteration: int):
        """The training runs' n_steps at ``iteration`` (None: the problem's own)."""
        return self.stage_at(iteration)[2] or None

    def lr_at(self, iteration: int, problem) -> float:
        """``lr (lr_final / lr)^min(1, k / decay_iterations)`` times the stage's grid ratio."""
        frac = min(1.0, iteration / self.decay_iterations)
        ratio = self.grid_at(0, problem)[0] / self.grid_at(iteration, problem)[0]
        return self.lr * (self.lr_final / self.lr) ** frac * ratio

    def make_optimizer(self):
        return make_optimizer(self.optimizer, lr=self.lr, clip=self.clip)


#: The defaults of ``python -m pes_ref design`` (measured in docs/synthesis.md, "Results").
DEFAULT_PLANS = {
    "funnel": Plan(iterations=500, lr=0.002, lr_final=0.0005, decay_iterations=400,
                   stages=((0, 25), (400, 0)), n_particles=64),
}

#: The oscillator's named settings (``design oscillator --objective NAME``): problem overrides and plan.
#: "eq6" is the paper's setting, eq. (6) + eq. (7) aimed at the target amplitude A; "overshoot"
#: (the default, measured best in docs/synthesis.md) aims the same cost at 1.4 A. Both share the
#: plan: RMSprop, lr 5e-4 -> 5e-5, 16 particles, a horizon curriculum of 250/400/600/1000 steps
#: (2 to 8 periods) on a 16 x 16 grid for 500 iterations, then the scene's 32 x 32.
_OSC_PLAN = Plan(iterations=3000, lr=0.0005, lr_final=0.00005, decay_iterations=3000, n_particles=16,
                 stages=((0, 16, 250), (500, 0, 400), (1000, 0, 600), (2000, 0, 1000)))
_OSC_PAPER = {"cost": "eq6", "target_scale": 1.0, "stratified": False, "spread_share": 0.0, "settle_periods": 0.0}
OSCILLATOR_OBJECTIVES = {
    "eq6": (_OSC_PAPER, _OSC_PLAN),
    "overshoot": ({**_OSC_PAPER, "target_scale": 1.4}, _OSC_PLAN),
}
#: The objective ``design oscillator`` uses without ``--objective`` (the problem's field defaults match it).
DEFAULT_OSCILLATOR_OBJECTIVE = "overshoot"
DEFAULT_PLANS["oscillator"] = OSCILLATOR_OBJECTIVES[DEFAULT_OSCILLATOR_OBJECTIVE][1]


# =========================================================================== state and loop

@dataclass
class DesignState:
    """One design run: problem, plan, seed, grid values, optimizer, iteration, history.

    Mutable on purpose (it is what the design loop advances); every field is plain data
    that :mod:`pes_ref.synthesis.design_file` writes and reads back bit-exactly. ``history`` maps
    ``"loss"`` and ``"metric"`` to lists with one float per finished iteration;
    ``status`` is ``"running"``, ``"done"``, ``"interrupted"`` or ``"non-finite: ..."``.
    """

    problem: object
    plan: Plan
    seed: int
    values: np.ndarray
    optimizer: object
    iteration: int = 0
    history: dict = dataclasses.field(default_factory=lambda: {"loss": [], "metric": []})
    status: str = "running"
    elapsed: float = 0.0

    @property
    def kind(self) -> str:
        return self.problem.kind


def new_design(kind: str, seed: int = 0, plan: Plan | None = None, **params) -> DesignState:
    """A fresh run of ``kind`` ("funnel" or "oscillator") with problem overrides ``params``."""
    kind = checks.as_choice("kind", kind, set(PROBLEMS))
    seed = checks.as_nonneg_int("seed", seed)
    problem = PROBLEMS[kind](**params)
    plan = DEFAULT_PLANS[kind] if plan is None else plan
    rng = np.random.default_rng([seed, 2 ** 32])       # the init draw, apart from every iteration's
    values = problem.initial_values(rng, plan.grid_at(0, problem))
    return DesignState(problem, plan, seed, values, plan.make_optimizer())


class Progress(NamedTuple):
    """What a progress callback receives."""

    iteration: int
    total: int
    loss: float
    metric: float
    it_per_s: float
    seconds_left: float


class _StopFlag:
    """Turns SIGINT into a flag checked between iterations (main thread only)."""

    def __init__(self):
        self.stop = False
        self._old = None

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            self._old = signal.signal(signal.SIGINT, self._handle)
        return self

    def _handle(self, signum, frame):
        if self.stop:                       # a second Ctrl-C: the user insists
            raise KeyboardInterrupt
        self.stop = True

    def __exit__(self, *exc):
        if self._old is not None:
            signal.signal(signal.SIGINT, self._old)
        return False


def design_step(problem, values, seed: int, iteration: int, n_particles: int, n_steps: int | None = None):
    """Loss, masked design gradient dL/dE and trajectory of iteration ``iteration``.

    Returns ``(loss, grad, traj, x0)``; the particles come from ``default_rng([seed, iteration])``;
    ``n_steps`` overrides the problem's. Raises :class:`pes_ref.NonFiniteError` when the run
    leaves the finite numbers.
    """
    rng = np.random.default_rng([seed, iteration])
    batch = problem.batch(values, rng, n_particles, n_steps)
    loss, grads, traj = value_and_grad(batch.scene, batch.x0, batch.v0, problem.objective(),
                                       regularization_weight=problem.regularization, wrt=("values",))
    return loss, grads["values"] * problem.mask(values.shape), traj, batch.x0


class GradientStep(NamedTuple):
    loss: float
    grad: np.ndarray
    traj: Trajectory
    x0: np.ndarray


def design_gradient(problem, values, seed: int = 0, iteration: int = 0, n_particles: int = 64,
                    n_steps: int | None = None) -> GradientStep:
    """One iteration's design gradient dL/dE (masked like the run's) with the paths behind it."""
    values = checks.as_float_array("values", values, ndim=2)
    return GradientStep(*design_step(problem, values, seed, iteration, n_particles, n_steps))


def run_design(state: DesignState, iterations: int | None = None, *, callback: Callable | None = None,
               progress_every: float = 2.0, checkpoint: Callable | None = None,
               checkpoint_every: float = 60.0) -> DesignState:
    """Advance ``state`` until ``state.iteration == iterations`` (default: the plan's).

    Each iteration draws its batch, takes the gradient of the objective (plus eq. (7))
    with respect to the grid values by the adjoint, masks it, and takes one optimizer
    step at the plan's learning rate. ``callback(Progress)`` is called every
    ``progress_every`` seconds and once at the end; ``checkpoint(state)`` every
    ``checkpoint_every`` seconds. Ctrl-C (SIGINT) finishes the current iteration and
    stops with ``status = "interrupted"``. A non-finite loss, gradient or trajectory
    stops the run and rolls it back one iteration, to the last grid whose loss was finite
    (``status = "non-finite: ..."``); resuming it repeats that iteration, so change the
    plan (a smaller ``lr``, ``clip``) first.
    """
    total = state.plan.iterations if iterations is None else checks.as_nonneg_int("iterations", iterations)
    problem, plan = state.problem, state.plan
    start_it, t_start = state.iteration, time.perf_counter()
    last_report = last_ckpt = t_start
    loss = metric = float("nan")
    state.status = "running"

    def report(now):
        done = state.iteration - start_it
        rate = done / (now - t_start) if now > t_start and done else 0.0
        left = (total - state.iteration) / rate if rate > 0 else float("inf")
        callback(Progress(state.iteration, total, loss, metric, rate, left))

    snapshot = None      # (values, optimizer state) before the last committed step

    def roll_back(reason):
        # the iterate just reached has a non-finite run: return to the last one whose loss was finite
        state.status = f"non-finite: {reason}"
        if snapshot is not None:
            state.values, opt_state = snapshot
            state.optimizer.load_state_dict(opt_state)
            state.iteration -= 1
            for h in state.history.values():
                del h[state.iteration:]

    with _StopFlag() as flag:
        while state.iteration < total:
            if flag.stop:
                state.status = "interrupted"
                break
            k = state.iteration
            shape = plan.grid_at(k, problem)
            values = state.values
            if values.shape != shape:
                values = resample(values, problem.lower, problem.upper, problem.periodic, shape)
                values = values * problem.mask(shape)
                state.values = values
                state.optimizer.reset()
            try:
                with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                    loss_k, grad, traj, _ = design_step(problem, values, state.seed, k, plan.n_particles,
                                                        plan.steps_at(k))
            except FloatingPointError as exc:          # NonFiniteError is one
                roll_back(f"iteration {k}: {exc}")
                break
            if not (np.isfinite(loss_k) and np.isfinite(grad).all()):
                roll_back(f"iteration {k}: the loss or its gradient is not finite")
                break
            snapshot = (values, state.optimizer.state_dict())
            state.optimizer.lr = plan.lr_at(k, problem)
            with np.errstate(over="ignore", invalid="ignore"):
                new = state.optimizer.step(values, grad)
            if not np.isfinite(new).all():
                state.optimizer.load_state_dict(snapshot[1])
                state.status = f"non-finite: iteration {k}: the optimizer step is not finite"
                break
            state.values = new
            loss, metric = float(loss_k), problem.batch_metric(traj)
            state.history["loss"].append(loss)
            state.history["metric"].append(metric)
            state.iteration = k + 1
            now = time.perf_counter()
            if callback is not None and now - last_report >= progress_every:
                report(now)
                last_report = now
            if checkpoint is not None and now - last_ckpt >= checkpoint_every:
                checkpoint(state)
                last_ckpt = now
        else:
            state.status = "done"
    state.elapsed += time.perf_counter() - t_start
    if callback is not None:
        report(time.perf_counter())
    return state


# =========================================================================== resampling

def _axis_weights(n_old: int, n_new: int, periodic: bool):
    """Linear interpolation from n_old nodes to n_new nodes on one axis: (i0, i1, f)."""
    if periodic:
        u = np.arange(n_new) * (n_old / n_new)
        i0 = np.floor(u).astype(np.intp)
        f = u - i0
        i0 %= n_old
        return i0, (i0 + 1) % n_old, f
    u = np.linspace(0.0, n_old - 1.0, n_new)
    i0 = np.minimum(np.floor(u), n_old - 2).astype(np.intp)
    return i0, i0 + 1, u - i0


def resample(values, lower, upper, periodic, shape) -> np.ndarray:
    """Bilinear resampling of a grid to a new shape over the same domain (coarse-to-fine).

    Node ``k`` of the new grid on axis d sits at ``lower_d + k h'_d`` and takes the
    bilinear value of the old surface there (exact where old and new nodes coincide).
    """
    out = np.asarray(values, dtype=np.float64)
    for d in range(2):
        i0, i1, f = _axis_weights(out.shape[d], shape[d], bool(periodic[d]))
        a, b = np.take(out, i0, axis=d), np.take(out, i1, axis=d)
        fb = f[:, None] if d == 0 else f[None, :]
        out = a * (1.0 - fb) + b * fb
    return out


# =========================================================================== held-out particles

class Paths(NamedTuple):
    x0: np.ndarray
    traj: Trajectory


class TorqueSweep(NamedTuple):
    torques: np.ndarray
    x0: np.ndarray
    traj: Trajectory


def funnel_paths(problem: FunnelProblem, values, n_particles: int = 200, seed: int = 1) -> Paths:
    """Held-out funnel particles: the training sampler with ``default_rng(seed)``."""
    batch = problem.batch(np.asarray(values, dtype=np.float64), np.random.default_rng(seed), n_particles)
    return Paths(batch.x0, simulate(batch.scene, batch.x0, batch.v0))


def exit_positions(problem: FunnelProblem, traj: Trajectory) -> np.ndarray:
    """q0 at the first state at or below the bottom edge (q1 <= 0), NaN if a path never gets there."""
    below = traj.x[:, :, 1] <= problem.lower[1]
    first = np.argmax(below, axis=0)
    exits = traj.x[first, np.arange(traj.x.shape[1]), 0]
    return np.where(below.any(axis=0), exits, np.nan)


def _long_scene(problem: OscillatorProblem, values, torques, periods: float) -> Scene:
    n_steps = int(math.ceil(periods * problem.period / problem.dt))
    return problem.scene(np.asarray(values, dtype=np.float64), (problem.torque_effect(torques),), n_steps)


def oscillator_torque_sweep(problem: OscillatorProblem, values, n_particles: int = 50, periods: float | None = None,
                            seed: int = 1) -> TorqueSweep:
    """Particles with torques evenly from min to max, started like the training batch (Figs. 8-9).

    Start q0 = amplitude (1 + kick) + start_noise * normal from ``default_rng(seed)``;
    simulated for ``periods`` target periods (default ``problem.eval_periods``).
    """
    periods = problem.eval_periods if periods is None else periods
    torques = np.linspace(problem.torque_min, problem.torque_max, n_particles)
    q0 = problem.amplitude * (1.0 + problem.kick) + problem.start_noise * \
        np.random.default_rng(seed).standard_normal(n_particles)
    x0 = np.stack([q0, np.zeros(n_particles)], axis=1)
    return TorqueSweep(torques, x0, simulate(_long_scene(problem, values, torques, periods), x0))


def oscillator_grid_starts(problem: OscillatorProblem, values, periods: float | None = None, n: int = 5) -> Paths:
    """An n x n grid of starts at rest with the maximum torque (Figs. 10-11).

    q0 evenly in ``[-1.5 A, 1.5 A]`` (A the target amplitude), q1 evenly over the
    period ``[0, 2 pi)``.
    """
    periods = problem.eval_periods if periods is None else periods
    a = np.linspace(-1.5 * problem.amplitude, 1.5 * problem.amplitude, n)
    b = np.arange(n) * (problem.upper[1] - problem.lower[1]) / n
    x0 = np.stack(np.meshgrid(a, b, indexing="ij"), axis=-1).reshape(-1, 2)
    torques = np.full(x0.shape[0], problem.torque_max)
    return Paths(x0, simulate(_long_scene(problem, values, torques, periods), x0))


def escapement_values(problem: OscillatorProblem, shape: tuple | None = None, *, kappa: float = 0.032,
                      d: float = 0.4, h: float = 0.5, teeth: int = 4) -> np.ndarray:
    """A hand-drawn escapement for the oscillator problem, sampled at the grid's nodes (n0, n1).

    Not a design found by gradient descent: a reference that shows what a torque-independent
    oscillator looks like on this scene (``docs/synthesis.md``, "The oscillator"). q1 runs
    down under the torque; with ``u = (-q1) mod 2 pi``, half tooth ``j = floor(u / (pi /
    teeth))`` and ``s = u - j pi / teeth``,

    ``E = kappa q0 g + h gate bump``

    where ``bump = sin^2(pi (s - 0.1) / 0.25)`` on ``s in [0.1, 0.35]`` is a wall that holds
    q1 (``h`` must beat the largest torque), ``gate = sigmoid((q0 + d) / 0.1)`` on even j
    (held while ``q0 > -d``) and ``sigmoid(-(q0 - d) / 0.1)`` on odd j (held while
    ``q0 < d``), and ``g`` goes from +1 to -1 (even j) or -1 to +1 (odd j) by a smoothstep
    over ``s in [0.35, 0.75]``. Each half swing q0 passes the far gate, the wall drops, q1
    falls half a tooth and turns the push ``-kappa g`` on q0 round for the next swing.
    """
    from scipy.special import expit

    if not isinstance(problem, OscillatorProblem):
        raise TypeError(f"problem must be an OscillatorProblem, got {type(problem).__name__}")
    shape = problem.shape() if shape is None else tuple(shape)
    if len(shape) != 2:
        raise ValueError(f"shape must be (n0, n1), got {shape!r}")
    n0, n1 = (checks.as_positive_int("shape", n) for n in shape)
    kappa, d, h = (checks.as_nonneg_float(name, val) for name, val in (("kappa", kappa), ("d", d), ("h", h)))
    teeth = checks.as_positive_int("teeth", teeth)
    q0 = np.linspace(problem.lower[0], problem.upper[0], n0)[:, None]
    q1 = (np.arange(n1) * (problem.upper[1] - problem.lower[1]) / n1)[None, :]
    u = np.mod(-q1, 2 * np.pi)
    j = np.floor(u / (np.pi / teeth))
    s = u - j * np.pi / teeth
    bump = np.where((s >= 0.1) & (s <= 0.35), np.sin(np.pi * (s - 0.1) / 0.25) ** 2, 0.0)
    even = j % 2 == 0
    gate = np.where(even, expit((q0 + d) / 0.1), expit(-(q0 - d) / 0.1))
    sm = np.clip((s - 0.35) / 0.4, 0.0, 1.0)
    sm = sm * sm * (3 - 2 * sm)
    g = np.where(even, 1 - 2 * sm, -1 + 2 * sm)
    return kappa * q0 * g + h * gate * bump


def phase_space(problem: OscillatorProblem, traj: Trajectory, after_periods: float):
    """(q0, dq0/dt) of every state after ``after_periods`` target periods, each (T', N)."""
    start = int(math.ceil(after_periods * problem.period / problem.dt))
    return traj.x[start:, :, 0], traj.v[start:, :, 0]


def cycle_figures(problem: OscillatorProblem, traj: Trajectory):
    """Per-particle amplitude, period, drift over the last ``ANALYSIS_PERIODS`` periods.

    Returns ``(amplitude, period, drift, captured)``, each (N,): amplitude ``(max - min)/2``
    of q0 over the window; period the mean spacing of upward crossings of q0's window mean
    (linearly interpolated; NaN with fewer than two); drift ``|a_last - a_first| / A``
    between the window's first and last period; captured where amplitude and period are
    within :data:`CYCLE_TOLERANCE` of the targets and drift below :data:`CYCLE_DRIFT`.
    """
    per = int(round(problem.period / problem.dt))
    q = traj.x[-ANALYSIS_PERIODS * per - 1:, :, 0]
    amp = 0.5 * (q.max(axis=0) - q.min(axis=0))
    first, last = q[:per + 1], q[-per - 1:]
    drift = np.abs(0.5 * (last.max(0) - last.min(0)) - 0.5 * (first.max(0) - first.min(0))) / problem.amplitude
    c = q - q.mean(axis=0)
    periods = np.full(q.shape[1], np.nan)
    for i in range(q.shape[1]):
        up = np.nonzero((c[:-1, i] < 0) & (c[1:, i] >= 0))[0]
        if up.size >= 2:
            tcross = (up + c[up, i] / (c[up, i] - c[up + 1, i])) * problem.dt
            periods[i] = np.mean(np.diff(tcross))
    with np.errstate(invalid="ignore"):
        amp_err = np.abs(amp - problem.amplitude) / problem.amplitude
        per_err = np.abs(periods - problem.period) / problem.period
        captured = (amp_err < CYCLE_TOLERANCE) & (per_err < CYCLE_TOLERANCE) & (drift < CYCLE_DRIFT)
    return amp, periods, drift, captured


# =========================================================================== evaluation

def evaluate(problem, values, seed: int = 12345, n_particles: int | None = None) -> dict:
    """The figures of ``python -m pes_ref evaluate``: name -> float.

    Funnel (``n_particles`` default 200, held-out seed ``seed``): ``in_band_fraction``,
    ``exit_spread`` (std of exit q0), ``exited_fraction``, and the same three on the flat
    starting surface (``flat_*``). Oscillator (``n_particles`` default 50 for the torque
    sweep, plus the 5 x 5 grid of starts): ``captured_fraction`` (both sets together),
    ``sweep_captured_fraction``, ``grid_captured_fraction``, ``amplitude_error`` and
    ``period_error`` (relative, worst over the captured particles; NaN if none) and
    ``flat_captured_fraction``.
    """
    values = checks.as_float_array("values", values, ndim=2)
    seed = checks.as_nonneg_int("seed", seed)
    if problem.kind == "funnel":
        n = 200 if n_particles is None else checks.as_positive_int("n_particles", n_particles)
        out = {}
        for prefix, vals in (("", values), ("flat_", problem.flat_values(values.shape))):
            paths = funnel_paths(problem, vals, n, seed)
            exits = exit_positions(problem, paths.traj)
            out[prefix + "in_band_fraction"] = float(np.mean(problem.in_band(exits)))
            done = exits[np.isfinite(exits)]
            out[prefix + "exit_spread"] = float(np.std(done)) if done.size else float("nan")
            out[prefix + "exited_fraction"] = float(np.mean(np.isfinite(exits)))
        out["particles"] = float(n)
        return out
    n = 50 if n_particles is None else checks.as_positive_int("n_particles", n_particles)
    out = {}
    for prefix, vals in (("", values), ("flat_", problem.flat_values(values.shape))):
        sweep = oscillator_torque_sweep(problem, vals, n, seed=seed)
        grid = oscillator_grid_starts(problem, vals)
        fig_s, fig_g = cycle_figures(problem, sweep.traj), cycle_figures(problem, grid.traj)
        captured = np.concatenate([fig_s[3], fig_g[3]])
        out[prefix + "captured_fraction"] = float(np.mean(captured))
        if prefix:
            continue
        out["sweep_captured_fraction"] = float(np.mean(fig_s[3]))
        out["grid_captured_fraction"] = float(np.mean(fig_g[3]))
        amp = np.concatenate([fig_s[0], fig_g[0]])[captured]
        per = np.concatenate([fig_s[1], fig_g[1]])[captured]
        out["amplitude_error"] = float(np.max(np.abs(amp - problem.amplitude)) / problem.amplitude) \
            if amp.size else float("nan")
        out["period_error"] = float(np.max(np.abs(per - problem.period)) / problem.period) \
            if per.size else float("nan")
    out["particles"] = float(n + 25)
    return out
