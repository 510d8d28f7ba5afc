"""validation/experiments/funnel_objective.{toml,py}: the funnel study of docs/synthesis.md.

The sweep file's variants mean what their names say (resolved as ``design`` resolves the same
flags), and the summary counts the bar of docs/synthesis.md (both held-out seeds >= 0.9) per design seed.
The study itself is ``make funnel-study`` (about 5 minutes), not part of ``make test``.
"""
from __future__ import annotations

import pytest
from _helpers import ROOT, load_script, run_script

from pes_ref.sweep.options import run_inputs
from pes_ref.sweep.spec import load_sweep

EXPERIMENTS = ROOT / "validation" / "experiments"
study = load_script(EXPERIMENTS / "funnel_objective.py")


def _problem(options):
    """A run's problem and plan, resolved as the sweep's task resolves them."""
    inputs = run_inputs("funnel", options)
    return inputs.problem, inputs.plan()


def test_the_variants_are_the_settings_they_name():
    sweep = load_sweep(EXPERIMENTS / "funnel_objective.toml")
    first = {run.variant: run.options for run in sweep.runs if run.seed == 0}
    default, plan = _problem(first["default"])
    assert (default.when, default.exit_zone) == ("exit", 0.0) and plan.n_particles == 64
    before, _ = _problem(first["final_strip"])
    assert (before.when, before.exit_zone) == ("final", 0.05)
    assert _problem(first["exit_strip"])[0].exit_zone == 0.05 and _problem(first["exit_strip"])[0].when == "exit"
    assert _problem(first["final_nostrip"])[0].when == "final" and _problem(first["final_nostrip"])[0].exit_zone == 0
    assert _problem(first["particles256"])[1].n_particles == 256
    assert sorted({run.seed for run in sweep.runs}) == list(range(16))


def _row(variant, seed, a, b, exited=1.0):
    return {"variant": variant, "seed": str(seed), "status": "ok", "in_band_fraction@12345": str(a),
            "in_band_fraction@9191": str(b), "exited_fraction@12345": str(exited), "exited_fraction@9191": "1.0"}


def test_the_summary_counts_design_seeds_that_pass_on_both_held_out_seeds():
    rows = [_row("v", 1, 0.95, 0.85), _row("v", 0, 0.9, 0.99, exited=0.97), _row("v", 2, 0.91, 0.92),
            _row("w", 0, 0.5, 0.5), {**_row("w", 1, 0.0, 0.0), "status": "failed"}]
    lines = study.table(rows).splitlines()
    assert lines[2] == ("| v | 0.920 | 0.850 | 2 of 3 | 0.970 | 0.900 / 0.990, 0.950 / 0.850, 0.910 / 0.920 |")
    assert lines[3].startswith("| w | 0.500 | 0.500 | 0 of 1 |")


def test_a_missing_results_file_is_one_line(tmp_path):
    proc = run_script(EXPERIMENTS / "funnel_objective.py", tmp_path / "nothing.csv")
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and "run the sweep first" in proc.stderr


def _results_csv(tmp_path, design_file):
    path = tmp_path / "results.csv"
    row = {**_row("default", 0, 0.9, 0.9), "design_file": str(design_file)}
    path.write_text(",".join(row) + "\n" + ",".join(row.values()) + "\n")
    return path


@pytest.mark.parametrize("words, said", [
    (["default"], "expected VARIANT SEED [HELD_OUT]"),
    (["default", "0", "abc"], "expected VARIANT SEED [HELD_OUT]"),
    (["default", "0", "1", "2"], "expected VARIANT SEED [HELD_OUT]"),
    (["nope", "0"], "no run of variant 'nope' with seed 0"),
    (["default", "0"], "nothing.npz does not exist"),
])
def test_bad_misses_arguments_are_one_line(tmp_path, words, said):
    proc = run_script(EXPERIMENTS / "funnel_objective.py", _results_csv(tmp_path, tmp_path / "nothing.npz"),
                      "--misses", *words)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("error: ") and said in proc.stderr


def test_misses_describes_a_design(tmp_path):
    from pes_ref.synthesis import Plan, new_design, run_design, save_design
    state = run_design(new_design("funnel", seed=0, plan=Plan(iterations=2, n_particles=4), grid=8, n_steps=300))
    save_design(tmp_path / "d.npz", state)
    proc = run_script(EXPERIMENTS / "funnel_objective.py", _results_csv(tmp_path, tmp_path / "d.npz"),
                      "--misses", "default", "0", "7")
    assert proc.returncode == 0, proc.stderr
    first, *lines = proc.stdout.splitlines()
    assert "when=exit, exit_zone=0; held-out seed 7:" in first and "of 200 missed" in first
    assert lines and all(line.startswith("  start q0 ") for line in lines)
