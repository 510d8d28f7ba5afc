"""A design run's stages, one after the other: the gradient iterations (a population of starts
screened first, if the plan has one), then the polish.

[`run_stages`][pes_ref.synthesis.engine.stages.run_stages] is what ``python -m pes_ref design``
runs: [`pes_ref.synthesis.engine.training.run_design`][pes_ref.synthesis.engine.training.run_design]
up to the plan's iterations, then, if the run has a polish plan,
[`pes_ref.synthesis.engine.polish.polish`][pes_ref.synthesis.engine.polish.polish] from the gradient
stage's grid. Progress, checkpoints and Ctrl-C work the same in both.

Resuming: the gradient stage continues bit-exactly from the saved optimizer state. The
polish's search state is not saved: a polish stopped part-way starts again from its
beginning (the gradient stage's grid, kept in the design file), and being deterministic it
ends where an uninterrupted polish would. Asking a polished run for more gradient
iterations drops its polish, continues the gradient stage from the grid that stage ended
with, and polishes again.
"""
from __future__ import annotations

import time
from typing import Callable

from pes_ref.core import checks
from pes_ref.core.runtime.progress import Clock, Progress
from pes_ref.core.runtime.signals import StopFlag
from pes_ref.synthesis.engine.design_state import DesignState
from pes_ref.synthesis.common.plans import PolishPlan
from pes_ref.synthesis.engine.polish import PolishStep, legendre_fourier_basis, polish
from pes_ref.synthesis.engine.population import screen_starts
from pes_ref.synthesis.engine.training import run_design

__all__ = ["run_stages", "set_polish"]


def _reopen_gradient_stage(state: DesignState) -> None:
    """Back to the end of the gradient stage: its grid, no polish progress."""
    state.values = state.base_values
    state.stage, state.base_values, state.evaluations = "gradient", None, 0
    state.polish_history = {"evaluations": [], "fitness": []}


def _run_polish(state: DesignState, flag: StopFlag, executor, tasks, callback, progress_every: float,
                checkpoint, checkpoint_every: float) -> None:
    """The polish from the gradient stage's grid (``base_values``), from its beginning."""
    if state.stage != "polish":
        state.stage, state.base_values = "polish", state.values
    plan, base = state.polish, state.base_values
    basis = legendre_fourier_basis(state.problem, base.shape, plan.fourier_order, plan.legendre_terms)
    state.values, state.evaluations = base, 0
    state.polish_history = {"evaluations": [], "fitness": []}
    state.status = "running"
    t_start = time.perf_counter()
    last = {"report": t_start, "checkpoint": t_start, "tick": t_start, "evaluations": 0}
    clock = Clock([(0, plan.evaluations)])

    def report(step: PolishStep, now: float) -> None:
        last["reported"] = step.evaluations
        callback(Progress(f"design {state.kind}", "polish", step.evaluations, plan.evaluations, "evaluations",
                          clock.rate(0), now - t_start, clock.seconds_left(step.evaluations),
                          (("fitness", step.fitness), ("start", step.fitness_start))
                          + ((("validation", step.validation),) if step.validation == step.validation else ())))

    def on_generation(step: PolishStep) -> None:
        state.evaluations = step.evaluations
        now = time.perf_counter()
        clock.tick(last["evaluations"], now - last["tick"], step.evaluations - last["evaluations"])
        last["tick"], last["evaluations"] = now, step.evaluations
        if callback is not None and now - last["report"] >= progress_every:
            report(step, now)
            last["report"] = now
        if checkpoint is not None and now - last["checkpoint"] >= checkpoint_every:
            state.values = base + basis @ step.coef
            checkpoint(state)
            last["checkpoint"] = now

    values, result = polish(state.problem, base, state.seed, plan, executor=executor, tasks=tasks,
                            callback=on_generation, stop=lambda: flag.stop, backend=state.backend)
    state.values, state.evaluations = values, result.evaluations
    state.polish_history = {"evaluations": [e for e, _ in result.history], "fitness": [f for _, f in result.history]}
    state.status = "interrupted" if result.stopped else "done"
    state.elapsed += time.perf_counter() - t_start
    if callback is not None and last.get("reported") != result.evaluations:     # once at the end, unless just shown
        share = result.validation[-1][1] if result.validation else float("nan")
        report(PolishStep(result.evaluations, result.fitness, result.fitness_start, result.coef, share),
               time.perf_counter())


def set_polish(state: DesignState, plan) -> None:
    """Give the run another polish plan; a polish finished with another plan will run again."""
    if not isinstance(plan, PolishPlan):
        raise TypeError(f"plan must be a PolishPlan, got {type(plan).__name__}")
    if plan != state.polish:
        state.polish = plan
        if state.stage == "polish" and state.status == "done":
            state.status = "interrupted"


def run_stages(state: DesignState, iterations: int | None = None, *, executor=None, tasks: int | None = None,
               callback: Callable | None = None, progress_every: float = 2.0, checkpoint: Callable | None = None,
               checkpoint_every: float = 60.0) -> DesignState:
    """Run every stage of ``state`` that is not done: the gradient iterations up to ``iterations``
    (default: the plan's), a plan with a population of starts screening them first
    ([`pes_ref.synthesis.engine.population.screen_starts`][pes_ref.synthesis.engine.population.screen_starts]), then the polish
    (if ``state.polish``).

    ``callback`` receives a
    [`pes_ref.core.runtime.progress.Progress`][pes_ref.core.runtime.progress.Progress] during both
    stages (its stage ``"stage 1/2"`` ... in the gradient stage, ``"polish"`` in the polish, with
    the ``fitness``, its ``start`` and, once judged, the best's ``validation`` share among the
    figures), every ``progress_every`` seconds and at the end of each; ``checkpoint(state)`` is
    called every ``checkpoint_every`` seconds. Ctrl-C stops either stage after its current iteration
    or generation with ``status = "interrupted"``; a gradient stage that goes non-finite stops as
    [`pes_ref.synthesis.engine.training.run_design`][pes_ref.synthesis.engine.training.run_design]
    says, and the polish does not start. ``executor`` evaluates the polish's candidates in ``tasks``
    parts (see [`pes_ref.synthesis.engine.polish.polish`][pes_ref.synthesis.engine.polish.polish]);
    both stages run on ``state.backend``.
    """
    total = state.plan.iterations if iterations is None else checks.as_nonneg_int("iterations", iterations)
    with StopFlag() as flag:
        if state.iteration < total or state.polish is None:
            if state.stage == "polish":
                _reopen_gradient_stage(state)
            screened = screen_starts(state, total, callback=callback, progress_every=progress_every)
            if screened and state.status not in ("running", "done"):     # interrupted, or every start stopped
                return state
            run_design(state, total, callback=callback, progress_every=progress_every, checkpoint=checkpoint,
                       checkpoint_every=checkpoint_every)
            if state.status != "done":
                return state
        elif state.stage == "gradient":
            state.status = "done"             # stopped right at the end of the gradient stage
        if state.polish is None or state.finished:
            return state
        if flag.stop:
            state.status = "interrupted"
            return state
        _run_polish(state, flag, executor, tasks, callback, progress_every, checkpoint, checkpoint_every)
    return state
