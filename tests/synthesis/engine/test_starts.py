"""A population of starts (pes_ref.synthesis.engine.population, Plan.starts/screen): the run's own start that
passes at least OWN_SHARE by the screen is the run itself, bit for bit, and no other start runs; otherwise the
starts run until two pass some (the own start among them if it passes some), the better of those (else, none passing, the start of least
validation loss) is chosen and the run goes on from it with its own batches; Ctrl-C leaves the run at its start; the plan refuses a population it cannot choose in;
the default plan screens through its coarse stages."""
import dataclasses
import os
import signal

import numpy as np
import pytest

import _helpers
from pes_ref import synthesis
from pes_ref.synthesis import Plan, load_design, problem_from_text, save_design, with_sets
from pes_ref.synthesis.engine import population
from pes_ref.synthesis.engine.training import design_step
from pes_ref.synthesis.common.validation import VALIDATION_STREAM, validation_success

GATHER = problem_from_text(_helpers.gather_problem(walls=True, noise=True, radius=0.3), "gather.toml")
PLAN = Plan(iterations=12, lr=0.02, stages=((0, 5), (6, 0)), n_particles=8, validate_every=3,
            validation_particles=16)
POPULATION = dataclasses.replace(PLAN, starts=3, screen=6)
#: Nothing passes: a disc no particle reaches, so every start validates at 0 and the loss chooses.
NOWHERE = with_sets(GATHER, {"evaluate.success.0.radius": 1e-6})
#: A small disc: with design seed 1 the run's own start passes none of its validation particles by
#: the screen, its second and third pass some (3 and 1 of 16), its fourth too.
SMALL = with_sets(GATHER, {"evaluate.success.0.radius": 0.05})


def _counting(monkeypatch):
    made = []
    real = population.new_design

    def counted(*args, **kwargs):
        made.append(kwargs["seed"])
        return real(*args, **kwargs)
    monkeypatch.setattr(population, "new_design", counted)
    return made


def test_an_own_start_that_passes_some_by_the_screen_is_the_run_itself(monkeypatch):
    made = _counting(monkeypatch)
    plain = synthesis.run_stages(synthesis.new_design(GATHER, seed=0, plan=PLAN, polish=None))
    assert max(s for i, s in zip(*plain.validation.values()) if i <= 6) > 0.0      # the case this test is about
    st = synthesis.run_stages(synthesis.new_design(GATHER, seed=0, plan=POPULATION, polish=None))
    assert made == []
    np.testing.assert_array_equal(st.values, plain.values)
    assert st.validation == plain.validation and st.history == plain.history and st.status == "done"


def test_with_nothing_passing_the_start_of_least_validation_loss_is_chosen(monkeypatch):
    made = _counting(monkeypatch)
    st = synthesis.new_design(NOWHERE, seed=4, plan=POPULATION, polish=None)
    population.screen_starts(st)
    seeds = [4] + [population.start_seed(4, j) for j in (1, 2)]
    assert made == seeds[1:] and len(set(seeds)) == 3
    losses, grids = [], []
    for seed in seeds:                                   # each start by hand, judged on the run's particles
        member = synthesis.new_design(NOWHERE, seed=seed, plan=POPULATION, polish=None)
        synthesis.run_design(member, 6, finish=False)
        assert member.status == "running" and member.iteration == 6
        losses.append(design_step(NOWHERE, member.values, 4, VALIDATION_STREAM, 16)[0])
        grids.append(member.values)
    chosen = int(np.argmin(losses))
    assert len(set(losses)) == 3
    np.testing.assert_array_equal(st.values, grids[chosen])
    success, final = validation_success(NOWHERE, grids[chosen], 4, 16)
    assert st.iteration == 6 and st.status == "running" and st.seed == 4
    assert st.validation == {"iteration": [6], "success": [success]} and st.best.iteration == 6
    np.testing.assert_array_equal(st.best.values, final)
    done = synthesis.run_design(st)                      # goes on with the run's own batches
    assert done.iteration == 12 and done.validation["iteration"] == [6, 9, 12]


def test_the_best_of_the_first_starts_that_pass_some_is_chosen(monkeypatch):
    made = _counting(monkeypatch)
    plan = dataclasses.replace(POPULATION, starts=4)
    st = synthesis.new_design(SMALL, seed=1, plan=plan, polish=None)
    population.screen_starts(st)
    seeds = [1] + [population.start_seed(1, j) for j in (1, 2)]
    assert population.COMPARED == 2 and made == seeds[1:]          # the fourth start is never made
    assert st.screened == {"starts": 3, "iterations": 18}
    judged, grids = [], []
    for j, seed in enumerate(seeds):                     # each start by hand, judged on the run's particles
        member = synthesis.new_design(SMALL, seed=seed, plan=plan, polish=None)
        synthesis.run_design(member, 6, finish=False)
        assert (member.best.success > 0.0) == (j > 0)
        success, _ = validation_success(SMALL, member.values, 1, 16)
        judged.append((-success, design_step(SMALL, member.values, 1, VALIDATION_STREAM, 16)[0], j))
        grids.append(member.values)
    chosen = min(judged[1:])[2]
    assert chosen == min(judged)[2] or judged[0][0] < min(judged[1:])[0]      # a passing start, the best of them
    np.testing.assert_array_equal(st.values, grids[chosen])
    assert st.iteration == 6 and st.status == "running" and st.validation["success"] == [-judged[chosen][0]]


def test_an_own_start_that_passes_less_than_its_share_is_compared_with_the_others(monkeypatch):
    made = _counting(monkeypatch)
    plan = dataclasses.replace(POPULATION, starts=4)
    st = synthesis.new_design(SMALL, seed=0, plan=plan, polish=None)
    population.screen_starts(st)
    seeds = [0] + [population.start_seed(0, j) for j in (1, 2, 3)]
    judged, grids = [], []
    for j, seed in enumerate(seeds):                     # each start by hand, judged on the run's particles
        member = synthesis.new_design(SMALL, seed=seed, plan=plan, polish=None)
        synthesis.run_design(member, 6, finish=False)
        if j == 0:                                       # the case this test is about
            assert 0.0 < member.best.success < population.OWN_SHARE
        if member.best.success > 0.0:
            success, _ = validation_success(SMALL, member.values, 0, 16)
            judged.append((-success, design_step(SMALL, member.values, 0, VALIDATION_STREAM, 16)[0], j))
            grids.append(member.values)
        if len(judged) == population.COMPARED:
            break
    assert made == seeds[1:j + 1]                        # screened until two pass some, the own start one of them
    chosen = min(judged)
    np.testing.assert_array_equal(st.values, grids[judged.index(chosen)])
    assert st.iteration == 6 and st.status == "running" and st.validation["success"] == [-chosen[0]]


def test_ctrl_c_during_the_screen_leaves_the_run_at_its_start(tmp_path):
    start = synthesis.new_design(NOWHERE, seed=4, plan=POPULATION, polish=None)
    first = start.values.copy()

    def interrupt(progress):                             # in the second start
        if progress.done == 3 and interrupt.calls == 1:
            os.kill(os.getpid(), signal.SIGINT)
        interrupt.calls += progress.done == 6
    interrupt.calls = 0
    stages = []
    st = synthesis.run_stages(start, callback=lambda p: (stages.append(p.stage), interrupt(p)), progress_every=0.0)
    assert stages[0] == "start 1/3 stage 1/1" and "start 2/3 stage 1/1" in stages     # the screen: the 5-node stage
    assert st.status == "interrupted" and st.iteration == 0 and st.history["loss"] == []
    np.testing.assert_array_equal(st.values, first)
    save_design(tmp_path / "d.npz", st)
    resumed = synthesis.run_stages(load_design(tmp_path / "d.npz"))
    whole = synthesis.run_stages(synthesis.new_design(NOWHERE, seed=4, plan=POPULATION, polish=None))
    assert resumed.plan == POPULATION
    np.testing.assert_array_equal(resumed.values, whole.values)
    assert resumed.history == whole.history and resumed.validation == whole.validation


def test_a_population_needs_validation_and_a_screen():
    for bad in ({"starts": 2}, {"starts": 2, "screen": 5, "validate_every": 0}, {"starts": 0}):
        with pytest.raises(ValueError, match="starts"):
            dataclasses.replace(PLAN, **{"screen": 0, **bad})


def test_the_default_plan_screens_its_starts_through_the_coarse_stages():
    plan = synthesis.default_plan((40, 20))
    assert (plan.starts, plan.screen) == (8, 225) and plan.stages[-1][0] == 225
    assert synthesis.default_plan((40, 20), coarse=False).starts == 1
    problem = synthesis.parse_problem({k: v for k, v in GATHER.data.items() if k != "train"}, "gather.toml")
    assert problem.plan.screen == 150 and synthesis.plan_for(problem, 600).screen == 300


def test_a_run_shorter_than_the_screen_screens_no_further(monkeypatch):
    made = _counting(monkeypatch)
    st = synthesis.run_stages(synthesis.new_design(NOWHERE, seed=4, plan=POPULATION, polish=None), 4)
    assert st.iteration == 4 and st.status == "done" and len(made) == 2
