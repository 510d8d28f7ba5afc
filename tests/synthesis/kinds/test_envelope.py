"""The realizable funnel's "envelope" start (pes_ref.synthesis.kinds.envelope) and the plan that uses it."""
import dataclasses

import numpy as np
import pytest

from pes_ref import synthesis
from pes_ref.synthesis.kinds import envelope
from pes_ref.synthesis.kinds.funnel import FunnelProblem
from pes_ref.synthesis.kinds.registry import KINDS
from pes_ref.synthesis.common.plans import FUNNEL_ENVELOPE_PLAN, FUNNEL_PLAN, Plan

#: A small funnel: 21 x 21 nodes, 60 steps of 0.05 (the smoke preset's dynamics).
SMALL = dict(grid=21, n_steps=60, dt=0.05)
#: A short plan with a coarse stage, so a smooth design resamples and resets its optimizer once.
SHORT = Plan(iterations=6, lr=0.002, lr_final=0.0005, decay_iterations=4, stages=((0, 9), (3, 0)), n_particles=8)


def test_a_smooth_funnel_is_the_grid_the_design_run_makes():
    problem = FunnelProblem(**SMALL)
    state = synthesis.run_design(synthesis.new_design(problem, seed=3, plan=SHORT))
    assert np.array_equal(envelope.smooth_funnel(problem, 3, SHORT), state.values)


def test_a_smooth_funnel_refuses_a_validating_plan():
    with pytest.raises(ValueError, match="without validation"):
        envelope.smooth_funnel(FunnelProblem(**SMALL), 0, dataclasses.replace(SHORT, validate_every=2))


@pytest.mark.parametrize("hi", [
    [0.1, 0.5, 0.6, 0.9, 0.95],          # concave already: kept
    [0.1, 0.2, 0.7, 0.75, 1.0],          # a notch at q1 = 0.25 and a bulge: filled
    [0.3, 0.3, 0.3, 0.3, 0.3],           # straight
    [0.5, 0.1, 0.4, 0.2, 0.9],           # zigzag
])
def test_convex_walls_hold_every_row_and_make_the_channel_convex(hi):
    q1 = np.linspace(0.0, 1.0, len(hi))
    hi = np.array(hi)
    lo, hi2 = envelope.convex_walls(q1, -hi, hi)
    assert (hi2 >= hi - 1e-12).all() and np.allclose(lo, -hi2)
    assert (np.diff(hi2, 2) <= 1e-12).all()                   # concave right edge: no pocket
    assert np.allclose(envelope.convex_walls(q1, lo, hi2)[1], hi2)        # a convex channel is kept
    if (np.diff(hi, 2) <= 0).all():
        assert np.allclose(hi2, hi)


@pytest.mark.parametrize("target, width, inset", [(0.0, 2.0, 0.02), (0.3, 2.0, 0.0), (-0.1, 3.0, 0.05)])
def test_the_feet_are_put_inset_inside_the_band_by_moving_each_wall(target, width, inset):
    problem = FunnelProblem(target=target, width=width)
    lo, hi = np.array([-0.5, -0.7, -0.9]), np.array([0.05, 0.4, 0.8])
    lo2, hi2 = envelope.feet_in_band(problem, lo, hi, inset)
    assert lo2[0] == pytest.approx(target - problem.band + inset)
    assert hi2[0] == pytest.approx(target + problem.band - inset)
    assert np.allclose(np.diff(lo2), np.diff(lo)) and np.allclose(np.diff(hi2), np.diff(hi))   # each wall moved whole


def _edges(problem, values, row):
    """The free channel's two edges on ``row`` of a level set's values (linear between nodes)."""
    phi = values[:, row] + problem.contact_r_c
    q0 = np.linspace(problem.lower[0], problem.upper[0], phi.size)
    free = np.nonzero(phi >= 0)[0]
    i0, i1 = free[0], free[-1]
    h = q0[1] - q0[0]
    return q0[i0] - h * phi[i0] / (phi[i0] - phi[i0 - 1]), q0[i1] + h * phi[i1] / (phi[i1] - phi[i1 + 1])


def test_the_convex_channel_fills_a_notch_and_keeps_a_convex_channel():
    problem = FunnelProblem(grid=41, realizable=True, init_shape="vee", init_gap=0.15)
    shape = problem.shape()
    vee = problem.initial_values(np.random.default_rng(0), shape)
    notched = vee.copy()
    notched[29:33, 20] = -0.2                 # a blocked bump into the channel at q1 = 1.0, right of centre
    out = envelope.convex_channel(problem, notched)
    assert (out[29:33, 20] + problem.contact_r_c > 0).all()            # the notch is gone
    lo, hi = _edges(problem, out, 0)
    assert (lo, hi) == pytest.approx((-problem.band + envelope.FOOT_INSET, problem.band - envelope.FOOT_INSET))
    assert np.allclose(envelope.convex_channel(problem, out), out, atol=1e-9)     # a convex channel is kept
    assert (out[problem.mask(shape) == 0] == 0).all()                  # the held start strip stays free


@pytest.mark.parametrize("init_shape, plan", [("envelope", FUNNEL_ENVELOPE_PLAN), ("strips", FUNNEL_PLAN),
                                              ("vee", FUNNEL_PLAN)])
def test_only_the_envelope_start_changes_the_funnel_s_plan_and_its_final_grid(init_shape, plan):
    kind = KINDS["funnel"]
    problem = FunnelProblem(realizable=True, init_shape=init_shape)
    assert kind.default_plan(problem) == plan
    assert kind.default_plan(FunnelProblem(init_shape=init_shape)) == FUNNEL_PLAN      # not realizable
    values = np.random.default_rng(1).normal(size=(11, 11))
    assert (FunnelProblem(init_shape=init_shape).final_values(values) is values)
    if init_shape != "envelope":
        assert problem.final_values(values) is values


def test_a_realizable_funnel_starts_from_the_envelope_by_default():
    assert FunnelProblem().init_shape == "envelope"


@pytest.fixture(scope="module")
def small_start():
    problem = FunnelProblem(realizable=True, **{**SMALL, "grid": 41})      # a spacing (0.05) below r_c
    shape = problem.shape()
    return problem, problem.initial_values(np.random.default_rng(7), shape)


def test_the_envelope_start_is_a_funnel_with_its_feet_in_the_band(small_start):
    problem, values = small_start
    n = problem.grid
    blocked = values + problem.contact_r_c < 0
    assert blocked[0, 0] and blocked[-1, 0]                   # the exit edge's corners are blocked
    assert not blocked[n // 2, 0]                             # the centre of the exit is free
    lo, hi = _edges(problem, values, 0)
    assert (lo, hi) == pytest.approx((-problem.band + envelope.FOOT_INSET, problem.band - envelope.FOOT_INSET))
    assert (values[problem.mask(values.shape) == 0] == 0).all()
    final = problem.final_values(values)                      # the same exit, and a convex channel is kept
    assert _edges(problem, final, 0) == pytest.approx((lo, hi))
    assert np.array_equal(problem.final_values(final) + problem.contact_r_c < 0, final + problem.contact_r_c < 0)


def test_the_envelope_start_is_drawn_from_its_rng(small_start):
    problem, values = small_start
    assert np.array_equal(problem.initial_values(np.random.default_rng(7), values.shape), values)


@pytest.mark.parametrize("trim", [0.0, 0.005, 0.1])
def test_the_path_envelope_covers_the_in_band_paths_rows(trim):
    problem = FunnelProblem(**SMALL)
    values = problem.flat_values()
    q1, lo, hi = envelope.path_envelope(problem, values, seed=2, n_particles=40, trim=trim)
    assert q1.shape == lo.shape == hi.shape == (problem.grid,)
    assert (lo <= hi).all()
    assert (lo >= problem.lower[0]).all() and (hi <= problem.upper[0]).all()
    if trim == 0.0:    # on the flat surface the in-band paths fall straight: the band's width at the exit
        assert -problem.band - 0.15 < lo[0] and hi[0] < problem.band + 0.15
