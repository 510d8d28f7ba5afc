"""validation/experiments/problems_*: the sweeps of ``make problems-study`` are valid and name the
shipped problem files; its script turns results into the tables of docs/problems.md."""
import csv

from _helpers import ROOT, load_script

from pes_ref.sweep.spec import load_sweep
from pes_ref.synthesis import load_problem, shipped_problem

EXPERIMENTS = ROOT / "validation" / "experiments"
study = load_script(EXPERIMENTS / "problems_study.py")


def test_the_sweeps_design_the_shipped_problems_on_three_seeds():
    for name in ("funnel", "latch"):
        sweep = load_sweep(EXPERIMENTS / f"problems_{name}.toml")
        assert sweep.problem == load_problem(shipped_problem(name))
        assert [r.seed for r in sweep.runs] == [0, 1, 2] and sweep.eval_seeds == (12345, 9191)


def _write(path, names, seed_values):
    columns = ["run", "seed", "status", "wall_s"] + [f"{n}@{h}" for n in names for h in study.HELD_OUT]
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, columns)
        w.writeheader()
        for seed, value in seed_values:
            w.writerow({"run": f"r{seed}", "seed": seed, "status": "ok", "wall_s": 12.3,
                        **{f"{n}@{h}": value for n in names for h in study.HELD_OUT}})


def test_the_tables(tmp_path, capsys):
    _write(tmp_path / "f.csv", ["success_in_band", "flat_success_fraction"], [(1, 0.9), (0, 0.95)])
    _write(tmp_path / "l.csv", [name for _, name in study.LATCH], [(0, 0.5)])
    assert study.main(["--funnel", str(tmp_path / "f.csv"), "--latch", str(tmp_path / "l.csv")]) == 0
    out = capsys.readouterr().out
    assert "| 0 | 12345 | 0.950 | 0.950 |" in out and "| 1 | 9191 | 0.900 | 0.900 |" in out
    assert out.index("| 0 | 12345") < out.index("| 1 | 12345")                  # by design seed
    assert "| 0 | 9191 | 0.500 | 0.500 | 0.500 | 0.500 | 0.500 | 0.500 | 0.500 | 12 |" in out
