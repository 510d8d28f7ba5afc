"""Probes the device analyses share (pes_ref.devices.probes): the batched threshold search
and the grid's stiffest barrier."""
import numpy as np
import pytest

from pes_ref.core.surface import Surface
from pes_ref.core.stability import grid_stiffness
from pes_ref.devices.probes import threshold_search


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
