"""Unit tests of pes_ref.core.scene: validation of Scene / simulate / value_and_grad, input
promotion and non-mutation, and determinism."""
import dataclasses

import numpy as np
import pytest

import pes_ref as pr
from pes_ref.core import steppers
from pes_ref.core.scene import gradient_names
from pes_ref.oracle.tolerances import TRAJ_ATOL, TRAJ_RTOL

N = 2


def _surface(periodic=(False, False)):
    return pr.Surface(np.random.default_rng(0).uniform(0, 1, (5, 4)), (0.0, 0.0), (1.0, 1.0), periodic)


def _scene(**kw):
    base = dict(surface=_surface(kw.pop("periodic", (False, False))), dt=0.05, n_steps=6)
    return pr.Scene(**dict(base, **kw))


X0 = np.array([[0.3, 0.4], [0.6, 0.55]])
V0 = np.array([[0.5, 0.0], [-0.2, 0.3]])


def _raises(exc, name):
    """pytest.raises whose message must name the argument (as a whole word, not inside another)."""
    return pytest.raises(exc, match=rf"(?<![\w.]){name}\b")


# --------------------------------------------------------------------------- Scene

@pytest.mark.parametrize("kw, exc, name", [
    (dict(dt=0.0), ValueError, "dt"),
    (dict(dt=-0.1), ValueError, "dt"),
    (dict(dt=np.nan), ValueError, "dt"),
    (dict(dt=np.inf), ValueError, "dt"),
    (dict(dt=[0.1, 0.2]), ValueError, "dt"),
    (dict(dt="0.1"), TypeError, "dt"),
    (dict(n_steps=-1), ValueError, "n_steps"),
    (dict(n_steps=3.0), TypeError, "n_steps"),
    (dict(t0=np.nan), ValueError, "t0"),
    (dict(mode="explicit"), ValueError, "mode"),
    (dict(mode=None), TypeError, "mode"),
    (dict(mass=0.0), ValueError, "mass"),
    (dict(mass=[1.0, -1.0]), ValueError, "mass"),
    (dict(mass=np.nan), ValueError, "mass"),
    (dict(mass=[1.0, np.inf]), ValueError, "mass"),
    (dict(mass=np.ones(3)), ValueError, "mass"),
    (dict(mass=np.ones((2, 3))), ValueError, "mass"),
    (dict(mass=np.ones((2, 2, 2))), ValueError, "mass"),
    (dict(damping=-0.1), ValueError, "damping"),
    (dict(damping=[0.1, np.nan]), ValueError, "damping"),
    (dict(damping=np.ones(3)), ValueError, "damping"),
    (dict(mode="quasistatic"), ValueError, "mobility"),
    (dict(mode="quasistatic", mobility=(0.1,)), ValueError, "mobility"),
    (dict(mode="quasistatic", mobility=(0.1, 0.0)), ValueError, "mobility"),
    (dict(mode="quasistatic", mobility=(0.1, np.nan)), ValueError, "mobility"),
    (dict(mobility=(0.1, 0.1)), ValueError, "mobility"),
    (dict(spring=(1.0, 0.5)), TypeError, "spring"),
    (dict(walls="all"), TypeError, "walls"),
    (dict(periodic=(True, False), walls=pr.Walls(10.0, 0.1, [[True, False], [False, False]])), ValueError, "walls"),
    (dict(periodic=(False, True), walls=pr.Walls(10.0, 0.1, [[False, False], [False, True]])), ValueError, "walls"),
    (dict(walls=pr.Walls(10.0, 0.5, [[True, True], [False, False]])), ValueError, "wall_margin"),
    (dict(effects=[object()]), TypeError, "effects"),
])
def test_scene_validation_names_the_argument(kw, exc, name):
    with _raises(exc, name):
        _scene(**kw)


def test_scene_needs_a_surface():
    with _raises(TypeError, "surface"):
        pr.Scene(np.zeros((3, 3)), dt=0.1, n_steps=1)


@pytest.mark.parametrize("periodic, edges", [
    ((True, False), [[False, False], [True, True]]),      # walls on the non-periodic axis of a cylinder
    ((False, True), [[True, True], [False, False]]),
    ((True, True), [[False, False], [False, False]]),     # no wall at all on a torus
])
def test_walls_on_non_periodic_axes_are_accepted(periodic, edges):
    _scene(periodic=periodic, walls=pr.Walls(10.0, 0.1, edges))


@pytest.mark.parametrize("field, value, want_dtype_shape", [
    ("dt", np.float32(0.05), None),
    ("n_steps", np.int16(6), None),
    ("mass", np.array([1, 2], dtype=np.int32), (2,)),
    ("mass", np.array([[1.5], [2.0]], dtype=np.float32), (2, 1)),
    ("damping", np.array([0, 1], dtype=np.uint8), (2,)),
    ("damping", True, ()),
])
def test_scene_promotes_numbers(field, value, want_dtype_shape):
    scene = _scene(**{field: value})
    got = getattr(scene, field)
    if want_dtype_shape is None:
        assert type(got) in (float, int)
        assert got == value
    else:
        assert got.dtype == np.float64 and got.shape == want_dtype_shape
        np.testing.assert_array_equal(got, np.asarray(value, dtype=np.float64))


def test_scene_with_values_keeps_the_domain():
    scene = _scene(periodic=(True, False))
    new = scene.with_values(np.ones((3, 7)))
    assert new.surface.periodic == (True, False) and new.surface.shape == (3, 7)
    np.testing.assert_array_equal(new.surface.lower, scene.surface.lower)
    assert scene.surface.shape == (5, 4)


# --------------------------------------------------------------------------- simulate / value_and_grad

@pytest.mark.parametrize("x0, v0, exc, name", [
    (np.zeros(2), None, ValueError, "x0"),
    (np.zeros((2, 3)), None, ValueError, "x0"),
    (np.zeros((0, 2)), None, ValueError, "x0"),
    ([[np.nan, 0.5]], None, ValueError, "x0"),
    ([[np.inf, 0.5]], None, ValueError, "x0"),
    ([["a", "b"]], None, TypeError, "x0"),
    ([[1j, 0.5]], None, TypeError, "x0"),
    (X0, np.zeros((3, 2)), ValueError, "v0"),
    (X0, np.zeros((2, 1)), ValueError, "v0"),
    (X0, np.zeros(2), ValueError, "v0"),
    (X0, [[0.0, np.nan], [0.0, 0.0]], ValueError, "v0"),
])
@pytest.mark.parametrize("entry", ["simulate", "value_and_grad"])
def test_state_validation_names_the_argument(x0, v0, exc, name, entry):
    scene = _scene()
    with _raises(exc, name):
        if entry == "simulate":
            pr.simulate(scene, x0, v0)
        else:
            pr.value_and_grad(scene, x0, v0, pr.Funnel())


@pytest.mark.parametrize("kw, name", [
    (dict(mass=np.ones((3, 1))), "mass"),
    (dict(mass=np.ones((3, 2))), "mass"),
    (dict(damping=np.full((3, 2), 0.1)), "damping"),
    (dict(spring=pr.Spring(np.ones((3, 1)), 0.5)), "spring_k"),
    (dict(spring=pr.Spring(1.0, np.zeros((3, 2)))), "spring_center"),
])
@pytest.mark.parametrize("entry", ["simulate", "value_and_grad"])
def test_per_particle_inputs_must_broadcast_to_the_particles(kw, name, entry):
    scene = _scene(**kw)                 # (3, ...) is fine for the scene ...
    with _raises(ValueError, name):      # ... but not for N = 2 particles
        if entry == "simulate":
            pr.simulate(scene, X0, V0)
        else:
            pr.value_and_grad(scene, X0, V0, pr.Funnel())


@pytest.mark.parametrize("fext, exc", [
    (np.zeros((6, N, 2)), ValueError),          # T + 1 = 7 states
    (np.zeros((7, N + 1, 2)), ValueError),
    (np.full((7, N, 2), np.nan), ValueError),
    ("none", TypeError),
])
def test_explicit_fext_is_validated(fext, exc):
    with _raises(exc, "fext"):
        pr.simulate(_scene(), X0, V0, fext=fext)


@pytest.mark.parametrize("mode, wrt, name", [
    ("dynamic", ["gradient_of_everything"], "wrt"),
    ("dynamic", "x0s", "wrt"),
    ("dynamic", ["x0", "mobility"], "mobility"),            # not in a dynamic scene
    ("dynamic", ["spring_k"], "spring_k"),                  # the scene has no spring
    ("quasistatic", ["v0"], "v0"),                          # plays no part in quasistatic mode
    ("quasistatic", ["mass"], "mass"),
    ("quasistatic", ["damping"], "damping"),
])
def test_wrt_validation(mode, wrt, name):
    scene = _scene(mode=mode, mobility=(0.01, 0.01) if mode == "quasistatic" else None)
    with _raises(ValueError, name):
        pr.value_and_grad(scene, X0, V0, pr.Funnel(), wrt=wrt)


@pytest.mark.parametrize("wrt", ["x0", ("x0",), ["values", "force"], frozenset({"mass"})])
def test_wrt_accepts_a_name_or_an_iterable(wrt):
    _, grads, _ = pr.value_and_grad(_scene(), X0, V0, pr.Funnel(), wrt=wrt)
    assert set(grads) == ({wrt} if isinstance(wrt, str) else set(wrt))


@pytest.mark.parametrize("mode, spring, want", [
    ("dynamic", False, {"values", "x0", "v0", "force", "mass", "damping"}),
    ("dynamic", True, {"values", "x0", "v0", "force", "mass", "damping", "spring_k", "spring_center"}),
    ("quasistatic", False, {"values", "x0", "force", "mobility"}),
    ("quasistatic", True, {"values", "x0", "force", "mobility", "spring_k", "spring_center"}),
])
def test_default_gradients_are_those_the_scene_uses(mode, spring, want):
    scene = _scene(mode=mode, mobility=(0.01, 0.01) if mode == "quasistatic" else None,
                   spring=pr.Spring(1.0, (0.5, 0.5)) if spring else None)
    _, grads, _ = pr.value_and_grad(scene, X0, V0, pr.Funnel())
    assert set(grads) == want
    assert set(grads) <= set(pr.GRADIENT_NAMES)
    assert tuple(grads) == gradient_names(mode, spring)       # the one home, in GRADIENT_NAMES order


def test_gradient_names_refuses_an_unknown_mode_naming_it():
    with pytest.raises(ValueError, match="mode must be one of .* got 'overdamped'"):
        gradient_names("overdamped", False)


def test_modes_and_integrators_come_from_the_stepper_registry():
    assert steppers.MODES == ("dynamic", "quasistatic") and steppers.INTEGRATORS == ("verlet", "gjf")
    assert set(steppers.STEPPERS) == {(m, i) for m in steppers.MODES for i in steppers.INTEGRATORS} - {
        ("quasistatic", "gjf")}
    assert steppers.modes_of("gjf") == ("dynamic",)


def test_an_unknown_stepper_is_refused_naming_it():
    with pytest.raises(ValueError, match="no stepper for mode='quasistatic' with integrator='gjf'"):
        steppers.stepper("quasistatic", "gjf")


def test_objective_without_value_and_grad_is_refused():
    with _raises(TypeError, "objective"):
        pr.value_and_grad(_scene(), X0, V0, lambda x, v, t: 0.0)


# --------------------------------------------------------------------------- promotion and non-mutation

def _readonly(a):
    a = np.array(a)
    a.setflags(write=False)
    return a


STATE_VARIANTS = {
    "float64": lambda a: np.array(a, dtype=np.float64),
    "float32": lambda a: np.array(a, dtype=np.float32),
    "list": lambda a: np.asarray(a).tolist(),
    "readonly": _readonly,
    "noncontiguous": lambda a: np.repeat(np.asarray(a, dtype=np.float64), 2, axis=1)[:, ::2],
    "fortran": lambda a: np.asfortranarray(np.asarray(a, dtype=np.float64)),
}
DYADIC_X0 = np.array([[0.25, 0.375], [0.625, 0.5625]])   # exact in float32 too
DYADIC_V0 = np.array([[0.5, 0.0], [-0.25, 0.125]])


@pytest.mark.parametrize("variant", sorted(STATE_VARIANTS))
@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
def test_state_inputs_of_any_layout_give_the_same_result_and_are_untouched(variant, mode):
    scene = _scene(mode=mode, mobility=(0.01, 0.02) if mode == "quasistatic" else None,
                   spring=pr.Spring(1.0, (0.5, 0.5)))
    x0, v0 = STATE_VARIANTS[variant](DYADIC_X0), STATE_VARIANTS[variant](DYADIC_V0)
    before = [np.array(a, copy=True) for a in (x0, v0)]
    flags = [a.flags.writeable if isinstance(a, np.ndarray) else None for a in (x0, v0)]
    ref = pr.simulate(scene, DYADIC_X0, DYADIC_V0)
    traj = pr.simulate(scene, x0, v0)
    loss_ref, g_ref, _ = pr.value_and_grad(scene, DYADIC_X0, DYADIC_V0, pr.Funnel(0.4, "every_step"))
    loss, g, _ = pr.value_and_grad(scene, x0, v0, pr.Funnel(0.4, "every_step"))
    for a, b in zip(traj, ref):
        assert a.dtype == np.float64
        np.testing.assert_array_equal(a, b)
    assert loss == loss_ref
    for name in g_ref:
        np.testing.assert_array_equal(g[name], g_ref[name])
    for a, b, w in zip((x0, v0), before, flags):
        np.testing.assert_array_equal(np.asarray(a), b)
        if w is not None:
            assert a.flags.writeable == w


def test_int_positions_are_promoted():
    scene = pr.Scene(pr.Surface(np.zeros((3, 3)), (0, 0), (4, 4), (False, False)), dt=0.5, n_steps=2)
    traj = pr.simulate(scene, np.array([[1, 2]], dtype=np.int64), np.array([[1, 0]], dtype=np.int8))
    assert traj.x.dtype == np.float64
    np.testing.assert_allclose(traj.x[:, 0], [[1, 2], [1.5, 2], [2, 2]], rtol=TRAJ_RTOL)


def test_scene_parameters_are_untouched_by_runs():
    mass = np.array([[1.0], [2.0]])
    damping = np.array([0.1, 0.2])
    values = np.random.default_rng(2).uniform(0, 1, (5, 4))
    k, c = np.array([1.0, 2.0]), np.array([[0.4, 0.4], [0.6, 0.6]])
    fext = np.random.default_rng(3).normal(0, 1, (7, N, 2))
    copies = [a.copy() for a in (mass, damping, values, k, c, fext)]
    scene = pr.Scene(pr.Surface(values, (0, 0), (1, 1), (True, False)), dt=0.05, n_steps=6, mass=mass,
                     damping=damping, spring=pr.Spring(k, c), effects=[pr.Schedule(fext)])
    pr.simulate(scene, X0, V0)
    pr.value_and_grad(scene, X0, V0, pr.Quadratic(wx=1.0, wv=1.0), regularization_weight=0.1)
    pr.energy(scene, pr.simulate(scene, X0, V0))
    for a, b in zip((mass, damping, values, k, c, fext), copies):
        np.testing.assert_array_equal(a, b)
        assert a.flags.writeable


def test_scene_is_frozen():
    scene = _scene()
    with pytest.raises(dataclasses.FrozenInstanceError):
        scene.dt = 1.0


# --------------------------------------------------------------------------- determinism

@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
@pytest.mark.parametrize("periodic", [(False, False), (True, True)])
def test_same_inputs_give_bit_identical_results(mode, periodic):
    def run():
        scene = _scene(periodic=periodic, mode=mode, mobility=(0.01, 0.02) if mode == "quasistatic" else None,
                       damping=0.3 if mode == "dynamic" else None, spring=pr.Spring(2.0, (0.5, 0.5)),
                       effects=[pr.Noise((0.5, 0.2), seed=7), pr.Window(pr.Constant((1.0, 0.0)), 0.1, 0.2)])
        traj = pr.simulate(scene, X0, V0)
        loss, grads, traj2 = pr.value_and_grad(scene, X0, V0, pr.Oscillator(0.3, 2.0), regularization_weight=0.1)
        return traj, traj2, loss, grads, pr.energy(scene, traj)

    a, b = run(), run()
    for t1, t2 in ((a[0], b[0]), (a[1], b[1]), (a[0], a[1])):
        for x, y in zip(t1, t2):
            assert x.tobytes() == y.tobytes()
    assert a[2] == b[2]
    assert a[3].keys() == b[3].keys()
    for name in a[3]:
        assert a[3][name].tobytes() == b[3][name].tobytes()
    assert a[4].tobytes() == b[4].tobytes()


# --------------------------------------------------------------------------- energy

SPRINGS = {
    "scalar": (1.5, (0.5, 0.5)),
    "per_axis": (np.array([1.5, 0.5]), np.array([0.5, 0.25])),
    "per_particle": (np.array([[1.5, 0.5], [2.0, 1.0]]), np.array([[0.5, 0.25], [0.4, 0.6]])),
    "per_particle_column": (np.array([[1.5], [2.0]]), np.array([[0.5, 0.25], [0.4, 0.6]])),
}


@pytest.mark.parametrize("spring", sorted(SPRINGS))
@pytest.mark.parametrize("periodic", [(False, False), (True, True)])
def test_energy_is_kinetic_plus_potential(spring, periodic):
    mass = np.array([[1.0, 2.0], [3.0, 0.5]])
    k, c = SPRINGS[spring]
    scene = _scene(mass=mass, spring=pr.Spring(k, c), periodic=periodic)
    traj = pr.simulate(scene, X0, V0)
    e = pr.energy(scene, traj)
    assert e.shape == (scene.n_steps + 1, N)
    delta = traj.x - np.broadcast_to(c, (N, 2))
    L = scene.surface.length
    delta = np.where(periodic, np.mod(delta + L / 2, L) - L / 2, delta)      # SPEC section 2 minimum image
    u_grid = scene.surface.energy(traj.x.reshape(-1, 2)).reshape(-1, N)
    u_spring = 0.5 * np.sum(np.broadcast_to(k, (N, 2)) * delta ** 2, axis=2)
    kinetic = 0.5 * np.sum(mass * traj.v ** 2, axis=2)
    np.testing.assert_allclose(e, u_grid + u_spring + kinetic, rtol=TRAJ_RTOL, atol=TRAJ_ATOL)


def test_a_single_effect_is_taken_for_a_tuple_of_one():
    alone = _scene(effects=pr.Constant((0.2, -0.1)))
    tupled = _scene(effects=(pr.Constant((0.2, -0.1)),))
    assert len(alone.effects) == 1
    np.testing.assert_array_equal(pr.simulate(alone, X0, V0).x, pr.simulate(tupled, X0, V0).x)


@pytest.mark.parametrize("effects", [3.0, "constant", pr.Spring(1.0, (0.0, 0.0))])
def test_something_else_as_effects_names_effects(effects):
    with pytest.raises(TypeError, match=r"\beffects\b"):
        _scene(effects=effects)


@pytest.mark.parametrize("bad", [np.empty((7, 3)), np.empty((7, N), dtype=np.float32), np.empty((N, 7)).T,
                                 np.broadcast_to(0.0, (7, N)), [[0.0] * N] * 7])
def test_energy_out_is_refused_unless_a_writable_c_contiguous_float64_array_of_the_run(bad):
    with _raises(ValueError, "energy_out"):
        pr.value_and_grad(_scene(), X0, V0, pr.Funnel(0.5), energy_out=bad)


@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
def test_energy_out_holds_the_runs_energy(mode):
    kw = dict(mode="quasistatic", mobility=(0.01, 0.01)) if mode == "quasistatic" else dict(damping=0.3)
    scene = _scene(**kw)
    e = np.empty((scene.n_steps + 1, N))
    _, _, traj = pr.value_and_grad(scene, X0, V0, pr.Funnel(0.5), energy_out=e, backend="numpy")
    assert e.tobytes() == pr.energy(scene, traj).tobytes()


@pytest.mark.parametrize("backend", ["numpy", "numba"])
@pytest.mark.parametrize("periodic", [(False, False), (True, False), (True, True)])
def test_the_dynamic_loops_compute_the_energy_as_they_step(monkeypatch, backend, periodic):
    """No pass over the trajectory: the loop's energy at each state's own lookup, the pass's
    bytes (NumPy's loop from ENERGY_CHUNK particles on: here from 1)."""
    pytest.importorskip("numba") if backend == "numba" else None
    from pes_ref.core import scene as scene_module
    monkeypatch.setattr(scene_module, "ENERGY_CHUNK", 1)
    walls = pr.Walls(20.0, 0.05, [[not periodic[0]] * 2, [not periodic[1]] * 2]) if not all(periodic) else None
    scene = _scene(periodic=periodic, damping=0.2, walls=walls, spring=pr.Spring((1.0, 0.5), (0.5, 0.5)),
                   effects=(pr.Constant((0.1, -0.2)),), mass=[[1.0, 2.0], [0.5, 1.5]])
    e = np.empty((scene.n_steps + 1, N))
    passes = []
    real = scene_module.energy
    monkeypatch.setattr(scene_module, "energy", lambda *a, **k: passes.append(1) or real(*a, **k))
    _, _, traj = pr.value_and_grad(scene, X0, V0, pr.Funnel(0.5, "every_step"), energy_out=e, backend=backend)
    assert not passes
    assert e.tobytes() == real(scene, traj).tobytes()


def test_an_energy_beyond_float64_is_refused_as_before_by_the_oracle():
    """A finite run whose kinetic energy overflows: the oracle refuses it naming dt on NumPy
    (the energy again after the run, under its np.errstate), as when the energy was a pass."""
    from pes_ref import oracle
    case = dict(values=np.zeros((4, 4)), lower=[0.0, 0.0], upper=[1.0, 1.0], periodic=[True, True], dt=1e-160,
                n_steps=np.int64(2), mode="dynamic", mass=1e10, damping=0.0, x0=[[0.3, 0.4]], v0=[[1e154, 0.0]],
                objective="funnel", target=0.5, when="final")
    with pytest.raises(oracle.CaseError) as err:
        oracle.run_case(case, backend="numpy")
    assert err.value.key == "dt" and "overflow" in str(err.value)


def test_numpys_loop_leaves_the_energy_of_few_particles_to_the_pass(monkeypatch):
    """Below ENERGY_CHUNK particles a state, the pass after the run (several states per call)."""
    from pes_ref.core import scene as scene_module
    passes = []
    real = scene_module.energy
    monkeypatch.setattr(scene_module, "energy", lambda *a, **k: passes.append(1) or real(*a, **k))
    scene = _scene(damping=0.2)
    e = np.empty((scene.n_steps + 1, N))
    _, _, traj = pr.value_and_grad(scene, X0, V0, pr.Funnel(0.5), energy_out=e, backend="numpy")
    assert passes == [1] and e.tobytes() == real(scene, traj).tobytes()
