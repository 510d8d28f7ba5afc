"""The level-set parameterization: eq. (1) of a shape, and its exact gradient against central differences."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from pes_ref.devices.cspace import apf_energy
from pes_ref.synthesis.common.level_set import LevelSet
from pes_ref.synthesis.common.resampling import resample, resample_vjp

LS = LevelSet(v=1e-3, r_c=0.3, r_min=0.05)
EPS = 1e-7


def _disc_psi(shape, lower, upper, periodic, centre, radius, rng):
    """psi of a disc (blocked inside), with a small random ripple so no two crossings are alike."""
    q = [np.linspace(lo, hi, n, endpoint=not p) for lo, hi, n, p in zip(lower, upper, shape, periodic)]
    d = np.hypot(q[0][:, None] - centre[0], q[1][None, :] - centre[1]) - radius
    return LS.from_distance(d) + 1e-3 * rng.standard_normal(shape)


def _loss(psi, w, lower, upper, periodic):
    return float(np.sum(w * LS.energy(psi, lower, upper, periodic)))


def _check(psi, lower, upper, periodic, rng, smooth_share: float):
    """The vjp against central differences at every node where the loss is smooth (its two
    one-sided differences agree); at least ``smooth_share`` of the nodes whose value moves
    the loss must be smooth, so the check cannot pass by skipping."""
    w = rng.standard_normal(psi.shape)
    grad = LS.vjp(psi, w * 1.0, lower, upper, periodic)
    base = _loss(psi, w, lower, upper, periodic)
    checked = moving = 0
    for idx in np.ndindex(psi.shape):
        up, dn = psi.copy(), psi.copy()
        up[idx] += EPS
        dn[idx] -= EPS
        f_up, f_dn = _loss(up, w, lower, upper, periodic), _loss(dn, w, lower, upper, periodic)
        right, left = (f_up - base) / EPS, (base - f_dn) / EPS
        scale = max(abs(right), abs(left), 1e-3)
        if abs(right) > 1e-6 or abs(left) > 1e-6 or grad[idx] != 0:
            moving += 1
        if abs(right - left) > 1e-3 * scale:
            continue                                                # a kink: not compared
        central = (f_up - f_dn) / (2 * EPS)
        assert grad[idx] == pytest.approx(central, rel=2e-4, abs=1e-5 * scale), idx
        checked += abs(central) > 1e-6
    assert moving > 0 and checked >= smooth_share * moving


def test_the_gradient_matches_central_differences_on_a_disc():
    rng = np.random.default_rng(3)
    lower, upper, periodic = (0.0, 0.0), (2.0, 2.0), (False, False)
    psi = _disc_psi((14, 14), lower, upper, periodic, (1.0, 0.9), 0.45, rng)
    _check(psi, lower, upper, periodic, rng, smooth_share=0.8)


@settings(max_examples=12)
@given(seed=st.integers(0, 2 ** 32 - 1), topology=st.sampled_from([(False, False), (False, True), (True, True)]),
       radius=st.floats(0.25, 0.6))
def test_the_gradient_matches_central_differences_on_every_topology(seed, topology, radius):
    rng = np.random.default_rng(seed)
    lower, upper = (0.0, 0.0), (2.0, 2.0)
    centre = rng.uniform(0.7, 1.3, 2)
    psi = _disc_psi((10, 11), lower, upper, topology, centre, radius, rng)
    _check(psi, lower, upper, topology, rng, smooth_share=0.6)


def test_the_surface_is_eq1_of_the_shape_s_distance():
    """Within r_c and two spacings of a straight contour the surface is eq. (1) of the exact
    distance; beyond, zero on the free side and higher still on the blocked side."""
    n = 21
    q0 = np.linspace(0.0, 2.0, n)[:, None]
    psi = LS.from_distance(np.broadcast_to(q0 - 0.95, (n, n)))      # blocked for q0 < 0.95, a straight edge
    e = LS.energy(psi, (0.0, 0.0), (2.0, 2.0), (False, False))
    d = np.broadcast_to(q0 - 0.95, (n, n))
    band = np.abs(d) <= LS.r_c + 2 * 0.1                    # the exact band: r_c and two spacings
    np.testing.assert_allclose(e[band], apf_energy(d[band], LS.v, LS.r_c, LS.r_min), rtol=1e-12, atol=1e-15)
    assert (e[~band & (d > 0)] == 0).all() and (e[~band & (d < 0)] > e[band].max()).all()


def test_resample_vjp_is_the_transpose_of_resample():
    rng = np.random.default_rng(0)
    for periodic in [(False, False), (True, False), (True, True)]:
        x = rng.standard_normal((6, 7))
        y = rng.standard_normal((13, 11))
        fine = resample(x, (0.0, 0.0), (1.0, 1.0), periodic, y.shape)
        assert np.sum(fine * y) == pytest.approx(np.sum(x * resample_vjp(y, x.shape, periodic)), rel=1e-12)


@pytest.mark.parametrize("shape, free_at, blocked_at", [
    ("strips", [(0.0, 1.0), (0.9, 1.0)], [(0.99, 1.0), (-0.99, 0.5)]),
    ("vee", [(0.0, 0.0), (0.1, 0.0), (0.8, 1.6)], [(0.3, 0.0), (-0.6, 0.5), (0.9, 1.0)]),
])
def test_a_realizable_funnel_starts_from_its_stated_shape(shape, free_at, blocked_at):
    from pes_ref.synthesis.kinds.funnel import FunnelProblem
    p = FunnelProblem(grid=41, realizable=True, init_shape=shape)
    values = p.initial_values(np.random.default_rng(0), (41, 41))
    node = lambda q: (int(round((q[0] + 1.0) * 20)), int(round(q[1] * 20)))   # noqa: E731
    assert all(values[node(q)] + p.contact_r_c > 0 for q in free_at)
    assert all(values[node(q)] + p.contact_r_c < 0 for q in blocked_at)
    held = p.mask((41, 41)) == 0
    assert (values[held] == 0).all()                          # the start strip is free


def test_a_starting_shape_is_one_of_the_stated():
    from pes_ref.synthesis.kinds.funnel import FunnelProblem
    with pytest.raises(ValueError, match="init_shape"):
        FunnelProblem(realizable=True, init_shape="star")
