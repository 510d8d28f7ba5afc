"""Design problems and the design loop: gradients, resampling, stopping, improvement on a small funnel."""
import math
import os
import signal

import numpy as np
import pytest

from pes_ref import synthesis
from pes_ref.core.integrator import NonFiniteError as pr_nonfinite
from pes_ref.synthesis import Plan
from pes_ref.testing.finite_differences import directional_derivative
from pes_ref.oracle.compare import relative_error
from pes_ref.oracle.tolerances import FD_RTOL

#: A tiny funnel (13 x 13 grid, 100 steps) on which 40 iterations take about a second.
TINY_FUNNEL = dict(grid=13, n_steps=100, dt=0.035)
TINY_PLAN = Plan(iterations=40, lr=0.005, lr_final=0.005, n_particles=16)


def tiny_state(kind="funnel", **kw):
    if kind == "funnel":
        return synthesis.new_design("funnel", seed=3, plan=kw.pop("plan", TINY_PLAN), **{**TINY_FUNNEL, **kw})
    plan = kw.pop("plan", Plan(iterations=4, lr=0.01, lr_final=0.01, n_particles=4))
    return synthesis.new_design("oscillator", seed=3, plan=plan, **{"grid0": 8, "grid1": 8, "n_steps": 60, **kw})


@pytest.mark.parametrize("kind, extra", [
    ("funnel", {"grid": 6, "n_steps": 40, "dt": 0.05}),
    ("oscillator", {"n_steps": 40, "cost": "eq6"}),
    # the phase-free cost with starts spread at rest and stratified torques; then eq. (6) before settle
    ("oscillator", {"n_steps": 40, "cost": "cycle", "spread_share": 0.5, "stratified": True}),
    ("oscillator", {"n_steps": 40, "cost": "phase_then_cycle", "settle_periods": 0.2}),
])
def test_design_gradient_matches_finite_differences(kind, extra):
    st = tiny_state(kind, **extra)
    rng = np.random.default_rng(1)
    mask = st.problem.mask(st.values.shape)
    values = st.values + 0.05 * rng.standard_normal(st.values.shape) * mask
    step = synthesis.design_gradient(st.problem, values, seed=3, iteration=0, n_particles=3)

    def loss(v):
        return synthesis.design_gradient(st.problem, v, seed=3, iteration=0, n_particles=3).loss

    for _ in range(3):                       # random directions over the designed values
        u = rng.standard_normal(values.shape) * mask
        fd = directional_derivative(loss, values, u)
        assert relative_error(np.sum(step.grad * u), fd) < FD_RTOL   # measured 1e-10 (funnel), 4e-9 (oscillator)


@pytest.mark.parametrize("exit_zone, held_bottom_rows", [(0.0, 0), (0.2, 2)])
def test_funnel_strips_are_held_at_zero(exit_zone, held_bottom_rows):
    st = synthesis.run_design(tiny_state(plan=Plan(iterations=3, lr=0.01, lr_final=0.01, n_particles=8),
                                         exit_zone=exit_zone))
    mask = st.problem.mask(st.values.shape)
    q1 = np.linspace(0.0, st.problem.height, st.values.shape[1])      # 13 rows, 1/6 apart
    assert not mask[:, q1 >= st.problem.height - st.problem.start_zone].any()
    np.testing.assert_array_equal(mask[0, :3], [0.0] * held_bottom_rows + [1.0] * (3 - held_bottom_rows))
    np.testing.assert_array_equal(st.values[mask == 0], 0.0)
    assert np.all(st.values[mask == 1] != 0.0)


@pytest.mark.parametrize("periodic", [(False, False), (False, True)])
def test_resample_is_exact_on_bilinear_functions(periodic):
    lower, upper = (-1.0, 0.0), (1.0, 2.0)

    def nodes(shape):
        q = [np.linspace(lower[d], upper[d], shape[d]) if not periodic[d]
             else lower[d] + np.arange(shape[d]) * (upper[d] - lower[d]) / shape[d] for d in range(2)]
        return np.meshgrid(*q, indexing="ij")

    # linear along a non-periodic axis; along a periodic one only a constant is exactly representable
    f = (lambda a, b: 2 * a - 0.5 * a * b + b) if not periodic[1] else (lambda a, b: 3 * a - 1)
    coarse, fine = (5, 9), (17, 33)
    got = synthesis.resample(f(*nodes(coarse)), lower, upper, periodic, fine)
    np.testing.assert_allclose(got, f(*nodes(fine)), rtol=1e-13, atol=1e-13)


def test_short_design_improves_the_funnel_over_the_flat_surface():
    st = synthesis.run_design(tiny_state())
    assert st.status == "done" and st.iteration == TINY_PLAN.iterations
    figures = synthesis.evaluate(st.problem, st.values, seed=7, n_particles=200)
    # the flat surface passes only the ~10-20% that happen to start in the band; the design must at
    # least double that share and narrow the exits
    assert figures["in_band_fraction"] >= 2 * figures["flat_in_band_fraction"]
    assert figures["exit_spread"] < figures["flat_exit_spread"]
    assert np.mean(st.history["loss"][-10:]) < np.mean(st.history["loss"][:10])


@pytest.mark.parametrize("cost", synthesis.OSCILLATOR_COSTS)
def test_short_oscillator_design_lowers_its_objective(cost):
    plan = Plan(iterations=30, lr=0.02, lr_final=0.02, n_particles=8)
    st = synthesis.run_design(tiny_state("oscillator", plan=plan, n_steps=150, cost=cost, settle_periods=1.0))
    assert st.status == "done"
    assert np.mean(st.history["loss"][-5:]) < np.mean(st.history["loss"][:5])


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_ctrl_c_or_sigterm_stops_after_the_iteration_with_its_state(signum):
    sent = []
    # a harmless handler of our own: were the loop to leave SIGTERM alone, the test fails
    # instead of the signal ending the test session
    own = signal.signal(signal.SIGTERM, lambda *_: None)
    try:
        _interrupted_run(signum, sent)
    finally:
        signal.signal(signal.SIGTERM, own)


def _interrupted_run(signum, sent):
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}

    def interrupt(progress):
        if progress.done == 2 and not sent:
            sent.append(True)
            os.kill(os.getpid(), signum)

    st = synthesis.run_design(tiny_state(plan=Plan(iterations=10, n_particles=4)), callback=interrupt,
                              progress_every=0.0)
    assert st.status == "interrupted"
    assert st.iteration == 2                    # the flag is seen before iteration 2 starts
    assert len(st.history["loss"]) == 2
    assert {s: signal.getsignal(s) for s in before} == before     # the handlers are given back


def test_non_finite_run_stops_at_the_last_finite_state(monkeypatch):
    # iteration 1's run leaves the finite numbers (within the stability rule a design's run
    # does not, so the step is made to fail here): the run rolls back to iteration 0
    from pes_ref.synthesis.engine import training
    real_step = training.design_step

    def failing_step(problem, values, seed, iteration, *args):
        if iteration == 1:
            raise pr_nonfinite("the trajectory became non-finite at step 7 (dt=0.01)")
        return real_step(problem, values, seed, iteration, *args)
    monkeypatch.setattr(training, "design_step", failing_step)
    plan = Plan(iterations=5, lr=10.0, lr_final=10.0, n_particles=4)
    st = synthesis.new_design("funnel", seed=0, plan=plan, grid=8, n_steps=200, dt=0.01, noise=0.0)
    start = st.values.copy()
    st = synthesis.run_design(st)
    assert st.status.startswith("non-finite: iteration 1")
    assert st.iteration == 0 and st.history["loss"] == []
    np.testing.assert_array_equal(st.values, start)
    assert np.isfinite(synthesis.design_gradient(st.problem, st.values, seed=0, iteration=0, n_particles=4).loss)


def test_coarse_to_fine_stages_resample_and_reset():
    plan = Plan(iterations=4, lr=0.01, lr_final=0.01, n_particles=4, stages=((0, 7), (2, 0)))
    st = synthesis.run_design(tiny_state(plan=plan), 2)
    assert st.values.shape == (7, 7)
    st = synthesis.run_design(st)
    assert st.values.shape == (13, 13) and st.optimizer.t == 2
    assert plan.lr_at(3, st.problem) == pytest.approx(0.01 * 7 / 13)


@pytest.mark.parametrize("kind", ["funnel", "oscillator"])
def test_figures_api_shapes(kind):
    st = tiny_state(kind)
    if kind == "funnel":
        paths = synthesis.funnel_paths(st.problem, st.values, n_particles=5, seed=2)
        assert paths.traj.x.shape == (101, 5, 2)
        assert synthesis.exit_positions(st.problem, paths.traj).shape == (5,)
        return
    sweep = synthesis.oscillator_torque_sweep(st.problem, st.values, n_particles=4, periods=2)
    assert sweep.torques[0] == st.problem.torque_min and sweep.torques[-1] == st.problem.torque_max
    grid = synthesis.oscillator_grid_starts(st.problem, st.values, periods=2)
    assert grid.x0.shape == (25, 2) and np.all(grid.traj.v[0] == 0)
    q0, dq0 = synthesis.phase_space(st.problem, sweep.traj, after_periods=1)
    assert q0.shape == dq0.shape and q0.shape[1] == 4


def test_cycle_figures_recognise_a_free_oscillation():
    # the flat surface with no damping along q0 and no torque: a pure spring oscillation of amplitude
    # A(1 + kick) at the spring's own frequency, which is the target's
    st = tiny_state("oscillator", damping0=0.0, kick=0.1, start_noise=0.0, torque_min=0.0, torque_max=0.0)
    sweep = synthesis.oscillator_torque_sweep(st.problem, st.problem.flat_values((8, 8)), n_particles=2, periods=5)
    amp, period, drift, captured = synthesis.cycle_figures(st.problem, sweep.traj)
    np.testing.assert_allclose(amp, 1.1, rtol=1e-3)
    np.testing.assert_allclose(period, 2 * np.pi, rtol=1e-3)
    assert captured.all()


@pytest.mark.parametrize("bad, match", [
    (dict(grid=0), "grid"), (dict(dt=-0.1), "dt"), (dict(when="sometimes"), "when"), (dict(noise=np.nan), "noise"),
])
def test_bad_problem_parameters_are_refused(bad, match):
    with pytest.raises(ValueError, match=match):
        synthesis.FunnelProblem(**bad)


@pytest.mark.parametrize("bad, match", [
    (dict(stages=((5, 10),)), "stages"), (dict(lr=0.0), "lr"), (dict(optimizer="sgd"), "optimizer"),
])
def test_bad_plans_are_refused(bad, match):
    with pytest.raises(ValueError, match=match):
        Plan(**bad)


@pytest.mark.parametrize("bad, match", [
    (dict(cost="phase"), "cost"), (dict(spread_share=1.5, cost="eq6"), "spread_share"),
    (dict(settle_periods=-1.0), "settle"), (dict(spread_share=0.5), "spread_share"), (dict(stratified=True), "stratified"),
])
def test_bad_oscillator_parameters_are_refused(bad, match):
    with pytest.raises(ValueError, match=match):
        synthesis.OscillatorProblem(**bad)


def test_oscillator_batch_spreads_starts_and_stratifies_torques():
    prob = synthesis.OscillatorProblem(grid0=8, grid1=8, spread_share=0.5, stratified=True, cost="eq6")
    batch = prob.batch(prob.flat_values(), np.random.default_rng(0), 8)
    torques = -batch.scene.effects[0].force[:, 1]
    slot = (torques - prob.torque_min) / (prob.torque_max - prob.torque_min) * 8
    np.testing.assert_array_equal(np.floor(slot), np.arange(8))      # one torque in each eighth of the range
    np.testing.assert_array_equal(batch.x0[:4, 1], 0.0)                # the paper's starts ...
    assert np.all(batch.x0[:4, 0] > prob.amplitude)
    assert np.all(np.abs(batch.x0[4:, 0]) <= 1.5 * prob.amplitude)    # ... and the spread ones, at rest
    assert np.all(batch.x0[4:, 1] > 0.0) and np.all(batch.v0 == 0.0)


def test_oscillator_defaults_are_the_default_named_plan():
    sets, plan = synthesis.OSCILLATOR_PLANS[synthesis.DEFAULT_OSCILLATOR_PLAN]
    problem = synthesis.OscillatorProblem()
    assert {k: getattr(problem, k) for k in sets} == sets
    assert synthesis.KINDS["oscillator"].default_plan(problem) == plan
    assert synthesis.KINDS["oscillator"].default_polish == synthesis.OSCILLATOR_POLISH["gait"] == synthesis.PolishPlan()
    assert synthesis.DEFAULT_OSCILLATOR_PLAN == "gait" and problem.cost == "gait"
    st = synthesis.new_design("oscillator")
    assert st.plan == plan and st.polish == synthesis.PolishPlan() and st.method == "gradient+polish"
    assert synthesis.new_design("oscillator", plan=plan).polish is None        # a plan given: no polish unless asked
    assert synthesis.OSCILLATOR_PLANS["eq6"][0]["cost"] == "eq6"             # the paper's setting stays available
    assert synthesis.OSCILLATOR_PLANS["eq6"][0]["target_scale"] == 1.0
    assert synthesis.OSCILLATOR_PLANS["overshoot"][0]["target_scale"] == 1.4  # and eq. (6) aimed above A
    assert synthesis.OSCILLATOR_POLISH["eq6"] is synthesis.OSCILLATOR_POLISH["overshoot"] is None


# --------------------------------------------------------------------------- the hand-drawn escapement

def test_escapement_values_shape_and_periodicity():
    p = synthesis.OscillatorProblem()
    v = synthesis.escapement_values(p)
    assert v.shape == p.shape() and np.isfinite(v).all()
    # the teeth repeat every 2 pi / teeth along q1 (32 nodes, 4 teeth: every 8 nodes)
    np.testing.assert_allclose(np.roll(v, 8, axis=1), v, atol=1e-12)
    assert synthesis.escapement_values(p, (16, 64)).shape == (16, 64)
    np.testing.assert_array_equal(synthesis.escapement_values(p, h=0.0, kappa=0.0), 0.0)


@pytest.mark.parametrize("kwargs, error, word", [
    ({"shape": (32,)}, ValueError, "shape"),
    ({"shape": (0, 32)}, ValueError, "shape"),
    ({"h": -1.0}, ValueError, "h"),
    ({"kappa": float("nan")}, ValueError, "kappa"),
    ({"teeth": 0}, ValueError, "teeth"),
])
def test_escapement_values_bad_input(kwargs, error, word):
    with pytest.raises(error, match=word):
        synthesis.escapement_values(synthesis.OscillatorProblem(), **kwargs)


def test_escapement_values_needs_the_oscillator():
    with pytest.raises(TypeError, match="OscillatorProblem"):
        synthesis.escapement_values(synthesis.FunnelProblem())


@pytest.mark.parametrize("kind, params, key", [
    ("funnel", {"dt": 0.0}, "dt"),
    ("funnel", {"grid": 1}, "grid"),
    ("oscillator", {"grid1": 1}, "grid1"),
    ("funnel", {"wall_margin": 5.0}, "wall_margin"),
])
def test_a_scene_that_cannot_run_is_refused_by_new_design(kind, params, key):
    """Before any run (and before a command line claims its file), keyed by the parameter."""
    from pes_ref.core.checks import InputError
    with pytest.raises(InputError) as info:
        synthesis.new_design(kind, plan=Plan(iterations=2, n_particles=2), **params)
    assert info.value.key == key and key in str(info.value)


@pytest.mark.parametrize("stages", [((0, 1),), ((0, 8), (5, 1)), ((3, 8),), ((0, -2),)])
def test_bad_stages_are_keyed(stages):
    from pes_ref.core.checks import InputError
    with pytest.raises(InputError) as info:
        Plan(stages=stages)
    assert info.value.key == "stages"


def _clocked(monkeypatch, seconds_per_step=1e-3):
    """A clock that advances only inside the design step, by ``seconds_per_step`` per time
    step of its training runs: the cost of an iteration is its stage's horizon."""
    from types import SimpleNamespace

    from pes_ref.synthesis.engine import training
    clock = [0.0]
    real = training.design_step

    def step(problem, values, seed, iteration, n_particles, n_steps=None, backend=None):
        clock[0] += seconds_per_step * (n_steps or problem.n_steps)
        return real(problem, values, seed, iteration, n_particles, n_steps, backend)
    monkeypatch.setattr(training, "design_step", step)
    monkeypatch.setattr(training, "time", SimpleNamespace(perf_counter=lambda: clock[0]))


def test_progress_shows_the_stage_and_sums_the_time_left_over_the_stages_to_run(monkeypatch):
    """A horizon 4x longer in the second stage: the time left counts it 4x (the plain
    'iterations left / rate' said a third of it, as on the oscillator's curriculum)."""
    _clocked(monkeypatch)
    plan = Plan(iterations=8, lr=0.005, lr_final=0.005, n_particles=2, stages=((0, 7, 10), (4, 0, 40)))
    seen = []
    synthesis.run_design(tiny_state(plan=plan), callback=seen.append, progress_every=0.0)
    by_it = {p.done: p for p in seen}
    p2, p5, p6 = by_it[2], by_it[5], by_it[6]
    assert (p2.stage, p2.figure("grid"), p2.figure("steps")) == ("stage 1/2", (7, 7), 10)
    assert p2.rate == pytest.approx(100.0)                            # 10 steps at 1 ms each
    assert p2.seconds_left == pytest.approx(2 * 0.010 + 4 * 0.040)   # 2 more of stage 1, then 4 of stage 2
    assert (p5.stage, p5.figure("grid"), p5.figure("steps")) == ("stage 2/2", (13, 13), 40)
    assert p5.rate == 0.0                                            # stage 2's first iteration: its warm-up
    assert p5.seconds_left == pytest.approx(3 * 0.040)               # scaled from stage 1
    assert p6.rate == pytest.approx(25.0) and p6.seconds_left == pytest.approx(2 * 0.040)
    assert by_it[8].seconds_left == 0.0


def test_a_stage_yet_to_be_measured_is_estimated_from_the_last_one(monkeypatch):
    _clocked(monkeypatch)
    plan = Plan(iterations=6, lr=0.005, lr_final=0.005, n_particles=2, stages=((0, 0, 10), (3, 0, 30)))
    seen = []
    synthesis.run_design(tiny_state(plan=plan), callback=seen.append, progress_every=0.0)
    p3 = next(p for p in seen if p.done == 3)          # stage 1 done, stage 2 not started
    assert p3.stage == "stage 1/2" and p3.seconds_left == pytest.approx(3 * 0.030)


def test_a_plain_run_is_one_stage(monkeypatch):
    _clocked(monkeypatch)
    seen = []
    synthesis.run_design(tiny_state(plan=Plan(iterations=3, n_particles=2)), callback=seen.append,
                         progress_every=0.0)
    assert {p.stage for p in seen} == {"stage 1/1"} and seen[0].figure("steps") == TINY_FUNNEL["n_steps"]
    assert seen[0].seconds_left == math.inf                          # iteration 1 is the warm-up: not timed
    assert seen[1].seconds_left == pytest.approx(0.1)


@pytest.mark.parametrize("kind, kw", [("funnel", dict(grid=8, n_steps=40)),
                                      ("oscillator", dict(grid0=6, grid1=6, eval_periods=4))])
def test_the_seeds_evaluated_together_give_each_seeds_own_figures(kind, kw):
    """evaluate_seeds runs every seed's held-out particles (and the flat surface's) as one
    population: the figures are evaluate's for each seed, number for number."""
    problem = synthesis.new_design(kind, **kw).problem
    values = 0.05 * np.random.default_rng(0).standard_normal(problem.shape())
    together = synthesis.evaluate_seeds(problem, values, (12345, 9191, 12345), n_particles=7)
    assert list(together) == [12345, 9191]
    for seed, figures in together.items():
        alone = synthesis.evaluate(problem, values, seed=seed, n_particles=7)
        assert figures.keys() == alone.keys()
        assert all(figures[k] == alone[k] or (np.isnan(figures[k]) and np.isnan(alone[k])) for k in alone)
        if kind == "funnel":        # against the held-out runs simulated one by one
            exits = synthesis.exit_positions(problem, synthesis.funnel_paths(problem, values, 7, seed).traj)
            assert figures["in_band_fraction"] == float(np.mean(problem.in_band(exits)))
        else:
            sweep = synthesis.oscillator_torque_sweep(problem, values, 7, seed=seed)
            grid = synthesis.oscillator_grid_starts(problem, values)
            assert figures["sweep_captured_fraction"] == float(np.mean(synthesis.cycle_figures(problem, sweep.traj)[3]))
            assert figures["grid_captured_fraction"] == float(np.mean(synthesis.cycle_figures(problem, grid.traj)[3]))
