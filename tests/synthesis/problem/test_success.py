"""pes_ref.synthesis.problem.success: each success test's verdict by hand, and its surrogate (``cost``):
zero for a particle that passes with room to spare, positive for one that fails, and its
derivative against central differences entry by entry on fixed cases (every kind, in a start
group and in an any-of), and on random cases of every topology away from its kinks."""
import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, strategies as st

from _helpers import check_state_derivatives

from pes_ref.synthesis.problem.failing import fail_cost, has_fail_cost
from pes_ref.synthesis.problem.objective_terms import Domain, Exit, StayIn
from pes_ref.synthesis.problem.success import (SUCCESS_TESTS, AnyOfTest, CrossTest, CustomTest, ExitTest, FinalPositionTest,
                                               GroupTest, PositionAtTest, SpeedAtTest, StayInTest, WithinTest, applies,
                                               passes_all)
from pes_ref.synthesis.problem.surrogates import Surrogate
from pes_ref.testing import strategies as pst

PLANE = Domain((-1.0, -1.0), (1.0, 1.0), (False, False))
CYLINDER = Domain((-1.0, 0.0), (1.0, 2.0), (False, True))
T = np.arange(6) * 0.5
RNG = np.random.default_rng(11)
X = RNG.uniform(-0.9, 0.9, (6, 4, 2))
V = RNG.normal(0.0, 1.0, (6, 4, 2))
MARGIN = 0.25


class Band:
    """A user's own test: q0 ends in [0, 0.5], with its surrogate."""

    def passes(self, x, v, t):
        return (x[-1, :, 0] >= 0.0) & (x[-1, :, 0] <= 0.5)

    def cost(self, x, v, t, margin):
        e = x[-1, :, 0] - np.clip(x[-1, :, 0], 0.0, 0.5)
        gx = np.zeros_like(x)
        gx[-1, :, 0] = 2 * e
        return e * e, gx, None


def _members(n):
    return np.arange(n) >= 1


#: One of each kind on fixed parameters, and the compound ones, on trajectories away from their kinks.
FIXED = {
    "final_position": FinalPositionTest((0.3, 1.9), 0.5, CYLINDER),
    "position_at": PositionAtTest(1.0, (0.1, -0.2), 0.4, PLANE),
    "stay_in": StayInTest(StayIn((-0.2, -0.3), (0.4, 0.25), 0.5, 2.0, 1.0, PLANE)),
    "within": WithinTest((0.2, 0.1), 0.5, 1.0, 2.5, PLANE),
    "exit": ExitTest(Exit("q1_lower", 0.1, 0.3, 1.0, Domain((-1.0, 0.0), (1.0, 2.0), (False, False))), 0.8, 0.75,
                     2.0),
    "cross": CrossTest((0.5, -0.2), (0.5, 0.3), 0.5, math.inf, PLANE),
    "speed_at": SpeedAtTest(1.5, 1, -0.2, 0.3),
    "any_of": AnyOfTest((FinalPositionTest((0.5, 0.5), 0.2, PLANE), FinalPositionTest((-0.5, -0.5), 0.2, PLANE))),
    "custom": CustomTest(Band()),
}


def _case(kind):
    x, v = X.copy(), V.copy()
    if kind == "exit":      # q1 falls through 0 at different steps (too early, on time, too late), or never
        x[:, :, 1] = np.array([[1.5, 0.7, 0.9, 1.2], [0.8, -0.05, 0.6, 1.1], [0.2, -0.2, 0.4, 1.0],
                               [-0.3, -0.5, 0.3, 0.9], [-0.6, -0.8, 0.2, 0.8], [-0.9, -0.9, -0.1, 0.7]])
    return x, v


def _check(test, x, v, t, margin=MARGIN):
    return check_state_derivatives(Surrogate(test, margin, "s"), x, v, t)


def test_every_kind_has_a_fixed_case():
    assert set(FIXED) == set(SUCCESS_TESTS)


@pytest.mark.parametrize("kind", sorted(FIXED))
@pytest.mark.parametrize("grouped", [False, True])
def test_surrogate_derivative_matches_central_differences_entrywise(kind, grouped):
    test = GroupTest(FIXED[kind], "g", _members) if grouped else FIXED[kind]
    x, v = _case(kind)
    value = _check(test, x, v, T)
    assert value > 0, "the fixed case has a failing particle, so the check sees a derivative"


@pytest.mark.parametrize("kind", sorted(FIXED))
def test_a_surrogate_is_zero_exactly_where_particles_pass_with_room_to_spare(kind):
    test = FIXED[kind]
    x, v = _case(kind)
    c, _, _ = test.cost(x, v, T, MARGIN)
    assert c.shape == (x.shape[1],) and np.all(c >= 0)
    # zero exactly for the particles that pass with the margin; with margin 0, exactly for those that pass
    ok = test.passes(x, v, T)
    assert np.all(ok[c == 0.0]), (c, ok)
    c0, _, _ = test.cost(x, v, T, 0.0)
    assert np.all(c0[~ok] > 0.0), (c0, ok)
    if kind != "custom":                    # a user's own test has no room to spare
        assert np.array_equal(c == 0.0, test.passes(x, v, T, MARGIN)), (c, test.passes(x, v, T, MARGIN))


def test_an_exits_window_is_charged_too_early_and_too_late():
    test = FIXED["exit"]                    # from 0.75 to 2: particle 1 leaves at 0.5, 2 at 2.5, 3 never
    x, v = _case("exit")
    v[:, :, 1] = -1.0                       # fast enough everywhere: only the window and the band count
    x[:, :, 0] = 0.1                        # on the band's centre
    c, _, _ = test.cost(x, v, T, 0.0)
    assert test.passes(x, v, T).tolist() == [True, False, False, False]
    assert c[0] == 0.0 and np.all(c[1:] > 0.0), c
    # too early by 0.05 past the edge at t = 0.5 (one of the two states before from), in half-widths
    assert c[1] == pytest.approx(0.5 * (0.05 / 0.3) ** 2, rel=1e-12)
    # too late: the deepest state by t = 2 is 0.2 short of the edge
    assert c[2] == pytest.approx((0.2 / 0.3) ** 2, rel=1e-12)
    # a run cut short of `from` (from 1.25, a stage's horizon t <= 0.5) charges leaving too early, not too late
    short, _, _ = dataclasses.replace(test, start=1.25).cost(x[:2], v[:2], T[:2], 0.0)
    assert short[1] == pytest.approx(0.5 * (0.05 / 0.3) ** 2, rel=1e-12) and np.all(short[[0, 2, 3]] == 0.0)


def test_verdicts_by_hand():
    t = np.array([0.0, 1.0, 2.0])
    x = np.array([[[0.0, 0.0], [0.0, 0.0]], [[0.5, 0.0], [0.0, 0.9]], [[0.55, 0.05], [0.0, -0.9]]])
    v = np.zeros_like(x)
    within = WithinTest((0.5, 0.0), 0.1, 1.0, math.inf, PLANE)
    assert within.passes(x, v, t).tolist() == [True, False]
    # the second particle's move from (0, 0.9) to (0, -0.9) crosses the segment y = 0 for -0.2 < q0 < 0.2
    cross = CrossTest((-0.2, 0.0), (0.2, 0.0), 0.0, math.inf, PLANE)
    assert cross.passes(x, v, t).tolist() == [False, True]
    assert CrossTest((-0.2, 0.0), (0.2, 0.0), 0.0, 0.5, PLANE).passes(x, v, t).tolist() == [False, False]
    both = AnyOfTest((within, cross))
    assert both.passes(x, v, t).tolist() == [True, True]
    assert GroupTest(within, "g", lambda n: np.array([False, True])).passes(x, v, t).tolist() == [True, False]
    # a particle outside the group passes the group's test whatever it does
    assert GroupTest(within, "g", lambda n: np.array([True, False])).passes(x, v, t).tolist() == [True, True]
    assert applies(GroupTest(within, "g", lambda n: np.array([False, True])), 2).tolist() == [False, True]
    assert applies(within, 2).tolist() == [True, True]
    every, each = passes_all([within, cross], x, v, t)
    assert every.tolist() == [False, False] and [e.tolist() for e in each] == [[True, False], [False, True]]


def test_a_disc_test_wraps_the_short_way_round():
    t = np.array([0.0])
    x = np.array([[[0.0, 1.95]]])            # 0.1 from (0, 0.05) across the cylinder's seam
    assert WithinTest((0.0, 0.05), 0.15, 0.0, math.inf, CYLINDER).passes(x, np.zeros_like(x), t).tolist() == [True]


def test_the_surrogate_of_an_any_of_is_the_cheapest_alternative():
    test = FIXED["any_of"]
    x, v = _case("any_of")
    c, _, _ = test.cost(x, v, T, MARGIN)
    each = np.stack([t.cost(x, v, T, MARGIN)[0] for t in test.tests])
    assert np.array_equal(c, each.min(axis=0))


def test_a_custom_test_must_have_passes():
    with pytest.raises(TypeError, match="passes"):
        CustomTest(Band)                    # the class, not an object
    with pytest.raises(TypeError, match="passes"):
        CustomTest(object())


def test_a_segment_needs_two_ends():
    with pytest.raises(ValueError, match="same point"):
        CrossTest((0.1, 0.2), (0.1, 0.2), 0.0, math.inf, PLANE)


@st.composite
def smooth_cases(draw):
    """A disc, box or speed test on a random domain of any topology, with states away from the
    surrogate's kinks (its shrunk disc's rim, its shrunk box's faces, its speed bounds)."""
    periodic = draw(pst.topologies())
    rng = np.random.default_rng(draw(pst.seeds()))
    lower = rng.uniform(-2.0, 0.0, 2)
    length = rng.uniform(1.0, 3.0, 2)
    domain = Domain(tuple(lower), tuple(lower + length), tuple(periodic))
    n_states, n = int(rng.integers(2, 7)), int(rng.integers(1, 4))
    t = 0.1 * np.arange(n_states)
    shape = (n_states, n, 2)
    laps = np.where(periodic, rng.integers(-1, 2, shape), 0) * length
    center = lower + rng.uniform(0, 1, 2) * length
    kind = draw(st.sampled_from(["final_position", "position_at", "within", "stay_in", "speed_at"]))
    margin = float(rng.uniform(0.0, 0.5))
    v = rng.normal(0.0, 1.0, shape)
    if kind == "stay_in":
        half = rng.uniform(0.05, 0.4, 2) * length
        start, end = sorted(rng.uniform(0.0, t[-1], 2))
        test = StayInTest(StayIn(tuple(center - half), tuple(center + half), float(start), float(end), 1.0, domain))
        x = center + pst._away(rng.uniform(-0.45, 0.45, shape) * length, half * (1 - margin)) + laps
    elif kind == "speed_at":
        low, high = sorted(rng.normal(0.0, 1.0, 2))
        test = SpeedAtTest(float(t[rng.integers(n_states)]), int(rng.integers(2)), float(low), float(high))
        scale = test._scale()
        v = np.where(np.abs(v - (low + margin * scale)) < 1e-3, v + 2e-3, v)
        v = np.where(np.abs(v - (high - margin * scale)) < 1e-3, v + 2e-3, v)
        x = center + rng.uniform(-0.45, 0.45, shape) * length
    else:
        radius = float(rng.uniform(0.05, 0.4) * length.min())
        test = {"final_position": lambda: FinalPositionTest(tuple(center), radius, domain),
                "position_at": lambda: PositionAtTest(float(t[rng.integers(n_states)]), tuple(center), radius, domain),
                "within": lambda: WithinTest(tuple(center), radius, float(t[0]), float(t[-1]), domain)}[kind]()
        r = pst._away(rng.uniform(0.0, 0.45 * length.min(), (n_states, n)), radius * (1 - margin))
        angle = rng.uniform(0, 2 * np.pi, (n_states, n))
        x = center + np.stack([r * np.cos(angle), r * np.sin(angle)], axis=-1) + laps
    return test, x, v, t, margin


KINDS = ["final_position", "position_at", "within", "stay_in", "exit", "cross", "speed_at", "any_of", "group"]


def _random_test(kind, rng, domain, t):
    """A test of ``kind`` with random parameters (a window anywhere in the run) on ``domain``."""
    lower, length = np.asarray(domain.lower), np.asarray(domain.upper) - np.asarray(domain.lower)
    point = lambda: tuple(lower + rng.uniform(0.2, 0.8, 2) * length)        # noqa: E731
    start, end = sorted(rng.uniform(0.0, t[-1], 2))
    radius = float(rng.uniform(0.1, 0.5) * length.min())
    if kind == "final_position":
        return FinalPositionTest(point(), radius, domain)
    if kind == "position_at":
        return PositionAtTest(float(rng.choice(t)), point(), radius, domain)
    if kind == "within":
        return WithinTest(point(), radius, float(start), float(end), domain)
    if kind == "stay_in":
        c, half = np.asarray(point()), rng.uniform(0.1, 0.4, 2) * length
        return StayInTest(StayIn(tuple(c - half), tuple(c + half), float(start), float(end), 1.0, domain))
    if kind == "exit":                      # a wide band, a window that often holds the exit
        return ExitTest(Exit("q0_upper", point()[1], 2.0 * radius, 1.0, domain), float(rng.choice([0.0, 0.5])),
                        float(start) / 2, float(end) if rng.random() < 0.7 else math.inf)
    if kind == "cross":                     # a long segment, mostly across q0
        a = point()
        return CrossTest((a[0], -0.8), (a[0] + rng.uniform(-0.3, 0.3), 0.8), float(start) / 2, float(end), domain)
    if kind == "speed_at":
        low, high = sorted(rng.normal(0.0, 1.0, 2))
        return SpeedAtTest(float(rng.choice(t)), int(rng.integers(2)), float(low), float(high))
    if kind == "any_of":
        return AnyOfTest(tuple(_random_test(k, rng, domain, t) for k in rng.choice(KINDS[:7], 2)))
    return GroupTest(_random_test(str(rng.choice(KINDS[:7])), rng, domain, t), "g", _members)


@st.composite
def random_cases(draw):
    """A random test of every kind (windows, any-of, a group's) and random particles: paths that
    wander from a random start with random steps (some through the exit edge q0 = upper)."""
    kind = draw(st.sampled_from(KINDS))
    rng = np.random.default_rng(draw(pst.seeds()))
    domain = Domain((-1.0, -1.0), (1.0, 1.0), (False, False))
    n_states, n = int(rng.integers(3, 9)), int(rng.integers(1, 7))
    t = 0.25 * np.arange(n_states)
    drift = np.array([rng.uniform(-0.1, 0.5), 0.0])          # towards the exit edge q0 = 1, or not
    x = rng.uniform(-0.9, 0.9, (1, n, 2)) + np.cumsum(drift + rng.normal(0.0, 0.2, (n_states, n, 2)), axis=0)
    x[0] = np.clip(x[0], -0.95, 0.95)
    return _random_test(kind, rng, domain, t), x, rng.normal(0.0, 1.0, (n_states, n, 2)), t, float(rng.uniform(0, 0.5))


@given(random_cases())
def test_a_surrogate_is_zero_exactly_when_its_test_passes_with_the_margin(case):
    test, x, v, t, margin = case
    c, _, _ = test.cost(x, v, t, margin)
    assert c.shape == (x.shape[1],) and np.all(c >= 0.0)
    assert np.array_equal(c == 0.0, test.passes(x, v, t, margin)), (c, test.passes(x, v, t, margin))
    c0, _, _ = test.cost(x, v, t, 0.0)
    assert np.array_equal(c0 == 0.0, test.passes(x, v, t)), (c0, test.passes(x, v, t))


@given(random_cases(), st.floats(1.1, 3.0))
def test_a_surrogate_grows_with_the_distance_from_passing(case, stretch):
    # a failing path moved further from passing costs more: scaled away from a path that passes with
    # the margin (the region's centre; for an exit, a path out through the band's centre on time,
    # moved along the edge or back from it), and for a crossing moved away across the segment's normal
    test, x, v, t, margin = case
    inner = getattr(test, "test", test)
    if isinstance(inner, AnyOfTest):
        return                              # the cheapest of two: each grows by its own test
    base, _, _ = test.cost(x, v, t, margin)
    if isinstance(inner, (FinalPositionTest, PositionAtTest, WithinTest, StayInTest)):
        centre = np.mean(inner.region(), axis=0)
        far_x, far_v = centre + stretch * (x - centre), v
    elif isinstance(inner, SpeedAtTest):
        mid = 0.5 * (max(inner.low, -5.0) + min(inner.high, 5.0))
        far_x, far_v = x, v.copy()
        far_v[..., inner.axis] = mid + stretch * (v[..., inner.axis] - mid)
    elif isinstance(inner, CrossTest):
        s = np.subtract(inner.b, inner.a)
        normal = np.array([-s[1], s[0]]) / np.hypot(*s)
        side = np.sign(np.sum((x - inner.a) * normal, axis=-1, keepdims=True))
        if not np.all(side == side[:1]):
            return                          # a path on both sides crosses the segment's line
        far_x, far_v = x + (stretch - 1.0) * side * normal, v
    else:                                   # an exit: along the edge from the band's centre
        far_x, far_v = x.copy(), v
        far_x[..., 1] = inner.edge.center + stretch * (x[..., 1] - inner.edge.center)
    far, _, _ = test.cost(far_x, far_v, t, margin)
    assert np.all(far >= base - 1e-12 * (1.0 + base)), (base, far)
    grows = base > 0.0                      # every failing particle costs more further away ...
    if isinstance(inner, ExitTest):         # ... an exit's where it leaves outside the band (its window
        along = inner._judged(x)[4]         # and speed do not move with the stretch along the edge)
        grows &= np.abs(along) > inner.edge.halfwidth * (1.0 - margin)
    assert np.all(far[grows] > base[grows]), (base, far)


@given(smooth_cases())
def test_surrogate_derivative_matches_central_differences_on_random_cases(case):
    test, x, v, t, margin = case
    _check(test, x, v, t, margin)


@given(random_cases())
def test_a_surrogate_of_failing_is_zero_exactly_when_its_test_fails_with_the_margin(case):
    # the mirror of the surrogate, what a share above its max charges (pes_ref.synthesis.failing)
    test, x, v, t, margin = case
    if not has_fail_cost(test):
        return                              # a crossing (or an any-of or group holding one): refused there
    c, _, _ = fail_cost(test, x, v, t, margin)
    assert c.shape == (x.shape[1],) and np.all(c >= 0.0)
    judged = applies(test, x.shape[1])      # a group's test: the others pass it and are not charged
    assert np.array_equal(c > 0.0, judged & test.passes(x, v, t, -margin)), (c, test.passes(x, v, t, -margin))


@pytest.mark.parametrize("kind", sorted(set(FIXED) - {"cross", "custom"}))
def test_a_surrogate_of_failing_grows_into_passing_and_matches_central_differences(kind):
    # on a fixed case drawn into passing (some particles), away from its kinks
    test = FIXED[kind]
    x, v = _case(kind)
    if hasattr(test, "region"):             # drawn towards the region's centre
        centre = np.mean(test.region(), axis=0)
        x = centre + np.array([[0.2], [0.5], [0.9], [1.0]]) * (x - centre)
    elif kind == "exit":                    # out fast within the band (particle 0 on time)
        x[..., 0] = 0.1 + 0.3 * (x[..., 0] - 0.1)
        v[..., 1] = -1.5 + 0.1 * v[..., 1]
    elif kind == "any_of":                  # two end near the first target, one near the second
        x[-1, :2] = (0.5, 0.5) + 0.3 * x[-1, :2]
        x[-1, 2] = (-0.5, -0.5) + 0.1 * x[-1, 2]
    else:                                   # speed_at: slow at its time
        v[..., 1] = 0.05 + 0.2 * v[..., 1]
    c, _, _ = fail_cost(test, x, v, T, MARGIN)
    assert np.array_equal(c > 0.0, test.passes(x, v, T, -MARGIN)) and np.count_nonzero(c) >= 1, c

    class Failing:
        def cost(self, x, v, t, margin):
            return fail_cost(test, x, v, t, margin)
    _check(Failing(), x, v, T)
