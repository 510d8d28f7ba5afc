"""The loop of a design run's gradient stage.

[`run_design`][pes_ref.synthesis.engine.training.run_design] advances a
[`DesignState`][pes_ref.synthesis.engine.design_state.DesignState], one optimizer step on the
adjoint gradient of the batch's objective per iteration
([`pes_ref.synthesis.engine.stages`][pes_ref.synthesis.engine.stages] runs the polish after it). It
reports a [`pes_ref.core.runtime.progress.Progress`][pes_ref.core.runtime.progress.Progress] with
the stage, its grid and horizon, the loss, the metric, the rate and the time left (a
[`pes_ref.core.runtime.progress.Clock`][pes_ref.core.runtime.progress.Clock] over the plan's
stages); Ctrl-C and SIGTERM stop it between two iterations
([`pes_ref.core.runtime.signals.StopFlag`][pes_ref.core.runtime.signals.StopFlag]).

Iteration ``k`` of a run with seed ``s`` draws its particles (start positions, noise,
torques) from ``numpy.random.default_rng([s, k])`` only, so a run stopped after ``k``
iterations and resumed gives bit-identical values to one that never stopped.
"""
from __future__ import annotations

import time
from typing import Callable, NamedTuple

import numpy as np

from pes_ref.core import checks
from pes_ref.core.integrator import Trajectory
from pes_ref.core.runtime.progress import Clock, Progress
from pes_ref.core.scene import value_and_grad
from pes_ref.core.runtime.signals import StopFlag
from pes_ref.core.stability import UnstableStepError
from pes_ref.synthesis.engine.design_state import DesignState
from pes_ref.synthesis.common.plans import Plan
from pes_ref.synthesis.common.validation import Best, on_grid, validation_success

__all__ = ["GradientStep", "run_design", "design_gradient"]


def design_step(problem, values, seed: int, iteration: int, n_particles: int, n_steps: int | None = None,
                backend: str | None = None, draw: int | None = None):
    """Loss, masked design gradient dL/dE and trajectory of iteration ``iteration``.

    Returns ``(loss, grad, traj, x0)``; the particles come from ``default_rng([seed, iteration])``
    (``[seed, iteration, draw]`` for one of a smoothed iteration's draws) and the objective with them (``batch.objective``, plus the batch's ``grid_cost`` of the values
    if it has one; the same particles, drawn again, run each scenario the problem charges, whose
    surrogates join the loss); ``n_steps`` overrides the problem's;
    ``backend`` as in [`pes_ref.value_and_grad`][pes_ref.core.scene.value_and_grad].
    Raises [`pes_ref.NonFiniteError`][pes_ref.core.integrator.NonFiniteError] when the run leaves the finite numbers.
    """
    key = [seed, iteration] if draw is None else [seed, iteration, draw]
    batch = problem.batch(values, np.random.default_rng(key), n_particles, n_steps)
    loss, grads, traj = value_and_grad(batch.scene, batch.x0, batch.v0, batch.objective,
                                       regularization_weight=problem.regularization, wrt=("values",),
                                       backend=backend)
    grad = problem.values_grad(values, grads["values"])
    for scenario in getattr(problem, "charged_scenarios", ()):     # the same particles under its schedule
        other = problem.scenario_batch(values, np.random.default_rng(key), n_particles, scenario, n_steps)
        loss_s, grads_s, _ = value_and_grad(other.scene, other.x0, other.v0, other.objective, wrt=("values",),
                                            backend=backend)
        loss += loss_s
        grad = grad + problem.values_grad(values, grads_s["values"])
    if batch.grid_cost is not None:
        cost, cost_grad = batch.grid_cost(values)
        loss += cost
        if cost_grad is not None:
            grad = grad + cost_grad
    return loss, grad * problem.mask(values.shape), traj, batch.x0


#: The key of a smoothed iteration's perturbations: ``default_rng([seed, iteration, SMOOTHING_STREAM])``,
#: apart from its draws' particles (``[seed, iteration, draw]``, draw < n_particles).
SMOOTHING_STREAM = 2 ** 32 + 3


def smoothed_step(problem, values, seed: int, iteration: int, plan: Plan, backend: str | None = None):
    """Loss, masked gradient and metric of iteration ``iteration`` of a run on ``plan``: one
    [`design_step`][pes_ref.synthesis.engine.training.design_step], or with ``plan.smoothing`` the mean over
    ``plan.smoothing_draws`` grids
    ``values + smoothing z_j`` (``z_j`` normal, zero where the problem holds the grid), draw ``j``
    with its share of the particles ([`Plan`][pes_ref.synthesis.common.plans.Plan]). Returns
    ``(loss, grad, metric)``."""
    n_steps = plan.steps_at(iteration)
    if not plan.smoothing:
        loss, grad, traj, _ = design_step(problem, values, seed, iteration, plan.n_particles, n_steps, backend)
        return loss, grad, problem.batch_metric(traj)
    k = plan.smoothing_draws
    z = np.random.default_rng([seed, iteration, SMOOTHING_STREAM]).standard_normal((k,) + values.shape)
    mask = problem.mask(values.shape)
    counts = np.full(k, plan.n_particles // k) + (np.arange(k) < plan.n_particles % k)
    loss, grad, metric = 0.0, np.zeros_like(values), 0.0
    for j in range(k):
        loss_j, grad_j, traj, _ = design_step(problem, values + plan.smoothing * z[j] * mask, seed, iteration,
                                              int(counts[j]), n_steps, backend, draw=j)
        share = counts[j] / plan.n_particles
        loss += loss_j / k
        grad += grad_j / k
        metric += share * problem.batch_metric(traj)
    return loss, grad, metric


class GradientStep(NamedTuple):
    """One iteration's loss, masked design gradient dL/dE (like the values' shape), trajectory and starts."""

    loss: float
    grad: np.ndarray
    traj: Trajectory
    x0: np.ndarray


def design_gradient(problem, values, seed: int = 0, iteration: int = 0, n_particles: int = 64,
                    n_steps: int | None = None, backend: str | None = None) -> GradientStep:
    """One iteration's design gradient dL/dE (masked like the run's) with the paths behind it."""
    values = checks.as_float_array("values", values, ndim=2)
    return GradientStep(*design_step(problem, values, seed, iteration, n_particles, n_steps, backend))


def _values_on_stage_grid(state: DesignState, shape: tuple) -> np.ndarray:
    """The run's values on its stage's grid ``shape``: at a change of stage resampled bilinearly,
    zeroed where the problem holds them, and the optimizer's moments reset (coarse-to-fine)."""
    values = state.values
    if values.shape != shape:
        values = on_grid(state.problem, values, shape)
        state.values = values
        state.optimizer.reset()
    return values


def _validate(state: DesignState) -> None:
    """Judge the run's grid on its validation particles
    ([`pes_ref.synthesis.common.validation`][pes_ref.synthesis.common.validation]):
    one more entry of ``state.validation``, and ``state.best`` if it is the best so far (the
    first of equals)."""
    success, final = validation_success(state.problem, state.values, state.seed, state.plan.validation_particles,
                                        state.backend)
    state.validation["iteration"].append(state.iteration)
    state.validation["success"].append(success)
    if state.best is None or success > state.best.success:
        state.best = Best(state.iteration, success, final)


def _uncharged(state: DesignState, k: int, loss: float, metric: float) -> bool:
    """Whether iteration ``k``'s batch fails its success tests while its loss is exactly 0 (so is
    its gradient: the run cannot move) on the problem's whole run (a shorter stage's horizon
    judges tests it does not reach), before a validation reached the plan's target."""
    whole = state.plan.steps_at(k) in (None, getattr(state.problem, "n_steps", None))
    return loss == 0.0 and metric < 1.0 and whole and not _reached_target(state)


def _below_target(state: DesignState) -> str:
    """`` and the best validation's ... below the target ...`` for a plan with a target, else ``""``."""
    if state.plan.target is None or state.best is None:
        return ""
    return f" and the best validation's {state.best.success:.3f}, below the target {state.plan.target:g}"


def _reached_target(state: DesignState) -> bool:
    """The plan's early stop: a validation has reached its target."""
    return state.plan.target is not None and state.best is not None and state.best.success >= state.plan.target


def run_design(state: DesignState, iterations: int | None = None, *, callback: Callable | None = None,
               progress_every: float = 2.0, checkpoint: Callable | None = None,
               checkpoint_every: float = 60.0, finish: bool = True) -> DesignState:
    """Advance ``state`` until ``state.iteration == iterations`` (default: the plan's).

    Each iteration draws its batch, takes the gradient of the objective (plus eq. (7))
    with respect to the grid values by the adjoint, masks it, and takes one optimizer
    step at the plan's learning rate. ``callback(Progress)`` is called every
    ``progress_every`` seconds and at the end (once): its stage (``"stage 2/4"``, the
    second of the plan's four) is that of the last finished iteration, its figures that
    stage's ``grid`` and ``steps`` per training run, the ``loss`` and the problem's
    metric, and its time left sums the stages still to run (a longer horizon costs
    more). The loss of one stage is not comparable with another's: a longer horizon
    sums more steps. ``checkpoint(state)`` is called every ``checkpoint_every`` seconds.

    Ctrl-C (SIGINT) or SIGTERM finishes the current iteration and stops with ``status =
    "interrupted"``. A non-finite loss, gradient or trajectory (``status = "non-finite:
    ..."``), or an iteration whose grid has steepened past the stability rule
    (``"unstable: ..."``, docs/spec.md section 10), stops the run and rolls it back one
    iteration, to the last grid whose run was finite and stable; resuming it repeats that
    iteration, so change the plan (a smaller ``lr``, ``clip``) first. A batch whose loss is
    exactly 0 while some of its particles fail their success tests (on the problem's whole
    run, before the plan's target is reached) stops it too (``"uncharged: ..."``): its
    gradient is 0, so the run could only end on the grid it has; what fails is not charged.

    A plan that validates (``validate_every``,
    [`pes_ref.synthesis.common.validation`][pes_ref.synthesis.common.validation]) judges the grid
    before the first iteration, every that many and after the last, keeps the best (``state.best``),
    stops early once one reaches the plan's ``target``, and a run that is done ends on the best grid
    (``state.values``); resuming a done run for more iterations continues from that grid. A run that
    is done ends on its problem's ``final_values`` of that grid (the grid itself, except a
    realizable funnel from the ``"envelope"`` start: its channel made convex again,
    [`pes_ref.synthesis.kinds.envelope.convex_channel`][pes_ref.synthesis.kinds.envelope.convex_channel]).
    The validations are part of the state a design file holds, so a stopped run resumes bit-exactly.
    ``finish=False`` (a start of a population,
    [`pes_ref.synthesis.engine.population`][pes_ref.synthesis.engine.population]): a run that
    reaches ``iterations`` below the plan's target stays ``"running"`` on its last grid.
    """
    total = state.plan.iterations if iterations is None else checks.as_nonneg_int("iterations", iterations)
    problem, plan = state.problem, state.plan
    t_start = time.perf_counter()
    last_report = last_ckpt = t_start
    loss = metric = float("nan")
    state.status = "running"
    stages = plan.stage_list(problem, total)
    clock = Clock([(st.start, st.end, st.steps) for st in stages])

    reported = [None]                   # the iteration of the last report
    label = getattr(problem, "name", problem.kind)      # a problem file's problem by its name

    def report(now):
        reported[0] = state.iteration
        i = clock.index(max(state.iteration - 1, 0))
        st = stages[i]
        callback(Progress(f"design {label}", f"stage {st.name}", state.iteration, total, "it", clock.rate(i),
                          now - t_start, clock.seconds_left(state.iteration, total),
                          (("grid", st.grid), ("steps", st.steps), ("loss", loss), (problem.metric_name, metric))))

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
            # the validation of the grid rolled back from goes with it; a best kept from it stays
            # (its validation particles ran finite and stable)
            kept = sum(i <= state.iteration for i in state.validation["iteration"])
            for h in state.validation.values():
                del h[kept:]

    if plan.validate_every and state.iteration == 0 and not state.validation["iteration"]:
        _validate(state)            # the start too: a run never ends below it (drawn shapes may already pass)
    with StopFlag() as flag:
        while state.iteration < total and not _reached_target(state):
            if flag.stop:
                state.status = "interrupted"
                break
            k = state.iteration
            t_k = time.perf_counter()
            values = _values_on_stage_grid(state, plan.grid_at(k, problem))
            try:
                with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                    loss_k, grad, metric = smoothed_step(problem, values, state.seed, k, plan, state.backend)
            except FloatingPointError as exc:          # NonFiniteError is one
                roll_back(f"iteration {k}: {exc}")
                break
            except UnstableStepError as exc:           # the grid steepened past the stability rule
                roll_back(f"iteration {k}: {exc}", "unstable")
                break
            if not (np.isfinite(loss_k) and np.isfinite(grad).all()):
                roll_back(f"iteration {k}: the loss or its gradient is not finite")
                break
            if _uncharged(state, k, loss_k, metric):
                state.status = (f"uncharged: iteration {k}: the loss is 0 while the batch's success is {metric:.3f}"
                                + _below_target(state) + ": nothing charges what its particles fail")
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
            loss, metric = float(loss_k), float(metric)
            state.history["loss"].append(loss)
            state.history["metric"].append(metric)
            state.iteration = k + 1
            if plan.validates_at(state.iteration, total):
                _validate(state)
            now = time.perf_counter()
            clock.tick(k, now - t_k)
            if callback is not None and now - last_report >= progress_every:
                report(now)
                last_report = now
            if checkpoint is not None and now - last_ckpt >= checkpoint_every:
                checkpoint(state)
                last_ckpt = now
        else:
            state.status = "done" if finish or _reached_target(state) else "running"
    if state.status == "done" and state.best is not None:
        state.values = state.best.values        # the run delivers its best validated grid
    if state.status == "done":
        state.values = problem.final_values(state.values)
    state.elapsed += time.perf_counter() - t_start
    if callback is not None and reported[0] != state.iteration:      # once at the end, unless just shown
        report(time.perf_counter())
    return state
