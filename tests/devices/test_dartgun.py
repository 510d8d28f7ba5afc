"""The paper's dart gun (Figs. 2-4) on a plane: reload and fire outcomes (pes_ref.devices.dartgun)."""
import dataclasses

import numpy as np
import pytest

from pes_ref.devices import dartgun as D

#: A coarser grid and step than the default (same geometry; dt still 16x inside the
#: stability limit of this grid) keep the module under ~3 s.
DESIGN = dataclasses.replace(D.DartGunDesign(), shape=(121, 81), dt=5e-4)
#: The latched equilibrium sits against the notch's wall, off by the barrier's reach: within
#: r_c plus one grid spacing of the geometric latch position.
LATCH_TOL = DESIGN.r_c + 0.025


@pytest.fixture(scope="module")
def surface():
    return D.dartgun_surface(DESIGN)


@pytest.fixture(scope="module")
def start(surface):
    return D.dartgun_start(DESIGN, surface)


@pytest.fixture(scope="module")
def latched(surface, start):
    return D.latched_state(DESIGN, surface, start)


@pytest.fixture(scope="module")
def reloads(surface, start):
    forces = [5.0, 30.0]
    return dict(zip(forces, D.run_reload(DESIGN, forces, 1.0, 3.0, surface, start).latched.tolist()))


def test_surface_is_a_finite_plane(surface):
    assert surface.topology == "plane"
    assert np.all(np.isfinite(surface.values))


def test_start_rests_against_the_darts_underside(start):
    assert abs(start[0, 0]) < 1e-3
    assert -DESIGN.r_c < start[0, 1] < 0.0


@pytest.mark.parametrize("force, latches", [(5.0, False), (30.0, True)])
def test_reload_outcome(reloads, force, latches):
    assert reloads[force] is latches


def test_latched_state_is_an_equilibrium_in_the_notch(latched):
    q0, q1 = latched[0]
    assert DESIGN.latch_q0 <= q0 < DESIGN.latch_q0 + LATCH_TOL
    assert 0.0 < q1 < DESIGN.notch_depth


@pytest.fixture(scope="module")
def fire(surface, latched):
    return D.run_fire(DESIGN, [10.0, 30.0], 0.3, 1.5, latched, surface)


def test_weak_trigger_push_does_not_fire(fire):
    assert not fire.fired[0] and fire.exit_speed[0] == 0.0 and np.isnan(fire.exit_time[0])


def test_firm_trigger_push_fires_below_the_springs_energy_bound(fire, latched):
    # energy: m v^2 / 2 <= k q0^2 / 2 (damping only removes energy); the dart leaves with most of it
    bound = latched[0, 0] * np.sqrt(DESIGN.dart_k / DESIGN.mass[0])
    assert fire.fired[1]
    assert 0.5 * bound < fire.exit_speed[1] < bound


def test_trajectory_bbox():
    x = np.array([[[0.0, 1.0]], [[2.0, -1.0]], [[1.0, 0.5]]])
    lo, hi = D.trajectory_bbox(x)
    np.testing.assert_array_equal(lo, [0.0, -1.0])
    np.testing.assert_array_equal(hi, [2.0, 1.0])


@pytest.mark.parametrize("kw, match", [
    ({"tooth_width": 2.0}, "must fit the notch"),
    ({"notch_depth": 1.5}, "notch_depth must be < dart_height"),
    ({"tooth_x": 0.5}, "tooth must sit under the dart"),
])
def test_design_refuses_bad_values(kw, match):
    with pytest.raises(ValueError, match=match):
        D.DartGunDesign(**kw)


def test_fire_refuses_a_start_already_past_the_exit_edge(surface):
    past = [[surface.lower[0] - 0.1, 0.0]]
    with pytest.raises(ValueError, match="already past the surface's exit edge"):
        D.run_fire(DESIGN, [10.0], 0.3, 0.01, past, surface)
