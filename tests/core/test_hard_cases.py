"""Hard cases that must stay numerically stable.

Stiff terms near and past the explicit stability limit (:mod:`pes_ref.core.stability`),
huge surfaces, eq. (1) near its singularity, particles on the grid's special points,
tiny and long runs, a chaotic scene whose gradient grows exponentially (the growth is
measured and reported, not hidden), and input dtypes and memory layouts.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import pes_ref as pr
from pes_ref.core import stability
from pes_ref.devices.cspace import apf_energy
from pes_ref import testing as pt
from pes_ref.oracle.tolerances import FD_RTOL

#: Velocity Verlet on a harmonic mode (omega dt = w) conserves E - w^2/8 omega^2 q^2,
#: so max_n |E_n - E_0| <= (w^2/4) / (1 - w^2/4) E_0: the exact bound of a bounded
#: error; the factor leaves room for rounding over 10^4 steps only.
HARMONIC_BOUND_SLACK = 1.0 + 1e-9
#: A run's error over all of it / over its first quarter: ~1 when bounded, 2 diffusing
#: (random-sign errors per wall contact), 4 for a secular drift (docs/testing.md).
BOUNDED_GROWTH = 1.3
DIFFUSIVE_GROWTH = 3.0
#: Rounding of positions far from the origin: coordinates of size X carry ~eps X.
EPS = float(np.finfo(np.float64).eps)


def _plane(values=None, periodic=(False, False), shape=(3, 3), lower=(0.0, 0.0), upper=(1.0, 1.0)):
    values = np.zeros(shape) if values is None else values
    return pr.Surface(values, lower, upper, periodic)


# ============================================================================ stability limit

@pytest.mark.parametrize("c", [0.0, 0.1, 1.0, 10.0])
def test_damping_leaves_the_limit_at_two(c):
    """The damped step's amplification matrix (scaled harmonic mode, c = dt gamma / 2m)
    has spectral radius <= 1 up to omega dt = 2 and > 1 beyond, for every damping: the
    limit of :mod:`pes_ref.core.stability` does not depend on gamma."""
    def radius(w):
        y_row = np.array([1.0 - w * w / 2.0, 1.0])                          # y' = (1 - w^2/2) y + u
        u_row = (np.array([0.0, 1.0 - c]) - w * w / 2.0 * (np.array([1.0, 0.0]) + y_row)) / (1.0 + c)
        return float(np.max(np.abs(np.linalg.eigvals(np.array([y_row, u_row])))))
    assert radius(2.0 * (1 - 1e-6)) <= 1.0 + 1e-9
    assert radius(2.0 * (1 + 1e-3)) > 1.0


def test_limit_of_a_spring_is_exact():
    """One harmonic spring: dt_max = 2 sqrt(m / k) exactly, and the advice names it."""
    scene = pr.Scene(_plane(), dt=0.1, n_steps=10, mass=2.0, spring=pr.Spring([8.0, 2.0], [0.5, 0.5]))
    lim = stability.stability_limit(scene)
    assert lim.limit == pytest.approx(1.0, rel=1e-15)
    assert lim.ratio == pytest.approx(0.1)


def test_limit_of_a_sampled_parabola_is_its_curvature():
    """A grid sampling k/2 q0^2 has second differences k h^2: K_0 = k."""
    q = np.linspace(-1.0, 1.0, 21)
    scene = pr.Scene(_plane(np.outer(0.5 * 50.0 * q ** 2, np.ones(4)), lower=(-1, 0), upper=(1, 1)),
                     dt=0.1, n_steps=1)
    assert sum(stability.stability_limit(scene).terms.values()) == pytest.approx([50.0, 0.0])


@pytest.mark.parametrize("periodic", [(False, False), (True, False), (False, True), (True, True)])
def test_grid_stiffness_is_the_largest_second_difference(periodic):
    """One home for the grid's edge stiffness: ``grid_stiffness`` is the larger of the two
    axes' ``grid_second_difference``, and the same number, bit for bit, as the devices'
    own copy (:func:`pes_ref.devices.ratchet.grid_stiffness`) that will call it."""
    from pes_ref.devices.ratchet import grid_stiffness as devices_grid_stiffness
    rng = np.random.default_rng(9)
    surf = pr.Surface(rng.uniform(-3.0, 3.0, (9, 7)), (0.0, -1.0), (2.0, 0.5), periodic)
    per_axis = stability.grid_second_difference(surf)
    assert stability.grid_stiffness(surf) == max(per_axis) > 0.0
    assert stability.grid_stiffness(surf) == devices_grid_stiffness(surf)


def _stiff_scenes():
    """(name, scene, x0, v0) with one stiff linear term each, dynamic and quasistatic.

    (Neither a stiff *grid* nor a quasistatic wall is among them: the bilinear force is
    bounded by the grid's largest slope, so past its limit a run rattles across cells
    with a growing O(dt) energy error but never overflows (validation/barrier.py
    measures that); a quasistatic step past a one-sided wall's limit throws the
    particle out of the wall, where nothing pushes it further.)"""
    walls = pr.Walls(1e4, 0.2, [[True, True], [False, False]])
    return {
        "spring": (pr.Scene(_plane(), dt=1.0, n_steps=2000, spring=pr.Spring(1e4, [0.5, 0.5])),
                   [[0.6, 0.45]], [[0.0, 0.0]]),
        "walls": (pr.Scene(_plane(), dt=1.0, n_steps=2000, walls=walls), [[0.5, 0.5]], [[1.0, 0.0]]),
        "damped-walls": (pr.Scene(_plane(), dt=1.0, n_steps=2000, walls=walls, damping=0.5),
                         [[0.5, 0.5]], [[3.0, 0.0]]),
        "quasistatic-spring": (pr.Scene(_plane(), dt=1.0, n_steps=5000, mode="quasistatic", mobility=[1.0, 1.0],
                                        spring=pr.Spring(1e4, [0.5, 0.5])), [[0.6, 0.45]], [[0.0, 0.0]]),
    }


STIFF = _stiff_scenes()


def _at(scene, ratio):
    """The scene at ``ratio`` times its stability limit (dt, or the mobility)."""
    lim = stability.stability_limit(scene)
    if scene.mode == "dynamic":
        return replace(scene, dt=ratio * lim.limit)
    K = sum(lim.terms.values())                        # each axis at ``ratio`` of its own limit 2 / K_d
    return replace(scene, mobility=ratio * np.where(K > 0, 2.0 / np.where(K > 0, K, 1.0), 1.0))


@pytest.mark.parametrize("name", list(STIFF))
@pytest.mark.parametrize("ratio", [1.1, 3.0])
def test_past_the_limit_raises_naming_it(name, ratio):
    """Past the limit a scene is refused before the run (the rule of docs/spec.md section
    10); run anyway (``allow_unstable``), it stops with NonFiniteError naming the limit and a
    stable step in one line, never returning inf or NaN; the suggested step then runs."""
    scene, x0, v0 = STIFF[name]
    bad = _at(scene, ratio)
    lim = stability.stability_limit(bad)
    with pytest.raises(stability.UnstableStepError):
        pr.simulate(bad, x0, v0)
    with pytest.raises(pr.NonFiniteError) as err:
        pr.simulate(bad, x0, v0, allow_unstable=True)
    msg = str(err.value)
    assert msg.count("stability limit") == 1 and "\n" not in msg
    if scene.mode == "dynamic":
        assert f"the stability limit is dt < {lim.limit:.3g}" in msg
        assert f"a stable dt is {lim.suggestion:.3g}" in msg
        good = replace(bad, dt=lim.suggestion)
    else:
        assert "a stable mobility is" in msg
        good = replace(bad, mobility=lim.suggestion)
    assert np.isfinite(pr.simulate(good, x0, v0).x).all()
    with pytest.raises(pr.NonFiniteError, match="stability limit"):
        pr.value_and_grad(bad, x0, v0, pr.Funnel(0.0), allow_unstable=True)


def test_below_the_limit_harmonic_energy_is_bounded():
    """omega dt = 1.9 (0.95 of the limit), 10^4 steps: the energy error is large but
    within the exact bound (w^2/4)/(1 - w^2/4) E_0 and does not grow."""
    scene, x0, _ = STIFF["spring"]
    scene = replace(_at(scene, 0.95), n_steps=10_000)
    drift = pt.energy_drift(pr.simulate, scene, x0, np.zeros((1, 2)))
    w2 = (0.95 * 2.0) ** 2
    E0 = float(drift.energies[0].sum())
    assert drift.max_abs <= (w2 / 4) / (1 - w2 / 4) * E0 * HARMONIC_BOUND_SLACK
    assert drift.growth(0.25, ensemble=False) <= BOUNDED_GROWTH


@pytest.mark.parametrize("ratio", [0.3, stability.SAFETY])
def test_below_the_limit_wall_energy_is_bounded(ratio):
    """Stiff one-sided walls (k_w = 1e4) at the suggested step and below: each contact
    leaves an O((omega dt)^2) residue of random sign, so the error diffuses but stays
    within (omega dt)^2 K per contact. (Closer to the limit, omega dt > ~1.4, a
    one-sided wall pumps energy in at contacts: validation/barrier.py measures it.)"""
    scene, x0, v0 = STIFF["walls"]
    scene = replace(_at(scene, ratio), n_steps=10_000)
    drift = pt.energy_drift(pr.simulate, scene, x0, v0)
    assert drift.growth(0.25, ensemble=False) <= DIFFUSIVE_GROWTH
    assert drift.max_abs <= pt.energy_error_budget(scene, drift.trajectory)


# ============================================================================ huge values

def test_huge_surface_runs_at_the_advised_step():
    """Grid values of 1e12 with slopes of ~1e13: at the advised step the run stays
    finite, the energy error is the usual fraction of the energy, gradients are finite."""
    rng = np.random.default_rng(0)
    surf = _plane(1e12 * rng.uniform(0.0, 1.0, (6, 5)), periodic=(True, False))
    scene = pr.Scene(surf, dt=1.0, n_steps=200)
    scene = replace(scene, dt=stability.stability_limit(scene).suggestion)
    x0 = rng.uniform(0.0, 1.0, (3, 2))
    traj = pr.simulate(scene, x0, np.zeros((3, 2)))
    assert np.isfinite(traj.x).all() and np.abs(traj.f).max() > 1e12
    E = pr.energy(scene, traj).sum(axis=1)
    assert np.abs(E - E[0]).max() <= pt.energy_error_budget(scene, traj)
    _, g, _ = pr.value_and_grad(scene, x0, np.zeros((3, 2)), pr.Funnel(0.5))
    assert all(np.isfinite(v).all() for v in g.values())


def test_constant_offset_of_1e12_changes_only_rounding():
    """G + 1e12 moves every node value by the same amount: forces are differences of
    node values, so they change by rounding of 1e12 only (~eps 1e12 / h)."""
    rng = np.random.default_rng(1)
    G = rng.uniform(-1.0, 1.0, (5, 6))
    a = pr.Scene(_plane(G, periodic=(True, True)), dt=0.05, n_steps=50)
    b = a.with_values(G + 1e12)
    x0, v0 = rng.uniform(0.0, 1.0, (4, 2)), rng.uniform(-1.0, 1.0, (4, 2))
    ta, tb = pr.simulate(a, x0, v0), pr.simulate(b, x0, v0)
    force_rounding = 4 * EPS * 1e12 / float(a.surface.spacing.min())
    assert np.abs(ta.f[0] - tb.f[0]).max() <= force_rounding
    assert np.isfinite(tb.x).all()


@pytest.mark.parametrize("r_min", [1e-2, 1e-3])
def test_barrier_near_its_singularity(r_min):
    """Eq. (1) (v = 1, r_c = 0.5) sampled with a node a distance ``r_min`` from a point
    obstacle: values up to v/2 r_min^-2. A particle thrown at that node with half the
    largest value as kinetic energy climbs into the last cell; at the advised step it
    stays finite, is turned back, and its energy error stays within the run's budget."""
    n = 41
    q = np.linspace(-1.0, 1.0, n)
    r = np.hypot(q[:, None] - r_min, q[None, :])            # the node (0, 0) is the nearest
    G = apf_energy(r, 1.0, 0.5, r_min)
    assert G.max() >= 0.4 / r_min ** 2
    scene = pr.Scene(_plane(G, lower=(-1, -1), upper=(1, 1)), dt=1.0, n_steps=1)
    scene = replace(scene, dt=stability.stability_limit(scene).suggestion)
    speed = float(np.sqrt(G.max()))                          # kinetic energy G.max() / 2
    scene = replace(scene, n_steps=int(np.ceil(3.0 * 0.6 / speed / scene.dt)))
    x0, v0 = np.array([[-0.6, 1e-3]]), np.array([[speed, 0.0]])
    traj = pr.simulate(scene, x0, v0)
    assert np.isfinite(traj.x).all() and np.isfinite(traj.v).all()
    assert traj.x[:, 0, 0].max() > -0.05                     # it reached the last cell
    assert traj.v[-1, 0, 0] < 0.0                            # and was turned back
    E = pr.energy(scene, traj).sum(axis=1)
    assert np.abs(E - E[0]).max() <= pt.energy_error_budget(scene, traj)


def test_barrier_at_its_singularity_is_refused():
    """Eq. (1) itself at r = 0 is infinite: such a grid is a ValueError naming 'values'."""
    G = np.zeros((3, 3))
    G[1, 1] = np.inf
    with pytest.raises(ValueError, match="values"):
        _plane(G)


# ============================================================================ special points

TOPOLOGIES = {"plane": (False, False), "cylinder0": (True, False), "torus": (True, True)}


def _grid_surface(periodic):
    rng = np.random.default_rng(2)
    return pr.Surface(rng.uniform(-1.0, 1.0, (4, 5)), (-1.0, 0.5), (2.0, 2.5), periodic)


@pytest.mark.parametrize("periodic", list(TOPOLOGIES.values()), ids=list(TOPOLOGIES))
def test_particles_on_nodes_edges_and_corners(periodic):
    """On a node the energy is exactly the node's value; on every node, cell edge and
    corner the force is finite and is the slope of the cell at or above it (SPEC 1)."""
    surf = _grid_surface(periodic)
    n0, n1 = surf.shape
    nodes = np.array([[a, b] for a in surf.nodes(0) for b in surf.nodes(1)])
    G = surf.values.reshape(-1)
    assert np.allclose(surf.energy(nodes), G, rtol=0, atol=4 * EPS)
    h = surf.spacing
    edges = nodes + 0.5 * h * np.array([1.0, 0.0])
    corners = np.array([surf.lower, surf.upper, [surf.lower[0], surf.upper[1]], [surf.upper[0], surf.lower[1]]])
    pts = np.concatenate((nodes, edges, corners))
    scene = pr.Scene(surf, dt=0.01, n_steps=3)
    traj = pr.simulate(scene, pts, np.zeros_like(pts))
    assert np.isfinite(traj.f).all() and np.isfinite(traj.x).all()
    # just above a node (inside the cell the lookup picks) the slope is the same
    inside = nodes + 1e-12 * h
    keep = np.all(nodes < surf.upper - 0.5 * h, axis=1) | np.array(periodic)[None, :].all(axis=1)
    assert np.allclose(surf.slope(nodes[keep]), surf.slope(inside[keep]), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("periodic", [(True, False), (True, True)], ids=["cylinder0", "torus"])
def test_periodic_seam_is_seamless(periodic):
    """q = upper on a periodic axis is q = lower: same energy and force to rounding."""
    surf = _grid_surface(periodic)
    lo = np.array([[surf.lower[0], 1.1], [surf.lower[0], surf.lower[1]]])
    hi = lo.copy()
    hi[:, 0] = surf.upper[0]
    if periodic[1]:
        hi[1, 1] = surf.upper[1]
    assert np.allclose(surf.energy(hi), surf.energy(lo), rtol=0, atol=1e-12)
    assert np.allclose(surf.slope(hi), surf.slope(lo), rtol=0, atol=1e-12)


def test_far_outside_the_grid():
    """1e6 lengths outside a plane: slope 0 along the clipped axis, the edge's energy;
    with walls the push is k (a - q), finite at the advised step."""
    surf = _grid_surface((False, False))
    far = np.array([[1e6, 1.0], [-1e6, 1.0], [0.0, 1e6], [-1e6, -1e6]])
    s = surf.slope(far)
    assert s[0, 0] == 0 and s[1, 0] == 0 and s[2, 1] == 0 and np.all(s[3] == 0)
    assert surf.energy(far[3:]) == pytest.approx(surf.values[0, 0])
    scene = pr.Scene(surf, dt=1.0, n_steps=50, walls=pr.Walls(10.0, 0.1, [[True, True], [True, True]]))
    scene = replace(scene, dt=stability.stability_limit(scene).suggestion)
    traj = pr.simulate(scene, far, np.zeros_like(far))
    assert np.isfinite(traj.x).all()
    assert np.all(np.abs(traj.x[1:, far == 1e6] < 1e6))      # pushed back inward from the far side
    E = pr.energy(scene, traj).sum(axis=1)
    assert np.abs(E - E[0]).max() <= pt.energy_error_budget(scene, traj)


def test_torus_across_many_periods():
    """A particle fast enough to cross ~1000 periods: the forces along the run equal
    those looked up at the wrapped positions, to the rounding of coordinates ~1e3 L."""
    surf = _grid_surface((True, True))
    scene = pr.Scene(surf, dt=0.05, n_steps=2000)
    v0 = np.array([[2000.0 * surf.length[0] / 100.0, 1300.0 * surf.length[1] / 100.0]])
    traj = pr.simulate(scene, [[0.3, 1.1]], v0)
    periods = np.abs(traj.x[-1, 0] - traj.x[0, 0]) / surf.length
    assert periods.min() > 500
    wrapped = surf.wrap(traj.x[:, 0])
    X = float(np.abs(traj.x).max())
    slope_rounding = 8 * EPS * X * pt.grid_slope_bound(surf).max() / float(surf.spacing.min())
    # no state is close enough to a cell edge for rounding to switch its cell (else the
    # two lookups could legitimately pick neighbouring cells): the fixed case is chosen so
    assert pt.kink_distance(scene, traj.x) > 1e3 * EPS * X
    assert np.abs(surf.slope(wrapped) + traj.f[:, 0]).max() <= slope_rounding


# ============================================================================ tiny runs

@pytest.mark.parametrize("n_steps", [0, 1])
@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
def test_single_particle_on_a_2x2_grid(n_steps, mode):
    """One particle, a 2 x 2 torus, T = 0 and T = 1: shapes, and every gradient against
    central differences entry by entry."""
    surf = pr.Surface([[0.0, 1.0], [0.5, -0.3]], (0.0, 0.0), (1.0, 1.0), (True, True))
    kw = dict(mobility=[0.05, 0.05]) if mode == "quasistatic" else dict(mass=1.3, damping=0.2)
    scene = pr.Scene(surf, dt=0.1, n_steps=n_steps, mode=mode, spring=pr.Spring(1.0, [0.4, 0.4]),
                     effects=(pr.Constant([0.1, 0.2]),), **kw)
    x0, v0 = np.array([[0.3, 0.2]]), np.array([[0.4, -0.2]])
    traj = pr.simulate(scene, x0, v0)
    assert traj.x.shape == (n_steps + 1, 1, 2)
    check = pt.check_gradient_fd(pr.value_and_grad, scene, x0, v0, pr.Quadratic(wx=1.0, wv=0.5, xref=[0.5, 0.5]),
                                 full=True, kink_margin=1e-5)
    assert check.valid
    assert check.max_error < FD_RTOL, check.errors


# ============================================================================ long horizons

def test_hundred_thousand_steps_bounded_energy():
    """10^5 steps, gamma = 0, two springs of incommensurate frequency on a constant
    grid: the O(dt^2) energy error stays within its bound and does not drift."""
    scene = pr.Scene(_plane(), dt=0.05, n_steps=100_000, spring=pr.Spring([3.0, 5.0], [0.5, 0.5]))
    drift = pt.energy_drift(pr.simulate, scene, [[0.3, 0.6]], [[0.1, 0.4]])
    w = pt.max_frequency(scene) * scene.dt
    assert drift.max_abs <= 0.3 * w ** 2 * drift.kinetic_scale
    assert drift.growth(0.25, ensemble=False) <= BOUNDED_GROWTH


def test_adjoint_over_ten_thousand_steps():
    """10^4 steps, damped, spring on a constant torus: the adjoint is finite and matches
    a central difference (no kinks: smooth scene)."""
    surf = _plane(np.full((3, 3), 0.2), periodic=(False, False))
    scene = pr.Scene(surf, dt=0.02, n_steps=10_000, damping=0.01, spring=pr.Spring([2.0, 3.0], [0.5, 0.5]),
                     effects=(pr.Constant([0.1, 0.0]),))
    x0, v0 = np.array([[0.2, 0.7]]), np.array([[0.5, 0.0]])
    _, g, _ = pr.value_and_grad(scene, x0, v0, pr.Funnel(0.3, "every_step"))
    assert all(np.isfinite(v).all() for v in g.values())
    check = pt.check_gradient_fd(pr.value_and_grad, scene, x0, v0, pr.Funnel(0.3, "every_step"),
                                 names=("x0",), kink_margin=0.0)
    assert check.max_error < FD_RTOL, check.errors


#: Horizons of the chaotic scene's gradient (t = 4 ... 32 at dt = 0.02).
CHAOS_STEPS = (200, 400, 800, 1600)


def test_chaotic_gradient_growth_is_reported(record_property, capsys):
    """A chaotic scene: the gradient stays finite and grows exponentially; the rate is
    printed and recorded (validation/gradients.py tabulates it), not hidden."""
    scene, x0, v0 = pt.chaotic_case()
    rate, norms = pt.gradient_growth_rate(pr.value_and_grad, scene, x0, v0,
                                          pr.Quadratic(wx=1.0, wv=0.0, xref=[0.0, 0.0]), CHAOS_STEPS)
    assert np.isfinite(norms).all()
    assert rate > 0.1 and np.all(np.diff(norms) > 0)
    record_property("chaotic_gradient_growth_rate", rate)
    with capsys.disabled():
        print(f"\n[hard cases] chaotic scene: |dL/dx0| grows like exp({rate:.3f} t) "
              f"(|g| = {norms[0]:.3g} at t = 4 -> {norms[-1]:.3g} at t = 32)")


# ============================================================================ dtypes and layouts

def _inputs(kind):
    """Every array input of a scene, as float64 (reference) or in another dtype/layout."""
    rng = np.random.default_rng(3)
    arrays = {
        "values": rng.integers(-3, 4, (4, 6)).astype(np.float64),
        "x0": np.array([[0.25, 0.5], [0.75, 0.25]]),
        "v0": np.array([[0.5, -0.25], [0.0, 0.5]]),
        "mass": np.array([[1.0], [2.0]]),
        "damping": np.array([0.5, 0.25]),
        "spring_k": np.array([2.0, 1.0]),
        "spring_center": np.array([0.5, 0.5]),
        "fext": rng.integers(-2, 3, (21, 2, 2)) / 4.0,
    }
    out = {}
    for name, a in arrays.items():
        if kind == "float32":
            b = a.astype(np.float32)
        elif kind == "integer":
            b = np.round(a * 4).astype(np.int64)
            arrays[name] = b.astype(np.float64)                # the exact reference
        elif kind == "readonly":
            b = a.copy()
            b.setflags(write=False)
        elif kind == "noncontiguous":
            big = np.zeros(a.shape + (3,))
            big[..., 1] = a
            b = big[..., 1]
            assert not b.flags.c_contiguous or b.ndim == 0
        else:
            b = a
        out[name] = b
    if kind == "integer":                                       # positive physical inputs
        for name in ("mass", "spring_k"):
            out[name] = np.maximum(out[name], 1)
            arrays[name] = out[name].astype(np.float64)
    return arrays, out


def _run(a):
    surf = pr.Surface(a["values"], (0, 0), (2, 3), (True, False))
    scene = pr.Scene(surf, dt=0.05, n_steps=20, mass=a["mass"], damping=a["damping"],
                     spring=pr.Spring(a["spring_k"], a["spring_center"]))
    traj = pr.simulate(scene, a["x0"], a["v0"], fext=a["fext"])
    loss, g, _ = pr.value_and_grad(scene, a["x0"], a["v0"], pr.Funnel(0.5), fext=a["fext"])
    return traj, loss, g


@pytest.mark.parametrize("kind", ["float32", "integer", "readonly", "noncontiguous"])
def test_dtypes_and_layouts(kind):
    """float32 and integer inputs are promoted to float64 (same results as the float64
    values they hold); read-only and non-contiguous arrays work; no input is modified."""
    ref, given = _inputs(kind)
    before = {k: np.array(v, copy=True) for k, v in given.items()}
    t, loss, g = _run(given)
    t_ref, l_ref, g_ref = _run(ref)
    assert t.x.dtype == np.float64 and all(v.dtype == np.float64 for v in g.values())
    if kind == "float32":      # the reference is the float64 value each float32 holds
        t_ref, l_ref, g_ref = _run({k: v.astype(np.float32).astype(np.float64) for k, v in ref.items()})
    assert np.array_equal(t.x, t_ref.x) and loss == l_ref
    for name in g_ref:
        assert np.array_equal(g[name], g_ref[name]), name
    for name, v in given.items():
        assert np.array_equal(v, before[name]) and v.dtype == before[name].dtype, f"{name} was modified"
