"""``pes_ref check``: it passes pes_ref's own oracle, and fails an implementation of each
kind of wrong (tests/testing/check_programs/broken.py), naming the key at fault."""
import importlib.util
import json
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from contextlib import ExitStack
from pathlib import Path

import numpy as np
import pytest
from hypothesis import settings

from pes_ref.core import stability
from pes_ref.oracle.case import CaseError, run_case, validate_case
from pes_ref.oracle.compare import compare_results, passes
from pes_ref.testing import check as chk
from pes_ref.testing import draws
from pes_ref.testing.conformance import load_manifest, names_key

PROGRAMS = Path(__file__).parent / "check_programs"
BROKEN = PROGRAMS / "broken.py"
ORACLE = f"{sys.executable} -m pes_ref oracle"
#: A few vectors of each kind: plain, on a node (a kink), quasistatic, invalid.
SUBSET = ["plane-dynamic", "on-node", "quadratic-quasistatic-arrays", "mass-zero", "dt-string"]


def _broken_module():
    spec = importlib.util.spec_from_file_location("broken_programs", BROKEN)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _broken_modes() -> dict:
    return _broken_module().MODES


def _check(*args, timeout=600):
    proc = subprocess.run([sys.executable, "-m", "pes_ref", "check", *args], capture_output=True, text=True,
                          timeout=timeout)
    assert "Traceback" not in proc.stderr
    return proc


def _only(ids):
    return [a for vid in ids for a in ("--only", vid)]


# =========================================================================== pes_ref passes

def test_pes_ref_passes_every_vector_and_200_random_cases_strictly(tmp_path):
    """The oracle on the whole newest set and 200 fresh cases, in strict mode, with its
    refusals in {refusals}: three processes (valid and random cases; invalid ones; the mixed
    batch of docs/spec.md 13.2)."""
    report = tmp_path / "r.json"
    proc = _check("--cmd", f"{ORACLE} --refusals {{refusals}} {{pairs}}", "--random", "200", "--seed", "0",
                  "--strict", "--report", str(report))
    n = len(load_manifest()["vectors"]) + 200 + 1          # and the mixed batch
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr
    lines = proc.stdout.strip().splitlines()
    assert lines[-1] == f"{n} passed, 0 failed" and len(lines) == n + 1
    data = json.loads(report.read_text())
    assert data["passed"] == n and data["settings"]["strict"] is True
    assert [b["what"] for b in data["batches"]] == ["valid", "invalid", "mixed"]
    kinds = [c["kind"] for c in data["cases"]]
    assert kinds == sorted(kinds, key=["valid", "invalid", "batch", "random"].index)   # random cases come last
    assert kinds.count("batch") == 1 and data["batches"][2]["exit"] == 2
    for case in data["cases"]:
        assert case["seconds"] is None and case["batch"] == ["valid", "invalid", "batch"].index(
            {"random": "valid"}.get(case["kind"], case["kind"]))                 # they ran in a batch: which
        if case["kind"] == "batch":
            assert case["case_id"] == chk.MIXED_BATCH and case["detail"].startswith("exit 2: 3 of 6 cases refused")
        elif case["kind"] == "invalid" and case["case_id"].startswith("random-"):
            assert case["key"] in ("dt", "mobility")                # a random case past the stability limit
        elif case["kind"] == "invalid":
            assert case["key"] == next(e["key"] for e in load_manifest()["vectors"] if e["id"] == case["case_id"])
        else:
            assert case["array"] in case["errors"] and case["error"] <= case["tolerance"]
            assert case["tolerance"] == (1e-12 if case["array"] in ("x", "v", "energy", "loss") else 1e-9)


def test_pes_ref_passes_every_vector_through_the_python_api():
    report = chk.check(run_case, strict=True)
    entries = load_manifest()["vectors"]
    files = [e["id"] for e in entries if "file" in e["flags"]]
    assert files and report.settings["not_run"]["ids"] == files       # a dict-taking function reads no file
    assert report.ok and report.passed == len(entries) - len(files), report.summary()


def test_pes_ref_passes_a_subset_one_process_per_case(tmp_path):
    report = tmp_path / "r.json"
    proc = _check("--cmd", f"{ORACLE} {{case}} {{result}}", *_only(SUBSET), "--report", str(report))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    lines = proc.stdout.strip().splitlines()
    assert lines[-1] == f"{len(SUBSET)} passed, 0 failed"
    assert all(line.startswith("ok    ") for line in lines[:-1])
    data = json.loads(report.read_text())
    assert len(data["batches"]) == len(SUBSET) and all(c["seconds"] > 0 for c in data["cases"])


def test_an_invalid_case_a_batch_leaves_unanswered_runs_alone(tmp_path):
    """A program that stops at its first refusal answers one invalid case of the batch;
    every other one runs again in a process of its own, and passes."""
    ids = ["plane-dynamic", "missing-values", "mass-zero", "dt-string"]
    report = chk.check(f"{sys.executable} {BROKEN} first-refusal-only {{pairs}}", only=ids)
    assert report.ok, [o.line() for o in report.outcomes]
    assert [b["what"] for b in report.batches] == ["valid", "invalid", "one invalid case", "one invalid case",
                                                   "mixed"]
    assert [o.seconds is None for o in report.outcomes] == [False, True, False, False, True]   # alone: timed
    assert [o.batch for o in report.outcomes] == [0, 1, 2, 3, 4]


# =========================================================================== each kind of wrong fails

#: Every kind of wrong implementation the checker must catch, with vectors that catch it
#: and the start of its verdict (after the case id), which names the key at fault: a
#: result array, or an invalid vector's key. A new promise of docs/spec.md gets a broken
#: program in broken.py and a row here (test_every_broken_program_has_a_row).
CLASSES = {
    # results
    "perturb": (["plane-dynamic"], "energy: relative error"),
    "no-damping": (["damping-strong"], "loss: relative error"),
    "other-side": (["on-node"], "v: relative error"),
    "omit-gradient": (["plane-dynamic"], "grad_values: missing from the result"),
    "nan": (["plane-dynamic"], "x: not finite"),
    "strict-clip-edge": (["grid-edge-plane"], "v: relative error"),
    "no-regularization-gradient": (["regularization"], "grad_values: relative error"),
    "float32-inverse-spacing": (["spacing-inexact-plane"], "energy: relative error"),
    "force-index-shifted": (["force-window-t0-negative"], "v: relative error"),
    "wrong-seam-period": (["spring-seam-cylinder-q0"], "v: relative error"),
    "wrong-damping-denominator": (["damping-strong"], "energy: relative error"),
    "no-final-force": (["force-constant"], "v: relative error"),
    "quasistatic-grad-v0": (["plane-quasistatic"], "grad_v0: relative error"),
    "t0-ignored": (["oscillator-t0-quasistatic"], "loss: relative error"),
    "missing-torus-result": (["torus-dynamic"], "no result written (exit 0)"),
    "zero-gradient": (["plane-dynamic"], "grad_values: gradient missing (all zeros): relative error"),
    "big-endian-result": (["plane-dynamic"], "x: dtype >f8, not float64 little-endian (<f8)"),
    "spring-center-sign": (["spring-per-axis"], "grad_spring_center: relative error"),
    # the kinks
    "wall-onset-split": (["wall-onset-dynamic"], "grad_x0: relative error"),
    "outside-edge-derivative": (["grid-edge-plane"], "grad_values: relative error"),
    # the valid cases v4 added (V4_FAMILIES)
    "float32-cell-index": (["near-edge-plane-dynamic", "near-edge-cylinder-q0-dynamic",
                            "near-edge-cylinder-q1-quasistatic", "near-edge-torus-dynamic"], "v: relative error"),
    "single-wall-room-rule": (["wide-margin-dynamic", "wide-margin-quasistatic"],
                              "no result written (exit 2 of the process of all 2 cases): error: <case>: "
                              "case key 'wall_margin'"),
    "bool-flags-only": (["integer-flags-int8", "integer-flags-uint8"],
                        "no result written (exit 2 of the process of all 2 cases): error: <case>: case key 'periodic'"),
    # refusals
    "accept-invalid": (["mass-zero"], "mass: accepted an invalid case (exit 0, a result written)"),
    "truncated-n-steps": (["n-steps-float-fraction"], "n_steps: accepted an invalid case (exit 0, a result written)"),
    "refusal-without-key": (["mass-zero", "dt-string"],
                            "mass: refused (exit 2 of the process of all 2 cases) without naming the key"),
    "wrong-key": (["mass-zero", "dt-string"],
                  "mass: refused (exit 2 of the process of all 2 cases) without naming the key"),
    "refusal-exits-0": (["mass-zero", "dt-string"], "mass: refused (naming the key, no result written) but exited 0"),
    # the families v5 added: the stability rule from both sides, optional keys invalid, edges of ranges
    "lenient-limit": (["limit-spring-particle-past"], "dt: accepted an invalid case (exit 0, a result written)"),
    "seamless-curvature": (["limit-grid-seam-dynamic-past", "limit-grid-seam-quasistatic-past"],
                           "dt: accepted an invalid case (exit 0 of the process of all 2 cases, a result written)"),
    "own-particle-mass": (["limit-spring-particle-past"], "dt: accepted an invalid case (exit 0, a result written)"),
    "t0-unchecked": (["optional-t0-nan", "optional-t0-inf"], "t0: accepted an invalid case (exit 0 of the process"),
    "spring-skipped-at-zero": (["edge-spring-k-all-zero"], "grad_spring_k: missing from the result"),
    # a process of several cases (docs/spec.md 13.2): its one exit status, judged on the mixed batch
    "last-exit-status": (["mass-zero", "plane-dynamic"], "exit status: exited 0 from a process of 2 cases"),
    "result-opened-early": (["overflow-dynamic"], "dt: wrote a result for an invalid case"),
    "error-kinds-swapped": (["mass-zero", "mass-bool"], "mass: refused as TypeError, the manifest declares ValueError"),
}
#: Classes caught only on the mixed batch: a process of valid and invalid cases (docs/spec.md 13.2).
MIXED_ONLY = {"last-exit-status"}
#: The programs the checks of spec v5 catch: the dtype, the messages, the mixed batch.
NEW_IN_V5 = {"zero-gradient", "big-endian-result", "refusal-exits-0", "last-exit-status", "lenient-limit",
             "seamless-curvature", "own-particle-mass", "t0-unchecked", "spring-skipped-at-zero"}
#: Those run again with --strict: two representatives (a result's dtype, a process's exit
#: status), every one under ``make test-thorough`` (the thorough profile's 10x examples).
STRICT_RERUNS = sorted(NEW_IN_V5) if settings.default.max_examples > 200 else ["big-endian-result",
                                                                                "last-exit-status"]
#: Programs that are not wrong (the baselines) or that test the timeout.
NOT_WRONG = {"ok", "reference", "first-refusal-only", "hang"}
#: Classes that only strict mode catches (docs/spec.md section 11).
STRICT_ONLY = {"error-kinds-swapped"}
#: Classes caught by the vectors v4 added: the family of vectors each fails on, every one,
#: and what its every verdict says.
V4_FAMILIES = {"float32-cell-index": ("near-edge", "relative error"),
               "single-wall-room-rule": ("wide-margin", "case key 'wall_margin'"),
               "bool-flags-only": ("integer-flags", "case key 'periodic'")}


def _broken(mode: str, ids, **kw) -> chk.CheckReport:
    refusals = " --refusals {refusals}" if kw.get("strict") else ""
    return chk.check(f"{sys.executable} {BROKEN} {mode}{refusals} {{pairs}}", only=ids, **kw)


@pytest.fixture(scope="module")
def verdicts() -> dict:
    """The check of every broken program on its vectors (strict where strict mode is what
    catches it), and of each again where its verdict must change: the strict-only ones
    without strict mode, the refusals without the key with ``--lenient-messages``, the
    readable reference on all their vectors. Run on a few threads: each check waits on
    its program's processes."""
    runs = {mode: (mode, ids, {"strict": mode in STRICT_ONLY}) for mode, (ids, _) in CLASSES.items()}
    runs.update({f"{mode} (not strict)": (mode, CLASSES[mode][0], {}) for mode in STRICT_ONLY})
    runs.update({f"{mode} (lenient)": (mode, CLASSES[mode][0], {"lenient_messages": True})
                 for mode in ("refusal-without-key", "wrong-key")})
    runs.update({f"{mode} (strict)": (mode, CLASSES[mode][0], {"strict": True}) for mode in STRICT_RERUNS})
    runs["reference"] = ("reference", sorted({vid for ids, _ in CLASSES.values() for vid in ids}), {})
    with ThreadPoolExecutor(max_workers=4) as pool:
        futures = {name: pool.submit(_broken, mode, ids, **kw) for name, (mode, ids, kw) in runs.items()}
        return {name: future.result() for name, future in futures.items()}


def test_every_broken_program_has_a_row():
    assert set(_broken_modes()) == set(CLASSES) | NOT_WRONG
    assert len(CLASSES) >= 16


@pytest.mark.parametrize("mode", sorted(CLASSES))
def test_a_broken_program_fails_named_by_its_key(mode, verdicts):
    ids, expect = CLASSES[mode]
    lines = [o.line() for o in verdicts[mode].outcomes]
    failed = [line for line in lines if line.startswith("FAIL")]
    first = chk.MIXED_BATCH if mode in MIXED_ONLY else ids[0]
    assert failed and failed[0].startswith(f"FAIL  {first}  {expect}"), lines


@pytest.mark.parametrize("mode", STRICT_RERUNS)
def test_a_broken_program_of_v5_fails_strictly_too(mode, verdicts):
    """Each program v5's checks catch fails ``check --strict`` too, on the same vectors."""
    report = verdicts[f"{mode} (strict)"]
    assert not report.ok and report.settings["strict"], [o.line() for o in report.outcomes]


@pytest.mark.parametrize("mode", sorted(V4_FAMILIES))
def test_a_case_v4_added_fails_its_broken_program_on_every_vector_of_its_family(mode, verdicts):
    family, says = V4_FAMILIES[mode]
    ids = [e["id"] for e in load_manifest()["vectors"] if e["id"].startswith(family + "-")]
    assert sorted(CLASSES[mode][0]) == sorted(ids) and not verdicts[mode].settings["strict"]
    assert [o.case_id for o in verdicts[mode].outcomes] == CLASSES[mode][0]
    for outcome in verdicts[mode].outcomes:
        assert not outcome.ok and says in outcome.detail, outcome.line()


def test_the_readable_reference_passes_where_the_broken_ones_fail(verdicts):
    """The broken programs built on the readable reference fail by their bug alone."""
    report = verdicts["reference"]
    assert report.ok and report.passed == len({vid for ids, _ in CLASSES.values() for vid in ids}) + 1, \
        [o.line() for o in report.outcomes if not o.ok]


def test_only_strict_mode_tells_the_error_kinds_apart(verdicts):
    for mode in STRICT_ONLY:
        assert verdicts[f"{mode} (not strict)"].ok


def test_lenient_messages_accept_a_refusal_without_the_key(verdicts):
    for mode in ("refusal-without-key", "wrong-key"):
        assert verdicts[f"{mode} (lenient)"].ok, [o.line() for o in verdicts[f"{mode} (lenient)"].outcomes]


@pytest.mark.parametrize("message, key, named", [
    ("error: case key 'mass': mass must be > 0, got 0", "mass", True),
    ("error: case key 'dt': refused", "mass", False),                  # declares another key
    ("error: case key 'dt': dt = 5 with mass 2 is past ...", "mass", False),   # the declared key decides
    ("mass must be > 0", "mass", True),                                # a bare key, as a whole word
    ("damping_k must be > 0", "damping", False),                       # not inside a longer name
    ("grad_v0 is not owed", "v0", False),
    ("", "mass", False),
    ("error: invalid case", None, True),                               # no key owed: any message
    ("", None, False),
])
def test_the_refusal_names_the_key(message, key, named):
    assert names_key(message, key) is named


def test_a_lenient_stability_rule_fails_on_random_cases_near_the_limit():
    """``--random`` draws cases just past the stability limit (draws.CHECK_ODDS): a rule that
    refuses only past 2.12 writes a result for some of them; each such verdict names the key."""
    report = chk.check(f"{sys.executable} {BROKEN} lenient-limit {{pairs}}", vectors=False, random=8, seed=0)
    failed = [o for o in report.outcomes if not o.ok]
    assert failed and all(o.case_id.startswith("random-0-") and o.kind == "invalid" and o.key in ("dt", "mobility")
                          and "a result written" in o.detail for o in failed), \
        [o.line() for o in report.outcomes]


def test_broken_programs_fail_on_random_cases_too():
    report = chk.check(f"{sys.executable} {BROKEN} perturb {{pairs}}", vectors=False, random=5)
    failed = [o for o in report.outcomes if not o.ok]
    assert len(failed) >= 4 and all(o.array == "energy" for o in failed)   # all-zero energy: unharmed


@pytest.fixture(scope="module")
def random_cases() -> list:
    """``check --random 30 --seed 3``'s cases, each with the reference's result."""
    return [(case, run_case(case)) for _, case, cond in chk.draw_cases(30, seed=3) if cond is not None]


@pytest.mark.parametrize("mode", sorted(V4_FAMILIES))
def test_the_broken_programs_of_v4_fail_on_random_cases_too(mode, random_cases):
    """``check --random 30 --seed 3`` reaches each case v4 added (draws.CHECK_ODDS): each
    program, run here in-process, refuses or gets wrong some of its cases, and only such."""
    broken = _broken_module()
    how = broken.MODES[mode][1]

    def run(case):
        with ExitStack() as stack:
            if "patch" in how:
                stack.enter_context(broken._patched(*how["patch"]))
            if "rule" in how:
                validate_case(case)
                how["rule"](case)
            return (broken._reference_run if how.get("run") == "reference" else run_case)(case)
    failed = []
    for case, want in random_cases:
        try:
            got = run(case)
        except CaseError as exc:
            failed.append(exc.key)
            continue
        errors = compare_results(got, want)
        if not all(passes(k, e) for k, e in errors.items()):
            failed.append("result")
    expect = {"float32-cell-index": "result", "single-wall-room-rule": "wall_margin", "bool-flags-only": "periodic"}
    assert failed and set(failed) == {expect[mode]}, failed


def test_the_random_draws_reach_the_rare_inputs_at_their_odds():
    """Over 400 draws of check's distribution: a wide margin on about half the scenes whose
    walls leave an axis with one wall, near-edge positions in about a quarter of the cases
    (where a coordinate is snapped, float32 misses the cell some of the time), flags as
    int8 or uint8 in about half, a step within 5% of the stability limit in about a fifth,
    inside and past it about evenly."""
    assert draws.CHECK_ODDS == {"wide_margin": 0.5, "near_edge": 0.25, "integer_flags": 0.5,
                                "near_limit": 0.2}                                     # docs/spec.md 13.1
    single = wide = near = float32_misses = 0
    dtypes, limits = [], []
    for attempt in range(400):
        d = draws.GeneratorDraws(np.random.default_rng([7, attempt]))
        scene, x0, v0 = draws.scene_case(d, max_particles=4, near_edge=draws.CHECK_ODDS["near_edge"],
                                         wide_margin=draws.CHECK_ODDS["wide_margin"])
        dtypes.append(draws.flag_dtype(d, draws.CHECK_ODDS["integer_flags"]).name)
        drawn = draws.near_limit(d, scene, draws.CHECK_ODDS["near_limit"])
        if drawn is not None:
            lim = stability.stability_limit(scene, "rule")
            limits.append((drawn[0], lim.ratio * drawn[1]))          # the rule's value over 2 once scaled
        s = scene.surface
        if scene.walls is not None:
            edges, L, w = np.asarray(scene.walls.edges), s.length, scene.walls.margin
            single += any(edges[a].sum() == 1 for a in range(2))
            wide += any(edges[a].sum() == 1 and 2 * w >= L[a] for a in range(2))
        u = (x0 - s.lower) / s.spacing
        off = np.abs(u - np.round(u))
        snapped = (off >= draws.NEAR_EDGE[0] * 0.99) & (off <= draws.NEAR_EDGE[1] * 1.01)
        near += bool(snapped.any())
        float32_misses += bool(np.any(np.floor(u.astype(np.float32)) != np.floor(u)))
    assert abs(wide / single - draws.CHECK_ODDS["wide_margin"]) < 0.12, (wide, single)
    assert abs(near / 400 - draws.CHECK_ODDS["near_edge"]) < 0.06 and float32_misses >= near / 3, near
    counts = {name: dtypes.count(name) / 400 for name in ("bool", "int8", "uint8")}
    odds = draws.CHECK_ODDS["integer_flags"]
    assert abs(counts["int8"] - odds / 2) < 0.06 and abs(counts["uint8"] - odds / 2) < 0.06, counts
    sides = [side for side, _ in limits]                    # (scenes of no stiffness or no step have none)
    assert 0.6 * draws.CHECK_ODDS["near_limit"] < len(limits) / 400 <= 1.2 * draws.CHECK_ODDS["near_limit"], limits
    assert abs(sides.count("past") / len(sides) - 0.5) < 0.2, sides
    assert all(lo <= r <= hi for side, r in limits for lo, hi in [draws.NEAR_LIMIT[side]])


def test_a_failing_case_is_kept_with_a_script_that_reproduces_it(tmp_path):
    keep = tmp_path / "keep"
    report = chk.check(f"{sys.executable} {BROKEN} perturb {{pairs}}", only=["plane-dynamic", "mass-zero"],
                       keep=keep)
    assert report.summary() == "1 passed, 2 failed"            # plane-dynamic, alone and in the mixed batch
    kept = keep / "plane-dynamic"
    assert sorted(p.name for p in keep.iterdir()) == ["plane-dynamic"]
    script = (kept / "reproduce.sh").read_text()
    assert script.splitlines()[-1].endswith("perturb case.npz result.npz")
    run = subprocess.run(["sh", str(kept / "reproduce.sh")], capture_output=True, text=True)
    assert run.returncode == 0 and (kept / "result.npz").is_file()


def test_a_hanging_program_is_reported_as_a_timeout():
    proc = _check("--cmd", f"{sys.executable} {BROKEN} hang {{case}} {{result}}", "--only", "plane-dynamic",
                  "--timeout", "2")
    assert proc.returncode == 1
    assert proc.stdout.splitlines()[0] == "FAIL  plane-dynamic  timed out after 2 s"


# =========================================================================== random cases

def test_random_cases_are_deterministic_and_well_conditioned():
    a = chk.draw_cases(12, seed=3)
    b = chk.draw_cases(12, seed=3)
    assert [x[0] for x in a] == [x[0] for x in b]
    for (_, ca, cond), (_, cb, _) in zip(a, b):
        assert cond <= chk.CONDITION_BOUND if cond is not None else chk.refusal_key(ca) in ("dt", "mobility")
        assert ca.keys() == cb.keys() and all(np.array_equal(ca[k], cb[k]) and ca[k].dtype == cb[k].dtype for k in ca)
    modes = {str(c["mode"]) for _, c, _ in chk.draw_cases(40, seed=1)}
    assert modes == {"dynamic", "quasistatic"}


def test_the_conditioning_filter_drops_an_ill_conditioned_case():
    with pytest.raises(RuntimeError, match="within the conditioning bound"):
        chk.draw_cases(3, seed=0, bound=0.5, max_draws=10)   # growth is >= 1 for every run


def test_random_cases_need_no_hypothesis():
    """``--random`` draws with NumPy: the checker runs on a plain install (no ``test`` extra)."""
    code = ("import sys; sys.modules['hypothesis'] = None\n"
            "from pes_ref.testing import check\n"
            "assert len(check.draw_cases(3, seed=0)) == 3")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr


# =========================================================================== arguments
# (bad arguments: the fault suite, tests/cli/test_faults_*.py)

def test_the_vectors_are_listed():
    proc = _check("--list")
    lines = proc.stdout.splitlines()
    assert proc.returncode == 0 and len(lines) == len(load_manifest()["vectors"])
    assert lines[0].startswith("plane-dynamic ") and any(line.split()[:3] == ["mass-zero", "invalid", "(mass)"]
                                                         for line in lines)
    listed = [line.split()[:3] for line in lines]            # id, kind, flags: v4's families among them
    for family, flag in (("wide-margin", "wide-margin"), ("integer-flags", "dtype"), ("near-edge", "near-edge")):
        rows = [row for row in listed if row[0].startswith(family + "-")]
        assert len(rows) >= 2 and all(row[1:] == ["valid", flag] for row in rows), family
