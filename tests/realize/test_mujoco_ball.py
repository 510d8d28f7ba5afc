"""The heightfield's check in MuJoCo: balls rolling on the plate, with the design's starts,
pushes, noise, walls and damping."""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco")

from pes_ref.realize import mujoco_ball                                             # noqa: E402
from pes_ref.realize.heightfield import heightfield, heightfield_check, rolling_paths  # noqa: E402
from pes_ref.synthesis.kinds.funnel import FunnelProblem                                   # noqa: E402

GRID = 41


def _grid(p, n=GRID):
    q0 = np.linspace(p.lower[0], p.upper[0], n)[:, None]
    q1 = np.linspace(p.lower[1], p.upper[1], n)[None, :]
    return q0, q1


def test_a_ball_pushed_on_a_flat_plate_rolls_at_5_7_of_the_push_over_its_mass():
    """x(t) = x0 - (1/2)(5/7)(F/m) t^2: rolling without slipping, not sliding (F/m) and not
    held (0). Within 0.2% over 1 s (measured 0.05%: the heightfield's cell boundaries)."""
    p = FunnelProblem(grid=GRID, n_steps=100, noise=0.0, damping=0.0, force=0.8)
    hf = heightfield(p, np.zeros((GRID, GRID)))
    traj = mujoco_ball.mujoco_paths(p, hf, seed=1, n_particles=3)
    t = np.arange(101) * p.dt
    fall = traj.x[0, :, 1] - traj.x[:, :, 1]                       # (T+1, N)
    expected = 0.5 * (5.0 / 7.0) * p.force * t ** 2
    np.testing.assert_allclose(fall[-1], expected[-1], rtol=2e-3)
    np.testing.assert_allclose(fall[50], expected[50], rtol=5e-3)
    assert np.abs(traj.x[:, :, 0] - traj.x[0, :, 0]).max() < 1e-4                 # no push across


def test_a_ball_on_a_small_bowl_ends_at_its_bottom():
    """E = k/2 |q - (0.3, 1.2)|^2 with k = 2, damping 3 (0.9 of critical at 7/5 the mass): after
    6 s a ball from the start row is within 0.01 of the bottom (the decay leaves 0.002). The
    bottom off both axes' middles: a plate turned or mirrored in MuJoCo puts it elsewhere."""
    p = FunnelProblem(grid=31, n_steps=600, noise=0.0, force=0.0, damping=3.0)
    q0, q1 = _grid(p, 31)
    bottom = np.array([0.3, 1.2])
    hf = heightfield(p, (q0 - bottom[0]) ** 2 + (q1 - bottom[1]) ** 2)
    traj = mujoco_ball.mujoco_paths(p, hf, seed=2, n_particles=4)
    assert np.all(np.abs(traj.x[0, :, 1] - 1.9) < 1e-12)            # the design's start row
    np.testing.assert_allclose(traj.x[-1], np.broadcast_to(bottom, (4, 2)), atol=0.01)
    assert np.all(np.hypot(*(traj.x[300] - bottom).T) > np.hypot(*(traj.x[-1] - bottom).T))


@pytest.fixture(scope="module")
def vee():
    p = FunnelProblem(grid=GRID, n_steps=200)
    q0, q1 = _grid(p)
    values = 0.2 * np.clip((np.abs(q0) - (0.25 + 0.4 * q1)) / 0.1, 0.0, 1.0) * p.mask((GRID, GRID))
    return p, values, heightfield(p, values)


def test_the_same_seed_gives_bit_identical_balls_on_the_design_s_starts(vee):
    p, values, hf = vee
    a = mujoco_ball.mujoco_paths(p, hf, seed=9191, n_particles=6)
    b = mujoco_ball.mujoco_paths(p, hf, seed=9191, n_particles=6)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    rolling = rolling_paths(p, hf.energy(), seed=9191, n_particles=6)
    np.testing.assert_array_equal(a.x[0], rolling.x[0])            # the held-out starts
    batch = p.batch(values, np.random.default_rng(9191), 6)
    np.testing.assert_array_equal(a.f[0], batch.scene.schedule(6)[0])   # the push and the noise draws
    c = mujoco_ball.mujoco_paths(p, hf, seed=12345, n_particles=6)
    assert not np.array_equal(a.x[0], c.x[0])


def test_a_longer_horizon_runs_the_same_balls_on(vee):
    p, _, hf = vee
    short = mujoco_ball.mujoco_paths(p, hf, seed=3, n_particles=4, n_steps=50)
    long = mujoco_ball.mujoco_paths(p, hf, seed=3, n_particles=4, n_steps=80)
    assert long.x.shape == (81, 4, 2)
    np.testing.assert_array_equal(long.x[:51], short.x)


def test_the_check_s_figures_and_its_line_without_mujoco(vee, monkeypatch):
    p, values, hf = vee
    got = heightfield_check(p, values, hf, seed=5, n_particles=8, n_steps=120)
    assert got["steps"] == 120 and got["mujoco_dt"] == pytest.approx(p.dt / 20)
    for prefix in ("", "rolling_", "sloped_", "mujoco_"):
        assert 0.0 <= got[prefix + "in_band_fraction"] <= got[prefix + "exited_fraction"] <= 1.0
    from pes_ref.devices.geometry import MissingExtraError
    from pes_ref.realize import extra

    def missing():
        raise MissingExtraError(f"the MuJoCo check needs mujoco (the optional extra 'mujoco'): {extra.MUJOCO_PIP_LINE}")

    monkeypatch.setattr(extra, "require_mujoco", missing)
    without = heightfield_check(p, values, hf, seed=5, n_particles=8, n_steps=120)
    assert "pip install 'pes_ref[mujoco]'" in without["mujoco"] and "mujoco_in_band_fraction" not in without
    np.testing.assert_equal({k: v for k, v in without.items() if k != "mujoco"},
                            {k: v for k, v in got.items() if not k.startswith("mujoco")})
    with pytest.raises(MissingExtraError):
        heightfield_check(p, values, hf, seed=5, n_particles=8, n_steps=120, mujoco=True)
    assert "mujoco" not in heightfield_check(p, values, hf, seed=5, n_particles=8, n_steps=120, mujoco=False)


def test_a_missing_mujoco_names_the_extra(monkeypatch):
    import sys
    from pes_ref.devices.geometry import MissingExtraError
    from pes_ref.realize.extra import require_mujoco
    monkeypatch.setitem(sys.modules, "mujoco", None)
    with pytest.raises(MissingExtraError, match=r"pip install 'pes_ref\[mujoco\]'"):
        require_mujoco()


def test_a_bad_horizon_is_refused_naming_it(vee):
    p, values, hf = vee
    with pytest.raises(ValueError, match="n_steps"):
        heightfield_check(p, values, hf, seed=5, n_particles=8, n_steps=0)
    with pytest.raises(ValueError, match="radius_share"):
        mujoco_ball.mujoco_paths(p, hf, seed=5, n_particles=2, radius_share=-1.0)


def test_a_ball_s_radius_is_a_share_of_the_grid_s_spacing(vee):
    p, _, hf = vee
    model = mujoco_ball.plate_model(hf, 2, 1.0, 0.25 * float(hf.spacing.min()), 1e-3, np.array([1.0, 1.0]))
    assert model.nbody == 3 and model.ngeom == 3
    assert model.geom_size[1, 0] == pytest.approx(0.25 * 2.0 / (GRID - 1))
    # the padded plate carries the grid's heights at its nodes, rows along q1
    pad = max(1, int(np.ceil(mujoco_ball.PAD * (GRID - 1))))
    data = model.hfield_data.reshape(model.hfield_nrow[0], model.hfield_ncol[0]) * model.hfield_size[0, 2]
    np.testing.assert_allclose(data[pad:-pad, pad:-pad], hf.heights.T, atol=1e-6 * hf.heights.max())


def test_a_stronger_gravity_gets_a_stiffer_contact_and_a_shorter_timestep():
    assert mujoco_ball.contact_timeconst(9.81) == mujoco_ball.CONTACT_TIMECONST
    assert mujoco_ball.contact_timeconst(2.0) == mujoco_ball.CONTACT_TIMECONST        # a weaker one keeps it
    assert mujoco_ball.contact_timeconst(98.1) == pytest.approx(0.002 / np.sqrt(10.0))
    assert mujoco_ball.substeps(0.01, 9.81) == 20 and mujoco_ball.substeps(0.01, 2.0) == 20
    assert mujoco_ball.substeps(0.01, 98.1) == 64                    # 0.01 / 64 <= 0.000632 / 4
    assert mujoco_ball.substeps(0.05, 9.81) == 100                   # a quarter of 0.002 s


def test_a_run_mujoco_warned_about_is_refused(vee, monkeypatch):
    """MuJoCo drops contacts or resets a state and carries on; the check says so instead."""
    import mujoco
    p, _, hf = vee
    real_step = mujoco.mj_step

    def step(model, data):
        real_step(model, data)
        data.warning[int(mujoco.mjtWarning.mjWARN_CONTACTFULL)].number += 1

    monkeypatch.setattr(mujoco, "mj_step", step)
    with pytest.raises(ValueError, match="ran out of room for contacts"):
        mujoco_ball.mujoco_paths(p, hf, seed=1, n_particles=2, n_steps=3)
