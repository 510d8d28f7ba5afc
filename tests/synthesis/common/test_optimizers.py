"""Optimizers: updates against hand-computed steps, clipping, known minima, bit-exact state."""
import numpy as np
import pytest

from pes_ref.synthesis.common.optimizers import Adam, RMSprop, clip_by_norm, make_optimizer, optimizer_from_state

G1 = np.array([0.5, -2.0])
G2 = np.array([1.0, 4.0])
P0 = np.array([1.0, 3.0])


def test_rmsprop_two_steps_by_hand():
    opt = RMSprop(lr=0.1, rho=0.9, eps=1e-8)
    p1 = opt.step(P0, G1)
    s1 = (1 - 0.9) * G1 ** 2
    np.testing.assert_array_equal(p1, P0 - 0.1 * G1 / (np.sqrt(s1) + 1e-8))
    p2 = opt.step(p1, G2)
    s2 = 0.9 * s1 + (1 - 0.9) * G2 ** 2
    np.testing.assert_array_equal(p2, p1 - 0.1 * G2 / (np.sqrt(s2) + 1e-8))


def test_adam_two_steps_by_hand():
    opt = Adam(lr=0.1, beta1=0.9, beta2=0.999, eps=1e-8)
    p1 = opt.step(P0, G1)
    m, v = 0.1 * G1, 0.001 * G1 ** 2
    want1 = P0 - 0.1 * (m / 0.1) / (np.sqrt(v / 0.001) + 1e-8)
    np.testing.assert_allclose(p1, want1, rtol=1e-15)
    p2 = opt.step(p1, G2)
    m, v = 0.9 * m + 0.1 * G2, 0.999 * v + 0.001 * G2 ** 2
    want2 = p1 - 0.1 * (m / (1 - 0.9 ** 2)) / (np.sqrt(v / (1 - 0.999 ** 2)) + 1e-8)
    np.testing.assert_allclose(p2, want2, rtol=1e-15)


def test_step_never_writes_its_inputs():
    p, g = P0.copy(), G1.copy()
    RMSprop().step(p, g)
    np.testing.assert_array_equal(p, P0)
    np.testing.assert_array_equal(g, G1)


@pytest.mark.parametrize("g, max_norm, want", [
    (np.array([3.0, 4.0]), 1.0, np.array([0.6, 0.8])),      # norm 5 scaled to 1
    (np.array([3.0, 4.0]), 10.0, np.array([3.0, 4.0])),     # below the limit: unchanged
    (np.array([3.0, 4.0]), None, np.array([3.0, 4.0])),     # clipping off
])
def test_clip_by_norm(g, max_norm, want):
    np.testing.assert_allclose(clip_by_norm(g, max_norm), want, rtol=1e-15)


@pytest.mark.parametrize("kind", ["rmsprop", "adam"])
def test_clip_inside_the_optimizer_equals_clipping_first(kind):
    g = np.array([30.0, -40.0])
    clipped = make_optimizer(kind, lr=0.1, clip=2.0).step(P0, g)
    plain = make_optimizer(kind, lr=0.1).step(P0, clip_by_norm(g, 2.0))
    np.testing.assert_array_equal(clipped, plain)


@pytest.mark.parametrize("kind, lr", [("rmsprop", 0.01), ("adam", 0.05)])
def test_reaches_the_minimum_of_a_quadratic_bowl(kind, lr):
    # f(p) = 1/2 (p - c)^T diag(a) (p - c), minimum at c, badly scaled on purpose
    a, c = np.array([100.0, 0.01]), np.array([0.3, -0.7])
    opt, p = make_optimizer(kind, lr=lr), np.zeros(2)
    for _ in range(3000):
        p = opt.step(p, a * (p - c))
    # RMSprop/Adam steps are ~lr in size whatever the scale: the iterate ends within ~lr of c
    np.testing.assert_allclose(p, c, atol=2 * lr)


@pytest.mark.parametrize("kind, clip", [("rmsprop", None), ("adam", 1.5), ("rmsprop", 0.5)])
def test_state_round_trip_continues_bit_exactly(kind, clip):
    rng = np.random.default_rng(0)
    grads = rng.standard_normal((8, 3, 2))
    full, p_full = make_optimizer(kind, lr=0.05, clip=clip), np.ones((3, 2))
    for g in grads:
        p_full = full.step(p_full, g)
    half, p = make_optimizer(kind, lr=0.05, clip=clip), np.ones((3, 2))
    for g in grads[:4]:
        p = half.step(p, g)
    state = {k: v.copy() for k, v in half.state_dict().items()}
    resumed = optimizer_from_state(state)
    for g in grads[4:]:
        p = resumed.step(p, g)
    np.testing.assert_array_equal(p, p_full)


def test_reset_forgets_the_moments():
    opt = RMSprop(lr=0.1)
    opt.step(P0, G1)
    opt.reset()
    assert opt.t == 0
    np.testing.assert_array_equal(opt.step(P0, G2), RMSprop(lr=0.1).step(P0, G2))


@pytest.mark.parametrize("make, match", [
    (lambda: RMSprop(lr=-1.0), "lr"),
    (lambda: RMSprop(rho=1.0), "rho"),
    (lambda: Adam(beta2=1.5), "beta2"),
    (lambda: RMSprop(clip=0.0), "clip"),
    (lambda: make_optimizer("sgd"), "optimizer"),
])
def test_bad_hyper_parameters_are_refused(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_shape_change_without_reset_is_refused():
    opt = RMSprop()
    opt.step(np.zeros(3), np.ones(3))
    with pytest.raises(ValueError, match="reset"):
        opt.step(np.zeros(4), np.ones(4))
