"""Unit tests of pes_ref.core.terms: springs and walls (SPEC section 2)."""
import numpy as np
import pytest

from pes_ref import Spring, Walls
from pes_ref.core.terms import (spring_add_force, spring_delta, spring_energy, spring_force_vjp, wall_add_force,
                           wall_bounds, wall_energy, wall_force_vjp)
from pes_ref.testing.finite_differences import central_gradient, check_vjp
from pes_ref.oracle.compare import relative_error
from _helpers import assert_dot
from pes_ref.oracle.tolerances import FD_RTOL, TRAJ_ATOL, TRAJ_RTOL

LOWER = np.array([0.0, -1.0])
UPPER = np.array([1.0, 1.0])
LENGTH = UPPER - LOWER                       # (1, 2)
PERIODICS = [(False, False), (True, False), (False, True), (True, True)]
PER_IDS = ["plane", "cylinder0", "cylinder1", "torus"]

#: Keep points at least this far from the minimum-image seam and the wall onset.
KINK_MARGIN = 0.05


def _spring_force(q, k, c, periodic):
    out = np.zeros_like(q)
    spring_add_force(q, k, c, LENGTH, periodic, out)
    return out



def _spring_points(periodic, n, seed):
    """Points and centers whose minimum-image deltas stay KINK_MARGIN away from the seam
    (points far off in unwrapped coordinates included)."""
    rng = np.random.default_rng(seed)
    c = LOWER + rng.uniform(0, 1, (n, 2)) * LENGTH
    delta = rng.uniform(-0.5 + KINK_MARGIN, 0.5 - KINK_MARGIN, (n, 2)) * LENGTH
    q = c + delta
    for d in range(2):
        if periodic[d]:
            q[:, d] += rng.integers(-5, 6, n) * LENGTH[d]
    return q, c


# --------------------------------------------------------------------------- springs

def test_spring_energy_and_force_by_hand():
    # k = (2, 3), c = (0.5, 0), q = (0.9, -0.5): delta = (0.4, -0.5)
    # U = 2/2 * 0.16 + 3/2 * 0.25 = 0.535 ; F = -k delta = (-0.8, 1.5)
    q = np.array([[0.9, -0.5]])
    k, c = np.array([2.0, 3.0]), np.array([0.5, 0.0])
    np.testing.assert_allclose(spring_energy(q, k, c, LENGTH, (False, False)), [0.535], rtol=TRAJ_RTOL)
    np.testing.assert_allclose(_spring_force(q, k, c, (False, False)), [[-0.8, 1.5]], rtol=TRAJ_RTOL)


@pytest.mark.parametrize("axis", [0, 1])
@pytest.mark.parametrize("periods", [0, 1, -3])
def test_spring_minimum_image_across_the_seam(axis, periods):
    """A center just above lower and a point just below upper are close across the seam."""
    periodic = (axis == 0, axis == 1)
    k = np.array([4.0, 4.0])
    c = np.array([0.5, 0.0])
    q = np.array([[0.5, 0.0]])
    c[axis] = LOWER[axis] + 0.05
    q[0, axis] = UPPER[axis] - 0.05 + periods * LENGTH[axis]
    # minimum image: delta = -0.1 (not L - 0.1), so U = 4/2 * 0.01 and the force pushes +0.4 across the seam
    want_delta = np.zeros((1, 2))
    want_delta[0, axis] = -0.1
    np.testing.assert_allclose(spring_delta(q, c, LENGTH, periodic), want_delta, atol=TRAJ_ATOL)
    np.testing.assert_allclose(spring_energy(q, k, c, LENGTH, periodic), [0.02], rtol=TRAJ_RTOL)
    np.testing.assert_allclose(_spring_force(q, k, c, periodic), -k * want_delta, atol=TRAJ_ATOL)


@pytest.mark.parametrize("axis", [0, 1])
def test_spring_on_a_non_periodic_axis_has_no_minimum_image(axis):
    c = np.array([0.5, 0.0])
    q = c.copy()[None]
    c[axis] = LOWER[axis] + 0.05
    q[0, axis] = UPPER[axis] - 0.05
    delta = spring_delta(q, c, LENGTH, (False, False))
    np.testing.assert_allclose(delta[0, axis], LENGTH[axis] - 0.1, rtol=TRAJ_RTOL)


def test_spring_delta_does_not_modify_its_inputs():
    q, c = _spring_points((True, True), 4, 0)
    q0, c0 = q.copy(), c.copy()
    spring_delta(q, c, LENGTH, (True, True))
    np.testing.assert_array_equal(q, q0)
    np.testing.assert_array_equal(c, c0)


@pytest.mark.parametrize("periodic", PERIODICS, ids=PER_IDS)
def test_spring_force_is_minus_gradient_of_energy(periodic):
    q, c = _spring_points(periodic, 5, 1)
    k = np.array([1.5, 0.7])
    fd = central_gradient(lambda p: np.sum(spring_energy(p, k, c, LENGTH, periodic)), q)
    assert relative_error(_spring_force(q, k, c, periodic), -fd) < FD_RTOL


def test_spring_add_force_accumulates():
    q, c = _spring_points((False, False), 3, 2)
    k = np.array([1.0, 2.0])
    base = np.full((3, 2), 0.25)
    out = base.copy()
    spring_add_force(q, k, c, LENGTH, (False, False), out)
    np.testing.assert_allclose(out - base, _spring_force(q, k, c, (False, False)), rtol=TRAJ_RTOL)


@pytest.mark.parametrize("periodic", PERIODICS, ids=PER_IDS)
@pytest.mark.parametrize("wrt", ["q", "k", "center"])
def test_spring_force_vjp_dot_product(periodic, wrt):
    n = 5
    q, c = _spring_points(periodic, n, 3)
    k = np.random.default_rng(4).uniform(0.5, 2.0, (n, 2))
    args = {"q": q, "k": k, "center": c}

    def f(z):
        a = dict(args, **{wrt: z})
        return _spring_force(a["q"], a["k"], a["center"], periodic)

    def vjp(z, w):
        a = dict(args, **{wrt: z})
        xbar = np.zeros((n, 2))
        kbar, cbar = spring_force_vjp(a["q"], a["k"], a["center"], LENGTH, periodic, w, xbar,
                                      want_k=True, want_center=True)
        return {"q": xbar, "k": kbar, "center": cbar}[wrt]

    assert_dot(*check_vjp(f, vjp, args[wrt], np.random.default_rng(5)))


def test_spring_force_vjp_adds_into_xbar_and_skips_unwanted():
    q, c = _spring_points((False, False), 3, 6)
    k = np.array([1.0, 2.0])
    w = np.ones((3, 2))
    xbar = np.full((3, 2), 10.0)
    kbar, cbar = spring_force_vjp(q, k, c, LENGTH, (False, False), w, xbar, want_k=False, want_center=False)
    assert kbar is None and cbar is None
    np.testing.assert_allclose(xbar, 10.0 - k * w, rtol=TRAJ_RTOL)


# --------------------------------------------------------------------------- walls

EDGES = [(d, side) for d in range(2) for side in (0, 1)]
EDGE_IDS = ["q0_lower", "q0_upper", "q1_lower", "q1_upper"]
K_WALL = 50.0
MARGIN = 0.1


def _one_wall(d, side):
    walls = np.zeros((2, 2), dtype=bool)
    walls[d, side] = True
    return wall_bounds(LOWER, UPPER, MARGIN, walls)


def _wall_force(q, lo, hi, k=K_WALL):
    out = np.zeros_like(q)
    wall_add_force(q, k, lo, hi, out)
    return out


@pytest.mark.parametrize("d, side", EDGES, ids=EDGE_IDS)
def test_wall_bounds_one_edge(d, side):
    lo, hi = _one_wall(d, side)
    for e in range(2):
        want_lo = LOWER[e] + MARGIN if (e, 0) == (d, side) else -np.inf
        want_hi = UPPER[e] - MARGIN if (e, 1) == (d, side) else np.inf
        assert lo[e] == want_lo and hi[e] == want_hi


@pytest.mark.parametrize("d, side", EDGES, ids=EDGE_IDS)
@pytest.mark.parametrize("depth", [0.05, 0.3, 2.0])
def test_wall_energy_and_force_by_hand_on_each_edge(d, side, depth):
    lo, hi = _one_wall(d, side)
    wall = LOWER[d] + MARGIN if side == 0 else UPPER[d] - MARGIN
    outward = -1.0 if side == 0 else 1.0
    q = np.array([[0.5, 0.0]])
    q[0, d] = wall + outward * depth
    # U = k/2 depth^2 ; the force pushes back inward with k depth
    np.testing.assert_allclose(wall_energy(q, K_WALL, lo, hi), [0.5 * K_WALL * depth ** 2], rtol=TRAJ_RTOL)
    want = np.zeros((1, 2))
    want[0, d] = -outward * K_WALL * depth
    np.testing.assert_allclose(_wall_force(q, lo, hi), want, rtol=TRAJ_RTOL, atol=TRAJ_ATOL)


@pytest.mark.parametrize("d, side", EDGES, ids=EDGE_IDS)
def test_wall_is_zero_inside_and_beyond_disabled_edges(d, side):
    lo, hi = _one_wall(d, side)
    rng = np.random.default_rng(7)
    inside = LOWER + MARGIN + rng.uniform(0, 1, (20, 2)) * (LENGTH - 2 * MARGIN)
    # far beyond the three disabled edges (but on the inner side of the enabled one)
    beyond = []
    for e, s in EDGES:
        if (e, s) == (d, side):
            continue
        p = np.array([0.5, 0.0])
        p[e] = (LOWER[e] - 5.0) if s == 0 else (UPPER[e] + 5.0)
        beyond.append(p)
    q = np.vstack([inside, beyond])
    np.testing.assert_array_equal(wall_energy(q, K_WALL, lo, hi), 0.0)
    np.testing.assert_array_equal(_wall_force(q, lo, hi), 0.0)


def _wall_points(n, seed):
    """Points at least KINK_MARGIN from the wall onsets, inside the walls and between them."""
    rng = np.random.default_rng(seed)
    q = np.empty((n, 2))
    for d in range(2):
        a, b = LOWER[d] + MARGIN, UPPER[d] - MARGIN
        choice = rng.integers(0, 3, n)
        q[:, d] = np.where(choice == 0, a - rng.uniform(KINK_MARGIN, 1.0, n),
                           np.where(choice == 1, b + rng.uniform(KINK_MARGIN, 1.0, n),
                                    rng.uniform(a + KINK_MARGIN, b - KINK_MARGIN, n)))
        q[0, d] = a - 0.2          # at least one point in a wall on each axis
    return q


ALL_WALLS = np.ones((2, 2), dtype=bool)


def test_wall_force_is_minus_gradient_of_energy():
    lo, hi = wall_bounds(LOWER, UPPER, MARGIN, ALL_WALLS)
    q = _wall_points(12, 8)
    fd = central_gradient(lambda p: np.sum(wall_energy(p, K_WALL, lo, hi)), q)
    assert relative_error(_wall_force(q, lo, hi), -fd) < FD_RTOL


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_wall_force_vjp_dot_product(seed):
    lo, hi = wall_bounds(LOWER, UPPER, MARGIN, ALL_WALLS)
    q = _wall_points(9, seed)

    def vjp(p, w):
        xbar = np.zeros_like(p)
        wall_force_vjp(p, K_WALL, lo, hi, w, xbar)
        return xbar

    assert_dot(*check_vjp(lambda p: _wall_force(p, lo, hi), vjp, q, np.random.default_rng(seed)))


def test_wall_force_vjp_adds_only_where_active():
    lo, hi = wall_bounds(LOWER, UPPER, MARGIN, ALL_WALLS)
    q = np.array([[0.5, 0.0], [-0.3, 0.0], [0.5, 0.95]])   # free; in the q0 lower wall; in the q1 upper wall
    w = np.ones((3, 2))
    xbar = np.full((3, 2), 3.0)
    wall_force_vjp(q, K_WALL, lo, hi, w, xbar)
    np.testing.assert_array_equal(xbar, [[3.0, 3.0], [3.0 - K_WALL, 3.0], [3.0, 3.0 - K_WALL]])


# --------------------------------------------------------------------------- validation

def test_spring_promotes_and_keeps_broadcast_shapes():
    s = Spring(k=np.array([1, 2], dtype=np.int32), center=np.zeros((3, 1), dtype=np.float32))
    assert s.k.dtype == np.float64 and s.k.shape == (2,)
    assert s.center.dtype == np.float64 and s.center.shape == (3, 1)


@pytest.mark.parametrize("k, center, exc, name", [
    (-1.0, 0.0, ValueError, "spring_k"),
    ([1.0, -0.1], 0.0, ValueError, "spring_k"),
    (np.nan, 0.0, ValueError, "spring_k"),
    ([1.0, 2.0, 3.0], 0.0, ValueError, "spring_k"),
    (np.ones((2, 2, 2)), 0.0, ValueError, "spring_k"),
    ("stiff", 0.0, TypeError, "spring_k"),
    (1.0, [np.inf, 0.0], ValueError, "spring_center"),
    (1.0, np.zeros((2, 3)), ValueError, "spring_center"),
    (1.0, np.zeros((1, 2, 2)), ValueError, "spring_center"),
    (1.0, [1j, 0], TypeError, "spring_center"),
])
def test_spring_validation_names_the_argument(k, center, exc, name):
    with pytest.raises(exc, match=rf"\b{name}\b"):
        Spring(k, center)


def test_walls_promotes():
    w = Walls(k=10, margin=0, edges=[[1, 0], [0, 1]])
    assert type(w.k) is float and type(w.margin) is float
    assert w.edges.dtype == bool and w.edges.tolist() == [[True, False], [False, True]]


@pytest.mark.parametrize("k, margin, edges, exc, name", [
    (0.0, 0.1, ALL_WALLS, ValueError, "wall_k"),
    (-5.0, 0.1, ALL_WALLS, ValueError, "wall_k"),
    (np.inf, 0.1, ALL_WALLS, ValueError, "wall_k"),
    ([1.0, 2.0], 0.1, ALL_WALLS, ValueError, "wall_k"),
    (True, 0.1, ALL_WALLS, TypeError, "wall_k"),
    (1.0, -0.1, ALL_WALLS, ValueError, "wall_margin"),
    (1.0, np.nan, ALL_WALLS, ValueError, "wall_margin"),
    (1.0, 0.1, [True, True], ValueError, "walls"),
    (1.0, 0.1, [[2, 0], [0, 0]], ValueError, "walls"),
    (1.0, 0.1, [["a", "b"], ["c", "d"]], TypeError, "walls"),
])
def test_walls_validation_names_the_argument(k, margin, edges, exc, name):
    with pytest.raises(exc, match=rf"\b{name}\b"):
        Walls(k, margin, edges)


# --------------------------------------------------------------------------- the hot loop's kernels

@pytest.mark.parametrize("periodic", PERIODICS, ids=PER_IDS)
@pytest.mark.parametrize("want_k, want_center", [(True, True), (True, False), (False, True), (False, False)])
def test_spring_kernels_are_bit_identical_to_the_functions(periodic, want_k, want_center):
    """The forward kernel's add_force and the adjoint kernel's force_vjp over stored states
    (descending, as a backward pass calls it) equal the functions, bit for bit."""
    from pes_ref.core.terms import SpringAdjoint, SpringKernel
    rng = np.random.default_rng(21)
    T1, N = 5, 7
    c = _spring_points(periodic, N, 21)[1]
    xs = np.stack([_spring_points(periodic, N, 21 + t)[0] for t in range(T1)])
    k, ws = rng.uniform(0.5, 2.0, (N, 2)), rng.standard_normal((T1, N, 2))
    base = rng.standard_normal((N, 2))
    got, want = base.copy(), base.copy()
    SpringKernel(k, c, LENGTH, periodic, N).add_force(xs[0], got)
    spring_add_force(xs[0], k, c, LENGTH, periodic, want)
    assert got.tobytes() == want.tobytes()
    adj = SpringAdjoint(k, c, LENGTH, periodic, xs, want_k, want_center)
    got_x, want_x = base.copy(), base.copy()
    want_k_sum, want_c_sum = np.zeros((N, 2)), np.zeros((N, 2))
    for n in range(T1 - 1, -1, -1):
        adj.force_vjp(n, ws[n], got_x)
        kbar, cbar = spring_force_vjp(xs[n], k, c, LENGTH, periodic, ws[n], want_x, want_k, want_center)
        if want_k:
            want_k_sum += kbar
        if want_center:
            want_c_sum += cbar
    assert got_x.tobytes() == want_x.tobytes()
    grads = adj.gradients()
    assert sorted(grads) == sorted(name for name, on in (("spring_k", want_k), ("spring_center", want_center)) if on)
    for name, want_sum in (("spring_k", want_k_sum), ("spring_center", want_c_sum)):
        if name in grads:
            assert grads[name].tobytes() == want_sum.tobytes()


@pytest.mark.parametrize("edges", [[[True, True], [True, True]], [[True, False], [False, True]],
                                   [[True, True], [False, False]]], ids=["all", "two", "axis0"])
@pytest.mark.parametrize("chunk", [8, 1 << 14], ids=["chunked", "one-chunk"])
def test_wall_kernels_are_bit_identical_to_the_functions(monkeypatch, edges, chunk):
    """The forward kernel's add_force and the adjoint kernel's force_vjp over stored states
    (a chunk of ``k s`` factors at a time, partial chunks included) equal the functions."""
    from pes_ref.core.terms import WallAdjoint, WallKernel
    monkeypatch.setattr(WallAdjoint, "CHUNK_ELEMENTS", chunk)
    rng = np.random.default_rng(22)
    lo, hi = wall_bounds(LOWER, UPPER, 0.1, np.array(edges))
    T1, N = 9, 3
    xs = LOWER + rng.uniform(-0.3, 1.3, (T1, N, 2)) * LENGTH
    ws = rng.standard_normal((T1, N, 2))
    base = rng.standard_normal((N, 2))
    got, want = base.copy(), base.copy()
    WallKernel(50.0, lo, hi, N).add_force(xs[0], got)
    wall_add_force(xs[0], 50.0, lo, hi, want)
    assert got.tobytes() == want.tobytes() and not np.array_equal(got, base)
    adj = WallAdjoint(50.0, lo, hi, xs)
    got, want = base.copy(), base.copy()
    for n in range(T1 - 1, -1, -1):
        adj.force_vjp(n, ws[n], got)
        wall_force_vjp(xs[n], 50.0, lo, hi, ws[n], want)
    assert got.tobytes() == want.tobytes() and not np.array_equal(got, base)
    assert adj.gradients() == {}
