"""The shipped ratchet and dart gun analysed on the rigid parts (their runs through ``run=``), and
the table of docs/rigid.md (pes_ref.rigid.shipped)."""
import math

import numpy as np
import pytest

from pes_ref.rigid.engines import ENGINES

pytest.importorskip("pymunk")

RIGID = ENGINES["rigid"].run


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_the_rigid_ratchet_advances_one_way_and_its_pawl_holds_the_other(sign):
    from pes_ref.devices.ratchet import ratchet_device, ratchet_start, run_ratchet
    device = ratchet_device().replace(shape=(128, 128))
    start = ratchet_start(device, RIGID)
    rotation = run_ratchet(device, [sign * 1.0], 2.0, start, RIGID).x[-1, 0, 0] - start[0, 0]
    pitch = device.analysis["pitch"]
    if sign > 0:
        assert rotation >= pitch                              # at least a tooth
    else:
        assert abs(rotation) < 0.01 * pitch                   # the hook against the steep face: no give


def test_the_rigid_dart_latches_against_the_notch_s_wall():
    from pes_ref.devices.dartgun import dartgun_device, run_reload
    device = dartgun_device().replace(shape=(121, 81))
    res = run_reload(device, [30.0], 1.0, 3.0, run=RIGID)
    a = device.analysis
    assert res.latched[0]
    # the dart spring holds the notch's wall on the tooth: q0 = latch_q0, the tooth up in the notch (0.4)
    assert res.final[0, 0] == pytest.approx(a["latch_q0"], abs=1e-3)
    assert res.final[0, 1] == pytest.approx(0.4, abs=1e-3)


def test_the_same_drive_on_the_rigid_engine_twice_is_bit_identical():
    from pes_ref.devices.device_file import shipped_device
    from pes_ref.devices.drive import drive
    device = shipped_device("ratchet").replace(shape=(64, 64))
    a, b = (drive(device, 0, 1.0, "quasistatic", 1, engine=RIGID) for _ in range(2))
    assert np.array_equal(a.q_out, b.q_out) and np.array_equal(a.path, b.path)


@pytest.mark.parametrize("q0, q1", [(0.0, 0.0), (0.75 * math.pi, 0.0), (math.pi, -0.25 * math.pi),
                                    (1.25 * math.pi, -0.5 * math.pi), (3.0 * math.pi, -0.75 * math.pi)])
def test_the_geneva_s_analytic_wheel_turns_a_quarter_while_the_pin_is_in_a_slot(q0, q1):
    from pes_ref.rigid.shipped import _geneva_wheel
    assert float(_geneva_wheel(q0)) == pytest.approx(q1, abs=1e-12)


def test_the_table_is_written_between_its_markers_and_nowhere_else():
    from pes_ref.rigid.shipped import BEGIN, END, rewrite
    text = f"a\n{BEGIN}\nold\n{END}\nb"
    assert rewrite(text, "| new |") == f"a\n{BEGIN}\n| new |\n{END}\nb"
    with pytest.raises(ValueError, match="once"):
        rewrite("a\nb", "x")


#: The drives of docs/rigid.md's table with an analytic advance, each on a coarse grid (the rigid
#: engine's substeps are a share of the grid's cell; the geometry is the file's), and the turns of
#: a dynamic drive: the Geneva's wheel rattles in its play, so its steady advance is the mean of two
#: turns after the first; the drum's pin has room for two turns.
COARSE = {"geneva4": ((128, 128), 3), "cam_follower": ((160, 41), 2), "drum_cam": ((41, 64), 2),
          "ratchet": ((64, 64), 2)}


@pytest.mark.parametrize("mode", ["quasistatic", "dynamic"])
@pytest.mark.parametrize("name", sorted(COARSE))
def test_the_rigid_parts_advance_as_the_analytic_answer_per_cycle(name, mode):
    from pathlib import Path

    import pes_ref
    from pes_ref.devices.drive import drive
    from pes_ref.rigid.shipped import ADVANCE_BAR, DRIVES, RMS_BAR, _law_vs
    from pes_ref.rigid.engines import steady_advance
    case = next(c for c in DRIVES if c.name == name)
    device = case.device(str(Path(pes_ref.__file__).resolve().parent.parent)).replace(shape=COARSE[name][0])
    cycles = COARSE[name][1] if mode == "dynamic" else case.cycles
    r = drive(device, case.axis, case.load, mode, cycles, case.start, engine=RIGID)
    assert r.stop_reason == "done"
    assert steady_advance(r) == pytest.approx(case.advance, abs=ADVANCE_BAR)
    if case.law is not None and name == "cam_follower":        # the follower on the cam: no standoff
        rms, offset = _law_vs(r, case.law)
        assert rms <= RMS_BAR * 0.4 and abs(offset) <= RMS_BAR * 0.4
        # the steepest lift, the law's 0.2 (0.5 + 0.2 sin q0), once the follower set down at the
        # surface's standoff has dropped onto the cam (a ratio of 0.65 in the first turn, left out)
        assert r.steady_from > 0 and r.max_ratio == pytest.approx(0.2, abs=0.005)
