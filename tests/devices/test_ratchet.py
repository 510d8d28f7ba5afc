"""The ratchet and pawl on a torus: direction selectivity (pes_ref.devices.ratchet)."""
import numpy as np
import pytest

from pes_ref.devices import ratchet as R
from pes_ref.devices.probes import steepest_slope

#: A coarser grid and step than the shipped file's (same geometry; dt still ~30x inside the
#: stability limit of this grid) keep the module under ~2 s.
DEVICE = R.ratchet_device().replace(shape=(128, 128), dt=2e-3)
PITCH = DEVICE.analysis["pitch"]
DURATION = 3.0
TORQUES = (0.8, 1.5)


@pytest.fixture(scope="module")
def runs():
    surface = DEVICE.surface()
    start = R.ratchet_start(DEVICE)
    torques = np.array([s * t for t in TORQUES for s in (1.0, -1.0)])
    x = R.run_ratchet(DEVICE, torques, DURATION, start).x
    return surface, start, dict(zip(torques.tolist(), (x[-1, :, 0] - x[0, :, 0]).tolist())), x


def test_surface_is_a_finite_torus(runs):
    surface = runs[0]
    assert surface.topology == "torus"
    assert np.all(np.isfinite(surface.values))


@pytest.mark.parametrize("torque", TORQUES)
def test_positive_torque_advances_tooth_by_tooth(runs, torque):
    assert runs[2][torque] >= PITCH


@pytest.mark.parametrize("torque", TORQUES)
def test_negative_torque_is_blocked(runs, torque):
    # the wheel only settles into the steep face: far less than one tooth
    assert abs(runs[2][-torque]) < 0.25 * PITCH


#: The pawl must lift at least halfway out of a tooth (the hook sits 0.05 above the root of a
#: 0.25 deep tooth, on a ~1 long lever: ~0.2 rad) to click over ...
MIN_LIFT = 0.1
#: ... and under a blocked torque it lifts by less than the grid resolves (2 pi / 128 ~ 0.05 rad).
MAX_BLOCKED_LIFT = 2 * np.pi / DEVICE.shape[1]


@pytest.mark.parametrize("k, torque", list(enumerate(TORQUES)))
def test_pawl_lifts_only_under_positive_torque(runs, k, torque):
    start, x = runs[1], runs[3]
    lift = start[0, 1] - x[:, :, 1].min(axis=0)     # q1 decreasing = the hook lifting out
    assert lift[2 * k] > MIN_LIFT
    assert lift[2 * k + 1] < MAX_BLOCKED_LIFT


def test_a_torque_past_the_steepest_barrier_turns_the_wheel_both_ways(runs):
    """What the analysis' warning says of a torque above barrier_torque_max (the grid's
    steepest slope along q0): nothing holds the wheel, in either direction."""
    start = runs[1]
    torque = 1.05 * steepest_slope(DEVICE.surface(), 0)
    x = R.run_ratchet(DEVICE, [torque, -torque], DURATION, start).x
    turned = x[-1, :, 0] - x[0, :, 0]
    assert turned[0] > PITCH and turned[1] < -PITCH


def test_the_shipped_file_holds_the_wheel_and_the_pawl():
    wheel, pawl = DEVICE.parts
    assert wheel.shapes[0].vertices.shape == (20, 2)           # 10 teeth: a root and a tip each
    assert wheel.periodic and pawl.periodic and DEVICE.periodic == (True, True)
    np.testing.assert_allclose(pawl.motion.pivot, [0.94, 1.14])
    assert PITCH == pytest.approx(2 * np.pi / 10)


def test_a_device_without_a_ratchet_analysis_is_refused():
    with pytest.raises(ValueError, match="no \\[analysis\\] of kind 'ratchet'"):
        R.analyze_ratchet(DEVICE.replace(analysis={}))
