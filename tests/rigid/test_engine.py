"""The rigid engine (pes_ref.rigid): parts in pymunk under the scene's forces, checked against
closed-form motions and against the parts' own geometry."""
import numpy as np
import pytest

from pes_ref.core.effects import Constant
from pes_ref.devices.device import Device
from pes_ref.devices.geometry import Circle, Drum, Part, Rectangle, Rotation, Translation
from pes_ref.rigid import StartBlockedError, simulate
from pes_ref.rigid.bodies import SLOP_SHARE, rigid_parts

pytest.importorskip("pymunk")

#: A pin (radius 0.05) sliding along x in a plate sliding along -y whose window is [-0.5, 0.5]^2.
PIN = Part(Circle([0.0, 0.0], 0.05), Translation([1.0, 0.0]))
PLATE = Part(Rectangle([-1.0, -1.0], [1.0, 1.0], minus=(Rectangle([-0.5, -0.5], [0.5, 0.5]),)), Translation([0.0, -1.0]))


def _plate_device(**kw) -> Device:
    return Device((PIN, PLATE), [-0.6, -0.6], [0.6, 0.6], (49, 49), v=1e-4, r_c=0.05,
                  mass=kw.pop("mass", (1.0, 2.0)), damping=kw.pop("damping", (0.0, 0.0)), **kw)


def test_a_free_part_under_a_constant_force_moves_as_f_t_squared_over_2m():
    device = _plate_device()
    scene = device.scene(200, (Constant([0.2, 0.0]),), dt=1e-3)
    traj = simulate(device, scene, [[0.0, 0.0]])
    t = 200 * 1e-3
    # pymunk moves a body with the velocity it had, then pushes it: x_n = F dt^2 n (n - 1) / (2 m)
    assert traj.x[-1, 0, 0] == pytest.approx(0.2 * t * (t - 1e-3) / 2.0, rel=1e-9)
    assert traj.v[-1, 0, 0] == pytest.approx(0.2 * t, rel=1e-9)
    assert abs(traj.x[-1, 0, 1]) < 1e-12


@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
def test_a_pin_pushed_into_the_window_s_edge_stops_at_it(mode):
    device = _plate_device(damping=(5.0, 5.0))
    kw = {"mode": "quasistatic", "dt": 1.0, "mobility": (0.01, 0.01)} if mode == "quasistatic" else {"dt": 2e-3}
    scene = device.scene(3000, (Constant([1.0, 0.0]),), **kw)
    traj = simulate(device, scene, [[0.0, 0.1]])
    slop = 10 * SLOP_SHARE * rigid_parts(device, device.mass).cell
    # the pin's centre stops a radius from the edge: the pin is round (a pymunk circle of the
    # radius as drawn), the contact within pymunk's slop of it
    assert 0.45 - slop <= traj.x[-1, 0, 0] <= 0.45 + slop
    assert traj.x[-1, 0, 1] == pytest.approx(0.1, abs=1e-9)


def test_a_start_inside_the_plate_is_refused_naming_x0():
    device = _plate_device()
    scene = device.scene(5, dt=1e-3)
    with pytest.raises(StartBlockedError, match=r"x0\[1\] = \(0\.52, 0\)"):
        simulate(device, scene, [[0.0, 0.0], [0.52, 0.0]])


def test_the_same_run_twice_is_bit_identical_and_noise_is_the_scene_s_draws():
    from pes_ref.core.effects import Noise
    device = _plate_device(damping=(1.0, 1.0))
    scene = device.scene(300, (Noise([0.5, 0.5], 7),), dt=2e-3)
    a = simulate(device, scene, np.zeros((3, 2)))
    b = simulate(device, scene, np.zeros((3, 2)))
    assert np.array_equal(a.x, b.x) and np.array_equal(a.v, b.v)
    assert np.array_equal(a.f[:, :, :], scene.schedule(3) - 1.0 * a.v)    # damping + the draws
    assert np.ptp(a.x[:, :, 0]) > 0


def test_a_drum_s_coordinate_stays_unwrapped_over_many_turns():
    # a drum with one small block far from the pin: the drum turns freely, several turns
    pin = Part(Circle([0.0, 0.0], 0.05), Translation([1.0, 0.0]))
    drum = Part(Rectangle([0.5, 0.0], [0.7, 0.2]), Drum(0.5))
    device = Device((pin, drum), [-0.3, 0.0], [0.3, 2 * np.pi], (25, 64), v=1e-4, r_c=0.05, mass=(1.0, 1.0),
                    damping=(0.0, 0.0))
    scene = device.scene(1000, dt=1e-2)
    traj = simulate(device, scene, [[0.0, 0.0]], [[0.0, 3.0]])
    q1 = traj.x[:, 0, 1]
    assert q1[-1] == pytest.approx(3.0 * 10.0, rel=1e-9)         # 30 rad: almost five turns
    assert np.all(np.diff(q1) > 0)


def test_a_rotating_bar_stops_against_a_fixed_block():
    # a bar turning about the origin meets a block: it stops where its corner touches
    bar = Part(Rectangle([0.0, -0.05], [1.0, 0.05]), Rotation([0.0, 0.0]))
    block = Part(Rectangle([0.2, 0.5], [1.2, 0.8]), Translation([0.0, 1.0]))
    device = Device((bar, block), [-1.0, -0.1], [1.0, 0.1], (64, 16), v=1e-4, r_c=0.05, mass=(0.1, 1e6),
                    damping=(0.5, 0.0))
    scene = device.scene(4000, (Constant([0.2, 0.0]),), dt=1e-3)
    traj = simulate(device, scene, [[0.0, 0.0]])
    # the bar's upper far corner (1, 0.05) reaches y = 0.5: sin(q + atan(0.05)) = 0.5 / |corner|
    corner = np.hypot(1.0, 0.05)
    expected = np.arcsin(0.5 / corner) - np.arctan2(0.05, 1.0)
    assert traj.x[-1, 0, 0] == pytest.approx(expected, abs=2e-3)


@pytest.mark.parametrize("load", [1.0, 10.0, 100.0])
def test_a_pin_slammed_into_the_edge_in_short_chunks_goes_on_and_rests_at_the_contact(load):
    # each chunk starts a new space from the last chunk's state: a state caught within the
    # substep of the impact overlaps the wall by up to a substep's move, and the next chunk
    # must take it; at rest the pin is at the edge (not pushed in by the load)
    from pes_ref.devices.drive import drive
    from pes_ref.rigid.engines import ENGINES
    device = _plate_device(damping=(0.0, 0.0), mass=(0.01, 1.0), dt=2e-3)
    result = drive(device, 0, load, "dynamic", start=(0.0, 0.1), engine=ENGINES["rigid"].run, chunk=7)
    assert result.stop_reason == "stalled"
    assert 0.45 <= result.stopped_at[0] <= 0.45 + SLOP_SHARE * 0.025 + 1e-9    # the round pin at the slop


@pytest.mark.parametrize("geom", [
    Circle([0.2, 0.1], 0.5).geometry(1e-4),
    Rectangle([-1.0, -1.0], [1.0, 1.0], minus=(Rectangle([-0.5, -0.5], [0.5, 0.5]),)).geometry(1e-4),
    Circle([0.0, 0.0], 0.5, minus=(Circle([-1.0, 0.0], 0.76),)).geometry(1e-4),
], ids=["disc", "plate with a window", "locking disc"])
def test_a_part_is_cut_into_few_convex_pieces_that_tile_it(geom):
    import shapely
    from pes_ref.rigid.bodies import _triangles, convex_pieces
    pieces = convex_pieces(geom)
    polys = [shapely.Polygon(p) for p in pieces]
    assert all(abs(p.convex_hull.area - p.area) <= 1e-12 for p in polys)          # each convex
    assert sum(p.area for p in polys) == pytest.approx(geom.area, rel=1e-12)       # no overlap, no gap
    assert shapely.union_all(polys).symmetric_difference(geom).area <= 1e-12
    assert len(pieces) <= len(_triangles(geom)) / 2
    if geom.equals(geom.convex_hull):
        assert len(pieces) == 1                     # a disc is one piece, not a fan of triangles
    assert all(np.array_equal(a, b) for a, b in zip(pieces, convex_pieces(geom)))


@pytest.mark.parametrize("start", [(0.3, 0.1), (0.3, 0.44)], ids=["free, then the edge", "along an edge"])
def test_quasistatic_steps_in_blocks_give_the_step_by_step_run_with_fewer_pymunk_steps(monkeypatch, start):
    # a quasistatic step that moves the pin a small share of a cell (the surface's stable
    # mobility does): steps under one force are one pymunk step while they move a part by at
    # most BLOCK_SHARE of a cell, the states between on the line between the block's ends
    import pes_ref.rigid.engine as engine
    device = _plate_device()
    scene = device.scene(3000, (Constant([1.0, 0.3]),), mode="quasistatic", dt=1.0, mobility=(1e-4, 1e-4))
    calls = []
    real = engine._block
    monkeypatch.setattr(engine, "_block", lambda *a: calls.append(real(*a)) or calls[-1])
    blocks = simulate(device, scene, [start])
    made = list(calls)
    monkeypatch.setattr(engine, "MAX_BLOCK", 1)
    single = simulate(device, scene, [start])
    assert sum(made) == 3000 and len(made) < 3000 / 8
    cell = rigid_parts(device, device.mass).cell
    assert np.max(np.abs(blocks.x - single.x)) <= engine.BLOCK_SHARE * cell
    assert blocks.x[-1, 0, 0] == pytest.approx(0.45, abs=2 * device.grid.tolerance + 1e-3 * cell)   # at the edge


# --------------------------------------------------------------------------- restitution adds no energy

def test_a_pin_pushed_steadily_onto_a_wall_settles_at_any_restitution():
    """An elastic bounce under damping decays: the pin comes to rest on the wall (pymunk's own
    bounce gave back the push's work over each overlap, and the pin never settled)."""
    for e in (1.0, 0.5):
        device = _plate_device(damping=(4.0, 4.0), restitution=e)
        scene = device.scene(2500, (Constant([10.0, 0.0]),), dt=2e-3)
        traj = simulate(device, scene, [[0.3, 0.0]])
        assert np.max(np.abs(traj.v[-250:, 0, 0])) < 1e-9, e            # at rest for the last half second
        assert traj.x[-1, 0, 0] == pytest.approx(0.45, abs=1e-3)


def test_an_elastic_pin_pushed_onto_a_wall_never_rebounds_past_its_start():
    """No damping, restitution 1, a constant push from rest 0.25 off the wall: every rebound's
    turning point is at most as far from the wall as the start (no impact adds energy)."""
    device = _plate_device(restitution=1.0)
    scene = device.scene(3000, (Constant([10.0, 0.0]),), dt=2e-3)
    traj = simulate(device, scene, [[0.2, 0.0]])
    x, v = traj.x[:, 0, 0], traj.v[:, 0, 0]
    turns = np.nonzero((v[:-1] < 0.0) & (v[1:] >= 0.0))[0] + 1
    assert turns.size >= 10                                              # it bounces, many times
    assert np.all(0.45 - x[turns] <= 0.25), 0.45 - x[turns]


@pytest.mark.parametrize("e", [1.0, 0.8])
def test_a_free_bounce_loses_energy_at_each_impact(e):
    """No push, a little damping: the kinetic energy after each impact is at most e^2 times the one before."""
    device = _plate_device(damping=(0.2, 0.0), restitution=e)
    scene = device.scene(3000, dt=2e-3)
    traj = simulate(device, scene, [[0.0, 0.0]], [[1.0, 0.0]])
    v = traj.v[:, 0, 0]
    impacts = np.nonzero(np.sign(v[1:]) != np.sign(v[:-1]))[0]
    assert impacts.size >= 3
    for k in impacts:
        before, after = v[k] ** 2, v[k + 1] ** 2
        assert after < before and after <= e * e * before * (1 + 1e-12), (k, before, after)


def test_a_circle_is_a_round_pymunk_circle_of_its_radius_as_drawn():
    """A pin (a circle without cuts) on a translation or a rotation is a pymunk circle, not its
    tolerance polygon; a shape with cuts stays polygons."""
    import pymunk
    from pes_ref.devices.geometry import Polygon
    crank = Part((Circle([0.5, 0.0], 0.05), Polygon([[-0.1, -0.05], [0.5, -0.05], [0.5, 0.05], [-0.1, 0.05]])),
                 Rotation([0.1, 0.0]))
    device = Device((crank, PLATE), [0.0, -0.6], [2 * np.pi, 0.6], (32, 49), v=1e-4, r_c=0.05)
    space, handles = rigid_parts(device, (1.0, 1.0)).space()
    crank_shapes = [s for s in space.shapes if s.body is handles[0][1]]
    circles = [s for s in crank_shapes if isinstance(s, pymunk.Circle)]
    assert len(circles) == 1 and circles[0].radius == 0.05 and tuple(circles[0].offset) == pytest.approx((0.4, 0.0))
    assert all(isinstance(s, pymunk.Poly) for s in crank_shapes if s is not circles[0]) and len(crank_shapes) > 1
    plate_shapes = [s for s in space.shapes if s.body is handles[1][1]]
    assert plate_shapes and all(isinstance(s, pymunk.Poly) for s in plate_shapes)
    pin_space, pin_handles = rigid_parts(_plate_device(), (1.0, 1.0)).space()
    (pin,) = [s for s in pin_space.shapes if s.body is pin_handles[0][1]]
    assert isinstance(pin, pymunk.Circle) and pin.radius == 0.05 and tuple(pin.offset) == (0.0, 0.0)
