"""The oracle's command line pays only for what it uses: its imports, the parser it
builds, and results stored uncompressed unless ``--compress`` (the oracle's timing target
is measured by ``python -m pes_ref.bench.oracle_cli``, not here: timings are no test)."""
import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

import pes_ref
from pes_ref import cli
from pes_ref.bench.oracle_cli import funnel_case_keys
from pes_ref.oracle import case as oracle
from pes_ref.oracle.conformance import LATEST, generate, vectors_dir

ROOT = Path(pes_ref.__file__).resolve().parent.parent

#: Every module that ``python -m pes_ref oracle CASE RESULT`` may add to those of a bare
#: ``import numpy``, each for a reason: the command line (its parser: argparse, which
#: translates its messages by gettext and locale), the oracle's own modules, the core it
#: runs (its registries import every interpolation and stepper), the .npz files (zipfile
#: and the compressions it imports), the rule for a closed pipe and Ctrl-C (signal,
#: threading) and the start-up freeze (gc). A module not listed here fails the test
#: below: add it only with its reason.
ORACLE_IMPORTS = {
    "pes_ref", "pes_ref.cli", "pes_ref.cli.common", "pes_ref.cli.oracle",
    "pes_ref.cli.files",                    # a case file told from a design or a result file
    "pes_ref.oracle", "pes_ref.oracle.case", "pes_ref.oracle.monitor", "pes_ref.oracle.errors",
    "pes_ref.oracle.from_scene",            # re-exported by pes_ref.oracle
    "pes_ref.oracle.conformance",           # the shipped vectors' version, in the examples of --help
    "pes_ref.core", "pes_ref.core.bicubic", "pes_ref.core.bilinear", "pes_ref.core.budget", "pes_ref.core.checks",
    "pes_ref.core.effects", "pes_ref.core.forces", "pes_ref.core.gjf", "pes_ref.core.grid",
    "pes_ref.core.integrator", "pes_ref.core.interpolations", "pes_ref.core.objectives", "pes_ref.core.runtime.progress",
    "pes_ref.core.scene", "pes_ref.core.stability", "pes_ref.core.steppers", "pes_ref.core.surface",
    "pes_ref.core.terms", "pes_ref.core.runtime", "pes_ref.core.runtime.files", "pes_ref.core.runtime.signals",
    "pes_ref.core.runtime.npz",
    "pes_ref.core.backends",                # the registry of loops: finds numba, never imports it here
    "pes_ref.accel", "pes_ref.accel.halves",  # a large case's NumPy run, as two halves on two threads
    "pes_ref.core.runtime.pages", "mmap",   # a large run's arrays, mapped without huge-page stalls
    "argparse", "gettext", "locale", "_locale", "copy", "dataclasses",
    "zipfile", "shutil", "binascii", "zlib", "bz2", "_bz2", "lzma", "_lzma", "_compression",
    "encodings.ascii", "encodings.cp437",
    "gc", "signal", "threading",
}
#: Modules that may appear or not.
ORACLE_IMPORTS_OPTIONAL = set()

#: Prints the modules that ``python -m pes_ref oracle CASE RESULT`` adds to those of a
#: bare ``import numpy``, as JSON on stdout's last line (the command line's own output
#: comes first).
_PROBE = """
import json, runpy, sys
import numpy
before = set(sys.modules)
sys.argv = ["pes_ref"] + sys.argv[1:]
try:
    runpy.run_module("pes_ref", run_name="__main__")
except SystemExit as exc:
    status = exc.code
print(json.dumps({"status": status, "added": sorted(set(sys.modules) - before)}))
"""


def small_case(**changes) -> dict:
    case = dict(values=np.arange(35.0).reshape(5, 7) / 35, lower=np.zeros(2), upper=np.array([1.0, 1.5]),
                periodic=np.array([False, False]), dt=np.float64(0.05), n_steps=np.int64(6), mode="dynamic",
                mass=np.float64(1.0), damping=np.float64(0.1), x0=np.array([[0.3, 0.4], [0.6, 1.1]]),
                v0=np.array([[0.2, 0.0], [0.0, -0.3]]), objective="funnel", target=np.float64(0.5), when="final")
    case.update(changes)
    return case


def modules_added_by_oracle(*args) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-c", _PROBE, "oracle", *map(str, args)], capture_output=True,
                          text=True, env=env, timeout=60)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.splitlines()[-1])


def test_the_oracle_command_imports_nothing_it_does_not_use(tmp_path):
    oracle.save_case(tmp_path / "c.npz", **small_case())
    run = modules_added_by_oracle(tmp_path / "c.npz", tmp_path / "r.npz")
    assert run["status"] == 0 and (tmp_path / "r.npz").exists()
    added = set(run["added"])
    assert "pes_ref.oracle.case" in added and "pes_ref.cli.oracle" in added   # the probe does watch them
    assert sorted(added - ORACLE_IMPORTS - ORACLE_IMPORTS_OPTIONAL) == []


def test_building_every_command_imports_no_handler_dependency():
    """``python -m pes_ref --help`` builds every command's parser: each command imports
    what its handler needs inside the handler."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    code = "import json, sys, pes_ref.cli; pes_ref.cli.build_parser(); print(json.dumps(sorted(sys.modules)))"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=60)
    assert proc.returncode == 0, proc.stderr
    loaded = json.loads(proc.stdout)
    assert "pes_ref.cli.design" in loaded
    assert sorted(m for m in loaded if m.startswith(HANDLER_ONLY)) == []


#: Packages that only a command's handler imports, never its parser.
HANDLER_ONLY = ("pes_ref.synthesis", "pes_ref.devices", "pes_ref.bench", "pes_ref.testing",
                "pes_ref.oracle.conformance.generate", "pes_ref.oracle.conformance.families",
                "pes_ref.oracle.conformance.writer", "pes_ref.oracle.conformance.compare", "scipy", "matplotlib", "hypothesis")


def test_main_builds_only_the_command_it_runs(monkeypatch):
    built = []
    for name in cli.COMMANDS:
        module = cli.command_module(name)
        monkeypatch.setattr(module, "add_parser", lambda sub, f=module.add_parser, n=name: (built.append(n), f(sub)))
    assert cli.main(["oracle", "only-one.npz"]) == 2       # a usage error, after parsing
    assert built == ["oracle"]
    built.clear()
    assert cli.main(["--version"]) == 0
    assert built == list(cli.COMMANDS)


def test_a_program_run_freezes_its_start_up_and_a_call_does_not(monkeypatch, tmp_path, capsys):
    frozen = []
    monkeypatch.setattr(cli.gc, "freeze", lambda: frozen.append(True))
    missing = [str(tmp_path / "missing.npz"), str(tmp_path / "r.npz")]
    assert cli.main(["oracle", *missing]) == 2
    assert frozen == []
    monkeypatch.setattr(sys, "argv", ["pes_ref", "oracle", *missing])
    assert cli.main() == 2
    assert frozen == [True]
    capsys.readouterr()


def test_each_command_is_named_after_its_module():
    sub = next(a for a in cli.build_parser()._actions if a.dest == "command")
    assert list(sub.choices) == list(cli.COMMANDS)
    assert all(cli.command_module(name).__name__ == f"pes_ref.cli.{name}" for name in cli.COMMANDS)


@pytest.mark.parametrize("argv", [
    ["oracle", "a.npz", "b.npz", "--compress"],
    ["oracle", "a.npz", "--out-dir", "d", "--force"],
    ["check", "--cmd", "prog {case} {result}", "--random", "3", "--seed", "2"],
    ["conformance", "--check"],
    ["analyze", "ratchet", "--smoke"],
    ["design", "funnel", "--set", "n_steps=10", "--smoke"],
    ["evaluate", "d.npz"],
    ["bench", "--quick"],
])
def test_one_command_parser_parses_like_the_full_one(argv):
    assert cli.build_parser(argv[0]).parse_args(argv) == cli.build_parser().parse_args(argv)


def _compress_types(path) -> set:
    with zipfile.ZipFile(path) as zf:
        return {info.compress_type for info in zf.infolist()}


def test_results_are_stored_unless_compress(tmp_path, capsys):
    oracle.save_case(tmp_path / "c.npz", **small_case())
    assert cli.main(["oracle", str(tmp_path / "c.npz"), str(tmp_path / "stored.npz")]) == 0
    assert cli.main(["oracle", str(tmp_path / "c.npz"), str(tmp_path / "deflated.npz"), "--compress"]) == 0
    capsys.readouterr()
    assert _compress_types(tmp_path / "stored.npz") == {zipfile.ZIP_STORED}
    assert _compress_types(tmp_path / "deflated.npz") == {zipfile.ZIP_DEFLATED}
    stored, deflated = oracle.read_npz(tmp_path / "stored.npz"), oracle.read_npz(tmp_path / "deflated.npz")
    assert sorted(stored) == sorted(deflated)
    for key in stored:
        np.testing.assert_array_equal(stored[key], deflated[key], err_msg=key)


def test_write_result_stores_by_default(tmp_path):
    oracle.write_result(oracle.run_case(small_case()), tmp_path / "r.npz")
    assert _compress_types(tmp_path / "r.npz") == {zipfile.ZIP_STORED}


def test_the_shipped_vectors_stay_deflated():
    import json
    manifest = json.loads((vectors_dir(LATEST) / "manifest.json").read_text())
    broken = {e["case"] for e in manifest["vectors"] if "file" in e["flags"]}     # files that are no case archive
    files = [f for f in sorted(vectors_dir(LATEST).glob("*.npz")) if f.name not in broken]
    assert files and all(_compress_types(f) == {zipfile.ZIP_DEFLATED} for f in files)


def test_the_conformance_command_offers_the_version_the_generator_writes():
    assert LATEST == generate.VERSION


def test_the_funnel_timing_case_is_paper_sized():
    vc = oracle.validate_case(funnel_case_keys())
    assert vc.scene.surface.values.shape == (200, 200) and vc.x0.shape == (64, 2) and vc.scene.n_steps == 400
    assert vc.grad_names == ("values", "x0", "v0", "force", "mass", "damping")


def test_the_oracle_runs_numpy_and_never_imports_numba_unless_asked(tmp_path):
    """The compiled loops are the library's default when numba is installed, but the oracle
    runs NumPy's unless ``--backend numba`` (then it does import numba: the probe sees it)."""
    oracle.save_case(tmp_path / "c.npz", **small_case())
    plain = modules_added_by_oracle(tmp_path / "c.npz", tmp_path / "r.npz")
    assert plain["status"] == 0 and not [m for m in plain["added"] if m.split(".")[0] in ("numba", "llvmlite")]
    assert "pes_ref.accel.compiled" not in plain["added"]
    pytest.importorskip("numba")
    compiled = modules_added_by_oracle(tmp_path / "c.npz", tmp_path / "r2.npz", "--backend", "numba")
    assert compiled["status"] == 0 and "numba" in compiled["added"] and "pes_ref.accel.compiled" in compiled["added"]
    a, b = (oracle.read_npz(tmp_path / name) for name in ("r.npz", "r2.npz"))
    assert a["x"].tobytes() == b["x"].tobytes()


def test_the_oracle_checks_each_thing_once(tmp_path, monkeypatch, capsys):
    """In one oracle run, the result's destination, the memory and the stability rule are
    each checked once (the case's validation is the boundary; the engine trusts it)."""
    from pes_ref.cli import common, oracle as cli_oracle
    from pes_ref.core import budget, stability
    calls = []

    def counted(owner, name):
        f = getattr(owner, name)
        monkeypatch.setattr(owner, name, lambda *a, **k: calls.append(name) or f(*a, **k))
    counted(budget, "available_memory")
    counted(stability, "check_stable")
    counted(cli_oracle, "output_file")
    counted(common, "_writable_folder")
    oracle.save_case(tmp_path / "c.npz", **small_case())
    assert cli.main(["oracle", str(tmp_path / "c.npz"), str(tmp_path / "r.npz")]) == 0
    assert sorted(calls) == ["_writable_folder", "available_memory", "check_stable", "output_file"]
    capsys.readouterr()
