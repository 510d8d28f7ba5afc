"""The paper's dart gun (Figs. 2-4) on a plane: reload and fire outcomes (pes_ref.devices.dartgun)."""
import numpy as np
import pytest

from pes_ref.devices import dartgun as D

#: A coarser grid and step than the shipped file's (same geometry; dt still 16x inside the
#: stability limit of this grid) keep the module under ~3 s.
DEVICE = D.dartgun_device().replace(shape=(121, 81), dt=5e-4)
LATCH_Q0 = DEVICE.analysis["latch_q0"]
NOTCH_DEPTH = 0.4          # the notch's depth in the shipped file (its ceiling is at y = 0.4)
DART_K = 10.0              # the dart spring's stiffness in the shipped file
#: The latched equilibrium sits against the notch's wall, off by the barrier's reach: within
#: r_c plus one grid spacing of the geometric latch position.
LATCH_TOL = DEVICE.r_c + 0.025


@pytest.fixture(scope="module")
def surface():
    return DEVICE.surface()


@pytest.fixture(scope="module")
def start(surface):
    return D.dartgun_start(DEVICE)


@pytest.fixture(scope="module")
def latched(surface, start):
    return D.latched_state(DEVICE, start)


@pytest.fixture(scope="module")
def reloads(surface, start):
    forces = [5.0, 30.0]
    return dict(zip(forces, D.run_reload(DEVICE, forces, 1.0, 3.0, start).latched.tolist()))


def test_surface_is_a_finite_plane(surface):
    assert surface.topology == "plane"
    assert np.all(np.isfinite(surface.values))


def test_start_rests_against_the_darts_underside(start):
    assert abs(start[0, 0]) < 1e-3
    assert -DEVICE.r_c < start[0, 1] < 0.0


@pytest.mark.parametrize("force, latches", [(5.0, False), (30.0, True)])
def test_reload_outcome(reloads, force, latches):
    assert reloads[force] is latches


def test_latched_state_is_an_equilibrium_in_the_notch(latched):
    q0, q1 = latched[0]
    assert LATCH_Q0 <= q0 < LATCH_Q0 + LATCH_TOL
    assert 0.0 < q1 < NOTCH_DEPTH


@pytest.fixture(scope="module")
def fire(surface, latched):
    return D.run_fire(DEVICE, [10.0, 30.0], 0.3, 1.5, latched)


def test_weak_trigger_push_does_not_fire(fire):
    assert not fire.fired[0] and fire.exit_speed[0] == 0.0 and np.isnan(fire.exit_time[0])


def test_firm_trigger_push_fires_below_the_springs_energy_bound(fire, latched):
    # energy: m v^2 / 2 <= k q0^2 / 2 (damping only removes energy); the dart leaves with most of it
    bound = latched[0, 0] * np.sqrt(DART_K / DEVICE.mass[0])
    assert fire.fired[1]
    assert 0.5 * bound < fire.exit_speed[1] < bound


def test_trajectory_bbox():
    x = np.array([[[0.0, 1.0]], [[2.0, -1.0]], [[1.0, 0.5]]])
    lo, hi = D.trajectory_bbox(x)
    np.testing.assert_array_equal(lo, [0.0, -1.0])
    np.testing.assert_array_equal(hi, [2.0, 1.0])


def test_the_shipped_file_holds_the_notched_dart_and_the_tooth():
    dart, tooth = DEVICE.parts
    geom = dart.geometry(1e-3)
    assert geom.area == pytest.approx(6.0 - 1.0 * NOTCH_DEPTH)      # the 6 x 1 bar less its notch
    assert tooth.geometry(1e-3).bounds == (3.0, -1.5, 3.6, 0.0)
    assert sum(s.k for s in DEVICE.springs if s.axis == 0) == DART_K
    assert DEVICE.walls is not None and DEVICE.periodic == (False, False)


def test_fire_refuses_a_start_already_past_the_exit_edge(surface):
    past = [[surface.lower[0] - 0.1, 0.0]]
    with pytest.raises(ValueError, match="already past the surface's exit edge"):
        D.run_fire(DEVICE, [10.0], 0.3, 0.01, past)
