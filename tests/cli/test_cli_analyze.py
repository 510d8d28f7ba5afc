"""``python -m pes_ref analyze DEVICE.toml|ratchet|dartgun``: output lines, files, help and errors (pes_ref.cli.analyze)."""
import json
import re
import sys

import numpy as np
import pytest

from _faults import DEVICE
from _helpers import without_progress

from pes_ref.cli import EXIT_ERROR, EXIT_OK, main

#: ``name: value unit``, or ``name: value`` where the value is a name, a flag or text; names may carry a
#: bracketed argument, values may be a range "a .. b".
LINE = re.compile(r"^[a-z_0-9]+(\[[a-z_]+=[-0-9.e+]+\]|\[[a-z-]+\])?: \S+( \.\. \S+)?( \S+.*)?$")
#: A number's line has a unit; a type where a unit would go (``jammed: False bool``) is not one.
NUMBER = re.compile(r"^[^:]+: [-+0-9.e]+(inf|nan)?$")
TYPE_WORDS = (" bool", " text", " name", " mode", " axis", " q0,q1")


def run(capsys, *argv):
    """``analyze ARGV`` in this process: (exit status, stdout, stderr without its progress lines)."""
    code = main(["analyze", *argv])
    out, err = capsys.readouterr()
    return code, out, without_progress(err)


@pytest.mark.parametrize("device, option", [("ratchet", "--torque"), ("dartgun", "--trigger-forces")])
def test_help_explains_the_options(capsys, device, option):
    code, out, _ = run(capsys, device, "--help")
    assert code == EXIT_OK
    assert option in out and "--smoke" in out


@pytest.mark.parametrize("device, module, name, table", [
    ("ratchet", "pes_ref.devices.ratchet", "analyze_ratchet", "RATCHET_ANALYSIS"),
    ("dartgun", "pes_ref.devices.dartgun", "analyze_dartgun", "DARTGUN_ANALYSIS"),
])
def test_without_options_the_command_runs_the_analysis_with_its_defaults(capsys, monkeypatch, device, module, name,
                                                                         table):
    """The defaults live in the device module (its table, which the function's signature
    reads); the command passes them unchanged and its help shows each one."""
    import importlib
    import inspect

    mod = importlib.import_module(module)
    signature = [p.default for p in inspect.signature(getattr(mod, name)).parameters.values()
                 if p.name not in ("device", "progress", "run")]
    got = []

    class Report:
        def as_lines(self):
            return []

        def warnings(self):
            return []

    def analysis(design, *values):
        got.extend(tuple(v) if isinstance(v, list) else v for v in values)
        return Report()
    monkeypatch.setattr(mod, name, analysis)
    assert run(capsys, device)[0] == EXIT_OK
    assert got == signature
    help_text = " ".join(run(capsys, device, "--help")[1].split())
    for value in getattr(mod, table).values():
        assert f"default {','.join(map(repr, value)) if isinstance(value, tuple) else repr(value)})" in help_text


def figures(capsys, *argv) -> dict:
    """Run a command that must succeed; its lines as {name: "value unit"}."""
    code, out, err = run(capsys, *argv)
    assert code == EXIT_OK and all(line.startswith("wrote ") for line in err.splitlines()), err
    lines = out.splitlines()
    assert all(LINE.match(line) for line in lines), lines
    assert not [line for line in lines if NUMBER.match(line) or line.endswith(TYPE_WORDS)], lines
    return dict(line.split(": ", 1) for line in lines)


def test_ratchet_prints_one_line_per_figure(capsys):
    values = figures(capsys, "ratchet", "--smoke", "--duration", "2", "--search-tol", "0.5")
    assert float(values["net_rotation_plus"].split()[0]) > float(values["net_rotation_minus"].split()[0])
    assert {"min_advancing_torque", "time_runs", "dt_stability_limit"} <= set(values)


def test_dartgun_prints_one_line_per_figure(capsys):
    values = figures(capsys, "dartgun", "--smoke", "--trigger-forces", "30", "--search-tol", "20")
    assert values["reload_latched"] == "True"
    assert float(values["exit_speed[trigger_force=30]"].split()[0]) > 0
    assert {"min_reload_force", "reload_bbox_q0", "fire_bbox_q1"} <= set(values)


@pytest.mark.parametrize("argv, quoted", [
    (("ratchet", "--torque", "abc"), "'abc'"),
    (("ratchet", "--torque", "-1"), "-1"),
    (("ratchet", "--duration", "nan"), "nan"),
    (("ratchet", "--search-tol", "0"), "0"),
    (("dartgun", "--reload-force", "inf"), "inf"),
    (("dartgun", "--trigger-forces", "10,x"), "'x'"),
    (("dartgun", "--trigger-forces", ","), "','"),
    (("dartgun", "--trigger-forces", "5,-2"), "-2"),
    (("dartgun", "--fire-time", "0"), "0"),
])
def test_bad_values_give_one_error_line(capsys, argv, quoted):
    code, out, err = run(capsys, *argv)
    assert code == EXIT_ERROR and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and argv[1] in lines[0] and quoted in lines[0]


# =========================================================================== any device file

from pathlib import Path  # noqa: E402

import pes_ref  # noqa: E402

CAM = Path(pes_ref.__file__).resolve().parent.parent / "examples" / "devices" / "cam_follower.toml"
#: A coarse grid for the cam (a quick look; the file's own grid is the worked example's).
QUICK = ("--shape", "160,41")


def test_a_device_file_prints_the_drive_figures_and_writes_its_outputs(capsys, tmp_path):
    out, plot, js = tmp_path / "cam", tmp_path / "cam.png", tmp_path / "cam.json"
    values = figures(capsys, str(CAM), "--drive", "0", "--load", "0.5", *QUICK, "--out", str(out),
                     "--plot", str(plot), "--json", str(js))
    assert {"input_travel", "advance_per_cycle", "moving_fraction", "max_ratio", "jammed", "stopped_at"} <= set(values)
    assert values["jammed"] == "False"
    law = np.loadtxt(out / "motion_law.csv", delimiter=",", skiprows=1)
    assert (out / "motion_law.csv").read_text().startswith("q_in,q_out\n")
    assert law.shape[1] == 2 and np.all(np.diff(law[:, 0]) > 0)
    assert law[-1, 0] - law[0, 0] == pytest.approx(4 * np.pi, abs=0.05)       # two turns by default
    summary = json.loads(js.read_text())
    assert summary["jammed"] is False and summary["moving_fraction"] == pytest.approx(
        float(values["moving_fraction"].split()[0]), rel=1e-5)
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_existing_outputs_are_kept_unless_forced(capsys, tmp_path):
    (tmp_path / "cam.json").write_text("a user's file")
    code, out, err = run(capsys, str(CAM), "--drive", "0", "--load", "0.5", *QUICK, "--json",
                         str(tmp_path / "cam.json"))
    assert code == EXIT_ERROR and out == "" and "exists already" in err
    assert (tmp_path / "cam.json").read_text() == "a user's file"
    code, out, err = run(capsys, str(CAM), "--drive", "0", "--load", "0.5", *QUICK, "--json",
                         str(tmp_path / "cam.json"), "--force")
    assert code == EXIT_OK and json.loads((tmp_path / "cam.json").read_text())["device"] == "cam_follower"


def test_without_shapely_the_command_prints_the_pip_line(capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "shapely", None)          # import shapely -> ImportError
    code, out, err = run(capsys, str(CAM), "--drive", "0", "--load", "0.5")
    assert code == EXIT_ERROR and out == ""
    assert err.count("\n") == 1 and "pip install 'pes_ref[devices]'" in err and "Traceback" not in err
    assert "internal error" not in err                           # refused as an input problem, not a crash


def test_a_start_with_a_negative_first_number_is_a_value_and_each_cycle_is_reported(capsys, tmp_path):
    """``--start -0.1,0.6`` (argparse alone reads a word starting with '-' as an option); the
    first turn holds the follower's settling from 0.6, the headline is the last turn's."""
    js = tmp_path / "cam.json"
    values = figures(capsys, str(CAM), "--drive", "0", "--load", "0.5", *QUICK, "--start", "-0.1,0.6", "--cycles",
                     "2", "--json", str(js))
    summary = json.loads(js.read_text())
    first, last = summary["advance_per_cycle_each"]
    assert summary["advance_per_cycle"] == last and abs(last) < abs(first)
    assert values["advance_per_cycle_each"].split()[0] == f"{first:.6g},{last:.6g}"
    assert "cycle 2 of 2; cycle 1, the start's transient, left out" in values["advance_per_cycle"]
    assert summary["advance"] == pytest.approx(first + last)


EXAMPLES = CAM.parent


@pytest.mark.parametrize("name, keys", [("geneva6_play.toml", ("[energy] r_c = 0.05", "set [energy] r_c below")),
                                        ("geneva6_play_fixed.toml", ())])
def test_a_device_whose_surface_cannot_be_trusted_says_so_after_its_figures(capsys, name, keys):
    code, out, err = run(capsys, str(EXAMPLES / name), "--drive", "0", "--load", "1")
    assert code == EXIT_OK and "advance_per_cycle" in out
    warnings = [line for line in err.splitlines() if line.startswith("warning: ")]
    assert len(warnings) == (1 if keys else 0), err
    for key in keys:
        assert key in warnings[0]


# =========================================================================== --engine

#: A Scotch yoke: a crank's pin (radius 0.05, 0.5 from the pivot) in the slot of a yoke sliding
#: along x, 0.015 clearance each side; on a 64 x 32 grid (0.045 in q1) the surface's drive stalls
#: in the channel and the rigid parts pass.
YOKE = """format = 1
name = "yoke"
[[part]]
name = "crank"
motion = "rotation"
pivot = [0.0, 0.0]
shapes = [{ circle = { center = [0.5, 0.0], radius = 0.05 } }]
[[part]]
name = "yoke"
motion = "translation"
direction = [1.0, 0.0]
shapes = [{ rectangle = { lower = [-0.2, -0.8], upper = [0.2, 0.8] }, minus = [
    { rectangle = { lower = [-0.065, -0.7], upper = [0.065, 0.7] } }] }]
[cspace]
lower = [0.0, -0.7]
upper = [6.283185307179586, 0.7]
shape = [64, 32]
[energy]
v = 1e-4
r_c = 0.03
[dynamics]
mass = [1.0, 1.0]
damping = [1.0, 1.0]
[start]
q = [0.0, 0.5]
"""
ENGINE_DEVICES = [(str(CAM), "--drive", "0", "--load", "0.5", *QUICK), ("ratchet", "--smoke"), ("dartgun", "--smoke")]


@pytest.mark.parametrize("argv", ENGINE_DEVICES, ids=["file", "ratchet", "dartgun"])
def test_an_unknown_engine_is_one_error_line_naming_the_flag(capsys, argv):
    code, out, err = run(capsys, *argv, "--engine", "soft")
    assert code == EXIT_ERROR and out == ""
    assert err.count("\n") == 1 and "--engine" in err and "'soft'" in err and "surface, rigid, both" in err


@pytest.mark.parametrize("engine", ["rigid", "both"])
@pytest.mark.parametrize("argv", ENGINE_DEVICES, ids=["file", "ratchet", "dartgun"])
def test_without_pymunk_the_rigid_engine_prints_the_pip_line_and_writes_nothing(capsys, monkeypatch, tmp_path,
                                                                                 argv, engine):
    monkeypatch.setitem(sys.modules, "pymunk", None)           # import pymunk -> ImportError
    extra = ("--json", str(tmp_path / "a.json")) if argv[0].endswith(".toml") else ()
    code, out, err = run(capsys, *argv, "--engine", engine, *extra)
    assert code == EXIT_ERROR and out == ""
    assert err.count("\n") == 1 and "pip install 'pes_ref[rigid]'" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_the_rigid_engine_writes_the_same_files_and_states_its_contact(capsys, tmp_path):
    out, js = tmp_path / "cam", tmp_path / "cam.json"
    values = figures(capsys, str(CAM), "--drive", "0", "--load", "0.5", *QUICK, "--engine", "rigid",
                     "--out", str(out), "--json", str(js))
    assert values["engine"] == "rigid" and values["restitution"] == "0 1" and values["friction"] == "0 1"
    assert (out / "motion_law.csv").read_text().startswith("q_in,q_out\n")
    summary = json.loads(js.read_text())
    assert (summary["engine"], summary["restitution"], summary["friction"]) == ("rigid", 0.0, 0.0)
    # the rigid follower rests on the cam: q1 = 0.5 + 0.2 sin q0 at the end of the turn
    assert summary["stopped_at"][1] == pytest.approx(0.5 + 0.2 * np.sin(summary["stopped_at"][0]), abs=2e-3)


def test_both_engines_side_by_side_with_their_difference_in_lines_csv_json_and_plot(capsys, tmp_path):
    out, js, plot = tmp_path / "cam", tmp_path / "cam.json", tmp_path / "cam.png"
    values = figures(capsys, str(CAM), "--drive", "0", "--load", "0.5", *QUICK, "--engine", "both",
                     "--out", str(out), "--json", str(js), "--plot", str(plot))
    assert values["device"] == "cam_follower"                          # the same in both: once
    s, r = (float(values[f"advance_per_cycle[{e}]"].split()[0]) for e in ("surface", "rigid"))
    assert float(values["advance_per_cycle[rigid-surface]"].split()[0]) == pytest.approx(r - s, abs=1e-5)
    # the surface's follower rides the barrier's standoff above the cam, the rigid one on it
    assert float(values["motion_law_offset[rigid-surface]"].split()[0]) < -0.03
    assert values["engine[rigid]"] == "rigid"
    text = (out / "motion_law.csv").read_text()
    assert text.startswith("q_in,q_out_surface,q_out_rigid\n")
    law = np.genfromtxt(out / "motion_law.csv", delimiter=",", skip_header=1)
    assert law.shape[1] == 3 and np.all(np.isfinite(law[:, 0]))
    summary = json.loads(js.read_text())
    assert summary["engine"] == "both" and summary["rigid"]["engine"] == "rigid"
    assert summary["difference"]["advance_per_cycle"] == pytest.approx(r - s, abs=1e-5)
    assert summary["difference"]["motion_law"]["offset"] < -0.03
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_ratchet_on_both_engines_side_by_side(capsys):
    values = figures(capsys, "ratchet", "--smoke", "--duration", "2", "--search-tol", "0.5", "--engine", "both")
    assert {"net_rotation_plus[surface]", "net_rotation_plus[rigid]", "net_rotation_plus[rigid-surface]",
            "engine[rigid]", "torque"} <= set(values)


@pytest.mark.parametrize("engine, verdict", [("surface", "resolution (the rigid parts pass)"),
                                             ("both", "resolution (the rigid parts pass)")])
def test_a_stall_of_the_grid_s_resolution_is_told_apart(capsys, tmp_path, engine, verdict):
    path = tmp_path / "yoke.toml"
    path.write_text(YOKE)
    values = figures(capsys, str(path), "--drive", "0", "--load", "1", "--engine", engine)
    assert values["stall"] == verdict
    assert values.get("stop_reason", values.get("stop_reason[surface]")) == "stalled"


def test_a_start_inside_the_rigid_parts_is_one_error_line_naming_start(capsys, tmp_path):
    # the follower's face at 0.45, inside the cam (its top at 0.5 at q0 = 0): the rigid parts overlap
    code, out, err = run(capsys, str(CAM), "--drive", "0", "--load", "0.5", *QUICK, "--engine", "rigid",
                         "--start", "0,0.45", "--json", str(tmp_path / "a.json"))
    assert code == EXIT_ERROR and out == "" and err.count("\n") == 1
    assert "--start" in err and "0.45" in err and "inside blocked space" in err
    assert list(tmp_path.iterdir()) == []


def test_an_angle_spanning_more_than_a_turn_warns_that_it_looks_like_degrees(capsys, tmp_path):
    """A rotating part's span typed in degrees (0..360) is taken as radians, 57 turns: the
    analysis runs, its travel says rad, and one warning names the axis and the radians meant."""
    device = tmp_path / "degrees.toml"
    assert 'motion = "rotation"' in DEGREES and "upper = [360.0, 0.5]" in DEGREES
    device.write_text(DEGREES)
    code, out, err = run(capsys, str(device), "--drive", "0", "--load", "1")
    assert code == EXIT_OK and "requested_travel: 360 rad" in out, out
    warnings = [line for line in err.splitlines() if line.startswith("warning: ")]
    assert len(warnings) == 1, err
    assert f"{device}: cspace: q0 is an angle" in warnings[0] and "0 .. 360 = 360 rad" in warnings[0], warnings
    assert "meant in degrees, write lower = 0, upper = 6.28319" in warnings[0], warnings
    device.write_text(DEGREES.replace("upper = [360.0, 0.5]", "upper = [6.0, 0.5]"))        # less than a turn: quiet
    code, out, err = run(capsys, str(device), "--drive", "0", "--load", "1")
    assert code == EXIT_OK and "requested_travel: 6 rad" in out and "warning" not in err, err


#: A pin on a crank (rotating about the origin) in a plate's hole, its angle's span typed in degrees:
#: the fault tables' device (tests/_faults.py) with its first part turned into a crank.
DEGREES = DEVICE.replace('motion = "translation"\ndirection = [1.0, 0.0]\nshapes = [{ circle = { center = [0.0, 0.0], '
                         'radius = 0.1 } }]', 'motion = "rotation"\npivot = [0.0, 0.0]\nshapes = [{ circle = { center = '
                         '[0.2, 0.0], radius = 0.1 } }]', 1).replace("lower = [-0.5, -0.5]\nupper = [0.5, 0.5]",
                                                                   "lower = [0.0, -0.5]\nupper = [360.0, 0.5]", 1)
