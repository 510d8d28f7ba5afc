"""Unit tests of pes_ref.core.integrator: the time stepping of SPEC section 3 and its adjoint
(section 5), through the scene layer and directly."""
import dataclasses
import functools
import warnings

import numpy as np
import pytest

import pes_ref as pr
from _helpers import TOPOLOGIES, kink_distance
from pes_ref.core.integrator import simulate_dynamic
from pes_ref.testing.finite_differences import central_gradient
from pes_ref.oracle.compare import relative_error
from pes_ref.oracle.tolerances import FD_EPS, FD_RTOL, TRAJ_RTOL

#: One step computed by hand from SPEC section 3's formulas (a different association of
#: the same arithmetic as the package's sub-steps) agrees to a few ulps.
STEP_RTOL = 1e-14

#: FD scenes are accepted only if every state keeps this distance from every kink
#: (cell and clip edges, wall onsets, minimum-image seams): an input perturbation of
#: FD_EPS moves the states by far less.
KINK_MARGIN = 1e-3

MODES = ("dynamic", "quasistatic")


# =========================================================================== one step by hand

ALPHA, BETA = 0.8, -0.6          # the grid is the plane E = ALPHA q0 + BETA q1 (bilinear reproduces it)


def _hand_scene(mode, n_steps, damping=True):
    rng = np.random.default_rng(17)
    lower, upper, shape = np.array([0.0, 0.0]), np.array([2.0, 1.5]), (5, 4)
    q0 = lower[0] + (upper[0] - lower[0]) * np.arange(shape[0]) / (shape[0] - 1)
    q1 = lower[1] + (upper[1] - lower[1]) * np.arange(shape[1]) / (shape[1] - 1)
    values = ALPHA * q0[:, None] + BETA * q1[None, :]
    surf = pr.Surface(values, lower, upper, (False, False))
    n = 2
    k = np.array([[1.5, 0.5], [2.0, 3.0]])
    c = np.array([[1.1, 0.7], [0.9, 0.8]])
    fext = rng.uniform(-0.5, 0.5, (n_steps + 1, n, 2))
    kw = dict(mass=np.array([[0.7], [1.9]]), damping=np.array([[0.3, 0.1], [2.5, 0.05]]) if damping else None) \
        if mode == "dynamic" else dict(mobility=(0.05, 0.02))
    scene = pr.Scene(surf, dt=0.03, n_steps=n_steps, mode=mode, spring=pr.Spring(k, c),
                     effects=[pr.Schedule(fext)], **kw)
    x0 = np.array([[1.0, 0.75], [0.8, 0.6]])
    v0 = np.array([[0.4, -0.3], [-0.2, 0.5]])
    return scene, x0, v0, fext, k, c


def _hand_force(x, k, c, fext_n):
    """F = -grad(ALPHA q0 + BETA q1) - k (x - c) + F_ext[n], valid inside the domain."""
    return -np.array([ALPHA, BETA]) - k * (x - c) + fext_n


def _assert_close(got, want):
    np.testing.assert_allclose(got, want, rtol=STEP_RTOL, atol=STEP_RTOL * np.max(np.abs(want)))


@pytest.mark.parametrize("n_steps", [0, 1, 4])
@pytest.mark.parametrize("damped", [True, False])
def test_dynamic_steps_match_the_spec_formulas(n_steps, damped):
    scene, x0, v0, fext, k, c = _hand_scene("dynamic", n_steps, damping=damped)
    m = scene.mass
    g = scene.damping if damped else 0.0
    dt = scene.dt
    X, V = [x0], [v0]
    F = [_hand_force(x0, k, c, fext[0])]
    for n in range(n_steps):
        X.append(X[n] + dt * V[n] + dt ** 2 / (2 * m) * F[n])
        F.append(_hand_force(X[n + 1], k, c, fext[n + 1]))
        V.append(((1 - dt * g / (2 * m)) * V[n] + dt / (2 * m) * (F[n] + F[n + 1])) / (1 + dt * g / (2 * m)))
    traj = pr.simulate(scene, x0, v0)
    assert traj.x.shape == traj.v.shape == traj.f.shape == (n_steps + 1, 2, 2)
    assert np.all(np.abs(traj.x - 0.75) < 0.7)          # stayed inside the grid: the hand force applies
    _assert_close(traj.x, np.array(X))
    _assert_close(traj.v, np.array(V))
    _assert_close(traj.f, np.array(F))


@pytest.mark.parametrize("n_steps", [0, 1, 4])
def test_quasistatic_steps_match_the_spec_formula(n_steps):
    scene, x0, v0, fext, k, c = _hand_scene("quasistatic", n_steps)
    mu = np.array([0.05, 0.02])
    X = [x0]
    for n in range(n_steps):
        X.append(X[n] + mu * _hand_force(X[n], k, c, fext[n]))
    F = [_hand_force(X[n], k, c, fext[n]) for n in range(n_steps + 1)]
    traj = pr.simulate(scene, x0, v0)
    _assert_close(traj.x, np.array(X))
    _assert_close(traj.f, np.array(F))
    np.testing.assert_array_equal(traj.v, 0.0)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("n_steps", [0, 1, 2, 7])
def test_trajectory_holds_t_plus_one_states_starting_at_x0(mode, n_steps):
    scene, x0, v0, _, _, _ = _hand_scene(mode, n_steps)
    traj = pr.simulate(scene, x0, v0)
    for a in traj:
        assert a.shape == (n_steps + 1, 2, 2) and a.dtype == np.float64
    np.testing.assert_array_equal(traj.x[0], x0)
    np.testing.assert_array_equal(traj.v[0], v0 if mode == "dynamic" else 0.0)
    assert not np.shares_memory(traj.x, x0)


def test_damping_zero_in_the_damped_formula_is_velocity_verlet():
    """Velocity Verlet is reversible: stepping back with -V returns to the start."""
    scene, x0, v0, _, _, _ = _hand_scene("dynamic", 6, damping=False)
    scene = dataclasses.replace(scene, effects=())
    fwd = pr.simulate(scene, x0, v0)
    back = pr.simulate(scene, fwd.x[-1], -fwd.v[-1])
    np.testing.assert_allclose(back.x[-1], x0, rtol=1e3 * TRAJ_RTOL)
    np.testing.assert_allclose(-back.v[-1], v0, rtol=1e3 * TRAJ_RTOL)


# =========================================================================== gradients vs central differences

N, T, DT, R = 3, 14, 0.05, 0.05
PARAM_SHAPES = {  # a different broadcast shape per topology, so every reduction is exercised
    "plane": dict(k=(N, 2), mass=(N, 1), damping=()),
    "cylinder0": dict(k=(2,), mass=(), damping=(N, 2)),
    "cylinder1": dict(k=(N, 1), mass=(N, 2), damping=(2,)),
    "torus": dict(k=(), mass=(2,), damping=(N, 1)),
}


def _full_case(topology, mode, seed):
    """Grid + spring + walls (where the topology allows) + external force + damping."""
    periodic = TOPOLOGIES[topology]
    shapes = PARAM_SHAPES[topology]
    rng = np.random.default_rng(seed)
    surf = pr.Surface(rng.uniform(0, 1, (6, 5)), (0.0, -0.5), (1.2, 0.5), periodic)
    edges = np.array([[not periodic[0]] * 2, [not periodic[1]] * 2])
    walls = pr.Walls(40.0, 0.15, edges) if edges.any() else None
    spring = pr.Spring(rng.uniform(0.5, 1.5, shapes["k"]), surf.lower + rng.uniform(0.2, 0.8, (N, 2)) * surf.length)
    if mode == "dynamic":
        kw = dict(mass=rng.uniform(0.7, 1.5, shapes["mass"]), damping=rng.uniform(0.1, 0.5, shapes["damping"]))
    else:
        kw = dict(mobility=rng.uniform(0.02, 0.04, 2))
    scene = pr.Scene(surf, dt=DT, n_steps=T, mode=mode, spring=spring, walls=walls, **kw)
    x0 = surf.lower + rng.uniform(0.05, 0.95, (N, 2)) * surf.length
    v0 = rng.normal(0, 1.0, (N, 2))
    fext = rng.normal(0, 0.5, (T + 1, N, 2))
    objective = pr.Quadratic(wx=1.0, wv=0.5 if mode == "dynamic" else 0.0,
                             xref=rng.normal(0, 0.5, (T + 1, N, 2)), vref=rng.normal(0, 0.5, (T + 1, N, 2)))
    return scene, x0, v0, fext, objective


def _lean_case(topology, mode, seed):
    """Grid only, no damping, deterministic effects; particles may leave a non-periodic span."""
    periodic = TOPOLOGIES[topology]
    rng = np.random.default_rng(seed)
    surf = pr.Surface(rng.uniform(-1, 1, (5, 6)), (-1.0, 0.0), (0.0, 1.5), periodic)
    # (mobility: within the stability rule of the grid's curvature, mu c <= 2, docs/spec.md section 10)
    kw = dict(mass=rng.uniform(0.5, 1.0, (N, 1))) if mode == "dynamic" else dict(mobility=rng.uniform(0.015, 0.03, 2))
    effects = [pr.Constant(rng.normal(0, 1, 2)), pr.Window(pr.PerParticle(rng.normal(0, 2, (N, 2))), 0.2, 0.45)]
    scene = pr.Scene(surf, dt=DT, n_steps=T, mode=mode, effects=effects, t0=0.1, **kw)
    x0 = surf.lower + rng.uniform(0.05, 0.95, (N, 2)) * surf.length
    v0 = rng.normal(0, 2.0, (N, 2))
    objective = pr.Oscillator(amplitude=0.4, omega=3.0) if mode == "dynamic" else pr.Funnel(-0.3, "every_step")
    return scene, x0, v0, scene.schedule(N), objective


BUILDERS = {"full": _full_case, "lean": _lean_case}


@functools.lru_cache(maxsize=None)
def _case(kind, topology, mode):
    """The first seed whose trajectory stays KINK_MARGIN away from every kink (deterministic).
    Cached: the arrays are made read-only so that no test can change another's case."""
    for seed in range(50):
        scene, x0, v0, fext, objective = BUILDERS[kind](topology, mode, seed)
        traj = pr.simulate(scene, x0, v0, fext=fext)
        if kink_distance(scene.field(), traj.x) > KINK_MARGIN:
            for a in (x0, v0, fext):
                a.setflags(write=False)
            return scene, x0, v0, fext, objective
    raise AssertionError(f"no kink-free {kind} scene for {topology}/{mode}")  # pragma: no cover


def _loss(scene, x0, v0, fext, objective, weight):
    """The forward program alone: run, objective, regularization."""
    traj = pr.simulate(scene, x0, v0, fext=fext)
    value = objective.value_and_grad(traj.x, traj.v, scene.times())[0]
    return value + weight * float(np.sum(scene.surface.values ** 2))


def _fd_eps(param) -> float:
    """FD_EPS relative to the parameter's scale (SPEC tolerances: 'relative to the parameter's scale')."""
    scale = float(np.max(np.abs(param), initial=0.0))
    return FD_EPS * (scale if scale > 0 else 1.0)


def _perturbable(name, scene, x0, v0, fext):
    """(parameter, loss-input builder) for one gradient name."""
    if name == "values":
        return scene.surface.values, lambda z: dict(scene=scene.with_values(z))
    if name == "x0":
        return x0, lambda z: dict(x0=z)
    if name == "v0":
        return v0, lambda z: dict(v0=z)
    if name == "force":
        return fext, lambda z: dict(fext=z)
    if name in ("mass", "damping", "mobility"):
        return getattr(scene, name), lambda z: dict(scene=dataclasses.replace(scene, **{name: z}))
    k, c = (scene.spring.k, scene.spring.center) if scene.spring is not None else (None, None)
    if name == "spring_k":
        return k, lambda z: dict(scene=dataclasses.replace(scene, spring=pr.Spring(z, c)))
    if name == "spring_center":
        return c, lambda z: dict(scene=dataclasses.replace(scene, spring=pr.Spring(k, z)))
    raise KeyError(name)


NAMES = {
    ("full", "dynamic"): ["values", "x0", "v0", "force", "mass", "damping", "spring_k", "spring_center"],
    ("full", "quasistatic"): ["values", "x0", "force", "spring_k", "spring_center", "mobility"],
    ("lean", "dynamic"): ["values", "x0", "v0", "force", "mass"],
    ("lean", "quasistatic"): ["values", "x0", "force", "mobility"],
}
GRAD_CASES = [(kind, topology, mode, name) for (kind, mode), names in NAMES.items()
              for topology in sorted(TOPOLOGIES) for name in names]

#: The worst relative error seen per gradient name (printed at the end of the module with `pytest -s`).
WORST_FD_ERROR: dict = {}


@pytest.fixture(scope="module", autouse=True)
def _print_worst_fd_errors():
    yield
    if WORST_FD_ERROR:
        print("\nworst FD relative error per gradient name: "
              + ", ".join(f"{k}={v:.1e}" for k, v in sorted(WORST_FD_ERROR.items())))


@pytest.mark.parametrize("kind, topology, mode, name", GRAD_CASES)
def test_gradient_matches_central_differences(kind, topology, mode, name):
    scene, x0, v0, fext, objective = _case(kind, topology, mode)
    weight = R if kind == "full" else 0.0
    loss, grads, _ = pr.value_and_grad(scene, x0, v0, objective, regularization_weight=weight, fext=fext)
    base = dict(scene=scene, x0=x0, v0=v0, fext=fext, objective=objective, weight=weight)
    assert loss == pytest.approx(_loss(**base), rel=TRAJ_RTOL)
    param, build = _perturbable(name, scene, x0, v0, fext)
    fd = central_gradient(lambda z: _loss(**dict(base, **build(z))), param, eps=_fd_eps(param))
    got = grads[name]
    assert got.shape == np.shape(param)
    assert np.max(np.abs(fd)) > 0, "the loss does not depend on this input in this scene"
    err = relative_error(got, fd)
    WORST_FD_ERROR[name] = max(err, WORST_FD_ERROR.get(name, 0.0))
    assert err < FD_RTOL, f"{name}: relative error {err:.3e}"


@pytest.mark.parametrize("topology", sorted(TOPOLOGIES))
def test_quasistatic_force_gradient_at_T_is_zero(topology):
    scene, x0, v0, fext, objective = _case("full", topology, "quasistatic")
    _, grads, _ = pr.value_and_grad(scene, x0, v0, objective, fext=fext, wrt=["force"])
    np.testing.assert_array_equal(grads["force"][-1], 0.0)
    assert np.all(np.any(grads["force"][:-1] != 0, axis=(1, 2)))


SHORT_CASES = [(mode, n_steps, name) for mode in MODES for n_steps in (0, 1) for name in NAMES[("full", mode)]]


@pytest.mark.parametrize("mode, n_steps, name", SHORT_CASES)
def test_gradients_of_the_shortest_runs(mode, n_steps, name):
    """T = 0 (no step: only the objective's and the regularization's direct terms) and T = 1."""
    scene, x0, v0, fext, objective = _case("full", "plane", mode)
    scene = dataclasses.replace(scene, n_steps=n_steps)
    fext = fext[: n_steps + 1]
    objective = dataclasses.replace(objective, xref=objective.xref[: n_steps + 1], vref=objective.vref[: n_steps + 1])
    _, grads, traj = pr.value_and_grad(scene, x0, v0, objective, regularization_weight=R, fext=fext)
    assert traj.x.shape[0] == n_steps + 1
    base = dict(scene=scene, x0=x0, v0=v0, fext=fext, objective=objective, weight=R)
    param, build = _perturbable(name, scene, x0, v0, fext)
    fd = central_gradient(lambda z: _loss(**dict(base, **build(z))), param, eps=_fd_eps(param))
    got = grads[name]
    assert got.shape == np.shape(param)
    if np.max(np.abs(fd)) == 0.0:          # e.g. mass and force at T = 0: exactly no influence
        np.testing.assert_array_equal(got, 0.0)
    else:
        assert relative_error(got, fd) < FD_RTOL


@pytest.mark.parametrize("topology", sorted(TOPOLOGIES))
def test_damping_gradient_of_an_undamped_scene_is_the_derivative_at_zero(topology):
    """damping=None: dL/dgamma at gamma = 0, a scalar (docs/decisions.md item 1). The core
    trusts its inputs, so the central difference can straddle 0 there."""
    scene, x0, v0, fext, objective = _case("full", topology, "dynamic")
    scene = dataclasses.replace(scene, damping=None)
    _, grads, _ = pr.value_and_grad(scene, x0, v0, objective, fext=fext, wrt=["damping"])
    assert np.shape(grads["damping"]) == ()

    def loss(gamma):
        traj = simulate_dynamic(scene.field(), x0, v0, fext, scene.dt, scene.n_steps, scene.mass, gamma)
        return objective.value_and_grad(traj.x, traj.v, scene.times())[0]

    fd = central_gradient(lambda g: loss(float(g)), np.array(0.0))
    assert relative_error(grads["damping"], fd) < FD_RTOL


@pytest.mark.parametrize("mode", MODES)
def test_only_wanted_gradients_are_returned_and_they_do_not_change(mode):
    scene, x0, v0, fext, objective = _case("full", "cylinder0", mode)
    _, full, _ = pr.value_and_grad(scene, x0, v0, objective, fext=fext)
    _, part, _ = pr.value_and_grad(scene, x0, v0, objective, fext=fext, wrt=("x0", "spring_k"))
    assert set(part) == {"x0", "spring_k"}
    np.testing.assert_array_equal(part["x0"], full["x0"])
    np.testing.assert_array_equal(part["spring_k"], full["spring_k"])


# =========================================================================== past the stability limit

def _unstable(mode, cause):
    """A scene far past the stability limit (run with ``allow_unstable=True``: by default
    it is refused before the run, tests/core/test_stability_rule.py)."""
    surf = pr.Surface(np.zeros((4, 4)), (0, 0), (1, 1), (False, False))
    kw = dict(mobility=(1.0, 1.0)) if mode == "quasistatic" else {}
    term = dict(walls=pr.Walls(1e12, 0.1, np.ones((2, 2), bool))) if cause == "walls" \
        else dict(spring=pr.Spring(1e12, (0.5, 0.5)))
    return pr.Scene(surf, dt=1.0, n_steps=80, mode=mode, **term, **kw)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("cause", ["walls", "spring"])
@pytest.mark.parametrize("errstate", ["ignore", "warn"])
@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_a_run_past_the_stability_limit_raises_non_finite_error(mode, cause, errstate):
    """With NumPy's default (warn) or silenced error state, the package's own check fires."""
    scene = _unstable(mode, cause)
    with np.errstate(all=errstate):
        with pytest.raises(pr.NonFiniteError, match=r"non-finite at step \d+ \((dt|mobility)="):
            pr.simulate(scene, [[0.05, 0.3]], allow_unstable=True)
        with pytest.raises(pr.NonFiniteError):
            pr.value_and_grad(scene, [[0.05, 0.3]], None, pr.Funnel(), allow_unstable=True)


def test_non_finite_error_is_a_floating_point_error():
    assert issubclass(pr.NonFiniteError, FloatingPointError)


# The integrator runs its loop under its own errstate (docs/decisions.md, "Non-finite
# runs"), so NonFiniteError is raised whatever the caller's error state; conftest makes
# overflow raise, so this test fails if a bare NumPy FloatingPointError escapes.
@pytest.mark.parametrize("mode", MODES)
def test_a_run_past_the_stability_limit_under_strict_errstate(mode):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(pr.NonFiniteError):
            pr.simulate(_unstable(mode, "walls"), [[0.05, 0.3]], allow_unstable=True)
