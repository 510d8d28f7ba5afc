"""Design options (pes_ref.sweep.options.design_inputs): a problem file's plan is its [train] with the
keys --set changes, the options on top, and its default stages follow the run's iteration count."""
import pytest

import _helpers
from pes_ref.synthesis import problem_from_text
from pes_ref.sweep.options import design_inputs

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
    inputs = design_inputs("problem", options, sets, FINE)
    plan = inputs.plan()
    assert (plan.iterations, plan.decay_iterations, plan.stages) == (iterations, decay, stages)
    for key, value in sets.items():                   # the problem the design file holds says the same
        assert inputs.problem.data["train"][key.split(".")[1]] == value
    if "train.particles" in sets:
        assert plan.n_particles == 3 and plan.lr == 0.01
