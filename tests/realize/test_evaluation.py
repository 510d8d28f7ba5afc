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
from pes_ref.synthesis.kinds.funnel import FunnelProblem

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


# ------------------------------------------------------------------ the engine the scenes run on
def test_the_surface_engine_given_as_an_engine_gives_today_s_figures_bit_for_bit(problem, device_data):
    from pes_ref.core.population import simulate_batch
    from pes_ref.synthesis.kinds.registry import evaluate
    values = _device(device_data).surface().values
    assert evaluate(problem, values, seed=3, n_particles=12, engine=simulate_batch) == \
        evaluate(problem, values, seed=3, n_particles=12)


def test_the_rigid_evaluation_of_a_small_realized_design_is_bit_identical_on_repeat(problem, device_data):
    pytest.importorskip("pymunk")
    device = _device(device_data)
    values = device.surface().values
    out = evaluate_realized(problem, values, device, seed=5, n_particles=6, engines=("surface", "rigid"))
    again = evaluate_realized(problem, values, device, seed=5, n_particles=6, engines=("surface", "rigid"))
    assert out == again
    assert out["dt"] == (problem.dt,) * 3 and out["n_steps"] == (problem.n_steps,) * 3
    assert 0.0 <= out["in_band_fraction"][2] <= 1.0 and out["exited_fraction"][2] > 0.0


def test_the_rigid_engine_keeps_the_design_s_step_where_the_barrier_would_need_less(problem, device_data):
    pytest.importorskip("pymunk")
    from pes_ref.realize.evaluation import rigid_problem
    stiff = copy.deepcopy(device_data)
    stiff["energy"]["v"] = 0.5
    device = _device(stiff)
    assert realized_problem(problem, device).dt < problem.dt
    run = rigid_problem(problem, device)
    assert (run.dt, run.n_steps) == (problem.dt, problem.n_steps) and run.engine is not None


def test_the_rigid_engine_without_pymunk_is_refused_with_the_pip_line(problem, device_data, monkeypatch):
    import sys
    from pes_ref.realize.evaluation import rigid_problem
    monkeypatch.setitem(sys.modules, "pymunk", None)
    with pytest.raises(ImportError, match=r"pip install 'pes_ref\[rigid\]'"):
        rigid_problem(problem, _device(device_data))


def test_an_unknown_engine_is_refused_naming_it(problem, device_data):
    with pytest.raises(ValueError, match="engine must be one of"):
        evaluate_realized(problem, np.zeros((GRID, GRID)), _device(device_data), engines=("soft",))


@pytest.mark.parametrize("kind", ["funnel", "oscillator", "problem"])
def test_every_kind_runs_its_design_s_scenes_on_the_engine_given_with_the_same_figures(kind):
    import _helpers
    from pes_ref.core.population import simulate_batch
    from pes_ref.synthesis import KINDS, problem_from_text
    from pes_ref.synthesis.kinds.registry import evaluate
    if kind == "problem":
        small = problem_from_text(_helpers.gather_problem(), "gather.toml")
    else:
        entry = KINDS[kind]
        small = entry.with_sets(entry.default_problem(), entry.smoke.scene(entry.default_problem()))
    values = 0.01 * np.random.default_rng(1).standard_normal(small.shape())
    calls = []

    def engine(scenes, x0s, v0s):
        calls.append(len(scenes))
        return simulate_batch(scenes, x0s, v0s)
    hooked = evaluate(small, values, seed=3, n_particles=5, engine=engine)
    assert calls                                                     # the design's runs went through it ...
    plain = evaluate(small, values, seed=3, n_particles=5)
    assert hooked.keys() == plain.keys()                             # ... and gave the same figures
    np.testing.assert_array_equal(list(hooked.values()), list(plain.values()))


def test_a_start_inside_the_parts_is_not_run_by_the_rigid_engine_and_passes_nothing(problem, device_data):
    pytest.importorskip("pymunk")
    from pes_ref.realize.evaluation import RigidRuns
    device = _device(device_data)
    scene = problem.plain().scene(np.zeros((GRID, GRID)))
    runs = RigidRuns(device)
    x0 = np.array([[0.0, 1.9], [1.05, 0.05]])                      # free; inside the plate's rim
    (traj,) = runs([scene], [x0], [None])
    assert runs.blocked == 1 and np.isnan(traj.x[:, 1]).all() and np.isfinite(traj.x[:, 0]).all()


def test_the_starts_run_keep_their_own_pushes_and_draws_when_one_is_left_out(problem, device_data):
    pytest.importorskip("pymunk")
    from pes_ref.core.effects import PerParticle
    from pes_ref.realize.evaluation import RigidRuns
    from pes_ref.rigid import simulate
    device = _device(device_data)
    scene = problem.plain().scene(np.zeros((GRID, GRID)))
    import dataclasses
    scene = dataclasses.replace(scene, n_steps=40, effects=scene.effects + (PerParticle([[0.0, -1.0], [0.0, 0.0],
                                                                                         [0.3, -0.5]]),))
    x0 = np.array([[0.0, 1.9], [0.95, 0.05], [0.2, 1.85]])
    (traj,) = RigidRuns(device)([scene], [x0], [None])
    alone = simulate(device, scene, x0[[0, 2]], fext=scene.schedule(3)[:, [0, 2]])
    np.testing.assert_array_equal(traj.x[:, [0, 2]], alone.x)
