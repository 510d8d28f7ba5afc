"""Design runs: the state of one run and the loop of its gradient stage.

A :class:`DesignState` is one run in progress (problem, plan, seed, grid values, optimizer
state, iteration, loss history, and the optional polish stage's plan and progress), which
:mod:`pes_ref.synthesis.design_file` saves and loads; :func:`new_design` starts one and
:func:`run_design` advances its gradient stage, one optimizer step on the adjoint gradient
of the batch's objective per iteration (:mod:`pes_ref.synthesis.stages` runs both stages).

Iteration ``k`` of a run with seed ``s`` draws its particles (start positions, noise,
torques) from ``numpy.random.default_rng([s, k])`` only, so a run stopped after ``k``
iterations and resumed gives bit-identical values to one that never stopped.
"""
from __future__ import annotations

import dataclasses
import signal
import threading
import time
from dataclasses import dataclass
from typing import Callable, NamedTuple

import numpy as np

from pes_ref.core import budget, checks
from pes_ref.core.integrator import Trajectory
from pes_ref.core.scene import value_and_grad
from pes_ref.core.stability import UnstableStepError, check_stable
from pes_ref.synthesis.plans import DEFAULT_PLANS, DEFAULT_POLISH, Plan, PolishPlan
from pes_ref.synthesis.problems import PROBLEMS
from pes_ref.synthesis.resampling import resample

__all__ = ["DesignState", "Progress", "Stage", "StageClock", "plan_stages", "GradientStep", "StopFlag", "new_design",
           "run_design", "design_gradient", "check_stable_design", "check_design_memory", "STOPPED", "STAGES"]

#: The statuses of a run that stopped on a failed iteration (rolled back to the last good state):
#: its run left the finite numbers, or its grid steepened past the stability rule.
STOPPED = ("non-finite", "unstable")

#: A run's stages in order: gradient descent on the grid values, then (if it has a polish plan) the polish.
STAGES = ("gradient", "polish")


@dataclass
class DesignState:
    """One design run: problem, plan, seed, grid values, optimizer, iteration, history, polish.

    Mutable on purpose (it is what the design loop advances); every field is plain data
    that :mod:`pes_ref.synthesis.design_file` writes and reads back bit-exactly. ``history`` maps
    ``"loss"`` and ``"metric"`` to lists with one float per finished iteration;
    ``status`` is ``"running"``, ``"done"``, ``"interrupted"``, or one of :data:`STOPPED`
    followed by ``": iteration k: <reason>"``.

    ``polish`` is the :class:`~pes_ref.synthesis.plans.PolishPlan` of the stage that follows
    the gradient iterations (None: none). ``stage`` is the stage the run is in (:data:`STAGES`);
    in the polish stage ``base_values`` holds the gradient stage's final grid (where the polish
    starts), ``values`` the best polished grid so far, ``evaluations`` the fitness evaluations
    made and ``polish_history`` maps ``"evaluations"`` and ``"fitness"`` to the count and the
    best fitness after the start and each generation.
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
    polish: PolishPlan | None = None
    stage: str = "gradient"
    base_values: np.ndarray | None = None
    evaluations: int = 0
    polish_history: dict = dataclasses.field(default_factory=lambda: {"evaluations": [], "fitness": []})

    @property
    def kind(self) -> str:
        return self.problem.kind

    @property
    def method(self) -> str:
        """``"gradient"`` or ``"gradient+polish"``: the stages this run has."""
        return "gradient" if self.polish is None else "gradient+polish"

    @property
    def finished(self) -> bool:
        """Every stage of the run is done."""
        return self.status == "done" and (self.polish is None or self.stage == "polish")


def new_design(kind: str, seed: int = 0, plan: Plan | None = None, polish: PolishPlan | None = None,
               **params) -> DesignState:
    """A fresh run of ``kind`` ("funnel" or "oscillator") with problem overrides ``params``.

    Without ``plan`` the run has the kind's default plan and, unless ``polish`` is given,
    its default polish stage (:data:`pes_ref.synthesis.plans.DEFAULT_POLISH`); with a
    ``plan`` it has the ``polish`` given (None: the gradient stage alone).
    """
    kind = checks.as_choice("kind", kind, set(PROBLEMS))
    seed = checks.as_nonneg_int("seed", seed)
    if polish is not None and not isinstance(polish, PolishPlan):
        raise TypeError(f"polish must be a PolishPlan or None, got {type(polish).__name__}")
    problem = PROBLEMS[kind](**params)
    if plan is None:
        plan, polish = DEFAULT_PLANS[kind], DEFAULT_POLISH[kind] if polish is None else polish
    _check_memory(problem, plan, polish)
    rng = np.random.default_rng([seed, 2 ** 32])       # the init draw, apart from every iteration's
    values = problem.initial_values(rng, plan.grid_at(0, problem))
    problem.scene(values)           # the scene's own checks (dt, wall margins ...), once, before any run
    state = DesignState(problem, plan, seed, values, plan.make_optimizer(), polish=polish)
    check_stable_design(state)
    return state


def check_stable_design(state: DesignState) -> None:
    """Refuse a run whose scene is past the stability rule (docs/spec.md section 10) on its
    current grid, before it runs: :class:`~pes_ref.core.stability.UnstableStepError` naming
    ``dt`` (e.g. a ``dt`` or ``wall_k`` override too large for the problem's springs and
    walls). Every iteration checks its own scene again as the grid changes."""
    check_stable(state.problem.scene(state.values))


def check_design_memory(state: DesignState) -> None:
    """Refuse a run whose training iterations cannot fit in the available memory, before it
    runs: :class:`~pes_ref.core.budget.RunTooLargeError` naming the grid's size (``grid``,
    ``grid0`` or ``grid1``; or ``stages``, when a stage's grid is the largest), or ``n_steps``
    (or ``stages``, when a stage's horizon is the longest) and ``n_particles`` (the plan's
    particles per iteration)."""
    _check_memory(state.problem, state.plan, state.polish)


def _check_memory(problem, plan: Plan, polish: PolishPlan | None) -> None:
    """:func:`check_design_memory` of a run of ``problem`` by ``plan`` and ``polish``, before its grid exists."""
    shapes = {st[1]: problem.shape(st[1] or None) for st in plan.stages}
    grid = max(shapes, key=lambda g: shapes[g][0] * shapes[g][1])
    key = "stages" if grid else max(("grid", "grid0", "grid1"), key=lambda k: getattr(problem, k, 0))
    arrays = budget.GRID_ARRAYS + (0 if polish is None else 2 * polish.n_terms)     # the polish's basis, built once
    budget.check_grid_memory(shapes[grid], key, arrays, length=f"{key} = {grid or getattr(problem, key)}")
    own = problem.n_steps
    steps = max(st[2] or own for st in plan.stages)
    if steps == own:
        budget.check_memory(steps, plan.n_particles, "value_and_grad", particles="n_particles")
    else:                                   # a stage's horizon is the longest
        budget.check_memory(steps, plan.n_particles, "value_and_grad", steps="stages", particles="n_particles",
                            length=f"stages of {steps} steps")


class Progress(NamedTuple):
    """What a progress callback receives.

    ``stage`` names the stage of the last finished iteration (``"2/4"``: the second of
    the four stages the run goes through), ``grid`` and ``steps`` are that stage's grid
    shape and steps per training run, ``it_per_s`` its rate; ``seconds_left`` sums the
    time of every stage still to run (:class:`StageClock`). A plan with one stage is
    ``"1/1"``. The loss of one stage is not comparable with another's: a longer horizon
    sums more steps.
    """

    iteration: int
    total: int
    loss: float
    metric: float
    it_per_s: float
    seconds_left: float
    stage: str = "1/1"
    grid: tuple = ()
    steps: int = 0


class Stage(NamedTuple):
    """One stage of a staged run: its name, iterations ``[start, end)``, grid shape and steps per run."""

    name: str
    start: int
    end: int
    grid: tuple
    steps: int


def plan_stages(plan: Plan, problem, total: int) -> list:
    """The :class:`Stage` list a run of ``plan`` to ``total`` iterations goes through."""
    starts = [st for st in plan.stages if st[0] < total] or [plan.stages[0]]
    ends = [st[0] for st in starts[1:]] + [total]
    return [Stage(f"{i + 1}/{len(starts)}", st[0], end, plan.grid_at(st[0], problem),
                  plan.steps_at(st[0]) or problem.n_steps)
            for i, (st, end) in enumerate(zip(starts, ends))]


class StageClock:
    """The rate of each stage of a run and the time left, summed over the stages still to run.

    An iteration's cost is taken as proportional to its stage's steps per run (the
    particles and the work per step are the same in every stage; the grid's size barely
    counts). A stage that has run is timed by its own iterations; one yet to run by the
    seconds per step of the latest stage timed. Any staged plan fits: it only has to
    give its :class:`Stage` list.
    """

    def __init__(self, stages: list):
        self.stages = stages
        self._seconds = [0.0] * len(stages)
        self._count = [0] * len(stages)
        self._per_step = None           # seconds per step of the latest stage timed

    def index(self, iteration: int) -> int:
        """The stage index of ``iteration``."""
        return max(i for i, st in enumerate(self.stages) if st.start <= iteration or i == 0)

    def tick(self, iteration: int, seconds: float) -> None:
        """Iteration ``iteration`` took ``seconds``."""
        i = self.index(iteration)
        self._seconds[i] += seconds
        self._count[i] += 1
        if self._seconds[i] > 0:
            self._per_step = self._seconds[i] / (self._count[i] * self.stages[i].steps)

    def rate(self, i: int) -> float:
        """Iterations per second of stage ``i`` (0 while it has not been timed)."""
        return self._count[i] / self._seconds[i] if self._seconds[i] > 0 else 0.0

    def seconds_left(self, iteration: int, total: int) -> float:
        """Seconds to run iterations ``iteration .. total - 1`` (inf before anything was timed)."""
        left = 0.0
        for i, st in enumerate(self.stages):
            n = max(0, min(st.end, total) - max(st.start, iteration))
            if n == 0:
                continue
            rate = self.rate(i)
            if rate > 0:
                left += n / rate
            elif self._per_step is not None:
                left += n * st.steps * self._per_step
            else:
                return float("inf")
        return left


class StopFlag:
    """Turns SIGINT (Ctrl-C) and SIGTERM (a batch scheduler preempting the run) into a flag
    checked between iterations (main thread only); a second signal stops at once.
    Nested flags each see their own signals."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self):
        self.stop = False
        self._old = {}

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            self._old = {signum: signal.signal(signum, self._handle) for signum in self.SIGNALS}
        return self

    def _handle(self, signum, frame):
        if self.stop:                       # a second signal: the user insists
            raise KeyboardInterrupt
        self.stop = True

    def __exit__(self, *exc):
        for signum, old in self._old.items():
            signal.signal(signum, old)
        return False


def design_step(problem, values, seed: int, iteration: int, n_particles: int, n_steps: int | None = None):
    """Loss, masked design gradient dL/dE and trajectory of iteration ``iteration``.

    Returns ``(loss, grad, traj, x0)``; the particles come from ``default_rng([seed, iteration])``
    and the objective with them (``batch.objective``); ``n_steps`` overrides the problem's.
    Raises :class:`pes_ref.NonFiniteError` when the run leaves the finite numbers.
    """
    rng = np.random.default_rng([seed, iteration])
    batch = problem.batch(values, rng, n_particles, n_steps)
    loss, grads, traj = value_and_grad(batch.scene, batch.x0, batch.v0, batch.objective,
                                       regularization_weight=problem.regularization, wrt=("values",))
    return loss, grads["values"] * problem.mask(values.shape), traj, batch.x0


class GradientStep(NamedTuple):
    """One iteration's loss, masked design gradient dL/dE (like the values' shape), trajectory and starts."""

    loss: float
    grad: np.ndarray
    traj: Trajectory
    x0: np.ndarray


def design_gradient(problem, values, seed: int = 0, iteration: int = 0, n_particles: int = 64,
                    n_steps: int | None = None) -> GradientStep:
    """One iteration's design gradient dL/dE (masked like the run's) with the paths behind it."""
    values = checks.as_float_array("values", values, ndim=2)
    return GradientStep(*design_step(problem, values, seed, iteration, n_particles, n_steps))


def _values_on_stage_grid(state: DesignState, shape: tuple) -> np.ndarray:
    """The run's values on its stage's grid ``shape``: at a change of stage resampled bilinearly,
    zeroed where the problem holds them, and the optimizer's moments reset (coarse-to-fine)."""
    problem, values = state.problem, state.values
    if values.shape != shape:
        values = resample(values, problem.lower, problem.upper, problem.periodic, shape)
        values = values * problem.mask(shape)
        state.values = values
        state.optimizer.reset()
    return values


def run_design(state: DesignState, iterations: int | None = None, *, callback: Callable | None = None,
               progress_every: float = 2.0, checkpoint: Callable | None = None,
               checkpoint_every: float = 60.0) -> DesignState:
    """Advance ``state`` until ``state.iteration == iterations`` (default: the plan's).

    Each iteration draws its batch, takes the gradient of the objective (plus eq. (7))
    with respect to the grid values by the adjoint, masks it, and takes one optimizer
    step at the plan's learning rate. ``callback(Progress)`` is called every
    ``progress_every`` seconds and once at the end; ``checkpoint(state)`` every
    ``checkpoint_every`` seconds. Ctrl-C (SIGINT) or SIGTERM finishes the current
    iteration and stops with ``status = "interrupted"``. A non-finite loss, gradient or trajectory
    (``status = "non-finite: ..."``), or an iteration whose grid has steepened past the
    stability rule (``"unstable: ..."``, docs/spec.md section 10), stops the run and rolls
    it back one iteration, to the last grid whose run was finite and stable; resuming it
    repeats that iteration, so change the plan (a smaller ``lr``, ``clip``) first.
    """
    total = state.plan.iterations if iterations is None else checks.as_nonneg_int("iterations", iterations)
    problem, plan = state.problem, state.plan
    start_it, t_start = state.iteration, time.perf_counter()
    last_report = last_ckpt = t_start
    loss = metric = float("nan")
    state.status = "running"
    clock = StageClock(plan_stages(plan, problem, total))

    def report(now):
        i = clock.index(max(state.iteration - 1, 0))
        st = clock.stages[i]
        callback(Progress(state.iteration, total, loss, metric, clock.rate(i),
                          clock.seconds_left(state.iteration, total), st.name, st.grid, st.steps))

    snapshot = None      # (values, optimizer state) before the last committed step

    def roll_back(reason, stop="non-finite"):
        # the iterate just reached has a non-finite or unstable run: return to the last good one
        state.status = f"{stop}: {reason}"
        if snapshot is not None:
            state.values, opt_state = snapshot
            state.optimizer.load_state_dict(opt_state)
            state.iteration -= 1
            for h in state.history.values():
                del h[state.iteration:]

    with StopFlag() as flag:
        while state.iteration < total:
            if flag.stop:
                state.status = "interrupted"
                break
            k = state.iteration
            t_k = time.perf_counter()
            values = _values_on_stage_grid(state, plan.grid_at(k, problem))
            try:
                with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                    loss_k, grad, traj, _ = design_step(problem, values, state.seed, k, plan.n_particles,
                                                        plan.steps_at(k))
            except FloatingPointError as exc:          # NonFiniteError is one
                roll_back(f"iteration {k}: {exc}")
                break
            except UnstableStepError as exc:           # the grid steepened past the stability rule
                roll_back(f"iteration {k}: {exc}", "unstable")
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
            clock.tick(k, now - t_k)
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
