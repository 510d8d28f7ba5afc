"""validation/experiments/realize_study.py (``make realize-study``): its smoke size runs the
design, realize and evaluate --realized commands and writes its table."""
import csv

import pytest

from _helpers import ROOT, load_script

study = load_script(ROOT / "validation" / "experiments" / "realize_study.py")
latch = load_script(ROOT / "validation" / "experiments" / "realize_latch.py")


def test_the_smoke_study_writes_a_row_per_held_out_seed(tmp_path, capsys):
    name = "realizable, V start, linger 1"
    assert study.main(["--smoke", "--out", str(tmp_path), "--only", name]) == 0
    out = capsys.readouterr().out
    assert out.count(f"| {name} |") == 2
    with open(tmp_path / "realize_study.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [int(r["seed"]) for r in rows] == list(study.HELD_OUT)
    for r in rows:
        assert r["rule"] == "level-set"
        assert 0.0 <= float(r["realized_in_band_fraction"]) <= 1.0
        assert float(r["realized_dt"]) <= 0.05                     # the smoke preset's dt, or the rule's


@pytest.mark.thorough      # 58 s; in make test: the study's other modes below, tests/realize/test_drum_cam.py and
#                           tests/cli/test_cli_realize.py's drum cam of a cylinder design
def test_the_smoke_oscillator_study_writes_a_row_per_level_and_seed_and_says_what_is_not_a_wall(tmp_path, capsys):
    assert study.main(["--oscillator", "--smoke", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    with open(tmp_path / "realize_oscillator.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 3 * len(study.HELD_OUT)                      # the visited level and its two neighbours
    for r in rows:
        assert 0.0 <= float(r["realized_captured_fraction"]) <= 1.0
        assert float(r["realized_dt"]) <= 0.05
    figures = dict(line.split(": ", 1) for line in out.splitlines() if ": " in line and not line.startswith("|"))
    assert 0.0 < float(figures["force_share_below_level"]) <= 1.0
    assert 0.0 < float(figures["grid_below_level"]) < 1.0


def test_the_latch_study_writes_a_row_per_held_out_seed(tmp_path, capsys):
    name = "latch_contact, starting shapes alone"
    assert latch.main(["--smoke", "--out", str(tmp_path), "--only", name]) == 0
    assert capsys.readouterr().out.count(f"| {name} |") == 2
    with open(tmp_path / "realize_latch.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [int(r["seed"]) for r in rows] == list(latch.HELD_OUT)
    for r in rows:
        assert r["rule"] == "level-set" and r["iterations"] == "0"
        assert 0.0 <= float(r["realized_success_fraction"]) <= 1.0


@pytest.mark.parametrize("name, shares", [("funnel, realizable, V start, linger 20", "-"),
                                          ("splitter_parts, design seed 0", "of 2")])
def test_the_smoke_rigid_study_writes_both_engines_scores_per_candidate_and_seed(tmp_path, capsys, name, shares):
    pytest.importorskip("pymunk")
    rigid = load_script(ROOT / "validation" / "experiments" / "realize_rigid.py")
    assert rigid.main(["--smoke", "--out", str(tmp_path), "--only", name]) == 0
    out = capsys.readouterr().out
    tried = [c for c, (applies, _) in rigid.CANDIDATES.items() if name in applies]
    assert out.count(f"| {name} |") == len(tried) * len(rigid.HELD_OUT)
    rows = [r for f in tmp_path.glob("realize_rigid*.csv") for r in csv.DictReader(open(f, newline=""))]
    assert [r["candidate"] for r in rows] == [c for c in tried for _ in rigid.HELD_OUT]
    for r in rows:
        assert 0.0 <= float(r["soft"]) <= 1.0 and 0.0 <= float(r["rigid"]) <= 1.0
        assert r["rigid_shares"].endswith(shares)             # the splitter's two [[evaluate.share]] criteria
