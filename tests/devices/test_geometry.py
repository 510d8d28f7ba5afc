"""Polygons, motions, posing and the positive-area overlap test (pes_ref.devices.geometry)."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pes_ref.devices import geometry as g

SQUARE = g.rectangle(0.0, 0.0, 1.0, 1.0).vertices
#: A non-convex L: the unit square's upper-right quarter is missing.
L_SHAPE = np.array([[0, 0], [1, 0], [1, 0.5], [0.5, 0.5], [0.5, 1], [0, 1]], dtype=float)
#: Intersection areas below this count as "touching" in the convex reference (the module's
#: probe inset is 1e-9 relative; random polygons never overlap that thinly by chance).
AREA_TOL = 1e-9


@pytest.mark.parametrize("offset, expected", [
    ((0.0, 0.0), True),          # identical: collinear edges everywhere, no proper crossing
    ((1.0, 0.0), False),         # sharing an edge: touching is free
    ((1.0, 1.0), False),         # sharing a corner
    ((0.5, 0.0), True),          # aligned half overlap (collinear edges, vertex on edge)
    ((0.999, 0.999), True),      # small corner overlap
    ((1.001, 0.0), False),       # a gap
    ((0.25, 0.25), True),        # crossing edges
])
def test_overlap_of_unit_squares(offset, expected):
    assert g.overlap(SQUARE, SQUARE + np.array(offset)) is expected


@pytest.mark.parametrize("other, expected", [
    (g.rectangle(0.6, 0.6, 0.9, 0.9).vertices, False),    # inside the L's missing quarter
    (g.rectangle(0.5, 0.5, 1.0, 1.0).vertices, False),    # filling the missing quarter exactly
    (g.rectangle(0.4, 0.6, 0.9, 0.9).vertices, True),     # poking into the upper arm
    (g.rectangle(0.1, 0.1, 0.2, 0.2).vertices, True),     # contained, no edge crossing
    (g.rectangle(-1.0, -1.0, 2.0, 2.0).vertices, True),   # containing the L
])
def test_overlap_non_convex(other, expected):
    assert g.overlap(L_SHAPE, other) is expected
    assert g.overlap(other, L_SHAPE) is expected


def _clip_area(subject, clip):
    """Intersection area of two convex ccw polygons (Sutherland-Hodgman), the reference."""
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
    return float(g.signed_area(np.array(out)))


def _convex(seed, n):
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0, 2 * np.pi, n))
    r = rng.uniform(0.3, 1.0, 2)
    return g.Polygon(np.stack((r[0] * np.cos(t), r[1] * np.sin(t)), axis=1) + rng.uniform(-0.8, 0.8, 2))


@settings(max_examples=40)
@given(st.integers(0, 10_000), st.integers(3, 12), st.integers(3, 12))
def test_overlap_matches_convex_clipping(seed, na, nb):
    a, b = _convex(seed, na), _convex(seed + 1, nb)
    area = _clip_area(list(a.vertices), b.vertices)
    if abs(area) > AREA_TOL:
        assert g.overlap(a, b) is True
    elif area == 0.0:
        assert g.overlap(a, b) is False


def test_overlap_table_is_every_pair_and_symmetric():
    polys = [_convex(s, 5 + s % 4) for s in range(6)]
    a = np.stack([p.vertices[:5] for p in polys])
    table = g.overlap_table(a, a[::-1])
    for i in range(6):
        for j in range(6):
            assert table[i, j] == g.overlap(a[i], a[::-1][j])
    np.testing.assert_array_equal(g.overlap_table(a[::-1], a), table.T)


def test_overlap_table_chunks_agree():
    a = np.stack([_convex(s, 7).vertices for s in range(10)])
    b = np.stack([_convex(s + 50, 6).vertices for s in range(9)])
    np.testing.assert_array_equal(g.overlap_table(a, b, chunk_elements=1), g.overlap_table(a, b))


def test_polygon_is_stored_counter_clockwise():
    cw = g.Polygon(SQUARE[::-1])
    assert cw.area == pytest.approx(1.0)
    assert g.signed_area(cw.vertices) > 0
    assert cw.edges().shape == (4, 2, 2)


@pytest.mark.parametrize("vertices, match", [
    ([[0, 0], [1, 0]], "at least 3"),
    ([[0, 0], [1, 0], [2, 0]], "positive area"),
    ([[0, 0], [2, 2], [2, 0], [0, 1]], "simple polygon"),
    ([[0, 0], [0, 0], [1, 0], [0, 1]], "zero-length"),
    ([[0, 0], [1, np.nan], [0, 1]], "finite"),
])
def test_polygon_refuses_bad_vertices(vertices, match):
    with pytest.raises(ValueError, match=match):
        g.Polygon(vertices)


def test_pose_translation_and_rotation():
    tri = g.Polygon([[1, 0], [2, 0], [1, 1]])
    shift = g.Part(tri, g.Translation((0.0, 2.0)))
    np.testing.assert_allclose(g.pose(shift, 0.5), tri.vertices + [0.0, 0.5])
    turn = g.Part(tri, g.Rotation((1.0, 0.0)))
    np.testing.assert_allclose(g.pose(turn, np.pi / 2), [[1, 0], [1, 1], [0, 0]], atol=1e-15)
    np.testing.assert_allclose(g.pose(turn, 2 * np.pi), tri.vertices, atol=1e-14)
    assert g.pose(turn, np.zeros((4, 3))).shape == (4, 3, 3, 2)
    assert turn.periodic and turn.period == pytest.approx(2 * np.pi)
    assert not shift.periodic and shift.period is None


def test_posed_vertices_and_bad_parts():
    tri = g.Polygon([[1, 0], [2, 0], [1, 1]])
    a, b = g.posed_vertices(g.Part(tri, g.Translation((1, 0))), g.Part(tri, g.Rotation((0, 0))), 1.0, np.pi)
    np.testing.assert_allclose(a, tri.vertices + [1, 0])
    np.testing.assert_allclose(b, -tri.vertices, atol=1e-15)
    with pytest.raises(TypeError, match="motion"):
        g.Part(tri, "spin")
    with pytest.raises(ValueError, match="direction"):
        g.Translation((0.0, 0.0))
