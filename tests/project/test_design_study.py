"""validation/experiments/design_study.py (``make design-study``): every shipped problem and
example on the default plan; its smoke size runs, writes its CSV and replaces only its table."""
import csv

from _helpers import ROOT, load_script

study = load_script(ROOT / "validation" / "experiments" / "design_study.py")


def test_the_study_covers_every_shipped_problem_and_example():
    names = {p.rsplit("/", 1)[-1] for p in study.problem_files()}
    assert {"funnel.toml", "latch.toml", "nest.toml", "offcentre_funnel.toml", "sorter.toml"} <= names


def test_a_problem_on_the_default_plan_has_no_train_table():
    problem = study.default_plan_problem(study.problem_files()[0], smoke=False)
    assert "train" not in problem.data


def test_the_smoke_size_runs_and_replaces_only_its_table(tmp_path):
    doc = tmp_path / "doc.md"
    doc.write_text(f"before\n{study.BEGIN}\nold\n{study.END}\nafter\n")
    assert study.main(["--smoke", "--problems", "nest,sorter", "--seeds", "0,1", "--backends", "numpy",
                       "--workers", "1", "--doc", str(doc), "--out", str(tmp_path / "out")]) == 0
    text = doc.read_text()
    assert text.startswith(f"before\n{study.BEGIN}\n") and text.endswith(f"{study.END}\nafter\n") and "old" not in text
    assert "| nest | numpy |" in text and "| sorter | numpy |" in text and "--smoke --problems nest,sorter" in text
    with open(tmp_path / "out" / "results.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [(r["problem"], r["seed"]) for r in rows] == [("nest", "0"), ("nest", "1"), ("sorter", "0"),
                                                          ("sorter", "1")]
    assert all(0.0 <= float(r["success@12345"]) <= 1.0 for r in rows)


def test_an_unknown_problem_is_refused_in_one_line(capsys, tmp_path):
    assert study.main(["--smoke", "--problems", "nope", "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err.startswith("error: --problems: no problem 'nope'")
