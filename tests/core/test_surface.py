"""Unit tests of pes_ref.core.surface, the grid lookup of pes_ref.core.grid and the bilinear
rule's textbook functions of pes_ref.core.bilinear, against SPEC section 1."""
import math

import numpy as np
import pytest

from pes_ref import Surface
from pes_ref.core.bilinear import grid_energy, grid_slope, grid_slope_vjp_q, grid_slope_vjp_values
from pes_ref.core.grid import locate, spacing, wrap
from pes_ref.testing.finite_differences import central_gradient, check_vjp
from pes_ref.oracle.compare import relative_error
from _helpers import TOPOLOGIES, assert_dot
from pes_ref.oracle.tolerances import FD_RTOL, TRAJ_ATOL, TRAJ_RTOL

TOPO_IDS = sorted(TOPOLOGIES)

#: Many periods away, q + P L rounds to a neighbour of the exact value: the fraction
#: carries an error of about P L eps / h. This bounds it for P = 1000 on our grids.
FAR_PERIODS = 1000
FAR_RTOL = 1e4 * FAR_PERIODS * np.finfo(float).eps

#: Keep points at least this fraction of a cell away from cell edges for derivative checks.
EDGE_MARGIN = 0.1


def _surface(topology, shape=(6, 5), seed=0, lower=(-0.5, 1.0), upper=(1.0, 2.0)):
    rng = np.random.default_rng(seed)
    return Surface(rng.uniform(-1.0, 1.0, shape), lower, upper, TOPOLOGIES[topology])


def _reference(G, lower, upper, periodic, q):
    """SPEC section 1 written out, one scalar point at a time (independent of the package)."""
    n = G.shape
    cell = []
    for d in range(2):
        L = upper[d] - lower[d]
        h = L / n[d] if periodic[d] else L / (n[d] - 1)
        u = (q[d] - lower[d]) / h
        if periodic[d]:
            k = math.floor(u)
            f = u - k
            i0, i1, s = k % n[d], (k + 1) % n[d], 1.0
        else:
            uc = min(max(u, 0.0), n[d] - 1.0)
            i0 = min(math.floor(uc), n[d] - 2)
            f, i1 = uc - i0, i0 + 1
            s = 1.0 if 0.0 <= u <= n[d] - 1 else 0.0
        cell.append((i0, i1, f, s, h))
    (i0, i1, f0, s0, h0), (j0, j1, f1, s1, h1) = cell
    E = ((1 - f0) * (1 - f1) * G[i0, j0] + f0 * (1 - f1) * G[i1, j0]
         + (1 - f0) * f1 * G[i0, j1] + f0 * f1 * G[i1, j1])
    d0 = s0 / h0 * ((1 - f1) * (G[i1, j0] - G[i0, j0]) + f1 * (G[i1, j1] - G[i0, j1]))
    d1 = s1 / h1 * ((1 - f0) * (G[i0, j1] - G[i0, j0]) + f0 * (G[i1, j1] - G[i1, j0]))
    return E, np.array([d0, d1])


def _interior_points(surf, n_points, seed, outside=False):
    """Random points whose fractions are EDGE_MARGIN away from every cell edge.

    With ``outside``, non-periodic coordinates may also lie well outside the span
    (there the surface is flat along that axis, so no kink is near either).
    """
    rng = np.random.default_rng(seed)
    h = surf.spacing
    q = np.empty((n_points, 2))
    for d in range(2):
        n = surf.shape[d]
        cells = n if surf.periodic[d] else n - 1
        k = rng.integers(-2 * cells, 3 * cells) if surf.periodic[d] else rng.integers(0, cells, n_points)
        f = rng.uniform(EDGE_MARGIN, 1 - EDGE_MARGIN, n_points)
        q[:, d] = surf.lower[d] + (k + f) * h[d]
        if outside and not surf.periodic[d]:
            away = rng.uniform(0.5, 3.0, n_points) * surf.length[d]
            side = rng.integers(0, 3, n_points)           # 0 inside, 1 below, 2 above
            side[: (n_points + 1) // 2] = 0               # keep half of the points inside
            q[side == 1, d] = surf.lower[d] - away[side == 1]
            q[side == 2, d] = surf.upper[d] + away[side == 2]
    return q


# --------------------------------------------------------------------------- spacing, nodes

@pytest.mark.parametrize("topology", TOPO_IDS)
def test_spacing_periodic_vs_non_periodic(topology):
    # L = (4, 3), n = (5, 4): periodic h = L/n = (0.8, 0.75), non-periodic h = L/(n-1) = (1, 1)
    surf = Surface(np.zeros((5, 4)), (-1.0, 2.0), (3.0, 5.0), TOPOLOGIES[topology])
    want = np.array([0.8 if surf.periodic[0] else 1.0, 0.75 if surf.periodic[1] else 1.0])
    np.testing.assert_allclose(surf.spacing, want, rtol=TRAJ_RTOL)
    np.testing.assert_allclose(spacing(surf.lower, surf.upper, (5, 4), np.array(surf.periodic)), want,
                               rtol=TRAJ_RTOL)


@pytest.mark.parametrize("topology", TOPO_IDS)
@pytest.mark.parametrize("axis", [0, 1])
def test_last_node_on_upper_only_if_non_periodic(topology, axis):
    surf = _surface(topology)
    nodes = surf.nodes(axis)
    assert nodes[0] == surf.lower[axis]
    last = surf.upper[axis] - (surf.spacing[axis] if surf.periodic[axis] else 0.0)
    np.testing.assert_allclose(nodes[-1], last, rtol=TRAJ_RTOL)


@pytest.mark.parametrize("topology", TOPO_IDS)
def test_topology_name(topology):
    assert _surface(topology).topology == {"plane": "plane", "torus": "torus"}.get(topology, "cylinder")


# --------------------------------------------------------------------------- energy and slope values

@pytest.mark.parametrize("topology", TOPO_IDS)
def test_energy_equals_grid_values_at_nodes(topology):
    surf = _surface(topology)
    i, j = np.meshgrid(np.arange(surf.shape[0]), np.arange(surf.shape[1]), indexing="ij")
    q = np.stack([surf.nodes(0)[i.ravel()], surf.nodes(1)[j.ravel()]], axis=1)
    np.testing.assert_allclose(surf.energy(q), surf.values.ravel(), rtol=TRAJ_RTOL, atol=TRAJ_ATOL)


G_HAND = np.array([[0.0, 1.0, 2.0],
                   [4.0, 8.0, 3.0],
                   [5.0, 7.0, 6.0]])


@pytest.mark.parametrize("periodic, upper, q, energy, slope", [
    # plane, h = 1: cell (0, 0), f = (0.25, 0.5)
    #   E = .375*0 + .125*4 + .375*1 + .125*8 = 1.875
    #   dE/dq0 = .5*(4-0) + .5*(8-1) = 5.5 ; dE/dq1 = .75*(1-0) + .25*(8-4) = 1.75
    ((False, False), (2.0, 2.0), (0.25, 0.5), 1.875, (5.5, 1.75)),
    # plane: cell (1, 1), f = (0.5, 0.75)
    #   E = .125*8 + .125*7 + .375*3 + .375*6 = 5.25 ; slope = (.25*(7-8) + .75*(6-3), .5*(3-8) + .5*(6-7))
    ((False, False), (2.0, 2.0), (1.5, 1.75), 5.25, (2.0, -3.0)),
    # torus, h = 1: cell (2 -> 0, 2 -> 0), f = (0.5, 0.5): the corners G22=6, G02=2, G20=5, G00=0
    #   E = (6 + 2 + 5 + 0)/4 = 3.25 ; dE/dq0 = .5*(2-6) + .5*(0-5) = -4.5 ; dE/dq1 = .5*(5-6) + .5*(0-2) = -1.5
    ((True, True), (3.0, 3.0), (2.5, 2.5), 3.25, (-4.5, -1.5)),
    # cylinder periodic along q1 only: q0 in cell 0 (h0 = 1), q1 in wrap cell 2 -> 0, f = (0.5, 0.5)
    #   corners G02=2, G12=3, G00=0, G10=4: E = 9/4
    #   dE/dq0 = .5*(3-2) + .5*(4-0) = 2.5 ; dE/dq1 = .5*(0-2) + .5*(4-3) = -0.5
    ((False, True), (2.0, 3.0), (0.5, 2.5), 2.25, (2.5, -0.5)),
])
def test_bilinear_energy_and_slope_at_hand_computed_points(periodic, upper, q, energy, slope):
    surf = Surface(G_HAND, (0.0, 0.0), upper, periodic)
    np.testing.assert_allclose(surf.energy([q]), [energy], rtol=TRAJ_RTOL)
    np.testing.assert_allclose(surf.slope([q]), [slope], rtol=TRAJ_RTOL)


@pytest.mark.parametrize("topology", TOPO_IDS)
@pytest.mark.parametrize("seed", [1, 2])
def test_energy_and_slope_match_the_spec_written_out(topology, seed):
    """Energy and analytic bilinear slope at random points, inside and outside the domain."""
    surf = _surface(topology, seed=seed)
    rng = np.random.default_rng(seed)
    q = surf.lower + rng.uniform(-1.5, 2.5, (64, 2)) * surf.length
    want = [_reference(surf.values, surf.lower, surf.upper, surf.periodic, p) for p in q]
    np.testing.assert_allclose(surf.energy(q), [w[0] for w in want], rtol=TRAJ_RTOL, atol=TRAJ_ATOL)
    np.testing.assert_allclose(surf.slope(q), [w[1] for w in want], rtol=TRAJ_RTOL, atol=TRAJ_ATOL)


@pytest.mark.parametrize("topology", TOPO_IDS)
def test_slope_matches_central_differences_of_energy(topology):
    surf = _surface(topology)
    q = _interior_points(surf, 12, seed=3, outside=True)
    slope = surf.slope(q)
    fd = central_gradient(lambda p: np.sum(surf.energy(p)), q)
    assert relative_error(slope, fd) < FD_RTOL


# --------------------------------------------------------------------------- cell edges and outside

@pytest.mark.parametrize("topology", TOPO_IDS)
@pytest.mark.parametrize("k", [1, 2, 4])
def test_on_a_cell_edge_the_floor_cell_is_used(topology, k):
    """f = 0 exactly: the slope along q0 is the forward difference of the cell to the right."""
    # dyadic domain so that q0 = k h0 is exact: L0 = 1, n0 = 8 (periodic) / 9 (not), h0 = 1/8
    periodic = TOPOLOGIES[topology]
    n0 = 8 if periodic[0] else 9
    G = np.random.default_rng(k).uniform(-1, 1, (n0, 4))
    surf = Surface(G, (0.0, 0.0), (1.0, 1.0), periodic)
    h0 = surf.spacing[0]
    assert h0 == 0.125
    c = surf.locate([[k * h0, 0.0]])
    assert (c.i0[0], c.f0[0]) == (k, 0.0)
    want = (G[(k + 1) % n0, 0] - G[k, 0]) / h0
    assert surf.slope([[k * h0, 0.0]])[0, 0] == pytest.approx(want, rel=TRAJ_RTOL)
    # and it differs from the left cell's slope, so the convention matters here
    assert want != pytest.approx((G[k, 0] - G[k - 1, 0]) / h0, rel=TRAJ_RTOL)


@pytest.mark.parametrize("topology", ["plane", "cylinder1"])
def test_upper_edge_of_a_non_periodic_axis_uses_the_last_cell(topology):
    surf = _surface(topology, shape=(5, 4), lower=(0.0, 0.0), upper=(1.0, 1.0))
    G, n0 = surf.values, surf.shape[0]
    c = surf.locate([[1.0, 0.0]])
    assert (c.i0[0], c.i1[0], c.f0[0], c.s0[0]) == (n0 - 2, n0 - 1, 1.0, 1.0)
    want = (G[n0 - 1, 0] - G[n0 - 2, 0]) / surf.spacing[0]
    assert surf.slope([[1.0, 0.0]])[0, 0] == pytest.approx(want, rel=TRAJ_RTOL)


@pytest.mark.parametrize("topology, axis", [("plane", 0), ("plane", 1), ("cylinder0", 1), ("cylinder1", 0)])
@pytest.mark.parametrize("side", ["below", "above"])
def test_outside_a_non_periodic_axis_energy_is_constant_and_slope_zero(topology, axis, side):
    surf = _surface(topology)
    other = 1 - axis
    edge = surf.lower[axis] if side == "below" else surf.upper[axis]
    sign = -1.0 if side == "below" else 1.0
    distances = np.array([1e-9, 0.3, 1.0, 7.0, 1e6]) * surf.length[axis]
    q = np.empty((len(distances) + 1, 2))
    q[:, other] = surf.lower[other] + 0.37 * surf.length[other]
    q[0, axis] = edge
    q[1:, axis] = edge + sign * distances
    e, s = surf.energy(q), surf.slope(q)
    np.testing.assert_allclose(e[1:], e[0], rtol=TRAJ_RTOL, atol=TRAJ_ATOL)
    np.testing.assert_array_equal(s[1:, axis], 0.0)
    np.testing.assert_allclose(s[1:, other], s[0, other], rtol=TRAJ_RTOL, atol=TRAJ_ATOL)
    assert np.all(surf.locate(q[1:]).__getattribute__("s0" if axis == 0 else "s1") == 0.0)
    assert s[0, axis] != 0.0        # on the edge itself the slope is the edge cell's


# --------------------------------------------------------------------------- periodic wrap

PERIODIC_AXES = [(t, d) for t in TOPO_IDS for d in range(2) if TOPOLOGIES[t][d]]


@pytest.mark.parametrize("topology, axis", PERIODIC_AXES)
@pytest.mark.parametrize("periods", [1, -1, 3, -7])
def test_periodic_lookup_wraps_bit_for_bit(topology, axis, periods):
    # dyadic domain and points: q + P L is exact and so is every fraction
    surf = _surface(topology, shape=(8, 8), lower=(0.0, 0.0), upper=(1.0, 1.0))
    q = np.array([[13 / 32, 21 / 64], [0.0, 0.5], [1 - 1 / 128, 3 / 128]])
    qs = q.copy()
    qs[:, axis] += periods * surf.length[axis]
    assert np.array_equal(surf.energy(qs), surf.energy(q))
    assert np.array_equal(surf.slope(qs), surf.slope(q))


@pytest.mark.parametrize("topology, axis", PERIODIC_AXES)
@pytest.mark.parametrize("periods", [FAR_PERIODS, -FAR_PERIODS])
def test_periodic_lookup_wraps_far_away(topology, axis, periods):
    surf = _surface(topology)
    q = _interior_points(surf, 10, seed=5)
    qs = q.copy()
    qs[:, axis] += periods * surf.length[axis]
    scale = np.max(np.abs(surf.values))
    np.testing.assert_allclose(surf.energy(qs), surf.energy(q), rtol=0, atol=FAR_RTOL * scale)
    np.testing.assert_allclose(surf.slope(qs), surf.slope(q), rtol=0,
                               atol=FAR_RTOL * scale / np.min(surf.spacing))


@pytest.mark.parametrize("topology", TOPO_IDS)
def test_wrap_is_for_display_and_preserves_the_lookup(topology):
    surf = _surface(topology)
    q = surf.lower + np.random.default_rng(9).uniform(-3, 4, (20, 2)) * surf.length
    w = surf.wrap(q)
    for d in range(2):
        if surf.periodic[d]:
            assert np.all((w[:, d] >= surf.lower[d]) & (w[:, d] < surf.upper[d]))
        else:
            np.testing.assert_array_equal(w[:, d], q[:, d])
    np.testing.assert_allclose(surf.energy(w), surf.energy(q), rtol=TRAJ_RTOL, atol=TRAJ_ATOL)
    assert not np.shares_memory(w, q)


def test_wrap_function_does_not_modify_its_input():
    q = np.array([[3.5, -2.25]])
    before = q.copy()
    wrap(q, np.zeros(2), np.ones(2), (True, True))
    np.testing.assert_array_equal(q, before)


# --------------------------------------------------------------------------- adjoint pieces


@pytest.mark.parametrize("topology", TOPO_IDS)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_grid_slope_vjp_q_is_the_hessian_vector_product(topology, seed):
    surf = _surface(topology, seed=seed)
    G, h, lo, shape, per = surf.values, surf.spacing, surf.lower, surf.shape, surf.periodic
    q = _interior_points(surf, 7, seed=seed + 10, outside=True)
    slope = lambda p: grid_slope(G, h, locate(p, lo, h, shape, per))                       # noqa: E731
    vjp = lambda p, w: grid_slope_vjp_q(G, h, locate(p, lo, h, shape, per), w)             # noqa: E731
    assert_dot(*check_vjp(slope, vjp, q, np.random.default_rng(seed)))


@pytest.mark.parametrize("topology", TOPO_IDS)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_grid_slope_vjp_values_against_central_differences(topology, seed):
    surf = _surface(topology, seed=seed)
    h, shape = surf.spacing, surf.shape
    q = _interior_points(surf, 7, seed=seed + 20, outside=True)
    cells = surf.locate(q)
    slope = lambda g: grid_slope(g, h, cells)                                                # noqa: E731
    vjp = lambda g, w: grid_slope_vjp_values(h, cells, w, shape[1], g.size).reshape(shape)  # noqa: E731
    assert_dot(*check_vjp(slope, vjp, surf.values, np.random.default_rng(seed)))


@pytest.mark.parametrize("topology", TOPO_IDS)
@pytest.mark.parametrize("i", [0, 1, 2])
@pytest.mark.parametrize("d", [0, 1])
def test_grid_slope_vjp_values_full_jacobian(topology, i, d):
    """Row by row: the VJP with a unit cotangent is the gradient in G of one slope entry."""
    surf = _surface(topology, shape=(4, 3), seed=4)
    h, shape = surf.spacing, surf.shape
    q = _interior_points(surf, 3, seed=6)
    cells = surf.locate(q)
    w = np.zeros((3, 2))
    w[i, d] = 1.0
    got = grid_slope_vjp_values(h, cells, w, shape[1], surf.values.size).reshape(shape)
    fd = central_gradient(lambda g: grid_slope(g, h, cells)[i, d], surf.values)
    assert np.any(got != 0)
    assert relative_error(got, fd) < FD_RTOL


@pytest.mark.parametrize("topology", TOPO_IDS)
def test_grid_energy_is_linear_in_values(topology):
    """The energy's gradient in G is the bilinear weights (they sum to 1)."""
    surf = _surface(topology, shape=(4, 3), seed=8)
    cells = surf.locate(_interior_points(surf, 1, seed=7))
    g = central_gradient(lambda v: grid_energy(v, cells)[0], surf.values)
    assert np.count_nonzero(np.abs(g) > FD_RTOL) == 4
    assert abs(g.sum() - 1.0) < FD_RTOL


# --------------------------------------------------------------------------- validation

GOOD = dict(values=np.zeros((3, 4)), lower=(0.0, 0.0), upper=(1.0, 1.0), periodic=(False, True))


@pytest.mark.parametrize("key, bad, exc, name", [
    ("values", np.zeros(4), ValueError, "values"),
    ("values", np.zeros((2, 2, 2)), ValueError, "values"),
    ("values", np.zeros((1, 4)), ValueError, "values"),
    ("values", np.zeros((4, 1)), ValueError, "values"),
    ("values", [[0.0, np.nan], [0.0, 0.0]], ValueError, "values"),
    ("values", [[0.0, np.inf], [0.0, 0.0]], ValueError, "values"),
    ("values", [["a", "b"], ["c", "d"]], TypeError, "values"),
    ("lower", (0.0, 0.0, 0.0), ValueError, "lower"),
    ("lower", (np.nan, 0.0), ValueError, "lower"),
    ("upper", (1.0,), ValueError, "upper"),
    ("upper", (1.0, np.inf), ValueError, "upper"),
    ("upper", (0.0, 1.0), ValueError, "upper"),            # upper == lower on axis 0
    ("upper", (1.0, -1.0), ValueError, "upper"),           # upper < lower on axis 1
    ("periodic", ("yes", "no"), TypeError, "periodic"),
    ("periodic", (2, 0), ValueError, "periodic"),
    ("periodic", (0.5, 1), ValueError, "periodic"),
    ("periodic", (True,), ValueError, "periodic"),
    ("periodic", (True, False, True), ValueError, "periodic"),
])
def test_surface_validation_names_the_argument(key, bad, exc, name):
    kw = dict(GOOD, **{key: bad})
    with pytest.raises(exc, match=rf"\b{name}\b"):
        Surface(**kw)


def test_surface_accepts_bool_like_periodic_and_promotes_values():
    surf = Surface(np.arange(6, dtype=np.int32).reshape(2, 3), (0, 0), (1, 1), np.array([1, 0]))
    assert surf.periodic == (True, False)
    assert surf.values.dtype == np.float64 and surf.lower.dtype == np.float64


def test_surface_does_not_alias_or_modify_caller_values():
    values = np.arange(12.0).reshape(3, 4)
    before = values.copy()
    surf = Surface(values, (0, 0), (1, 1), (False, False))
    assert not np.shares_memory(surf.values, values)
    assert values.flags.writeable
    values[0, 0] = 99.0
    assert surf.values[0, 0] == before[0, 0]
