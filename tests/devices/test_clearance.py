"""Where a device's surface cannot be trusted (pes_ref.devices.clearance): the narrow free channels
of the examples made for it are found from the C-space's distance field, with the numbers and
the fix; the fixed examples and every other shipped device have none."""
from pathlib import Path

import numpy as np
import pytest

import pes_ref
from pes_ref.devices.clearance import BARRIER_REACH, check_clearance
from pes_ref.devices.device_file import load_device

ROOT = Path(pes_ref.__file__).resolve().parent.parent
FILES = {p.stem: p for p in [*(ROOT / "examples" / "devices").glob("*.toml"),
                             *(ROOT / "pes_ref" / "devices" / "data").glob("*.toml")]}


@pytest.fixture(scope="module")
def findings():
    """Each device file's findings, once (the C-spaces take a few seconds in all)."""
    cache = {}

    def get(name):
        if name not in cache:
            device = load_device(FILES[name])
            cache[name] = device, check_clearance(device)
        return cache[name]
    return get


def test_a_geneva_whose_locked_play_is_below_r_c_is_told_to_lower_r_c(findings):
    """The locked wheel's play is +-0.028 rad (the channel's half-width in q1), r_c 0.05."""
    device, found = findings("geneva6_play")
    assert [f.kind for f in found] == ["barrier"]
    f = found[0]
    assert f.keys == ("energy.r_c",) and f.half_width == pytest.approx(0.028, abs=0.001)
    assert abs(f.at[1]) < 0.03 or abs(f.at[1] + np.pi / 3) < 0.03             # a locked pose: q1 = 0 or -pi/3
    assert f.limit == pytest.approx(BARRIER_REACH * 0.05) and f.suggestion < f.half_width / BARRIER_REACH
    assert "[energy] r_c = 0.05" in f.message and "set [energy] r_c below 0.04" in f.message
    r_c = 0.9 * f.half_width                                                  # the fix it suggests
    fixed = device.replace(r_c=r_c, v=device.v * (r_c / device.r_c) ** 3)
    assert not check_clearance(fixed, device.cspace())     # the same C-space (its distance reaches further)


def test_a_yoke_whose_channel_is_a_cell_across_is_told_to_raise_the_grid(findings):
    """The yoke's channel: 0.015 / sqrt(1 + (0.5 sin q0)^2) on each side, 0.0134 where it is steepest."""
    device, found = findings("yoke")
    assert [f.kind for f in found] == ["resolution"]
    f = found[0]
    assert f.keys == ("cspace.shape",) and 0.0125 < f.half_width < 0.0155
    assert f.limit > f.half_width and "raise [cspace] shape to at least" in f.message
    fine = load_device(FILES["yoke_fine"])
    assert all(n >= m for n, m in zip(fine.shape, f.suggestion))             # the fixed file applies it


@pytest.mark.parametrize("name", ["geneva6_play_fixed", "yoke_fine", "geneva4", "cam_follower", "drum_cam",
                                  "ratchet", "dartgun"])
def test_the_fixed_examples_and_the_shipped_devices_warn_nothing(name, findings):
    assert findings(name)[1] == [], [f.message for f in findings(name)[1]]


def test_every_device_file_shipped_is_checked():
    assert set(FILES) == {"geneva6_play", "geneva6_play_fixed", "yoke", "yoke_fine", "geneva4", "cam_follower",
                          "drum_cam", "ratchet", "dartgun"}

