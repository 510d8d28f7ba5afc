"""The drive analysis (pes_ref.devices.drive): no stall in a free channel, the worked example's
lift law against its analytic answer in both modes, jams, and refusals."""
import tomllib
from pathlib import Path

import numpy as np
import pytest

import pes_ref
from pes_ref.devices import dartgun
from pes_ref.devices.device_file import load_device, parse_device
from pes_ref.devices.drive import drive

ROOT = Path(pes_ref.__file__).resolve().parent.parent
CAM = ROOT / "examples" / "devices" / "cam_follower.toml"

# --------------------------------------------------------------------------- a free channel

#: The channel: a pin (q0, along x) in a slot of a plate (q1, along y) that rises at SLOPE; in
#: C-space the free region is the channel q1 = -SLOPE q0, CELLS grid spacings wide (perpendicular).
N0, SLOPE, CELLS, RC_CELLS = 64, 1.5, 8, 10


def channel_device():
    h = 2.0 / (N0 - 1)                                    # q0 in [-1, 1]
    q1_half = SLOPE + 0.5
    n1 = int(round(2 * q1_half / h)) + 1
    half = 0.1 + CELLS * h / 2                            # the slot's half-width: pin radius + half the channel
    d = np.array([1.0, SLOPE]) / np.hypot(1.0, SLOPE)
    nrm = np.array([-d[1], d[0]])
    slot = [(s * 5.0 * d + t * half * nrm).tolist() for s, t in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    rc = RC_CELLS * h
    text = f"""
        format = 1
        name = "channel"
        [[part]]
        motion = "translation"
        direction = [1.0, 0.0]
        shapes = [{{ circle = {{ center = [0.0, 0.0], radius = 0.1 }} }}]
        [[part]]
        motion = "translation"
        direction = [0.0, 1.0]
        shapes = [{{ rectangle = {{ lower = [-4.0, -6.0], upper = [4.0, 6.0] }}, minus = [{{ polygon = {slot} }}] }}]
        [cspace]
        lower = [-1.0, {-q1_half}]
        upper = [1.0, {q1_half}]
        shape = [{N0}, {n1}]
        [energy]
        v = {rc ** 3 / 18}
        r_c = {rc}
        [dynamics]
        mass = [1.0, 1.0]
        damping = [1.0, 1.0]
        [start]
        q = [-0.95, {SLOPE * 0.95}]
    """
    return parse_device(tomllib.loads(text), "channel.toml")


def test_a_quasistatic_drive_never_stalls_in_a_free_channel():
    """The channel is 8 cells wide and oblique to the grid; the load pushes along q0 only, so the
    pin slides along the slot's wall. A distance quantized to the node mask stalls here."""
    device = channel_device()
    h = device.spacing[0]
    width = CELLS * h * np.hypot(1, SLOPE)                # the free band's height in q1
    cs = device.cspace()
    q0, q1 = np.meshgrid(device.grid.nodes(0), device.grid.nodes(1), indexing="ij")
    centre = -SLOPE * q0
    inside = np.abs(q1 - centre) < 0.5 * width - device.spacing[1]
    assert not cs.blocked[inside].any() and cs.blocked[np.abs(q1 - centre) > 0.5 * width + device.spacing[1]].all()
    r = drive(device, 0, 1.0, "quasistatic")
    assert not r.jammed, f"stalled at {r.stopped_at} after {r.input_travel:.3g} of {r.requested_travel:.3g}"
    middle = np.abs(r.q_in) < 0.5                         # the pin rides the wall: q1 = -SLOPE q0 + const
    slope = np.polyfit(r.q_in[middle], r.q_out[middle], 1)[0]
    assert slope == pytest.approx(-SLOPE, rel=0.02)


# --------------------------------------------------------------------------- the worked example

#: The cam's eccentricity and radius (examples/devices/cam_follower.toml): lift q1 = R + E sin(q0).
E, R = 0.2, 0.5
#: The analytic figures: stroke 2 E; |dq1/dq0| = E |cos q0| is above 0.05 where |cos q0| > 0.25.
STROKE = 2 * E
MOVING = 4 * np.arccos(0.25) / (2 * np.pi)          # 0.8391
MAX_RATIO = E


@pytest.fixture(scope="module")
def cam():
    device = load_device(CAM)
    device.cspace()
    return device


@pytest.fixture(scope="module", params=["quasistatic", "dynamic"])
def cam_drive(request, cam):
    return drive(cam, 0, 0.5, request.param)


def test_the_cam_turns_a_full_cycle_and_the_follower_returns(cam_drive):
    assert not cam_drive.jammed and cam_drive.input_travel >= 2 * np.pi
    assert abs(cam_drive.advance_per_cycle) < 0.01 * STROKE


def test_the_lift_law_is_simple_harmonic(cam_drive):
    """q_out - E sin(q_in) is R plus eq. (1)'s standoff (about r_c / 3 here), constant to 3% of the
    stroke: the spring's force, 1.2 to 1.35 over the stroke, and the chatter across cell lines move
    the standoff by about +-0.005 (measured: 2.3% in quasistatic, 2.5% in dynamic mode)."""
    rest = cam_drive.q_out - E * np.sin(cam_drive.q_in)
    assert np.ptp(rest) < 0.03 * STROKE
    assert 0.5 < np.mean(rest) < 0.5 + 0.2 / 2             # R plus a standoff below r_c / 2
    assert np.ptp(cam_drive.q_out) == pytest.approx(STROKE, rel=0.02)


#: The chatter across cell lines (about 0.002 in q1), differenced across 4 spacings of q0
#: (0.039 rad), adds up to about +-0.05 to a ratio, twice that at a peak read between two chatters.
CHATTER = 0.1


def test_the_moving_fraction_and_peak_ratio_match_the_lift_law(cam_drive):
    assert cam_drive.moving_fraction == pytest.approx(MOVING, abs=0.05)
    assert MAX_RATIO <= cam_drive.max_ratio < MAX_RATIO + CHATTER


# --------------------------------------------------------------------------- jams and refusals

@pytest.fixture(scope="module")
def gun():
    return dartgun.dartgun_device().replace(shape=(61, 41))


def test_a_blocked_input_is_reported_jammed_where_it_stopped(gun):
    """The trigger pushed up into the dart's underside (q1 = 0) stops just below it."""
    r = drive(gun, 1, 5.0, "quasistatic")
    assert r.jammed and r.stop_reason == "stalled"
    assert -gun.r_c < r.stopped_at[1] < 0.0
    assert r.input_travel < r.requested_travel


@pytest.mark.parametrize("kw, match", [
    ({"axis": 2}, "axis must be 0 or 1"),
    ({"load": 0.0}, "load must be non-zero"),
    ({"load": np.inf}, "load must be finite"),
    ({"mode": "fast"}, "mode"),
    ({"cycles": 2}, "cycles counts turns of a periodic input"),
    ({"start": (5.0, 0.0)}, "start q0 = 5 is outside the grid"),
    ({"start": (2.5, 0.0)}, "at or past the grid's edge"),
    ({"threshold": 0.0}, "threshold must be > 0"),
])
def test_bad_drives_are_refused(gun, kw, match):
    args = {"axis": 0, "load": 1.0} | kw
    with pytest.raises(ValueError, match=match):
        drive(gun, **args)


def test_a_start_inside_blocked_space_and_a_fully_blocked_c_space_are_refused(gun):
    """The trigger's tooth inside the dart (q1 = 0.5 at q0 = 0) overlaps it; a dart with no room
    for the tooth at any node leaves nothing free."""
    with pytest.raises(ValueError, match=r"start q = \[0, 0.5\] is inside blocked space"):
        drive(gun, 0, 1.0, start=(0.0, 0.5))
    no_room = gun.replace(lower=(-0.5, 0.2), upper=(0.5, 0.3), shape=(11, 5), walls=None)   # the tooth in the bar
    with pytest.raises(ValueError, match="no configuration is free: the parts' interiors overlap at every node"):
        drive(no_room, 0, 1.0, start=(0.0, 0.25))


# --------------------------------------------------------------------------- the advance per cycle

@pytest.fixture(scope="module")
def cam_two_cycles():
    """The cam on a coarse grid for two turns from q1 = 0.6, above its rest: the follower settles
    onto the cam during the first turn."""
    return drive(load_device(CAM).replace(shape=(160, 41)), 0, 0.5, cycles=2, start=(0.0, 0.6))


def test_each_cycle_is_reported_and_the_headline_is_the_last_full_one(cam_two_cycles):
    r = cam_two_cycles
    first, last = r.advance_per_cycle_each
    assert r.advance_per_cycle == last and abs(last) < 0.01 * STROKE          # steady: the follower returns
    assert first < -0.02                                                       # the start's transient: it settles
    assert r.advance == pytest.approx(first + last, abs=1e-9)
    assert r.summary()["advance_per_cycle_each"] == [first, last]
    lines = "\n".join(r.as_lines())
    assert "advance_per_cycle: " in lines and "(cycle 2 of 2; cycle 1, the start's transient, left out)" in lines
    assert "over cycles 2-2 of 2: the first, the start's transient, left out" in lines.split("max_ratio: ")[1]


@pytest.mark.parametrize("travel, jammed, cycles, per_cycle", [
    (2 * np.pi, False, 1, 1.0),
    (4 * np.pi, False, 2, 1.0),
    (1.5 * np.pi, True, 0, np.nan),            # jammed short of a turn: no figure per cycle
    (3 * np.pi, True, 1, 1.0),                 # jammed in the second turn: the first one counts
])
def test_a_jammed_run_is_never_extrapolated_to_a_full_turn(travel, jammed, cycles, per_cycle):
    """An output that advances 1 per turn, steadily: each full turn reads 1, and a run that
    stopped short of a turn has only its advance over the travel it achieved."""
    from pes_ref.devices.drive import _advances
    s = np.linspace(0.0, travel, 200)
    advance, got, each = _advances(s, s / (2 * np.pi), True, 4 * np.pi if cycles == 2 else 2 * np.pi, jammed)
    assert advance == pytest.approx(travel / (2 * np.pi))
    assert len(each) == cycles and np.allclose(each, 1.0)
    assert got == pytest.approx(per_cycle, nan_ok=True)


def test_the_plot_title_fits_and_says_jammed(gun):
    """The motion law's title of a jammed run: the advance over the travel achieved (a translation's
    per unit of it) and JAMMED, both inside the figure."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from pes_ref.devices.plots import drive_figure

    r = drive(gun, 1, 5.0, "quasistatic")
    fig = drive_figure(gun, r)
    try:
        fig.canvas.draw()
        title = fig.axes[1].title
        box, frame = title.get_window_extent(), fig.bbox
        assert "JAMMED" in title.get_text()
        assert frame.x0 <= box.x0 and box.x1 <= frame.x1, (box, frame)
    finally:
        plt.close(fig)


@pytest.mark.parametrize("name, shape, axis, start", [
    ("cam_follower", (160, 41), 0, (0.0, 0.3)),          # the follower's face inside the cam (lift 0.5 at q0 = 0)
    ("drum_cam", None, 1, (0.0, np.pi)),                 # the pin inside the wall between two turns of the groove
])
def test_a_part_started_inside_the_other_is_refused(name, shape, axis, start):
    device = load_device(ROOT / "examples" / "devices" / f"{name}.toml")
    device = device if shape is None else device.replace(shape=shape)
    with pytest.raises(ValueError, match=r"start q = \[0, (0.3|3.14159)\] is inside blocked space"):
        drive(device, axis, 0.5, start=start)


def test_the_moving_share_and_the_largest_ratio_leave_the_first_turn_out(cam_two_cycles):
    """With two turns or more, ``moving_fraction`` and ``max_ratio`` are the steady turns' (the
    start's transient left out: ``steady_from``); with one, the whole travel, and the line says so."""
    from pes_ref.devices.drive import THRESHOLD, ratio as ratio_of
    r = cam_two_cycles
    s = np.abs(r.q_in - r.q_in[0])
    ratio = np.abs(ratio_of(r.q_in, r.q_out))
    steady = s >= 2 * np.pi * (1 - 1e-9)
    assert r.steady_from == 2 * np.pi and r.summary()["steady_from"] == 2 * np.pi
    assert r.max_ratio == np.max(ratio[steady]) and r.moving_fraction == np.mean(ratio[steady] > THRESHOLD)
    one = drive(load_device(CAM).replace(shape=(160, 41)), 0, 0.5, cycles=1, start=(0.0, 0.6))
    assert one.steady_from == 0.0 and one.max_ratio == np.max(np.abs(ratio_of(one.q_in, one.q_out)))
    assert "it includes the start's transient" in "\n".join(one.as_lines()).split("max_ratio: ")[1]


def test_a_quasistatic_drive_is_not_held_at_a_crease_of_the_bilinear_grid():
    """The ratchet's pawl at a tooth's tip: the surface's slope along q0 jumps past the load at a
    cell's edge (the stall sat on one at every resolution), where eq. (1) of the exact distance
    passes; the drive goes on (the rigid pawl rides every tooth, docs/rigid.md) and returns the
    pawl each turn, while a jam of the geometry still stops it (tests/rigid/test_engines.py)."""
    from pes_ref.devices.device_file import shipped_device
    device = shipped_device("ratchet").replace(shape=(128, 128))
    r = drive(device, 0, 1.0, "quasistatic", 1, start=(0.0, -0.26))     # the pawl in, as it settles
    assert r.stop_reason == "done" and r.crease_passes >= 10            # at least one pass per tooth
    assert abs(r.advance) < np.radians(1.0)                             # the pawl back where it started
    assert any(line.startswith("crease_passes: ") for line in r.as_lines())
