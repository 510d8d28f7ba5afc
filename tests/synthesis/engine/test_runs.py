"""A run from what a user names (pes_ref.synthesis.engine.runs): design_inputs resolves the options (a problem
file's plan is its [train] with the keys --set changes, the options on top, and its default stages follow
the run's iteration count); start_design starts it, or resumes a saved run after checking it is the run
asked for."""
import numpy as np
import pytest

import _helpers
from pes_ref import synthesis
from pes_ref.core.checks import InputError
from pes_ref.synthesis import DesignFileError, check_resume, design_inputs, problem_from_text, start_design

#: A problem on a 40 x 40 grid without train.stages: 25 nodes for 80% of the run, then 40.
FINE = problem_from_text(_helpers.gather_problem(iterations=300).replace("shape = [8, 8]", "shape = [40, 40]"),
                         "fine.toml")

#: (options, --set keys, the plan's iterations, decay_iterations and stages)
PLANS = [
    ({}, {}, 300, 300, ((0, 25, 0), (240, 0, 0))),
    ({"iterations": 100}, {}, 100, 300, ((0, 25, 0), (80, 0, 0))),
    ({}, {"train.iterations": 20}, 20, 20, ((0, 25, 0), (16, 0, 0))),
    ({"iterations": 50}, {"train.iterations": 20}, 50, 20, ((0, 25, 0), (40, 0, 0))),
    ({}, {"train.particles": 3, "train.lr": 0.01}, 300, 300, ((0, 25, 0), (240, 0, 0))),
    ({"iterations": 100, "stages": "0:0"}, {}, 100, 300, ((0, 0, 0),)),
    ({"iterations": 100}, {"train.stages": [[0, 10], [5, 0]]}, 100, 300, ((0, 10, 0), (5, 0, 0))),
    ({"smoke": True}, {}, 6, 300, ((0, 0, 0),)),
    ({"smoke": True}, {"train.iterations": 20}, 20, 20, ((0, 0, 0),)),
]


@pytest.mark.parametrize("options, sets, iterations, decay, stages", PLANS,
                         ids=[f"{o}-{s}" for o, s, *_ in PLANS])
def test_a_problem_file_s_plan_is_its_train_table_with_the_sets_and_options(options, sets, iterations, decay,
                                                                             stages):
    inputs = design_inputs(FINE, options, sets)
    plan = inputs.plan()
    assert (plan.iterations, plan.decay_iterations, plan.stages) == (iterations, decay, stages)
    for key, value in sets.items():                   # the problem the design file holds says the same
        assert inputs.problem.data["train"][key.split(".")[1]] == value
    if "train.particles" in sets:
        assert plan.n_particles == 3 and plan.lr == 0.01


def _tiny_funnel():
    return synthesis.new_design("funnel", grid=8, n_steps=50, plan=synthesis.Plan(iterations=2, n_particles=4))


def test_a_resumed_built_in_design_must_have_each_parameter_the_run_sets():
    state = _tiny_funnel()
    with pytest.raises(DesignFileError, match="funnel design, not an oscillator design"):
        check_resume(state, design_inputs(synthesis.OscillatorProblem(), {}))
    with pytest.raises(DesignFileError, match="n_steps = 50 there, 80 asked"):
        check_resume(state, design_inputs(synthesis.FunnelProblem(), {}, {"n_steps": 80}))
    check_resume(state, design_inputs(synthesis.FunnelProblem(), {}, {"n_steps": 50}))    # the same: accepted
    check_resume(state, design_inputs(synthesis.FunnelProblem(), {}))                     # nothing named: accepted


def test_a_resumed_problem_file_design_must_have_the_file_s_problem_in_every_key():
    gather = problem_from_text(_helpers.gather_problem(), "gather.toml")
    state = synthesis.new_design(gather)
    check_resume(state, design_inputs(gather, {}))                                 # the same problem: fine
    changed = problem_from_text(_helpers.gather_problem().replace("dt = 0.05", "dt = 0.04"), "changed.toml")
    with pytest.raises(DesignFileError, match=r"the problem file changed\.toml differs .* dynamics\.dt = 0\.04 there, "
                                              r"0\.05 in the design's problem"):
        check_resume(state, design_inputs(changed, {}))
    with pytest.raises(InputError, match=r"set: a resumed design keeps its problem; dynamics\.dt = 0\.04, 0\.05"):
        check_resume(state, design_inputs(state.problem, {}, {"dynamics.dt": 0.04}))   # its own problem, set
    with pytest.raises(DesignFileError, match="a funnel design, not a problem design"):
        check_resume(_tiny_funnel(), design_inputs(gather, {}))


def test_a_resumed_run_keeps_its_seed_optimizer_and_backend_and_takes_the_options_given(tmp_path):
    state = _tiny_funnel()
    inputs = design_inputs(synthesis.FunnelProblem(), {"iterations": 5, "lr": 0.02})
    with pytest.raises(InputError, match=r"seed 3 differs from the resumed run's \(0\)"):
        start_design(inputs, seed=3, resume=state)
    with pytest.raises(InputError, match="optimizer adam differs"):
        start_design(design_inputs(synthesis.FunnelProblem(), {"optimizer": "adam"}), resume=state)
    other = "numpy" if state.backend != "numpy" else "numba"
    with pytest.raises(InputError, match=f"backend {other} differs"):
        start_design(inputs, backend=other, resume=state)
    resumed = start_design(inputs, seed=0, resume=state)
    assert resumed is state and (resumed.plan.iterations, resumed.plan.lr) == (5, 0.02)
    assert resumed.plan.n_particles == 4                  # the rest of its plan is its own


def test_a_sweep_s_resume_must_be_the_very_run():
    inputs = design_inputs(synthesis.FunnelProblem(), {"smoke": True})
    state = start_design(inputs, seed=2)
    assert start_design(inputs, seed=2, resume=state, exact=True) is state
    for change in ({"seed": 3}, {"inputs": design_inputs(synthesis.FunnelProblem(), {"smoke": True, "lr": 0.5})},
                   {"inputs": design_inputs(synthesis.FunnelProblem(), {"smoke": True}, {"noise": 0.1})}):
        with pytest.raises(ValueError, match="holds another run's design"):
            start_design(change.get("inputs", inputs), seed=change.get("seed", 2), resume=state, where="x.npz",
                         exact=True)


def test_a_fresh_run_is_new_design_of_the_resolved_problem_and_plan():
    inputs = design_inputs(synthesis.OscillatorProblem(), {"smoke": True, "plan": "eq6"}, {"kick": 0.3})
    state = start_design(inputs, seed=4)
    assert state.seed == 4 and state.problem == inputs.problem and state.plan == inputs.plan()
    assert state.problem.cost == "eq6" and state.problem.kick == 0.3 and state.polish is None
    np.testing.assert_array_equal(state.values, synthesis.new_design(inputs.problem, seed=4, plan=inputs.plan()).values)
