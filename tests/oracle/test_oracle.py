"""The oracle's case/result interchange format (SPEC section 6) and its command line."""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from _helpers import without_progress

import pes_ref
from pes_ref import cli
from pes_ref.core import checks
from pes_ref.core.runtime import pages
from pes_ref.core.scene import gradient_names
from pes_ref.oracle import case as oracle
from pes_ref.oracle.conformance import LATEST, vectors_dir
from pes_ref.testing.conformance import load_manifest

ROOT = Path(pes_ref.__file__).resolve().parent.parent
VECTORS = vectors_dir(LATEST)
MANIFEST = load_manifest(LATEST)["vectors"]
VALID = [e for e in MANIFEST if e["kind"] == "valid"]
INVALID = [e for e in MANIFEST if e["kind"] == "invalid"]
STRING_KEYS = ("mode", "objective", "when")


def _ids(entries):
    return [e["id"] for e in entries]


def _case(entry) -> dict:
    return oracle.load_case(VECTORS / entry["case"])


def base_case(**changes) -> dict:
    """A small valid dynamic case (plane, 2 particles, 6 steps) with ``changes`` applied."""
    rng = np.random.default_rng(5)
    case = dict(values=rng.normal(size=(5, 7)), lower=np.zeros(2), upper=np.array([1.0, 1.5]),
                periodic=np.array([False, False]), dt=np.float64(0.05), n_steps=np.int64(6), mode="dynamic",
                mass=np.float64(1.0), damping=np.float64(0.1), x0=np.array([[0.3, 0.4], [0.6, 1.1]]),
                v0=np.array([[0.2, 0.0], [0.0, -0.3]]), objective="funnel", target=np.float64(0.5), when="final")
    case.update(changes)
    return {k: v for k, v in case.items() if v is not None}


def run_cli(*args, cwd=None):
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "pes_ref", *map(str, args)], capture_output=True, text=True,
                          env=env, cwd=cwd, timeout=60)


def assert_same_result(got: dict, want: dict):
    assert sorted(got) == sorted(want)
    for k in want:
        assert got[k].dtype == np.float64 and got[k].shape == want[k].shape, k
        np.testing.assert_array_equal(got[k], want[k], err_msg=k)


# =========================================================================== valid cases

@pytest.mark.parametrize("entry", VALID, ids=_ids(VALID))
def test_round_trip_through_files(entry, tmp_path):
    """Every kind of case: file -> run_case_file -> result file equals run_case in memory."""
    case_path = tmp_path / "case.npz"
    oracle.save_case(case_path, **_case(entry))
    written = oracle.run_case_file(case_path, tmp_path / "result.npz")
    read_back = oracle.read_npz(tmp_path / "result.npz", what="result")
    assert_same_result(read_back, written)
    assert sorted(os.listdir(tmp_path)) == ["case.npz", "result.npz"]   # no temporary file left


@pytest.mark.parametrize("entry", VALID, ids=_ids(VALID))
def test_result_keys_and_shapes(entry):
    case = _case(entry)
    result = oracle.run_case(case)
    T, N = int(case["n_steps"]), case["x0"].shape[0]
    mode = str(case["mode"])
    grads = gradient_names(mode, "spring_k" in case)
    assert tuple(result) == oracle.result_keys(grads)
    assert result["x"].shape == result["v"].shape == (T + 1, N, 2)
    assert result["energy"].shape == (T + 1, N) and result["loss"].shape == ()
    assert result["grad_force"].shape == (T + 1, N, 2)       # always: the schedule is an input of every case
    for name in grads:
        if name != "force":
            assert result["grad_" + name].shape == np.shape(case[name]), name
    if mode == "quasistatic":
        assert not {"grad_v0", "grad_mass", "grad_damping"} & set(result)
        assert np.all(result["v"] == 0) and np.all(result["grad_force"][T] == 0)
    else:
        assert "grad_mobility" not in result


CASES = VALID + [e for e in INVALID if "file" not in e["flags"]]     # (a "file" vector is no case)


@pytest.mark.parametrize("backend", ["numpy", "numba"])
def test_a_large_runs_arrays_are_returned_as_made(backend):
    """A run's arrays of pages.THRESHOLD bytes or more are maps of their own (no huge-page
    stalls: pes_ref.core.runtime.pages), returned as they are, not copied."""
    n, T = 2048, 300
    x0 = np.random.default_rng(3).uniform([0.2, 0.2], [0.8, 1.3], (n, 2))
    got = oracle.run_case(base_case(x0=x0, v0=np.zeros((n, 2)), n_steps=np.int64(T)), backend=backend)
    for key in ("x", "v", "energy", "grad_force"):
        assert got[key].nbytes >= pages.THRESHOLD and isinstance(got[key].base, pages.Pages), key
        assert pages.owns(got[key]) and got[key].flags.writeable, key


@pytest.mark.parametrize("entry", CASES, ids=_ids(CASES))
def test_shipped_strings_are_0d_unicode(entry):
    case = _case(entry)
    for key in STRING_KEYS:
        if key in case and entry.get("key") not in STRING_KEYS:
            assert case[key].dtype.kind == "U" and case[key].ndim == 0, key


def test_save_case_writes_strings_as_0d_unicode(tmp_path):
    oracle.save_case(tmp_path / "c.npz", **base_case())
    raw = np.load(tmp_path / "c.npz", allow_pickle=False)
    for key in STRING_KEYS:
        assert raw[key].dtype.kind == "U" and raw[key].shape == (), key
        assert str(raw[key]) == base_case()[key]


def test_python_strings_and_0d_arrays_are_the_same_case():
    case = base_case()
    arrays = {k: np.asarray(v) for k, v in case.items()}
    assert_same_result(oracle.run_case(arrays), oracle.run_case(case))


def test_optional_keys_take_their_defaults():
    implicit = oracle.run_case(base_case())
    explicit = oracle.run_case(base_case(force=np.zeros((7, 2, 2)), t0=np.float64(0.0),
                                         regularization=np.float64(0.0)))
    assert_same_result(explicit, implicit)


def test_regularization_adds_R_sum_G2():
    case = base_case(regularization=np.float64(0.3))
    plain, reg = oracle.run_case(base_case()), oracle.run_case(case)
    np.testing.assert_allclose(reg["loss"], plain["loss"] + 0.3 * np.sum(case["values"] ** 2), rtol=1e-14)
    np.testing.assert_allclose(reg["grad_values"], plain["grad_values"] + 0.6 * case["values"], rtol=1e-14, atol=1e-15)


def test_run_case_accepts_a_path(tmp_path):
    oracle.save_case(tmp_path / "c.npz", **base_case())
    assert_same_result(oracle.run_case(tmp_path / "c.npz"), oracle.run_case(base_case()))


def test_validate_case_unpacks():
    scene, x0, v0, objective, reg, force, grads = oracle.validate_case(base_case())
    assert isinstance(scene, pes_ref.Scene) and isinstance(objective, pes_ref.Funnel)
    assert force.shape == (7, 2, 2) and reg == 0.0 and grads == ("values", "x0", "v0", "force", "mass", "damping")


@pytest.mark.parametrize("layout", ["float64", "float32", "strided"])
def test_the_force_is_read_only_and_checked_finite_to_its_last_entry(layout, monkeypatch):
    """A float64 C-contiguous force is read through a read-only view of the case's own array
    (no copy), any other converted; the same result, the case untouched, and a non-finite
    entry anywhere (past the first chunk of the check) refused naming force."""
    monkeypatch.setattr(oracle, "FINITE_CHUNK", 8)
    force = np.random.default_rng(2).normal(size=(7, 2, 2)) * 0.1
    given = {"float64": force.copy(), "float32": force.astype(np.float32),
             "strided": np.repeat(force, 2, axis=2)[:, :, ::2]}[layout]
    before = given.copy()
    vc = oracle.validate_case(base_case(force=given))
    assert not vc.force.flags.writeable and np.shares_memory(vc.force, given) == (layout == "float64")
    assert_same_result(oracle.run_case(base_case(force=given)), oracle.run_case(base_case(force=given.astype(float))))
    assert np.array_equal(given, before)
    bad = given.copy()
    bad[-1, -1, -1] = np.nan
    with pytest.raises(oracle.CaseError) as err:
        oracle.run_case(base_case(force=bad))
    assert err.value.key == "force" and "finite" in str(err.value)


def test_integer_inputs_are_promoted():
    ints = base_case(lower=np.array([0, 0]), upper=np.array([1, 2]), mass=np.int64(2), n_steps=np.int32(6))
    floats = base_case(lower=np.array([0.0, 0.0]), upper=np.array([1.0, 2.0]), mass=np.float64(2.0))
    assert_same_result(oracle.run_case(ints), oracle.run_case(floats))


# =========================================================================== invalid cases

def _assert_case_error(exc: oracle.CaseError, key, error: str):
    """``key`` None: a file that is not an .npz, refused without a key."""
    assert exc.key == key
    assert str(exc).startswith(f"case key {key!r}: ") == (key is not None)
    assert "\n" not in str(exc)
    assert isinstance(exc, ValueError)
    assert isinstance(exc, TypeError) == (error == "TypeError")


@pytest.mark.parametrize("entry", INVALID, ids=_ids(INVALID))
def test_invalid_vector_raises_one_case_error_naming_the_key(entry, tmp_path):
    with pytest.raises(oracle.CaseError) as info:
        oracle.run_case_file(VECTORS / entry["case"], tmp_path / "result.npz")
    _assert_case_error(info.value, entry["key"], entry["error"])
    assert not os.listdir(tmp_path)   # a broken case writes nothing


@pytest.mark.parametrize("entry", INVALID, ids=_ids(INVALID))
def test_cli_refuses_invalid_vector_with_one_line(entry, tmp_path, capsys):
    status = cli.main(["oracle", str(VECTORS / entry["case"]), str(tmp_path / "result.npz")])
    out, err = capsys.readouterr()
    assert status == 2 and out == ""
    assert err.endswith("\n") and err.count("\n") == 1
    assert err.startswith(f"error: case key {entry['key']!r}: " if entry["key"] is not None else "error: case file ")
    assert not os.listdir(tmp_path)


# Rules beyond the shipped vectors: in-memory cases and broken files.
EXTRA_INVALID = {
    "values-3d": (dict(values=np.zeros((2, 2, 2))), "values", "ValueError"),
    "lower-nan": (dict(lower=np.array([np.nan, 0.0])), "lower", "ValueError"),
    "t0-inf": (dict(t0=np.float64(np.inf)), "t0", "ValueError"),
    "t0-array": (dict(t0=np.zeros(2)), "t0", "ValueError"),
    "n_steps-bool": (dict(n_steps=np.bool_(True)), "n_steps", "TypeError"),
    "n_steps-array": (dict(n_steps=np.array([3])), "n_steps", "ValueError"),
    "mode-python-int": (dict(mode=3), "mode", "TypeError"),
    "when-every": (dict(when="every"), "when", "ValueError"),
    "walls-float": (dict(wall_k=np.float64(1.0), wall_margin=np.float64(0.0), walls=np.ones((2, 2))),
                    "walls", "TypeError"),
    "mobility-nan-quasistatic": (dict(mode="quasistatic", mobility=np.array([np.nan, 1.0])), "mobility", "ValueError"),
    "amplitude-for-funnel": (dict(amplitude=np.float64(1.0)), "amplitude", "ValueError"),
    "wx-for-oscillator": (dict(objective="oscillator", target=None, when=None, amplitude=np.float64(1.0),
                               omega=np.float64(1.0), wx=np.float64(1.0)), "wx", "ValueError"),
    "quadratic-wv-string": (dict(objective="quadratic", target=None, when=None, wx=1.0, wv="a", xref=0.0, vref=0.0),
                            "wv", "TypeError"),
    "spring-center-4d": (dict(spring_k=np.float64(1.0), spring_center=np.zeros((1, 1, 1, 2))),
                         "spring_center", "ValueError"),
    "ragged-x0": (dict(x0=[[0.1, 0.2], [0.3]]), "x0", "TypeError"),
    "object-x0": (dict(x0=np.array([[0.1, None], [0.2, 0.3]], dtype=object)), "x0", "TypeError"),
    "unstable-dt": (dict(dt=np.float64(50.0), n_steps=np.int64(40), spring_k=np.float64(100.0),
                         spring_center=np.zeros(2)), "dt", "ValueError"),
    "unstable-mobility": (dict(mode="quasistatic", mobility=np.array([30.0, 30.0]), n_steps=np.int64(150),
                               spring_k=np.float64(100.0), spring_center=np.zeros(2)), "mobility", "ValueError"),
    "non-string-key": ({1: np.float64(1.0)}, "1", "TypeError"),
}


@pytest.mark.parametrize("name", sorted(EXTRA_INVALID))
def test_more_invalid_cases_name_their_key(name):
    changes, key, error = EXTRA_INVALID[name]
    case = base_case()
    case.update(changes)
    case = {k: v for k, v in case.items() if v is not None}
    with pytest.raises(oracle.CaseError) as info:
        oracle.run_case(case)
    _assert_case_error(info.value, key, error)


@pytest.mark.parametrize("core_error, key, error", [
    (checks.InputError("upper", "the domain is empty"), "upper", "ValueError"),
    (checks.InputTypeError("walls", "not a bool array"), "walls", "TypeError"),
    (checks.InputError("surface", "a message that names no key at all"), "values", "ValueError"),
])
def test_core_errors_name_the_case_key_by_their_key_not_their_message(core_error, key, error, monkeypatch):
    """The key comes from the core's keyed error (``exc.key``, translated by
    CORE_NAME_TO_CASE_KEY), never from its message."""
    def refuse(*args, **kwargs):
        raise core_error
    monkeypatch.setattr(oracle, "Surface", refuse)
    with pytest.raises(oracle.CaseError) as info:
        oracle.validate_case(base_case())
    _assert_case_error(info.value, key, error)
    assert info.value.reason == str(core_error)


def test_case_errors_are_keyed_input_errors():
    assert issubclass(oracle.CaseError, checks.InputError)
    assert issubclass(oracle.CaseTypeError, checks.InputTypeError)
    assert set(oracle.CORE_NAME_TO_CASE_KEY.values()) <= set(oracle.CASE_KEYS)
    assert not set(oracle.CORE_NAME_TO_CASE_KEY) & set(oracle.CASE_KEYS)


def test_a_case_must_be_a_mapping():
    with pytest.raises(oracle.CaseError, match="mapping"):
        oracle.validate_case([("values", 1)])


def test_object_array_in_a_file_is_refused_without_pickle(tmp_path):
    case = base_case()
    case["x0"] = np.array([[0.1, None], [0.2, 0.3]], dtype=object)
    np.savez(tmp_path / "c.npz", **case)    # np.savez pickles object arrays
    with pytest.raises(oracle.CaseTypeError) as info:
        oracle.load_case(tmp_path / "c.npz")
    assert info.value.key == "x0" and "pickle" in str(info.value)


@pytest.mark.parametrize("content", [b"not a zip file", b"", b"values = [1, 2]\nmode = dynamic\n"],
                         ids=["garbage", "empty", "plain-text"])
def test_a_file_that_is_not_npz_is_refused(tmp_path, content):
    """Said as it is, without numpy's advice to load pickled data (untrue, and unsafe)."""
    (tmp_path / "c.npz").write_bytes(content)
    with pytest.raises(oracle.CaseError, match="is not an .npz archive") as info:
        oracle.load_case(tmp_path / "c.npz")
    assert info.value.key is None
    assert "pickle" not in str(info.value)


def test_a_damaged_npz_is_said_to_be_damaged(tmp_path):
    oracle.save_case(tmp_path / "c.npz", **base_case())
    whole = (tmp_path / "c.npz").read_bytes()
    (tmp_path / "c.npz").write_bytes(whole[: len(whole) // 2])
    with pytest.raises(oracle.CaseError, match="damaged .npz archive") as info:
        oracle.load_case(tmp_path / "c.npz")
    assert "pickle" not in str(info.value)


def test_an_npy_file_is_refused(tmp_path):
    np.save(tmp_path / "c.npy", np.zeros(3))
    with pytest.raises(oracle.CaseError, match="single .npy array"):
        oracle.load_case(tmp_path / "c.npy")


def test_a_missing_case_file_is_an_os_error(tmp_path):
    with pytest.raises(FileNotFoundError):
        oracle.run_case_file(tmp_path / "nope.npz", tmp_path / "r.npz")
    assert not os.listdir(tmp_path)


def test_cli_missing_case_file_one_line(tmp_path, capsys):
    assert cli.main(["oracle", str(tmp_path / "nope.npz"), str(tmp_path / "r.npz")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1 and "nope.npz" in err


# =========================================================================== writing results

def test_cli_missing_result_folder_one_line(tmp_path, capsys):
    oracle.save_case(tmp_path / "c.npz", **base_case())
    assert cli.main(["oracle", str(tmp_path / "c.npz"), str(tmp_path / "no" / "r.npz")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "does not exist" in err and str(tmp_path / "no") in err
    assert sorted(os.listdir(tmp_path)) == ["c.npz"]


def test_existing_result_is_not_overwritten(tmp_path):
    oracle.save_case(tmp_path / "c.npz", **base_case())
    (tmp_path / "r.npz").write_bytes(b"precious")
    with pytest.raises(oracle.ResultExistsError) as info:
        oracle.run_case_file(tmp_path / "c.npz", tmp_path / "r.npz")
    assert isinstance(info.value, FileExistsError) and str(tmp_path / "r.npz") in str(info.value)
    assert (tmp_path / "r.npz").read_bytes() == b"precious"
    with pytest.raises(oracle.ResultExistsError):
        oracle.write_result(oracle.run_case(base_case()), tmp_path / "r.npz")
    assert (tmp_path / "r.npz").read_bytes() == b"precious"
    assert sorted(os.listdir(tmp_path)) == ["c.npz", "r.npz"]


def test_overwrite_replaces_the_result(tmp_path):
    oracle.save_case(tmp_path / "c.npz", **base_case())
    (tmp_path / "r.npz").write_bytes(b"old")
    result = oracle.run_case_file(tmp_path / "c.npz", tmp_path / "r.npz", overwrite=True)
    assert_same_result(oracle.read_npz(tmp_path / "r.npz"), result)


def test_the_case_file_is_never_the_result(tmp_path):
    oracle.save_case(tmp_path / "c.npz", **base_case())
    before = (tmp_path / "c.npz").read_bytes()
    with pytest.raises(ValueError, match="case file itself"):
        oracle.run_case_file(tmp_path / "c.npz", tmp_path / "c.npz", overwrite=True)
    assert (tmp_path / "c.npz").read_bytes() == before


def test_written_files_are_reproducible(tmp_path):
    result = oracle.run_case(base_case())
    oracle.write_result(result, tmp_path / "a.npz")
    oracle.write_result(result, tmp_path / "b.npz")
    assert (tmp_path / "a.npz").read_bytes() == (tmp_path / "b.npz").read_bytes()


def test_write_npz_refuses_object_arrays(tmp_path):
    with pytest.raises(TypeError, match="pickle"):
        oracle.write_npz(tmp_path / "a.npz", {"a": np.array([None])})
    assert not os.listdir(tmp_path)


def test_cli_force_flag(tmp_path, capsys):
    oracle.save_case(tmp_path / "c.npz", **base_case())
    (tmp_path / "r.npz").write_bytes(b"old")
    assert cli.main(["oracle", str(tmp_path / "c.npz"), str(tmp_path / "r.npz")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "exists already" in err
    assert (tmp_path / "r.npz").read_bytes() == b"old"
    assert cli.main(["oracle", str(tmp_path / "c.npz"), str(tmp_path / "r.npz"), "--force"]) == 0
    assert_same_result(oracle.read_npz(tmp_path / "r.npz"), oracle.run_case(base_case()))


# =========================================================================== the command line, for real

SUBPROCESS_VALID = ["plane-dynamic", "spring-per-particle-torus", "steps-0-quasistatic"]
SUBPROCESS_INVALID = ["mass-zero", "unknown-key", "n-steps-float"]


@pytest.mark.parametrize("vid", SUBPROCESS_VALID)
def test_cli_subprocess_round_trip(vid, tmp_path):
    entry = next(e for e in VALID if e["id"] == vid)
    proc = run_cli("oracle", VECTORS / entry["case"], tmp_path / "r.npz")
    assert proc.returncode == 0, proc.stderr
    assert without_progress(proc.stderr) == "" and proc.stdout.startswith(f"wrote {tmp_path / 'r.npz'}")
    assert_same_result(oracle.read_npz(tmp_path / "r.npz"), oracle.run_case(_case(entry)))


@pytest.mark.parametrize("vid", SUBPROCESS_INVALID)
def test_cli_subprocess_refuses(vid, tmp_path):
    entry = next(e for e in INVALID if e["id"] == vid)
    proc = run_cli("oracle", VECTORS / entry["case"], tmp_path / "r.npz")
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.startswith(f"error: case key {entry['key']!r}: ") and proc.stderr.count("\n") == 1
    assert "Traceback" not in proc.stderr
    assert not os.listdir(tmp_path)


def test_cli_help_for_each_command(capsys):
    for argv in (["--help"], ["oracle", "--help"], ["conformance", "--help"]):
        assert cli.main(argv) == 0
    out = capsys.readouterr().out
    assert "oracle" in out and "--force" in out and "--write" in out and "--check" in out


def test_cli_usage_errors_exit_2(capsys):
    assert cli.main([]) == 2
    assert cli.main(["oracle", "only-one.npz"]) == 2
    assert cli.main(["conformance"]) == 2            # --write or --check is required
    assert cli.main(["conformance", "--write", "--check"]) == 2
    capsys.readouterr()


def test_python_dash_m_help():
    proc = run_cli("--help")
    assert proc.returncode == 0 and "oracle" in proc.stdout and "conformance" in proc.stdout


def test_save_case_refuses_to_overwrite_like_write_result(tmp_path):
    (tmp_path / "c.npz").write_bytes(b"precious")
    with pytest.raises(oracle.ResultExistsError, match="case file"):
        oracle.save_case(tmp_path / "c.npz", **base_case())
    assert (tmp_path / "c.npz").read_bytes() == b"precious"
    oracle.save_case(tmp_path / "c.npz", overwrite=True, **base_case())
    assert sorted(oracle.load_case(tmp_path / "c.npz")) == sorted(base_case())
