"""Prescribed-gait shooting: the cost's gradient, the design gradient through the
adjoint, the starts, and the default oscillator setting that uses them."""
import math

import numpy as np
import pytest

from pes_ref import synthesis
from pes_ref.synthesis import GaitShooting, Plan, sample_gait_starts
from pes_ref.synthesis.kinds.gait import gait_teeth
from pes_ref.testing.finite_differences import central_gradient
from pes_ref.oracle.compare import relative_error
from pes_ref.oracle.tolerances import FD_RTOL


def random_run(n=5, n_states=7, seed=0, dead_zone=math.pi / 8):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((n_states, n, 2))
    v = rng.standard_normal((n_states, n, 2))
    t = np.linspace(0.0, 1.3, n_states)
    cost = GaitShooting(1.0, 1.3, math.pi / 2, rng.uniform(0, 6, n), rng.uniform(-6, 0, n), w0=3.0, w1=2.0,
                        dead_zone=dead_zone)
    x[:, :, 1] = cost.reference(t)[1] + 0.4 * rng.standard_normal((n_states, n))     # near the gait
    return cost, x, v, t


@pytest.mark.parametrize("dead_zone", [math.pi / 8, 0.0, 0.2])
def test_gait_cost_gradient_matches_central_differences(dead_zone):
    cost, x, v, t = random_run(dead_zone=dead_zone)
    _, gx, gv = cost.value_and_grad(x, v, t)
    z = x[:, :, 1] - cost.reference(t)[1]
    assert np.any(np.abs(z) < dead_zone) or dead_zone == 0.0     # some steps inside the dead zone, ...
    assert np.any(np.abs(z) > dead_zone)                          # ... some outside it
    num_x = central_gradient(lambda xx: cost.value_and_grad(xx, v, t)[0], x)
    num_v = central_gradient(lambda vv: cost.value_and_grad(x, vv, t)[0], v)
    assert relative_error(gx, num_x) < FD_RTOL
    assert relative_error(gv, num_v) < FD_RTOL
    np.testing.assert_array_equal(gv[:, :, 1], 0.0)               # q1's speed is not charged


def test_gait_cost_is_zero_on_the_cycle_and_within_the_dead_zone():
    cost, _, _, t = random_run()
    phi, q1ref = cost.reference(t)
    x = np.stack([cost.amplitude * np.cos(phi), q1ref + 0.9 * cost.dead_zone], axis=-1)
    v = np.stack([-cost.amplitude * cost.omega * np.sin(phi), np.zeros_like(phi)], axis=-1)
    assert cost.value_and_grad(x, v, t)[0] == pytest.approx(0.0, abs=1e-24)
    x[:, :, 1] = q1ref + 1.5 * cost.dead_zone                      # beyond it: w1 (0.5 h)^2 at every state
    assert cost.value_and_grad(x, v, t)[0] == pytest.approx(cost.w1 * (0.5 * cost.dead_zone) ** 2)


@pytest.mark.parametrize("kwargs, word", [
    (dict(theta=np.zeros(3), q1_start=np.zeros(2)), "same length"),
    (dict(omega=0.0), "omega"),
    (dict(dead_zone=-0.1), "dead_zone"),
    (dict(w0=float("nan")), "w0"),
])
def test_gait_cost_bad_input(kwargs, word):
    args = {**dict(amplitude=1.0, omega=1.0, delta=1.0, theta=np.zeros(2), q1_start=np.zeros(2)), **kwargs}
    with pytest.raises(ValueError, match=word):
        GaitShooting(**args)


def test_gait_cost_refuses_another_particle_count():
    cost, x, v, t = random_run(n=5)
    with pytest.raises(ValueError, match="built for 5 particles, the run has 3"):
        cost.value_and_grad(x[:, :3], v[:, :3], t)


def test_design_gradient_through_the_adjoint_matches_central_differences():
    """The default oscillator's batch (gait starts, the gait cost) through the adjoint, node by node."""
    problem = synthesis.OscillatorProblem(grid0=8, grid1=8)
    assert problem.cost == "gait"
    rng = np.random.default_rng(3)
    values = 0.1 * rng.standard_normal(problem.shape()) + synthesis.escapement_values(problem)
    step = synthesis.design_gradient(problem, values, seed=4, iteration=7, n_particles=6, n_steps=60)

    def loss(v):
        return synthesis.design_gradient(problem, v, seed=4, iteration=7, n_particles=6, n_steps=60).loss

    nodes = [(2, 3), (4, 0), (5, 7), (3, 5), (1, 6)]
    got = np.array([step.grad[i] for i in nodes])
    assert np.count_nonzero(got) >= 3                             # nodes the particles visit
    want = []
    for i in nodes:
        e = np.zeros_like(values)
        e[i] = 1.0
        want.append(central_gradient(lambda s: loss(values + s[0] * e), np.zeros(1))[0])
    assert relative_error(got, np.array(want)) < FD_RTOL          # measured 5e-10


def test_starts_lie_on_the_target_cycle_and_the_gait():
    problem = synthesis.OscillatorProblem()
    delta = math.pi / 2
    s = sample_gait_starts(problem, np.random.default_rng(0), 400, delta)
    cost = GaitShooting(problem.amplitude, problem.omega, delta, s.theta, s.q1_start, dead_zone=0.0)
    assert cost.value_and_grad(s.x0[None], s.v0[None], np.zeros(1))[0] == pytest.approx(0.0, abs=1e-24)
    np.testing.assert_allclose(s.x0[:, 0] ** 2 + (s.v0[:, 0] / problem.omega) ** 2, problem.amplitude ** 2)
    np.testing.assert_allclose(s.v0[:, 1], -delta * problem.omega / (2 * math.pi))
    np.testing.assert_array_equal(s.q1_start, s.x0[:, 1])
    tooth = np.floor(-s.x0[:, 1] / delta + 1e-12)                 # q1 = -k delta - delta theta / 2 pi
    np.testing.assert_allclose(-s.x0[:, 1] - tooth * delta, delta * s.theta / (2 * math.pi), atol=1e-12)
    assert set(tooth.astype(int)) == set(range(gait_teeth(delta))) == {0, 1, 2, 3}
    assert np.all((s.torques >= problem.torque_min) & (s.torques <= problem.torque_max))
    assert np.all((s.theta >= 0) & (s.theta < 2 * math.pi))


def test_gait_batch_carries_the_cost_of_its_own_starts():
    problem = synthesis.OscillatorProblem(grid0=8, grid1=8)
    batch = problem.batch(problem.flat_values(), np.random.default_rng([1, 2]), 5)
    starts = sample_gait_starts(problem, np.random.default_rng([1, 2]), 5, problem.gait_delta)
    np.testing.assert_array_equal(batch.x0, starts.x0)
    np.testing.assert_array_equal(batch.objective.theta, starts.theta)
    assert batch.objective.dead_zone == problem.gait_dead_zone * problem.gait_delta
    assert batch.scene.n_steps == problem.shooting_steps == math.ceil(2 * math.pi / problem.dt)
    np.testing.assert_array_equal(-batch.scene.effects[0].force[:, 1], starts.torques)
    with pytest.raises(ValueError, match="built per batch"):
        problem.objective()


def test_the_gait_plan_keeps_its_learning_rate_across_the_grid_change():
    problem = synthesis.OscillatorProblem()
    plan = synthesis.KINDS["oscillator"].default_plan(problem)
    assert plan.grid_at(1499, problem) == (16, 16) and plan.grid_at(1500, problem) == (32, 32)
    assert plan.lr_at(0, problem) == 1e-2 and plan.lr_at(2999, problem) == pytest.approx(1e-4)
    ratio = plan.lr_at(1500, problem) / plan.lr_at(1499, problem)
    assert ratio == pytest.approx((1e-4 / 1e-2) ** (1 / 2999))   # no jump at the grid change ...
    scaled = Plan(lr=1.0, lr_final=1.0, stages=((0, 16), (2, 0)))
    assert scaled.lr_at(2, problem) == 0.5                        # ... which the other plans have


@pytest.mark.parametrize("bad, word", [(dict(gait_delta=0.0), "gait_delta"), (dict(shooting_periods=0.0),
                                                                             "shooting_periods")])
def test_bad_gait_parameters_are_refused(bad, word):
    with pytest.raises(ValueError, match=word):
        synthesis.OscillatorProblem(**bad)
