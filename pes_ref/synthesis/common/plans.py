"""Plans: how a design problem is optimized, and the project's default plans.

A [`Plan`][pes_ref.synthesis.common.plans.Plan] holds the gradient stage: the optimizer, its learning-rate schedule, the
coarse-to-fine grid and horizon stages, and the particles per iteration; it does not depend
on the run's total length, so a run stopped early and resumed follows the same schedule. A
[`PolishPlan`][pes_ref.synthesis.common.plans.PolishPlan] holds the optional gradient-free stage that follows it
([`pes_ref.synthesis.engine.polish`][pes_ref.synthesis.engine.polish]). `OSCILLATOR_PLANS` (problem overrides and plan)
and `OSCILLATOR_POLISH` are the oscillator's named training plans of ``design oscillator
--plan NAME``, [`default_plan`][pes_ref.synthesis.common.plans.default_plan] the plan of a problem file without ``[train]``;
each kind's
default is its entry in `pes_ref.synthesis.kinds.registry.KINDS`. Measured in ``docs/synthesis.md``, "Results".
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from pes_ref.core import checks
from pes_ref.synthesis.common.optimizers import make_optimizer

__all__ = ["Plan", "Stage", "PolishPlan", "default_plan", "coarse_to_fine", "FUNNEL_PLAN", "FUNNEL_ENVELOPE_PLAN",
           "OSCILLATOR_PLANS", "OSCILLATOR_POLISH", "DEFAULT_OSCILLATOR_PLAN", "POLISH_METHODS"]


class Stage(NamedTuple):
    """One stage of a staged run: its name (``"2/4"``: the second of four), iterations
    ``[start, end)``, grid shape and steps per training run."""

    name: str
    start: int
    end: int
    grid: tuple
    steps: int


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
        ([`pes_ref.synthesis.common.resampling.resample`][pes_ref.synthesis.common.resampling.resample]) and the optimizer's moments
        reset at each change. The learning
        rate of a stage is multiplied by ``(first stage's grid / this stage's grid)``: RMSprop
        moves every node by about ``lr`` whatever its gradient's size, so on a grid ``r``
        times finer the same ``lr`` would roughen the surface ``r`` times more per cell
        (unless ``scale_lr_by_grid`` is False).
    n_particles : int
        Particles per iteration.
    scale_lr_by_grid : bool
        Whether a stage's learning rate is scaled by the grid ratio (above).
    validate_every : int
        0 (off), or before the first iteration, every this many and after the run's last, the design, resampled
        to the problem's grid, is judged on ``validation_particles`` fixed validation particles
        ([`pes_ref.synthesis.common.validation`][pes_ref.synthesis.common.validation]) by the problem's success share; the run keeps
        the best such grid and ends on it.
    validation_particles : int
    target : float or None
        With validation: stop once a validation reaches this success share (None: never early).
    smoothing : float
        Randomized smoothing (energy; 0: off): an iteration's gradient is the mean of
        ``smoothing_draws`` design gradients, each on the grid plus ``smoothing`` times a normal
        draw (zero where the problem holds the grid) with its share of the ``n_particles``: the
        exact gradient of the mean loss over the perturbed grids, at the same particle budget. A
        designed surface's gradient turns under a perturbation the size of one step; the mean
        over nearby grids is the gradient of a smoothed objective (Suh et al., ICML 2022;
        measured in docs/problems.md, "The default plan").
    smoothing_draws : int
        The perturbed grids of an iteration with ``smoothing`` (at most ``n_particles``).
    starts : int
        A population of starts (1: the run's own alone): before the rest of the run, this many
        starts each run the first ``screen`` iterations and the run goes on from the one its
        validation particles judge best ([`pes_ref.synthesis.engine.population`][pes_ref.synthesis.engine.population]; a plan
        with more than one validates).
    screen : int
        The iterations each start runs before the choice.
    """

    iterations: int = 300
    optimizer: str = "rmsprop"
    lr: float = 0.01
    lr_final: float = 0.01
    decay_iterations: int = 300
    clip: float | None = None
    stages: tuple = ((0, 0),)
    n_particles: int = 64
    scale_lr_by_grid: bool = True
    validate_every: int = 0
    validation_particles: int = 200
    target: float | None = None
    smoothing: float = 0.0
    smoothing_draws: int = 4
    starts: int = 1
    screen: int = 0

    def __post_init__(self):
        checks.as_positive_int("iterations", self.iterations)
        checks.as_choice("optimizer", self.optimizer, {"rmsprop", "adam"})
        checks.as_positive_float("lr", self.lr)
        checks.as_positive_float("lr_final", self.lr_final)
        checks.as_positive_int("decay_iterations", self.decay_iterations)
        if self.clip is not None:
            checks.as_positive_float("clip", self.clip)
        checks.as_positive_int("n_particles", self.n_particles)
        if not isinstance(self.scale_lr_by_grid, bool):
            raise TypeError(f"scale_lr_by_grid must be a bool, got {self.scale_lr_by_grid!r}")
        checks.as_nonneg_int("validate_every", self.validate_every)
        checks.as_positive_int("validation_particles", self.validation_particles)
        if self.target is not None and not 0.0 < checks.as_finite_float("target", self.target) <= 1.0:
            raise checks.InputError("target", f"target must be in (0, 1], got {self.target!r}")
        checks.as_nonneg_float("smoothing", self.smoothing)
        checks.as_positive_int("smoothing_draws", self.smoothing_draws)
        if self.smoothing and self.smoothing_draws > self.n_particles:
            raise checks.InputError("smoothing_draws", f"smoothing_draws = {self.smoothing_draws} is more than the "
                                                       f"{self.n_particles} particles per iteration shared among them")
        checks.as_positive_int("starts", self.starts)
        checks.as_nonneg_int("screen", self.screen)
        if self.starts > 1 and not (self.validate_every and self.screen):
            raise checks.InputError("starts", f"starts = {self.starts} chooses among starts on validation after "
                                              f"screen iterations: give validate_every and screen > 0")
        stages = tuple(tuple(int(x) for x in st) + (0,) * (3 - len(st)) for st in self.stages)
        if any(len(st) != 3 or min(st) < 0 for st in stages):
            raise checks.InputError("stages", f"stages must be (start_iteration, grid[, n_steps]) tuples >= 0, "
                                              f"got {self.stages!r}")
        if any(st[1] == 1 for st in stages):
            raise checks.InputError("stages", f"stages: a grid has 2 nodes per axis at least (0: the problem's), "
                                              f"got {self.stages!r}")
        if not stages or stages[0][0] != 0 or any(b[0] <= a[0] for a, b in zip(stages, stages[1:])):
            raise checks.InputError("stages", f"stages must start at iteration 0 and increase, got {self.stages!r}")
        object.__setattr__(self, "stages", stages)

    def stage_at(self, iteration: int) -> tuple:
        """The entry of ``stages`` in force at ``iteration`` (the last one that starts at or before it)."""
        return [st for st in self.stages if st[0] <= iteration][-1]

    def grid_at(self, iteration: int, problem) -> tuple:
        """The grid shape of ``problem`` at ``iteration``: its stage's grid (``problem.shape(grid)``), or
        the problem's own when the stage's grid is 0."""
        return problem.shape(self.stage_at(iteration)[1] or None)

    def steps_at(self, iteration: int):
        """The training runs' n_steps at ``iteration`` (None: the problem's own)."""
        return self.stage_at(iteration)[2] or None

    def stage_list(self, problem, total: int) -> list:
        """The [`Stage`][pes_ref.synthesis.common.plans.Stage] list a run of ``problem`` to ``total`` iterations goes through
        (a plan with one stage: ``"1/1"``)."""
        starts = [st for st in self.stages if st[0] < total] or [self.stages[0]]
        ends = [st[0] for st in starts[1:]] + [total]
        return [Stage(f"{i + 1}/{len(starts)}", st[0], end, self.grid_at(st[0], problem),
                      self.steps_at(st[0]) or problem.n_steps)
                for i, (st, end) in enumerate(zip(starts, ends))]

    def lr_at(self, iteration: int, problem) -> float:
        """``lr (lr_final / lr)^min(1, k / decay_iterations)``, times the stage's grid ratio if ``scale_lr_by_grid``."""
        frac = min(1.0, iteration / self.decay_iterations)
        lr = self.lr * (self.lr_final / self.lr) ** frac
        if not self.scale_lr_by_grid:
            return lr
        return lr * (self.grid_at(0, problem)[0] / self.grid_at(iteration, problem)[0])

    def validates_at(self, iteration: int, total: int) -> bool:
        """Whether the design after ``iteration`` iterations (of ``total``) is validated."""
        return self.validate_every > 0 and (iteration % self.validate_every == 0 or iteration == total)

    def make_optimizer(self):
        """A fresh optimizer of the plan: ``optimizer`` with ``lr`` and ``clip``
        ([`pes_ref.synthesis.common.optimizers.make_optimizer`][pes_ref.synthesis.common.optimizers.make_optimizer])."""
        return make_optimizer(self.optimizer, lr=self.lr, clip=self.clip)


#: Gradient-free searches of the polish stage (`PolishPlan` ``method``): pycma's CMA-ES and
#: scipy's differential evolution (measured in docs/synthesis.md; CMA-ES is the default).
POLISH_METHODS = ("cma", "de")


@dataclass(frozen=True)
class PolishPlan:
    """The polish stage: a gradient-free search over ``coef`` in ``values + B coef``.

    ``B``
    ([`pes_ref.synthesis.engine.polish.legendre_fourier_basis`][pes_ref.synthesis.engine.polish.legendre_fourier_basis])
    is ``legendre_terms`` Legendre polynomials in ``q0 / q0_extent`` times ``1, cos k q1, sin k q1``
    for ``k <= fourier_order`` (72 terms by default); ``values`` is the gradient stage's grid. The
    fitness
    ([`pes_ref.synthesis.engine.polish.capture_fitness`][pes_ref.synthesis.engine.polish.capture_fitness])
    runs ``n_particles`` fixed training particles for ``periods`` target periods (None: the
    problem's ``eval_periods``) and judges them with the capture test of ``evaluate``.

    Parameters
    ----------
    method : {"cma", "de"}
        pycma's CMA-ES from ``coef = 0`` with step ``sigma0``, or scipy's differential
        evolution in the box ``[-bound, bound]^n`` (``coef = 0`` in its first population).
    evaluations : int
        Fitness evaluations: the search stops after the generation that reaches it.
    popsize : int
        Candidates per generation (16 is pycma's own default for 72 terms; for ``"de"`` the
        population is the nearest multiple of the term count, at least one).
    n_particles, rest_share, center_share, center_std, rest_max_share : int, float, float, float, float
        The training particles
        ([`pes_ref.synthesis.engine.polish.polish_particles`][pes_ref.synthesis.engine.polish.polish_particles]).
    margin_weight : float
        Weight of the smooth margin term of the fitness.
    strictness : float in (0, 1]
        A training particle counts as captured only within ``strictness`` times the capture
        test's tolerances (1: the test of ``evaluate`` itself).
    target : float
        Stop early once the best fitness is at or below it.
    validation_particles : int
        0 (off), or the fixed validation particles the best candidate is judged on
        ([`pes_ref.synthesis.engine.polish.validation_particles`][pes_ref.synthesis.engine.polish.validation_particles]:
        shaped like the held-out torque sweep and grid of starts, from their own seed) by the share
        the capture test of ``evaluate`` passes.
    validate_every : int
        With validation: after every this many generations, the best candidate so far is
        judged (unless it was judged already).
    validation_target : float or None
        With validation: stop once the best candidate's validation share reaches it (None:
        never early). The training fitness keeps improving past the point where the held-out
        share does; the validation share says when the design is done.
    """

    method: str = "cma"
    evaluations: int = 3000
    sigma0: float = 0.01
    popsize: int = 16
    bound: float = 0.1
    fourier_order: int = 4
    legendre_terms: int = 8
    n_particles: int = 96
    rest_share: float = 2 / 3
    center_share: float = 1 / 3
    center_std: float = 0.05
    rest_max_share: float = 0.5
    periods: float | None = None
    margin_weight: float = 0.05
    strictness: float = 1.0
    target: float = 0.0
    validation_particles: int = 150
    validate_every: int = 5
    validation_target: float | None = 0.96

    def __post_init__(self):
        checks.as_choice("method", self.method, set(POLISH_METHODS))
        checks.as_nonneg_int("validation_particles", self.validation_particles)
        checks.as_positive_int("validate_every", self.validate_every)
        if self.validation_target is not None and \
                not 0.0 < checks.as_finite_float("validation_target", self.validation_target) <= 1.0:
            raise ValueError(f"validation_target must be in (0, 1], got {self.validation_target!r}")
        for name in ("evaluations", "popsize", "legendre_terms", "n_particles"):
            checks.as_positive_int(name, getattr(self, name))
        checks.as_nonneg_int("fourier_order", self.fourier_order)
        for name in ("sigma0", "bound"):
            checks.as_positive_float(name, getattr(self, name))
        for name in ("center_std", "margin_weight", "target"):
            checks.as_nonneg_float(name, getattr(self, name))
        for name in ("rest_share", "center_share", "rest_max_share"):
            if not 0.0 <= checks.as_finite_float(name, getattr(self, name)) <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {getattr(self, name)!r}")
        if not 0.0 < checks.as_finite_float("strictness", self.strictness) <= 1.0:
            raise ValueError(f"strictness must be in (0, 1], got {self.strictness!r}")
        if self.periods is not None:
            checks.as_positive_float("periods", self.periods)

    @property
    def n_terms(self) -> int:
        """Coefficients searched: ``legendre_terms (2 fourier_order + 1)``."""
        return self.legendre_terms * (2 * self.fourier_order + 1)


#: The oscillator's named training plans (``design oscillator --plan NAME``): the problem
#: overrides that choose the objective it trains on (``cost``), its aim and weight, and the Plan.
#: "gait" (the default) is prescribed-gait multiple shooting (`pes_ref.synthesis.kinds.gait`):
#: Adam, lr 1e-2 -> 1e-4 geometric over the 3000 iterations (no grid scaling), 128 starts on the
#: cycle and the gait per iteration, one-period runs, 16 x 16 until 1500 then the scene's 32 x 32;
#: its polish follows (`OSCILLATOR_POLISH`: up to 3000 evaluations, stopped once the best
#: candidate captures 0.96 of its validation particles). "eq6" is the paper's setting, eq. (6) + eq. (7)
#: aimed at the target amplitude A, and "overshoot" (the best eq. (6) plan of docs/synthesis.md)
#: aims the same cost at 1.4 A; these two share the plan: RMSprop, lr 5e-4 -> 5e-5, 16 particles,
#: a horizon curriculum of 250/400/600/1000 steps (2 to 8 periods) on a 16 x 16 grid for 500
#: iterations, then 32 x 32.
_GAIT_PLAN = Plan(iterations=3000, optimizer="adam", lr=1e-2, lr_final=1e-4, decay_iterations=2999,
                  n_particles=128, stages=((0, 16), (1500, 0)), scale_lr_by_grid=False)
_OSC_PLAN = Plan(iterations=3000, lr=0.0005, lr_final=0.00005, decay_iterations=3000, n_particles=16,
                 stages=((0, 16, 250), (500, 0, 400), (1000, 0, 600), (2000, 0, 1000)))
_OSC_SHARED = {"target_scale": 1.0, "stratified": False, "spread_share": 0.0, "settle_periods": 0.0}
_OSC_PAPER = {**_OSC_SHARED, "cost": "eq6", "regularization": 1e-4}
OSCILLATOR_PLANS = {
    "gait": ({**_OSC_SHARED, "cost": "gait", "regularization": 0.0}, _GAIT_PLAN),
    "overshoot": ({**_OSC_PAPER, "target_scale": 1.4}, _OSC_PLAN),
    "eq6": (_OSC_PAPER, _OSC_PLAN),
}
#: The polish stage that follows each named plan's gradient stage (None: none).
OSCILLATOR_POLISH = {"gait": PolishPlan(), "overshoot": None, "eq6": None}
#: The named plan ``design oscillator`` uses without ``--plan`` (the problem's field defaults match it).
DEFAULT_OSCILLATOR_PLAN = "gait"

#: The funnel's default plan (measured in docs/synthesis.md, "Results").
FUNNEL_PLAN = Plan(iterations=500, lr=0.002, lr_final=0.0005, decay_iterations=400, stages=((0, 25), (400, 0)),
                   n_particles=64)
#: The default plan of a realizable funnel from the ``"envelope"`` start (``init_shape``;
#: measured in docs/realize.md, "The candidates"): 100 iterations of RMSprop at lr 5e-4 on the
#: problem's own grid (a coarse grid would not hold the start), validated every 10 on 200
#: particles, ending on the best validated grid (its channel made convex:
#: `pes_ref.synthesis.kinds.envelope.convex_channel`).
FUNNEL_ENVELOPE_PLAN = Plan(iterations=100, lr=0.0005, lr_final=0.0005, decay_iterations=100, stages=((0, 0),),
                            n_particles=64, validate_every=10, validation_particles=200)


#: The grids (nodes along axis 0) of `coarse_to_fine`'s stages below the final grid: each
#: about twice the last, so a stage refines the one before by resampling (5, 9, 17, ...).
COARSE_GRIDS = (5, 9, 17)
#: The plan of a problem file without ``[train]`` (its measured comparison is in
#: docs/problems.md, "The default plan"): `coarse_to_fine` stages, RMSprop from ``lr`` to
#: ``lr_final`` over the run, and validation every ``validate_every`` iterations with an early
#: stop at ``target`` (no randomized smoothing: measured there, it did not pay for its time).
DEFAULT_FILE_PLAN = {"iterations": 300, "lr": 0.005, "lr_final": 0.005, "n_particles": 128,
                     "validate_every": 10, "validation_particles": 200, "target": 0.97}


#: The default plan's population of starts (`default_starts`; measured in docs/problems.md, "Phases,
#: classes and timing windows").
DEFAULT_STARTS = 8


def coarse_to_fine(n0: int, iterations: int) -> tuple:
    """Stages of equal shares of ``iterations`` on the `COARSE_GRIDS` below ``n0`` nodes,
    then the final grid: ``((0, 5), (75, 9), (150, 17), (225, 0))`` for 300 iterations on a grid of 40."""
    grids = [g for g in COARSE_GRIDS if g < n0] + [0]
    return tuple((iterations * i // len(grids), g) for i, g in enumerate(grids))


def default_plan(shape, coarse: bool = True, iterations: int | None = None) -> Plan:
    """The plan of a problem file without ``[train]``, on a final grid of ``shape`` (`DEFAULT_FILE_PLAN`),
    its stages shared out over ``iterations`` (None: the plan's 300; ``--iterations``).

    ``coarse=False`` (a design that starts from drawn shapes, a realizable contact's ``blocked``)
    designs on the final grid throughout: a coarse grid would not hold the shapes it starts from."""
    its = DEFAULT_FILE_PLAN["iterations"]
    stages = coarse_to_fine(shape[0], iterations or its) if coarse else ((0, 0),)
    return Plan(**DEFAULT_FILE_PLAN, decay_iterations=its, stages=stages, **default_starts(stages))


def default_starts(stages: tuple) -> dict:
    """The default plan's population of starts for ``stages`` (``starts``, ``screen``): `DEFAULT_STARTS`
    starts, each screened through the coarse stages (to the start of the last stage, the final
    grid); none (one start) for a plan on its final grid throughout."""
    if len(stages) < 2:
        return {"starts": 1, "screen": 0}
    return {"starts": DEFAULT_STARTS, "screen": stages[-1][0]}
