"""A cylinder design realized as a drum cam: the walls, the device file read back, the meshes
and the DXF, and the oscillator's entry of the design kinds (pes_ref.realize)."""
from __future__ import annotations

import copy
import math
import tomllib

import numpy as np
import pytest

from pes_ref.core.stability import check_stable
from pes_ref.devices.cspace import apf_energy, spring_grid
from pes_ref.devices.device_file import parse_device
from pes_ref.realize import exports
from pes_ref.realize.contact import realize_contact
from pes_ref.realize.evaluation import evaluate_realized, realized_problem
from pes_ref.realize.hooks import contact_parameters, held_out_positions, start_point
from pes_ref.realize.followers import drum_cam
from pes_ref.synthesis.kinds.oscillator import OscillatorProblem

GRID = 24
LEVEL = 0.25


@pytest.fixture(scope="module")
def problem():
    return OscillatorProblem(grid0=GRID, grid1=GRID, eval_periods=5)


def _values(problem) -> np.ndarray:
    """Walls 0.5 high beyond |q0| = 1.8, and a bump 0.5 high round (0, pi) and its neighbours."""
    q0 = np.linspace(problem.lower[0], problem.upper[0], GRID)[:, None]
    q1 = (np.arange(GRID) * 2 * np.pi / GRID)[None, :]
    ends = np.clip((np.abs(q0) - 1.6) / 0.4, 0.0, 1.0)
    bump = np.exp(-(q0 ** 2 + (q1 - np.pi) ** 2) / 0.3)
    return 0.5 * np.maximum(ends, bump)


def _device(data):
    return parse_device(tomllib.loads(exports.device_text(data, "test")), "test.toml")


@pytest.fixture(scope="module", params=[1.0, 2.0], ids=["R=1", "R=2"])
def realized(request, problem):
    return realize_contact(problem, _values(problem), "value", LEVEL, name="osc", drum_radius=request.param)


def _next_to(mask, periodic):
    out = mask.copy()
    for axis in range(2):
        for step in (1, -1):
            shifted = np.roll(mask, step, axis=axis)
            if not periodic[axis]:
                shifted[(slice(None),) * axis + ((0 if step == 1 else -1),)] = False
            out |= shifted
    return out


def test_the_drum_s_walls_block_what_the_design_blocks(realized):
    parts = realized.parts
    assert parts.follower == "drum-cam" and parts.motion == {"motion": "drum", "radius": parts.y_scale}
    _, y0, _, y1 = parts.plate.bounds
    assert y0 >= 0.0 and y1 <= 2 * np.pi * parts.y_scale + 1e-12          # one turn of the unrolled surface
    device = _device(realized.device)
    assert device.periodic == (False, True)
    blocked = device.cspace().blocked
    design = realized.region.phi < 0
    differ = blocked != design
    near = _next_to(design, (False, True)) & _next_to(~design, (False, True))      # a node from the boundary
    assert differ.mean() < 0.03 and not (differ & ~near).any()
    assert parts.lost_share < 0.01


def test_the_drum_s_meshes_are_watertight_and_its_dxf_is_its_walls(realized, tmp_path):
    parts = realized.parts
    exports.write_dxf(tmp_path / "drum.dxf", parts.plate, overwrite=False)
    back = exports.read_dxf_plate(tmp_path / "drum.dxf")
    assert back.symmetric_difference(parts.plate).area < 1e-9 * parts.plate.area
    cell = float(min(realized.region.spacing * [1.0, parts.y_scale])) / 4
    exports.write_stl(tmp_path / "drum.stl", exports.drum_mesh(parts.plate, parts.y_scale, 0.1, cell), False)
    mesh = exports.read_stl(tmp_path / "drum.stl")
    assert mesh.is_watertight and mesh.is_winding_consistent
    expected = exports.drum_volume(back, parts.y_scale, 0.1)
    walls = expected - math.pi * parts.y_scale ** 2 * (back.bounds[2] - back.bounds[0])
    # the tube's chords and the walls' sides rising across one cell
    assert abs(mesh.volume - expected) < 0.2 * walls
    assert mesh.bounds[1, 1] == pytest.approx(parts.y_scale + 0.1, rel=1e-6)


def test_a_drum_cam_needs_a_cylinder(realized):
    plane = copy.copy(realized.region)
    object.__setattr__(plane, "periodic", (False, False))
    with pytest.raises(ValueError, match="a drum cam realizes a cylinder"):
        drum_cam(plane, 0.02, 0.1)


def test_the_oscillator_s_entry(problem):
    assert start_point(problem) == [problem.amplitude * (1 + problem.kick), 0.0]
    energy = _values(problem)
    v, r_c, r_min = contact_parameters(problem, energy)
    h = np.array([5.0 / (GRID - 1), 2 * np.pi / GRID])
    assert r_c == pytest.approx(2 * h.max()) and r_min == pytest.approx(h.min() / 2)
    assert apf_energy(np.array([r_min]), v, r_c, r_min)[0] == pytest.approx(np.ptp(energy))
    x = held_out_positions(problem, energy, seed=3, n_particles=4)
    assert x.shape == (problem.steps_for(problem.eval_periods) + 1, 4, 2)     # the torque sweep, held-out long
    np.testing.assert_allclose(x[0, :, 1], 0.0)                      # the torque sweep's starts


def test_the_realized_grid_is_eq1_alone_as_the_design_s_scene_adds_its_spring(problem, realized):
    device = _device(realized.device)
    assert [s.axis for s in device.springs] == [0] and device.springs[0].k == problem.spring_k
    run = realized_problem(problem, device)
    springs = spring_grid(device.springs, device.lower, device.upper, device.shape, device.periodic)
    np.testing.assert_allclose(device.surface().values - run.values, springs, atol=1e-12)
    assert run.problem.spring_k == problem.spring_k                  # the device's spring, as the scene's


def test_the_oscillator_s_evaluation_runs_on_its_drum_cam(problem, realized):
    device = _device(realized.device)
    out = evaluate_realized(problem, _values(problem), device, seed=5, n_particles=6)
    assert set(out["captured_fraction"]) <= {i / 31 for i in range(32)}          # 6 + 25 particles
    assert out["n_steps"][0] == problem.steps_for(problem.eval_periods)
    assert "flat_captured_fraction" not in out


def test_a_stiff_drum_cam_runs_at_the_rule_s_step_for_the_design_s_duration(problem, realized):
    stiff = copy.deepcopy(realized.device)
    stiff["energy"]["v"] *= 100
    run = realized_problem(problem, _device(stiff))
    assert run.dt < problem.dt
    check_stable(run.problem.scene(run.values))
    assert run.problem.steps_for(run.problem.eval_periods) * run.dt >= problem.eval_periods * problem.period
    with pytest.raises(ValueError, match="stability limit"):
        check_stable(problem.scene(run.values))


def test_a_device_whose_springs_are_not_an_oscillator_s_is_refused(problem, realized):
    other = copy.deepcopy(realized.device)
    other["energy"]["springs"] = [{"axis": 1, "k": 1.0, "center": 0.0}]
    with pytest.raises(ValueError, match="not an oscillator's: one spring along q0 centred on 0"):
        realized_problem(problem, _device(other))
