"""Problem files (pes_ref.synthesis.problem.problem_file, design_problem): the funnel from its file is
the built-in funnel bit for bit, every bad key is refused in one line naming it, the design
gradient of a problem's terms matches central differences, and a design file holds its problem."""
import re
import sys
import tomllib

import numpy as np
import pytest

import _helpers
from pes_ref import synthesis
from pes_ref.oracle.compare import relative_error
from pes_ref.testing.finite_differences import central_gradient
from pes_ref.oracle.tolerances import FD_RTOL
from pes_ref.synthesis import (DesignFileError, Plan, ProblemFileError, load_design, load_problem,
                               parse_problem, problem_from_text, problem_text, save_design, shipped_problem, with_sets)

#: A small problem as a stranger writes it: particles gather at a point.
GATHER = _helpers.gather_problem(walls=True, noise=True, eval_particles=20, radius=0.2, iterations=5,
                                 train_particles=8)


def gather(**sets):
    return with_sets(problem_from_text(GATHER, "gather.toml"), sets)


# --------------------------------------------------------------------------- the funnel's file

def test_the_funnel_file_is_the_built_in_funnel_bit_for_bit():
    problem = with_sets(load_problem(shipped_problem("funnel")), {"surface.shape": [30, 30]})
    assert problem.plan == synthesis.FUNNEL_PLAN                      # the file states the built-in's plan
    plan = Plan(iterations=5, lr=0.002, lr_final=0.0005, decay_iterations=4, stages=((0, 12), (3, 0)), n_particles=16)
    builtin = synthesis.run_design(synthesis.new_design("funnel", seed=3, plan=plan, grid=30))
    ours = synthesis.run_design(synthesis.new_design(problem, seed=3, plan=plan))
    np.testing.assert_array_equal(ours.values, builtin.values)
    assert ours.history == builtin.history
    a = synthesis.evaluate(builtin.problem, builtin.values, seed=9191, n_particles=40)
    b = synthesis.evaluate(ours.problem, ours.values, seed=9191, n_particles=40)
    assert b["success_in_band"] == b["success_fraction"] == a["in_band_fraction"]
    assert b["flat_success_fraction"] == a["flat_in_band_fraction"]


#: The example problem files (examples/problems/): problems the package does not ship, as a user writes them.
EXAMPLES = sorted(str(p) for p in (_helpers.ROOT / "examples" / "problems").glob("*.toml"))


@pytest.mark.parametrize("path", [shipped_problem(n) for n in synthesis.SHIPPED_PROBLEMS] + EXAMPLES,
                         ids=lambda p: p.rsplit("/", 1)[-1])
def test_shipped_problems_and_examples_read_and_design_at_smoke_size(path):
    problem = load_problem(path)
    small = with_sets(problem, {"surface.shape": list(problem.shape(8))})
    start = synthesis.paths_start(small, 0, 2)[0] if synthesis.needs_paths_start(small) else None
    state = synthesis.run_design(synthesis.new_design(small, plan=Plan(iterations=2, n_particles=4),
                                                      start_values=start))
    assert state.status == "done" and state.values.shape == small.shape()
    figures = synthesis.evaluate(small, state.values, n_particles=4)
    assert 0.0 <= figures["success_fraction"] <= 1.0


#: A surface drawn by hand for each example of issue 41's kinds, ``energy(q0, q1)`` on the nodes:
#: each scores >= 0.95 on both held-out seeds (run, scenarios included), where the flat surface scores 0.
HAND_MADE = {
    # a slope of 0.9 against the push of 2: out between t = 2 and 3, not at 1.6
    "delay": lambda q0, q1: 0.9 * (q0 + 1.0),
    # a Gaussian trap (depth 0.35, width 0.2) that holds a push of 1, not of 3; past the gate a bowl
    # 2 (q0 - 0.5)^2 (a step of 0.5 up at q0 = 0) that catches what the overload throws; 2 q1^2 across
    "overload_release": lambda q0, q1: (-0.35 * np.exp(-((q0 + 0.5) / 0.2) ** 2)
                                        + np.where(q0 > 0.0, 2.0 * (q0 - 0.5) ** 2, 0.0) + 2.0 * q1 ** 2),
    # the trap, a speed bump of 1 at q0 = 0.2 that takes the overload's momentum, a narrow well of
    # depth 1 at the bin (width 0.08) and a ramp 12 (q0 - 0.55)^2 beyond it: with damping 1 a bowl
    # alone lets the particles swing out again
    "overload_release_light": lambda q0, q1: (-0.3 * np.exp(-((q0 + 0.5) / 0.15) ** 2)
                                              + np.exp(-((q0 - 0.2) / 0.1) ** 2)
                                              - np.exp(-((q0 - 0.5) / 0.08) ** 2)
                                              + 12.0 * np.maximum(q0 - 0.55, 0.0) ** 2 + 2.0 * q1 ** 2),
    # a valley (q1 - 0.3 cos(2 pi (q0 + 0.3)))^2 winding through the three bins, and a shallow well
    # (depth 0.2, width 0.1) along q0 at each bin, where each class comes to rest
    "speed_sorter": lambda q0, q1: ((q1 - 0.3 * np.cos(2.0 * np.pi * (q0 + 0.3))) ** 2
                                    - 0.2 * sum(np.exp(-((q0 - b) / 0.1) ** 2) for b in (-0.3, 0.2, 0.7))),
    # along the channel: a barrier of 0.3 at q0 = -0.2 (slow ones stop before it), a taller one of 0.8
    # at q0 = 0.45 (only fast ones pass), a well of depth 0.3 at each bin (Gaussians of widths 0.08
    # and 0.12), and 5 q1^2 across
    "speed_sorter_barriers": lambda q0, q1: (0.3 * np.exp(-((q0 + 0.2) / 0.08) ** 2)
                                             + 0.8 * np.exp(-((q0 - 0.45) / 0.08) ** 2)
                                             - 0.3 * sum(np.exp(-((q0 - b) / 0.12) ** 2) for b in (-0.4, 0.2, 0.75))
                                             + 5.0 * q1 ** 2),
    # a double well 10 (q1^2 - 0.25)^2: against the spring its minima are at q1 = +-0.35, and a
    # pulse tips the particles into one or the other
    "toggle": lambda q0, q1: 10.0 * (q1 ** 2 - 0.25) ** 2,
}


@pytest.mark.parametrize("name", sorted(HAND_MADE))
def test_each_kind_of_example_is_achievable_by_a_hand_made_surface(name):
    problem = load_problem(str(_helpers.ROOT / "examples" / "problems" / f"{name}.toml"))
    shape = problem.shape()
    q0, q1 = np.meshgrid(*(np.linspace(problem.lower[a], problem.upper[a], shape[a]) for a in (0, 1)),
                         indexing="ij")
    values = HAND_MADE[name](q0, q1)
    for seed in (12345, 9191):
        figures = synthesis.evaluate(problem, values, seed=seed)
        scores = [figures["success_fraction"]] + [figures[f"scenario_{s.name}_success_fraction"]
                                                  for s in problem.scenarios]
        assert min(scores) >= 0.95 and figures["flat_success_fraction"] == 0.0, (seed, figures)


# --------------------------------------------------------------------------- refusals

def _without(data, dotted):
    parts = dotted.split(".")
    node = data
    for p in parts[:-1]:
        node = node[int(p)] if isinstance(node, list) else node[p]
    del node[parts[-1]]
    return data


#: (what changes, the key the one-line refusal names, and words it holds)
BAD = [
    ({"format": 2}, "format", "format 1"),
    ({"colour": "red"}, "colour", "unknown key"),
    ({"surface.shape": [1, 8]}, "surface.shape[0]", "integer >= 2"),
    ({"surface.upper": [-1.0, 1.0]}, "surface.upper[0]", "upper > lower"),
    ({"surface.periodic": ["no", False]}, "surface.periodic[0]", "true or false"),
    ({"surface.interpolation": "cubic"}, "surface.interpolation", "'bilinear'"),
    ({"surface.hold": [{"lower": [0, 0]}]}, "surface.hold[0].upper", "missing"),
    ({"surface.hold": [{"lower": [0, 0], "upper": [-0.5, 0.5]}]}, "surface.hold[0].upper[0]",
     "expected upper >= lower, got lower 0, upper -0.5"),
    ({"starts.box": {"lower": [0, 0.5], "upper": [0.5, 0.2]}}, "starts.box.upper[1]",
     "expected upper >= lower, got lower 0.5, upper 0.2"),
    ({"starts.velocity": {"lower": [1, 0], "upper": [0, 0]}}, "starts.velocity.upper[0]",
     "expected upper >= lower, got lower 1, upper 0"),
    ({"dynamics.dt": -0.1}, "dynamics.dt", "> 0"),
    ({"dynamics.dt": 1.0}, "dynamics.dt", "stab"),
    ({"dynamics.n_steps": 40}, "dynamics.duration", "exactly one"),
    ({"dynamics.mode": "fast"}, "dynamics.mode", "'dynamic'"),
    ({"dynamics.mobility": 1.0}, "dynamics.mobility", "quasistatic"),
    ({"dynamics.walls.kk": 1.0}, "dynamics.walls.kk", "unknown key"),
    ({"dynamics.walls.margin": 1.5}, "dynamics.walls.margin", "no room"),
    ({"dynamics.spring": {"k": -1.0}}, "dynamics.spring.k", ">= 0"),
    ({"starts.points": [[0, 0]]}, "starts.box", "exactly one"),
    ({"starts.velocity": [1.0]}, "starts.velocity", "two numbers"),
    ({"forces.0.kind": "magnet"}, "forces[0].kind", "'noise'"),
    ({"forces.0.std": -1.0}, "forces[0].std", ">= 0"),
    ({"forces.0.force": [1.0, 0.0]}, "forces[0].force", "unknown key"),
    ({"forces.0.from": 1.0, "forces.0.to": 0.5}, "forces[0].to", "to >= from"),
    ({"forces.0.from": 9.0}, "forces[0].from", "after the end of the run"),
    ({"forces": [{"kind": "per_particle", "lower": [1, 0], "upper": [0.5, 0]}]}, "forces[0].upper[0]",
     "expected upper >= lower, got lower 1, upper 0.5"),
    ({"objective.0.kind": "happiness"}, "objective[0].kind", "'final_position'"),
    ({"objective.0.weight": -1.0}, "objective[0].weight", ">= 0"),
    ({"objective": [{"kind": "stay_in", "lower": [0, 0.5], "upper": [0.3, 0.2]}]}, "objective[0].upper[1]",
     "expected upper >= lower, got lower 0.5, upper 0.2"),
    ({"objective.0.target": [0.3]}, "objective[0].target", "two numbers"),
    ({"objective.0.kind": "position_at", "objective.0.time": 3.0}, "objective[0].time", "after the end"),
    ({"objective": [{"kind": "exit", "edge": "q2_lower", "center": 0.0}]}, "objective[0].edge", "'q0_lower'"),
    ({"objective": [{"kind": "custom", "object": "no_such_module_here:thing"}]}, "objective[0].object",
     "cannot import"),
    ({"objective": [{"kind": "custom", "object": "nocolon"}]}, "objective[0].object", "'module:object'"),
    ({"objective": [{"kind": "custom", "object": "_helpers:NOTHING"}]}, "objective[0].object", "not found"),
    ({"objective": [{"kind": "custom", "object": "_helpers:GatherAt"}]}, "objective[0].object",
     "'_helpers:GatherAt' is a class; expected an object with value_and_grad(x, v, t)"),
    ({"objective": [{"kind": "custom", "object": "_helpers:gather_problem"}]}, "objective[0].object",
     "'_helpers:gather_problem' (a function) has no value_and_grad(x, v, t)"),
    ({"objective": [{"kind": "custom", "object": _helpers.GatherAt}]}, "objective[0].object",
     "is a class; expected an object with value_and_grad(x, v, t)"),
    ({"objective": [{"kind": "custom", "object": 3}]}, "objective[0].object", "3 (an int) has no value_and_grad"),
    ({"surface.periodic": [True, False], "dynamics.walls.edges": [[False, False], [True, True]],
      "objective": [{"kind": "exit", "edge": "q0_lower", "center": 0.0}]}, "objective[0]", "periodic axis"),
    ({"objective": [{"kind": "final_position", "target": [0, 0], "colour": 1}]}, "objective[0].colour",
     "unknown key"),
    ({"evaluate.particles": 0}, "evaluate.particles", ">= 1"),
    ({"evaluate.success.0.radius": 0.0}, "evaluate.success[0].radius", "> 0"),
    ({"evaluate.success": [{"kind": "stay_in", "lower": [0.4, 0], "upper": [0.2, 0.1]}]},
     "evaluate.success[0].upper[0]", "expected upper >= lower, got lower 0.4, upper 0.2"),
    ({"evaluate.scenario": [{"name": "x", "success": [{"kind": "stay_in", "lower": [0, 0], "upper": [1, -1]}]}]},
     "evaluate.scenario[0].success[0].upper[1]", "expected upper >= lower, got lower 0, upper -1"),
    ({"evaluate.scenario": [{"name": "x", "success": []}]}, "evaluate.scenario[0].success", "list of tables"),
    ({"train.optimizer": "sgd"}, "train.optimizer", "'rmsprop'"),
    ({"train.stages": [[5, 4]]}, "train.stages", "start at iteration 0"),
    ({"train.lr": "fast"}, "train.lr", "finite number"),
    ({"train.starts": 0}, "train.starts", "expected an integer >= 1, got 0"),
    ({"train.starts": 2.5}, "train.starts", "expected an integer >= 1, got 2.5"),
    ({"train.screen": 0}, "train.screen", "expected an integer >= 1, got 0"),
    ({"train.starts": 4, "train.screen": 6}, "train.screen", "expected at most train.iterations (5), got 6"),
    ({"train.starts": 4}, "train.starts", "give validate_every"),
    ({"surface.contact": {"v": 1e-3}}, "surface.contact.r_c", "missing"),
    ({"surface.contact": {"v": 1e-3, "r_c": 0.3, "colour": 1}}, "surface.contact.colour", "unknown key"),
    ({"surface.contact": {"v": 0.0, "r_c": 0.3}}, "surface.contact.v", "> 0"),
    ({"surface.contact": {"v": 1e-3, "r_c": 0.3, "r_min": 0.4}}, "surface.contact.r_min", "r_min < r_c"),
    ({"surface.contact": {"v": 1e-3, "r_c": 0.01}}, "surface.contact.r_c", "r_min's default"),
    ({"surface.contact": {"v": 1e-3, "r_c": 0.3, "restitution": 1.5}}, "surface.contact.restitution",
     "expected a number in [0, 1], got 1.5"),
    ({"surface.contact": {"v": 1e-3, "r_c": 0.3, "clearance": -0.01}}, "surface.contact.clearance", ">= 0"),
    ({"surface.contact": {"v": 1e-3, "r_c": 0.3, "blocked": [{"polygon": [[0, 0], [1, 0], [0, 1]]}]}},
     "surface.contact.blocked", "realizable = true"),
    ({"surface.contact": {"v": 1e-3, "r_c": 0.3, "realizable": True, "blocked": []}}, "surface.contact.blocked",
     "non-empty list of shapes"),
    ({"surface.contact": {"v": 1e-3, "r_c": 0.3, "realizable": True,
                          "blocked": [{"circle": {"center": [0, 0], "radius": -1}}]}},
     "surface.contact.blocked[0].circle.radius", "> 0"),
]


@pytest.mark.parametrize("sets, key, words", BAD, ids=[b[1] + ":" + b[2] for b in BAD])
def test_a_bad_key_is_refused_in_one_line_naming_it(sets, key, words):
    with pytest.raises(ProblemFileError) as err:
        gather(**sets)
    message = str(err.value)
    assert message.startswith(f"gather.toml: {key}: ") and words in message and "\n" not in message, message


@pytest.mark.parametrize("missing, key", [("surface", "surface"),
                                          ("evaluate.success", "evaluate.success"), ("dynamics.dt", "dynamics.dt"),
                                          ("objective.0.target", "objective[0].target"),
                                          ("forces.0.kind", "forces[0].kind")])
def test_a_missing_key_is_refused_naming_it(missing, key):
    data = _without(tomllib.loads(GATHER), missing)
    with pytest.raises(ProblemFileError, match=rf"^p\.toml: {re.escape(key)}: missing"):
        parse_problem(data, "p.toml")


def test_bad_toml_and_unreadable_files_are_one_line(tmp_path):
    with pytest.raises(ProblemFileError, match="not valid TOML"):
        problem_from_text("surface = [", "x.toml")
    with pytest.raises(ProblemFileError, match="^problem file .*nothing.toml does not exist$"):
        load_problem(tmp_path / "nothing.toml")
    with pytest.raises(ProblemFileError, match="is a folder, not a file"):
        load_problem(tmp_path)
    (tmp_path / "latin1.toml").write_bytes(b"name = '\xff'\n")
    with pytest.raises(ProblemFileError, match="latin1.toml: cannot read the problem file"):
        load_problem(tmp_path / "latin1.toml")


# --------------------------------------------------------------------------- the design gradient

def test_design_gradient_of_every_term_kind_matches_central_differences_entrywise():
    # a cylinder (q1 periodic) with phases, a spring, a per-particle force and every smooth term
    problem = problem_from_text("""
format = 1
[surface]
lower = [-1.0, 0.0]
upper = [1.0, 2.0]
periodic = [false, true]
shape = [5, 4]
[dynamics]
dt = 0.05
duration = 1.0
damping = [0.5, 1.0]
spring = { k = [1.0, 0.0] }
walls = { k = 50.0, margin = 0.05 }
[starts]
points = [[-0.3, 0.4], [0.2, 1.1], [0.5, 1.7]]
velocity = { lower = [-0.2, 0.0], upper = [0.2, 0.3] }
[[forces]]
kind = "per_particle"
lower = [0.0, 0.5]
upper = [0.0, 1.5]
to = 0.5
[[forces]]
kind = "constant"
force = [0.4, 0.0]
from = 0.5
[[objective]]
kind = "stay_in"
lower = [-0.2, 0.5]
upper = [0.1, 1.0]
from = 0.3
to = 0.7
[[objective]]
kind = "position_at"
time = 0.5
target = [0.1, 1.9]
weight = 0.5
[[objective]]
kind = "speed_at"
time = 0.8
axis = 1
target = 0.3
[[objective]]
kind = "cycle"
amplitude = 0.5
omega = 2.0
weight = 0.1
[[objective]]
kind = "final_position"
target = [0.3, 0.2]
[[objective]]
kind = "custom"
object = "_helpers:GATHER"
weight = 0.2
[[objective]]
kind = "regularization"
R = 0.01
[evaluate]
[[evaluate.success]]
kind = "final_position"
target = [0.3, 0.2]
radius = 0.3
""", "cylinder.toml")
    rng = np.random.default_rng(4)
    values = 0.2 * rng.standard_normal(problem.shape())
    step = synthesis.design_gradient(problem, values, seed=1, iteration=0, n_particles=3)
    fd = central_gradient(lambda v: synthesis.design_gradient(problem, v, seed=1, iteration=0, n_particles=3).loss,
                          values)
    assert np.count_nonzero(fd) == values.size
    assert relative_error(step.grad, fd) < FD_RTOL


# --------------------------------------------------------------------------- realizable problems

#: A realizable gather: a level set that starts from a disc at (-0.2, 0.1) and a box (docs/problems.md).
CONTACT = {"v": 2e-3, "r_c": 0.4, "r_min": 0.1, "realizable": True,
           "blocked": [{"circle": {"center": [-0.2, 0.1], "radius": 0.35}},
                       {"rectangle": {"lower": [0.6, -1.2], "upper": [1.2, -0.5]}}]}


def test_a_realizable_problem_starts_from_its_shapes_and_its_surface_is_eq1_of_them():
    problem = gather(**{"surface.contact": CONTACT, "surface.shape": [21, 21]})
    values = problem.initial_values(np.random.default_rng(0), problem.shape())
    q = np.linspace(-1.0, 1.0, 21)
    disc = np.hypot(q[:, None] + 0.2, q[None, :] - 0.1) - 0.35
    out = [np.maximum.reduce([lo - x, x - hi]) for x, lo, hi in ((q[:, None], 0.6, 1.2), (q[None, :], -1.2, -0.5))]
    box = np.hypot(np.maximum(out[0], 0), np.maximum(out[1], 0)) + np.minimum(np.maximum(out[0], out[1]), 0)
    # the starting values are the shapes' signed distance less r_c, capped at 0 (the disc's polygon within h/20)
    expected = np.minimum(np.minimum(disc, box), 0.4) - 0.4
    assert np.max(np.abs(values - expected)) < 0.1 / 20 + 1e-12
    energy = problem.scene(values).surface.values
    from pes_ref.devices.cspace import apf_energy
    exact = apf_energy(problem.level_set.forward(values, problem.lower, problem.upper, problem.periodic).distance,
                       2e-3, 0.4, 0.1)
    np.testing.assert_array_equal(energy, exact)
    assert problem.plain().scene(values).surface.values is not None
    np.testing.assert_array_equal(problem.plain().scene(exact).surface.values, exact)


@pytest.mark.parametrize("periodic", [[False, False], [False, True], [True, True]])
def test_a_realizable_problem_s_design_gradient_matches_central_differences(periodic):
    sets = {"surface.contact": CONTACT, "surface.shape": [9, 9], "surface.periodic": periodic}
    if any(periodic):
        sets["dynamics.walls.edges"] = [[not periodic[0]] * 2, [not periodic[1]] * 2]
    problem = gather(**sets)
    values = problem.initial_values(np.random.default_rng(0), problem.shape())
    values = values + 1e-3 * np.random.default_rng(1).standard_normal(values.shape)
    step = synthesis.design_gradient(problem, values, seed=1, iteration=0, n_particles=4)

    def loss(v):
        return synthesis.design_gradient(problem, v, seed=1, iteration=0, n_particles=4).loss

    checked = 0
    for idx in np.ndindex(values.shape):
        e = np.zeros_like(values)
        e[idx] = 1e-7
        up, down, base = loss(values + e), loss(values - e), step.loss
        right, left = (up - base) / 1e-7, (base - down) / 1e-7
        if abs(right - left) > 1e-3 * max(abs(right), abs(left), 1e-3):
            continue                                                # a kink of the level set: not compared
        central = (up - down) / 2e-7
        assert step.grad[idx] == pytest.approx(central, rel=1e-4, abs=1e-6 * max(abs(central), 1e-2)), idx
        checked += abs(central) > 1e-6
    assert checked >= 5


def test_at_step_keeps_durations_and_the_noise_s_diffusion():
    from pes_ref.synthesis.problem.problem_file import at_step
    problem = gather(**{"dynamics.duration": 2.0})
    slow = at_step(problem, 0.02)
    assert slow.dt == 0.02 and slow.n_steps == 100 and problem.n_steps == 40
    noise = [f for f in slow.forces if f.kind == "noise"][0]
    np.testing.assert_allclose(noise.keys["std"], 0.1 * np.sqrt(0.05 / 0.02), rtol=1e-15)


# --------------------------------------------------------------------------- design files and resuming

def test_a_design_file_holds_its_problem_and_resumes_bit_identically(tmp_path):
    problem = gather(**{"train.iterations": 6})
    whole = synthesis.run_design(synthesis.new_design(problem, seed=2))
    half = synthesis.run_design(synthesis.new_design(problem, seed=2), 3)
    save_design(tmp_path / "half.npz", half)
    back = load_design(tmp_path / "half.npz")
    assert back.kind == "problem" and back.problem == problem and back.problem.name == "gather"
    assert back.problem.source_text is not None and "particles gather" not in back.problem.source_text
    finished = synthesis.run_design(back)
    np.testing.assert_array_equal(finished.values, whole.values)


def test_a_problem_built_in_code_with_its_own_objective_object(tmp_path):
    data = tomllib.loads(GATHER)
    data["objective"] = [{"kind": "custom", "object": _helpers.GatherAt((0.3, -0.2))}]
    problem = parse_problem(data, "<code>")
    state = synthesis.run_design(synthesis.new_design(problem, seed=0))
    reference = synthesis.run_design(synthesis.new_design(gather(), seed=0))
    np.testing.assert_array_equal(state.values, reference.values)   # the same cost as final_position
    with pytest.raises(ProblemFileError, match=r"objective\[0\]\.object: an object built in code"):
        save_design(tmp_path / "x.npz", state)
    data["objective"] = [{"kind": "custom", "object": _helpers.GATHER}]        # importable: saved by name
    state = synthesis.new_design(parse_problem(data, "<code>"), seed=0)
    save_design(tmp_path / "y.npz", state)
    assert 'object = "_helpers:GATHER"' in problem_text(load_design(tmp_path / "y.npz").problem)


class _Fails:
    """A user's own objective with a bug in it."""

    def __init__(self, exc):
        self.exc = exc

    def value_and_grad(self, x, v, t):
        raise self.exc


@pytest.mark.parametrize("exc, said", [(ValueError("boom"), "boom"),
                                       (ZeroDivisionError("division by zero"), "ZeroDivisionError: division by zero")])
def test_a_custom_term_s_own_failure_names_the_term(exc, said):
    data = tomllib.loads(GATHER)
    data["objective"].append({"kind": "custom", "object": _Fails(exc), "name": "spread"})
    problem = parse_problem(data, "<code>")
    with pytest.raises(ValueError) as err:
        synthesis.design_gradient(problem, problem.flat_values(), seed=0, iteration=0, n_particles=2)
    assert str(err.value) == f"objective[1] (custom 'spread', a _Fails): {said}"


def test_a_custom_object_is_imported_from_the_problem_file_s_folder(tmp_path):
    module = "problem_folder_objective"                 # a name nothing else imports
    (tmp_path / f"{module}.py").write_text("import numpy as np\n\n\nclass Gather:\n"
                                           "    def value_and_grad(self, x, v, t):\n"
                                           "        gx = np.zeros_like(x)\n        gx[-1] = 2 * x[-1]\n"
                                           "        return float(np.sum(x[-1] ** 2)), gx, None\n\n\n"
                                           "GATHER = Gather()\n")
    (tmp_path / "p.toml").write_text(GATHER.replace('kind = "final_position"\ntarget = [0.3, -0.2]\n[evaluate]',
                                                    f'kind = "custom"\nobject = "{module}:GATHER"\n[evaluate]'))
    path = list(sys.path)
    try:
        problem = load_problem(tmp_path / "p.toml")
        assert type(problem.terms[0].obj).__module__ == module
        assert sys.path == path                  # searched for the import only
    finally:
        sys.modules.pop(module, None)


def test_with_sets_changes_dotted_keys_and_refuses_what_is_not_there():
    p = gather(**{"dynamics.dt": 0.04, "objective.0.weight": 2.0, "train.lr": 0.01})
    assert p.dt == 0.04 and p.terms[0].weight == 2.0 and p.plan.lr == 0.01
    assert problem_text(p).startswith("# gather: written by pes_ref")
    assert problem_from_text(problem_text(p)) == p
    with pytest.raises(ProblemFileError, match="objective.5.weight: objective has entries 0 to 0"):
        gather(**{"objective.5.weight": 1.0})
    with pytest.raises(ProblemFileError, match="dynamics.dt.x: dynamics.dt is a value"):
        gather(**{"dynamics.dt.x": 1.0})


def test_without_train_stages_a_fine_grid_starts_coarse():
    assert gather().plan.stages == ((0, 0, 0),)
    fine = gather(**{"surface.shape": [100, 50], "train.iterations": 100})
    assert fine.plan.stages == ((0, 25, 0), (80, 0, 0)) and fine.shape(25) == (25, 12)


def test_starts_and_forces_draw_from_the_generator_in_order():
    p = gather(**{"forces": [{"kind": "per_particle", "lower": [1.0, 0.0], "upper": [2.0, 0.0], "to": 1.0}],
                  "starts.velocity": {"lower": [0.0, -1.0], "upper": [0.0, 1.0]}})
    a = p.batch(p.flat_values(), np.random.default_rng(5), 6)
    rng = np.random.default_rng(5)
    x0 = np.stack([rng.uniform(-0.8, 0.8, 6), rng.uniform(-0.8, 0.8, 6)], axis=1)
    v0 = np.stack([np.zeros(6), rng.uniform(-1.0, 1.0, 6)], axis=1)
    np.testing.assert_array_equal(a.x0, x0)
    np.testing.assert_array_equal(a.v0, v0)
    sched = a.scene.schedule(6)
    np.testing.assert_array_equal(sched[0, :, 0], rng.uniform(1.0, 2.0, 6))     # on before t = 1
    assert not sched[20:].any()                                                  # off from t = 1 (step 20)


def test_the_example_problems_are_there():
    assert {p.rsplit("/", 1)[-1] for p in EXAMPLES} >= {"nest.toml", "offcentre_funnel.toml", "sorter.toml"} | {
        f"{name}.toml" for name in HAND_MADE}


def test_train_starts_and_screen_set_the_plans_population():
    sets = {"train.validate_every": 1, "train.stages": [[0, 5], [3, 0]]}
    assert gather(**sets).plan.starts == 1 and gather(**sets).plan.screen == 0      # one start by default
    plan = gather(**sets, **{"train.starts": 3}).plan
    assert (plan.starts, plan.screen) == (3, 3)                 # screened to the start of the last stage
    plan = gather(**sets, **{"train.starts": 3, "train.screen": 2}).plan
    assert (plan.starts, plan.screen) == (3, 2)
    fine = {"surface.shape": [40, 40], "train.validate_every": 1, "train.starts": 2}      # default stages
    assert gather(**fine).plan.screen == 4 and synthesis.plan_for(gather(**fine), 100).screen == 80
    assert synthesis.plan_for(gather(**fine, **{"train.screen": 3}), 100).screen == 3
