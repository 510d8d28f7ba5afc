"""``python -m pes_ref realize`` and ``evaluate --realized``: files written, read back and checked."""
from __future__ import annotations

import sys

import numpy as np
import pytest

from pes_ref.cli import EXIT_ERROR, EXIT_OK, main
from pes_ref.synthesis import new_design, save_design

GRID = 41
FILES = ("device.toml", "plate.dxf", "plate.stl", "base.stl", "pin.stl", "parts.png")


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def figures(out: str) -> dict:
    return dict(line.split(": ", 1) for line in out.splitlines() if ": " in line)


@pytest.fixture(scope="module")
def design(tmp_path_factory):
    """A funnel design file whose grid is two V walls (energy 0.2 beyond a ramp)."""
    state = new_design("funnel", grid=GRID, n_steps=300)
    p = state.problem
    q0 = np.linspace(p.lower[0], p.upper[0], GRID)[:, None]
    q1 = np.linspace(p.lower[1], p.upper[1], GRID)[None, :]
    state.values = 0.2 * np.clip((np.abs(q0) - (0.25 + 0.4 * q1)) / 0.1, 0.0, 1.0) * p.mask((GRID, GRID))
    path = tmp_path_factory.mktemp("design") / "vee.npz"
    save_design(path, state)
    return path


def test_realize_writes_every_file_and_checks_each_read_back(capsys, design, tmp_path):
    out_dir = tmp_path / "parts"
    code, out, err = run(capsys, "realize", str(design), "--as", "contact", "--rule", "value", "--level", "0.1",
                         "--out", str(out_dir), "--particles", "6", "--seed", "9191")
    assert code == EXIT_OK, err
    assert sorted(p.name for p in out_dir.iterdir()) == sorted(FILES)
    got = figures(out)
    # the design's headline figure beside the parts' under eq. (1) and in rigid contact
    assert got["score_seed"] == "9191" and got["score_particles"] == "6"
    assert {"in_band_fraction", "realized_in_band_fraction", "rigid_in_band_fraction"} <= got.keys()
    assert got["rule"] == "value" and float(got["level"]) == 0.1
    assert abs(float(got["device_blocked_share"]) - float(got["blocked_share"])) < 0.02
    assert float(got["plate_area_dxf"]) == pytest.approx(float(got["plate_area_device"]), rel=1e-9)
    assert got["plate_watertight"] == got["base_watertight"] == got["pin_watertight"] == "True"
    assert float(got["plate_volume"]) == pytest.approx(float(got["plate_volume_expected"]), rel=1e-6)
    assert out.count("neighbour: ") == 2 and out.count("lost: ") == 2
    assert (out_dir / "parts.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    code, out, err = run(capsys, "analyze", str(out_dir / "device.toml"), "--drive", "1", "--load", "-1")
    assert code == EXIT_OK, err                                     # every device tool applies to it

    code, out, err = run(capsys, "evaluate", str(design), "--realized", str(out_dir / "device.toml"),
                         "--particles", "30")
    assert code == EXIT_OK, err
    got = figures(out)
    for name in ("in_band_fraction", "exit_spread", "exited_fraction", "dt", "n_steps"):
        assert name in got and f"realized_{name}" in got
    assert float(got["realized_dt"]) <= float(got["dt"])


def test_realize_as_heightfield_writes_the_plate_and_checks_the_rolling_ball(capsys, design, tmp_path):
    code, out, err = run(capsys, "realize", str(design), "--as", "heightfield", "--out", str(tmp_path / "hf"),
                         "--g", "2", "--particles", "40", "--seed", "9191")
    assert code == EXIT_OK, err
    assert [p.name for p in (tmp_path / "hf").iterdir()] == ["heightfield.stl"]
    got = figures(out)
    assert got["watertight"] == "True" and float(got["height_error"]) < 1e-6
    assert float(got["height_range"]) == pytest.approx(0.2 / 2.0, rel=1e-12)      # the design's range / (m g)
    assert float(got["max_slope"]) > 0 and got["seed"] == "9191" and got["particles"] == "40"
    assert got["steps"] == "300"                                                       # the design's horizon
    for prefix in ("", "rolling_", "sloped_", "mujoco_"):
        assert 0.0 <= float(got[prefix + "in_band_fraction"]) <= float(got[prefix + "exited_fraction"]) <= 1.0
    assert float(got["mujoco_dt"]) == pytest.approx(0.01 / 20) and float(got["mujoco_radius"]) == pytest.approx(0.0125)
    assert float(got["mujoco_seconds"]) > 0 and "mujoco" not in got


def test_realize_as_heightfield_runs_longer_with_steps_and_refuses_a_bad_horizon(capsys, design, tmp_path):
    argv = ["realize", str(design), "--as", "heightfield", "--particles", "6", "--seed", "7"]
    code, out, err = run(capsys, *argv, "--out", str(tmp_path / "a"), "--steps", "450")
    assert code == EXIT_OK, err
    got = figures(out)
    assert got["steps"] == "450" and got["exited_fraction"] == "1"
    for bad in ("0", "-3"):
        code, out, err = run(capsys, *argv, "--out", str(tmp_path / "b"), "--steps", bad)
        assert code == EXIT_ERROR and out == "" and err == f"error: --steps must be >= 1, got {bad}\n"
        assert not (tmp_path / "b").exists()
    code, out, err = run(capsys, "realize", str(design), "--as", "contact", "--out", str(tmp_path / "c"), "--steps", "9")
    assert code == EXIT_ERROR and err == "error: --steps goes with --as heightfield, not --as contact\n"


def test_without_mujoco_the_heightfield_check_runs_the_rolling_ball_and_says_how_to_add_it(capsys, monkeypatch,
                                                                                             design, tmp_path):
    monkeypatch.setitem(sys.modules, "mujoco", None)           # import mujoco -> ImportError
    code, out, err = run(capsys, "realize", str(design), "--as", "heightfield", "--out", str(tmp_path / "hf"),
                         "--particles", "6")
    assert code == EXIT_OK, err
    got = figures(out)
    assert "rolling_in_band_fraction" in got and not any(k.startswith("mujoco_") for k in got)
    assert [line for line in out.splitlines() if "mujoco" in line] == \
        ["mujoco: not run: the MuJoCo check needs mujoco >= 3.2 (the optional extra 'mujoco'): "
         "pip install 'pes_ref[mujoco]'"]


def test_existing_files_are_kept_unless_forced(capsys, design, tmp_path):
    out_dir = tmp_path / "parts"
    out_dir.mkdir()
    (out_dir / "plate.dxf").write_text("a user's drawing")
    argv = ["realize", str(design), "--as", "contact", "--rule", "value", "--level", "0.1", "--out", str(out_dir),
            "--particles", "4"]
    code, out, err = run(capsys, *argv)
    assert code == EXIT_ERROR and out == "" and "plate.dxf exists already" in err
    assert [p.name for p in out_dir.iterdir()] == ["plate.dxf"] and (out_dir / "plate.dxf").read_text() == "a user's drawing"
    code, out, err = run(capsys, *argv, "--force")
    assert code == EXIT_OK and (out_dir / "plate.dxf").read_text().startswith("  0\nSECTION")


@pytest.mark.parametrize("argv", [["--out", "parts"], ["--out", "newparts", "--drum-radius", "2"]])
def test_outputs_and_options_are_refused_before_anything_is_computed(capsys, monkeypatch, design, tmp_path, argv):
    from pes_ref.realize import contact
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "device.toml").write_text("a user's device")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(contact, "contact_region", lambda *a, **k: pytest.fail("the region was computed"))
    code, out, err = run(capsys, "realize", str(design), "--as", "contact", *argv)
    assert code == EXIT_ERROR and out == "" and err.count("\n") == 1
    assert ("device.toml exists already" in err) if len(argv) == 2 else ("--drum-radius goes with a cylinder" in err)


def test_a_write_that_fails_part_way_leaves_no_file_of_the_set(capsys, monkeypatch, design, tmp_path):
    from pes_ref.realize import exports
    real_write = exports.write_stl

    def fail_on_the_base(path, mesh, overwrite):
        if str(path).endswith("base.stl"):
            raise OSError(28, "No space left on device", str(path))
        real_write(path, mesh, overwrite)

    monkeypatch.setattr(exports, "write_stl", fail_on_the_base)
    out_dir = tmp_path / "parts"
    out_dir.mkdir()
    (out_dir / "notes.txt").write_text("a user's notes")
    code, out, err = run(capsys, "realize", str(design), "--as", "contact", "--rule", "value", "--level", "0.1",
                         "--out", str(out_dir))
    assert code == EXIT_ERROR and err.count("\n") == 1 and "No space left on device" in err
    assert [p.name for p in out_dir.iterdir()] == ["notes.txt"]        # no staging folder, no part of the set


@pytest.mark.parametrize("module", ["ezdxf", "trimesh", "contourpy"])
def test_without_the_extra_the_command_prints_the_pip_line(capsys, monkeypatch, design, tmp_path, module):
    monkeypatch.setitem(sys.modules, module, None)           # import MODULE -> ImportError
    code, out, err = run(capsys, "realize", str(design), "--as", "contact", "--out", str(tmp_path / "p"))
    assert code == EXIT_ERROR and out == ""
    assert err.count("\n") == 1 and "pip install 'pes_ref[realize]'" in err and module in err
    assert not (tmp_path / "p").exists()


@pytest.fixture(scope="module")
def oscillator_design(tmp_path_factory):
    """A small oscillator design file: walls 0.5 high beyond |q0| = 1.8 and a bump round (0, pi)."""
    state = new_design("oscillator", grid0=16, grid1=16, eval_periods=5)
    p = state.problem
    q0 = np.linspace(p.lower[0], p.upper[0], 16)[:, None]
    q1 = (np.arange(16) * 2 * np.pi / 16)[None, :]
    state.values = 0.5 * np.maximum(np.clip((np.abs(q0) - 1.6) / 0.4, 0.0, 1.0),
                                    np.exp(-(q0 ** 2 + (q1 - np.pi) ** 2) / 0.3))
    path = tmp_path_factory.mktemp("osc") / "osc.npz"
    save_design(path, state)
    return path


def test_a_cylinder_design_becomes_a_drum_cam_and_its_own_evaluation_runs_on_it(capsys, oscillator_design, tmp_path):
    out_dir = tmp_path / "drum"
    code, out, err = run(capsys, "realize", str(oscillator_design), "--as", "contact", "--rule", "value", "--level",
                         "0.25", "--drum-radius", "2", "--out", str(out_dir), "--particles", "4")
    assert code == EXIT_OK, err
    assert sorted(p.name for p in out_dir.iterdir()) == sorted(("device.toml", "drum.dxf", "drum.stl", "pin.stl",
                                                                "parts.png"))
    got = figures(out)
    assert abs(float(got["device_blocked_share"]) - float(got["blocked_share"])) < 0.03
    assert float(got["drum_area_dxf"]) == pytest.approx(float(got["drum_area_device"]), rel=1e-9)
    assert got["drum_watertight"] == got["pin_watertight"] == "True"
    assert float(got["drum_volume"]) == pytest.approx(float(got["drum_volume_expected"]), rel=0.01)
    assert 'motion = "drum"' in (out_dir / "device.toml").read_text()
    code, out, err = run(capsys, "evaluate", str(oscillator_design), "--realized", str(out_dir / "device.toml"),
                         "--particles", "5")
    assert code == EXIT_OK, err
    got = figures(out)
    assert 0.0 <= float(got["realized_captured_fraction"]) <= 1.0 and "realized_q1_advance_median" in got
    assert float(got["realized_dt"]) <= float(got["dt"])


def test_realize_without_pymunk_says_the_rigid_score_is_not_run_with_the_pip_line(capsys, monkeypatch, design,
                                                                                     tmp_path):
    monkeypatch.setitem(sys.modules, "pymunk", None)
    code, out, err = run(capsys, "realize", str(design), "--as", "contact", "--rule", "value", "--level", "0.1",
                         "--out", str(tmp_path / "p"), "--particles", "4")
    assert code == EXIT_OK, err
    got = figures(out)
    assert "realized_in_band_fraction" in got
    assert got["rigid_in_band_fraction"].startswith("not run") and "pip install 'pes_ref[rigid]'" in out


def test_an_example_that_draws_no_shape_is_designed_from_its_paths_realized_and_run_rigid(capsys, tmp_path):
    from _helpers import ROOT
    example = ROOT / "examples" / "problems" / "lanes_parts.toml"
    design_file, parts = tmp_path / "lanes.npz", tmp_path / "parts"
    code, out, err = run(capsys, "design", str(example), "--smoke", "--progress", "0", "--out", str(design_file))
    assert code == EXIT_OK, err
    assert "lanes_parts: its start is made from the passing paths of a smooth design" in err
    assert "start (smooth design): design lanes_parts" in err
    code, out, err = run(capsys, "realize", str(design_file), "--as", "contact", "--out", str(parts),
                         "--particles", "4")
    assert code == EXIT_OK, err
    assert "the pin is made 0.0353853 larger" in out                # eq. (1)'s standoff under a push of 1
    code, out, err = run(capsys, "evaluate", str(design_file), "--realized", str(parts / "device.toml"),
                         "--engine", "both", "--particles", "6")
    assert code == EXIT_OK, err
    got = figures(out)
    assert 0.0 <= float(got["rigid_success_fraction"]) <= 1.0
    assert got["rigid_starts_blocked"] == "0"                        # every start is free in the parts


@pytest.mark.parametrize("module", ["contourpy", "shapely"])
def test_a_design_from_paths_without_the_extra_is_one_line_with_the_pip_line_before_any_run(capsys, monkeypatch,
                                                                                          tmp_path, module):
    from _helpers import ROOT
    monkeypatch.setitem(sys.modules, module, None)           # import MODULE -> ImportError
    out_file = tmp_path / "lanes.npz"
    code, out, err = run(capsys, "design", str(ROOT / "examples" / "problems" / "lanes_parts.toml"), "--smoke",
                         "--quiet", "--out", str(out_file))
    assert code == EXIT_ERROR and out == ""
    assert err.count("\n") == 1 and "pip install 'pes_ref[" in err and module in err
    assert not out_file.exists()
