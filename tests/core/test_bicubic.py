"""Unit tests of pes_ref.core.bicubic: the C1 Catmull-Rom surface (an option beside the paper's
bilinear rule), its derivatives and adjoints, and what it does to the accuracy."""
import numpy as np
import pytest

import pes_ref as pr
from _helpers import TOPOLOGIES, assert_dot
from pes_ref import Surface
from pes_ref.core import bicubic as bc
from pes_ref import testing as pt
from pes_ref.core.forces import Field
from pes_ref.core.bilinear import grid_slope as bilinear_slope
from pes_ref.core.grid import Cells, locate, spacing
from pes_ref.core.scene import gradient_names
from pes_ref.testing.finite_differences import check_vjp
from pes_ref.oracle.compare import relative_error
from pes_ref.oracle.tolerances import FD_EPS, FD_RTOL, TRAJ_RTOL

TOPO_IDS = sorted(TOPOLOGIES)
SHAPES = [(6, 5), (3, 4), (2, 3), (4, 2)]          # 2 and 3 nodes: the ghost rules' corner cases
LOWER, UPPER = np.array([-0.5, 1.0]), np.array([1.0, 2.0])

#: Polynomials of degree <= 2 per axis are reproduced to rounding (a few hundred ulps of
#: the values' scale: the coefficients sum terms of both signs).
REPRO_RTOL = 1e-12

#: Measured orders of the surface's error (max over 4000 points, h halved 8 -> 64 nodes;
#: docs/variants.md): bicubic energy 3.05-3.66, slope 1.91-2.17; bilinear energy
#: 1.57-2.16, slope 0.80-1.05 (the coarsest grid is pre-asymptotic; the bands apply to
#: the finest halving, measured 3.05-3.10, 2.01-2.08, 1.89-2.03, 1.03-1.04).
ORDER_BANDS = {("bicubic", "energy"): (2.8, 3.3), ("bicubic", "slope"): (1.8, 2.3),
               ("bilinear", "energy"): (1.8, 2.3), ("bilinear", "slope"): (0.8, 1.2)}


def _grid(topology, shape, seed=0):
    rng = np.random.default_rng(seed)
    periodic = TOPOLOGIES[topology]
    values = rng.uniform(-1.0, 1.0, shape)
    return values, periodic, spacing(LOWER, UPPER, shape, np.array(periodic))


def _points(n, seed, margin=0.0):
    """Random points inside the domain, ``margin`` (fraction of the length) from its edges."""
    rng = np.random.default_rng(seed)
    return LOWER + rng.uniform(margin, 1.0 - margin, (n, 2)) * (UPPER - LOWER)


def _nodes(shape, h, d):
    return LOWER[d] + h[d] * np.arange(shape[d])


# =========================================================================== the surface

@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("topology", TOPO_IDS)
def test_the_surface_passes_through_the_nodes(topology, shape):
    values, periodic, h = _grid(topology, shape)
    q = np.stack(np.meshgrid(_nodes(shape, h, 0), _nodes(shape, h, 1), indexing="ij"), -1).reshape(-1, 2)
    e = bc.grid_energy(bc.cell_coefficients(values, periodic), locate(q, LOWER, h, shape, periodic))
    np.testing.assert_allclose(e, values.reshape(-1), rtol=0, atol=REPRO_RTOL)


def _biquadratic(q0, q1, periodic):
    """1 + q + q^2 terms and their products per axis; constant along a periodic axis."""
    a = np.zeros_like(q0) if periodic[0] else q0
    b = np.zeros_like(q1) if periodic[1] else q1
    return (1.0 + 0.3 * a - 0.7 * b + 0.5 * a * a - 0.2 * a * b + 0.9 * b * b + 0.4 * a * a * b * b
            - 0.3 * a * a * b)


def _biquadratic_slope(q0, q1, periodic):
    a = np.zeros_like(q0) if periodic[0] else q0
    b = np.zeros_like(q1) if periodic[1] else q1
    d0 = 0.3 + a - 0.2 * b + 0.8 * a * b * b - 0.6 * a * b
    d1 = -0.7 - 0.2 * a + 1.8 * b + 0.8 * a * a * b - 0.3 * a * a
    return (0.0 if periodic[0] else 1.0) * d0, (0.0 if periodic[1] else 1.0) * d1


@pytest.mark.parametrize("shape", [(6, 5), (3, 3), (4, 7)])
@pytest.mark.parametrize("topology", TOPO_IDS)
def test_polynomials_of_degree_two_per_axis_are_reproduced_up_to_the_edges(topology, shape):
    """Central differences (and the second-order one-sided ones at a non-periodic edge) are
    exact for quadratics, so the Catmull-Rom surface reproduces them in every cell."""
    _, periodic, h = _grid(topology, shape)
    g = _biquadratic(_nodes(shape, h, 0)[:, None], _nodes(shape, h, 1)[None, :], periodic)
    coef = bc.cell_coefficients(g, periodic)
    q = np.concatenate((_points(300, 1), LOWER + np.array([[0.0, 0.0], [1.0, 1.0], [0.5, 1.0]]) * (UPPER - LOWER)))
    c = locate(q, LOWER, h, shape, periodic)
    want = _biquadratic(q[:, 0], q[:, 1], periodic)
    np.testing.assert_allclose(bc.grid_energy(coef, c), want, rtol=REPRO_RTOL, atol=REPRO_RTOL)
    d0, d1 = _biquadratic_slope(q[:, 0], q[:, 1], periodic)
    slope_scale = np.max(np.abs(g)) / h.min()          # the slope's rounding: values' over a spacing
    np.testing.assert_allclose(bc.grid_slope(coef, h, c), np.stack((d0, d1), axis=1), rtol=REPRO_RTOL,
                               atol=REPRO_RTOL * slope_scale)


@pytest.mark.parametrize("degree, axis_nodes", [(3, 6), (2, 2)])
def test_the_reproduction_check_can_fail(degree, axis_nodes):
    """A cubic (central differences are not exact for it), or a quadratic on an axis of 2
    nodes (where the ghost node is only linear: the surface is linear along that axis)."""
    shape = (axis_nodes, 4)
    h = spacing(LOWER, UPPER, shape, np.array([False, False]))
    g = _nodes(shape, h, 0)[:, None] ** degree + 0.0 * _nodes(shape, h, 1)[None, :]
    q = _points(200, 2)
    e = bc.grid_energy(bc.cell_coefficients(g, (False, False)), locate(q, LOWER, h, shape, (False, False)))
    assert np.max(np.abs(e - q[:, 0] ** degree)) > 1e3 * REPRO_RTOL


@pytest.mark.parametrize("topology", TOPO_IDS)
def test_outside_a_non_periodic_axis_the_surface_is_constant_along_it(topology):
    values, periodic, h = _grid(topology, (5, 4))
    coef = bc.cell_coefficients(values, periodic)
    inside = _points(50, 3)
    for d in range(2):
        for edge, sign in ((LOWER[d], -1.0), (UPPER[d], 1.0)):
            out = inside.copy()
            out[:, d] = edge + sign * np.linspace(0.01, 3.0, 50)
            on = out.copy()
            on[:, d] = edge
            c_out, c_on = (locate(p, LOWER, h, values.shape, periodic) for p in (out, on))
            e_out, s_out = bc.grid_energy(coef, c_out), bc.grid_slope(coef, h, c_out)
            if periodic[d]:      # a periodic axis repeats instead: another point of the surface
                continue
            np.testing.assert_array_equal(e_out, bc.grid_energy(coef, c_on))
            np.testing.assert_array_equal(s_out[:, d], 0.0)
            np.testing.assert_array_equal(s_out[:, 1 - d], bc.grid_slope(coef, h, c_on)[:, 1 - d])


def _edge_cells(shape, periodic, axis, f_other):
    """Both sides of every interior cell edge along ``axis`` (and the periodic seam): the
    left cell at f = 1 and the right cell at f = 0, at the same other fraction."""
    n = shape[axis]
    m = n if periodic[axis] else n - 1
    left = np.arange(m - 1 if not periodic[axis] else m)
    right = (left + 1) % n
    k = len(left)
    o0, o1 = np.zeros(k, dtype=np.intp), np.ones(k, dtype=np.intp)     # the cell (0, 1) across
    ones, zeros, f = np.ones(k), np.zeros(k), np.full(k, f_other)
    nxt = lambda i: (i + 1) % n   # noqa: E731
    if axis == 0:
        return (Cells(left, nxt(left), o0, o1, ones, f, ones, ones),
                Cells(right, nxt(right), o0, o1, zeros, f, ones, ones))
    return (Cells(o0, o1, left, nxt(left), f, ones, ones, ones),
            Cells(o0, o1, right, nxt(right), f, zeros, ones, ones))


@pytest.mark.parametrize("axis", [0, 1])
@pytest.mark.parametrize("topology", TOPO_IDS)
def test_energy_and_slope_are_continuous_across_cell_edges_and_seams(topology, axis):
    """C1: the two cells sharing an edge give the same energy and the same slope on it."""
    values, periodic, h = _grid(topology, (6, 5))
    coef = bc.cell_coefficients(values, periodic)
    for f_other in (0.0, 0.37, 1.0):
        left, right = _edge_cells(values.shape, periodic, axis, f_other)
        scale = np.max(np.abs(values))
        np.testing.assert_allclose(bc.grid_energy(coef, left), bc.grid_energy(coef, right), rtol=0,
                                   atol=REPRO_RTOL * scale)
        np.testing.assert_allclose(bc.grid_slope(coef, h, left), bc.grid_slope(coef, h, right), rtol=0,
                                   atol=REPRO_RTOL * scale / h.min())


def test_the_continuity_check_can_fail():
    """The bilinear rule's slope along an axis jumps across that axis's cell edges."""
    values, periodic, h = _grid("plane", (6, 5))
    left, right = _edge_cells(values.shape, periodic, 0, 0.37)
    jump = bilinear_slope(values, h, left)[:, 0] - bilinear_slope(values, h, right)[:, 0]
    assert np.max(np.abs(jump)) > 1e3 * REPRO_RTOL * np.max(np.abs(values)) / h.min()


# =========================================================================== derivatives and adjoints

@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("topology", TOPO_IDS)
def test_slope_is_the_derivative_of_the_energy(topology, shape):
    """Central differences of the energy (C1, so even across cell edges) against the slope,
    at points kept off the clip edges of a non-periodic axis (where the slope jumps to 0)."""
    values, periodic, h = _grid(topology, shape)
    coef = bc.cell_coefficients(values, periodic)
    q = _points(200, 4, margin=0.01)
    energy = lambda p: bc.grid_energy(coef, locate(p, LOWER, h, shape, periodic))   # noqa: E731
    fd = np.stack([(energy(q + FD_EPS * e) - energy(q - FD_EPS * e)) / (2 * FD_EPS) for e in np.eye(2)], axis=1)
    assert relative_error(bc.grid_slope(coef, h, locate(q, LOWER, h, shape, periodic)), fd) < FD_RTOL


def _kink_free(q, h, shape, margin=1e-3):
    """Drop points within ``margin`` (fraction of a cell) of a cell edge: there the Hessian jumps."""
    u = (q - LOWER) / h
    return q[np.all(np.abs(u - np.round(u)) > margin, axis=1)]


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("topology", TOPO_IDS)
def test_hessian_vector_product_dot_product(topology, shape):
    values, periodic, h = _grid(topology, shape)
    coef = bc.cell_coefficients(values, periodic)
    q = _kink_free(_points(100, 5, margin=0.01), h, shape)
    at = lambda p: locate(p, LOWER, h, shape, periodic)   # noqa: E731
    assert_dot(*check_vjp(lambda p: bc.grid_slope(coef, h, at(p)),
                          lambda p, w: bc.grid_slope_vjp_q(coef, h, at(p), w), q, np.random.default_rng(6)))


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("topology", TOPO_IDS)
def test_slope_vjp_wrt_values_dot_product(topology, shape):
    """Through the coefficient map (C1) and the bincount scatter (CB2)-(CB3); points also
    outside a non-periodic span (switch s = 0 there)."""
    values, periodic, h = _grid(topology, shape)
    q = LOWER + np.random.default_rng(7).uniform(-0.3, 1.3, (100, 2)) * (UPPER - LOWER)
    c = locate(q, LOWER, h, shape, periodic)
    assert_dot(*check_vjp(lambda g: bc.grid_slope(bc.cell_coefficients(g, periodic), h, c),
                          lambda g, w: bc.grid_slope_vjp_values(h, c, w, shape, periodic).reshape(shape),
                          values, np.random.default_rng(8)))


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("topology", TOPO_IDS)
def test_coefficient_map_transpose_is_exact(topology, shape):
    """(C1) is linear: <W, A(G)> = <A^T W, G> to rounding, for random G and W (on the cells
    that exist; the padding rows of a non-periodic axis are not part of the map)."""
    values, periodic, _ = _grid(topology, shape)
    rng = np.random.default_rng(9)
    wbar = rng.normal(size=shape + (16,))
    m0, m1 = (shape[0] if periodic[0] else shape[0] - 1), (shape[1] if periodic[1] else shape[1] - 1)
    wbar[m0:], wbar[:, m1:] = 0.0, 0.0
    lhs = np.sum(wbar * bc.cell_coefficients(values, periodic))
    rhs = np.sum(bc.cell_coefficients_vjp(wbar, periodic) * values.reshape(-1))
    assert abs(lhs - rhs) <= TRAJ_RTOL * np.sum(np.abs(wbar)) * np.max(np.abs(values))


# =========================================================================== the force path's kernels

@pytest.mark.parametrize("topology", TOPO_IDS)
def test_kernels_match_the_pure_functions(topology):
    values, periodic, h = _grid(topology, (6, 5))
    field = Field(values, LOWER, h, UPPER - LOWER, periodic, None, None, "bicubic")
    rng = np.random.default_rng(10)
    xs = LOWER + rng.uniform(-0.3, 1.3, (4, 7, 2)) * (UPPER - LOWER)
    ws = rng.normal(size=xs.shape)
    coef = bc.cell_coefficients(values, periodic)
    kernel, out = bc.BicubicForce(field, 7), np.empty((7, 2))
    adjoint = bc.BicubicAdjoint(field, xs, True)
    xbar, gvalues = np.zeros((7, 2)), np.zeros(values.size)
    for n in range(3, -1, -1):
        c = locate(xs[n], LOWER, h, values.shape, periodic)
        np.testing.assert_allclose(kernel.call(xs[n], out), -bc.grid_slope(coef, h, c), rtol=TRAJ_RTOL, atol=TRAJ_RTOL)
        xb = np.zeros((7, 2))
        adjoint.vjp(n, ws[n], xb)
        np.testing.assert_allclose(xb, -bc.grid_slope_vjp_q(coef, h, c, ws[n]), rtol=TRAJ_RTOL, atol=TRAJ_RTOL)
        gvalues -= bc.grid_slope_vjp_values(h, c, ws[n], values.shape, periodic)
        single = np.zeros((7, 2))
        bc.point_force_vjp(values, LOWER, h, periodic, xs[n], ws[n], single, None)
        np.testing.assert_allclose(single, xb, rtol=TRAJ_RTOL, atol=TRAJ_RTOL)
    np.testing.assert_allclose(adjoint.values_grad(), gvalues, rtol=TRAJ_RTOL, atol=TRAJ_RTOL * np.abs(gvalues).max())
    e = bc.point_energy(values, LOWER, h, periodic, xs[0])
    np.testing.assert_allclose(e, bc.grid_energy(coef, locate(xs[0], LOWER, h, values.shape, periodic)),
                               rtol=TRAJ_RTOL)


# =========================================================================== accuracy

def _smooth(q0, q1):
    return np.sin(q0) * np.cos(2 * q1) + 0.5 * np.cos(q0 + q1)


def _smooth_slope(q0, q1):
    return np.stack((np.cos(q0) * np.cos(2 * q1) - 0.5 * np.sin(q0 + q1),
                     -2 * np.sin(q0) * np.sin(2 * q1) - 0.5 * np.sin(q0 + q1)), axis=1)


def _surface_errors(interpolation, periodic, n):
    """Max error of energy and slope of the grid sampled from _smooth, n x n nodes."""
    lower = np.zeros(2)
    upper = np.full(2, 2 * np.pi) if periodic[0] else np.array([2.0, 1.5])
    shape = (n, n)
    h = spacing(lower, upper, shape, np.array(periodic))
    g = _smooth(*np.meshgrid(lower[0] + h[0] * np.arange(n), lower[1] + h[1] * np.arange(n), indexing="ij"))
    q = lower + np.random.default_rng(11).uniform(0, 1, (4000, 2)) * (upper - lower)
    surf = Surface(g, lower, upper, periodic, interpolation)
    c = locate(q, lower, h, shape, periodic)
    if interpolation == "bicubic":
        coef = bc.cell_coefficients(g, periodic)
        e, s = bc.grid_energy(coef, c), bc.grid_slope(coef, h, c)
    else:
        e, s = surf.energy(q), surf.slope(q)
    return np.max(np.abs(e - _smooth(*q.T))), np.max(np.abs(s - _smooth_slope(*q.T)))


@pytest.mark.parametrize("interpolation", ["bicubic", "bilinear"])
@pytest.mark.parametrize("periodic", [(True, True), (False, False)], ids=["torus", "plane"])
def test_order_of_the_surface_error(interpolation, periodic):
    """Energy O(h^3) and slope O(h^2) for bicubic; O(h^2) and O(h) for bilinear."""
    coarse, fine = (_surface_errors(interpolation, periodic, n) for n in (32, 64))
    for what, c, f in zip(("energy", "slope"), coarse, fine):
        lo, hi = ORDER_BANDS[(interpolation, what)]
        order = np.log2(c / f)
        assert lo <= order <= hi, f"{what}: order {order:.3f}"


def test_interpolation_is_validated():
    with pytest.raises(ValueError, match=r"interpolation must be one of \['bicubic', 'bilinear'\], got 'cubic'"):
        Surface(np.zeros((3, 3)), (0, 0), (1, 1), (False, False), interpolation="cubic")
    assert Surface(np.zeros((3, 3)), (0, 0), (1, 1), (False, False)).interpolation == "bilinear"


# =========================================================================== through scenes

#: FD scenes must keep this distance from every kink (cell edges: the force's derivative
#: jumps there); check_gradient_fd also detects a difference that crosses one.
KINK_MARGIN = 1e-4

#: Measured ensemble ratios of the energy error at dt and dt/2 (gamma = 0, 256 particles,
#: random 8 x 8 grids; docs/variants.md): bicubic 3.76-3.97 on the torus, 3.97-4.20 on the
#: plane inside walls; bilinear 1.89-2.15 on both.
SECOND_ORDER_RATIO = (3.5, 4.5)
FIRST_ORDER_MAX_RATIO = 2.6


def _scene_case(topology, kind, seed):
    """Bicubic grid + springs + external force; damped Verlet, damped GJF or quasistatic."""
    periodic = TOPOLOGIES[topology]
    rng = np.random.default_rng(seed)
    surf = Surface(rng.uniform(0, 1, (5, 4)), (0.0, -0.5), (1.2, 0.5), periodic, interpolation="bicubic")
    n = 2
    spring = pr.Spring(rng.uniform(0.5, 1.5, (n, 2)), surf.lower + rng.uniform(0.2, 0.8, (n, 2)) * surf.length)
    effects = [pr.PerParticle(rng.normal(0, 0.5, (n, 2)))]
    if kind == "quasistatic":
        scene = pr.Scene(surf, dt=0.05, n_steps=8, mode="quasistatic", mobility=rng.uniform(0.03, 0.05, 2),
                         spring=spring, effects=effects)
    else:
        scene = pr.Scene(surf, dt=0.05, n_steps=8, mass=rng.uniform(0.7, 1.5, (n, 1)),
                         damping=rng.uniform(0.2, 0.8, (n, 2)), spring=spring, effects=effects, integrator=kind)
    x0 = surf.lower + rng.uniform(0.1, 0.9, (n, 2)) * surf.length
    return scene, x0, rng.normal(0, 1.0, (n, 2))


def _kink_free_scene(topology, kind):
    for seed in range(50):
        scene, x0, v0 = _scene_case(topology, kind, seed)
        if pt.kink_distance(scene, pr.simulate(scene, x0, v0).x) > KINK_MARGIN:
            return scene, x0, v0
    raise AssertionError(f"no kink-free case for {topology}/{kind}")  # pragma: no cover


SCENE_CASES = [(t, "verlet") for t in TOPO_IDS] + [("torus", "gjf"), ("cylinder0", "quasistatic")]


@pytest.mark.parametrize("topology, kind", SCENE_CASES)
def test_every_gradient_of_a_bicubic_scene_matches_central_differences(topology, kind):
    scene, x0, v0 = _kink_free_scene(topology, kind)
    assert scene.field().interpolation == "bicubic"
    objective = pr.Funnel(0.3, "every_step") if kind == "quasistatic" else \
        pr.Quadratic(wx=1.0, wv=0.5, xref=0.3, vref=-0.2)
    check = pt.check_gradient_fd(pr.value_and_grad, scene, x0, v0, objective, full=True,
                                 kink_margin=KINK_MARGIN, regularization_weight=0.05)
    assert check.valid
    assert set(check.errors) == set(gradient_names(scene.mode, scene.spring is not None))
    for name, err in check.errors.items():
        assert err < FD_RTOL, f"{name}: relative error {err:.3e}"


def test_scenes_carry_the_interpolation():
    surf = Surface(np.arange(12.0).reshape(3, 4) ** 2, (0, 0), (1, 1), (False, True), interpolation="bicubic")
    scene = pr.Scene(surf, dt=0.1, n_steps=2)
    assert scene.with_values(np.ones((3, 4))).surface.interpolation == "bicubic"
    traj = pr.simulate(scene, [[0.3, 0.4]], [[0.5, 0.2]])
    h = surf.spacing
    e = bc.grid_energy(bc.cell_coefficients(surf.values, surf.periodic), locate(traj.x[:, 0], surf.lower, h, (3, 4),
                                                                               surf.periodic))
    np.testing.assert_allclose(pr.energy(scene, traj)[:, 0] - 0.5 * np.sum(traj.v[:, 0] ** 2, axis=1), e,
                               rtol=TRAJ_RTOL)
    bilinear = pr.simulate(pr.Scene(Surface(surf.values, surf.lower, surf.upper, surf.periodic), dt=0.1, n_steps=2),
                           [[0.3, 0.4]], [[0.5, 0.2]])
    assert not np.allclose(traj.x[-1], bilinear.x[-1])


def _energy_case(interpolation, topology, seed):
    """gamma = 0, 256 particles on a random 8 x 8 grid; on the plane, stiff walls keep every
    particle inside the span (its clip edge is a jump of the force, as on a bilinear grid)."""
    rng = np.random.default_rng(seed)
    periodic = TOPOLOGIES[topology]
    surf = Surface(rng.uniform(-1, 1, (8, 8)), (0, 0), (1, 1), periodic, interpolation=interpolation)
    x0, v0 = rng.uniform(0.3, 0.7, (256, 2)), rng.normal(0, 1, (256, 2))
    if topology == "torus":
        return pr.Scene(surf, dt=0.01, n_steps=150), x0, v0
    return pr.Scene(surf, dt=0.002, n_steps=400, walls=pr.Walls(2000.0, 0.2, np.ones((2, 2), bool))), x0, v0


@pytest.mark.parametrize("topology", ["torus", "plane"])
@pytest.mark.parametrize("interpolation", ["bicubic", "bilinear"])
def test_order_of_the_energy_error(interpolation, topology):
    """Velocity Verlet's energy error: second order on the C1 bicubic grid, first order on
    the bilinear one (whose force jumps at cell edges); the second asserts the check fails."""
    scene, x0, v0 = _energy_case(interpolation, topology, 0)
    r = pt.drift_ratio(pr.simulate, scene, x0, v0)
    if interpolation == "bicubic":
        if topology == "plane":
            assert np.max(np.abs(r.coarse.trajectory.x - 0.5)) < 0.5      # never at a clip edge
        assert SECOND_ORDER_RATIO[0] <= r.ensemble_ratio <= SECOND_ORDER_RATIO[1], r.ensemble_ratio
    else:
        assert r.ensemble_ratio < FIRST_ORDER_MAX_RATIO, r.ensemble_ratio


@pytest.mark.parametrize("topology", TOPO_IDS)
def test_surface_methods_follow_the_interpolation(topology):
    """``Surface.energy`` / ``Surface.slope`` evaluate the surface's own rule: bicubic
    values and slopes, not the bilinear ones, for an ``interpolation="bicubic"`` surface."""
    values, periodic, h = _grid(topology, (6, 5), seed=3)
    surf = Surface(values, LOWER, UPPER, periodic, interpolation="bicubic")
    q = _points(40, seed=4, margin=0.05)
    np.testing.assert_array_equal(surf.energy(q), bc.point_energy(values, LOWER, h, periodic, q))
    fd = np.stack([(surf.energy(q + FD_EPS * e) - surf.energy(q - FD_EPS * e)) / (2 * FD_EPS)
                   for e in np.eye(2)], axis=1)
    assert relative_error(surf.slope(q), fd) < FD_RTOL
    bilinear = Surface(values, LOWER, UPPER, periodic)
    assert relative_error(surf.slope(q), bilinear.slope(q)) > 1e-3   # the check can tell them apart
