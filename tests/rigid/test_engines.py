"""The engines by name, one analysis on two engines side by side, two motion laws compared, and
a surface drive's stall told apart by the rigid parts (pes_ref.rigid.engines)."""
import math

import numpy as np
import pytest

from pes_ref.core.checks import InputError
from pes_ref.devices.device import Device
from pes_ref.devices.drive import DriveResult, _advances, drive
from pes_ref.devices.geometry import Circle, Part, Rectangle, Rotation, Translation
from pes_ref.rigid.bodies import rigid_parts
from pes_ref.rigid.engines import (BOTH, ENGINES, compare_laws, cycle_advances, engine_facts, engine_names,
                                   side_by_side, stall_from_runs, steady_advance, tell_stall)

pytest.importorskip("pymunk")


def _result(q_in, q_out, periodic=True, **kw) -> DriveResult:
    q_in, q_out = np.asarray(q_in, float), np.asarray(q_out, float)
    travel = float(q_in[-1] - q_in[0])
    advance, per_cycle, each = _advances(q_in - q_in[0], q_out, periodic, travel, False)
    fields = dict(device="d", drive=0, load=1.0, mode="quasistatic", periodic_input=periodic,
                  requested_travel=travel, input_travel=travel, advance=advance, advance_per_cycle=per_cycle,
                  advance_per_cycle_each=each, moving_fraction=0.0, max_ratio=0.0, jammed=False, stop_reason="done",
                  stopped_at=(0.0, 0.0), threshold=0.05, steps=1, q_in=q_in, q_out=q_out,
                  path=np.zeros((1, 2)))
    fields.update(kw)
    return DriveResult(**fields)


def test_both_names_every_engine_and_another_word_is_refused_naming_engine():
    assert engine_names(BOTH) == tuple(ENGINES) == ("surface", "rigid")
    assert engine_names("rigid") == ("rigid",)
    with pytest.raises(InputError, match=r"engine must be one of surface, rigid, both, got 'soft'") as info:
        engine_names("soft")
    assert info.value.key == "engine"


def test_the_rigid_engine_states_its_contact_and_the_surface_only_its_name():
    device = _yoke(0.1, 0.7, (16, 16)).replace(restitution=0.25, friction=0.5)
    assert engine_facts(device, "surface") == {"engine": "surface"}
    assert engine_facts(device, "rigid") == {"engine": "rigid", "restitution": 0.25, "friction": 0.5}


def test_side_by_side_prints_a_shared_line_once_and_a_figure_three_times_with_the_difference():
    lines = side_by_side({"surface": ["device: cam name", "advance: 1.5 rad per cycle", "jammed: False bool"],
                          "rigid": ["device: cam name", "advance: 1.25 rad per cycle", "jammed: True bool",
                                    "engine: rigid name"]})
    assert lines == ["device: cam name", "advance[surface]: 1.5 rad per cycle", "advance[rigid]: 1.25 rad per cycle",
                     "advance[rigid-surface]: -0.25 rad per cycle", "jammed[surface]: False bool",
                     "jammed[rigid]: True bool", "engine[rigid]: rigid name"]


@pytest.mark.parametrize("turns", [1, 3])
def test_each_turn_s_advance_is_read_off_the_law_and_the_steady_one_leaves_the_first_out(turns):
    q_in = np.linspace(0.0, 2 * math.pi * turns, 64 * turns + 1)
    lag = np.minimum(q_in, 1.0) * 0.1                       # a start transient within the first turn
    r = _result(q_in, -q_in / 4 - lag)
    adv = cycle_advances(r)
    assert adv.size == turns
    assert adv[0] == pytest.approx(-math.pi / 2 - 0.1)
    assert steady_advance(r) == pytest.approx(-math.pi / 2 - (0.1 if turns == 1 else 0.0))


@pytest.mark.parametrize("turns, first", [(1, 0), (2, 128)])
def test_two_laws_differ_by_their_mean_offset_and_a_centred_rms_after_the_first_turn(turns, first):
    q_in = np.linspace(0.0, 2 * math.pi * turns, 128 * turns + 1)
    a = _result(q_in, 0.5 + 0.2 * np.sin(q_in) + 0.067)     # the surface: held at the barrier's standoff
    wobble = 0.003 * np.sin(3 * q_in)
    b = _result(q_in, 0.5 + 0.2 * np.sin(q_in) + wobble)
    d = compare_laws(a, b)
    assert d.samples == q_in.size - first
    assert d.offset == pytest.approx(-0.067 + np.mean(wobble[first:]), abs=1e-12)
    assert d.rms_centred == pytest.approx(np.std(wobble[first:]), rel=1e-9)
    assert d.output_travel == max(np.ptp(a.q_out[first:]), np.ptp(b.q_out[first:]))
    assert d.rms == pytest.approx(math.hypot(d.offset, d.rms_centred), rel=1e-9)


# --------------------------------------------------------------------------- a Scotch yoke: stall or jam
def _yoke(clearance: float, slot_half: float, shape, r_c: float = 0.03) -> Device:
    """A crank (q0) with a pin of radius 0.05 at 0.5 from its pivot, in the vertical slot of a yoke
    sliding along x (q1): the slot is ``2 clearance`` wider than the pin and reaches ``slot_half``
    up and down (the pin's centre goes 0.5 up and down: a slot shorter than 0.55 closes on it)."""
    pin = Part(Circle([0.5, 0.0], 0.05), Rotation([0.0, 0.0]))
    w = 0.05 + clearance
    frame = Part(Rectangle([-0.2, -0.8], [0.2, 0.8], minus=(Rectangle([-w, -slot_half], [w, slot_half]),)),
                 Translation([1.0, 0.0]))
    return Device((pin, frame), [0.0, -0.7], [2 * np.pi, 0.7], shape, v=1e-4, r_c=r_c, mass=(1.0, 1.0),
                  damping=(1.0, 1.0), start=(0.0, 0.5), r_min=r_c / 3)


#: (clearance, slot's half length, grid, the verdict): a channel 0.03 wide on a grid of spacing
#: 0.045 in q1 holds the surface's input (the rigid parts pass), and a slot closed 0.25 above the
#: pin's path's centre stops both (a jam, at q0 = asin(0.25 / 0.5) = 30 degrees).
YOKES = [(0.015, 0.7, (64, 32), "resolution"), (0.1, 0.3, (64, 32), "jam")]


@pytest.mark.parametrize("clearance, slot, shape, kind", YOKES)
def test_a_surface_stall_is_told_apart_by_the_rigid_parts_from_the_stall_point(clearance, slot, shape, kind):
    device = _yoke(clearance, slot, shape)
    surface = drive(device, 0, 1.0, "quasistatic", 1)
    assert surface.stop_reason == "stalled"
    stall = tell_stall(device, surface)
    assert stall.kind == kind
    assert stall.line() == {"resolution": "stall: resolution (the rigid parts pass)",
                            "jam": "stall: jam (the rigid parts stop too)"}[kind]


@pytest.mark.parametrize("clearance, slot, shape, kind", YOKES)
def test_a_surface_stall_is_told_apart_by_a_whole_rigid_drive(clearance, slot, shape, kind):
    device = _yoke(clearance, slot, shape)
    surface = drive(device, 0, 1.0, "quasistatic", 1)
    rigid = drive(device, 0, 1.0, "quasistatic", 1, engine=ENGINES["rigid"].run)
    assert stall_from_runs(device, surface, rigid).kind == kind
    if kind == "jam":           # the pin stops at the slot's closed end
        assert rigid.stopped_at[0] == pytest.approx(math.asin(0.25 / 0.5), abs=2e-3)
    else:                       # the yoke follows the pin: q1 = 0.5 cos q0 within the clearance and the
        assert rigid.stop_reason == "done"      # contact's overlap while the pin pushes (docs/rigid.md: about
        lag = np.abs(rigid.q_out - 0.5 * np.cos(rigid.q_in))     # a tenth of the cell, 0.045 here)
        assert np.max(lag) <= 0.015 + 0.25 * rigid_parts(device, device.mass).cell


def test_a_stall_point_inside_the_rigid_parts_is_unknown_not_a_verdict():
    device = _yoke(0.1, 0.3, (64, 32))
    inside = _result([0.0, 0.1], [0.5, 0.5], stopped_at=(math.pi / 2, 0.0), stop_reason="stalled")
    stall = tell_stall(device, inside)
    assert stall.kind == "unknown" and "overlap" in stall.line()
