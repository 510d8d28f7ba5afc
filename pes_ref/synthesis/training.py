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

from pes_ref.core import checks
from pes_ref.core.integrator import Trajectory
from pes_ref.core.scene import value_and_grad
from pes_ref.synthesis.plans import DEFAULT_PLANS, DEFAULT_POLISH, Plan, PolishPlan
from pes_ref.synthesis.problems import PROBLEMS
from pes_ref.synthesis.resampling import resample

__all__ = ["DesignState", "Progress", "GradientStep", "StopFlag", "new_design", "run_design", "design_gradient",
           "STAGES"]

#: A run's stages in order: gradient descent on the grid values, then (if it has a polish plan) the polish.
STAGES = ("gradient", "polish")


@dataclass
class DesignState:
    """One design run: problem, plan, seed, grid values, optimizer, iteration, history, polish.

    Mutable on purpose (it is what the design loop advances); every field is plain data
    that :mod:`pes_ref.synthesis.design_file` writes and reads back bit-exactly. ``history`` maps
    ``"loss"`` and ``"metric"`` to lists with one float per finished iteration;
    ``status`` is ``"running"``, ``"done"``, ``"interrupted"`` or ``"non-finite: ..."``.

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
    rng = np.random.default_rng([seed, 2 ** 32])       # the init draw, apart from every iteration's
    values = problem.initial_values(rng, plan.grid_at(0, problem))
    return DesignState(problem, plan, seed, values, plan.make_optimizer(), polish=polish)


class Progress(NamedTuple):
    """What a progress callback receives."""

    iteration: int
    total: int
    loss: float
    metric: float
    it_per_s: float
    seconds_left: float


class StopFlag:
    """Turns SIGINT into a flag checked between iterations (main thread only); a second Ctrl-C
    raises :class:`KeyboardInterrupt` at once. Nested flags each see their own signals."""

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

    with StopFlag() as flag:
        while state.iteration < total:
            if flag.stop:
                state.status = "interrupted"
                break
            k = state.iteration
            values = _values_on_stage_grid(state, plan.grid_at(k, problem))
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
