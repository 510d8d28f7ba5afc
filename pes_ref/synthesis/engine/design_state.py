"""The state of one design run, and how a fresh one starts.

A [`DesignState`][pes_ref.synthesis.engine.design_state.DesignState] is one run in progress
(problem, plan, seed, grid values, optimizer state, iteration, loss history, and the optional polish
stage's plan and progress), which
[`pes_ref.synthesis.engine.design_file`][pes_ref.synthesis.engine.design_file] saves and loads;
[`new_design`][pes_ref.synthesis.engine.design_state.new_design] starts one, after the refusals of
[`pes_ref.synthesis.engine.refusals`][pes_ref.synthesis.engine.refusals].
[`pes_ref.synthesis.engine.training`][pes_ref.synthesis.engine.training] advances its gradient stage
and [`pes_ref.synthesis.engine.stages`][pes_ref.synthesis.engine.stages] runs both stages.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from pes_ref.core import backends, checks
from pes_ref.synthesis.kinds.registry import kind_named
from pes_ref.synthesis.common.plans import Plan, PolishPlan
from pes_ref.synthesis.engine.refusals import check_run_memory, check_stable_design
from pes_ref.synthesis.common.validation import Best, on_grid

__all__ = ["DesignState", "new_design", "STOPPED", "STAGES"]

#: The statuses of a run that stopped on a failed iteration (rolled back to the last good state):
#: its run left the finite numbers, or its grid steepened past the stability rule; or whose loss
#: was 0 while particles of its batch failed their tests (nothing to follow: no step taken).
STOPPED = ("non-finite", "unstable", "uncharged")

#: A run's stages in order: gradient descent on the grid values, then (if it has a polish plan) the polish.
STAGES = ("gradient", "polish")


@dataclass
class DesignState:
    """One design run: problem, plan, seed, grid values, optimizer, iteration, history, polish.

    Mutable on purpose (it is what the design loop advances); every field is plain data that
    [`pes_ref.synthesis.engine.design_file`][pes_ref.synthesis.engine.design_file] writes and reads
    back bit-exactly. ``history`` maps ``"loss"`` and ``"metric"`` to lists with one float per
    finished iteration; ``status`` is ``"running"``, ``"done"``, ``"interrupted"``, or one of
    `STOPPED` followed by ``": iteration k: <reason>"``.

    ``polish`` is the [`PolishPlan`][pes_ref.synthesis.common.plans.PolishPlan] of the stage that follows
    the gradient iterations (None: none). ``stage`` is the stage the run is in (`STAGES`);
    in the polish stage ``base_values`` holds the gradient stage's final grid (where the polish
    starts), ``values`` the best polished grid so far, ``evaluations`` the fitness evaluations
    made and ``polish_history`` maps ``"evaluations"`` and ``"fitness"`` to the count and the
    best fitness after the start and each generation.

    ``backend`` names the loops that run it (`pes_ref.core.backends.BACKENDS`): the
    gradients, hence the design, depend on it in their last bits, so a run keeps its own
    (the same backend reproduces a design bit for bit).

    ``validation`` maps ``"iteration"`` and ``"success"`` to the iterations after which a plan
    that validates judged the grid and the validation success there; ``best`` is the best of
    them so far ([`pes_ref.synthesis.common.validation.Best`][pes_ref.synthesis.common.validation.Best], None before the first).

    ``screened`` counts a population's screening
    ([`pes_ref.synthesis.engine.population`][pes_ref.synthesis.engine.population]): ``"starts"`` screened and the
    ``"iterations"`` they ran together (the chosen start's among them; 0 and 0 for a run that screened none).
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
    backend: str = "numpy"
    validation: dict = dataclasses.field(default_factory=lambda: {"iteration": [], "success": []})
    best: Best | None = None
    screened: dict = dataclasses.field(default_factory=lambda: {"starts": 0, "iterations": 0})

    @property
    def kind(self) -> str:
        """The problem's kind (``"funnel"``, ``"oscillator"``, ``"problem"``)."""
        return self.problem.kind

    @property
    def method(self) -> str:
        """``"gradient"`` or ``"gradient+polish"``: the stages this run has."""
        return "gradient" if self.polish is None else "gradient+polish"

    @property
    def grid_iteration(self) -> int:
        """The iteration whose grid the run holds as its design: a done run that validated delivers
        its best validated grid (``best``), which may be an earlier iteration's than the last
        (a polish starts from that grid); otherwise the last iteration's."""
        if self.best is not None and (self.status == "done" or self.stage == "polish"):
            return self.best.iteration
        return self.iteration

    @property
    def finished(self) -> bool:
        """Every stage of the run is done."""
        return self.status == "done" and (self.polish is None or self.stage == "polish")


def new_design(kind, seed: int = 0, plan: Plan | None = None, polish: PolishPlan | None = None,
               backend: str | None = None, start_values=None, **params) -> DesignState:
    """A fresh run of a problem ``kind`` (a problem object: a
    [`DesignProblem`][pes_ref.synthesis.problem.design_problem.DesignProblem] from a problem file or built in code,
    a [`FunnelProblem`][pes_ref.synthesis.kinds.funnel.FunnelProblem] or
    [`OscillatorProblem`][pes_ref.synthesis.kinds.oscillator.OscillatorProblem]), or of a built-in kind by its name
    (``"funnel"``, ``"oscillator"``) with problem overrides ``params``.

    Without ``plan`` the run has its kind's default plan (a problem file's own: its ``[train]``
    section, or the default plan of a file without one) and, unless ``polish`` is given, its
    default polish stage (`pes_ref.synthesis.kinds.registry.DesignKind.default_polish`); with a
    ``plan`` it has the ``polish`` given (None: the gradient stage alone). ``backend`` (None:
    [`pes_ref.core.backends.default_backend`][pes_ref.core.backends.default_backend]) runs it.
    ``start_values`` (a finite grid of the problem's final shape) is the start made elsewhere (a realizable problem
    file's without drawn shapes: [`pes_ref.synthesis.engine.paths_start`][pes_ref.synthesis.engine.paths_start]),
    resampled to the plan's first grid; None: the problem's ``initial_values``.
    """
    seed = checks.as_nonneg_int("seed", seed)
    backend = backends.check_backend(backend)
    if polish is not None and not isinstance(polish, PolishPlan):
        raise TypeError(f"polish must be a PolishPlan or None, got {type(polish).__name__}")
    if isinstance(kind, str):
        entry = kind_named(kind)
        if entry.default_problem is None:
            raise TypeError(f"a {kind!r} design starts from its problem object (a problem file read with "
                            f"pes_ref.synthesis.load_problem), not from its kind's name")
        problem = entry.with_sets(entry.default_problem(), params)
    else:
        problem, entry = kind, kind_named(getattr(kind, "kind", None))
        if params:
            raise TypeError(f"problem overrides {sorted(params)} are for a kind named by its name; change a "
                            f"problem object's parameters with its kind's with_sets (pes_ref.synthesis.KINDS)")
    if plan is None:
        plan, polish = entry.default_plan(problem), entry.default_polish if polish is None else polish
    check_run_memory(problem, plan, polish)         # before the first grid is made
    rng = np.random.default_rng([seed, 2 ** 32])       # the init draw, apart from every iteration's
    shape = plan.grid_at(0, problem)
    if start_values is None:
        values = problem.initial_values(rng, shape)
    else:
        values = on_grid(problem, checks.as_float_array("start_values", start_values, shape=tuple(problem.shape())),
                         shape)
    problem.scene(values)           # the scene's own checks (dt, wall margins ...), once, before any run
    state = DesignState(problem, plan, seed, values, plan.make_optimizer(), polish=polish, backend=backend)
    check_stable_design(state)
    return state
