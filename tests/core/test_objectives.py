"""Unit tests of pes_ref.core.objectives (SPEC section 4): values by hand, derivatives by
central differences."""
import math

import numpy as np
import pytest

import pes_ref as pr
from pes_ref import Custom, Funnel, Oscillator, Quadratic, regularization
from pes_ref.core.objectives import OscillatorCycle
from pes_ref.testing.finite_differences import central_gradient
from pes_ref.oracle.compare import relative_error
from pes_ref.oracle.tolerances import FD_RTOL, TRAJ_RTOL

# A tiny trajectory: T + 1 = 3 states, N = 2 particles.
X = np.array([[[0.0, 9.0], [1.0, 9.0]],
              [[2.0, 9.0], [-1.0, 9.0]],
              [[1.0, 9.0], [-0.5, 9.0]]])
V = np.array([[[0.5, 7.0], [0.0, 7.0]],
              [[1.0, 7.0], [-2.0, 7.0]],
              [[0.0, 7.0], [3.0, 7.0]]])
TIMES = np.array([0.0, 0.5, 1.0])


def _random_traj(seed, shape=(4, 3, 2)):
    rng = np.random.default_rng(seed)
    return rng.normal(0, 1, shape), rng.normal(0, 1, shape), np.arange(shape[0]) * 0.1 + 0.2


def _check_grads_by_fd(obj, x, v, t):
    _, gx, gv = obj.value_and_grad(x, v, t)
    fd_x = central_gradient(lambda z: obj.value_and_grad(z, v, t)[0], x)
    fd_v = central_gradient(lambda z: obj.value_and_grad(x, z, t)[0], v)
    assert np.max(np.abs(fd_x)) > 0
    assert relative_error(np.zeros_like(x) if gx is None else gx, fd_x) < FD_RTOL
    if gv is None:
        np.testing.assert_array_equal(fd_v, 0.0)
    else:
        assert relative_error(gv, fd_v) < FD_RTOL


# --------------------------------------------------------------------------- funnel

@pytest.mark.parametrize("when, want", [
    # final: (1 - 0.5)^2 + (-0.5 - 0.5)^2 = 0.25 + 1 = 1.25
    ("final", 1.25),
    # every_step: n=0: 0.25 + 0.25 ; n=1: 2.25 + 2.25 ; n=2: 1.25 -> 6.25
    ("every_step", 6.25),
])
def test_funnel_value_by_hand(when, want):
    value, gx, gv = Funnel(target=0.5, when=when).value_and_grad(X, V, TIMES)
    assert value == pytest.approx(want, rel=TRAJ_RTOL)
    assert gv is None
    assert gx.shape == X.shape
    np.testing.assert_array_equal(gx[..., 1], 0.0)          # only q0 counts
    want_gx = 2 * (X[..., 0] - 0.5)
    if when == "final":
        want_gx[:-1] = 0.0
    np.testing.assert_allclose(gx[..., 0], want_gx, rtol=TRAJ_RTOL)


@pytest.mark.parametrize("when", ["final", "every_step"])
def test_funnel_is_its_formula_bit_for_bit(when):
    """``sum e^2`` and ``2 e`` of eq. (5), written plainly over (T+1, N), on a trajectory of
    many states (the sum's pairwise blocks): the same bytes as the objective's in-place ops."""
    x = np.random.default_rng(3).standard_normal((301, 37, 2))
    value, gx, _ = Funnel(target=0.3, when=when).value_and_grad(x, None, None)
    e = x[:, :, 0] - 0.3 if when == "every_step" else x[-1, :, 0] - 0.3
    assert value == float(np.sum(e * e))
    want = np.zeros(x.shape)
    (want[:, :, 0] if when == "every_step" else want[-1, :, 0])[...] = 2.0 * e
    assert gx.tobytes() == want.tobytes()


@pytest.mark.parametrize("when", ["final", "every_step"])
@pytest.mark.parametrize("seed", [0, 1])
def test_funnel_gradient_by_central_differences(when, seed):
    _check_grads_by_fd(Funnel(target=0.3, when=when), *_random_traj(seed))


def test_funnel_defaults_and_promotion():
    f = Funnel(np.float32(0.25))
    assert f.when == "final" and type(f.target) is float and f.target == 0.25


@pytest.mark.parametrize("kw, exc, name", [
    (dict(when="sometimes"), ValueError, "when"),
    (dict(when=1), TypeError, "when"),
    (dict(target=np.nan), ValueError, "target"),
    (dict(target=[0.0, 1.0]), ValueError, "target"),
])
def test_funnel_validation_names_the_argument(kw, exc, name):
    with pytest.raises(exc, match=rf"\b{name}\b"):
        Funnel(**kw)


# --------------------------------------------------------------------------- oscillator

def _oscillator_by_hand(A, w, x, v, t):
    total = 0.0
    n_particles = x.shape[1]
    for n in range(x.shape[0]):
        s = 0.0
        for i in range(n_particles):
            ex = x[n, i, 0] - A * math.cos(w * t[n])
            ev = v[n, i, 0] + A * w * math.sin(w * t[n])
            s += ex * ex + ev * ev
        total += math.sqrt(s) / n_particles ** 2
    return total


def test_oscillator_value_by_hand_pythagorean():
    # one state at t = 0: e_x = x - A, e_v = v. Particles (A+3, 0) and (A, 4): sqrt(9 + 16) / 2^2 = 1.25
    A = 2.0
    x = np.array([[[A + 3.0, 0.0], [A, 0.0]]])
    v = np.array([[[0.0, 0.0], [4.0, 0.0]]])
    value, gx, gv = Oscillator(A, 1.7).value_and_grad(x, v, np.array([0.0]))
    assert value == pytest.approx(1.25, rel=TRAJ_RTOL)
    # d/dx sqrt(s)/N^2 = e_x / (sqrt(s) N^2) = 3 / 20 ; d/dv = 4 / 20
    np.testing.assert_allclose(gx, [[[0.15, 0.0], [0.0, 0.0]]], rtol=TRAJ_RTOL)
    np.testing.assert_allclose(gv, [[[0.0, 0.0], [0.2, 0.0]]], rtol=TRAJ_RTOL)


@pytest.mark.parametrize("A, w", [(1.0, 2.0), (0.3, -1.1), (0.0, 5.0)])
def test_oscillator_value_by_hand(A, w):
    value, _, _ = Oscillator(A, w).value_and_grad(X, V, TIMES)
    assert value == pytest.approx(_oscillator_by_hand(A, w, X, V, TIMES), rel=TRAJ_RTOL)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_oscillator_gradient_by_central_differences(seed):
    _check_grads_by_fd(Oscillator(0.7, 2.5), *_random_traj(seed))


def test_oscillator_zero_root_has_zero_derivative():
    """All particles exactly on the reference at a step: root 0, its derivative taken as 0,
    and no division by zero (conftest makes that raise)."""
    A, w = 0.8, 3.0
    x, v, t = _random_traj(3)
    t = t.copy()
    t[1] = 0.0                                  # cos = 1, sin = 0 exactly
    x[1, :, 0] = A
    v[1, :, 0] = 0.0
    value, gx, gv = Oscillator(A, w).value_and_grad(x, v, t)
    np.testing.assert_array_equal(gx[1], 0.0)
    np.testing.assert_array_equal(gv[1], 0.0)
    assert np.all(gx[[0, 2, 3], :, 0] != 0)
    assert value == pytest.approx(_oscillator_by_hand(A, w, x, v, t), rel=TRAJ_RTOL)


def test_oscillator_gradient_ignores_axis_1():
    _, gx, gv = Oscillator(1.0, 1.0).value_and_grad(X, V, TIMES)
    np.testing.assert_array_equal(gx[..., 1], 0.0)
    np.testing.assert_array_equal(gv[..., 1], 0.0)


@pytest.mark.parametrize("kw, name", [(dict(amplitude=np.inf, omega=1.0), "amplitude"),
                                      (dict(amplitude=1.0, omega=np.nan), "omega")])
def test_oscillator_validation_names_the_argument(kw, name):
    with pytest.raises(ValueError, match=rf"\b{name}\b"):
        Oscillator(**kw)



def test_oscillator_cycle_value_by_hand():
    # A = 2, w = 0.5, one state: particle (x, v) = (3, 2) has r = sqrt(9 + 16) = 5, e = 3; particle
    # (0, 0) has r = 0, e = -2: sqrt(9 + 4) / 2^2; the phase (time) does not matter
    x = np.array([[[3.0, 9.0], [0.0, 9.0]]])
    v = np.array([[[2.0, 7.0], [0.0, 7.0]]])
    for t in (0.0, 1.3):
        value, gx, gv = OscillatorCycle(2.0, 0.5).value_and_grad(x, v, np.array([t]))
        assert value == pytest.approx(math.sqrt(13.0) / 4, rel=TRAJ_RTOL)
    # dl/dx = e x / (r root N^2) = 3 * 3 / (5 sqrt(13) 4); dl/dv = e v / (w^2 r root N^2) = 3 * 2 / (0.25 ...)
    np.testing.assert_allclose(gx[0, 0, 0], 9.0 / (20 * math.sqrt(13.0)), rtol=TRAJ_RTOL)
    np.testing.assert_allclose(gv[0, 0, 0], 6.0 / (0.25 * 20 * math.sqrt(13.0)), rtol=TRAJ_RTOL)
    np.testing.assert_array_equal(gx[0, 1], 0.0)              # r = 0: the derivative is taken as 0
    np.testing.assert_array_equal(gv[0, 1], 0.0)
    np.testing.assert_array_equal(gx[..., 1], 0.0)


def test_oscillator_cycle_is_zero_on_the_ellipse_at_any_phase():
    A, w = 1.5, 2.0
    t = np.linspace(0.0, 3.0, 7)
    phase = np.array([0.0, 1.0, 2.5])
    x = np.zeros((7, 3, 2))
    v = np.zeros((7, 3, 2))
    x[:, :, 0] = A * np.cos(w * t[:, None] + phase)
    v[:, :, 0] = -A * w * np.sin(w * t[:, None] + phase)
    value, gx, gv = OscillatorCycle(A, w).value_and_grad(x, v, t)
    assert value == pytest.approx(0.0, abs=1e-14)


@pytest.mark.parametrize("settle", [0.0, 0.35])
@pytest.mark.parametrize("seed", [0, 1])
def test_oscillator_cycle_gradient_by_central_differences(seed, settle):
    obj = OscillatorCycle(0.7, 2.5, settle=settle)
    x, v, t = _random_traj(seed)
    _check_grads_by_fd(obj, x, v, t)
    if settle:                                   # steps before settle do not count
        _, gx, gv = obj.value_and_grad(x, v, t)
        np.testing.assert_array_equal(gx[t < settle], 0.0)
        np.testing.assert_array_equal(gv[t < settle], 0.0)


@pytest.mark.parametrize("kw, name", [(dict(amplitude=0.0, omega=1.0), "amplitude"),
                                      (dict(amplitude=1.0, omega=-1.0), "omega"),
                                      (dict(amplitude=1.0, omega=1.0, settle=np.nan), "settle")])
def test_oscillator_cycle_validation_names_the_argument(kw, name):
    with pytest.raises(ValueError, match=rf"\b{name}\b"):
        OscillatorCycle(**kw)

# --------------------------------------------------------------------------- quadratic

def test_quadratic_value_by_hand():
    # one state, one particle: x = (1, 2), v = (3, -1)
    # 1/2 [2 (1-0)^2 + 3 (2-1)^2] + 1/2 [0.5 (3-1)^2 + 0.5 (-1-1)^2] = 2.5 + 2 = 4.5
    x = np.array([[[1.0, 2.0]]])
    v = np.array([[[3.0, -1.0]]])
    q = Quadratic(wx=[2.0, 3.0], wv=0.5, xref=[0.0, 1.0], vref=1.0)
    value, gx, gv = q.value_and_grad(x, v, np.array([0.0]))
    assert value == pytest.approx(4.5, rel=TRAJ_RTOL)
    np.testing.assert_allclose(gx, [[[2.0, 3.0]]], rtol=TRAJ_RTOL)
    np.testing.assert_allclose(gv, [[[1.0, -1.0]]], rtol=TRAJ_RTOL)


SHAPE = (4, 3, 2)


@pytest.mark.parametrize("wx, wv, xref, vref", [
    (1.0, 0.5, 0.0, 0.0),
    (np.array([2.0, 0.5]), np.array([[[1.0]], [[2.0]], [[0.0]], [[3.0]]]), np.ones((3, 2)), -1.0),
    (np.linspace(0.1, 1, 24).reshape(SHAPE), 1.0, np.arange(4.0)[:, None, None], np.ones((1, 3, 1))),
])
def test_quadratic_with_broadcast_parameters(wx, wv, xref, vref):
    x, v, t = _random_traj(4, SHAPE)
    q = Quadratic(wx=wx, wv=wv, xref=xref, vref=vref)
    value, gx, gv = q.value_and_grad(x, v, t)
    bx = [np.broadcast_to(a, SHAPE) for a in (wx, xref)]
    bv = [np.broadcast_to(a, SHAPE) for a in (wv, vref)]
    want = 0.5 * np.sum(bx[0] * (x - bx[1]) ** 2) + 0.5 * np.sum(bv[0] * (v - bv[1]) ** 2)
    assert value == pytest.approx(want, rel=TRAJ_RTOL)
    assert gx.shape == SHAPE and gv.shape == SHAPE
    _check_grads_by_fd(q, x, v, t)


def test_quadratic_with_zero_velocity_weight_returns_no_gv():
    x, v, t = _random_traj(5)
    assert Quadratic(wx=1.0, wv=0.0, vref=3.0).value_and_grad(x, v, t)[2] is None


@pytest.mark.parametrize("kw, name", [
    (dict(xref=np.zeros(5)), "xref"),
    (dict(wx=np.zeros((3, 1, 2))), "wx"),
    (dict(wv=np.ones((2, 2, 3, 2))), "wv"),
    (dict(vref=np.zeros((4, 2, 2))), "vref"),
])
def test_quadratic_refuses_parameters_that_do_not_broadcast(kw, name):
    x, v, t = _random_traj(6, SHAPE)
    with pytest.raises(ValueError, match=rf"\b{name}\b"):
        Quadratic(**kw).value_and_grad(x, v, t)


@pytest.mark.parametrize("kw, exc, name", [
    (dict(wx=np.nan), ValueError, "wx"), (dict(vref="zero"), TypeError, "vref"),
])
def test_quadratic_validation_names_the_argument(kw, exc, name):
    with pytest.raises(exc, match=rf"\b{name}\b"):
        Quadratic(**kw)


# --------------------------------------------------------------------------- custom

def _quad_fn(x, v, t):
    return 0.5 * float(np.sum(x ** 2)), x.copy(), None


def test_custom_passes_through_and_converts():
    x, v, t = _random_traj(7)
    value, gx, gv = Custom(_quad_fn).value_and_grad(x, v, t)
    assert type(value) is float and value == pytest.approx(0.5 * np.sum(x ** 2), rel=TRAJ_RTOL)
    np.testing.assert_array_equal(gx, x)
    assert gv is None


def test_custom_objective_gives_the_same_gradients_as_the_builtin():
    surf = pr.Surface(np.random.default_rng(0).uniform(0, 1, (5, 5)), (0, 0), (1, 1), (True, False))
    scene = pr.Scene(surf, dt=0.05, n_steps=8)
    x0, v0 = [[0.3, 0.4], [0.6, 0.7]], [[0.2, 0.0], [0.0, -0.1]]
    quad = Quadratic(wx=1.0, wv=0.0)
    _, g_builtin, _ = pr.value_and_grad(scene, x0, v0, quad)
    _, g_custom, _ = pr.value_and_grad(scene, x0, v0, Custom(_quad_fn))
    for name in g_builtin:
        np.testing.assert_allclose(g_custom[name], g_builtin[name], rtol=TRAJ_RTOL, atol=TRAJ_RTOL)


@pytest.mark.parametrize("fn, exc, name", [
    (lambda x, v, t: (0.0, np.zeros(x.shape[1:]), None), ValueError, "objective gx"),
    (lambda x, v, t: (0.0, None, np.zeros((1,) + v.shape)), ValueError, "objective gv"),
    (lambda x, v, t: (0.0, np.full(x.shape, np.nan), None), ValueError, "objective gx"),
    (lambda x, v, t: (np.nan, None, None), ValueError, "objective value"),
    (lambda x, v, t: (np.zeros(2), None, None), ValueError, "objective value"),
    (lambda x, v, t: ("1", None, None), TypeError, "objective value"),
])
def test_custom_validates_what_the_function_returns(fn, exc, name):
    x, v, t = _random_traj(8)
    with pytest.raises(exc, match=rf"^mine {name}\b"):
        Custom(fn, name="mine").value_and_grad(x, v, t)


def test_custom_refuses_a_non_callable():
    with pytest.raises(TypeError, match=r"Custom\.fn"):
        Custom(3.0)


# --------------------------------------------------------------------------- regularization

@pytest.mark.parametrize("weight", [0.3, 1e-3, 2.0])
def test_regularization_value_and_gradient(weight):
    G = np.array([[1.0, -2.0], [0.5, 3.0]])
    value, grad = regularization(G, weight)
    assert value == pytest.approx(weight * 14.25, rel=TRAJ_RTOL)          # 1 + 4 + 0.25 + 9
    np.testing.assert_allclose(grad, 2 * weight * G, rtol=TRAJ_RTOL)
    fd = central_gradient(lambda g: regularization(g, weight)[0], G)
    assert relative_error(grad, fd) < FD_RTOL


def test_regularization_zero_weight_costs_nothing():
    assert regularization(np.ones((3, 3)), 0.0) == (0.0, None)


def test_regularization_enters_value_and_grad():
    G = np.random.default_rng(1).uniform(-1, 1, (4, 5))
    scene = pr.Scene(pr.Surface(G, (0, 0), (1, 1), (False, False)), dt=0.05, n_steps=5)
    x0 = [[0.3, 0.4]]
    R = 0.25
    loss0, g0, _ = pr.value_and_grad(scene, x0, None, Funnel(0.5))
    loss1, g1, _ = pr.value_and_grad(scene, x0, None, Funnel(0.5), regularization_weight=R)
    assert loss1 - loss0 == pytest.approx(R * np.sum(G ** 2), rel=TRAJ_RTOL)
    np.testing.assert_allclose(g1["values"] - g0["values"], 2 * R * G, rtol=TRAJ_RTOL, atol=TRAJ_RTOL)


@pytest.mark.parametrize("bad, exc", [(-0.1, ValueError), (np.nan, ValueError), ("1", TypeError)])
def test_regularization_weight_is_validated(bad, exc):
    scene = pr.Scene(pr.Surface(np.zeros((2, 2)), (0, 0), (1, 1), (False, False)), dt=0.1, n_steps=1)
    with pytest.raises(exc, match="regularization_weight"):
        pr.value_and_grad(scene, [[0.5, 0.5]], None, Funnel(), regularization_weight=bad)
