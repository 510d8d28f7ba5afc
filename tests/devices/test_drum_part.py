"""A drum part (``motion = "drum"``): posed unrolled and tiled a turn apart, and the drum-cam
example's C-space against the analytic one (pes_ref.devices.geometry.Drum)."""
from pathlib import Path

import numpy as np
import pytest

import pes_ref
from pes_ref.devices.geometry import Circle, Drum, Part, Rectangle, Translation, default_tolerance, pose

ROOT = Path(pes_ref.__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "devices" / "drum_cam.toml"
#: The example's drum radius, lead, groove width and pin radius (its comments).
R, LEAD, WIDTH, PIN = 0.5, 1.0, 0.5, 0.1


def test_turning_the_drum_moves_its_drawing_round_the_circumference():
    drum = Part(Rectangle([0.0, 0.1], [0.2, 0.3]), Drum(2.0))
    turn = 2 * np.pi * 2.0
    for q in (0.0, 0.05, 1.0, 2 * np.pi + 1.0, -1.0):
        posed = pose(drum, [q], 1e-3)[0]
        shift = -2.0 * np.mod(q, 2 * np.pi)
        # every copy a turn apart, over y in [-turn, turn] at least
        lows = sorted(p.bounds[1] for p in posed.geoms)
        expected = [0.1 + shift + k * turn for k in range(-3, 4)]
        expected = [y for y in expected if any(abs(y - low) < 1e-9 for low in lows)]
        assert lows == pytest.approx(expected)
        assert min(lows) <= -turn + 0.3 and max(lows) >= turn - 0.3


def test_a_drum_is_periodic_and_its_circles_tolerance_scales_with_its_radius():
    pin = Part(Circle([0.0, 0.0], 0.1), Translation([1.0, 0.0]))
    drum = Part(Rectangle([-1.0, 0.0], [1.0, 1.0]), Drum(3.0))
    assert drum.periodic and drum.period == 2 * np.pi and not pin.periodic
    h = np.array([0.01, 0.02])
    assert default_tolerance((pin, drum), h) == pytest.approx(min(0.01, 0.02 * 3.0) / 20)
    assert default_tolerance((pin, Part(Rectangle([-1.0, 0.0], [1.0, 1.0]), Drum(0.1))), h) == \
        pytest.approx(0.02 * 0.1 / 20)


def _analytic(grid):
    """The helical groove's signed distance (> 0 free) in (q0, q1) at the grid's nodes."""
    q0, q1 = grid.nodes(0)[:, None], grid.nodes(1)[None, :]
    slope = LEAD / (2 * np.pi)                               # dq0/dq1 along the groove
    c = q0 - slope * q1
    off = np.abs(np.mod(c / LEAD + 0.5, 1.0) - 0.5) * LEAD   # from the nearest groove's centre, along q0
    half = WIDTH / 2 - PIN * np.hypot(1.0, LEAD / (2 * np.pi * R))
    return (half - off) / np.hypot(1.0, slope)


@pytest.fixture(scope="module")
def example():
    return pes_ref.load_device(EXAMPLE)


def test_the_drum_cam_examples_cspace_is_the_analytic_one(example):
    cs = example.cspace()
    assert example.periodic == (False, True)
    exact = _analytic(example.grid)
    h = float(example.spacing.min())
    # the nodes on the wrong side are within the circle's tolerance (h/20) of the groove's edge
    wrong = cs.blocked != (exact < 0)
    assert wrong.mean() < 0.002 and np.all(np.abs(exact[wrong]) < h / 20)
    # the distance to it within h/10, away from the ends of q0 (where the grid's edge cuts the region)
    near = np.abs(exact) < example.r_c
    near[:4] = near[-4:] = False
    assert np.abs(cs.distance - exact)[near].max() < 0.1 * h
