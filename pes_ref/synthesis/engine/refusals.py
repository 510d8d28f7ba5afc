"""What a design run refuses before it starts: a scene past the stability rule, and
iterations that cannot fit in the memory there is.

Both take a [`DesignState`][pes_ref.synthesis.engine.design_state.DesignState] (a fresh one, or one
resumed with a changed plan) and raise a keyed error naming what to change; the ``design`` command
and [`pes_ref.synthesis.new_design`][pes_ref.synthesis.engine.design_state.new_design] call them
before anything is written or run.
"""
from __future__ import annotations

from pes_ref.core import budget
from pes_ref.core.stability import check_stable

__all__ = ["check_stable_design", "check_design_memory", "check_run_memory"]


def check_stable_design(state) -> None:
    """Refuse a run whose scene is past the stability rule (docs/spec.md section 10) on its
    current grid, before it runs: [`UnstableStepError`][pes_ref.core.stability.UnstableStepError] naming
    ``dt`` (e.g. a ``dt`` or ``wall_k`` override too large for the problem's springs and
    walls). Every iteration checks its own scene again as the grid changes."""
    check_stable(state.problem.scene(state.values))


def check_design_memory(state) -> None:
    """Refuse a run whose training iterations cannot fit in the available memory, before it
    runs: [`RunTooLargeError`][pes_ref.core.budget.RunTooLargeError] naming the grid's size (``grid``,
    ``grid0`` or ``grid1``; or ``stages``, when a stage's grid is the largest), or ``n_steps``
    (or ``stages``, when a stage's horizon is the longest) and ``n_particles`` (the plan's
    particles per iteration)."""
    check_run_memory(state.problem, state.plan, state.polish)


def check_run_memory(problem, plan, polish) -> None:
    """[`check_design_memory`][pes_ref.synthesis.engine.refusals.check_design_memory] of a run of ``problem`` by ``plan`` and
    ``polish``
    (a [`PolishPlan`][pes_ref.synthesis.common.plans.PolishPlan] or None), before its grid exists."""
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
