"""Unit tests of pes_ref.core.bilinear, the hot loop's grid force and its adjoint, and of the
:class:`pes_ref.core.grid.Locator` they use: the same numbers as the textbook functions
(SPEC section 1), bit for bit where the arithmetic is the same."""
import numpy as np
import pytest

import pes_ref as pr
from _helpers import TOPOLOGIES
from pes_ref.core import bilinear
from pes_ref.core.bilinear import grid_slope, grid_slope_vjp_q, grid_slope_vjp_values
from pes_ref.core.grid import Locator, locate
from pes_ref.oracle.tolerances import TRAJ_ATOL, TRAJ_RTOL

SHAPE = (6, 5)
LOWER, UPPER = np.array([0.0, -0.5]), np.array([1.2, 0.5])
#: The table regroups the slope formula: a few ulp of the largest term.
REGROUP_RTOL = TRAJ_RTOL


def _field(topology, seed=0):
    rng = np.random.default_rng(seed)
    surf = pr.Surface(rng.uniform(-1, 1, SHAPE), LOWER, UPPER, TOPOLOGIES[topology])
    return pr.Scene(surf, dt=0.01, n_steps=1).field()


def _points(n, seed, spread=1.0):
    """Points over and beyond the domain (several periods away), with some exactly on
    nodes, on the edges and on the clip limits."""
    rng = np.random.default_rng(seed)
    x = LOWER + rng.uniform(-0.5 * spread, 1 + 0.5 * spread, (n, 2)) * (UPPER - LOWER)
    x[:4] = [LOWER, UPPER, [LOWER[0], UPPER[1]], [0.48, 0.3]]      # 0.48: a node of a non-periodic axis 0
    x[4:8] += 3 * (UPPER - LOWER)
    return x


def _locate_axis(q, lower, h, n, periodic):
    """SPEC section 1's cell, fraction and switch along one axis, written per axis with
    np.mod and np.minimum (independent of the package's whole-array lookup)."""
    u = (q - lower) / h
    if periodic:
        k = np.floor(u)
        return np.mod(k, n).astype(np.intp), u - k, np.ones_like(u)
    uc = np.clip(u, 0.0, n - 1.0)
    i0 = np.minimum(np.floor(uc), n - 2).astype(np.intp)
    return i0, uc - i0, ((u >= 0.0) & (u <= n - 1.0)).astype(np.float64)


@pytest.mark.parametrize("topology", sorted(TOPOLOGIES))
@pytest.mark.parametrize("lead", [(7,), (3, 9)])
def test_locator_matches_the_per_axis_formulas_bit_for_bit(topology, lead):
    field = _field(topology)
    x = _points(int(np.prod(lead)), 1, spread=4.0).reshape(lead + (2,))
    got = Locator(field.lower, field.h, SHAPE, field.periodic).locate(x)
    flat = x.reshape(-1, 2)
    (i0, f0, s0), (j0, f1, s1) = (_locate_axis(flat[:, d], field.lower[d], field.h[d], SHAPE[d], field.periodic[d])
                                  for d in range(2))
    np.testing.assert_array_equal(got.cell.reshape(-1), i0 * SHAPE[1] + j0)
    assert got.f.reshape(-1, 2).tobytes() == np.stack([f0, f1], axis=1).tobytes()
    if all(field.periodic):
        assert got.inside is None
    else:
        np.testing.assert_array_equal(got.inside.reshape(-1, 2), np.stack([s0, s1], axis=1))


@pytest.mark.parametrize("topology", sorted(TOPOLOGIES))
def test_scalar_lookup_matches_the_vectorized_one_bit_for_bit(topology):
    """Locator.bind_scalar (one particle, Python floats) gives the cells, fractions and
    switches of Locator.bind, and None for a non-finite position."""
    field = _field(topology)
    loc = Locator(field.lower, field.h, SHAPE, field.periodic)
    x = _points(60, 9, spread=4.0)
    vec = loc.locate(x)
    locate1 = loc.bind_scalar()
    inside = vec.inside if vec.inside is not None else np.ones((60, 2))
    for i in range(60):
        cell, f0, f1, s0, s1 = locate1(x[i:i + 1])
        assert cell == vec.cell[i]
        assert np.array([f0, f1]).tobytes() == vec.f[i].tobytes()
        assert (s0, s1) == tuple(inside[i])
    for bad in (np.nan, np.inf, -np.inf):
        assert locate1(np.array([[0.3, bad]])) is None


def test_cells_are_the_located_cells_per_axis():
    """locate (per axis, for the textbook functions) is a view of Locator.locate."""
    for topology in TOPOLOGIES:
        field = _field(topology)
        x = _points(30, 10, spread=4.0)
        loc = Locator(field.lower, field.h, SHAPE, field.periodic).locate(x)
        c = locate(x, field.lower, field.h, SHAPE, field.periodic)
        np.testing.assert_array_equal(c.i0 * SHAPE[1] + c.j0, loc.cell)
        for d, (lo, hi) in enumerate(((c.i0, c.i1), (c.j0, c.j1))):
            want = lo + 1 if not field.periodic[d] else (lo + 1) % SHAPE[d]
            np.testing.assert_array_equal(hi, want)
            assert (lo >= 0).all() and (hi < SHAPE[d]).all()


@pytest.mark.parametrize("topology", sorted(TOPOLOGIES))
def test_table_kernels_agree_bit_for_bit_and_with_the_textbook_slope(topology):
    field = _field(topology)
    x = _points(40, 2, spread=4.0)
    vec = bilinear.BilinearForce(field, 40).call(x, np.empty((40, 2)))
    one = np.concatenate([bilinear.BilinearForce1(field).call(x[i:i + 1], np.empty((1, 2))) for i in range(40)])
    point = bilinear.point_force(field.values, field.lower, field.h, field.periodic, x, np.empty((40, 2)))
    assert vec.tobytes() == one.tobytes() == point.tobytes()
    slope = grid_slope(field.values, field.h, locate(x, field.lower, field.h, SHAPE, field.periodic))
    scale = np.abs(slope).max()
    np.testing.assert_allclose(vec, -slope, rtol=REGROUP_RTOL, atol=REGROUP_RTOL * scale)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_position_gives_no_error(bad):
    """The loop checks finiteness once at the end, under its own silenced errstate; until
    then a lookup must not fail (no IndexError from a garbage cell index)."""
    field = _field("cylinder0")
    x = np.array([[bad, 0.1], [0.3, 0.2]])
    with np.errstate(over="ignore", invalid="ignore"):
        out = bilinear.BilinearForce(field, 2).call(x, np.empty((2, 2)))
        one = bilinear.BilinearForce1(field).call(x[:1], np.empty((1, 2)))
    assert np.isfinite(out[1]).all()
    assert not np.isfinite(one).all()


def test_cross_table_is_the_hessian_cross_term():
    field = _field("torus")
    c = locate(_points(30, 8), field.lower, field.h, SHAPE, field.periodic)
    w = np.random.default_rng(8).standard_normal((30, 2))
    hw = grid_slope_vjp_q(field.values, field.h, c, w)        # (Hc w1, Hc w0)
    hc = bilinear.cross_table(field.values, field.h)[c.i0 * SHAPE[1] + c.j0]
    np.testing.assert_allclose(np.stack([hc * w[:, 1], hc * w[:, 0]], axis=1), hw, rtol=REGROUP_RTOL,
                               atol=REGROUP_RTOL * np.abs(hw).max())


def test_table_grad_to_values_is_the_transpose_of_the_table():
    rng = np.random.default_rng(3)
    for topology in TOPOLOGIES:
        field = _field(topology)
        G = rng.standard_normal(SHAPE)
        gtab = rng.standard_normal((SHAPE[0] * SHAPE[1], 4))
        lhs = np.sum(gtab * bilinear.coefficient_table(G, field.h))
        rhs = np.dot(bilinear.table_grad_to_values(gtab.copy(), field.h, SHAPE), G.reshape(-1))
        assert abs(lhs - rhs) <= 1e-12 * max(1.0, abs(lhs))


@pytest.mark.parametrize("topology", sorted(TOPOLOGIES))
@pytest.mark.parametrize("chunk, lookup", [(16, 8), (64, 16), (1 << 16, 1 << 12)],
                         ids=["add.at+sub-lookups", "bincount", "defaults"])
def test_adjoint_equals_the_sum_of_pointwise_vjps(monkeypatch, topology, chunk, lookup):
    """Chunks, partial chunks, sub-lookups and both scatter paths give the pointwise sums."""
    monkeypatch.setattr(bilinear, "CHUNK_ELEMENTS", chunk)
    monkeypatch.setattr(bilinear, "LOOKUP_ELEMENTS", lookup)
    field = _field(topology)
    rng = np.random.default_rng(4)
    T1, N = 11, 3
    xs = _points(T1 * N, 5, spread=3.0).reshape(T1, N, 2)
    ws = rng.standard_normal((T1, N, 2))
    adj = bilinear.BilinearAdjoint(field, xs, want_values=True)
    xbar = np.zeros((N, 2))
    want_x, want_g = np.zeros((N, 2)), np.zeros(field.values.size)
    for n in range(T1 - 1, -1, -1):
        adj.vjp(n, ws[n], xbar)
        c = locate(xs[n], field.lower, field.h, SHAPE, field.periodic)
        want_x -= grid_slope_vjp_q(field.values, field.h, c, ws[n])
        want_g -= grid_slope_vjp_values(field.h, c, ws[n], SHAPE[1], field.values.size)
    np.testing.assert_allclose(xbar, want_x, rtol=TRAJ_RTOL, atol=TRAJ_ATOL * np.abs(want_x).max())
    np.testing.assert_allclose(adj.values_grad(), want_g, rtol=1e3 * TRAJ_RTOL,
                               atol=1e3 * TRAJ_ATOL * np.abs(want_g).max())


@pytest.mark.parametrize("topology", sorted(TOPOLOGIES))
@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
def test_one_particle_runs_exactly_as_in_a_batch(topology, mode):
    """N = 1 takes the scalar path; the particle's trajectory is the same bits as in a batch."""
    rng = np.random.default_rng(6)
    surf = pr.Surface(rng.uniform(-1, 1, SHAPE), LOWER, UPPER, TOPOLOGIES[topology])
    walls = None if all(surf.periodic) else pr.Walls(30.0, 0.1, [[not surf.periodic[0]] * 2,
                                                                  [not surf.periodic[1]] * 2])
    kw = dict(mobility=(0.01, 0.02)) if mode == "quasistatic" else dict(damping=(0.3, 0.1))
    scene = pr.Scene(surf, dt=0.02, n_steps=30, mode=mode, spring=pr.Spring(0.5, (0.6, 0.0)), walls=walls,
                     effects=[pr.Constant((0.2, -0.1))], **kw)
    x0 = np.array([[0.3, 0.1], [0.9, -0.2]])
    v0 = np.array([[1.0, -0.5], [0.2, 0.3]])
    both = pr.simulate(scene, x0, v0)
    one = pr.simulate(scene, x0[:1], v0[:1])
    for a, b in zip(one, both):
        assert a.tobytes() == np.ascontiguousarray(b[:, :1]).tobytes()
