"""Blocked regions, the signed distance field, eq. (1) and its cap, grid springs (pes_ref.devices.cspace)."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import pes_ref as pr
from pes_ref.devices import cspace as c
from pes_ref.devices import geometry as g
from pes_ref.testing.finite_differences import directional_derivative
from pes_ref.oracle.compare import relative_error
from pes_ref.oracle.tolerances import FD_RTOL

TWO_PI = 2 * np.pi


def _torus_pair():
    """A square wheel (4-fold symmetric) about the origin and a bar about (1.2, 0)."""
    wheel = g.Part(g.regular_polygon(4, 1.0), g.Rotation((0.0, 0.0)))
    bar = g.Part(g.rectangle(0.0, -0.1, 1.0, 0.1), g.Rotation((1.2, 0.0)))
    return wheel, bar


@pytest.fixture(scope="module")
def torus():
    wheel, bar = _torus_pair()
    grid = c.CSpaceGrid(wheel, bar, (0.0, 0.0), (TWO_PI, TWO_PI), (48, 40))
    return grid, grid.blocked()


def test_torus_grid_is_periodic_on_both_axes(torus):
    grid, mask = torus
    assert grid.periodic == (True, True)
    assert 0.05 < mask.mean() < 0.95


def test_blocked_region_has_the_wheels_fourfold_symmetry(torus):
    grid, mask = torus                      # 48 nodes per turn: a quarter turn is 12 nodes
    np.testing.assert_array_equal(np.roll(mask, 12, axis=0), mask)


def test_blocked_region_repeats_after_a_full_turn(torus):
    grid, mask = torus
    shifted = c.blocked_mask(grid.part0, grid.part1, grid.nodes(0) + TWO_PI, grid.nodes(1) - TWO_PI)
    np.testing.assert_array_equal(shifted, mask)


def test_blocked_region_is_symmetric_under_swapping_the_parts():
    a = g.Part(g.Polygon([[0, 0], [1, 0], [1, 0.4], [0.5, 0.4], [0.5, 1], [0, 1]]), g.Translation((1, 0)))
    b = g.Part(g.regular_polygon(5, 0.4), g.Translation((0.3, 1)))
    q0, q1 = np.linspace(-2, 2, 23), np.linspace(-1.5, 1.5, 19)
    np.testing.assert_array_equal(c.blocked_mask(a, b, q0, q1), c.blocked_mask(b, a, q1, q0).T)


@pytest.mark.parametrize("periodic", [(True, True), (True, False), (False, True), (False, False)])
def test_distance_field_across_seams(periodic):
    n, h = 20, np.array([0.1, 0.2])
    mask = np.zeros((n, n), dtype=bool)
    mask[0, 0] = True
    d = c.signed_distance(mask, h, periodic)
    half = 0.5 * h.min()
    assert d[0, 0] == pytest.approx(-half)          # its free neighbour is one h0 = 0.1 away
    far0 = h[0] if periodic[0] else (n - 1) * h[0]
    far1 = h[1] if periodic[1] else (n - 1) * h[1]
    assert d[n - 1, 0] == pytest.approx(far0 - half)
    assert d[0, n - 1] == pytest.approx(far1 - half)
    assert d[n - 1, n - 1] == pytest.approx(np.hypot(far0, far1) - half)


def test_distance_field_signs_and_degenerate_masks():
    mask = np.zeros((6, 5), dtype=bool)
    mask[2:4, 1:3] = True
    d = c.signed_distance(mask, (1.0, 1.0), (False, False))
    assert np.all(d[mask] < 0) and np.all(d[~mask] > 0)
    free = c.signed_distance(np.zeros((3, 4), bool), (1.0, 2.0), (False, True))
    blocked = c.signed_distance(np.ones((3, 4), bool), (1.0, 2.0), (False, True))
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
    d = c.signed_distance(mask, h, (False, False))
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
