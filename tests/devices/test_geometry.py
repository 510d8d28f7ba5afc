"""Shapes, motions, posing and the positive-area overlap test (pes_ref.devices.geometry, on shapely 2)."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pes_ref.devices import geometry as g

SQUARE = g.Rectangle((0.0, 0.0), (1.0, 1.0))
#: A non-convex L: the unit square's upper-right quarter is missing.
L_SHAPE = g.Polygon([[0, 0], [1, 0], [1, 0.5], [0.5, 0.5], [0.5, 1], [0, 1]])


def _square_at(dx, dy):
    return g.Rectangle((dx, dy), (dx + 1.0, dy + 1.0))


@pytest.mark.parametrize("offset, expected", [
    ((0.0, 0.0), True),          # identical
    ((1.0, 0.0), False),         # sharing an edge: touching is free
    ((1.0, 1.0), False),         # sharing a corner
    ((0.5, 0.0), True),          # aligned half overlap (collinear edges)
    ((0.999, 0.999), True),      # small corner overlap
    ((1.001, 0.0), False),       # a gap
    ((0.25, 0.25), True),        # crossing edges
])
def test_overlap_of_unit_squares(offset, expected):
    assert g.overlap(SQUARE, _square_at(*offset)) is expected


@pytest.mark.parametrize("other, expected", [
    (g.Rectangle((0.6, 0.6), (0.9, 0.9)), False),    # inside the L's missing quarter
    (g.Rectangle((0.5, 0.5), (1.0, 1.0)), False),    # filling the missing quarter exactly
    (g.Rectangle((0.4, 0.6), (0.9, 0.9)), True),     # poking into the upper arm
    (g.Rectangle((0.1, 0.1), (0.2, 0.2)), True),     # contained, no edge crossing
    (g.Rectangle((-1.0, -1.0), (2.0, 2.0)), True),   # containing the L
])
def test_overlap_non_convex(other, expected):
    assert g.overlap(L_SHAPE, other) is expected
    assert g.overlap(other, L_SHAPE) is expected


def test_minus_cuts_a_hole_and_a_shape_in_the_hole_is_free():
    plate = g.Rectangle((-1.0, -1.0), (1.0, 1.0), minus=[g.Circle((0.0, 0.0), 0.5)])
    assert g.overlap(plate, g.Circle((0.0, 0.0), 0.4)) is False      # a pin in the hole
    assert g.overlap(plate, g.Circle((0.3, 0.0), 0.4)) is True       # pressed into the hole's wall
    geom = plate.geometry(1e-4)
    assert geom.area == pytest.approx(4.0 - np.pi * 0.25, abs=1e-4 * np.pi)     # tolerance x perimeter
    assert len(geom.interiors) == 1


@pytest.mark.parametrize("radius, tol", [(0.5, 1e-3), (2.0, 1e-4), (0.05, 1e-5)])
def test_circle_is_within_its_tolerance(radius, tol):
    """Every point of the polygon's edge lies within ``tol`` of the true circle."""
    poly = g.Circle((0.3, -0.2), radius).geometry(tol)
    ring = np.asarray(poly.exterior.coords)
    t = np.linspace(0.0, 1.0, 11)[:, None, None]
    pts = (ring[:-1] + t * (ring[1:] - ring[:-1])).reshape(-1, 2)      # along every edge
    err = np.abs(np.hypot(pts[:, 0] - 0.3, pts[:, 1] + 0.2) - radius)
    assert err.max() <= tol * (1 + 1e-9)
    assert err.max() > 0.3 * tol                 # not needlessly finer: the count follows the tolerance


def test_part_is_the_union_of_disjoint_pieces():
    crank = g.Part([g.Circle((-0.7, 0.0), 0.05), g.Circle((0.0, 0.0), 0.5)], g.Rotation((0.0, 0.0)))
    geom = crank.geometry(1e-4)
    assert geom.geom_type == "MultiPolygon" and len(geom.geoms) == 2
    assert len(crank.circles) == 2


def test_cuts_that_leave_nothing_are_refused():
    part = g.Part(g.Circle((0, 0), 1.0, minus=[g.Rectangle((-2, -2), (2, 2))]), g.Translation((1, 0)))
    with pytest.raises(ValueError, match="leave nothing"):
        part.geometry(1e-3)


def _convex(seed, n):
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0, 2 * np.pi, n))
    r = rng.uniform(0.3, 1.0, 2)
    return np.stack((r[0] * np.cos(t), r[1] * np.sin(t)), axis=1) + rng.uniform(-0.8, 0.8, 2)


def _clip_area(subject, clip):
    """Intersection area of two convex ccw polygons (Sutherland-Hodgman), the independent reference."""
    out = list(subject)
    for a, b in zip(clip, np.roll(clip, -1, axis=0)):
        inp, out = out, []
        if not inp:
            break
        side = lambda p: (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])  # noqa: E731
        for p, q in zip(inp, inp[1:] + inp[:1]):
            sp, sq = side(p), side(q)
            if sp >= 0:
                out.append(p)
            if sp * sq < 0:
                out.append(p + (q - p) * (sp / (sp - sq)))
    if len(out) < 3:
        return 0.0
    x, y = np.array(out).T
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


@settings(max_examples=40)
@given(st.integers(0, 10_000), st.integers(3, 12), st.integers(3, 12))
def test_overlap_matches_convex_clipping(seed, na, nb):
    a, b = _convex(seed, na), _convex(seed + 1, nb)
    area = _clip_area(list(a), b)
    if abs(area) > 1e-9:
        assert g.overlap(g.Polygon(a), g.Polygon(b)) is True
    elif area == 0.0:
        assert g.overlap(g.Polygon(a), g.Polygon(b)) is False


def test_interiors_overlap_is_every_pair_at_once():
    polys = np.array([g.Polygon(_convex(s, 5 + s % 4)).geometry(1e-3) for s in range(6)], dtype=object)
    table = g.interiors_overlap(polys[:, None], polys[None, ::-1])
    for i in range(6):
        for j in range(6):
            assert table[i, j] == g.overlap(polys[i], polys[::-1][j])
    np.testing.assert_array_equal(g.interiors_overlap(polys[::-1][:, None], polys[None, :]), table.T)


@pytest.mark.parametrize("vertices, match", [
    ([[0, 0], [1, 0]], "at least 3"),
    ([[0, 0], [1, 0], [2, 0]], "positive area"),
    ([[0, 0], [3, 3], [3, 0], [0, 1]], r"simple polygon: the outline is self-crossing \(its edges cross at \(0.75, 0.75\)\)"),
    ([[0, 0], [1, 1], [1, 0], [0, 1]], r"self-crossing \(its edges cross at \(0.5, 0.5\)\)"),   # a bow tie: zero net area
    ([[0, 0], [1, np.nan], [0, 1]], "finite"),
])
def test_polygon_refuses_bad_vertices(vertices, match):
    with pytest.raises(ValueError, match=match):
        g.Polygon(vertices)


def test_pose_translation_and_rotation():
    tri = g.Polygon([[1, 0], [2, 0], [1, 1]])
    shift = g.Part(tri, g.Translation((0.0, 2.0)))
    moved = g.pose(shift, [0.5], 1e-3)[0]
    np.testing.assert_allclose(np.asarray(moved.exterior.coords)[:-1].min(axis=0), [1.0, 0.5])
    turn = g.Part(tri, g.Rotation((1.0, 0.0)))
    quarter = g.pose(turn, [np.pi / 2], 1e-3)[0]
    assert quarter.normalize().equals_exact(g.Polygon([[1, 0], [1, 1], [0, 0]]).geometry(1e-3).normalize(), 1e-12)
    full = g.pose(turn, [2 * np.pi], 1e-3)[0]
    assert full.normalize().equals_exact(turn.geometry(1e-3), 1e-12)
    assert g.pose(turn, np.zeros(7), 1e-3).shape == (7,)
    assert turn.periodic and turn.period == pytest.approx(2 * np.pi)
    assert not shift.periodic and shift.period is None


def test_bad_parts_and_motions():
    tri = g.Polygon([[1, 0], [2, 0], [1, 1]])
    with pytest.raises(TypeError, match="motion"):
        g.Part(tri, "spin")
    with pytest.raises(TypeError, match="shapes"):
        g.Part([[0, 0], [1, 0], [0, 1]], g.Translation((1, 0)))
    with pytest.raises(ValueError, match="direction"):
        g.Translation((0.0, 0.0))
    with pytest.raises(ValueError, match="upper must be > lower"):
        g.Rectangle((0, 0), (1, -1))
    with pytest.raises(ValueError, match="radius"):
        g.Circle((0, 0), 0.0)
