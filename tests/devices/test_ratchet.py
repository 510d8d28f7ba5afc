"""The ratchet and pawl on a torus: direction selectivity (pes_ref.devices.ratchet)."""
import dataclasses

import numpy as np
import pytest

from pes_ref.devices import ratchet as R
from pes_ref.devices.probes import steepest_slope

#: A coarser grid and step than the default (same geometry; dt still ~30x inside the
#: stability limit of this grid) keep the module under ~2 s.
DESIGN = dataclasses.replace(R.RatchetDesign(), shape=(128, 128), dt=2e-3)
DURATION = 3.0
TORQUES = (0.8, 1.5)


@pytest.fixture(scope="module")
def runs():
    surface = R.ratchet_surface(DESIGN)
    start = R.ratchet_start(DESIGN, surface)
    torques = np.array([s * t for t in TORQUES for s in (1.0, -1.0)])
    x = R.run_ratchet(DESIGN, torques, DURATION, surface, start).x
    return surface, start, dict(zip(torques.tolist(), (x[-1, :, 0] - x[0, :, 0]).tolist())), x


def test_surface_is_a_finite_torus(runs):
    surface = runs[0]
    assert surface.topology == "torus"
    assert np.all(np.isfinite(surface.values))


@pytest.mark.parametrize("torque", TORQUES)
def test_positive_torque_advances_tooth_by_tooth(runs, torque):
    assert runs[2][torque] >= DESIGN.pitch


@pytest.mark.parametrize("torque", TORQUES)
def test_negative_torque_is_blocked(runs, torque):
    # the wheel only settles into the steep face: far less than one tooth
    assert abs(runs[2][-torque]) < 0.25 * DESIGN.pitch


#: The pawl must lift at least halfway out of a tooth (the hook sits 0.05 above the root of a
#: 0.25 deep tooth, on a ~1 long lever: ~0.2 rad) to click over ...
MIN_LIFT = 0.1
#: ... and under a blocked torque it lifts by less than the grid resolves (2 pi / 128 ~ 0.05 rad).
MAX_BLOCKED_LIFT = 2 * np.pi / DESIGN.shape[1]


@pytest.mark.parametrize("k, torque", list(enumerate(TORQUES)))
def test_pawl_lifts_only_under_positive_torque(runs, k, torque):
    start, x = runs[1], runs[3]
    lift = start[0, 1] - x[:, :, 1].min(axis=0)     # q1 decreasing = the hook lifting out
    assert lift[2 * k] > MIN_LIFT
    assert lift[2 * k + 1] < MAX_BLOCKED_LIFT


def test_a_torque_past_the_steepest_barrier_turns_the_wheel_both_ways(runs):
    """What the analysis' warning says of a torque above barrier_torque_max (the grid's
    steepest slope along q0): nothing holds the wheel, in either direction."""
    surface, start = runs[0], runs[1]
    torque = 1.05 * steepest_slope(surface, 0)
    x = R.run_ratchet(DESIGN, [torque, -torque], DURATION, surface, start).x
    turned = x[-1, :, 0] - x[0, :, 0]
    assert turned[0] > DESIGN.pitch and turned[1] < -DESIGN.pitch


def test_wheel_and_pawl_parts():
    wheel, pawl = R.ratchet_parts(DESIGN)
    assert wheel.polygon.vertices.shape == (2 * DESIGN.n_teeth, 2)
    assert wheel.periodic and pawl.periodic
    np.testing.assert_allclose(pawl.motion.pivot, DESIGN.pivot)


@pytest.mark.parametrize("kw, match", [
    ({"hook_radius": 1.2}, "root_radius < hook_radius < tip_radius"),
    ({"steep_width": 1.0}, "steep_width"),
    ({"n_teeth": 0}, "n_teeth"),
])
def test_design_refuses_bad_values(kw, match):
    with pytest.raises(ValueError, match=match):
        R.RatchetDesign(**kw)
