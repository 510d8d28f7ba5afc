"""Unit tests of pes_ref.core.forces: the total conservative force, its adjoint, and the
guarantee that an effect a scene does not name costs nothing."""
import numpy as np
import pytest

import pes_ref as pr
import pes_ref.core.forces as forces_mod
import pes_ref.core.scene as scene_mod
from _helpers import TOPOLOGIES, assert_dot, kink_distance
from pes_ref.core.forces import GradAccumulator, force, force_vjp, potential_energy
from pes_ref.testing.finite_differences import central_gradient, check_vjp, relative_error
from pes_ref.oracle.tolerances import FD_RTOL, TRAJ_RTOL

N = 6
#: Points used in derivative checks keep at least this distance from every kink.
KINK_MARGIN = 1e-2

TERMS = ["grid", "grid+spring", "grid+walls", "grid+spring+walls"]
CASES = [(t, terms) for t in sorted(TOPOLOGIES) for terms in TERMS
         if not ("walls" in terms and t == "torus")]


def _walls_for(periodic, k=30.0, margin=0.15):
    edges = np.array([[not periodic[0]] * 2, [not periodic[1]] * 2])
    return pr.Walls(k, margin, edges)


def _scene(topology, terms, seed=0, **kw):
    periodic = TOPOLOGIES[topology]
    rng = np.random.default_rng(seed)
    surf = pr.Surface(rng.uniform(-1, 1, (6, 5)), (0.0, -0.5), (1.2, 0.5), periodic)
    spring = pr.Spring(rng.uniform(0.5, 2.0, (N, 2)), surf.lower + rng.uniform(0, 1, (N, 2)) * surf.length) \
        if "spring" in terms else None
    walls = _walls_for(periodic) if "walls" in terms else None
    return pr.Scene(surf, dt=0.05, n_steps=10, spring=spring, walls=walls, **kw)


def _points(field, seed, n=N):
    """n points spread over (and beyond) the domain, each KINK_MARGIN from every kink."""
    rng = np.random.default_rng(seed)
    per = list(field.periodic)
    out = np.empty((n, 2))
    for i in range(n):
        own = field if field.spring is None else field._replace(
            spring=tuple(np.broadcast_to(a, (n, 2))[i] for a in field.spring))
        while True:
            out[i] = field.lower + rng.uniform(-0.3, 1.3, 2) * field.length
            out[i, per] += rng.integers(-3, 4) * field.length[per]
            if kink_distance(own, out[i:i + 1]) > KINK_MARGIN:
                break
    return out


def _force(field, x):
    return force(field, x, np.empty_like(x))


def _vjp(field, x, w, want=frozenset()):
    xbar = np.zeros_like(x)
    acc = GradAccumulator(field, x.shape[0], want)
    force_vjp(field, x, w, xbar, acc)
    return xbar, acc


# --------------------------------------------------------------------------- force and energy

@pytest.mark.parametrize("topology, terms", CASES)
def test_force_is_minus_gradient_of_potential_energy(topology, terms):
    field = _scene(topology, terms).field()
    x = _points(field, 1)
    fd = central_gradient(lambda p: np.sum(potential_energy(field, p)), x)
    assert relative_error(_force(field, x), -fd) < FD_RTOL


@pytest.mark.parametrize("topology, terms", CASES)
def test_force_writes_into_out_and_returns_it(topology, terms):
    field = _scene(topology, terms).field()
    x = _points(field, 2)
    out = np.full_like(x, np.pi)              # stale content must be overwritten, not added to
    got = force(field, x, out)
    assert got is out
    np.testing.assert_allclose(out, _force(field, x.copy()), rtol=TRAJ_RTOL)


def test_potential_energy_adds_the_terms():
    sc_all = _scene("plane", "grid+spring+walls")
    x = _points(sc_all.field(), 3)
    total = potential_energy(sc_all.field(), x)
    grid = potential_energy(_scene("plane", "grid").field(), x)
    spring = potential_energy(_scene("plane", "grid+spring").field(), x) - grid
    walls = potential_energy(_scene("plane", "grid+walls").field(), x) - grid
    np.testing.assert_allclose(total, grid + spring + walls, rtol=TRAJ_RTOL)
    assert np.all(spring > 0) and np.any(walls > 0)


# --------------------------------------------------------------------------- the adjoint

@pytest.mark.parametrize("topology, terms", CASES)
def test_force_vjp_in_x(topology, terms):
    field = _scene(topology, terms).field()
    x = _points(field, 4)
    assert_dot(*check_vjp(lambda p: _force(field, p), lambda p, w: _vjp(field, p, w)[0], x,
                          np.random.default_rng(4)))


@pytest.mark.parametrize("topology, terms", CASES)
def test_force_vjp_in_values(topology, terms):
    field = _scene(topology, terms).field()
    x = _points(field, 5)
    shape = field.values.shape
    assert_dot(*check_vjp(lambda g: _force(field._replace(values=g), x),
                          lambda g, w: _vjp(field._replace(values=g), x, w, {"values"})[1].values.reshape(shape),
                          field.values, np.random.default_rng(5)))


@pytest.mark.parametrize("topology", sorted(TOPOLOGIES))
@pytest.mark.parametrize("which", ["spring_k", "spring_center"])
def test_force_vjp_in_spring_parameters(topology, which):
    field = _scene(topology, "grid+spring+walls" if topology != "torus" else "grid+spring").field()
    x = _points(field, 6)
    k, c = field.spring

    def with_(z):
        return field._replace(spring=(z, c) if which == "spring_k" else (k, z))

    assert_dot(*check_vjp(lambda z: _force(with_(z), x),
                          lambda z, w: getattr(_vjp(with_(z), x, w, {which})[1], which),
                          k if which == "spring_k" else c, np.random.default_rng(6)))


@pytest.mark.parametrize("topology, terms", CASES)
def test_force_vjp_accumulates(topology, terms):
    """Two calls into the same buffers equal one call with the summed cotangent."""
    field = _scene(topology, terms).field()
    x = _points(field, 7)
    rng = np.random.default_rng(7)
    w1, w2 = rng.standard_normal((2, N, 2))
    want = {"values", "spring_k", "spring_center"}
    base = rng.standard_normal((N, 2))
    xbar = base.copy()
    acc = GradAccumulator(field, N, want)
    force_vjp(field, x, w1, xbar, acc)
    force_vjp(field, x, w2, xbar, acc)
    xbar_once, acc_once = _vjp(field, x, w1 + w2, want)
    np.testing.assert_allclose(xbar - base, xbar_once, rtol=1e3 * TRAJ_RTOL, atol=TRAJ_RTOL)
    for name in ("values", "spring_k", "spring_center"):
        got, once = getattr(acc, name), getattr(acc_once, name)
        assert (got is None) == (once is None) == (field.spring is None and name != "values")
        if got is not None:
            np.testing.assert_allclose(got, once, rtol=1e3 * TRAJ_RTOL, atol=TRAJ_RTOL)


@pytest.mark.parametrize("want, allocated", [
    (set(), set()),
    ({"values"}, {"values"}),
    ({"spring_k"}, {"spring_k"}),
    ({"values", "spring_center", "x0", "mass"}, {"values", "spring_center"}),
])
def test_grad_accumulator_allocates_only_what_is_wanted(want, allocated):
    acc = GradAccumulator(_scene("plane", "grid+spring").field(), N, frozenset(want))
    for name in ("values", "spring_k", "spring_center"):
        assert (getattr(acc, name) is not None) == (name in allocated)


def test_grad_accumulator_without_spring_allocates_no_spring_gradients():
    acc = GradAccumulator(_scene("plane", "grid").field(), N, frozenset({"spring_k", "spring_center"}))
    assert acc.spring_k is None and acc.spring_center is None


# --------------------------------------------------------------------------- costs nothing

SPRING_FUNCS = ("spring_add_force", "spring_energy", "spring_force_vjp")
WALL_FUNCS = ("wall_add_force", "wall_energy", "wall_force_vjp")


def _forbid(monkeypatch, module, names):
    for name in names:
        def boom(*args, _name=name, **kwargs):
            raise AssertionError(f"{_name} was called")
        monkeypatch.setattr(module, name, boom)


def _run_everything(scene, n=3):
    x0 = scene.surface.lower + np.linspace(0.2, 0.8, 2 * n).reshape(n, 2) * scene.surface.length
    v0 = np.full((n, 2), 0.3)
    traj = pr.simulate(scene, x0, v0)
    loss, grads, _ = pr.value_and_grad(scene, x0, v0, pr.Quadratic(wx=1.0, wv=0.5), regularization_weight=0.1)
    pr.energy(scene, traj)
    field = scene.field()
    force_vjp(field, x0, v0, np.zeros((n, 2)), GradAccumulator(field, n, frozenset(grads)))
    return traj, loss, grads


def _bare(topology, mode, **kw):
    periodic = TOPOLOGIES[topology]
    surf = pr.Surface(np.random.default_rng(0).uniform(-1, 1, (5, 4)), (0, 0), (1, 1), periodic)
    extra = {"mobility": (0.01, 0.02)} if mode == "quasistatic" else {}
    return pr.Scene(surf, dt=0.05, n_steps=6, mode=mode, **extra, **kw)


@pytest.mark.parametrize("topology", sorted(TOPOLOGIES))
@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
def test_a_bare_scene_never_calls_spring_or_wall_code(monkeypatch, topology, mode):
    _forbid(monkeypatch, forces_mod, SPRING_FUNCS + WALL_FUNCS)
    _run_everything(_bare(topology, mode))


@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
def test_a_spring_only_scene_never_calls_wall_code(monkeypatch, mode):
    _forbid(monkeypatch, forces_mod, WALL_FUNCS)
    _run_everything(_bare("plane", mode, spring=pr.Spring(1.0, (0.5, 0.5))))


@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
def test_a_walls_only_scene_never_calls_spring_code(monkeypatch, mode):
    _forbid(monkeypatch, forces_mod, SPRING_FUNCS)
    _run_everything(_bare("plane", mode, walls=pr.Walls(10.0, 0.1, np.ones((2, 2), bool))))


def test_walls_with_no_enabled_edge_cost_nothing(monkeypatch):
    _forbid(monkeypatch, forces_mod, WALL_FUNCS)
    _run_everything(_bare("plane", "dynamic", walls=pr.Walls(10.0, 0.1, np.zeros((2, 2), bool))))


@pytest.mark.parametrize("kw, forbidden", [
    (dict(spring=pr.Spring(1.0, (0.5, 0.5))), SPRING_FUNCS),
    (dict(walls=pr.Walls(10.0, 0.1, np.ones((2, 2), bool))), WALL_FUNCS),
])
def test_the_patch_is_effective_when_the_scene_names_the_term(monkeypatch, kw, forbidden):
    """Positive control: the monkeypatch above does catch a call when there is one."""
    _forbid(monkeypatch, forces_mod, forbidden)
    with pytest.raises(AssertionError, match="was called"):
        _run_everything(_bare("plane", "dynamic", **kw))


RANDOM_FUNCS = ("default_rng", "Generator", "RandomState", "seed", "random", "rand", "randn",
                "normal", "standard_normal", "uniform")


@pytest.mark.parametrize("topology", sorted(TOPOLOGIES))
@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
@pytest.mark.parametrize("kw", [{}, {"effects": [pr.Constant((0.1, 0.0))], "spring": pr.Spring(1.0, (0.5, 0.5))}],
                         ids=["bare", "deterministic_effects"])
def test_a_scene_without_noise_never_calls_numpy_random(monkeypatch, topology, mode, kw):
    scene = _bare(topology, mode, **kw)
    with monkeypatch.context() as m:   # restored before teardown, where test tools may seed NumPy
        _forbid(m, np.random, RANDOM_FUNCS)
        _run_everything(scene)


def test_a_scene_with_noise_does_call_numpy_random(monkeypatch):
    """Positive control for the test above."""
    scene = _bare("plane", "dynamic", effects=[pr.Noise((0.1, 0.1), seed=0)])
    _forbid(monkeypatch, np.random, RANDOM_FUNCS)
    with pytest.raises(AssertionError, match="default_rng was called"):
        _run_everything(scene)


def _spy(monkeypatch, name, calls):
    real = getattr(scene_mod, name)

    def spy(*args, **kwargs):
        calls.append((name, args, kwargs))
        return real(*args, **kwargs)

    monkeypatch.setattr(scene_mod, name, spy)


@pytest.mark.parametrize("damping, reaches_core", [
    (None, False), (0.0, False), (np.zeros(2), False), (np.zeros((3, 2)), False),
    (0.2, True), (np.array([0.0, 0.1]), True),
])
def test_an_undamped_scene_never_enters_the_damping_branch(monkeypatch, damping, reaches_core):
    """The core receives damping=None (no damping arithmetic) unless some gamma is nonzero."""
    calls = []
    _spy(monkeypatch, "simulate_dynamic", calls)
    _spy(monkeypatch, "adjoint_dynamic", calls)
    _run_everything(_bare("cylinder0", "dynamic", damping=damping))
    # simulate_dynamic(field, x0, v0, fext, dt, n_steps, mass, damping)
    # adjoint_dynamic(field, traj, dt, mass, damping, gx, gv, want)
    seen = [args[7] if name == "simulate_dynamic" else args[4] for name, args, _ in calls]
    assert len(seen) == 3
    assert all((d is not None) == reaches_core for d in seen)


@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
def test_a_scene_without_effects_gives_the_core_no_external_force(monkeypatch, mode):
    calls = []
    name = "simulate_dynamic" if mode == "dynamic" else "simulate_quasistatic"
    _spy(monkeypatch, name, calls)
    _run_everything(_bare("plane", mode))
    assert calls and all(args[3 if mode == "dynamic" else 2] is None for _, args, _ in calls)


@pytest.mark.parametrize("topology", sorted(TOPOLOGIES))
@pytest.mark.parametrize("zero", [0.0, np.zeros(2), np.zeros((3, 1))])
def test_damping_none_and_zero_are_bit_identical(topology, zero):
    traj_a, loss_a, grads_a = _run_everything(_bare(topology, "dynamic", damping=None))
    traj_b, loss_b, grads_b = _run_everything(_bare(topology, "dynamic", damping=zero))
    for a, b in zip(traj_a, traj_b):
        assert a.tobytes() == b.tobytes()
    assert loss_a == loss_b
    assert grads_a.keys() == grads_b.keys()
    for name in grads_a:
        if name == "damping":      # the same derivative, reduced to each input's own shape
            np.testing.assert_allclose(np.sum(grads_b[name]), grads_a[name], rtol=1e3 * TRAJ_RTOL)
        else:
            assert grads_a[name].tobytes() == grads_b[name].tobytes()
