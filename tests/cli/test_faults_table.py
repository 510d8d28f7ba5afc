"""The command line's fault tables as a whole, and the faults that are not one command's row.

Every command's rows are in ``tests/cli/test_faults_<command>.py`` (the harness:
``tests/_faults.py``); here: their ids are unique and every command has rows, a missing input
is said the same way by every command, late refusals of a long case, :data:`WARNINGS` (runs
that succeed but whose figures mean something else than they say: one ``warning:`` line),
:data:`CLOSED_PIPES` (every command with its output going into a pipe its reader has closed:
the one rule of :func:`pes_ref.cli.common.watch_pipes`) and :data:`INTERRUPTED_IMPORTS` (Ctrl-C
while the command line is still being imported).
"""
from __future__ import annotations

import importlib
import os
import re
import shutil
import stat
import subprocess
import sys

import numpy as np
import pytest

from _helpers import without_progress
from _faults import (CASE, ENV, UNPRIVILEGED, Fault, Outcome, Piped, Warned, _bench_whole_or_absent, _design,
                     _parts_whole_or_absent, _result_whole, _sweep_whole_or_absent, _vectors_whole_or_absent, changes,
                     check_fault, run_piped, run_python_m, run_rows, snapshot)

from pes_ref import cli
from pes_ref.oracle import load_case

#: Every command's table (``tests/cli/test_faults_<name>.py``).
TABLES = ("oracle", "check", "conformance", "analyze", "design", "evaluate", "realize", "bench", "sweep", "top")
FAULTS = [row for name in TABLES for row in importlib.import_module(f"test_faults_{name}").FAULTS]

#: The commands the tables must cover: every one of the command line (tested below).
COVERED = {f.argv.split()[0] for f in FAULTS if f.argv} | {"analyze ratchet", "analyze dartgun", "analyze DEVICE.toml"}


def test_the_ids_are_unique():
    assert len({f.id for f in FAULTS}) == len(FAULTS)


def test_every_command_is_covered():
    commands = set(cli.COMMANDS)
    devices = {f"analyze {a.split()[1]}" for a in (f.argv for f in FAULTS) if a.startswith("analyze ")
               and len(a.split()) > 1}
    assert commands <= COVERED
    assert {"analyze ratchet", "analyze dartgun"} <= devices
    assert any(d.endswith(".toml") for d in devices)


_REFUSED = Fault("a-row", "analyze dev.toml --drive 0 --load 1 --start 0.45,0", ("--start 0.45,0", "blocked"))
_PROGRESS = "dev.toml: distance | percent 100/100 | 33 percent/s | elapsed 0:03 | left 0:00\n"
_ERROR = "error: --start 0.45,0 is inside blocked space: the parts' interiors overlap there\n"


@pytest.mark.parametrize("err, passes", [
    (_ERROR, True),
    (_PROGRESS + _ERROR, True),                                  # what a slow machine prints: the same verdict
    (_PROGRESS + _PROGRESS + _ERROR, True),
    ("note: something else\n" + _ERROR, False),                 # any other line still fails the row
    (_ERROR + _ERROR, False),
    (_PROGRESS, False),
], ids=["alone", "after-progress", "after-two", "after-another-line", "twice", "progress-only"])
def test_a_row_compares_the_error_line_and_not_the_progress_before_it(err, passes):
    """No row's verdict depends on the machine's speed: a progress line, which a command prints
    only once it has run for seconds, is left out of what a row compares (docs/testing.md)."""
    got = Outcome(cli.EXIT_ERROR, "", err, {}, {})
    if passes:
        check_fault(_REFUSED, got)
    else:
        with pytest.raises(AssertionError):
            check_fault(_REFUSED, got)


def test_a_blocked_start_is_refused_before_the_c_space_s_distance_is_computed(fault_assets, tmp_path, capsys,
                                                                               monkeypatch):
    """The refusal needs only the blocked nodes: the boundary and the distance, which take
    seconds on a loaded machine, are never computed for it."""
    from pes_ref.devices.cspace import CSpaceGrid

    def never(*args, **kwargs):
        raise AssertionError("the C-space's distance was computed for a refused start")
    monkeypatch.setattr(CSpaceGrid, "compute", never)
    code = cli.main(["analyze", str(fault_assets / "dev.toml"), "--drive", "0", "--load", "1", "--start", "0.45,0"])
    out, err = capsys.readouterr()
    assert code == cli.EXIT_ERROR and out == "" and err.startswith("error: --start 0.45,0") and "blocked" in err, err


def test_the_assets_are_what_the_rows_say(fault_assets):
    """The rows rely on these: a valid case, a design, a result, an invalid case keyed 'mass'."""
    from pes_ref.synthesis import load_design
    assert load_design(fault_assets / "design.npz").kind == "funnel" and load_design(fault_assets / "design.npz").seed == 0
    assert sorted(load_case(fault_assets / "case.npz")) == sorted(load_case(CASE))
    assert "x" in np.load(fault_assets / "result.npz")


# =========================================================================== late refusals (a long case)

@pytest.fixture(scope="module")
def long_case(tmp_path_factory):
    """A case that computes for several seconds (2048 particles, 3000 steps)."""
    case = load_case(CASE)
    rng = np.random.default_rng(0)
    n, lower, upper = 2048, case["lower"], case["upper"]
    case.update(x0=lower + (upper - lower) * rng.uniform(0.2, 0.8, size=(n, 2)), v0=np.zeros((n, 2)),
                n_steps=np.int64(3000))
    path = tmp_path_factory.mktemp("long") / "long.case.npz"
    from pes_ref.oracle import save_case
    save_case(path, **case)
    return path


def _refused_at_once(long_case, result, capsys, monkeypatch):
    """Run ``oracle LONG RESULT`` in this process; return its stderr, watching that the case
    is never run (the watch, not a clock: no verdict depends on the machine's speed)."""
    from pes_ref.oracle import case as oracle_case
    runs = []
    run = oracle_case.run_case
    monkeypatch.setattr(oracle_case, "run_case", lambda *a, **k: runs.append(1) or run(*a, **k))
    code = cli.main(["oracle", str(long_case), str(result)])
    err = capsys.readouterr().err
    assert code == cli.EXIT_ERROR and not runs, err
    return err


@pytest.mark.parametrize("where", ["nodir/r.npz", "file.txt/r.npz"], ids=["no-folder", "under-a-file"])
def test_a_destination_that_cannot_be_written_is_refused_before_computing(where, long_case, tmp_path, capsys,
                                                                          monkeypatch):
    (tmp_path / "file.txt").write_text("a file")
    before = snapshot(tmp_path)
    err = _refused_at_once(long_case, tmp_path / where, capsys, monkeypatch)
    assert err.startswith("error: cannot write ") and err.count("\n") == 1
    assert ".tmp" not in err and "/." not in err               # no temporary file's name
    assert snapshot(tmp_path) == before


#: Runs the command line on its arguments and prints, last, how often the oracle ran a case.
_WATCH_RUNS = """
import sys
from pes_ref.oracle import case
runs = []
run = case.run_case
case.run_case = lambda *a, **k: runs.append(1) or run(*a, **k)
from pes_ref.cli import main
code = main(sys.argv[1:])
print(len(runs))
sys.exit(code)
"""


def test_a_read_only_folder_is_refused_before_computing(long_case, tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    os.chmod(ro, stat.S_IRUSR | stat.S_IXUSR)
    try:
        proc = subprocess.run([*UNPRIVILEGED, sys.executable, "-c", _WATCH_RUNS, "oracle", str(long_case),
                               str(ro / "r.npz")], capture_output=True, text=True, env=ENV, timeout=120)
    finally:
        os.chmod(ro, stat.S_IRWXU)
    assert proc.returncode == cli.EXIT_ERROR and proc.stdout.split() == ["0"], proc.stderr
    assert proc.stderr.count("\n") == 1 and "not writable" in proc.stderr
    assert ".tmp" not in proc.stderr and not os.listdir(ro)


def test_the_long_case_is_long(long_case):
    """What makes the two tests above mean something: the case takes seconds to run."""
    assert int(load_case(long_case)["n_steps"]) * load_case(long_case)["x0"].shape[0] >= 6_000_000


#: The rows where a file or folder to read is missing: every command says it in the same words.
MISSING = ["oracle-missing-case", "evaluate-missing", "design-resume-missing", "check-missing-program",
           "conformance-check-missing"]


def test_a_missing_input_is_said_the_same_way_by_every_command(fault_assets, tmp_path_factory):
    rows = [f for f in FAULTS if f.id in MISSING]
    outcomes = run_rows(rows, fault_assets, tmp_path_factory.mktemp("missing"))
    for fid in MISSING:
        line = outcomes[fid].err.strip()
        assert re.fullmatch(r"error: (case file|design file|--cmd: program|--check folder) "
                            r"(nothing\.npz|\./nothing\.sh|nodir) does not exist", line), (fid, line)


# =========================================================================== the harness

#: Rows of every kind the harness meets: a refusal at parsing, one after reading a file, one
#: of an option's value, one that prints a warning and exits 0, a run that writes a file, and
#: a refusal in a command that runs another program.
LIKE_PYTHON_M = ["ratchet-torque-negative", "device-format-other", "design-particles-zero", "evaluate-missing",
                 "oracle-design-file", "check-unknown-program"]


def _untimed(out: str) -> str:
    """``out`` without the times it reports (``time_cspace: 0.37 s``, a design's ``..., 0.5 s``)."""
    return re.sub(r"(?m)[\d.]+ s$", "T s", re.sub(r"(?m)^time_\w+: .*\n", "", out))


def test_a_forked_row_is_what_python_m_pes_ref_gives(fault_assets, tmp_path_factory):
    """The forked process of a row (``tests/_forked.py``) gives what ``python -m pes_ref`` gives:
    the exit status, stdout, stderr and the files left behind, warning rows included."""
    rows = [f for f in FAULTS if f.id in LIKE_PYTHON_M] + WARNINGS[:1] + [
        Warned("design-writes", "design funnel --smoke --quiet --out new.npz", ())]
    forked = run_rows(rows, fault_assets, tmp_path_factory.mktemp("forked"))
    python_m = run_rows(rows, fault_assets, tmp_path_factory.mktemp("python-m"), run=run_python_m)
    assert len(rows) == len(LIKE_PYTHON_M) + 2
    for row in rows:
        a, b = forked[row.id], python_m[row.id]
        assert (a.status, _untimed(a.out), a.err) == (b.status, _untimed(b.out), b.err), row.id
        assert sorted(a.after) == sorted(b.after), row.id
    assert {forked[r].status for r in LIKE_PYTHON_M} == {cli.EXIT_ERROR}
    assert forked["design-writes"].status == 0 and "new.npz" in forked["design-writes"].after


# =========================================================================== warnings

WARNINGS = [
    Warned("ratchet-torque-overwhelms-the-barrier", "analyze ratchet --smoke --torque 1e6",
           ("warning: the torque 1e+06 torque-unit exceeds", "barrier_torque_max", "overwhelms the barrier")),
    Warned("dartgun-reload-does-not-latch", "analyze dartgun --smoke --reload-force 1e12",
           ("warning: the reload with force 1e+12 did not latch", "reference latch")),
    Warned("device-channel-below-the-grid", "analyze dev-narrow.toml --drive 1 --load 0.5",
           ("warning: dev-narrow.toml: [cspace] shape = [21, 41] cannot resolve a free channel", "half-width 0.05",
            "raise [cspace] shape to at least")),
    Warned("device-channel-below-the-grid-shape", "analyze dev-narrow.toml --drive 1 --load 0.5 --shape 25,41",
           ("warning: dev-narrow.toml: --shape 25,41 cannot resolve a free channel", "raise --shape to at least")),
    Warned("device-barrier-wider-than-the-clearance", "analyze dev-slot.toml --drive 1 --load 0.5 --shape 81,41",
           ("warning: dev-slot.toml: [energy] r_c = 0.1 is wider than the clearance", "half-width 0.029",
            "set [energy] r_c below 0.042", "widen the clearance to 0.07 or more")),
    Warned("device-dynamic-free-play", "analyze geneva4.toml --drive 0 --load 1 --mode dynamic",
           ("warning: geneva4.toml: the output q1 dwells in 0.119 rad of free play between its contacts",
            "held by no spring", "rigid parts coast across such play", "--engine rigid (or both)",
            "docs/rigid.md")),
]


@pytest.fixture(scope="module")
def warned(fault_assets, tmp_path_factory):
    return run_rows(WARNINGS, fault_assets, tmp_path_factory.mktemp("warnings"), workers=2)


@pytest.mark.parametrize("row", WARNINGS, ids=[w.id for w in WARNINGS])
def test_warning(row, warned):
    got = warned[row.id]
    assert got.status == cli.EXIT_OK and "Traceback" not in got.err, got.err
    err = without_progress(got.err)
    assert err.startswith("warning: ") and err.count("\n") == 1, got.err
    for token in row.tokens:
        assert token in err, f"{token!r} is not in {got.err!r}"
    assert got.out and all(": " in line for line in got.out.splitlines()), got.out
    assert got.after == got.before, changes(got.before, got.after)


# =========================================================================== closed pipes

CLOSED_PIPES = [
    Piped("oracle", "oracle case.npz out.npz", "stdout", ("out.npz",), _result_whole),
    Piped("oracle-head-0", "oracle case.npz out.npz", "both", ("out.npz",), _result_whole),
    Piped("check", "check --cmd '{python} -m pes_ref oracle {pairs}' --only plane-dynamic", "stdout"),
    Piped("check-progress", "check --cmd '{python} -m pes_ref oracle {pairs}' --no-vectors --random 2", "stderr"),
    Piped("conformance", "conformance --check", "stdout"),
    Piped("conformance-write", "conformance --write vw", "stdout", ("vw",), _vectors_whole_or_absent),
    Piped("analyze", "analyze ratchet --smoke", "stdout"),
    Piped("design", "design funnel --smoke --out new.npz", "stdout", ("new.npz",), _design("done", 6, 6)),
    Piped("design-progress", "design funnel --smoke --iterations 300 --progress 0 --out new.npz", "stderr",
          ("new.npz",), _design("interrupted", 1, 299)),
    Piped("design-head-1", "design funnel --smoke --iterations 300 --progress 0 --out new.npz", "both",
          ("new.npz",), _design("interrupted", 1, 299)),
    Piped("evaluate", "evaluate design.npz --particles 8", "stdout"),
    Piped("realize", "realize design.npz --as contact --out rp", "stdout", ("rp",), _parts_whole_or_absent),
    Piped("sweep", "sweep tiny.toml --out sw --workers 1", "stderr", ("sw",), _sweep_whole_or_absent),
    Piped("bench", "bench --quick --no-autodiff --out bench.json", "stdout", ("bench.json", "bench-scaling.png"),
          _bench_whole_or_absent),
]


@pytest.fixture(scope="module")
def piped(fault_assets, tmp_path_factory):
    root = tmp_path_factory.mktemp("pipes")
    got = run_rows(CLOSED_PIPES, fault_assets, root, run=run_piped)
    return {pid: (outcome, root / pid) for pid, outcome in got.items()}


def test_every_command_is_tested_under_a_closed_pipe():
    assert {p.argv.split()[0] for p in CLOSED_PIPES} == set(cli.COMMANDS)


@pytest.mark.parametrize("row", CLOSED_PIPES, ids=[p.id for p in CLOSED_PIPES])
def test_closed_pipe(row, piped):
    """The one rule (pes_ref.cli.common.watch_pipes): the command stops as Ctrl-C stops it,
    keeps what it saved whole, says nothing more and exits 141."""
    got, work = piped[row.id]
    said = got.out + got.err                # what went to the stream that stayed open
    for word in ("Traceback", "Exception ignored", "error", "BrokenPipe"):
        assert word not in said, said
    assert got.status == cli.EXIT_PIPE, (got.status, said)
    unchanged = {k: v for k, v in got.before.items() if got.after.get(k) != v}
    assert not unchanged, f"changed or lost: {sorted(unchanged)}"
    added = {k.split("/")[0] for k in set(got.after) - set(got.before)}
    assert added <= set(row.made), f"left {sorted(added - set(row.made))}"
    if row.check is not None and added:
        row.check(work, got.before)
    if row.made and row.check is not None and row.check.__name__.startswith("_result"):
        assert "out.npz" in added                    # the result was written before the line that failed


# =========================================================================== Ctrl-C while importing

#: Runs ``python -m pes_ref ARGV`` as ``pes_ref.__main__`` does, with Ctrl-C arriving while
#: the module ``sys.argv[1]`` is being imported: raised as KeyboardInterrupt (``raise``), or
#: turned into an ImportError as a C extension's import may turn it (``lost``).
_INTERRUPT_IMPORT = """
import signal, sys
target, how = sys.argv[1], sys.argv[2]


class Interrupt:
    def find_spec(self, name, path=None, target_module=None):
        if name == target:
            sys.meta_path.remove(self)
            try:
                signal.raise_signal(signal.SIGINT)
            except KeyboardInterrupt:
                if how == "lost":
                    raise ImportError(name + ": an extension's import turned Ctrl-C into this") from None
                raise
        return None


sys.meta_path.insert(0, Interrupt())
sys.argv = ["pes_ref", *sys.argv[3:]]
from pes_ref.__main__ import run
sys.exit(run())
"""

#: (module being imported, how Ctrl-C arrives): from the command line's first module to the
#: libraries the chosen command imports.
INTERRUPTED_IMPORTS = [("pes_ref.cli", "raise"), ("argparse", "raise"), ("pes_ref.cli.design", "raise"),
                       ("numpy", "raise"), ("numpy", "lost"), ("pes_ref.synthesis", "raise"),
                       ("pes_ref.synthesis", "lost")]


@pytest.mark.parametrize("module, how", INTERRUPTED_IMPORTS, ids=[f"{m}-{h}" for m, h in INTERRUPTED_IMPORTS])
def test_ctrl_c_while_importing(module, how, tmp_path):
    proc = subprocess.run([sys.executable, "-c", _INTERRUPT_IMPORT, module, how, "design", "funnel", "--smoke",
                           "--out", str(tmp_path / "new.npz")], capture_output=True, text=True, env=ENV, timeout=120)
    assert (proc.returncode, proc.stderr, proc.stdout) == (cli.EXIT_INTERRUPTED, "interrupted\n", "")
    assert os.listdir(tmp_path) == []


# =========================================================================== PES_REF_DEBUG

@pytest.mark.parametrize("value, shown", [("1", True), ("0", False), ("", False)])
def test_debug_shows_the_traceback_of_a_caught_error(fault_assets, tmp_path, value, shown):
    """``PES_REF_DEBUG=1``: a refusal the command catches prints its traceback, then its one line."""
    work = tmp_path / "work"
    shutil.copytree(fault_assets, work)
    proc = subprocess.run([sys.executable, "-m", "pes_ref", "evaluate", "design.npz", "--particles", "0"], cwd=work,
                          env=dict(ENV, PES_REF_DEBUG=value), capture_output=True, text=True, timeout=120,
                          stdin=subprocess.DEVNULL)
    assert proc.returncode == cli.EXIT_ERROR and proc.stdout == ""
    lines = proc.stderr.splitlines()
    assert lines[-1] == "error: --particles must be >= 1, got 0", proc.stderr
    assert ("Traceback (most recent call last):" in proc.stderr) == shown, proc.stderr
    if shown:
        assert lines[0].startswith("Traceback") and "InputError" in lines[-2], proc.stderr
