"""The shipped conformance vectors and the checker that other implementations use."""
import configparser
import fnmatch
import hashlib
import importlib.util
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

import pes_ref
from pes_ref import cli
from pes_ref.oracle import case as oracle
from pes_ref.oracle.conformance import LATEST, generate, vectors_dir
from pes_ref.testing import conformance as conf
from pes_ref.oracle.tolerances import GRAD_RTOL, TRAJ_RTOL

VECTORS = vectors_dir(LATEST)
MANIFEST = conf.load_manifest(LATEST)
ENTRIES = MANIFEST["vectors"]
VALID = [e for e in ENTRIES if e["kind"] == "valid"]
INVALID = [e for e in ENTRIES if e["kind"] == "invalid"]
VALID_IDS = [e["id"] for e in VALID]
ALL_IDS = [e["id"] for e in ENTRIES]


_RUNS = {}


def run_cached(case) -> dict:
    """``oracle.run_case`` remembered per case content: the checker tests below run the
    same vectors through many (mutated) implementations."""
    key = tuple((k, v.dtype.str, v.shape, v.tobytes()) for k, v in sorted((k, np.asarray(v)) for k, v in case.items()))
    if key not in _RUNS:
        _RUNS[key] = oracle.run_case(case)
    return {k: v.copy() for k, v in _RUNS[key].items()}


@pytest.fixture(scope="module")
def regenerated(tmp_path_factory):
    """The vectors generated afresh by ``pes_ref conformance --write DIR`` (once per module),
    into a folder that holds an older vector set (its manifest and a stale vector file) and
    a file that is not a vector. (A folder with files but no manifest is refused: the
    fault suite, tests/cli/test_faults_*.py.)"""
    folder = tmp_path_factory.mktemp("v1")
    (folder / "manifest.json").write_text("{}\n")
    (folder / "stale.case.npz").write_bytes(b"old")
    (folder / "keep.txt").write_text("not a vector")
    assert cli.main(["conformance", "--write", str(folder), "--quiet"]) == 0
    return folder


def _load(folder: Path, name: str) -> dict:
    return oracle.read_npz(folder / name)


# =========================================================================== the shipped set

@pytest.mark.parametrize("entry", VALID, ids=VALID_IDS)
def test_shipped_result_matches_the_engine(entry):
    got = oracle.run_case(oracle.load_case(VECTORS / entry["case"]))
    want = _load(VECTORS, entry["result"])
    assert sorted(got) == sorted(want)
    errors = conf.compare_results(got, want)
    assert all(conf.passes(k, e) for k, e in errors.items()), errors


def _files(entry: dict) -> list:
    """Every file of a vector: its case, and its result and other one-sided results."""
    return [entry["case"]] + ([entry["result"]] if "result" in entry else []) + entry.get("one_sided", [])


@pytest.mark.parametrize("vid", ALL_IDS)
def test_regenerating_gives_identical_arrays(vid, regenerated):
    entry = next(e for e in ENTRIES if e["id"] == vid)
    if conf.is_file_vector(entry):          # a file that is no case: the same bytes
        assert (regenerated / entry["case"]).read_bytes() == (VECTORS / entry["case"]).read_bytes()
        return
    for name in _files(entry):
        fresh, shipped = _load(regenerated, name), _load(VECTORS, name)
        assert sorted(fresh) == sorted(shipped), name
        for key in shipped:
            assert fresh[key].dtype == shipped[key].dtype and fresh[key].shape == shipped[key].shape, (name, key)
            assert np.array_equal(fresh[key], shipped[key], equal_nan=shipped[key].dtype.kind == "f"), (name, key)


def test_regenerated_manifest_is_identical(regenerated):
    assert json.loads((regenerated / "manifest.json").read_text()) == MANIFEST
    assert (regenerated / "manifest.json").read_bytes() == (VECTORS / "manifest.json").read_bytes()
    names = sorted(p.name for p in regenerated.iterdir())
    assert names == sorted([p.name for p in VECTORS.iterdir()] + ["keep.txt"])   # stale vector removed


def test_manifest_lists_exactly_the_files():
    listed = {"manifest.json"} | {name for e in ENTRIES for name in _files(e)}
    assert {p.name for p in VECTORS.iterdir()} == listed
    assert len(ALL_IDS) == len(set(ALL_IDS))
    assert [e["tc_id"] for e in ENTRIES] == list(range(1, len(ENTRIES) + 1))
    for e in INVALID:
        assert e["key"] in oracle.CASE_KEYS or e["key"] == "gravity" or (e["key"] is None and conf.is_file_vector(e))
        assert e["error"] in ("ValueError", "TypeError") and "result" not in e
    for e in VALID:
        assert ("one_sided" in e) == ("kink" in e["flags"])      # from v3 on every kink vector binds its gradients
    assert MANIFEST["version"] == LATEST == generate.VERSION == "v5"
    assert MANIFEST["tolerances"]["TRAJ_RTOL"] == TRAJ_RTOL and MANIFEST["tolerances"]["GRAD_RTOL"] == GRAD_RTOL


#: The newest set's size budget, in bytes. A set holds every vector of the one before it
#: (v4: 0.86 MB), so the budget grows with the sets: v5, with 68 vectors more, is 1.18 MB.
SET_BYTES = 1_250_000


def test_the_set_is_small_and_shipped_as_package_data():
    files = list(VECTORS.iterdir())
    assert sum(p.stat().st_size for p in files) < SET_BYTES
    cfg = configparser.ConfigParser()
    cfg.read(Path(pes_ref.__file__).resolve().parent.parent / "setup.cfg")
    patterns = [p.strip() for p in cfg["options.package_data"]["pes_ref"].split(",")]
    for p in files:
        rel = p.relative_to(Path(pes_ref.__file__).resolve().parent).as_posix()
        assert any(fnmatch.fnmatch(rel, pat) for pat in patterns), rel


def _features(case: dict) -> set:
    periodic = tuple(bool(p) for p in case["periodic"])
    topo = {(False, False): "plane", (True, False): "cylinder-q0", (False, True): "cylinder-q1",
            (True, True): "torus"}[periodic]
    f = {topo, str(case["mode"]), str(case["objective"]), f"{topo}-{case['mode']}"}
    if "when" in case:
        f.add("funnel-" + str(case["when"]))
    if "spring_k" in case:
        f.add("spring")
    if "walls" in case:
        f |= {f"wall-{d}-{e}" for d in range(2) for e in range(2) if case["walls"][d, e]}
    if "force" in case:
        f.add("force")
    if float(case.get("regularization", 0.0)) > 0:
        f.add("regularization")
    if np.ndim(case["mass"]) == 2:
        f.add("mass-per-particle")
    if np.shape(case["damping"]) == (2,):
        f.add("damping-per-axis")
    if np.all(case["damping"] == 0):
        f.add("damping-zero")
    f.add(f"T={int(case['n_steps'])}")
    if case["values"].shape == (2, 2):
        f.add("grid-2x2")
    return f


def test_coverage_of_the_valid_set():
    seen = set()
    for _, case, _ in conf.iter_vectors(LATEST):
        seen |= _features(case)
    need = {f"{t}-{m}" for t in ("plane", "cylinder-q0", "cylinder-q1", "torus") for m in ("dynamic", "quasistatic")}
    need |= {"funnel-final", "funnel-every_step", "oscillator", "quadratic", "spring", "force", "regularization",
             "mass-per-particle", "damping-per-axis", "damping-zero", "T=0", "T=1", "grid-2x2"}
    need |= {f"wall-{d}-{e}" for d in range(2) for e in range(2)}
    assert need <= seen, need - seen
    flags = {f for e in VALID for f in e["flags"]}
    assert "kink" in flags


def test_invalid_set_covers_every_rule():
    ids = {e["id"] for e in INVALID}
    for rule in ("values-1d", "x0-nan", "dt-inf", "mass-zero", "mass-negative", "dt-zero", "dt-negative",
                 "damping-negative", "wall-on-periodic-axis", "unknown-key", "unknown-objective", "unknown-mode",
                 "missing-values", "missing-mobility"):
        assert rule in ids


# =========================================================================== the checker against the oracle

def test_checker_passes_the_reference_oracle():
    n = len(VALID)
    assert len(conf.check_simulate(run_cached)) == n
    reports = conf.check_gradients(run_cached, strict_kinks=True)
    assert len(reports) == n and all(r.ok for r in reports)
    reports = conf.check_invalid(lambda p: oracle.validate_case(oracle.load_case(p)), strict_types=True)
    run_only = [e for e in INVALID if "nonfinite" in e["flags"]]        # refused only when run (12.1)
    assert run_only and len(reports) == len(ENTRIES) - len(run_only) and all(r.ok for r in reports)
    for e in run_only:
        case = oracle.load_case(VECTORS / e["case"])
        oracle.validate_case(case)
        left = "the (run|trajectory) left the (finite numbers|range of the grid lookup)"     # 12.1
        with pytest.raises(oracle.CaseError, match=f"case key '{e['key']}': {left}"):
            oracle.run_case(case)


def test_checker_reads_a_regenerated_folder(regenerated):
    assert len(conf.check_simulate(run_cached, directory=regenerated)) == len(VALID)


def _fingerprint(case) -> bytes:
    return case["values"].tobytes() + case["x0"].tobytes()


KINKED = [e for e in VALID if "kink" in e["flags"]]
#: The one-sided gradients a kink vector accepts besides its result's, by fingerprint.
OTHER_SIDES = {_fingerprint(case): conf.one_sided_results(e) for e, case, _ in conf.iter_vectors(LATEST)
               if "kink" in e["flags"]}


def _at_kinks(change):
    """The reference, with the gradients of the kink vectors replaced by ``change(result, others)``."""
    def fn(case):
        result = run_cached(case)
        others = OTHER_SIDES.get(_fingerprint(case))
        if others is not None:
            result.update(change(result, others))
        return result
    return fn


def test_kink_gradients_bind_to_their_one_sided_values():
    """On a kink, each gradient entry may take any one-sided value the manifest lists
    (the wall's onset: inactive or active), and no other; strict mode takes the
    reference's own only."""
    assert {e["id"] for e in KINKED if e["one_sided"]} == {"wall-onset-dynamic", "wall-onset-cylinder-q1-quasistatic"}
    other_side = _at_kinks(lambda result, others: others[0] if others else {})
    assert len(conf.check_gradients(other_side)) == len(VALID)
    with pytest.raises(AssertionError, match="wall-onset-dynamic"):
        conf.check_gradients(other_side, strict_kinks=True)

    def halfway(result, others):       # the mean of the two one-sided values: neither of them
        return {k: 0.5 * (result[k] + others[0][k]) for k in others[0]} if others else {}
    with pytest.raises(AssertionError, match="2 of .* fail"):
        conf.check_gradients(_at_kinks(halfway))
    negated = _at_kinks(lambda result, others: {k: -v for k, v in result.items() if k.startswith("grad_")})
    with pytest.raises(AssertionError, match=f"{len(KINKED)} of .* fail"):
        conf.check_gradients(negated)


def test_kinks_of_v2_do_not_bind_gradients():
    """v2's kink vectors list no one-sided values: there only x, v, energy and loss bind."""
    kinked = {e["id"] for e in conf.load_manifest("v2")["vectors"] if "kink" in e["flags"]}
    prints = {_fingerprint(case) for e, case, _ in conf.iter_vectors("v2") if e["id"] in kinked}

    def wrong_at_kinks(case):
        result = run_cached(case)
        if _fingerprint(case) in prints:
            for k in result:
                if k.startswith("grad_"):
                    result[k] = -result[k]
        return result
    reports = conf.check_gradients(wrong_at_kinks, "v2")
    assert {r.id for r in reports if "kink" in r.note} == kinked
    with pytest.raises(AssertionError):
        conf.check_gradients(wrong_at_kinks, "v2", strict_kinks=True)


def _perturbed(name, how):
    def fn(case):
        result = run_cached(case)
        result[name] = how(result[name], case)
        return result
    return fn


def _dt_off(case):
    case = dict(case)
    case["dt"] = np.float64(float(case["dt"]) * (1 + 1e-9))
    return run_cached(case)


SIMULATE_MUTANTS = {
    "x-relative-1e-10": _perturbed("x", lambda x, c: x * (1 + 1e-10)),
    "v-shifted": _perturbed("v", lambda v, c: v + 1e-9),
    "energy-without-kinetic": _perturbed("energy", lambda e, c: e - 1e-6),
    "x-wrong-shape": _perturbed("x", lambda x, c: x[:-1]),
    "x-nan": _perturbed("x", lambda x, c: np.where(np.arange(x.size).reshape(x.shape) == 0, np.nan, x)),
    "dt-off-by-1e-9": _dt_off,
    "missing-energy": lambda case: {k: v for k, v in run_cached(case).items() if k != "energy"},
    "raises": lambda case: 1 / 0,
}


@pytest.mark.parametrize("name", sorted(SIMULATE_MUTANTS))
def test_check_simulate_catches_a_wrong_implementation(name):
    with pytest.raises(AssertionError, match="check_simulate"):
        conf.check_simulate(SIMULATE_MUTANTS[name])


def _drop(key):
    return lambda case: {k: v for k, v in run_cached(case).items() if k != key}


def _quasistatic_v0_grad(case):
    result = run_cached(case)
    if str(case["mode"]) == "quasistatic":
        result["grad_v0"] = np.ones_like(case["v0"], dtype=float)
    return result


GRADIENT_MUTANTS = {
    "values-scaled-1e-7": _perturbed("grad_values", lambda g, c: g * (1 + 1e-7)),
    "force-transposed-in-time": _perturbed("grad_force", lambda g, c: g[::-1]),
    "mass-sign": _perturbed("grad_mass", lambda g, c: -g),
    "loss-off": _perturbed("loss", lambda g, c: g * (1 + 1e-10)),
    "missing-grad-x0": _drop("grad_x0"),
    "quasistatic-nonzero-grad-v0": _quasistatic_v0_grad,
    "dt-off-by-1e-9": _dt_off,
}


@pytest.mark.parametrize("name", sorted(GRADIENT_MUTANTS))
def test_check_gradients_catches_a_wrong_implementation(name):
    with pytest.raises(AssertionError, match="check_gradients"):
        conf.check_gradients(GRADIENT_MUTANTS[name])


def test_quasistatic_zero_extras_are_accepted():
    def with_zeros(case):
        result = run_cached(case)
        if str(case["mode"]) == "quasistatic":
            for k in ("v0", "mass", "damping"):
                result["grad_" + k] = np.zeros(np.shape(case[k]))
        return result
    conf.check_gradients(with_zeros)


def _oracle_load(path):
    return oracle.validate_case(oracle.load_case(path))


def _silent_load(path):
    try:
        _oracle_load(path)
    except oracle.CaseError as exc:
        raise ValueError("bad case") from exc   # refuses, but does not name the key


def _accept_everything(path):
    return dict(np.load(path, allow_pickle=False))


def _refuse_everything(path):
    raise ValueError("case key 'values': nope " + " ".join(oracle.CASE_KEYS) + " gravity")


def _wrong_exception(path):
    try:
        _oracle_load(path)
    except oracle.CaseError as exc:
        raise KeyError(str(exc)) from exc


def _types_swapped(path):
    try:
        _oracle_load(path)
    except oracle.CaseError as exc:
        raise (ValueError if isinstance(exc, TypeError) else TypeError)(str(exc)) from exc


LOADER_MUTANTS = {
    "accepts-everything": (_accept_everything, {}),
    "refuses-everything": (_refuse_everything, {}),
    "message-without-key": (_silent_load, {}),
    "raises-key-error": (_wrong_exception, {}),
    "error-types-swapped": (_types_swapped, {"strict_types": True}),
}


@pytest.mark.parametrize("name", sorted(LOADER_MUTANTS))
def test_check_invalid_catches_a_wrong_loader(name):
    fn, kw = LOADER_MUTANTS[name]
    with pytest.raises(AssertionError, match="check_invalid"):
        conf.check_invalid(fn, **kw)


def test_swapped_types_pass_unless_strict():
    conf.check_invalid(_types_swapped)


# =========================================================================== compare_results

def test_compare_results_normalized_error():
    want = {"x": np.array([1.0, 0.0]), "grad_values": np.array([2.0, 0.0])}
    got = {"x": np.array([1.0 + 2e-12, 1e-12]), "grad_values": np.array([2.0, 1e-9])}
    errors = conf.compare_results(got, want)
    assert errors["x"] == pytest.approx(1e-12, rel=1e-3)         # 2e-12 / (1 + 1)
    assert errors["grad_values"] == pytest.approx(5e-10, rel=1e-3)  # 1e-9 / (2 + 0)
    assert conf.passes("x", errors["x"]) and conf.passes("grad_values", errors["grad_values"])
    assert conf.compare_results({}, want) == {"x": np.inf, "grad_values": np.inf}
    assert conf.compare_results({"x": np.zeros(3)}, {"x": np.zeros(2)}) == {"x": np.inf}
    assert conf.compare_results({"grad_v0": np.full(2, 1e-12)}, {"grad_v0": np.zeros(2)})["grad_v0"] <= GRAD_RTOL


# =========================================================================== the command line

def test_cli_conformance_check_passes(capsys):
    assert cli.main(["conformance", "--check"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert len(out) == len(ENTRIES) + 1 and all(line.startswith("ok") for line in out[:-1])
    assert "max rel err" in out[0] and out[-1].startswith("conformance check ok")


def test_cli_conformance_check_fails_on_a_changed_vector(tmp_path, capsys, monkeypatch):
    shipped = tmp_path / LATEST
    shutil.copytree(VECTORS, shipped)
    result = oracle.read_npz(shipped / "plane-dynamic.result.npz")
    result["grad_values"] = result["grad_values"] * (1 + 1e-6)
    oracle.write_result(result, shipped / "plane-dynamic.result.npz", overwrite=True)
    (shipped / "torus-long.case.npz").unlink()
    # the comparison is under test here, not the generator: "regenerate" by copying
    monkeypatch.setattr(generate, "write_vectors", lambda d, **kw: shutil.copytree(VECTORS, d, dirs_exist_ok=True))
    assert cli.main(["conformance", "--check", str(shipped), "--quiet"]) == 1
    out = capsys.readouterr().out
    assert "FAIL  plane-dynamic" in out and "grad_values" in out and "FAIL  torus-long" in out
    assert "FAILED: 2 of" in out
    assert cli.main(["conformance", "--check", str(tmp_path / "nowhere")]) == 2
    assert capsys.readouterr().err.startswith("error: ")


# =========================================================================== v1 to v4, frozen

#: The sha256 of each frozen set's files (name and bytes, in name order). A frozen set
#: never changes: a new version is a new folder.
FROZEN = {"v1": "f40a3b79b4f55d59995ef03fb99494bdd6596e88423451901815c15a6d152e52",
          "v2": "453e832da6d6c2c11e97406691958a603e0e157f4f9689c6a532ead1dd353c51",
          "v3": "105caf716c63c858089e0d11ca5d08523ed301f0ae2da5f47397dd55680bd3a1",
          "v4": "c688a2d6cdbf05851ba1cceeb77e2b2afda2b1be9d2cab89c8c53a2e2d767be1"}


def _digest(version: str) -> str:
    h = hashlib.sha256()
    for path in sorted(vectors_dir(version).iterdir()):
        h.update(path.name.encode() + b"\0" + path.read_bytes())
    return h.hexdigest()


@pytest.mark.parametrize("version", sorted(FROZEN))
def test_a_frozen_set_stays_byte_for_byte(version):
    assert _digest(version) == FROZEN[version]


@pytest.mark.parametrize("older", ["v2", "v3", "v4"])
def test_the_newest_set_holds_every_vector_of_the_older_ones_unchanged(older):
    """Every case, result and one-sided file of v2, v3 and v4 is in the newest set byte for
    byte (from v3 on with its manifest entry, but for its number), in the same order."""
    entries = conf.load_manifest(older)["vectors"]
    for e in entries:
        for name in _files(e):
            assert (VECTORS / name).read_bytes() == (vectors_dir(older) / name).read_bytes(), name
    if older != "v2":
        newest = {e["id"]: e for e in ENTRIES}
        for e in entries:
            assert dict(newest[e["id"]], tc_id=None) == dict(e, tc_id=None), e["id"]
    ids = [e["id"] for e in entries]
    assert [vid for vid in ALL_IDS if vid in set(ids)] == ids

def test_v1_stays_shipped_and_readable_as_it_was():
    """v1 is frozen: still shipped, readable, its manifest unchanged (its old generator
    name and spec pointer), its 114 vectors; every valid one still matches the engine,
    except that spec v2 refuses the one past the stability rule, which runs with the
    opt-out and matches too."""
    v1 = conf.load_manifest("v1")
    assert v1["version"] == "v1" and v1["generator"] == "pes_ref.conformance.generate"
    assert v1["spec"].startswith("SPEC.md") and len(v1["vectors"]) == 114
    past = []
    for entry, case, want in conf.iter_vectors("v1"):
        try:
            got = oracle.run_case(case)
        except oracle.CaseError as exc:
            assert exc.key == "mobility", exc
            past.append(entry["id"])
            got = oracle.run_case(case, allow_unstable=True)
        errors = conf.compare_results(got, want)
        assert all(conf.passes(k, e) for k, e in errors.items()), (entry["id"], errors)
    assert past == ["far-outside-spring-quasistatic"]


def _case(vid: str) -> dict:
    return oracle.load_case(VECTORS / f"{vid}.case.npz")


def _spacing(case: dict) -> np.ndarray:
    n = np.array(case["values"].shape, dtype=float)
    return (case["upper"] - case["lower"]) / np.where(case["periodic"], n, n - 1)


def test_v3_sits_on_each_point_the_spec_fixes():
    """v3's states sit exactly on a wall's onset, the closed edge of each non-periodic
    axis, the spring's seam, and the oscillator's root at 0 mid-run; its spacings
    include ones whose -1/h float32 does not hold; its refusals cover docs/spec.md 8.1,
    12.1 and a non-integral n_steps."""
    c = _case("wall-onset-dynamic")
    onsets = np.stack((c["lower"] + c["wall_margin"], c["upper"] - c["wall_margin"]))
    assert [c["x0"][i, d] == onsets[side, d] for i, (d, side) in enumerate([(0, 0), (0, 1), (1, 0), (1, 1)])] == [True] * 4
    c = _case("grid-edge-plane")
    u = (c["x0"] - c["lower"]) / _spacing(c)
    n1 = np.array(c["values"].shape) - 1
    assert {(d, float(u[i, d])) for i, d in enumerate([0, 0, 1, 1])} == {(0, 0.0), (0, n1[0]), (1, 0.0), (1, n1[1])}
    c = _case("spring-seam-cylinder-q0")
    L = c["upper"][0] - c["lower"][0]
    assert np.all(np.mod(c["x0"][:, 0] - c["spring_center"][0] + 0.5 * L, L) == 0.0)
    c = _case("oscillator-zero-root-mid-run")
    result = oracle.run_case(c)
    t = c["t0"] + c["dt"] * np.arange(int(c["n_steps"]) + 1)
    S = (result["x"][:, 0, 0] - c["amplitude"] * np.cos(c["omega"] * t)) ** 2 + (c["amplitude"] * c["omega"] * np.sin(c["omega"] * t)) ** 2
    assert S[5] == 0.0 and np.all(S[np.arange(len(S)) != 5] > 0)
    for vid in ("spacing-inexact-plane", "spacing-inexact-torus-quasistatic", "spacing-inexact-cylinder-q0"):
        h = _spacing(_case(vid))
        assert np.any(np.float32(-1.0 / h) != -1.0 / h), vid      # on one axis at least
    by_id = {e["id"]: e for e in ENTRIES}
    for vid in ("object-array", "member-not-array", "not-npz", "single-npy", "truncated-zip"):
        assert by_id[vid]["flags"] == ["file"] and by_id[vid]["kind"] == "invalid"
    assert by_id["n-steps-float-fraction"]["key"] == "n_steps" and _case("n-steps-float-fraction")["n_steps"] == 10.5
    assert [e["id"] for e in INVALID if "nonfinite" in e["flags"]] == ["overflow-dynamic", "overflow-quasistatic"]
    assert sum("t0" in case and case["t0"] != 0 for _, case, _ in conf.iter_vectors(LATEST)) >= 6


def _u(case: dict) -> np.ndarray:
    """Each particle's ``u = (q - lower) / h`` (docs/spec.md 2.3), (N, 2)."""
    return (case["x0"] - case["lower"]) / _spacing(case)


def test_v4_holds_the_cases_the_spec_accepts_and_v3_lacked():
    """v4's three families: a single wall of an axis with wall_margin >= L/2 in both modes;
    periodic and walls as int8 and uint8 0/1 arrays; particles 1e-9 below and above
    interior cell edges on a plane, cylinders and a torus, where a float32 u picks
    another cell. Each is valid, so the reference runs it."""
    family = {name: [e for e in VALID if e["id"].startswith(name + "-")]
              for name in ("wide-margin", "integer-flags", "near-edge")}
    wide_modes = set()
    for e in family["wide-margin"]:
        c = _case(e["id"])
        L, w = c["upper"] - c["lower"], float(c["wall_margin"])
        single = [d for d in range(2) if c["walls"][d].sum() == 1 and 2 * w >= L[d]]
        assert single and e["flags"] == ["wide-margin"], e["id"]
        assert all(2 * w < L[d] for d in range(2) if c["walls"][d].all())
        wide_modes.add(str(c["mode"]))
    assert wide_modes == {"dynamic", "quasistatic"}
    dtypes = set()
    for e in family["integer-flags"]:
        c = _case(e["id"])
        assert c["periodic"].dtype == c["walls"].dtype and c["periodic"].dtype.kind in "iu", e["id"]
        assert {0, 1} <= set(c["periodic"].tolist()) and {0, 1} <= set(c["walls"].ravel().tolist())
        dtypes.add(c["periodic"].dtype.name)
    assert dtypes == {"int8", "uint8"}
    topologies, sides = set(), set()
    for e in family["near-edge"]:
        c = _case(e["id"])
        u = _u(c)
        near = np.abs(u - np.round(u)) < 1e-8
        n = np.array(c["values"].shape)
        interior = c["periodic"] | ((np.round(u) > 0) & (np.round(u) < n - 1))
        assert np.all(near.any(axis=1)) and np.all(interior[near]) and e["flags"] == ["near-edge"], e["id"]
        assert np.any(np.floor(u.astype(np.float32)) != np.floor(u)), e["id"]     # float32 picks another cell
        sides |= {("below", d) for d in range(2) if np.any(near[:, d] & (u[:, d] < np.round(u[:, d])))}
        sides |= {("above", d) for d in range(2) if np.any(near[:, d] & (u[:, d] > np.round(u[:, d])))}
        topologies.add(tuple(bool(p) for p in c["periodic"]))
    assert topologies == {(False, False), (True, False), (False, True), (True, True)}
    assert sides == {(side, d) for side in ("below", "above") for d in range(2)}
    assert MANIFEST["flags"]["wide-margin"] and MANIFEST["flags"]["near-edge"]


def test_v2_pins_the_stability_rule():
    """v2 refuses a case past the rule for each term (key dt) and in quasistatic mode (key
    mobility), accepts cases at 0.9 of the limit, and a case of no step past it."""
    by_id = {e["id"]: e for e in ENTRIES}
    for vid, key in (("unstable-spring", "dt"), ("unstable-wall", "dt"), ("unstable-grid", "dt"),
                     ("unstable-quasistatic", "mobility")):
        assert by_id[vid]["kind"] == "invalid" and by_id[vid]["key"] == key
        case = oracle.load_case(VECTORS / by_id[vid]["case"])
        with pytest.raises(oracle.CaseError) as info:
            oracle.validate_case(case)
        assert info.value.key == key and "stability limit" in str(info.value)
        oracle.validate_case(case, allow_unstable=True)
    for vid in ("near-limit-spring-dynamic", "near-limit-grid-quasistatic", "steps-0-past-limit",
                "far-outside-spring-quasistatic"):
        assert by_id[vid]["kind"] == "valid"
    assert MANIFEST["spec"].startswith("docs/spec.md")
    assert MANIFEST["generator"] == "pes_ref.oracle.conformance.generate"


# =========================================================================== v5: each rule from both sides

def _broken_programs():
    """tests/testing/check_programs/broken.py, whose :func:`rule_value` states the stability
    rule on its own, and under each misreading."""
    path = Path(__file__).resolve().parents[1] / "testing" / "check_programs" / "broken.py"
    spec = importlib.util.spec_from_file_location("broken_programs", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_rule_value = _broken_programs().rule_value


#: The misreadings of the stability rule that the ``limit-*`` vectors of v5 tell apart:
#: name -> the options of :func:`_rule_value`, or "at-2" (a value of exactly 2 refused).
MISREADINGS = {
    "own particle's mass": dict(mass="own"), "largest mass": dict(mass="max"),
    "other axis's mass": dict(mass="other-axis"), "smallest mass of both axes": dict(mass="all"),
    "wall a term of every axis": dict(wall="every-axis"), "wall a term only with both walls": dict(wall="both"),
    "no cells across the seam": dict(seam=False), "terms summed": dict(summed=True),
    "second differences a term": dict(edges=True), "largest mobility": dict(mobility="max"),
    "other axis's mobility": dict(mobility="other-axis"), "exactly 2 refused": "at-2",
}
#: Each ``limit-*`` vector and the misreadings it catches (the misreading lands on the wrong
#: side of 2): the closing note of v5.
CATCHES = {
    "limit-spring-axis-q1-inside": {"other axis's mass", "smallest mass of both axes"},
    "limit-wall-one-upper-q1-inside": {"other axis's mass", "smallest mass of both axes", "wall a term of every axis"},
    "limit-grid-seam-dynamic-inside": {"second differences a term"},
    "limit-grid-seam-quasistatic-inside": {"second differences a term"},
    "limit-mobility-axis-q1-inside": {"largest mobility", "other axis's mobility"},
    "limit-mobility-axis-q0-inside": {"terms summed", "second differences a term"},
    "limit-terms-one-at-a-time": {"terms summed", "second differences a term"},
    "limit-edges-not-a-term": {"second differences a term"},
    "limit-exact-dynamic": {"exactly 2 refused", "terms summed", "second differences a term"},
    "limit-exact-quasistatic": {"exactly 2 refused", "terms summed", "second differences a term"},
    "limit-spring-particle-past": {"own particle's mass", "largest mass"},
    "limit-spring-axis-q0-past": {"other axis's mass"},
    "limit-wall-one-lower-q0-past": {"other axis's mass", "wall a term only with both walls"},
    "limit-wall-one-upper-q1-past": {"wall a term only with both walls"},
    "limit-grid-seam-dynamic-past": {"no cells across the seam"},
    "limit-grid-seam-quasistatic-past": {"no cells across the seam"},
    "limit-mobility-axis-q0-past": {"other axis's mobility"},
}


def _refused_under(case: dict, how) -> bool:
    if how == "at-2":
        return _rule_value(case) >= 2.0
    return _rule_value(case, **how) > 2.0


@pytest.mark.parametrize("entry", [e for e in ENTRIES if e["id"].startswith("limit-")],
                         ids=[e["id"] for e in ENTRIES if e["id"].startswith("limit-")])
def test_v5_limit_vectors_sit_where_they_say_and_catch_their_misreadings(entry):
    """A ``limit-*`` vector's rule value is 1.98 (valid), 2.02 (refused) or exactly 2 (valid),
    by this test's own statement of the rule and by the oracle; and each misreading listed
    in :data:`CATCHES` for it, and no other, decides it the other way."""
    case = _case(entry["id"])
    value = _rule_value(case)
    assert entry["flags"] == ["limit"] and int(case["n_steps"]) > 0
    expect = {"valid": (1.98, 2.0), "invalid": (2.02,)}[entry["kind"]]
    assert any(abs(value - v) < 1e-12 for v in expect), value
    assert (entry["kind"] == "invalid") == (value > 2.0)
    if entry["kind"] == "invalid":
        assert entry["key"] == ("mobility" if str(case["mode"]) == "quasistatic" else "dt")
    caught = {name for name, how in MISREADINGS.items() if _refused_under(case, how) != (value > 2.0)}
    assert caught == CATCHES.get(entry["id"], set()), sorted(caught)


def test_v5_every_misreading_is_caught_by_a_limit_vector():
    assert set().union(*CATCHES.values()) == set(MISREADINGS)
    assert set(CATCHES) <= set(ALL_IDS)


def test_v5_holds_every_optional_key_invalid_and_the_edges_of_ranges():
    """Each optional key NaN, infinite, of a wrong shape and of a wrong type (as applies),
    and the valid edges of the ranges, each valid edge run by the reference."""
    optional = {"t0", "regularization", "force", "spring_k", "spring_center", "wall_k", "wall_margin", "walls",
                "mobility"}
    by_key = {}
    for e in INVALID:
        if e["id"].startswith("optional-"):
            by_key.setdefault(e["key"], set()).add(e["id"].split("-")[-1])
    assert optional <= set(by_key), sorted(optional - set(by_key))
    for key in ("t0", "regularization", "spring_k", "wall_k", "mobility"):
        assert {"nan", "inf", "string"} <= by_key[key], (key, by_key[key])
    edges = [e for e in VALID if e["id"].startswith("edge-")]
    assert len(edges) >= 8 and all(e["flags"] == ["edge"] for e in edges)
    c = _case("edge-spring-k-zero-axis")
    assert c["spring_k"][0] == 0.0
    result = oracle.run_case(c)
    assert result["grad_spring_k"][0] != 0.0            # a stiffness of 0 still has a gradient
    c = _case("edge-room-just-inside")
    assert 2 * c["wall_margin"] < c["upper"][0] - c["lower"][0] and 2 * np.nextafter(c["wall_margin"], 1) >= 1.0
