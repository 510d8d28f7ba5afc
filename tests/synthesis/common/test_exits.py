"""pes_ref.synthesis.common.exits: a funnel particle's exit step, and eq. (5) charged at the exit.

Values by hand, the derivative by central differences entry by entry, and the design gradient
through the adjoint against central differences on a funnel whose particles exit.
"""
import numpy as np
import pytest
from hypothesis import given

from pes_ref import synthesis
from pes_ref.core.objectives import Funnel
from pes_ref.synthesis import FunnelExit, FunnelProblem, Plan, exit_steps
from pes_ref.testing import strategies as pst
from pes_ref.testing.finite_differences import central_gradient
from pes_ref.oracle.compare import relative_error
from pes_ref.oracle.tolerances import FD_EPS, FD_RTOL, TRAJ_RTOL

# T + 1 = 4 states, N = 3 particles: particle 0 exits at step 2, particle 1 at step 1 (exactly
# on the level counts), particle 2 never exits.
X = np.array([[[0.5, 1.0], [-0.4, 0.3], [0.9, 2.0]],
              [[0.4, 0.5], [-0.3, 0.0], [0.8, 1.5]],
              [[0.3, -0.1], [-0.2, -0.5], [0.7, 1.0]],
              [[0.1, -0.6], [0.0, -0.9], [0.6, 0.5]]])
V = np.zeros_like(X)
TIMES = np.arange(4) * 0.1


def test_exit_steps_by_hand():
    step, exited = exit_steps(X, 0.0)
    np.testing.assert_array_equal(step, [2, 1, 3])
    np.testing.assert_array_equal(exited, [True, True, False])


def test_exit_value_and_gradient_by_hand():
    value, gx, gv = FunnelExit(target=0.1, level=0.0).value_and_grad(X, V, TIMES)
    # (0.3 - 0.1)^2 + (-0.3 - 0.1)^2 + (0.6 - 0.1)^2 (the last one at the final state)
    assert value == pytest.approx(0.04 + 0.16 + 0.25, rel=TRAJ_RTOL)
    assert gv is None
    want = np.zeros_like(X)
    want[2, 0, 0], want[1, 1, 0], want[3, 2, 0] = 2 * 0.2, 2 * -0.4, 2 * 0.5
    np.testing.assert_allclose(gx, want, rtol=TRAJ_RTOL, atol=0.0)


def test_without_exits_it_is_eq5_at_the_final_step():
    x = X.copy()
    x[:, :, 1] += 5.0                                   # nobody reaches the level
    got = FunnelExit(target=0.2).value_and_grad(x, V, TIMES)
    want = Funnel(target=0.2, when="final").value_and_grad(x, V, TIMES)
    assert got[0] == want[0]
    np.testing.assert_array_equal(got[1], want[1])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_exit_gradient_matches_central_differences(seed):
    rng = np.random.default_rng(seed)
    x = rng.normal(0.0, 1.0, (6, 4, 2))
    x[:, :, 1] = np.sort(rng.uniform(-1.0, 1.0, (6, 4)), axis=0)[::-1]     # q1 falls through the level
    # away from the kinks: no q1 within the finite-difference step of the level
    assert np.min(np.abs(x[:, :, 1] - 0.25)) > 10 * FD_EPS
    cost = FunnelExit(target=-0.3, level=0.25)
    v, t = rng.normal(0.0, 1.0, x.shape), np.arange(6.0)
    _, gx, _ = cost.value_and_grad(x, v, t)
    fd = central_gradient(lambda z: cost.value_and_grad(z, v, t)[0], x)
    assert np.count_nonzero(fd) == 4                   # one state per particle counts
    assert relative_error(gx, fd) < FD_RTOL


@pytest.mark.parametrize("seed", [0, 1])
def test_linger_gradient_matches_central_differences(seed):
    """The linger term: ``linger dt`` on q1 of every state up to each particle's exit, nothing after."""
    rng = np.random.default_rng(seed)
    x = rng.normal(0.0, 1.0, (6, 4, 2))
    x[:, :, 1] = np.sort(rng.uniform(-1.0, 1.0, (6, 4)), axis=0)[::-1]
    assert np.min(np.abs(x[:, :, 1] - 0.25)) > 10 * FD_EPS
    cost = FunnelExit(target=-0.3, level=0.25, linger=0.7)
    t = np.arange(6.0) * 0.5
    value, gx, _ = cost.value_and_grad(x, None, t)
    fd = central_gradient(lambda z: cost.value_and_grad(z, None, t)[0], x)
    assert relative_error(gx, fd) < FD_RTOL
    step, _ = exit_steps(x, 0.25)
    live = np.arange(6)[:, None] <= step[None, :]
    assert value == pytest.approx(np.sum((x[step, np.arange(4), 0] + 0.3) ** 2)
                                  + 0.7 * 0.5 * np.sum((x[:, :, 1] - 0.25) * live), rel=1e-12)
    assert (fd[..., 1][~live] == 0).all() and (fd[..., 1][live] != 0).all()


def test_linger_belongs_to_the_exit_cost():
    with pytest.raises(ValueError, match="linger is a term of the exit cost"):
        FunnelProblem(linger=1.0, when="final", exit_zone=0.05)


def test_bad_exit_parameters_are_keyed():
    with pytest.raises(ValueError, match="target"):
        FunnelExit(target=float("nan"))
    with pytest.raises(ValueError, match="level"):
        FunnelExit(level=float("inf"))


def test_the_funnel_trains_on_the_exit_by_default():
    problem = synthesis.FunnelProblem()
    assert problem.when == "exit" and problem.exit_zone == 0.0
    assert problem.objective() == FunnelExit(target=0.0, level=0.0)
    assert problem.mask(problem.shape(25))[:, 0].all()          # no held strip at the bottom
    assert synthesis.FunnelProblem(when="final").objective() == Funnel(target=0.0, when="final")
    assert set(synthesis.FUNNEL_OBJECTIVES) == {"exit", "final", "every_step"}


def test_exit_positions_are_the_exit_steps_q0():
    st = synthesis.new_design("funnel", seed=1, plan=Plan(iterations=1, n_particles=8), grid=9, n_steps=285,
                              dt=0.01)
    paths = synthesis.funnel_paths(st.problem, st.values, n_particles=20, seed=5)
    step, exited = exit_steps(paths.traj.x, 0.0)
    assert exited.any() and not exited.all()            # 2.85 time units: some exit, some not yet
    exits = synthesis.exit_positions(st.problem, paths.traj)
    np.testing.assert_array_equal(np.isfinite(exits), exited)
    np.testing.assert_array_equal(exits[exited], paths.traj.x[step[exited], np.flatnonzero(exited), 0])


def test_design_gradient_through_the_adjoint_matches_central_differences_entrywise():
    # a small funnel on which most of the particles exit within the run
    st = synthesis.new_design("funnel", seed=2, plan=Plan(iterations=1, n_particles=4), grid=6, n_steps=100,
                              dt=0.035)
    rng = np.random.default_rng(3)
    values = 0.1 * rng.standard_normal(st.values.shape)
    step = synthesis.design_gradient(st.problem, values, seed=3, iteration=0, n_particles=4)
    steps, exited = exit_steps(step.traj.x, 0.0)
    assert exited.sum() >= 2

    def run(v):
        return synthesis.design_gradient(st.problem, v, seed=3, iteration=0, n_particles=4)

    fd = np.zeros_like(values)
    for idx in np.ndindex(values.shape):
        e = np.zeros_like(values)
        e[idx] = FD_EPS
        up, down = run(values + e), run(values - e)
        # away from the kinks: the perturbation moves no particle's exit step
        for side in (up, down):
            np.testing.assert_array_equal(exit_steps(side.traj.x, 0.0)[0], steps)
        fd[idx] = (up.loss - down.loss) / (2 * FD_EPS)
    mask = st.problem.mask(values.shape)                 # the start strip is held: no design gradient
    assert np.count_nonzero(fd * mask) > mask.sum() // 2
    np.testing.assert_array_equal(step.grad[mask == 0], 0.0)
    assert relative_error(step.grad, fd * mask) < FD_RTOL


@given(pst.exit_paths())
def test_exit_gradient_matches_central_differences_on_random_paths(case):
    x, level = case
    cost = FunnelExit(target=0.2, level=level)
    value, gx, gv = cost.value_and_grad(x, None, None)
    step, exited = exit_steps(x, level)
    assert value == pytest.approx(np.sum((x[step, np.arange(x.shape[1]), 0] - 0.2) ** 2), rel=TRAJ_RTOL)
    fd = central_gradient(lambda z: cost.value_and_grad(z, None, None)[0], x)
    assert relative_error(gx, fd) < FD_RTOL
    assert np.count_nonzero(gx[..., 1]) == 0 and gv is None
