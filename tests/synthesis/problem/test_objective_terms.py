"""pes_ref.synthesis.problem.objective_terms: each term of a problem file, its value by hand and its
derivative with respect to the states by central differences, entry by entry on fixed cases
and on random ones of every topology (hypothesis), away from the kinks."""
import math

import numpy as np
import pytest
from hypothesis import given

from _helpers import check_state_derivatives

from pes_ref.core.objectives import Oscillator
from pes_ref.oracle.compare import relative_error
from pes_ref.oracle.tolerances import FD_RTOL, TRAJ_RTOL
from pes_ref.synthesis import FunnelExit
from pes_ref.synthesis.problem.objective_terms import (OBJECTIVE_TERMS, CustomTerm, Cycle, Domain, Exit, FinalPosition,
                                                       PositionAt, Regularization, SpeedAt, StayIn, TermSum)
from pes_ref.testing import strategies as pst
from pes_ref.testing.finite_differences import central_gradient

PLANE = Domain((-1.0, -1.0), (1.0, 1.0), (False, False))
CYLINDER = Domain((-1.0, 0.0), (1.0, 2.0), (False, True))      # q1 periodic, period 2
T = np.arange(5) * 0.25
RNG = np.random.default_rng(7)
X = RNG.uniform(-0.9, 0.9, (5, 3, 2))
V = RNG.normal(0.0, 1.0, (5, 3, 2))


class Quadratic:
    """A user's own objective: ``sum (x - 0.2)^2 + 0.5 sum v^2``."""

    def value_and_grad(self, x, v, t):
        return float(np.sum((x - 0.2) ** 2) + 0.5 * np.sum(v * v)), 2 * (x - 0.2), v.copy()


#: One of each state term on fixed parameters (the cylinder's wrap exercised by final_position).
FIXED = {
    "final_position": FinalPosition((0.3, 1.9), 1.5, CYLINDER),
    "position_at": PositionAt(0.5, (0.1, -0.2), 2.0, PLANE),
    "stay_in": StayIn((-0.2, -0.3), (0.4, 0.25), 0.25, 0.75, 3.0, PLANE),
    "speed_at": SpeedAt(0.75, 1, 0.4, 0.5),
    "cycle": Cycle(0.8, 1.3, 1, 2.0),
    "exit": Exit("q1_lower", 0.1, 0.05, 1.5, Domain((-1.0, 0.0), (1.0, 2.0), (False, False))),
    "custom": CustomTerm(Quadratic(), 0.7),
}


def test_every_state_term_kind_has_a_fixed_case():
    assert set(FIXED) == {k for k, cls in OBJECTIVE_TERMS.items() if not hasattr(cls, "grid_value_and_grad")}


_check_derivatives = check_state_derivatives


@pytest.mark.parametrize("kind", sorted(FIXED))
def test_derivative_matches_central_differences_entrywise(kind):
    x = X.copy()
    if kind == "exit":                      # q1 falls through 0 at different steps, away from the level
        x[:, :, 1] = np.array([[1.5, 0.7, 0.9], [0.8, 0.3, 0.6], [0.2, -0.2, 0.4], [-0.3, -0.5, 0.3],
                               [-0.6, -0.8, 0.2]])
    value = _check_derivatives(FIXED[kind], x, V, T)
    assert value > 0


@given(pst.term_cases())
def test_derivative_matches_central_differences_on_random_cases(case):
    term, x, v, t = case
    _check_derivatives(term, x, v, t)


def test_values_by_hand():
    x, v = X, V
    fp = FIXED["final_position"]
    d = x[-1] - np.array([0.3, 1.9])
    d[:, 1] -= 2.0 * np.round(d[:, 1] / 2.0)                   # the short way round the cylinder
    assert fp.value_and_grad(x, v, T)[0] == pytest.approx(1.5 * np.sum(d * d), rel=TRAJ_RTOL)
    pa = FIXED["position_at"]                                   # t = 0.5 is state 2
    assert pa.value_and_grad(x, v, T)[0] == pytest.approx(2.0 * np.sum((x[2] - [0.1, -0.2]) ** 2), rel=TRAJ_RTOL)
    sa = FIXED["speed_at"]                                      # t = 0.75 is state 3
    assert sa.value_and_grad(x, v, T)[0] == pytest.approx(0.5 * np.sum((v[3, :, 1] - 0.4) ** 2), rel=TRAJ_RTOL)
    box = FIXED["stay_in"]                                      # states 1..3, the mean distance to the box
    lo, hi = np.array([-0.2, -0.3]), np.array([0.4, 0.25])
    e = x[1:4] - np.clip(x[1:4], lo, hi)
    assert box.value_and_grad(x, v, T)[0] == pytest.approx(3.0 * np.sum(e * e) / 3, rel=TRAJ_RTOL)
    inside = np.broadcast_to(0.5 * (lo + hi), x.shape).copy()
    assert box.value_and_grad(inside, v, T)[0] == 0.0


def test_a_time_after_the_run_charges_nothing():
    for term in (PositionAt(5.0, (0.0, 0.0), 1.0, PLANE), SpeedAt(5.0, 0, 1.0, 1.0),
                 StayIn((0, 0), (0.1, 0.1), 5.0, math.inf, 1.0, PLANE)):
        assert term.value_and_grad(X, V, T) == (0.0, None, None)


def test_exit_is_the_funnels_eq5_at_the_exit_bit_for_bit():
    x = X.copy()
    x[:, :, 1] = np.linspace(1.0, -1.0, 5)[:, None] + np.array([0.1, -0.2, 0.35])
    dom = Domain((-1.0, 0.0), (1.0, 2.0), (False, False))
    got = Exit("q1_lower", 0.05, 0.0, 1.0, dom).value_and_grad(x, V, T)
    want = FunnelExit(target=0.05, level=0.0).value_and_grad(x, V, T)
    assert got[0] == want[0]
    np.testing.assert_array_equal(got[1], want[1])


def test_cycle_is_eq6_on_its_axis():
    value, gx, gv = Cycle(0.8, 1.3, 0, 2.0).value_and_grad(X, V, T)
    want = Oscillator(0.8, 1.3).value_and_grad(X, V, T)
    assert value == 2.0 * want[0]
    np.testing.assert_array_equal(gx, 2.0 * want[1])
    swapped = Cycle(0.8, 1.3, 1, 1.0).value_and_grad(X[..., ::-1], V[..., ::-1], T)
    assert swapped[0] == want[0]
    np.testing.assert_array_equal(swapped[1][..., ::-1], want[1])


def test_regularization_is_eq7():
    g = RNG.normal(0.0, 1.0, (4, 5))
    value, grad = Regularization(0.3).grid_value_and_grad(g)
    assert value == pytest.approx(0.3 * np.sum(g * g), rel=TRAJ_RTOL)
    fd = central_gradient(lambda z: Regularization(0.3).grid_value_and_grad(z)[0], g)
    assert relative_error(grad, fd) < FD_RTOL


def test_the_sum_adds_values_and_derivatives():
    terms = [FIXED["position_at"], FIXED["speed_at"], FIXED["custom"]]
    total, gx, gv = TermSum(terms).value_and_grad(X, V, T)
    parts = [t.value_and_grad(X, V, T) for t in terms]
    assert total == pytest.approx(sum(p[0] for p in parts), rel=TRAJ_RTOL)
    np.testing.assert_allclose(gx, parts[0][1] + parts[2][1], rtol=TRAJ_RTOL)
    np.testing.assert_allclose(gv, parts[1][2] + parts[2][2], rtol=TRAJ_RTOL)
    assert TermSum(terms).values(X, V, T) == [p[0] for p in parts]


def test_an_exit_on_a_periodic_axis_is_refused():
    with pytest.raises(ValueError, match="periodic"):
        Exit("q1_lower", 0.0, 0.0, 1.0, CYLINDER)
