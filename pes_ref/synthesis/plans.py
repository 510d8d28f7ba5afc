"""Plans: how a design problem is optimized, and the project's default plans.

A :class:`Plan` holds the optimizer, its learning-rate schedule, the coarse-to-fine grid
and horizon stages, and the particles per iteration; it does not depend on the run's
total length, so a run stopped early and resumed follows the same schedule.
:data:`DEFAULT_PLANS` are the defaults of ``python -m pes_ref design``;
:data:`OSCILLATOR_OBJECTIVES` the oscillator's named settings (problem overrides and plan)
of ``design oscillator --objective NAME``. Measured in ``docs/synthesis.md``, "Results".
"""
from __future__ import annotations

from dataclasses import dataclass

from pes_ref.core import checks
from pes_ref.synthesis.optimizers import make_optimizer

__all__ = ["Plan", "DEFAULT_PLANS", "OSCILLATOR_OBJECTIVES", "DEFAULT_OSCILLATOR_OBJECTIVE"]


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
        (:func:`pes_ref.synthesis.resampling.resample`) and the optimizer's moments reset at each change. The learning
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
            raise checks.InputError("stages", f"stages must be (start_iteration, grid[, n_steps]) tuples >= 0, "
                                              f"got {self.stages!r}")
        if any(st[1] == 1 for st in stages):
            raise checks.InputError("stages", f"stages: a grid has 2 nodes per axis at least (0: the problem's), "
                                              f"got {self.stages!r}")
        if not stages or stages[0][0] != 0 or any(b[0] <= a[0] for a, b in zip(stages, stages[1:])):
            raise checks.InputError("stages", f"stages must start at iteration 0 and increase, got {self.stages!r}")
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

#: The defaults of ``python -m pes_ref design`` (measured in docs/synthesis.md, "Results").
DEFAULT_PLANS = {
    "funnel": Plan(iterations=500, lr=0.002, lr_final=0.0005, decay_iterations=400,
                   stages=((0, 25), (400, 0)), n_particles=64),
    "oscillator": OSCILLATOR_OBJECTIVES[DEFAULT_OSCILLATOR_OBJECTIVE][1],
}
