"""The polish stage: the basis, the training particles, the fitness, the search with
and without an executor, and a run's stages one after the other (stop, save, resume)."""
import dataclasses
import importlib
import os
import signal
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np
import pytest

from pes_ref import synthesis
from pes_ref.synthesis import Plan, PolishPlan, capture_fitness, legendre_fourier_basis, polish, polish_particles
from pes_ref.synthesis.engine.design_file import load_design, save_design
from pes_ref.synthesis.engine.polish import MARGIN_CAP, PARTICLE_SEED, VALIDATION_SEED, validation_particles
from pes_ref.synthesis.engine.stages import run_stages, set_polish

polish_module = importlib.import_module("pes_ref.synthesis.engine.polish")   # the module: the package's `polish` is the function

#: A small oscillator on which a polish generation takes a fraction of a second.
SMALL = dict(grid0=8, grid1=8, eval_periods=4)
TINY_POLISH = PolishPlan(n_particles=4, evaluations=25, popsize=8)


def test_basis_is_legendre_in_q0_times_fourier_in_q1():
    problem = synthesis.OscillatorProblem()
    B = legendre_fourier_basis(problem)
    assert B.shape == (32, 32, 72)
    np.testing.assert_allclose(B[:, :, 0], 1.0)                    # P_0 times 1
    q0 = np.linspace(-1, 1, 32)[:, None]
    q1 = np.arange(32)[None, :] * 2 * np.pi / 32
    # term m (2K + 1) + f: P_2 (q0) sin(3 q1) is m = 2, f = 6 (1, cos, sin, cos 2, sin 2, cos 3, sin 3)
    np.testing.assert_allclose(B[:, :, 2 * 9 + 6], 0.5 * (3 * q0 ** 2 - 1) * np.sin(3 * q1), atol=1e-12)
    flat = B.reshape(-1, 72)
    assert np.linalg.matrix_rank(flat) == 72                       # independent on the grid's nodes
    assert legendre_fourier_basis(problem, (8, 16), fourier_order=1, legendre_terms=3).shape == (8, 16, 9)


def test_training_particles_are_shaped_like_the_held_out_sets():
    problem = synthesis.OscillatorProblem()
    p = polish_particles(problem, np.random.default_rng([0, PARTICLE_SEED]), 64)
    assert p.x0.shape == (64, 2) and p.torques.shape == (64,)
    sweep, rest, center = slice(0, 21), slice(21, 43), slice(43, 64)
    np.testing.assert_array_equal(p.x0[sweep, 1], 0.0)                          # like the torque sweep
    assert np.all(np.abs(p.x0[sweep, 0] - 1.2) < 0.3)
    slot = np.floor((p.torques[sweep] - 0.5) / 0.5 * 21)
    np.testing.assert_array_equal(slot, np.arange(21))                           # stratified torques
    assert np.all(np.abs(p.x0[rest, 0]) <= 1.5) and np.all((p.x0[rest, 1] >= 0) & (p.x0[rest, 1] < 2 * np.pi))
    assert np.all(np.abs(p.x0[center, 0]) < 0.3)                                 # near the spring's rest point
    assert np.all((p.torques >= 0.5) & (p.torques <= 1.0))
    at_rest = p.torques[21:]
    np.testing.assert_array_equal(at_rest[1::2], 1.0)                              # every other one: the grid's torque
    assert np.all(at_rest[0::2] < 1.0)
    other = polish_particles(problem, np.random.default_rng([0, PARTICLE_SEED]), 64, rest_max_share=0.0)
    np.testing.assert_array_equal(other.x0, p.x0)                                  # the same draws otherwise
    np.testing.assert_array_equal(other.torques[:21], p.torques[:21])
    np.testing.assert_array_equal(other.torques[21::2], p.torques[21::2])


def test_fitness_ranks_the_escapement_above_the_flat_surface():
    problem = synthesis.OscillatorProblem()
    particles = polish_particles(problem, np.random.default_rng(5), 8, rest_share=0.0)     # sweep-like only
    flat = capture_fitness(problem, problem.flat_values(), particles)
    escapement = capture_fitness(problem, synthesis.escapement_values(problem), particles)
    assert flat == pytest.approx(1.0 + 0.05 * MARGIN_CAP)             # nothing captured, every margin capped
    assert escapement < 0.3


def test_a_stricter_fitness_counts_captures_near_the_tolerances_as_failures():
    problem = synthesis.OscillatorProblem()
    particles = polish_particles(problem, np.random.default_rng(5), 8, rest_share=0.0)
    values = synthesis.escapement_values(problem)
    plain = capture_fitness(problem, values, particles)
    strict = capture_fitness(problem, values, particles, strictness=0.5)
    assert strict - plain == pytest.approx(round((strict - plain) * 8) / 8) and strict > plain   # whole particles
    assert capture_fitness(problem, values, particles, strictness=1.0) == plain


def test_polish_with_an_executor_equals_serial():
    problem = synthesis.OscillatorProblem(**SMALL)
    values = synthesis.escapement_values(problem)
    serial, info = polish(problem, values, 0, TINY_POLISH)
    assert info.evaluations == 1 + 3 * 8 and len(info.history) == 4          # the start, then 3 generations
    assert info.fitness <= info.fitness_start and not info.stopped
    with ThreadPoolExecutor(max_workers=2) as ex:
        threaded, info_t = polish(problem, values, 0, TINY_POLISH, executor=ex)
    with ProcessPoolExecutor(max_workers=2) as ex:
        processes, info_p = polish(problem, values, 0, TINY_POLISH, executor=ex)
    for other, other_info in ((threaded, info_t), (processes, info_p)):
        np.testing.assert_array_equal(other, serial)
        assert other_info.history == info.history


def test_polish_leaves_numpy_global_random_state_alone():
    problem = synthesis.OscillatorProblem(**SMALL)
    np.random.seed(123)
    before = np.random.get_state()
    polish(problem, problem.flat_values(), 1, TINY_POLISH)
    after = np.random.get_state()
    assert before[0] == after[0] and before[2:] == after[2:]
    np.testing.assert_array_equal(before[1], after[1])


def test_polish_stops_when_asked_and_differential_evolution_runs():
    problem = synthesis.OscillatorProblem(**SMALL)
    values = synthesis.escapement_values(problem)
    seen = []
    _, info = polish(problem, values, 0, TINY_POLISH, callback=seen.append, stop=lambda: len(seen) >= 1)
    assert info.stopped and info.evaluations == 9 and len(seen) == 1
    assert seen[0].evaluations == 9 and seen[0].fitness_start == info.fitness_start
    de = PolishPlan(method="de", n_particles=4, evaluations=20, popsize=9, fourier_order=0, legendre_terms=9)
    out, info = polish(problem, values, 0, de)
    assert info.evaluations == 1 + 2 * 9 and info.fitness <= info.fitness_start
    assert out.shape == values.shape


def test_validation_particles_are_shaped_like_the_held_out_sets():
    problem = synthesis.OscillatorProblem()
    p = validation_particles(problem, np.random.default_rng([0, VALIDATION_SEED]), 30)
    sweep, rest = slice(0, 20), slice(20, 30)
    np.testing.assert_array_equal(p.x0[sweep, 1], 0.0)                          # like the torque sweep
    assert np.all(np.abs(p.x0[sweep, 0] - 1.2) < 0.3)
    np.testing.assert_array_equal(np.floor((p.torques[sweep] - 0.5) / 0.5 * 20), np.arange(20))
    assert np.all(np.abs(p.x0[rest, 0]) <= 1.5) and np.all((p.x0[rest, 1] >= 0) & (p.x0[rest, 1] < 2 * np.pi))
    assert np.abs(p.x0[rest, 0]).max() > 0.5                                     # anywhere, not near the centre
    np.testing.assert_array_equal(p.torques[rest], 1.0)                           # the grid's torque
    training = polish_particles(problem, np.random.default_rng([0, PARTICLE_SEED]), 30)
    assert not np.isin(p.x0[:, 0], training.x0[:, 0]).any()                       # drawn afresh


def test_polish_stops_once_the_validation_share_reaches_the_target(monkeypatch):
    problem = synthesis.OscillatorProblem(**SMALL)
    values = synthesis.escapement_values(problem)
    plan = dataclasses.replace(TINY_POLISH, evaluations=57, validation_particles=5, validate_every=2,
                               validation_target=0.9)
    seen, shares = [], iter([0.5, 0.95, 1.0])

    def share(problem_, grid, particles, periods, backend):
        seen.append(particles)
        return next(shares)

    monkeypatch.setattr(polish_module, "captured_share", share)
    out, info = polish(problem, values, 3, plan)
    # judged after generations 2 and 4; the second reaches 0.9, so the search ends there
    assert info.reached and not info.stopped and info.evaluations == 1 + 4 * 8
    assert [e for e, _ in info.validation] == [17, 33] and [v for _, v in info.validation] == [0.5, 0.95]
    expected = validation_particles(problem, np.random.default_rng([3, VALIDATION_SEED]), 5)
    np.testing.assert_array_equal(seen[0].x0, expected.x0)
    np.testing.assert_array_equal(seen[0].torques, expected.torques)
    # the validation only says when to stop: the search to that point is the search without it
    unvalidated, plain = polish(problem, values, 3, dataclasses.replace(plan, evaluations=33, validation_particles=0))
    np.testing.assert_array_equal(out, unvalidated)
    assert plain.history == info.history and plain.validation == [] and not plain.reached
    # without a target the search runs its whole budget, validating as it goes
    shares = iter([0.5, 0.95, 1.0] + [1.0] * 10)
    _, full = polish(problem, values, 3, dataclasses.replace(plan, validation_target=None))
    assert full.evaluations == 57 and not full.reached and len(full.validation) >= 3


def test_the_validation_share_is_the_capture_test_on_the_validation_particles():
    problem = synthesis.OscillatorProblem()
    p = validation_particles(problem, np.random.default_rng(5), 6)
    escapement = synthesis.escapement_values(problem)
    assert polish_module.captured_share(problem, problem.flat_values(), p) == 0.0
    share = polish_module.captured_share(problem, escapement, p)
    assert share > 0.3 and share * 6 == pytest.approx(round(share * 6))          # whole particles


@pytest.mark.parametrize("bad, word", [
    (dict(method="nelder-mead"), "method"), (dict(evaluations=0), "evaluations"), (dict(sigma0=0.0), "sigma0"),
    (dict(rest_share=1.5), "rest_share"), (dict(periods=-1.0), "periods"), (dict(popsize=2.5), "popsize"),
    (dict(strictness=0.0), "strictness"), (dict(rest_max_share=-0.5), "rest_max_share"),
    (dict(validation_particles=-1), "validation_particles"), (dict(validate_every=0), "validate_every"),
    (dict(validation_target=1.5), "validation_target"),
])
def test_bad_polish_plans_are_refused(bad, word):
    with pytest.raises((ValueError, TypeError), match=word):
        PolishPlan(**bad)


# --------------------------------------------------------------------------- a run's stages


def tiny_run(iterations=4, polish_plan=TINY_POLISH):
    plan = Plan(iterations=iterations, optimizer="adam", lr=0.01, lr_final=0.001, n_particles=4,
                stages=((0, 6), (2, 0)), scale_lr_by_grid=False)
    return synthesis.new_design("oscillator", seed=2, plan=plan, polish=polish_plan, **SMALL)


def test_stages_run_the_gradient_iterations_then_the_polish():
    seen = []
    st = run_stages(tiny_run(), callback=seen.append, progress_every=0.0)
    assert st.status == "done" and st.stage == "polish" and st.finished and st.iteration == 4
    polishing = [p.stage == "polish" for p in seen]
    assert not polishing[0] and polishing[-1] and polishing == sorted(polishing)      # gradient lines, then polish
    assert st.evaluations == 25 and st.polish_history["evaluations"] == [1, 9, 17, 25]
    gradient_only = synthesis.run_design(tiny_run())
    np.testing.assert_array_equal(st.base_values, gradient_only.values)
    expected, _ = polish(st.problem, gradient_only.values, 2, TINY_POLISH)
    np.testing.assert_array_equal(st.values, expected)


def test_a_polish_stopped_by_ctrl_c_resumes_to_the_uninterrupted_result(tmp_path):
    straight = run_stages(tiny_run())
    sent = []

    def interrupt(p):
        if p.stage == "polish" and not sent:
            sent.append(p.done)
            os.kill(os.getpid(), signal.SIGINT)

    st = run_stages(tiny_run(), callback=interrupt, progress_every=0.0)
    assert st.status == "interrupted" and st.stage == "polish" and st.evaluations == sent[0] < 25
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    save_design(tmp_path / "half.npz", st)
    back = load_design(tmp_path / "half.npz")
    np.testing.assert_array_equal(back.base_values, straight.base_values)
    resumed = run_stages(back)
    np.testing.assert_array_equal(resumed.values, straight.values)
    assert resumed.polish_history == straight.polish_history and resumed.finished


def test_more_iterations_after_the_polish_continue_the_gradient_stage_and_polish_again():
    longer = run_stages(tiny_run(iterations=6))
    st = run_stages(tiny_run(iterations=4))
    st.plan = dataclasses.replace(st.plan, iterations=6)
    st = run_stages(st)
    assert st.iteration == 6 and st.finished
    np.testing.assert_array_equal(st.base_values, longer.base_values)
    np.testing.assert_array_equal(st.values, longer.values)


def test_a_finished_polish_runs_again_only_with_another_plan():
    st = run_stages(tiny_run())
    values = st.values
    assert run_stages(st).values is values                               # nothing left to do
    set_polish(st, TINY_POLISH)
    assert st.finished                                                   # the same plan: still done
    set_polish(st, PolishPlan(n_particles=4, evaluations=9, popsize=8))
    assert not st.finished
    st = run_stages(st)
    assert st.finished and st.evaluations == 9
