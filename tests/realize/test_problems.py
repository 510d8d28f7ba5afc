"""Realizing a problem file's design: the latch's tooth and cam as a pin in a plate, the
device's springs acting as the scene's linear springs, and the problem at the rule's step."""
from __future__ import annotations

import copy
import math
import tomllib

import numpy as np
import pytest

import _helpers
from pes_ref.devices.device_file import parse_device
from pes_ref.realize import exports
from pes_ref.realize.contact import realize_contact
from pes_ref.realize.evaluation import device_spring, evaluate_realized, realized_problem
from pes_ref.synthesis import load_problem, problem_from_text, shipped_problem, with_sets

#: A realizable gather with springs on both axes and a blocked disc to start from.
SETS = {"surface.shape": [25, 25], "dynamics.spring": {"k": [1.0, 20.0], "center": [-0.2, 0.1]},
        "surface.contact": {"v": 2e-3, "r_c": 0.3, "r_min": 0.1, "realizable": True,
                            "blocked": [{"circle": {"center": [0.2, -0.3], "radius": 0.3}}]}}


@pytest.fixture(scope="module")
def problem():
    return with_sets(problem_from_text(_helpers.gather_problem(walls=True, noise=True), "gather.toml"), SETS)


@pytest.fixture(scope="module")
def values(problem):
    return problem.initial_values(np.random.default_rng(0), problem.shape())


@pytest.fixture(scope="module")
def realized(problem, values):
    return realize_contact(problem, values)


def _device(data):
    return parse_device(tomllib.loads(exports.device_text(data, "test")), "test.toml")


def test_the_device_keeps_the_problem_s_springs_contact_and_start(realized):
    energy = realized.device["energy"]
    assert (energy["v"], energy["r_c"], energy["r_min"]) == (2e-3, 0.3, 0.1)
    assert energy["springs"] == [{"axis": 0, "k": 1.0, "center": -0.2}, {"axis": 1, "k": 20.0, "center": 0.1}]
    assert realized.device["start"]["q"] == [0.0, 0.0]                # the starts box's centre
    assert realized.region.rule == "level-set"


def test_the_realized_run_has_the_device_s_springs_as_linear_springs_not_a_grid(problem, realized):
    device = _device(realized.device)
    run = realized_problem(problem, device)
    eq1 = device.cspace().surface(device.v, device.r_c, (), device.r_min).values
    np.testing.assert_array_equal(run.values, eq1)                    # no spring baked into the grid ...
    spring = run.problem.scene(run.values).spring                     # ... they act as the scene's
    np.testing.assert_array_equal(np.broadcast_to(spring.k, (2,)), [1.0, 20.0])
    np.testing.assert_array_equal(np.broadcast_to(spring.center, (2,)), [-0.2, 0.1])
    assert run.problem.level_set is None                               # the values are energies


def test_a_design_scores_on_its_realized_device_as_on_its_own_surface(problem, values, realized):
    out = evaluate_realized(problem, values, _device(realized.device), seed=5, n_particles=30)
    assert out["dt"] == (problem.dt, problem.dt)
    design, device = out["success_fraction"]
    assert abs(design - device) <= 0.1                                # the exported plate is the level set's shape


def test_springs_on_one_axis_add_up_and_a_one_sided_spring_is_refused(realized):
    data = copy.deepcopy(realized.device)
    data["energy"]["springs"] = [{"axis": 0, "k": 1.0, "center": 0.0}, {"axis": 0, "k": 3.0, "center": 0.4}]
    spring = device_spring(_device(data))
    np.testing.assert_allclose(spring.k, [4.0, 0.0])
    np.testing.assert_allclose(spring.center, [0.3, 0.0])
    data["energy"]["springs"][1]["side"] = "above"
    with pytest.raises(ValueError, match="spring 1 acts on one side only"):
        device_spring(_device(data))


def test_a_stiff_realization_runs_the_problem_at_the_rule_s_step(problem, realized):
    stiff = copy.deepcopy(realized.device)
    stiff["energy"]["v"] = 5.0
    run = realized_problem(problem, _device(stiff))
    assert run.dt < problem.dt
    assert run.n_steps * run.dt >= problem.n_steps * problem.dt > (run.n_steps - 1) * run.dt
    noise = [f for f in run.problem.forces if f.kind == "noise"][0]
    np.testing.assert_allclose(noise.keys["std"], 0.1 * math.sqrt(problem.dt / run.dt), rtol=1e-12)


def test_a_problem_without_contact_is_refused_naming_the_table(realized):
    plain = problem_from_text(_helpers.gather_problem(), "plain.toml")
    with pytest.raises(ValueError, match=r"^plain\.toml states no \[surface\.contact\]"):
        realize_contact(plain, plain.flat_values())


def test_the_shipped_latch_s_starting_shapes_are_realized_by_a_pin_in_a_plate():
    problem = load_problem(shipped_problem("latch_contact"))
    values = problem.initial_values(np.random.default_rng(0), problem.shape())
    real = realize_contact(problem, values)
    assert real.parts.lost_share < 0.01 and 0.3 < real.region.blocked_share < 0.35
    assert [s["axis"] for s in real.device["energy"]["springs"]] == [0, 1]
    assert real.device["dynamics"]["walls"]["edges"][0] == [False, True]      # the dart leaves by q0 = -1


def test_the_problem_s_clearance_and_restitution_are_the_parts_and_the_options_win(problem, values, realized):
    stated = copy.deepcopy(SETS["surface.contact"])
    stated.update(clearance=0.02, restitution=0.8)
    loose = with_sets(problem, {"surface.contact": stated})
    real = realize_contact(loose, values)
    pin = real.device["part"][0]["shapes"][0]["circle"]["radius"]
    assert pin == pytest.approx(realized.parts.pin_radius + 0.02) and real.device["rigid"] == {"restitution": 0.8}
    own = realize_contact(loose, values, clearance=0.0, restitution=0.0)         # the options win
    assert own.device["part"][0]["shapes"][0]["circle"]["radius"] == realized.parts.pin_radius
    assert own.device["rigid"] == {"restitution": 0.0}
    assert "rigid" not in realized.device                                          # none stated: inelastic


def test_a_restitution_above_one_in_the_problem_file_is_refused_naming_the_key(problem):
    stated = {**SETS["surface.contact"], "restitution": 1.5}
    with pytest.raises(ValueError, match=r"surface\.contact\.restitution.*\[0, 1\]"):
        with_sets(problem, {"surface.contact": stated})


def test_the_shipped_latch_states_the_clearance_and_restitution_its_rigid_parts_need():
    contact = load_problem(shipped_problem("latch_contact")).contact
    assert (contact.clearance, contact.restitution) == (0.035, 1.0)


def test_a_start_inside_the_parts_moves_to_the_nearest_free_node_and_says_so(problem):
    """The starts box's centre (0, 0) inside a drawn disc: the device's [start] is a free grid node
    near it (an analysis of the device starts there), and a lost line says so."""
    from pes_ref.devices.drive import check_free
    inside = with_sets(problem, {"surface.contact.blocked": [{"circle": {"center": [0.0, 0.0], "radius": 0.2}}]})
    real = realize_contact(inside, inside.initial_values(np.random.default_rng(0), inside.shape()))
    start = real.device["start"]["q"]
    device = _device(real.device)
    check_free(device, np.array(start))                                   # refused if blocked
    assert 0.2 + real.parts.pin_radius <= math.hypot(*start) <= 0.2 + real.parts.pin_radius + 0.2
    assert any("the problem's start (0, 0) lies inside the parts" in line for line in real.lost)
