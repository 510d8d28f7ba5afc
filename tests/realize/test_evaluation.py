"""The design's own held-out evaluation on a realized device, at the step the stability rule allows."""
from __future__ import annotations

import copy
import math
import tomllib

import numpy as np
import pytest

from pes_ref.core.stability import check_stable
from pes_ref.devices.device_file import parse_device
from pes_ref.realize import exports
from pes_ref.realize.contact import realize_contact
from pes_ref.realize.evaluation import evaluate_realized, realized_problem
from pes_ref.synthesis.funnel import FunnelProblem

GRID = 41


@pytest.fixture(scope="module")
def problem():
    return FunnelProblem(grid=GRID, n_steps=300)


@pytest.fixture(scope="module")
def device_data(problem):
    q0 = np.linspace(problem.lower[0], problem.upper[0], GRID)[:, None]
    q1 = np.linspace(problem.lower[1], problem.upper[1], GRID)[None, :]
    values = 0.2 * np.clip((np.abs(q0) - (0.25 + 0.4 * q1)) / 0.1, 0.0, 1.0) * problem.mask((GRID, GRID))
    return realize_contact(problem, values, "value", 0.1).device


def _device(data):
    return parse_device(tomllib.loads(exports.device_text(data, "test")), "test.toml")


def test_a_design_on_its_own_realized_surface_scores_the_same(problem, device_data):
    device = _device(device_data)
    values = device.surface().values
    out = evaluate_realized(problem, values, device, seed=5, n_particles=40)
    assert out["dt"] == (problem.dt, problem.dt)
    for name in ("in_band_fraction", "exit_spread", "exited_fraction"):
        assert out[name][0] == out[name][1]


def test_a_stiff_realization_runs_at_the_rule_s_step_for_the_design_s_duration(problem, device_data):
    stiff = copy.deepcopy(device_data)
    stiff["energy"]["v"] = 0.5
    run = realized_problem(problem, _device(stiff))
    assert run.dt < problem.dt
    check_stable(run.problem.scene(run.values))                     # the rule accepts it ...
    assert run.n_steps * run.dt >= problem.n_steps * problem.dt > (run.n_steps - 1) * run.dt
    assert run.problem.noise == pytest.approx(problem.noise * math.sqrt(problem.dt / run.dt), rel=1e-12)
    with pytest.raises(ValueError, match="stability limit"):    # ... and refuses the design's own step
        check_stable(problem.scene(run.values))


def test_a_device_on_another_grid_is_refused(problem, device_data):
    other = copy.deepcopy(device_data)
    other["cspace"]["shape"] = [GRID + 2, GRID + 2]
    with pytest.raises(ValueError, match="is not the design's"):
        realized_problem(problem, _device(other))
