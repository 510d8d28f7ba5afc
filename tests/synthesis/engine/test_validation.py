"""Validation of a design run (pes_ref.synthesis.common.validation, Plan.validate_every/target): the run
keeps and ends on its best validated grid, stops early at the target, is bit-identical for a
seed and across a stop and resume through a design file, and a file without [train] gets the
default plan."""
import os
import signal

import numpy as np
import pytest

import _helpers
from pes_ref import synthesis
from pes_ref.synthesis import Plan, load_design, problem_from_text, save_design, with_sets
from pes_ref.synthesis.common.validation import VALIDATION_STREAM, validation_success

GATHER = problem_from_text(_helpers.gather_problem(walls=True, noise=True, radius=0.3), "gather.toml")
PLAN = Plan(iterations=12, lr=0.02, stages=((0, 5), (6, 0)), n_particles=8, validate_every=3,
            validation_particles=16)


def _run(plan=PLAN, seed=0, iterations=None):
    return synthesis.run_design(synthesis.new_design(GATHER, seed=seed, plan=plan), iterations)


def test_the_run_ends_on_its_best_validated_grid():
    st = _run()
    assert st.status == "done" and st.validation["iteration"] == [0, 3, 6, 9, 12]
    best = int(np.argmax(st.validation["success"]))          # the first of equals
    assert st.best.iteration == st.validation["iteration"][best]
    assert st.best.success == max(st.validation["success"])
    np.testing.assert_array_equal(st.values, st.best.values)
    assert st.values.shape == GATHER.shape()                 # on the problem's grid, whatever the stage's
    success, _ = validation_success(GATHER, st.values, 0, 16)
    assert success == st.best.success


def test_validation_particles_are_their_own_stream():
    a = GATHER.batch(GATHER.flat_values(), np.random.default_rng([0, VALIDATION_STREAM]), 4)
    b = GATHER.batch(GATHER.flat_values(), np.random.default_rng(0), 4)
    assert not np.array_equal(a.x0, b.x0)


def test_the_target_stops_the_run_early():
    full = _run()
    target = max(full.validation["success"])
    first = full.validation["iteration"][full.validation["success"].index(target)]
    early = _run(Plan(**{**PLAN.__dict__, "target": target}))
    assert early.status == "done" and early.iteration == first
    assert early.validation["iteration"] == [i for i in full.validation["iteration"] if i <= first]
    assert synthesis.run_design(early).iteration == first     # reached: no more iterations


def test_a_start_at_the_target_is_not_designed_at_all():
    easy = with_sets(GATHER, {"evaluate.success.0.radius": 5.0})        # every particle passes from the start
    st = synthesis.run_design(synthesis.new_design(easy, plan=Plan(**{**PLAN.__dict__, "target": 0.97})))
    assert st.status == "done" and st.iteration == 0 and st.validation == {"iteration": [0], "success": [1.0]}
    np.testing.assert_array_equal(st.values, st.best.values)


def test_a_drawn_start_is_designed_on_its_own_grid():
    assert synthesis.default_plan((40, 40), coarse=False).stages == ((0, 0, 0),)
    assert synthesis.default_plan((40, 40)).stages == ((0, 5, 0), (75, 9, 0), (150, 17, 0), (225, 0, 0))
    contact = synthesis.load_problem(synthesis.shipped_problem("latch_contact"))
    data = {k: v for k, v in contact.data.items() if k != "train"}
    assert synthesis.parse_problem(data, "latch_contact.toml").plan.stages == ((0, 0, 0),)


def test_the_same_seed_gives_the_same_run():
    a, b = _run(), _run()
    np.testing.assert_array_equal(a.values, b.values)
    assert a.validation == b.validation and a.history == b.history


def test_an_interrupted_run_resumes_bit_exactly(tmp_path):
    whole = _run()

    def interrupt(progress):                                 # Ctrl-C after iteration 5, between validations
        if progress.done == 5:
            os.kill(os.getpid(), signal.SIGINT)

    part = synthesis.run_design(synthesis.new_design(GATHER, plan=PLAN), callback=interrupt, progress_every=0.0)
    assert part.status == "interrupted" and part.iteration == 5 and part.validation["iteration"] == [0, 3]
    save_design(tmp_path / "part.npz", part)
    resumed = synthesis.run_design(load_design(tmp_path / "part.npz"))
    np.testing.assert_array_equal(resumed.values, whole.values)
    assert resumed.validation == whole.validation and resumed.history == whole.history
    assert resumed.best.iteration == whole.best.iteration


def test_a_run_done_early_ends_on_its_best_and_goes_on_from_it():
    short = _run(iterations=7)                               # the last iteration is validated too
    assert short.status == "done" and short.validation["iteration"] == [0, 3, 6, 7]
    np.testing.assert_array_equal(short.values, short.best.values)
    more = synthesis.run_design(short, 9)
    assert more.validation["iteration"] == [0, 3, 6, 7, 9]


def test_a_design_file_holds_the_validations(tmp_path):
    st = _run()
    save_design(tmp_path / "d.npz", st)
    back = load_design(tmp_path / "d.npz")
    assert back.validation == st.validation and back.plan == st.plan
    assert back.best.iteration == st.best.iteration and back.best.success == st.best.success
    np.testing.assert_array_equal(back.best.values, st.best.values)


def test_a_file_without_train_gets_the_default_plan():
    data = {k: v for k, v in GATHER.data.items() if k != "train"}
    problem = synthesis.parse_problem(data, "gather.toml")
    assert problem.plan == synthesis.default_plan(problem.grid_shape)
    assert problem.plan.validate_every > 0 and problem.plan.target is not None
    assert with_sets(problem, {"train.iterations": 5}).plan.validate_every == 0     # a [train] table: as before


def test_train_states_validation_and_refuses_a_target_above_one():
    p = with_sets(GATHER, {"train.validate_every": 2, "train.target": 0.9})
    assert (p.plan.validate_every, p.plan.validation_particles, p.plan.target) == (2, 200, 0.9)
    assert GATHER.plan.validate_every == 0 and GATHER.plan.target is None          # off unless asked for
    with pytest.raises(synthesis.ProblemFileError, match="train.target"):
        with_sets(GATHER, {"train.target": 1.5})


def test_iterations_from_the_command_line_share_out_the_default_stages():
    problem = synthesis.parse_problem({k: v for k, v in GATHER.data.items() if k != "train"}, "gather.toml")
    assert problem.plan.stages == ((0, 5, 0), (150, 0, 0))                  # an 8-node grid: 5, then 8
    assert synthesis.plan_for(problem, 600).stages == ((0, 5, 0), (300, 0, 0))
    assert synthesis.plan_for(problem, 600).validate_every == problem.plan.validate_every
