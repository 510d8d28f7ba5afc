"""What a design run refuses before it starts: a scene past the stability rule, and
iterations that cannot fit in the memory there is.

Both take a :class:`~pes_ref.synthesis.design_state.DesignState` (a fresh one, or one
resumed with a changed plan) and raise a keyed error naming what to change; the
``design`` command and :func:`pes_ref.synthesis.new_design` call them before anything
is written or run.
"""
from __future__ import annotations

from pes_ref.core import budget
from pes_ref.core.stability import check_stable

__all__ = ["check_stable_design", "check_design_memory"]


def check_stable_design(state) -> None:
    """Refuse a run whose scene is past the stability rule (docs/spec.md section 10) on its
    current grid, before it runs: :class:`~pes_ref.core.stability.UnstableStepError` naming
    ``dt`` (e.g. a ``dt`` or ``wall_k`` override too large for the problem's springs and
    walls). Every iteration checks its own scene again as the grid changes."""
    check_stable(state.problem.scene(state.values))


def check_design_memory(state) -> None:
    """Refuse a run whose training iterations cannot fit in the available memory, before it
    runs: :class:`~pes_ref.core.budget.RunTooLargeError` naming ``n_steps`` (or ``stages``,
    when a stage's horizon is the longest) and ``n_particles`` (the plan's particles per iteration)."""
    plan, own = state.plan, state.problem.n_steps
    steps = max(st[2] or own for st in plan.stages)
    if steps == own:
        budget.check_memory(steps, plan.n_particles, "value_and_grad", particles="n_particles")
    else:                                   # a stage's horizon is the longest
        budget.check_memory(steps, plan.n_particles, "value_and_grad", steps="stages", particles="n_particles",
                            length=f"stages of {steps} steps")
