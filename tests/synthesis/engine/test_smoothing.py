"""Randomized smoothing (Plan.smoothing): an iteration's gradient is the exact gradient of the mean loss
over its perturbed grids, each draw with its share of the particles."""
import numpy as np
import pytest

import _helpers
from pes_ref import synthesis
from pes_ref.core.checks import InputError
from pes_ref.synthesis import Plan, problem_from_text
from pes_ref.synthesis.engine.training import SMOOTHING_STREAM, design_step, smoothed_step
from pes_ref.testing.finite_differences import directional_derivative

PROBLEM = problem_from_text(_helpers.gather_problem(noise=True), "gather.toml")
PLAN = Plan(iterations=3, n_particles=7, smoothing=0.01, smoothing_draws=3)


def _values():
    return 0.02 * np.random.default_rng(5).standard_normal(PROBLEM.shape())


def _mean_loss(values, plan=PLAN, iteration=2, problem=PROBLEM):
    """The smoothed loss by hand: the same perturbations (none where the problem holds the grid)
    and particles, the loss of each draw."""
    z = np.random.default_rng([0, iteration, SMOOTHING_STREAM]).standard_normal((plan.smoothing_draws,) + values.shape)
    held = problem.mask(values.shape)
    counts = [3, 2, 2]
    return np.mean([design_step(problem, values + plan.smoothing * z[j] * held, 0, iteration, counts[j], None,
                                "numpy", draw=j)[0] for j in range(plan.smoothing_draws)])


def test_the_smoothed_loss_is_the_mean_over_the_perturbed_grids_with_the_particles_shared_out():
    loss, grad, metric = smoothed_step(PROBLEM, _values(), 0, 2, PLAN, "numpy")
    assert loss == pytest.approx(_mean_loss(_values()), rel=1e-12)
    assert grad.shape == PROBLEM.shape() and 0.0 <= metric <= 1.0


def test_a_held_part_of_the_grid_is_not_perturbed():
    funnel = synthesis.with_sets(synthesis.load_problem(synthesis.shipped_problem("funnel")),
                                 {"surface.shape": [10, 10], "dynamics.n_steps": 40})
    values = 0.02 * np.random.default_rng(5).standard_normal(funnel.shape()) * funnel.mask(funnel.shape())
    assert not funnel.mask(funnel.shape()).all()                        # the funnel holds its start strip
    loss, _, _ = smoothed_step(funnel, values, 0, 2, PLAN, "numpy")
    assert loss == pytest.approx(_mean_loss(values, problem=funnel), rel=1e-12)


def test_the_smoothed_gradient_matches_central_differences_entrywise():
    values = _values()
    _, grad, _ = smoothed_step(PROBLEM, values, 0, 2, PLAN, "numpy")
    rng = np.random.default_rng(1)
    for flat in rng.choice(values.size, 6, replace=False):
        unit = np.zeros_like(values)
        unit.flat[flat] = 1.0
        fd = directional_derivative(_mean_loss, values, unit, 1e-6)
        assert grad.flat[flat] == pytest.approx(float(fd), rel=1e-5, abs=1e-8)


def test_without_smoothing_the_step_is_the_plain_design_step():
    plan = Plan(iterations=3, n_particles=7)
    loss, grad, metric = smoothed_step(PROBLEM, _values(), 0, 2, plan, "numpy")
    plain_loss, plain_grad, traj, _ = design_step(PROBLEM, _values(), 0, 2, 7, None, "numpy")
    assert loss == plain_loss and metric == PROBLEM.batch_metric(traj)
    np.testing.assert_array_equal(grad, plain_grad)


def test_a_smoothed_design_is_the_same_for_the_same_seed_and_differs_from_the_plain_one():
    plan = Plan(iterations=4, n_particles=8, smoothing=0.005, smoothing_draws=4)
    a = synthesis.run_design(synthesis.new_design(PROBLEM, seed=1, plan=plan, backend="numpy"))
    b = synthesis.run_design(synthesis.new_design(PROBLEM, seed=1, plan=plan, backend="numpy"))
    plain = synthesis.run_design(synthesis.new_design(PROBLEM, seed=1, plan=Plan(iterations=4, n_particles=8),
                                                      backend="numpy"))
    np.testing.assert_array_equal(a.values, b.values)
    assert not np.array_equal(a.values, plain.values)


@pytest.mark.parametrize("kw, key", [({"smoothing": -0.1}, "smoothing"), ({"smoothing_draws": 0}, "smoothing_draws"),
                                     ({"smoothing": 0.01, "smoothing_draws": 9, "n_particles": 8}, "smoothing_draws")])
def test_bad_smoothing_is_refused_naming_the_key(kw, key):
    with pytest.raises(InputError) as err:
        Plan(**kw)
    assert err.value.key == key


@pytest.mark.parametrize("train, message", [
    ("smoothing = -1", "train.smoothing: expected a number >= 0, got -1"),
    ("smoothing = 0.01\nsmoothing_draws = 0", "train.smoothing_draws: expected an integer >= 1, got 0"),
    ("smoothing = 0.01\nsmoothing_draws = 50", "train.smoothing_draws: smoothing_draws = 50 is more than the 6 "
                                              "particles per iteration"),
    ("smoothin = 0.01", "train.smoothin: unknown key"),
])
def test_a_bad_smoothing_key_in_a_file_is_one_line_naming_it(train, message):
    with pytest.raises(synthesis.ProblemFileError) as err:
        problem_from_text(_helpers.gather_problem().replace("[train]", f"[train]\n{train}"), "bad.toml")
    assert message in str(err.value) and "\n" not in str(err.value)


def test_train_states_smoothing_and_the_default_plan_does_not_smooth():
    assert synthesis.default_plan((40, 40)).smoothing == 0.0
    stated = problem_from_text(_helpers.gather_problem().replace("[train]", "[train]\nsmoothing = 0.01\n"
                                                                "smoothing_draws = 2"), "s.toml")
    assert (stated.plan.smoothing, stated.plan.smoothing_draws) == (0.01, 2)
    assert problem_from_text(_helpers.gather_problem(), "g.toml").plan.smoothing == 0.0   # a [train] without it
