"""A run past the stability rule (docs/spec.md section 10) is refused in one line at every
public boundary: the oracle (in process and on the command line), ``design`` (before any
file is written) and ``analyze``; ``--allow-unstable`` / ``allow_unstable=True`` opt out.
A fresh design that stops before finishing an iteration leaves no file behind."""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import pes_ref
from pes_ref import synthesis
from pes_ref.cli import EXIT_ERROR, EXIT_FAIL, EXIT_OK, main
from pes_ref.core import stability
from pes_ref.oracle import case as oracle
from pes_ref.synthesis import Plan

ROOT = Path(pes_ref.__file__).resolve().parent.parent


def run_cli(*args, cwd=None, timeout=120):
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "pes_ref", *map(str, args)], capture_output=True, text=True,
                          env=env, cwd=cwd, timeout=timeout)


def one_error_line(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), stderr
    assert "Traceback" not in stderr
    return lines[0]


def spring_case(factor=1.5, mode="dynamic", n_steps=6) -> dict:
    """A small case whose spring is at ``factor`` times its stability limit (k = 400, m = 1:
    dt = 0.1 factor, or mobility_0 = 0.005 factor); finite for a few steps at 1.5x."""
    rng = np.random.default_rng(3)
    case = dict(values=0.1 * rng.normal(size=(5, 7)), lower=np.zeros(2), upper=np.array([1.0, 1.5]),
                periodic=np.array([False, False]), dt=np.float64(0.1 * factor), n_steps=np.int64(n_steps),
                mode=mode, mass=np.float64(1.0), damping=np.float64(0.0), x0=np.array([[0.3, 0.4], [0.6, 1.1]]),
                v0=np.zeros((2, 2)), objective="funnel", target=np.float64(0.5), when="final",
                spring_k=np.array([400.0, 1.0]), spring_center=np.array([0.5, 0.75]))
    if mode == "quasistatic":
        case.update(dt=np.float64(0.1), mobility=np.array([0.005 * factor, 0.01]))
    return case


# =========================================================================== the oracle

@pytest.mark.parametrize("mode, key", [("dynamic", "dt"), ("quasistatic", "mobility")])
def test_oracle_refuses_a_finite_case_past_the_limit(mode, key):
    case = spring_case(1.5, mode)
    with pytest.raises(oracle.CaseError) as info:
        oracle.validate_case(case)
    assert info.value.key == key and str(info.value).startswith(f"case key '{key}': {key} = ")
    with pytest.raises(oracle.CaseError):
        oracle.run_case(case)
    result = oracle.run_case(case, allow_unstable=True)          # its numbers stay finite
    assert np.isfinite(result["x"]).all()
    inside = oracle.run_case(spring_case(0.99, mode))
    assert np.isfinite(inside["loss"])


def test_oracle_never_refuses_a_case_of_no_step():
    assert oracle.run_case(spring_case(50.0, n_steps=0))["x"].shape == (1, 2, 2)


def test_oracle_non_finite_refusal_is_one_short_line():
    case = spring_case(30.0, n_steps=400)
    with pytest.raises(oracle.CaseError) as info:
        oracle.run_case(case, allow_unstable=True)
    msg = str(info.value)
    assert info.value.key == "dt" and "non-finite at step" in msg and msg.count("stability limit") == 1, msg
    assert len(msg) < 220, (len(msg), msg)


@pytest.mark.parametrize("mode, key", [("dynamic", "dt"), ("quasistatic", "mobility")])
def test_cli_oracle_refuses_with_one_line_and_writes_nothing(mode, key, tmp_path):
    path, out = tmp_path / "c.npz", tmp_path / "r.npz"
    oracle.save_case(path, **spring_case(1.5, mode))
    proc = run_cli("oracle", path, out)
    line = one_error_line(proc.stderr)
    assert proc.returncode == EXIT_ERROR and not out.exists()
    assert f"case key '{key}'" in line and "stability limit" in line and f"a stable {key} is" in line
    proc = run_cli("oracle", path, out, "--allow-unstable")
    assert proc.returncode == EXIT_OK, proc.stderr
    assert out.exists() and proc.stderr == ""


# =========================================================================== design

@pytest.mark.parametrize("dt", ["1e9", "5"])
def test_cli_design_refuses_an_unstable_dt_before_writing(dt, tmp_path):
    out = tmp_path / "d.npz"
    proc = run_cli("design", "funnel", "--smoke", "--set", f"dt={dt}", "--out", out, "--quiet")
    line = one_error_line(proc.stderr)
    assert proc.returncode == EXIT_ERROR and "--set dt = " in line and "a stable --set dt is" in line, line   # named by its flag
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_new_design_refuses_an_unstable_scene():
    with pytest.raises(stability.UnstableStepError) as info:
        synthesis.new_design("funnel", dt=5.0)
    assert info.value.key == "dt"
    with pytest.raises(stability.UnstableStepError):
        synthesis.new_design("oscillator", wall_k=1e7)


def test_a_grid_steepening_past_the_limit_stops_the_run_at_the_last_good_state():
    """lr = 1e4: the first step makes the grid so steep that iteration 1's scene is past the
    rule; the run stops there and rolls back to the state before that step."""
    plan = Plan(iterations=5, lr=1e4, lr_final=1e4, n_particles=4)
    st = synthesis.new_design("funnel", seed=0, plan=plan, grid=8, n_steps=200, noise=0.0)
    start = st.values.copy()
    st = synthesis.run_design(st)
    assert st.status.startswith("unstable: iteration 1: dt = "), st.status
    assert st.iteration == 0 and st.history["loss"] == []
    np.testing.assert_array_equal(st.values, start)


def test_cli_design_that_stops_before_its_first_iteration_leaves_no_file(tmp_path):
    """noise = 1e300 overflows the first run: nothing is saved (the file was never usable)."""
    out = tmp_path / "d.npz"
    proc = run_cli("design", "funnel", "--smoke", "--set", "noise=1e300", "--out", out, "--quiet")
    assert proc.returncode == EXIT_FAIL, proc.stderr
    line = one_error_line(proc.stderr)
    assert "non-finite" in line and "no design file" in line, line
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_cli_design_stopped_at_iteration_0_keeps_the_file_it_would_replace(tmp_path, capsys):
    out = tmp_path / "d.npz"
    assert main(["design", "funnel", "--smoke", "--out", str(out), "--quiet"]) == EXIT_OK
    before = out.read_bytes()
    code = main(["design", "funnel", "--smoke", "--set", "noise=1e300", "--out", str(out), "--force", "--quiet"])
    err = capsys.readouterr().err
    assert code == EXIT_FAIL and out.read_bytes() == before, err


def test_cli_design_unstable_midway_saves_nothing_if_no_iteration_finished(tmp_path, capsys):
    out = tmp_path / "d.npz"
    code = main(["design", "funnel", "--smoke", "--lr", "1e4", "--lr-final", "1e4", "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert code == EXIT_FAIL and "unstable: iteration 1" in err and not out.exists(), err


# =========================================================================== analyze

@pytest.mark.parametrize("device, preset", [("ratchet", "RATCHET_SMOKE"), ("dartgun", "DARTGUN_SMOKE")])
def test_cli_analyze_refusal_is_one_line(device, preset, capsys, monkeypatch):
    """No analyze option changes a device's step (none exists that makes it unstable); a
    design whose dt is past the limit is refused in one line, exit 2."""
    from pes_ref.cli import analyze
    monkeypatch.setitem(getattr(analyze, preset), "dt", 5.0)
    code = main(["analyze", device, "--smoke"])
    out, err = capsys.readouterr()
    assert code == EXIT_ERROR and out == ""
    line = one_error_line(err)
    assert "dt = 5 is" in line and "a stable dt is" in line, line
