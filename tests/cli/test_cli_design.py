"""``python -m pes_ref design`` and ``evaluate`` at tiny sizes (``--smoke``)."""
import dataclasses
import os

import numpy as np
import pytest

from pes_ref.cli import EXIT_ERROR, EXIT_FAIL, EXIT_OK, build_parser, main
from pes_ref.synthesis import KINDS, OSCILLATOR_PLANS, load_design


def run(capsys, *argv):
    code = main(list(map(str, argv)))
    out, err = capsys.readouterr()
    return code, out, err


def test_set_help_names_every_field_of_each_kinds_problem():
    design = next(a for a in build_parser()._actions if a.dest == "command").choices["design"]
    entry = " ".join(design.format_help().split())
    start = entry.index("--set NAME=VALUE override")
    entry = entry[start:entry.index("--lr LR", start)]
    for name, kind in KINDS.items():
        if kind.default_problem is not None:
            fields = ", ".join(f.name for f in dataclasses.fields(kind.default_problem))
            assert f"{name}: {fields};" in entry


@pytest.fixture
def funnel_file(tmp_path, capsys):
    path = tmp_path / "f.npz"
    code, out, err = run(capsys, "design", "funnel", "--smoke", "--out", path, "--progress", 0)
    assert code == EXIT_OK, err
    return path


def test_design_writes_a_loadable_file_with_progress(funnel_file, capsys):
    st = load_design(funnel_file)
    assert st.kind == "funnel" and st.iteration == 6 and st.status == "done"
    assert st.values.shape == (12, 12) and len(st.history["loss"]) == 6


def test_progress_line_and_summary(tmp_path, capsys):
    code, out, err = run(capsys, "design", "oscillator", "--smoke", "--out", tmp_path / "o.npz", "--progress", 0)
    assert code == EXIT_OK
    lines = err.strip().splitlines()
    gradient = [line for line in lines if line.startswith("design oscillator: stage ")]
    polish = [line for line in lines if line.startswith("design oscillator: polish ")]
    assert gradient and polish and lines.index(gradient[-1]) < lines.index(polish[0])
    for part in ("design oscillator: stage 1/1 | it 6/6 | grid 8x8 | steps 60 | loss ", "| amp_err ", " it/s |",
                 "| elapsed ", "| left "):
        assert part in gradient[-1]
    for part in ("design oscillator: polish | evaluations 25/20 | fitness ", "| start ", " evaluations/s |",
                 "| left "):
        assert part in polish[-1]
    assert out.startswith(f"wrote {tmp_path / 'o.npz'}: oscillator, iteration 6/6 (done)")
    assert ", polish 25 evaluations, fitness " in out


def test_existing_out_is_refused_without_force(funnel_file, capsys):
    before = funnel_file.read_bytes()
    code, out, err = run(capsys, "design", "funnel", "--smoke", "--out", funnel_file, "--seed", 1)
    assert code == EXIT_ERROR and err.startswith("error: ") and "exists" in err
    assert funnel_file.read_bytes() == before
    code, *_ = run(capsys, "design", "funnel", "--smoke", "--out", funnel_file, "--seed", 1, "--force", "--quiet")
    assert code == EXIT_OK and load_design(funnel_file).seed == 1


def test_resume_continues_like_an_uninterrupted_run(tmp_path, capsys):
    a, b = tmp_path / "a.npz", tmp_path / "b.npz"
    assert run(capsys, "design", "funnel", "--smoke", "--out", a, "--quiet")[0] == EXIT_OK
    assert run(capsys, "design", "funnel", "--smoke", "--iterations", 3, "--out", b, "--quiet")[0] == EXIT_OK
    assert run(capsys, "design", "funnel", "--smoke", "--resume", b, "--quiet")[0] == EXIT_OK   # back to 6, in place
    sa, sb = load_design(a), load_design(b)
    assert sb.iteration == 6
    np.testing.assert_array_equal(sa.values, sb.values)
    assert sa.history == sb.history


@pytest.mark.parametrize("argv, message", [
    (["design", "oscillator", "--smoke", "--resume", "{f}", "--out", "{tmp}/o.npz"], "is a funnel design, not an oscillator design"),
    (["design", "funnel", "--resume", "{f}", "--set", "n_steps=80"], "another scene: n_steps"),
    (["design", "funnel", "--set", "colour=red", "--out", "{tmp}/x.npz"], "--set 'colour=red'"),
    (["design", "funnel", "--stages", "0-25", "--out", "{tmp}/x.npz"], "--stages '0-25'"),
    (["design", "funnel", "--plan", "eq6", "--out", "{tmp}/x.npz"], "only the oscillator"),
    (["design", "oscillator", "--plan", "eq6", "--evaluations", "5", "--out", "{tmp}/x.npz"],
     "--evaluations: this oscillator run has no polish stage"),
    (["design", "funnel", "--workers", "2", "--out", "{tmp}/x.npz"], "--workers: this funnel run has no polish"),
    (["design", "oscillator", "--smoke", "--workers", "0", "--out", "{tmp}/x.npz"], "--workers must be >= 1"),
    (["evaluate", "{tmp}/nothing.npz"], "does not exist"),
    (["evaluate", "{tmp}/text.npz"], "is not an .npz archive"),
])
def test_bad_input_gets_one_error_line(funnel_file, tmp_path, capsys, argv, message):
    (tmp_path / "text.npz").write_text("not a design")
    argv = [a.format(f=funnel_file, tmp=tmp_path) for a in argv]
    code, out, err = run(capsys, *argv)
    assert code == EXIT_ERROR
    assert err.count("\n") == 1 and err.startswith("error: ") and message in err
    assert not (tmp_path / "o.npz").exists() and not (tmp_path / "x.npz").exists()


def test_resume_alone_continues_a_built_in_design(funnel_file, capsys):
    code, out, err = run(capsys, "design", "--resume", funnel_file, "--iterations", 7, "--quiet")
    assert code == EXIT_OK, err
    assert load_design(funnel_file).iteration == 7 and out.startswith(f"wrote {funnel_file}: funnel, iteration 7/7")


def test_smoke_resumes_only_a_design_of_its_size(tmp_path, capsys):
    path = tmp_path / "g16.npz"
    assert run(capsys, "design", "funnel", "--smoke", "--set", "grid=16", "--iterations", 1, "--out", path,
               "--quiet")[0] == EXIT_OK
    code, out, err = run(capsys, "design", "funnel", "--resume", path, "--smoke", "--quiet")
    assert (code, out) == (EXIT_ERROR, "")
    assert err == ("error: --smoke resumes only a design of its size: the design has grid = 16, --smoke's is 12; "
                   f"leave --smoke out to resume it\n")
    assert load_design(path).iteration == 1


def test_evaluate_prints_one_line_per_figure(funnel_file, capsys):
    code, out, err = run(capsys, "evaluate", funnel_file, "--particles", 20)
    assert code == EXIT_OK
    lines = dict(line.split(": ", 1) for line in out.strip().splitlines())
    for name in ("in_band_fraction", "exit_spread", "flat_in_band_fraction", "flat_exit_spread", "exited_fraction"):
        assert 0.0 <= float(lines[name]) <= 2.0
    assert lines["kind"] == "funnel" and lines["particles"] == "20"


@pytest.mark.parametrize("plan, method, stage", [("gait", "gradient+polish", "polish"),
                                                       ("eq6", "gradient", "gradient")])
def test_evaluate_oscillator_figures(tmp_path, capsys, plan, method, stage):
    """A smoke-size run of each stage through the command line, then evaluate."""
    path = tmp_path / "o.npz"
    assert run(capsys, "design", "oscillator", "--smoke", "--plan", plan, "--out", path,
               "--quiet")[0] == EXIT_OK
    code, out, err = run(capsys, "evaluate", path, "--particles", 3)
    assert code == EXIT_OK
    lines = dict(line.split(": ", 1) for line in out.strip().splitlines())
    assert lines["method"] == method and lines["stage"] == stage and lines["iterations"] == "6"
    assert lines["evaluations"] == ("25" if stage == "polish" else "0") and lines["status"] == "done"
    for name in ("captured_fraction", "amplitude_error", "period_error", "amplitude_error_median",
                 "period_error_median", "q1_advance_min", "q1_advance_median", "q1_advance_max", "gait_advance",
                 "flat_captured_fraction"):
        assert name in lines
    assert float(lines["gait_advance"]) == pytest.approx(np.pi / 2, rel=1e-5)


def test_polish_options_and_resume_through_the_command_line(tmp_path, capsys):
    a, b = tmp_path / "a.npz", tmp_path / "b.npz"
    assert run(capsys, "design", "oscillator", "--smoke", "--evaluations", 9, "--polish-particles", 3,
               "--out", a, "--quiet")[0] == EXIT_OK
    st = load_design(a)
    assert st.polish.evaluations == 9 and st.polish.n_particles == 3 and st.evaluations == 9
    # a bigger budget on resume runs the polish again, like a straight run with that budget
    assert run(capsys, "design", "oscillator", "--smoke", "--resume", a, "--evaluations", 17,
               "--polish-particles", 3, "--quiet")[0] == EXIT_OK
    assert run(capsys, "design", "oscillator", "--smoke", "--evaluations", 17, "--polish-particles", 3,
               "--workers", 2, "--out", b, "--quiet")[0] == EXIT_OK
    sa, sb = load_design(a), load_design(b)
    assert sa.evaluations == 17
    np.testing.assert_array_equal(sa.values, sb.values)
    assert sa.polish_history == sb.polish_history


@pytest.mark.parametrize("name", OSCILLATOR_PLANS)
def test_plan_selects_the_oscillator_overrides_and_plan(tmp_path, capsys, name):
    path = tmp_path / "o.npz"
    code, out, err = run(capsys, "design", "oscillator", "--smoke", "--plan", name, "--out", path, "--quiet")
    assert code == EXIT_OK, err
    st = load_design(path)
    sets, plan = OSCILLATOR_PLANS[name]
    assert all(getattr(st.problem, k) == v for k, v in sets.items())
    assert st.plan.lr == plan.lr and st.iteration == 6             # the setting's plan under the smoke preset
    # resuming with another named plan is another scene, refused
    other = [n for n in OSCILLATOR_PLANS if n != name][0]
    code, out, err = run(capsys, "design", "oscillator", "--resume", path, "--plan", other, "--quiet")
    assert code == EXIT_ERROR and "another scene" in err


def test_a_run_that_stops_exits_1_with_its_last_good_state(tmp_path, capsys):
    # three good iterations, then lr = 1e4: iteration 4's grid is past the stability rule,
    # so the run rolls back to iteration 3, saves it and exits 1
    path = tmp_path / "nf.npz"
    assert run(capsys, "design", "funnel", "--smoke", "--iterations", 3, "--out", path, "--quiet")[0] == EXIT_OK
    code, out, err = run(capsys, "design", "funnel", "--smoke", "--resume", path, "--lr", "1e4", "--lr-final", "1e4",
                         "--quiet")
    assert code == EXIT_FAIL and "unstable: iteration 4" in err and len(err.strip().splitlines()) == 1
    st = load_design(path)
    assert st.status.startswith("unstable") and st.iteration == 3 and np.isfinite(st.values).all()


def test_a_run_that_fails_before_its_first_iteration_leaves_no_file(tmp_path, capsys, monkeypatch):
    """The file claimed before the run is removed when nothing was done in it."""
    from pes_ref.synthesis.engine import runs

    def fail(*args, **kwargs):
        raise ValueError("n_steps must fit in memory")
    monkeypatch.setattr(runs, "run_stages", fail)
    code, out, err = run(capsys, "design", "funnel", "--smoke", "--out", tmp_path / "d.npz", "--quiet")
    assert code == EXIT_ERROR and err == "error: n_steps must fit in memory\n"
    assert not os.listdir(tmp_path)


def test_a_failed_resume_keeps_the_file(funnel_file, capsys, monkeypatch):
    from pes_ref.synthesis.engine import runs

    def fail(*args, **kwargs):
        raise ValueError("boom")
    monkeypatch.setattr(runs, "run_stages", fail)
    code, *_ = run(capsys, "design", "funnel", "--smoke", "--resume", funnel_file, "--iterations", 9, "--quiet")
    assert code == EXIT_ERROR and funnel_file.exists()
    assert load_design(funnel_file).iteration == 6


def test_the_progress_line_shows_the_stage_and_a_change_of_stage_says_so(tmp_path, capsys):
    """The curriculum is visible: a loss that rises with a longer horizon is not a divergence."""
    code, out, err = run(capsys, "design", "oscillator", "--smoke", "--stages", "0:6:30,3:0:60",
                         "--out", tmp_path / "o.npz", "--progress", 0)
    assert code == EXIT_OK, err
    lines = err.strip().splitlines()
    assert any(line.startswith("design oscillator: stage 1/2 | it 1/6 | grid 6x6 | steps 30 | loss ")
               for line in lines), err
    assert any(line.startswith("design oscillator: stage 2/2 | it 6/6 | grid 8x8 | steps 60 | loss ")
               for line in lines), err
    changes = [line for line in lines if "now stage" in line]
    assert changes == ["design oscillator: now stage 2/2: grid 8x8, 60 steps per run "
                       "(its loss is not comparable with stage 1/2's)"], err


def test_the_polish_uses_both_cores_by_default_and_an_explicit_workers_wins(monkeypatch):
    from pes_ref.synthesis.engine.polish import DEFAULT_WORKERS, polish_workers
    from pes_ref.synthesis import FunnelProblem, OscillatorProblem, design_inputs
    osc, funnel = design_inputs(OscillatorProblem(), {}), design_inputs(FunnelProblem(), {})
    monkeypatch.setattr(os, "cpu_count", lambda: 8)
    assert polish_workers(None, osc) == DEFAULT_WORKERS == 2
    assert polish_workers(None, osc, smoke=True) == 1 and polish_workers(None, funnel) == 1
    assert polish_workers(1, osc) == 1 and polish_workers(3, osc) == 3 and polish_workers(3, osc, smoke=True) == 3
    monkeypatch.setattr(os, "cpu_count", lambda: 1)
    assert polish_workers(None, osc) == 1


@pytest.mark.parametrize("validates", [True, False])
def test_the_summary_names_the_grid_a_validating_plan_delivers(tmp_path, capsys, validates):
    sets = ["--set", "realizable=true", "--set", "grid=21", "--set", "n_steps=60", "--set", "dt=0.05"] if validates \
        else ["--smoke"]
    code, out, _ = run(capsys, "design", "funnel", *sets, "--iterations", 4, "--out", tmp_path / "f.npz")
    assert code == EXIT_OK
    state = load_design(tmp_path / "f.npz")
    if validates:
        assert f"; delivered: the grid of iteration {state.best.iteration}, validation {state.best.success:.3f};" in out
    else:
        assert state.best is None and "delivered" not in out


def test_the_summary_and_evaluate_count_the_iterations_every_start_screened(tmp_path, capsys):
    # a disc no particle reaches: no start passes, so all three are screened (2 iterations each)
    # and the run goes on from one of them to its 4 iterations
    import json
    import _helpers
    text = _helpers.gather_problem(radius=1e-6, iterations=4).replace(
        "particles = 6", "particles = 6\nvalidate_every = 1\nvalidation_particles = 4\nstarts = 3\nscreen = 2")
    (tmp_path / "p.toml").write_text(text)
    code, out, _ = run(capsys, "design", tmp_path / "p.toml", "--out", tmp_path / "d.npz")
    assert code == EXIT_OK
    assert "iteration 4/4" in out and "; screened: 3 starts, 6 iterations;" in out
    assert load_design(tmp_path / "d.npz").screened == {"starts": 3, "iterations": 6}
    code, out, _ = run(capsys, "evaluate", tmp_path / "d.npz", "--particles", 4, "--json", tmp_path / "d.json")
    printed = dict(line.split(": ", 1) for line in out.splitlines())
    assert code == EXIT_OK and printed["screened_starts"] == "3" and printed["screened_iterations"] == "6"
    data = json.loads((tmp_path / "d.json").read_text())
    assert data["screened_starts"] == 3 and data["screened_iterations"] == 6
    code, out, _ = run(capsys, "design", tmp_path / "p.toml", "--set", "train.starts=1", "--out", tmp_path / "e.npz",
                       "--force")
    assert code == EXIT_OK and "screened" not in out                  # one start screens none
