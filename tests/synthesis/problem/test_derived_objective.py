"""Problem files without ``[[objective]]`` are designed on their success tests' surrogates
(pes_ref.synthesis.problem.surrogates), and the format's start groups, disc, segment, any-of and custom
tests and the population criterion ([[evaluate.share]]): read, refused in one line when bad, and the design gradient of the derived objective
against central differences on every grid value, on a plane, a cylinder and a torus."""
import numpy as np
import pytest

from _helpers import check_state_derivatives

from pes_ref import synthesis
from pes_ref.oracle.compare import relative_error
from pes_ref.testing.finite_differences import central_gradient
from pes_ref.oracle.tolerances import FD_RTOL
from pes_ref.synthesis import ProblemFileError, parse_problem, problem_from_text, problem_text
from pes_ref.synthesis import held_out_panels
from pes_ref.synthesis.problem.success import GroupTest
from pes_ref.synthesis.problem.surrogates import Surrogate

#: A sorter as the docs state one: two start groups, each with its own test, no [[objective]].
SORTER = {
    "format": 1, "name": "sorter",
    "surface": {"lower": [-1.0, -1.0], "upper": [1.0, 1.0], "shape": [5, 5]},
    "dynamics": {"dt": 0.05, "duration": 1.0, "damping": 1.0, "walls": {"k": 50.0, "margin": 0.05}},
    "starts": {"group": [{"name": "left", "box": {"lower": [-0.9, -0.5], "upper": [-0.1, 0.5]}},
                         {"name": "right", "share": 2.0, "points": [[0.5, 0.0], [0.6, 0.1]]}]},
    "forces": [{"kind": "constant", "force": [0.5, 0.0]}],
    "evaluate": {"particles": 9, "success": [
        {"name": "up", "group": "left", "kind": "within", "center": [0.5, 0.5], "radius": 0.3, "from": 0.5},
        {"name": "down", "group": "right", "kind": "stay_in", "lower": [0.0, -1.0], "upper": [1.0, 0.0],
         "from": 1.0},
        {"name": "either", "kind": "any_of", "tests": [
            {"kind": "cross", "a": [0.0, -1.0], "b": [0.0, 1.0]},
            {"kind": "final_position", "target": [0.9, 0.9], "radius": 0.1}]}]},
}


def _sorter(**changes):
    data = {**SORTER, **changes}
    return parse_problem(data, "sorter.toml")


def test_a_file_without_objective_is_designed_on_its_tests_surrogates():
    problem = _sorter()
    assert problem.term_names == ("surrogate_up", "surrogate_down", "surrogate_either")
    assert all(isinstance(t, Surrogate) and t.margin == 0.25 for t in problem.terms)
    assert [t.margin for t in _sorter(evaluate={**SORTER["evaluate"], "margin": 0.1}).terms] == [0.1] * 3


def test_start_groups_split_a_batch_by_their_shares_in_order():
    problem = _sorter()
    assert problem.starts.counts(9) == [3, 6] and problem.starts.counts(10) == [3, 7]
    assert problem.starts.counts(1) == [0, 1]
    x0, _ = problem.starts.sample(np.random.default_rng(0), 9)
    assert np.all(x0[:3, 0] < 0) and np.array_equal(x0[3:], [[0.5, 0.0], [0.6, 0.1]] * 3)
    up, down, _ = (t for _, t in problem.tests)
    assert isinstance(up, GroupTest) and up.members(9).tolist() == [True] * 3 + [False] * 6
    assert down.members(9).tolist() == [False] * 3 + [True] * 6


def test_a_group_s_figure_is_the_share_of_its_own_particles():
    problem = _sorter()
    figures = synthesis.evaluate(problem, problem.flat_values(), seed=3)
    held = problem.run(problem.flat_values(), 3, 9)
    up = next(t for n, t in problem.tests if n == "up")
    assert figures["success_up"] == pytest.approx(np.mean(up.test.passes(held.traj.x, held.traj.v, held.times)[:3]))
    assert "objective_surrogate_up" in figures


@pytest.mark.parametrize("periodic", [(False, False), (False, True), (True, True)])
def test_design_gradient_of_the_derived_objective_matches_central_differences_entrywise(periodic):
    walls = {"k": 50.0, "margin": 0.05, "edges": [[not periodic[0]] * 2, [not periodic[1]] * 2]}
    tests = [t for t in SORTER["evaluate"]["success"] if t["kind"] != "any_of"]
    if not periodic[0]:
        tests.append({"name": "out", "kind": "exit", "edge": "q0_upper", "center": 0.2, "halfwidth": 0.3,
                      "min_speed": 2.0})
    tests.append({"name": "fast", "kind": "speed_at", "time": 0.5, "axis": 1, "min": 0.4})
    problem = _sorter(surface={**SORTER["surface"], "periodic": list(periodic)},
                      dynamics={**SORTER["dynamics"], "walls": walls},
                      evaluate={"particles": 9, "success": tests},
                      forces=[{"kind": "constant", "force": [0.5, 0.2]}, {"kind": "noise", "std": 0.05}])
    rng = np.random.default_rng(4)
    values = 0.2 * rng.standard_normal(problem.shape())
    step = synthesis.design_gradient(problem, values, seed=1, iteration=0, n_particles=6)
    fd = central_gradient(lambda v: synthesis.design_gradient(problem, v, seed=1, iteration=0, n_particles=6).loss,
                          values)
    assert step.loss > 0 and np.count_nonzero(fd) >= values.size // 2      # the particles visit most nodes
    assert relative_error(step.grad, fd) < FD_RTOL


#: The sorter with a scenario that pushes the other way, its tests charged with the run's.
SCENARIO = {"name": "back", "forces": [{"kind": "constant", "force": [-0.5, -0.2]}, {"kind": "noise", "std": 0.05}],
            "success": [{"name": "left", "kind": "within", "center": [-0.5, 0.0], "radius": 0.3, "from": 0.5},
                        {"name": "out", "kind": "exit", "edge": "q0_lower", "center": 0.0, "halfwidth": 0.5,
                         "from": 0.5, "to": 0.9}]}


def _with_scenario(**changes):
    tests = [t for t in SORTER["evaluate"]["success"] if t["kind"] != "any_of"]
    return _sorter(evaluate={"particles": 9, "success": tests, "scenario": [SCENARIO]},
                   forces=[{"kind": "constant", "force": [0.5, 0.2]}, {"kind": "noise", "std": 0.05}], **changes)


def test_design_gradient_with_a_charged_scenario_matches_central_differences_entrywise():
    problem = _with_scenario()
    assert [sc.name for sc in problem.charged_scenarios] == ["back"]
    values = 0.2 * np.random.default_rng(6).standard_normal(problem.shape())
    step = synthesis.design_gradient(problem, values, seed=1, iteration=0, n_particles=6)
    fd = central_gradient(lambda v: synthesis.design_gradient(problem, v, seed=1, iteration=0, n_particles=6).loss,
                          values)
    assert np.count_nonzero(fd) >= values.size // 2
    assert relative_error(step.grad, fd) < FD_RTOL
    # the loss is the run's plus the scenario's: without the scenario only the run's
    alone = _sorter(evaluate={"particles": 9, "success": [t for t in SORTER["evaluate"]["success"]
                                                          if t["kind"] != "any_of"]},
                    forces=[{"kind": "constant", "force": [0.5, 0.2]}, {"kind": "noise", "std": 0.05}])
    base = synthesis.design_gradient(alone, values, seed=1, iteration=0, n_particles=6).loss
    assert step.loss > base > 0.0


def test_a_scenario_of_a_hand_written_objective_is_a_check_not_charged():
    problem = _with_scenario(objective=[{"kind": "final_position", "target": [0.5, 0.5]}])
    assert problem.charged_scenarios == () and [sc.name for sc in problem.scenarios] == ["back"]


def test_validation_judges_the_particles_in_the_run_and_in_each_charged_scenario():
    from pes_ref.synthesis.common.validation import validation_success
    import _helpers
    problem = synthesis.load_problem(str(_helpers.ROOT / "examples" / "problems" / "toggle.toml"))
    q1 = problem.nodes(problem.shape(), 1)[None, :] * np.ones(problem.shape())
    values = 10.0 * (q1 - 0.5) ** 2         # one well, up: the run holds up, the reset scenario fails
    figures = synthesis.evaluate(problem, values, seed=5)
    assert figures["success_fraction"] >= 0.95 and figures["scenario_reset_success_fraction"] == 0.0
    assert validation_success(problem, values, 0, 50)[0] == 0.0


def test_a_custom_test_from_a_module_is_read_and_its_surrogate_used():
    data = {**SORTER, "evaluate": {"success": [{"kind": "custom", "object": "_helpers:BAND_TEST"}]}}
    problem = parse_problem(data, "c.toml")
    assert problem.term_names == ("surrogate_custom",)
    assert "_helpers:BAND_TEST" in problem_text(problem)


def test_a_loss_of_zero_while_particles_fail_is_an_error_the_run_reports():
    # every particle fails the test and its surrogate charges nothing: the gradient is 0, the run
    # cannot move, so it stops at once rather than finishing "done" on its starting grid
    data = {**SORTER, "evaluate": {"success": [{"kind": "custom", "object": "_helpers:UNCHARGED_TEST"}]},
            "train": {"iterations": 3, "particles": 4, "validate_every": 1, "validation_particles": 4,
                      "target": 0.9}}
    state = synthesis.run_design(synthesis.new_design(parse_problem(data, "u.toml")))
    assert state.status == ("uncharged: iteration 0: the loss is 0 while the batch's success is 0.000 and the best "
                            "validation's 0.000, below the target 0.9: nothing charges what its particles fail")
    assert state.status.startswith(synthesis.STOPPED) and state.iteration == 0
    # charged, the same problem runs to its end
    charged = {**data, "evaluate": {"success": [{"kind": "custom", "object": "_helpers:BAND_TEST"}]}}
    assert synthesis.run_design(synthesis.new_design(parse_problem(charged, "c.toml"))).status == "done"


BAD = [
    ({"starts": {"box": {"lower": [0, 0], "upper": [1, 1]}, "group": SORTER["starts"]["group"]}},
     "starts.group", "not both"),
    ({"starts": {"group": [{"name": "a", "box": {"lower": [0, 0], "upper": [1, 1]}},
                           {"name": "a", "points": [[0, 0]]}]}}, "starts.group", "same name"),
    ({"starts": {"group": [{"name": "a"}]}}, "starts.group[0].box", "exactly one of box and points"),
    ({"starts": {"group": [{"name": "a", "points": [[0, 0]], "share": 0}]}}, "starts.group[0].share", "> 0"),
    ({"starts": {"group": [{"name": "a", "points": [[0, 0]], "group": []}]}}, "starts.group[0].group", "unknown"),
    ({"evaluate": {"success": [{"kind": "within", "center": [0, 0], "radius": 0.1, "group": "middle"}]}},
     "evaluate.success[0].group", "no start group 'middle'"),
    ({"evaluate": {"margin": 1.0, "success": [{"kind": "within", "center": [0, 0], "radius": 0.1}]}},
     "evaluate.margin", "< 1"),
    ({"evaluate": {"success": [{"kind": "any_of", "tests": []}]}}, "evaluate.success[0].tests", "non-empty list"),
    ({"evaluate": {"success": [{"kind": "any_of", "tests": [{"kind": "within", "center": [0, 0]}]}]}},
     "evaluate.success[0].tests[0].radius", "missing"),
    ({"evaluate": {"success": [{"kind": "cross", "a": [0, 0], "b": [0, 0]}]}}, "evaluate.success[0]", "same point"),
    ({"evaluate": {"success": [{"kind": "speed_at", "time": 0.5, "axis": 0, "min": 1, "max": 0}]}},
     "evaluate.success[0]", "max >= min"),
    ({"evaluate": {"success": [{"kind": "custom", "object": "_helpers:BAND_TEST_WITHOUT_COST"}]}},
     "evaluate.success[0].object", "no cost"),
    ({"evaluate": {"success": [{"kind": "custom", "object": "_helpers:gather_problem"}]}},
     "evaluate.success[0].object", "has no passes(x, v, t)"),
    ({"evaluate": {"success": [{"kind": "custom", "object": "_helpers:_Band"}]}},
     "evaluate.success[0].object", "is a class"),
]


@pytest.mark.parametrize("changes, key, words", BAD, ids=[b[1] + ":" + b[2] for b in BAD])
def test_a_bad_key_of_the_new_tables_is_refused_in_one_line_naming_it(changes, key, words):
    with pytest.raises(ProblemFileError) as err:
        _sorter(**changes)
    message = str(err.value)
    assert message.startswith(f"sorter.toml: {key}: ") and words in message and "\n" not in message, message


def test_a_file_of_format_1_without_the_new_keys_reads_as_before():
    problem = problem_from_text(open(synthesis.shipped_problem("latch")).read(), "latch.toml")
    assert problem.term_names == ("latched", "out") and not problem.starts.groups


#: A splitter: from the top's centre, out by either side edge, at least 40% by each.
SPLITTER = {
    "format": 1, "name": "splitter",
    "surface": {"lower": [-1.0, -1.0], "upper": [1.0, 1.0], "shape": [5, 5]},
    "dynamics": {"dt": 0.05, "duration": 2.0, "damping": 1.0},
    "starts": {"box": {"lower": [-0.2, 0.5], "upper": [0.2, 0.5]}},
    "forces": [{"kind": "noise", "std": 0.3}],
    "evaluate": {"particles": 40, "success": [{"kind": "any_of", "tests": [
        {"kind": "exit", "edge": "q0_lower", "center": 0.0, "halfwidth": 1.0},
        {"kind": "exit", "edge": "q0_upper", "center": 0.0, "halfwidth": 1.0}]}],
        "share": [{"name": "left", "min": 0.4, "test": {"kind": "exit", "edge": "q0_lower", "center": 0.0,
                                                          "halfwidth": 1.0}},
                  {"name": "right", "min": 0.4, "max": 0.6, "test": {"kind": "exit", "edge": "q0_upper",
                                                                       "center": 0.0, "halfwidth": 1.0}}]},
}


def test_a_share_criterion_is_reported_and_its_lower_bound_charged():
    problem = parse_problem(SPLITTER, "splitter.toml")
    assert problem.term_names == ("surrogate_any_of", "surrogate_share_left", "surrogate_share_right",
                                  "surrogate_share_right_max")
    tilt = np.outer(np.linspace(1.0, -1.0, 5), np.ones(5))           # downhill to the right: all go right
    figures = synthesis.evaluate(problem, tilt, seed=2)
    assert figures["share_left"] < 0.4 and figures["share_left_met"] == 0.0
    assert figures["share_right"] > 0.6 and figures["share_right_met"] == 0.0
    flat = synthesis.evaluate(problem, problem.flat_values(), seed=2)
    assert set(flat) >= {"share_left", "share_left_met", "share_right", "share_right_met"}


def test_a_share_s_surrogate_charges_the_cheapest_failing_particles_it_lacks():
    from pes_ref.synthesis.problem.success import ShareCriterion
    problem = parse_problem(SPLITTER, "splitter.toml")
    left = next(c for n, c in problem.shares if n == "left")
    rng = np.random.default_rng(0)
    x = rng.uniform(-0.5, 0.5, (4, 10, 2))
    x[-1, :3, 0] = -1.5                                    # three of ten out by the left edge
    v, t = np.zeros_like(x), np.arange(4) * 0.1
    c_all, _, _ = left.test.cost(x, v, t, 0.25)
    c, _, _ = left.cost(x, v, t, 0.25)
    failing = np.flatnonzero(c_all > 0)
    cheapest = failing[np.argsort(c_all[failing])[:1]]     # 0.4 of 10 is 4: one lacking
    assert np.flatnonzero(c).tolist() == cheapest.tolist() and c[cheapest] == c_all[cheapest]
    assert not ShareCriterion(left.test, 0.3, 1.0).cost(x, v, t, 0.25)[0].any()
    check_state_derivatives(Surrogate(left, 0.25, "s"), x, v, t)


def _right_exits(k, aside=None):
    """Ten particles at rest in the middle, ``k`` of them out by the right edge at the last state
    (at q1 = 0.2, inside the band) and, with ``aside``, one more out at q1 = ``aside``."""
    x = np.zeros((4, 10, 2))
    x[-1, :k] = (1.5, 0.2)
    if aside is not None:
        x[-1, k] = (1.5, aside)
    return x, np.zeros_like(x), np.arange(4) * 0.1


def test_a_share_above_its_max_is_charged_more_the_more_it_exceeds():
    problem = parse_problem(SPLITTER, "splitter.toml")
    term = dict(zip(problem.term_names, problem.terms))["surrogate_share_right_max"]     # max 0.6
    loss = [term.value_and_grad(*_right_exits(k))[0] for k in range(11)]
    assert loss[:7] == [0.0] * 7                           # 6 of 10 out: within the max
    assert 0.0 < loss[7] < loss[8] < loss[9] < loss[10]    # each particle over it costs its way back
    # a particle out beside the band (half-width 1) by less than the margin (0.25 half-widths) has
    # not failed with room to spare: the seventh counts; with margin 0 it does not
    x, v, t = _right_exits(6, aside=1.1)
    assert term.value_and_grad(x, v, t)[0] > 0.0
    assert Surrogate(term.test, 0.0, "s").value_and_grad(x, v, t)[0] == 0.0
    assert term.value_and_grad(*_right_exits(6, aside=1.3))[0] == 0.0
    x, v, t = _right_exits(8)
    x[-1, :8, 1] = np.linspace(-0.5, 0.9, 8)               # away from the band's rim and the edge
    check_state_derivatives(term, x, v, t)


def test_a_share_max_on_a_test_without_a_surrogate_of_failing_is_refused():
    cross = {"kind": "cross", "a": [0.5, -1.0], "b": [0.5, 1.0]}
    data = {**SPLITTER, "evaluate": {**SPLITTER["evaluate"], "share": [{"name": "c", "max": 0.5, "test": cross}]}}
    with pytest.raises(ProblemFileError) as err:
        parse_problem(data, "splitter.toml")
    message = str(err.value)
    assert message.startswith("splitter.toml: evaluate.share[0].max: ") and "cross" in message, message
    data["objective"] = [{"kind": "final_position", "target": [0.0, 0.0]}]
    assert parse_problem(data, "splitter.toml").shares[0][1].high == 0.5


@pytest.mark.parametrize("share, key, words", [
    ({"min": 0.6, "max": 0.4, "test": {"kind": "within", "center": [0, 0], "radius": 0.1}}, "evaluate.share[0].max",
     "max >= min"),
    ({"min": 1.5, "test": {"kind": "within", "center": [0, 0], "radius": 0.1}}, "evaluate.share[0].min", "<= 1"),
    ({"min": 0.5}, "evaluate.share[0].test", "missing"),
    ({"min": 0.5, "test": {"kind": "within", "center": [0, 0]}}, "evaluate.share[0].test.radius", "missing"),
    ({"min": 0.5, "test": 3}, "evaluate.share[0].test", "expected a table"),
])
def test_a_bad_share_is_refused_in_one_line_naming_it(share, key, words):
    data = {**SPLITTER, "evaluate": {**SPLITTER["evaluate"], "share": [share]}}
    with pytest.raises(ProblemFileError) as err:
        parse_problem(data, "splitter.toml")
    message = str(err.value)
    assert message.startswith(f"splitter.toml: {key}: ") and words in message and "\n" not in message, message


def test_a_group_test_s_panel_draws_its_group_s_paths():
    problem = _sorter()
    panels = held_out_panels(problem, problem.flat_values(), seed=3)
    assert [p.title for p in panels] == ["every success test", "success test up (within, group left)",
                                         "success test down (stay_in, group right)", "success test either (any_of)"]
    assert [p.x.shape[1] for p in panels] == [9, 3, 6, 9]
    assert all(p.passed.shape == (p.x.shape[1],) for p in panels)


def test_a_custom_test_s_own_failure_names_the_test():
    from pes_ref.synthesis.problem.objective_terms import CustomTermError
    data = {**SORTER, "evaluate": {"particles": 4, "success": [
        {"name": "mine", "kind": "custom", "object": "_helpers:RAISES_TEST"}]}}
    problem = parse_problem(data, "c.toml")
    with pytest.raises(CustomTermError, match=r"^evaluate\.success\[0\] \(custom 'mine', _helpers:RAISES_TEST\): "
                                              r"RuntimeError: boom$"):
        synthesis.evaluate(problem, problem.flat_values(), seed=1)
    with pytest.raises(CustomTermError, match=r"^evaluate\.success\[0\] \(custom 'mine', _helpers:RAISES_TEST\): "
                                              r"bang$"):
        synthesis.design_gradient(problem, problem.flat_values(), n_particles=4)
