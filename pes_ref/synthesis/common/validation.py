"""Validation of a design run: a grid judged by the problem's success on fixed particles, and the best kept.

A plan with ``validate_every > 0`` ([`pes_ref.synthesis.common.plans.Plan`][pes_ref.synthesis.common.plans.Plan]) judges the run's
grid before its first iteration and every that many iterations: the grid resampled to the problem's own (what the run would
deliver, whatever its stage's grid), run on ``validation_particles`` particles drawn by the
training sampler from ``numpy.random.default_rng([seed, VALIDATION_STREAM])`` and scored by
the problem's ``batch_metric`` (the share passing every success test; for a problem that charges
its scenarios, the share of the particles that pass in the run and in every such scenario). The particles are the
same at every validation, so the scores compare grids, and they are neither a training
iteration's (``[seed, k]``, ``k < 2**32``), the initial grid's (``[seed, 2**32]``), the
polish's (``[seed, 2**32 + 1]``) nor a held-out seed's (a plain integer): selecting on them
does not select on the held-out particles ``evaluate`` reports.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from pes_ref.core.scene import simulate
from pes_ref.core.stability import UnstableStepError
from pes_ref.synthesis.common.resampling import resample

__all__ = ["VALIDATION_STREAM", "Best", "on_grid", "validation_success"]

#: The second entry of the validation particles' seed sequence ``[seed, VALIDATION_STREAM]``.
VALIDATION_STREAM = 2 ** 32 + 2


class Best(NamedTuple):
    """The best validated grid of a run so far: after ``iteration`` iterations, its validation
    ``success`` and its ``values`` on the problem's grid."""

    iteration: int
    success: float
    values: np.ndarray


def on_grid(problem, values, shape: tuple) -> np.ndarray:
    """``values`` on a grid of ``shape``: resampled bilinearly if it differs, zero where the problem holds them."""
    if values.shape == tuple(shape):
        return values
    return resample(values, problem.lower, problem.upper, problem.periodic, shape) * problem.mask(shape)


def validation_success(problem, values, seed: int, n_particles: int, backend: str | None = None) -> tuple:
    """``(success, final_values)``: ``values`` on the problem's grid and the share of the run's
    validation particles that pass its success tests there (0 for a run that leaves the
    finite numbers or the stability rule)."""
    final = on_grid(problem, values, problem.shape())
    key = [seed, VALIDATION_STREAM]
    batch = problem.batch(final, np.random.default_rng(key), n_particles)
    scenarios = getattr(problem, "charged_scenarios", ())
    try:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            traj = simulate(batch.scene, batch.x0, batch.v0, backend=backend)
            if not scenarios:
                return float(problem.batch_metric(traj)), final
            ok = problem.batch_passes(traj)
            for scenario in scenarios:        # the same particles must pass each charged scenario's tests too
                other = problem.scenario_batch(final, np.random.default_rng(key), n_particles, scenario)
                ok &= problem.batch_passes(simulate(other.scene, other.x0, other.v0, backend=backend), scenario.tests)
    except (FloatingPointError, UnstableStepError):
        return 0.0, final
    return float(np.mean(ok)), final
