"""``pes_ref check``: it passes pes_ref's own oracle and fails each broken program,
naming the key at fault (tests/testing/check_programs/broken.py)."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pes_ref.oracle.case import run_case
from pes_ref.testing import check as chk
from pes_ref.testing.conformance import load_manifest

BROKEN = Path(__file__).parent / "check_programs" / "broken.py"
ORACLE = f"{sys.executable} -m pes_ref oracle"
#: A few vectors of each kind: plain, damped, on a node and on the domain edge (kinks), invalid.
SUBSET = ["plane-dynamic", "cylinder-q0-dynamic", "damping-strong", "on-node", "on-domain-edge",
          "quadratic-quasistatic-arrays", "missing-values", "mass-zero", "dt-string"]


def _check(*args, timeout=600):
    proc = subprocess.run([sys.executable, "-m", "pes_ref", "check", *args], capture_output=True, text=True,
                          timeout=timeout)
    assert "Traceback" not in proc.stderr
    return proc


def _only(ids):
    return [a for vid in ids for a in ("--only", vid)]


def test_pes_ref_passes_200_random_cases(tmp_path):
    report = tmp_path / "r.json"
    proc = _check("--cmd", f"{ORACLE} {{pairs}}", "--no-vectors", "--random", "200", "--seed", "0", "--quiet",
                  "--report", str(report))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.strip().splitlines()[-1] == "200 passed, 0 failed"
    data = json.loads(report.read_text())
    assert data["passed"] == 200 and data["failed"] == 0
    assert all(c["ok"] for c in data["cases"])


def test_pes_ref_passes_every_vector_through_the_python_api():
    report = chk.check(run_case)
    assert report.ok and report.failed == 0 and report.passed == len(load_manifest()["vectors"]), report.summary()


def test_pes_ref_passes_a_subset_one_process_per_case():
    proc = _check("--cmd", f"{ORACLE} {{case}} {{result}}", *_only(SUBSET))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    lines = proc.stdout.strip().splitlines()
    assert lines[-1] == f"{len(SUBSET)} passed, 0 failed"
    assert all(line.startswith("ok    ") for line in lines[:-1])


@pytest.mark.parametrize("mode, vectors, expect", [
    ("perturb", ["plane-dynamic"], "FAIL  plane-dynamic  energy: relative error"),
    ("no-damping", ["damping-strong"], "FAIL  damping-strong  "),
    ("other-side", ["on-node"], "FAIL  on-node  "),
    ("omit-gradient", ["plane-dynamic"], "FAIL  plane-dynamic  grad_values: missing from the result"),
    ("nan", ["plane-dynamic"], "FAIL  plane-dynamic  x: not finite"),
    ("accept-invalid", ["mass-zero"], "FAIL  mass-zero  accepted an invalid case"),
])
def test_a_broken_program_fails_and_names_the_key(mode, vectors, expect, tmp_path):
    keep = tmp_path / "keep"
    proc = _check("--cmd", f"{sys.executable} {BROKEN} {mode} {{pairs}}", *_only(vectors), "--keep", str(keep))
    assert proc.returncode == 1, proc.stdout + proc.stderr
    lines = proc.stdout.strip().splitlines()
    assert lines[-1] == f"0 passed, {len(vectors)} failed"
    assert lines[0].startswith(expect), lines[0]
    if mode in ("no-damping", "other-side"):       # the worst key of a wrong trajectory is named
        key = lines[0].split()[2].rstrip(":")
        assert key in ("x", "v", "energy", "loss") or key.startswith("grad_"), lines[0]
    kept = keep / vectors[0]
    assert (kept / "case.npz").is_file() and (kept / "reproduce.sh").is_file()


def test_broken_programs_fail_on_random_cases_too():
    proc = _check("--cmd", f"{sys.executable} {BROKEN} perturb {{pairs}}", "--no-vectors", "--random", "5")
    lines = proc.stdout.strip().splitlines()
    assert proc.returncode == 1 and lines[-1].endswith(" failed")
    failed = [line for line in lines if line.startswith("FAIL")]
    assert len(failed) >= 4 and all("energy: relative error" in line for line in failed)   # all-zero energy: unharmed


def test_a_hanging_program_is_reported_as_a_timeout():
    proc = _check("--cmd", f"{sys.executable} {BROKEN} hang {{case}} {{result}}", "--only", "plane-dynamic",
                  "--timeout", "2")
    assert proc.returncode == 1
    assert proc.stdout.splitlines()[0] == "FAIL  plane-dynamic  timed out after 2 s"


def test_random_cases_are_deterministic_and_well_conditioned():
    a = chk.draw_cases(12, seed=3)
    b = chk.draw_cases(12, seed=3)
    assert [x[0] for x in a] == [x[0] for x in b]
    for (_, ca, cond), (_, cb, _) in zip(a, b):
        assert cond <= chk.CONDITION_BOUND
        assert ca.keys() == cb.keys() and all(np.array_equal(ca[k], cb[k]) for k in ca)


def test_the_conditioning_filter_drops_an_ill_conditioned_case():
    with pytest.raises(RuntimeError, match="within the conditioning bound"):
        chk.draw_cases(3, seed=0, bound=0.5, max_draws=10)   # growth is >= 1 for every run


@pytest.mark.parametrize("args, message", [
    (["--cmd", "prog"], "names neither {case}"),
    (["--cmd", "prog {case}"], "names {case} but not {result}"),
    (["--cmd", "prog {pairs}", "--random", "-1"], "--random must be >= 0"),
    (["--cmd", "prog {pairs}", "--no-vectors"], "leaves nothing to check"),
])
def test_bad_arguments_get_one_line(args, message):
    proc = _check(*args)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1 and message in proc.stderr, proc.stderr
