"""Unit tests of pes_ref.core.effects: external force effects and their schedule (SPEC section 2)."""
import numpy as np
import pytest

from pes_ref import Constant, Noise, PerParticle, Schedule, Window, build_schedule
from pes_ref.core.effects import step_times

N, T = 3, 8
#: dt and t0 are dyadic so that every t_n = t0 + n dt is exact and window edges can sit on it.
DT, T0 = 0.25, 0.5

#: Sample size per axis for the noise statistics, and the tolerance on the sample std:
#: the sample std of n normal draws has relative std 1/sqrt(2n) (0.2 % here); 5 of those.
NOISE_STEPS, NOISE_PARTICLES = 1999, 50
NOISE_N = (NOISE_STEPS + 1) * NOISE_PARTICLES
NOISE_STD_RTOL = 5.0 / np.sqrt(2 * NOISE_N)
#: ... and on the sample mean, in units of std: 5 / sqrt(n).
NOISE_MEAN_TOL = 5.0 / np.sqrt(NOISE_N)


def _build(*effects, n=N, t=T, dt=DT, t0=T0):
    return build_schedule(list(effects), n, t, dt, t0)


def test_step_times_are_t0_plus_n_dt():
    np.testing.assert_array_equal(step_times(4, DT, T0), [0.5, 0.75, 1.0, 1.25, 1.5])


@pytest.mark.parametrize("effects", [[], ()])
def test_no_effects_means_no_schedule(effects):
    assert build_schedule(effects, N, T, DT, T0) is None


def test_constant_is_the_same_everywhere():
    s = _build(Constant((1.0, -2.0)))
    assert s.shape == (T + 1, N, 2) and s.dtype == np.float64
    np.testing.assert_array_equal(s[..., 0], 1.0)
    np.testing.assert_array_equal(s[..., 1], -2.0)


def test_per_particle_is_constant_in_time():
    f = np.arange(2 * N, dtype=np.int64).reshape(N, 2)
    s = _build(PerParticle(f))
    np.testing.assert_array_equal(s, np.broadcast_to(f.astype(float), (T + 1, N, 2)))


def test_effects_add_up():
    f = np.arange(2 * N, dtype=float).reshape(N, 2)
    s = _build(Constant((1.0, 2.0)), PerParticle(f), Constant((0.5, 0.0)))
    np.testing.assert_array_equal(s, np.broadcast_to(f + [1.5, 2.0], (T + 1, N, 2)))


# t_n = 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5 for n = 0..8
@pytest.mark.parametrize("t_start, t_end, on", [
    (0.75, 1.25, [1, 2]),              # end on a step time: excluded (half-open)
    (0.7, 1.3, [1, 2, 3]),
    (0.5, 0.75, [0]),                  # start on t0: included
    (-10.0, 10.0, list(range(T + 1))),
    (2.5, 3.0, [8]),                   # the last state's force
    (2.6, 3.0, []),
    (0.0, 0.5, []),                    # ends exactly at t0
])
def test_window_is_half_open_on_step_times(t_start, t_end, on):
    s = _build(Window(Constant((3.0, -1.0)), t_start, t_end))
    mask = np.zeros(T + 1, dtype=bool)
    mask[on] = True
    np.testing.assert_array_equal(s[mask], np.broadcast_to([3.0, -1.0], (mask.sum(), N, 2)))
    np.testing.assert_array_equal(s[~mask], 0.0)


def test_window_uses_t0():
    # same window, t0 shifted by one step: the on-steps shift by one
    a = _build(Window(Constant((1.0, 1.0)), 1.0, 1.5), t0=T0)
    b = _build(Window(Constant((1.0, 1.0)), 1.0, 1.5), t0=T0 + DT)
    np.testing.assert_array_equal(a[1:], b[:-1])
    assert a[:, 0, 0].tolist().index(1.0) == 2 and b[:, 0, 0].tolist().index(1.0) == 1


def test_window_around_noise_keeps_the_draws_inside():
    noise = Noise((1.0, 2.0), seed=11)
    full = _build(noise)
    s = _build(Window(noise, 1.0, 2.0))                  # on at n = 2, 3, 4, 5
    np.testing.assert_array_equal(s[2:6], full[2:6])
    np.testing.assert_array_equal(s[:2], 0.0)
    np.testing.assert_array_equal(s[6:], 0.0)


def test_noise_per_axis_std_on_a_large_draw():
    std = np.array([0.5, 2.0])
    s = build_schedule([Noise(std, seed=0)], NOISE_PARTICLES, NOISE_STEPS, DT, T0)
    sample = s.reshape(-1, 2)
    assert sample.shape[0] == NOISE_N
    np.testing.assert_allclose(sample.std(axis=0), std, rtol=NOISE_STD_RTOL)
    assert np.all(np.abs(sample.mean(axis=0)) < NOISE_MEAN_TOL * std)
    # independent across axes, steps and particles: tiny correlations
    assert abs(np.corrcoef(sample[:, 0], sample[:, 1])[0, 1]) < NOISE_MEAN_TOL
    assert abs(np.corrcoef(s[1:, :, 0].ravel(), s[:-1, :, 0].ravel())[0, 1]) < 2 * NOISE_MEAN_TOL


def test_noise_is_the_documented_draw():
    """docs/decisions.md item 6: default_rng(seed).standard_normal((T+1, N, 2)) * std."""
    std = np.array([0.3, 0.7])
    want = np.random.default_rng(42).standard_normal((T + 1, N, 2)) * std
    np.testing.assert_array_equal(_build(Noise(std, seed=42)), want)


def test_noise_is_reproducible_by_seed():
    a = _build(Noise((1.0, 1.0), seed=3))
    b = _build(Noise((1.0, 1.0), seed=3))
    c = _build(Noise((1.0, 1.0), seed=4))
    np.testing.assert_array_equal(a, b)
    assert not np.any(a == c)


@pytest.mark.parametrize("std", [(0.0, 0.0), (0, 0), np.zeros(2, dtype=np.float32)])
def test_noise_with_zero_std_is_zero(std):
    s = _build(Noise(std, seed=1))
    np.testing.assert_array_equal(s, 0.0)


def test_noise_with_one_zero_axis():
    s = _build(Noise((0.0, 1.0), seed=1))
    np.testing.assert_array_equal(s[..., 0], 0.0)
    assert np.all(s[..., 1] != 0.0)


def test_schedule_is_added_as_given():
    f = np.random.default_rng(0).standard_normal((T + 1, N, 2))
    np.testing.assert_array_equal(_build(Schedule(f)), f)
    np.testing.assert_array_equal(_build(Schedule(f), Constant((1.0, 0.0)))[..., 0], f[..., 0] + 1.0)


def test_build_schedule_does_not_modify_effect_arrays():
    f = np.ones((T + 1, N, 2))
    eff = Schedule(f)
    _build(eff, Constant((1.0, 1.0)))
    _build(eff, Constant((1.0, 1.0)))
    np.testing.assert_array_equal(eff.force, 1.0)
    np.testing.assert_array_equal(f, 1.0)


# --------------------------------------------------------------------------- validation

@pytest.mark.parametrize("make, exc, name", [
    (lambda: Constant((1.0, 2.0, 3.0)), ValueError, "Constant.force"),
    (lambda: Constant((1.0, np.nan)), ValueError, "Constant.force"),
    (lambda: Constant("up"), TypeError, "Constant.force"),
    (lambda: PerParticle(np.zeros(2)), ValueError, "PerParticle.force"),
    (lambda: PerParticle(np.zeros((3, 3))), ValueError, "PerParticle.force"),
    (lambda: PerParticle([[np.inf, 0.0]]), ValueError, "PerParticle.force"),
    (lambda: Noise((-1.0, 1.0), 0), ValueError, "Noise.std"),
    (lambda: Noise((1.0,), 0), ValueError, "Noise.std"),
    (lambda: Noise((1.0, np.nan), 0), ValueError, "Noise.std"),
    (lambda: Noise((1.0, 1.0), -1), ValueError, "Noise.seed"),
    (lambda: Noise((1.0, 1.0), 1.5), TypeError, "Noise.seed"),
    (lambda: Window("not an effect", 0.0, 1.0), TypeError, "Window.effect"),
    (lambda: Window(Constant((1, 1)), 1.0, 1.0), ValueError, "Window.t_end"),
    (lambda: Window(Constant((1, 1)), 0.0, np.inf), ValueError, "Window.t_end"),
    (lambda: Window(Constant((1, 1)), np.nan, 1.0), ValueError, "Window.t_start"),
    (lambda: Schedule(np.zeros((T + 1, N))), ValueError, "force"),
    (lambda: Schedule(np.zeros((T + 1, N, 3))), ValueError, "force"),
    (lambda: Schedule(np.full((T + 1, N, 2), np.nan)), ValueError, "force"),
])
def test_effect_validation_names_the_argument(make, exc, name):
    with pytest.raises(exc, match=rf"(?<![\w.]){name}\b"):
        make()


@pytest.mark.parametrize("effect, name", [
    (PerParticle(np.zeros((N + 1, 2))), "PerParticle.force"),
    (Schedule(np.zeros((T, N, 2))), "force"),
    (Schedule(np.zeros((T + 1, N + 1, 2))), "force"),
    (Window(Schedule(np.zeros((T, N, 2))), 0.0, 1.0), "force"),
])
def test_shape_mismatch_with_the_scene_is_refused_when_building(effect, name):
    with pytest.raises(ValueError, match=rf"(?<![\w.]){name}\b"):
        _build(effect)
