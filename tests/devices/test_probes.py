"""Probes the device analyses share (pes_ref.devices.probes): the batched threshold search,
the grid's steepest slope and the grid's stiffest barrier."""
import numpy as np
import pytest

from pes_ref.core.surface import Surface
from pes_ref.core.stability import grid_stiffness
from pes_ref.devices.probes import RESOLUTION, steepest_slope, threshold_search


@pytest.mark.parametrize("threshold", [0.0, 0.37, 0.999])
def test_threshold_search_brackets_a_monotone_test(threshold):
    calls = []

    def passes(values):
        calls.append(len(values))
        return np.asarray(values) >= threshold
    found = threshold_search(passes, 0.0, 1.0, 1e-3)
    assert threshold <= found <= threshold + 1e-3
    assert len(calls) <= 6


def test_threshold_search_refuses_a_failing_upper_end():
    with pytest.raises(ValueError, match="hi = 1 is too low") as info:
        threshold_search(lambda v: np.zeros(len(v), bool), 0.0, 1.0, 0.1)
    assert info.value.key == "hi"       # so that a command line can name its own option


@pytest.mark.parametrize("tol", [1e-300, 5e-324, 1e-14])
def test_threshold_search_refuses_a_tolerance_float64_cannot_reach(tol):
    """A bracket narrower than float64 resolves never shrinks to it: refused at once, naming tol."""
    calls = []
    with pytest.raises(ValueError, match="finer than float64") as info:
        threshold_search(lambda v: calls.append(1) or np.asarray(v) >= 0.5, 0.0, 2.0, tol)
    assert info.value.key == "tol" and calls == []


def test_threshold_search_reaches_the_finest_tolerance_it_takes():
    rounds = []

    def passes(values):
        rounds.append(1)
        return np.asarray(values) >= 1 / 3
    found = threshold_search(passes, 0.0, 2.0, RESOLUTION * 2.0)
    assert 1 / 3 <= found <= 1 / 3 + RESOLUTION * 2.0 and len(rounds) < 20


@pytest.mark.parametrize("periodic", [(False, False), (True, True)])
def test_steepest_slope_of_a_ramp(periodic):
    """E = 3 q0 - q1 on [0, 1]^2: the steepest slope along q0 is 3 and along q1 is 1 (and a
    periodic axis adds the seam's step back down, 3 (n-1) over one spacing)."""
    n = 11
    q0, q1 = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n), indexing="ij")
    surface = Surface(3 * q0 - q1, (0, 0), (1, 1), periodic)
    h = surface.spacing
    seam = (3.0 / h[0] if periodic[0] else 0.0, 1.0 / h[1] if periodic[1] else 0.0)
    assert steepest_slope(surface, 0) == pytest.approx(max(3 * (1 / (n - 1)) / h[0], seam[0]))
    assert steepest_slope(surface, 1) == pytest.approx(max(1 * (1 / (n - 1)) / h[1], seam[1]))


def test_grid_stiffness_is_the_curvature_of_a_quadratic():
    # E = a q0^2 + b q1^2 on a non-periodic grid: every second difference / h^2 is 2a or 2b exactly
    q0, q1 = np.linspace(-1.0, 1.0, 9), np.linspace(0.0, 3.0, 13)
    a, b = 1.5, 4.0
    values = a * q0[:, None] ** 2 + b * q1[None, :] ** 2
    surface = Surface(values, (-1.0, 0.0), (1.0, 3.0), (False, False))
    assert grid_stiffness(surface) == pytest.approx(2 * b, rel=1e-12)


def test_grid_stiffness_wraps_a_periodic_axis():
    # a spike at node 0 of axis 1: its second difference -2 is seen only through the wrap from the
    # last node to node 0 (periodic); without the wrap node 0 is an edge and the largest is 1
    n, span = 16, 2 * np.pi
    values = np.zeros((3, n))
    values[:, 0] = 1.0
    periodic = Surface(values, (0.0, 0.0), (1.0, span), (False, True))
    assert grid_stiffness(periodic) == pytest.approx(2.0 / (span / n) ** 2, rel=1e-12)
    flat_ended = Surface(values, (0.0, 0.0), (1.0, span), (False, False))
    assert grid_stiffness(flat_ended) == pytest.approx(1.0 / (span / (n - 1)) ** 2, rel=1e-12)
