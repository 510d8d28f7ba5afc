"""Unit tests of pes_ref.core.forces: the total conservative force, its adjoint, and the
guarantee that an effect a scene does not name costs nothing."""
from collections import Counter

import numpy as np
import pytest

import pes_ref as pr
import pes_ref.core.forces as forces_mod
import pes_ref.core.steppers as steppers_mod
import pes_ref.core.terms as terms_mod
from _helpers import TOPOLOGIES, assert_dot, kink_distance
from pes_ref.core.forces import ForceAdjoint, ForceKernel, GradAccumulator, force, force_vjp, potential_energy
from pes_ref.core.interpolations import INTERPOLATIONS, interpolation
from pes_ref.core.kernels import GridAdjoint, GridForce, TermAdjoint, TermForce
from pes_ref.testing.finite_differences import central_gradient, check_vjp
from pes_ref.oracle.compare import relative_error
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


# --------------------------------------------------------------------------- registry and kernels

@pytest.mark.parametrize("name", sorted(INTERPOLATIONS))
@pytest.mark.parametrize("n_particles", [1, N])
def test_every_kernel_has_its_protocol(name, n_particles):
    """Each interpolation's kernels and the term kernels provide the one hot-loop callable
    of their protocol; ForceKernel and ForceAdjoint chain them."""
    scene = _scene("plane", "grid+spring+walls")
    field = scene.field()._replace(interpolation=name, spring=tuple(a[:n_particles] for a in scene.field().spring))
    xs = np.stack([_points(field, s, n_particles) for s in range(3)])
    rule = interpolation(name)
    assert isinstance(rule.forward(field, n_particles), GridForce)
    assert isinstance(rule.adjoint(field, xs, True), GridAdjoint)
    fk, fa = ForceKernel(field, n_particles), ForceAdjoint(field, xs, frozenset({"values", "spring_k"}))
    assert all(isinstance(t, TermForce) for t in fk.terms) and len(fk.terms) == 2
    assert all(isinstance(t, TermAdjoint) for t in fa.terms) and len(fa.terms) == 2
    got = fk.call(xs[0], np.empty((n_particles, 2)))
    assert got.tobytes() == _force(field, xs[0]).tobytes()
    for n in range(2, -1, -1):
        fa.vjp(n, np.ones((n_particles, 2)), np.zeros((n_particles, 2)))
    assert sorted(fa.result()) == ["spring_k", "values"]


def test_an_unknown_interpolation_is_refused_naming_it():
    with pytest.raises(ValueError, match=r"interpolation must be one of \['bicubic', 'bilinear'\], got 'spline'"):
        interpolation("spline")
    field = _scene("plane", "grid").field()._replace(interpolation="spline")
    with pytest.raises(ValueError, match="got 'spline'"):
        ForceKernel(field, N)


# --------------------------------------------------------------------------- costs nothing

#: The single-call functions of each term (reached by energy() and force_vjp()).
TERM_FUNCS = {"spring": ("spring_add_force", "spring_energy", "spring_force_vjp"),
              "walls": ("wall_add_force", "wall_energy", "wall_force_vjp")}
#: The hot loop's kernels of each term, forward and adjoint, with the one callable each
#: exposes to the loop.
TERM_KERNELS = {"spring": ((terms_mod.SpringKernel, "add_force"), (terms_mod.SpringAdjoint, "force_vjp")),
                "walls": ((terms_mod.WallKernel, "add_force"), (terms_mod.WallAdjoint, "force_vjp"))}
T_STEPS = 6


def _forbid(monkeypatch, module, names):
    for name in names:
        def boom(*args, _name=name, **kwargs):
            raise AssertionError(f"{_name} was called")
        monkeypatch.setattr(module, name, boom)


def _watch_kernels(monkeypatch):
    """Count, per term kernel class, the kernels built (wherever they are built from) and
    the hot loop's calls of the callable each exposes: returns the two Counters."""
    built, calls = Counter(), Counter()
    for cls, attr in (k for pair in TERM_KERNELS.values() for k in pair):
        def init(self, *args, _cls=cls, _attr=attr, _init=cls.__init__, **kwargs):
            _init(self, *args, **kwargs)
            built[_cls.__name__] += 1
            real = getattr(self, _attr)

            def counted(*a, _real=real, _name=_cls.__name__):
                calls[_name] += 1
                return _real(*a)
            setattr(self, _attr, counted)
        monkeypatch.setattr(cls, "__init__", init)
    return built, calls


def _names(terms) -> set:
    return {cls.__name__ for term in terms for cls, _ in TERM_KERNELS[term]}


def _run_everything(scene, n=3):
    """simulate, value_and_grad (forward and backward), energy and a single force_vjp, on the
    NumPy loops (whose kernels and steppers these tests watch)."""
    x0 = scene.surface.lower + np.linspace(0.2, 0.8, 2 * n).reshape(n, 2) * scene.surface.length
    v0 = np.full((n, 2), 0.3)
    traj = pr.simulate(scene, x0, v0, backend="numpy")
    loss, grads, _ = pr.value_and_grad(scene, x0, v0, pr.Quadratic(wx=1.0, wv=0.5), regularization_weight=0.1,
                                       backend="numpy")
    pr.energy(scene, traj)
    field = scene.field()
    force_vjp(field, x0, v0, np.zeros((n, 2)), GradAccumulator(field, n, frozenset(grads)))
    return traj, loss, grads


def _bare(topology, mode, **kw):
    periodic = TOPOLOGIES[topology]
    surf = pr.Surface(np.random.default_rng(0).uniform(-1, 1, (5, 4)), (0, 0), (1, 1), periodic)
    extra = {"mobility": (0.01, 0.02)} if mode == "quasistatic" else {}
    return pr.Scene(surf, dt=0.05, n_steps=T_STEPS, mode=mode, **extra, **kw)


def _assert_never_ran(monkeypatch, scene, absent, present=()):
    """Run everything on ``scene`` with the single-call functions of the ``absent`` terms
    forbidden and every term kernel watched: no kernel of an absent term was built or
    called, forward or backward; each kernel of a ``present`` term ran in the hot loop."""
    _forbid(monkeypatch, forces_mod, [f for term in absent for f in TERM_FUNCS[term]])
    built, calls = _watch_kernels(monkeypatch)
    _run_everything(scene)
    assert not _names(absent) & (set(built) | set(calls)), (dict(built), dict(calls))
    for name in _names(present):
        assert calls[name] > 0, (name, dict(calls))


@pytest.mark.parametrize("topology", sorted(TOPOLOGIES))
@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
def test_a_bare_scene_never_runs_spring_or_wall_code(monkeypatch, topology, mode):
    _assert_never_ran(monkeypatch, _bare(topology, mode), absent=("spring", "walls"))


@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
def test_a_spring_only_scene_never_runs_wall_code(monkeypatch, mode):
    _assert_never_ran(monkeypatch, _bare("plane", mode, spring=pr.Spring(1.0, (0.5, 0.5))),
                      absent=("walls",), present=("spring",))


@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
def test_a_walls_only_scene_never_runs_spring_code(monkeypatch, mode):
    _assert_never_ran(monkeypatch, _bare("plane", mode, walls=pr.Walls(10.0, 0.1, np.ones((2, 2), bool))),
                      absent=("spring",), present=("walls",))


def test_walls_with_no_enabled_edge_cost_nothing(monkeypatch):
    _assert_never_ran(monkeypatch, _bare("plane", "dynamic", walls=pr.Walls(10.0, 0.1, np.zeros((2, 2), bool))),
                      absent=("walls",))


@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
@pytest.mark.parametrize("term, kw", [
    ("spring", dict(spring=pr.Spring(1.0, (0.5, 0.5)))),
    ("walls", dict(walls=pr.Walls(10.0, 0.1, np.ones((2, 2), bool)))),
])
def test_the_watch_sees_every_hot_loop_call_of_a_named_term(monkeypatch, mode, term, kw):
    """Positive control for the tests above: when the scene names the term, the watch
    counts one forward kernel per forward run and one adjoint kernel for the backward run,
    and every call the loops make (T+1 forces per run; T+1 vjps dynamic, T quasistatic)."""
    built, calls = _watch_kernels(monkeypatch)
    _run_everything(_bare("plane", mode, **kw))
    (fwd, _), (adj, _) = ((cls.__name__, attr) for cls, attr in TERM_KERNELS[term])
    assert dict(built) == {fwd: 2, adj: 1}
    assert dict(calls) == {fwd: 2 * (T_STEPS + 1), adj: T_STEPS + (mode == "dynamic")}


@pytest.mark.parametrize("term, kw", [
    ("spring", dict(spring=pr.Spring(1.0, (0.5, 0.5)))),
    ("walls", dict(walls=pr.Walls(10.0, 0.1, np.ones((2, 2), bool)))),
])
def test_the_forbidden_functions_are_reached_when_the_scene_names_the_term(monkeypatch, term, kw):
    """Positive control: energy() and force_vjp() do reach the patched functions."""
    _forbid(monkeypatch, forces_mod, TERM_FUNCS[term])
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
    with monkeypatch.context() as m:     # undone before teardown, where pytest-randomly reseeds
        _forbid(m, np.random, RANDOM_FUNCS)
        _run_everything(scene)


def test_a_scene_with_noise_does_call_numpy_random(monkeypatch):
    """Positive control for the test above."""
    scene = _bare("plane", "dynamic", effects=[pr.Noise((0.1, 0.1), seed=0)])
    with monkeypatch.context() as m, pytest.raises(AssertionError, match="default_rng was called"):
        _forbid(m, np.random, RANDOM_FUNCS)
        _run_everything(scene)


def _spy_steppers(monkeypatch):
    """Record what every registered stepper receives, forward and backward: a list of
    ``("simulate", fext, params)`` and ``("adjoint", None, params)``."""
    calls = []
    for key, real in list(steppers_mod.STEPPERS.items()):
        def simulate(field, x0, v0, fext, params, _real=real):
            calls.append(("simulate", fext, params))
            return _real.simulate(field, x0, v0, fext, params)

        def adjoint(field, traj, params, gx, gv, want, _real=real):
            calls.append(("adjoint", None, params))
            return _real.adjoint(field, traj, params, gx, gv, want)
        monkeypatch.setitem(steppers_mod.STEPPERS, key, real._replace(simulate=simulate, adjoint=adjoint))
    return calls


@pytest.mark.parametrize("integrator", ["verlet", "gjf"])
@pytest.mark.parametrize("damping, reaches_core", [
    (None, False), (0.0, False), (np.zeros(2), False), (np.zeros((3, 2)), False),
    (0.2, True), (np.array([0.0, 0.1]), True),
])
def test_an_undamped_scene_gives_the_core_no_damping(monkeypatch, integrator, damping, reaches_core):
    """The steppers receive damping=None (no damping arithmetic, forward or backward)
    unless some gamma is nonzero."""
    calls = _spy_steppers(monkeypatch)
    _run_everything(_bare("cylinder0", "dynamic", damping=damping, integrator=integrator))
    assert [what for what, _, _ in calls] == ["simulate", "simulate", "adjoint"]
    assert all((params.damping is not None) == reaches_core for _, _, params in calls)


@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
@pytest.mark.parametrize("effects, reaches_core", [((), False), ((pr.Constant((0.1, 0.0)),), True)])
def test_a_scene_without_effects_gives_the_core_no_external_force(monkeypatch, mode, effects, reaches_core):
    calls = _spy_steppers(monkeypatch)
    _run_everything(_bare("plane", mode, effects=effects))
    forwards = [fext for what, fext, _ in calls if what == "simulate"]
    assert len(forwards) == 2 and all((fext is not None) == reaches_core for fext in forwards)


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
