"""Blocked regions, the signed distance field, eq. (1) and its cap, grid springs (pes_ref.devices.cspace)."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import pes_ref as pr
from pes_ref.devices import boundary, cspace as c
from pes_ref.devices import geometry as g
from pes_ref.testing.finite_differences import directional_derivative
from pes_ref.oracle.compare import relative_error
from pes_ref.oracle.tolerances import FD_RTOL

TWO_PI = 2 * np.pi


def _torus_pair():
    """A square wheel (4-fold symmetric) about the origin and a bar about (1.2, 0)."""
    wheel = g.Part(g.regular_polygon(4, 1.0), g.Rotation((0.0, 0.0)))
    bar = g.Part(g.Rectangle((0.0, -0.1), (1.0, 0.1)), g.Rotation((1.2, 0.0)))
    return wheel, bar


@pytest.fixture(scope="module")
def torus():
    wheel, bar = _torus_pair()
    grid = c.CSpaceGrid(wheel, bar, (0.0, 0.0), (TWO_PI, TWO_PI), (48, 40))
    return grid, grid.compute()


def test_torus_grid_is_periodic_on_both_axes(torus):
    grid, cs = torus
    assert grid.periodic == (True, True)
    assert 0.05 < cs.blocked.mean() < 0.95


def test_blocked_region_and_distance_have_the_wheels_fourfold_symmetry(torus):
    grid, cs = torus                      # 48 nodes per turn: a quarter turn is 12 nodes
    np.testing.assert_array_equal(np.roll(cs.blocked, 12, axis=0), cs.blocked)
    near = np.abs(cs.distance) < boundary.BAND * grid.spacing.max()      # where the distance is exact
    np.testing.assert_allclose(np.roll(cs.distance, 12, axis=0)[near], cs.distance[near], atol=1e-9)


def test_blocked_region_repeats_after_a_full_turn(torus):
    grid, cs = torus
    turned = c.CSpaceGrid(grid.part0, grid.part1, (TWO_PI, -TWO_PI), (2 * TWO_PI, 0.0), grid.shape)
    np.testing.assert_array_equal(turned.blocked(), cs.blocked)


def test_distance_is_signed_by_the_mask_and_below_a_spacing_at_the_boundary(torus):
    grid, cs = torus
    assert np.all(cs.distance[cs.blocked] <= 0) and np.all(cs.distance[~cs.blocked] >= 0)
    nxt = cs.blocked != np.roll(cs.blocked, -1, axis=0)          # neighbours across the boundary
    gap = np.abs(cs.distance) + np.abs(np.roll(cs.distance, -1, axis=0))
    assert np.all(gap[nxt] <= grid.spacing[0] * (1 + 1e-9))


def test_blocked_region_is_symmetric_under_swapping_the_parts():
    a = g.Part(g.Polygon([[0, 0], [1, 0], [1, 0.4], [0.5, 0.4], [0.5, 1], [0, 1]]), g.Translation((1, 0)))
    b = g.Part(g.regular_polygon(5, 0.4), g.Translation((0.3, 1)))
    ab = c.CSpaceGrid(a, b, (-2, -1.5), (2, 1.5), (23, 19)).compute()
    ba = c.CSpaceGrid(b, a, (-1.5, -2), (1.5, 2), (19, 23)).compute()
    np.testing.assert_array_equal(ab.blocked, ba.blocked.T)
    np.testing.assert_allclose(ab.distance, ba.distance.T, atol=1e-12)


def _ellipse(rng, n, a, b, angle, center):
    t = np.sort(rng.uniform(0, 2 * np.pi, n))
    p = np.stack((a * np.cos(t), b * np.sin(t)), axis=1)
    cs, sn = np.cos(angle), np.sin(angle)
    return p @ np.array([[cs, sn], [-sn, cs]]) + center


def _exact_signed_distance(points, poly):
    """Signed distance to a convex counter-clockwise polygon: < 0 inside."""
    a, b = poly, np.roll(poly, -1, axis=0)
    e = b - a
    rel = points[:, None, :] - a[None]
    t = np.clip(np.sum(rel * e, axis=2) / np.sum(e * e, axis=1), 0.0, 1.0)
    d = np.min(np.linalg.norm(rel - t[..., None] * e, axis=2), axis=1)
    inside = np.all(e[None, :, 0] * rel[..., 1] - e[None, :, 1] * rel[..., 0] > 0, axis=1)
    return np.where(inside, -d, d)


@pytest.mark.parametrize("seed", [3, 11])
def test_distance_matches_the_exact_minkowski_difference_to_a_tenth_of_a_spacing(seed):
    """Two convex 50-gons in translation (validation/cspace_minkowski.py's pair): the obstacle is
    hull{b - a}, at (q0, -q1); its edges span a cell or more, so its corners are put back."""
    from scipy.spatial import ConvexHull
    rng = np.random.default_rng(seed)
    A, B = _ellipse(rng, 50, 1.0, 0.6, 0.3, (0.2, -0.1)), _ellipse(rng, 50, 0.8, 0.5, -0.6, (-0.1, 0.3))
    diff = (B[None] - A[:, None]).reshape(-1, 2)
    M = diff[ConvexHull(diff).vertices]
    R = 1.25 * float(np.max(np.abs(M)))
    grid = c.CSpaceGrid(g.Part(g.Polygon(A), g.Translation((1, 0))), g.Part(g.Polygon(B), g.Translation((0, 1))),
                        (-R, -R), (R, R), (61, 55))
    cs = grid.compute()
    q0, q1 = np.meshgrid(grid.nodes(0), grid.nodes(1), indexing="ij")
    exact = _exact_signed_distance(np.stack((q0.ravel(), -q1.ravel()), axis=1), M).reshape(q0.shape)
    np.testing.assert_array_equal(cs.blocked, exact < 0)
    h = float(np.max(grid.spacing))
    band = np.abs(exact) < 8 * h
    assert np.max(np.abs(cs.distance - exact)[band]) < 0.1 * h
    mask_err = np.abs(boundary.mask_distance(cs.blocked, grid.spacing, grid.periodic) - exact)[band]
    assert np.max(mask_err) > 0.3 * h            # the node mask alone cannot do it


def test_touching_is_free_and_sits_on_the_boundary():
    """A bar sliding along a block's top face: the row q1 = 0 touches, so it is free at distance 0."""
    block = g.Part(g.Rectangle((-1.0, -1.0), (1.0, 0.0)), g.Translation((1, 0)))
    bar = g.Part(g.Rectangle((-0.2, 0.0), (0.2, 0.5)), g.Translation((0, 1)))
    grid = c.CSpaceGrid(block, bar, (-0.5, -0.4), (0.5, 0.4), (11, 9))
    cs = grid.compute()
    row = int(np.argmin(np.abs(grid.nodes(1))))
    assert grid.nodes(1)[row] == 0.0
    assert not cs.blocked[:, row].any() and cs.blocked[:, :row].all()
    np.testing.assert_allclose(cs.distance[:, row], 0.0, atol=grid.spacing[1] / 2 ** (boundary.BISECTION_STEPS + 1))
    np.testing.assert_allclose(cs.distance[:, row + 1], grid.spacing[1], atol=grid.spacing[1] / 2 ** 9)


@pytest.mark.parametrize("periodic", [(True, True), (True, False), (False, True), (False, False)])
def test_mask_distance_across_seams(periodic):
    n, h = 20, np.array([0.1, 0.2])
    mask = np.zeros((n, n), dtype=bool)
    mask[0, 0] = True
    d = boundary.mask_distance(mask, h, periodic)
    half = 0.5 * h.min()
    assert d[0, 0] == pytest.approx(-half)          # its free neighbour is one h0 = 0.1 away
    far0 = h[0] if periodic[0] else (n - 1) * h[0]
    far1 = h[1] if periodic[1] else (n - 1) * h[1]
    assert d[n - 1, 0] == pytest.approx(far0 - half)
    assert d[0, n - 1] == pytest.approx(far1 - half)
    assert d[n - 1, n - 1] == pytest.approx(np.hypot(far0, far1) - half)


def test_boundary_distance_across_the_seam_is_mirror_symmetric():
    """A bar turning about the origin against a block sliding in y: its obstacle straddles the
    seam q0 = 0 of the angle axis, and the mirror y -> -y maps (q0, q1) to (-q0, -q1)."""
    bar = g.Part(g.Rectangle((0.0, -0.05), (1.0, 0.05)), g.Rotation((0.0, 0.0)))
    block = g.Part(g.Rectangle((0.5, -0.1), (0.7, 0.1)), g.Translation((0.0, 1.0)))
    grid = c.CSpaceGrid(bar, block, (0.0, -0.6), (TWO_PI, 0.6), (96, 41))
    cs = grid.compute()
    assert cs.blocked[0, 20] and cs.blocked[-1, 20]               # blocked on both sides of the seam
    mirror = np.roll(cs.distance[::-1, ::-1], 1, axis=0)          # node i -> node -i, j -> -j
    near = np.abs(cs.distance) < boundary.BAND * grid.spacing.max()
    np.testing.assert_allclose(mirror[near], cs.distance[near], atol=1e-9)


def test_distance_field_signs_and_degenerate_masks():
    mask = np.zeros((6, 5), dtype=bool)
    mask[2:4, 1:3] = True
    d = boundary.mask_distance(mask, (1.0, 1.0), (False, False))
    assert np.all(d[mask] < 0) and np.all(d[~mask] > 0)
    free = boundary.mask_distance(np.zeros((3, 4), bool), (1.0, 2.0), (False, True))
    blocked = boundary.mask_distance(np.ones((3, 4), bool), (1.0, 2.0), (False, True))
    np.testing.assert_allclose(free, np.hypot(3.0, 8.0))
    np.testing.assert_allclose(blocked, -np.hypot(3.0, 8.0))


# eq. (1) with v = 2, r_c = 1, r_min = 0.25: E = (1/r - 1)^2 on [0.25, 1), E(0.25) = 9,
# E'(0.25) = -2 (4 - 1) / 0.0625 = -96, continued linearly below 0.25.
@pytest.mark.parametrize("r, energy, slope, curvature", [
    (2.0, 0.0, 0.0, 0.0),
    (1.0, 0.0, 0.0, 0.0),
    (0.5, 1.0, -8.0, 2 * (3 / 0.5 ** 4 - 2 / 0.5 ** 3)),
    (0.25, 9.0, -96.0, 2 * (3 / 0.25 ** 4 - 2 / 0.25 ** 3)),
    (0.2, 9.0 + 96 * 0.05, -96.0, 0.0),
    (-1.0, 9.0 + 96 * 1.25, -96.0, 0.0),
])
def test_eq1_against_hand_computed_points(r, energy, slope, curvature):
    assert c.apf_energy(r, 2.0, 1.0, 0.25) == pytest.approx(energy, rel=1e-14)
    assert c.apf_slope(r, 2.0, 1.0, 0.25) == pytest.approx(slope, rel=1e-14)
    assert c.apf_curvature(r, 2.0, 1.0, 0.25) == pytest.approx(curvature, rel=1e-14)


# The same eq. (1) (v = 2, r_c = 1, r_min = 0.25): |E'| is 8 at 0.5 and 96 at the cap 0.25.
@pytest.mark.parametrize("force, standoff", [(8.0, 0.5), (96.0, 0.25), (500.0, 0.25), (0.0, 1.0)])
def test_the_standoff_is_where_eq1_holds_a_push(force, standoff):
    assert c.apf_standoff(force, 2.0, 1.0, 0.25) == pytest.approx(standoff, rel=1e-12)


@pytest.mark.parametrize("force", [0.01, 0.7, 3.0, 50.0])
def test_eq1s_force_at_the_standoff_is_the_push(force):
    d = c.apf_standoff(force, 2.0, 1.0, 0.25)
    assert 0.25 < d < 1.0 and -c.apf_slope(d, 2.0, 1.0, 0.25) == pytest.approx(force, rel=1e-12)


@pytest.mark.parametrize("r", [0.3, 0.6, 0.95, 0.1, -0.5])
def test_eq1_slope_and_curvature_match_finite_differences(r):
    x = np.array([r])
    u = np.ones(1)
    fd = directional_derivative(lambda q: c.apf_energy(q, 2.0, 1.0, 0.25), x, u)
    assert relative_error(c.apf_slope(x, 2.0, 1.0, 0.25), fd) < FD_RTOL
    fd2 = directional_derivative(lambda q: c.apf_slope(q, 2.0, 1.0, 0.25), x, u)
    assert np.abs(c.apf_curvature(x, 2.0, 1.0, 0.25) - fd2).max() <= FD_RTOL * max(1.0, abs(fd2).max())


@pytest.mark.parametrize("kw, match", [
    ({"r_min": 1.0}, "r_min must be < r_c"),
    ({"v": -1.0}, "v must be >= 0"),
    ({"r_c": 0.0}, "r_c must be > 0"),
    ({"r": np.inf}, "r must be finite"),
])
def test_eq1_refuses_bad_parameters(kw, match):
    args = {"r": 0.5, "v": 1.0, "r_c": 1.0, "r_min": 0.1} | kw
    with pytest.raises(ValueError, match=match):
        c.apf_energy(**args)


def _random_polygon(rng, n):
    """A star-shaped (hence simple), usually non-convex polygon."""
    t = (np.arange(n) + rng.uniform(0.0, 0.8, n)) * (2 * np.pi / n)     # gaps < pi: star-shaped about 0
    r = rng.uniform(0.2, 1.0, n)
    return g.Polygon(np.stack((r * np.cos(t), r * np.sin(t)), axis=1))


@settings(max_examples=6)
@given(st.integers(0, 2 ** 31), st.sampled_from(["plane", "cylinder", "torus"]))
def test_surface_is_finite_for_any_geometry(seed, topology):
    """The cap: every node finite and >= 0, blocked or not, at any resolution."""
    rng = np.random.default_rng(seed)
    pa, pb = _random_polygon(rng, 8), _random_polygon(rng, 6)
    part0 = g.Part(pa, g.Rotation((0.2, 0.0)) if topology == "torus" else g.Translation((1, 0)))
    part1 = g.Part(pb, g.Rotation((1.0, 0.3)) if topology != "plane" else g.Translation((0, 1)))
    lower = (0.0 if part0.periodic else -2.0, 0.0 if part1.periodic else -2.0)
    upper = (TWO_PI if part0.periodic else 2.0, TWO_PI if part1.periodic else 2.0)
    grid = c.CSpaceGrid(part0, part1, lower, upper, (17, 13))
    surf = grid.surface(v=rng.uniform(1e-6, 10.0), r_c=rng.uniform(0.3, 1.0))
    assert isinstance(surf, pr.Surface)
    assert surf.topology == topology
    assert np.all(np.isfinite(surf.values)) and np.all(surf.values >= 0)


def test_grid_springs_sides_and_minimum_image():
    lower, upper = (-1.0, 0.0), (1.0, TWO_PI)
    shape = (5, 8)
    both = c.spring_grid([c.GridSpring(0, 2.0, 0.5)], lower, upper, shape, (False, True))
    q0 = np.linspace(-1, 1, 5)
    np.testing.assert_allclose(both[:, 3], (q0 - 0.5) ** 2)
    above = c.spring_grid([c.GridSpring(0, 2.0, 0.5, side="above")], lower, upper, shape, (False, True))
    np.testing.assert_allclose(above[:, 0], np.maximum(q0 - 0.5, 0) ** 2)
    wrap = c.spring_grid([c.GridSpring(1, 2.0, 0.1)], lower, upper, shape, (False, True))
    q1 = np.arange(8) * TWO_PI / 8
    d = np.mod(q1 - 0.1 + np.pi, TWO_PI) - np.pi
    np.testing.assert_allclose(wrap[2], d ** 2)
    with pytest.raises(ValueError, match="side"):
        c.GridSpring(0, 1.0, 0.0, side="left")


def test_build_surface_adds_eq1_and_springs():
    mask = np.zeros((9, 7), dtype=bool)
    mask[4, 3] = True
    h = np.array([0.25, 2.0 / 6])
    d = boundary.mask_distance(mask, h, (False, False))
    spring = c.GridSpring(1, 3.0, 0.0)
    s = c.build_surface(d, (-1, -1), (1, 1), (False, False), v=1.0, r_c=0.5, springs=[spring])
    want = c.apf_energy(d, 1.0, 0.5, c.default_r_min(h)) + c.spring_grid([spring], (-1, -1), (1, 1), (9, 7),
                                                                          (False, False))
    np.testing.assert_allclose(s.values, want)
    np.testing.assert_allclose(s.spacing, h)


@pytest.mark.parametrize("kw, match", [
    ({"periodic": (True, False)}, "periodic\\[0\\] needs a rotating part0"),
    ({"shape": (1, 5)}, "shape must be two integers >= 2"),
    ({"upper": (-3.0, 1.0)}, "upper must be > lower"),
])
def test_cspace_grid_refuses_bad_input(kw, match):
    part = g.Part(g.regular_polygon(3, 1.0), g.Translation((1, 0)))
    args = {"part0": part, "part1": part, "lower": (-1.0, -1.0), "upper": (1.0, 1.0), "shape": (4, 5)} | kw
    with pytest.raises(ValueError, match=match):
        c.CSpaceGrid(**args)
