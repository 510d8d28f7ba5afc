"""Free play a dynamic drive on the surface cannot follow (`pes_ref.rigid.play`); the Geneva's
warning is a row of tests/cli/test_faults_table.py's WARNINGS."""
from __future__ import annotations

import numpy as np

from pes_ref import cli
from pes_ref.devices.device_file import load_device
from pes_ref.devices.drive import drive
from pes_ref.rigid.play import free_play, pocket_spans
from pes_ref.rigid.shipped import RMS_BAR

CAM = "examples/devices/cam_follower.toml"


def test_a_spring_loaded_follower_on_an_open_stroke_is_in_no_free_play_and_analyze_does_not_warn(capsys):
    """The cam's follower is free upward to the grid's edge (an open span) and its spring holds
    it on the cam: its dynamic drive agrees with rigid parts (docs/rigid.md) and nothing warns."""
    device = load_device(CAM).replace(shape=(160, 41))
    r = drive(device, 0, 0.5, "dynamic", 2, (0.0, 0.6))
    assert np.all(np.isinf(pocket_spans(device, device.cspace(), 0, r.q_in, r.q_out)))
    assert free_play(device, r) is None
    assert cli.main(["analyze", CAM, "--drive", "0", "--load", "0.5", "--mode", "dynamic",
                     "--shape", "160,41"]) == cli.EXIT_OK
    err = capsys.readouterr().err
    assert "free play" not in err and "coast" not in err, err


def test_the_geneva_s_locked_wheel_has_closed_play_above_the_bar_and_only_dynamic_drives_count():
    """At the Geneva's locked dwell the wheel's span is closed by the slot's and the locking arc's
    walls, about 0.12 rad (docs/rigid.md, Play), far above RMS_BAR of its quarter turn; a
    quasistatic drive is never reported."""
    device = load_device("examples/devices/geneva4.toml")
    spans = pocket_spans(device, device.cspace(), 0, np.array([0.0, 6.3]), np.array([0.0, -np.pi / 2]))
    assert np.all(np.isfinite(spans)) and np.all((spans > 0.1) & (spans < 0.14)), spans
    assert 0.5 * spans.min() > RMS_BAR * np.pi / 2
    from pes_ref.devices.drive import DriveResult
    q_in = np.linspace(0.0, 4 * np.pi, 400)
    r = DriveResult("g", 0, 1.0, "quasistatic", True, 4 * np.pi, 4 * np.pi, 0.0, 0.0, (0.0, 0.0), 0.0, 0.0,
                    False, "done", (0.0, 0.0), 0.05, 1, q_in, np.zeros_like(q_in), np.zeros((1, 2)))
    assert free_play(device, r) is None
    dynamic = DriveResult("g", 0, 1.0, "dynamic", True, 4 * np.pi, 4 * np.pi, 0.0, 0.0, (0.0, 0.0), 0.0, 0.0,
                          False, "done", (0.0, 0.0), 0.05, 1, q_in, np.zeros_like(q_in), np.zeros((1, 2)))
    assert free_play(device, dynamic) is not None    # the wheel held at 0 through the locked stretches
