"""The kinds of design as one interface (pes_ref.synthesis.kinds.registry): every kind answers every question
the package asks, and the generic functions give each kind's own answer."""
import dataclasses

import numpy as np
import pytest

import _helpers
from pes_ref import synthesis
from pes_ref.synthesis import KINDS, Plan, PolishPlan, design_inputs, kind_named, kind_of, problem_from_text


def _small(name):
    """A small problem of kind ``name``."""
    if name == "problem":
        return problem_from_text(_helpers.gather_problem(), "gather.toml")
    kind = KINDS[name]
    problem = kind.default_problem()
    return kind.with_sets(problem, kind.smoke.scene(problem))


@pytest.fixture(params=sorted(KINDS))
def problem(request):
    return _small(request.param)


def test_the_table_names_each_kind_by_its_problem_s_kind():
    assert sorted(KINDS) == ["funnel", "oscillator", "problem"]
    for name, kind in KINDS.items():
        assert kind.name == name
        if kind.default_problem is not None:
            assert kind.default_problem().kind == name
    assert kind_of(_small("problem")) is KINDS["problem"]
    with pytest.raises(ValueError, match="catapult"):
        kind_named("catapult")


def test_the_text_round_trip_gives_the_same_problem(problem):
    kind = kind_of(problem)
    back = kind.from_text(kind.to_text(problem), "x.npz")
    assert back == problem and kind.data(back) == kind.data(problem)


def test_with_sets_changes_a_parameter_and_checks_it_again(problem):
    kind = kind_of(problem)
    name, value = ("dynamics.damping", 2.0) if kind.name == "problem" else ("damping" if kind.name == "funnel"
                                                                            else "damping0", 0.5)
    changed = kind.with_sets(problem, {name: value})
    assert changed != problem and kind.with_sets(problem, {}) == problem
    with pytest.raises(ValueError):
        kind.with_sets(problem, {name: -1.0})


def test_the_default_plan_and_polish_and_the_smoke_preset(problem):
    kind = kind_of(problem)
    plan = kind.default_plan(problem)
    assert isinstance(plan, Plan) and (kind.default_polish is None or isinstance(kind.default_polish, PolishPlan))
    smoke = design_inputs(problem, {"smoke": True})
    assert smoke.plan().iterations == kind.smoke.iterations and smoke.plan().n_particles == kind.smoke.particles
    assert smoke.problem.shape()[0] <= 12


def test_the_held_out_evaluation_has_the_headline_figure_and_its_steps(problem):
    kind = kind_of(problem)
    values = 0.01 * np.random.default_rng(1).standard_normal(problem.shape())
    figures = synthesis.evaluate(problem, values, seed=3, n_particles=5)
    assert kind.headline in figures and 0.0 <= figures[kind.headline] <= 1.0
    assert synthesis.held_out_steps(problem) == kind.held_out_steps(problem) >= 1
    panels = synthesis.held_out_panels(problem, values, seed=3, n_particles=5)
    assert panels and all(p.x.shape[1] == p.passed.shape[0] for p in panels)
    again = synthesis.evaluate_seeds(problem, values, (3,), 5)[3]
    assert again.keys() == figures.keys()
    np.testing.assert_array_equal(list(again.values()), list(figures.values()))     # NaN where none captured


def test_the_realization_hooks(problem):
    hooks = kind_of(problem).realizable
    start = hooks.start(problem)
    assert len(start) == 2 and all(isinstance(x, float) for x in start)
    values = np.zeros(problem.shape())
    x = hooks.positions(problem, values, 4, 3)
    assert x.ndim == 3 and x.shape[1:] == (3, 2)
    slower = hooks.at_step(problem, problem.dt / 2)
    assert slower.dt == pytest.approx(problem.dt / 2)


def test_a_design_starts_from_a_kind_s_name_with_its_default_problem_and_plan():
    state = synthesis.new_design("funnel", grid=8)
    assert state.problem == dataclasses.replace(synthesis.FunnelProblem(), grid=8)
    assert state.plan == KINDS["funnel"].default_plan(state.problem) and state.polish is None
    with pytest.raises(TypeError, match="starts from its problem object"):
        synthesis.new_design("problem")
