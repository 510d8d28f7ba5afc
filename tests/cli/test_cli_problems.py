"""``python -m pes_ref design PROBLEM.toml`` and ``evaluate``: a problem file gets the whole
design machinery (progress with time left, the design file, resume, Ctrl-C) at tiny sizes."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import _helpers

import pes_ref
from pes_ref.cli import EXIT_ERROR, EXIT_INTERRUPTED, EXIT_OK, main
from pes_ref.cli import build_parser
from pes_ref.synthesis import SHIPPED_PROBLEMS, load_design

ROOT = Path(pes_ref.__file__).resolve().parent.parent
ENV = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), OMP_NUM_THREADS="1")

GATHER = _helpers.gather_problem(walls=True, eval_particles=20, radius=0.2, iterations=6, train_particles=8)


def run(capsys, *argv):
    code = main(list(map(str, argv)))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def gather(tmp_path):
    path = tmp_path / "gather.toml"
    path.write_text(GATHER)
    return path


def test_the_shipped_problems_are_the_package_files_and_the_help_names_them():
    data = Path(pes_ref.__file__).parent / "synthesis" / "data"
    assert sorted(SHIPPED_PROBLEMS) == sorted(p.stem for p in data.glob("*.toml"))
    design = next(a for a in build_parser()._actions if a.dest == "command").choices["design"]
    assert ", ".join(f"{name}.toml" for name in SHIPPED_PROBLEMS) in " ".join(design.format_help().split())


def test_design_a_problem_file_then_evaluate_and_resume(gather, tmp_path, capsys):
    out = tmp_path / "g.npz"
    code, stdout, err = run(capsys, "design", gather, "--out", out, "--progress", 0)
    assert code == EXIT_OK, err
    assert stdout.startswith(f"wrote {out}: gather, iteration 6/6 (done)") and ", success " in stdout
    line = err.strip().splitlines()[-1]
    for part in ("design gather: stage 1/1 | it 6/6 | grid 8x8 | steps 40 | loss ", "| success ", " it/s |",
                 "| elapsed ", "| left 0:00"):
        assert part in line, line
    code, stdout, err = run(capsys, "evaluate", out, "--seed", 9191)
    assert code == EXIT_OK, err
    lines = dict(line.split(": ", 1) for line in stdout.strip().splitlines())
    assert lines["kind"] == "problem" and lines["problem"] == "gather" and lines["particles"] == "20"
    for name in ("success_fraction", "success_final_position", "flat_success_fraction"):
        assert 0.0 <= float(lines[name]) <= 1.0
    assert float(lines["objective_final_position"]) > 0
    # resumed with nothing but the design file, then with the same file
    assert run(capsys, "design", "--resume", out, "--iterations", 8, "--quiet")[0] == EXIT_OK
    assert load_design(out).iteration == 8
    assert run(capsys, "design", gather, "--resume", out, "--iterations", 9, "--quiet")[0] == EXIT_OK
    assert load_design(out).iteration == 9


def test_a_changed_problem_file_is_refused_on_resume(gather, tmp_path, capsys):
    out = tmp_path / "g.npz"
    assert run(capsys, "design", gather, "--out", out, "--quiet")[0] == EXIT_OK
    before = out.read_bytes()
    gather.write_text(GATHER.replace("dt = 0.05", "dt = 0.04"))
    code, stdout, err = run(capsys, "design", gather, "--resume", out, "--iterations", 9)
    assert code == EXIT_ERROR and err.count("\n") == 1
    assert f"the problem file {gather} differs from the one the design was made with: dynamics.dt = 0.04 there, " \
           "0.05 in the design's problem" in err
    code, stdout, err = run(capsys, "design", "--resume", out, "--set", "dynamics.dt=0.04")
    assert code == EXIT_ERROR and "--set: a resumed design keeps its problem; dynamics.dt = 0.04" in err
    assert out.read_bytes() == before


@pytest.mark.parametrize("name", ["latch", "funnel.toml"])
def test_a_shipped_problem_by_its_name(name, tmp_path, capsys):
    out = tmp_path / "s.npz"
    code, stdout, err = run(capsys, "design", name, "--smoke", "--out", out, "--quiet")
    assert code == EXIT_OK, err
    state = load_design(out)
    assert state.kind == "problem" and state.problem.name == name.removesuffix(".toml")
    assert state.iteration == 6 and max(state.values.shape) <= 12


@pytest.mark.parametrize("target, warned", [("[1.5, 0.2]", True), ("[0.9, 0.2]", False)])
def test_a_success_region_outside_the_domain_is_one_warning_before_the_run(target, warned, tmp_path, capsys):
    # the disc of radius 0.3 about (1.5, 0.2) lies wholly beyond q0 = 1; about (0.9, 0.2) it reaches in
    path = tmp_path / "far.toml"
    path.write_text(_helpers.gather_problem(iterations=1, train_particles=2).replace(
        "target = [0.3, -0.2]\nradius", f"target = {target}\nradius"))
    code, out, err = run(capsys, "design", path, "--quiet", "--out", tmp_path / "far.npz")
    assert code == EXIT_OK, err
    warnings = [line for line in err.splitlines() if line.startswith("warning:")]
    if not warned:
        assert warnings == []
        return
    assert warnings == [f"warning: {path}: evaluate.success[0] (final_position): its region [[1.2, -0.1], [1.8, 0.5]] "
                        f"lies wholly outside the domain [[-1.0, -1.0], [1.0, 1.0]], where the surface is not "
                        f"designed: no particle is brought there"]


def test_a_loss_of_zero_while_particles_fail_is_one_error_line_and_no_file(tmp_path, capsys):
    path = tmp_path / "blind.toml"
    path.write_text(_helpers.gather_problem(iterations=3, train_particles=4).replace(
        '[[evaluate.success]]\nkind = "final_position"\ntarget = [0.3, -0.2]\nradius = 0.3',
        '[[evaluate.success]]\nkind = "custom"\nobject = "_helpers:UNCHARGED_TEST"').replace(
        '[[objective]]\nkind = "final_position"\ntarget = [0.3, -0.2]\n', ''))
    code, out, err = run(capsys, "design", path, "--quiet", "--out", tmp_path / "blind.npz")
    assert code == 1 and out == ""
    assert err.splitlines() == ["error: the run stopped at its first iteration, so no design file was written: "
                                "uncharged: iteration 0: the loss is 0 while the batch's success is 0.000: "
                                "nothing charges what its particles fail"]
    assert not (tmp_path / "blind.npz").exists()


def test_set_train_keys_change_the_plan_the_design_runs(gather, tmp_path, capsys):
    out = tmp_path / "g.npz"
    code, stdout, err = run(capsys, "design", gather, "--set", "train.iterations=3", "--set", "train.particles=5",
                            "--out", out, "--quiet")
    assert code == EXIT_OK and stdout.startswith(f"wrote {out}: gather, iteration 3/3 (done)"), (stdout, err)
    state = load_design(out)
    assert (state.plan.iterations, state.plan.n_particles) == (3, 5) == (state.problem.plan.iterations,
                                                                        state.problem.plan.n_particles)


@pytest.mark.parametrize("with_file", [True, False], ids=["with-the-file", "design-file-alone"])
def test_smoke_resumes_only_a_design_of_its_size(tmp_path, capsys, with_file):
    """--smoke on --resume continues a smoke design; any other is refused naming --smoke, not the file."""
    big = tmp_path / "big.toml"
    big.write_text(GATHER.replace("shape = [8, 8]", "shape = [16, 16]"))
    out = tmp_path / "b.npz"
    assert run(capsys, "design", big, "--iterations", 1, "--out", out, "--quiet")[0] == EXIT_OK
    before = out.read_bytes()
    code, stdout, err = run(capsys, "design", *([big] if with_file else []), "--resume", out, "--smoke", "--quiet")
    assert (code, stdout) == (EXIT_ERROR, "")
    assert err == ("error: --smoke resumes only a design of its size: the design has surface.shape = [16, 16], "
                   "--smoke's is [12, 12]; leave --smoke out to resume it\n")
    assert out.read_bytes() == before


def test_without_the_extra_a_contact_problem_is_refused_with_the_pip_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "shapely", None)          # import shapely -> ImportError
    code, out, err = run(capsys, "design", "latch_contact", "--smoke", "--out", tmp_path / "lc.npz")
    assert code == EXIT_ERROR and out == "" and err.count("\n") == 1, err
    assert err.startswith("error: ") and "the optional extra 'devices'" in err and "pip install 'pes_ref[devices]'" in err
    assert "internal error" not in err and not os.listdir(tmp_path)


def test_the_default_out_is_named_after_the_problem(gather, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert run(capsys, "design", gather, "--iterations", 1, "--quiet")[0] == EXIT_OK
    assert (tmp_path / "gather.npz").exists()


def test_a_stopped_problem_design_is_saved_and_exits_130(gather, tmp_path):
    out = tmp_path / "g.npz"
    proc = subprocess.Popen([sys.executable, "-m", "pes_ref", "design", str(gather), "--iterations", "100000",
                             "--progress", "0", "--out", str(out)], stderr=subprocess.PIPE, text=True, env=ENV)
    line = proc.stderr.readline()
    assert line.startswith("design gather:"), line
    time.sleep(0.2)
    proc.send_signal(signal.SIGINT)
    err = proc.communicate(timeout=60)[1]
    assert proc.returncode == EXIT_INTERRUPTED and "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith(f"interrupted; saved; continue with: python -m pes_ref design "
                                                  f"--resume {out}")
    state = load_design(out)
    assert state.status == "interrupted" and state.iteration >= 1
