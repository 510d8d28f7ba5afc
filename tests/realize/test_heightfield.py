"""The heightfield realization: a watertight plate whose top is the energy, and a ball rolling on it."""
from __future__ import annotations

import numpy as np
import pytest

from pes_ref import Scene, Surface, simulate
from pes_ref.realize import exports
from pes_ref.realize.heightfield import (ROLLING, HeightField, _sloped, heightfield, heightfield_mesh,
                                         heights_from_mesh, rolling_paths)
from pes_ref.synthesis.kinds.funnel import FunnelProblem

GRID = 31


@pytest.fixture(scope="module")
def problem():
    return FunnelProblem(grid=GRID, n_steps=200)


@pytest.fixture(scope="module")
def values(problem):
    q0 = np.linspace(problem.lower[0], problem.upper[0], GRID)[:, None]
    q1 = np.linspace(problem.lower[1], problem.upper[1], GRID)[None, :]
    return (0.3 * q0 ** 2 - 0.1 * q1) * problem.mask((GRID, GRID))


def test_the_plate_is_watertight_and_its_top_gives_the_heights_back(problem, values, tmp_path):
    hf = heightfield(problem, values, g=2.0)
    assert hf.heights.min() == 0.0
    np.testing.assert_allclose(hf.energy() - hf.energy().min(), values - values.min(), rtol=1e-12, atol=1e-15)
    mesh = heightfield_mesh(hf, base=0.05)
    exports.write_stl(tmp_path / "h.stl", mesh, overwrite=False)
    back = exports.read_stl(tmp_path / "h.stl")
    assert back.is_watertight
    heights = heights_from_mesh(back, hf)
    np.testing.assert_allclose(heights, hf.heights, atol=1e-6)           # STL stores float32
    # the volume of a bilinear-top prism: the trapezoid rule on the cells' two triangles
    assert back.volume == pytest.approx(mesh.volume, rel=1e-6) and mesh.volume > 0


def test_with_no_slope_the_ball_is_the_design_s_particle_at_7_5_its_mass(problem, values):
    a = rolling_paths(problem, values, seed=3, n_particles=6)
    b = rolling_paths(problem, values, seed=3, n_particles=6, g=1e12)      # a slope of ~1e-12: no shortening
    np.testing.assert_allclose(b.x, a.x, rtol=0, atol=1e-12)
    batch = problem.batch(values, np.random.default_rng(3), 6)
    import dataclasses
    heavy = simulate(dataclasses.replace(batch.scene, mass=ROLLING), batch.x0, batch.v0)
    np.testing.assert_array_equal(a.x, heavy.x)


def test_a_ball_on_a_constant_slope_accelerates_by_the_shortened_force():
    """E = s m g q0 (a plane of slope s): horizontal acceleration -g s / (1 + s^2) / (7/5)."""
    s, g, m = 0.5, 3.0, 1.0
    q0 = np.linspace(-10.0, 10.0, 5)
    surface = Surface(np.broadcast_to(s * m * g * q0[:, None], (5, 5)).copy(), (-10.0, -10.0), (10.0, 10.0),
                      (False, False))
    scene = Scene(surface, dt=0.01, n_steps=100, mass=ROLLING * m)
    x0 = np.array([[0.3, 0.1]])
    traj = _sloped(scene, x0, np.zeros_like(x0), m * g)
    t = np.arange(101) * 0.01
    expected = 0.3 - 0.5 * (g * s / (1 + s * s) / ROLLING) * t ** 2
    np.testing.assert_allclose(traj.x[:, 0, 0], expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj.x[:, 0, 1], 0.1, rtol=0, atol=1e-15)


def test_a_wrapping_surface_is_refused():
    from pes_ref.synthesis.kinds.oscillator import OscillatorProblem
    osc = OscillatorProblem(grid0=8, grid1=8)
    with pytest.raises(ValueError, match="realizes a plane"):
        heightfield(osc, np.zeros((8, 8)))


def test_heights_read_back_need_every_node(problem, values):
    hf = heightfield(problem, values)
    mesh = heightfield_mesh(hf, 0.05)
    partial = HeightField(np.zeros((GRID + 1, GRID)), hf.lower, hf.upper, hf.mass, hf.g)
    with pytest.raises(ValueError, match="lacks a vertex"):
        heights_from_mesh(mesh, partial)


def test_a_realizable_design_s_ball_rolls_on_its_surface_not_on_its_level_set():
    """The heights are the surface's energies; the ball runs on them as they are (the level
    set is the design's variables, not the ball's surface)."""
    import dataclasses
    p = FunnelProblem(grid=GRID, n_steps=150, realizable=True, init_shape="vee")
    values = p.initial_values(np.random.default_rng(0), (GRID, GRID))
    energy = p.surface_values(values)
    got = rolling_paths(p, energy, seed=4, n_particles=5)
    batch = dataclasses.replace(p, realizable=False).batch(energy, np.random.default_rng(4), 5)
    want = simulate(dataclasses.replace(batch.scene, mass=ROLLING), batch.x0, batch.v0)
    np.testing.assert_array_equal(got.x, want.x)
