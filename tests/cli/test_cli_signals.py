"""The command line under signals, for real (subprocesses): a reader that closes the pipe
early (``| head -1``), Ctrl-C (SIGINT) and a batch scheduler's SIGTERM during ``design``."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import pes_ref
from pes_ref.cli import EXIT_INTERRUPTED, EXIT_PIPE
from pes_ref.synthesis import load_design

ROOT = Path(pes_ref.__file__).resolve().parent.parent
ENV = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), OMP_NUM_THREADS="1")
PES_REF = [sys.executable, "-m", "pes_ref"]


def run(*args, **kw):
    return subprocess.run([*PES_REF, *map(str, args)], capture_output=True, text=True, env=ENV, timeout=120, **kw)


@pytest.fixture(scope="module")
def design_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("signals") / "f.npz"
    proc = run("design", "funnel", "--smoke", "--quiet", "--out", path)
    assert proc.returncode == 0, proc.stderr
    return path


def _into_head(argv):
    """Run ``pes_ref ARGV | head -1``; return (pes_ref's exit status, its stderr, what head printed)."""
    head = subprocess.Popen(["head", "-1"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    proc = subprocess.Popen([*PES_REF, *map(str, argv)], stdout=head.stdin, stderr=subprocess.PIPE, text=True,
                            env=ENV)
    head.stdin.close()                      # only the two processes hold the pipe
    err = proc.communicate(timeout=120)[1]
    out = head.stdout.read()
    head.wait(timeout=10)
    return proc.returncode, err, out


PIPED = [["evaluate", "{design}", "--particles", "8"], ["conformance", "--check"]]


@pytest.mark.parametrize("argv", PIPED, ids=["evaluate", "conformance-check"])
def test_into_head_ends_quietly(argv, design_file):
    code, err, out = _into_head([a.format(design=design_file) for a in argv])
    assert out.count("\n") == 1
    assert "Traceback" not in err and "Exception ignored" not in err and "BrokenPipe" not in err, err
    assert err == "" and code in (0, EXIT_PIPE)        # 141 when the pipe closed under it (cli.common.watch_pipes)


@pytest.mark.parametrize("argv", PIPED, ids=["evaluate", "conformance-check"])
def test_a_reader_gone_before_the_first_line_ends_quietly(argv, design_file):
    """``| head -1`` races: head may read everything before it exits. Here the reading end
    is closed before pes_ref writes at all, so its first write surely meets a closed pipe."""
    read, write = os.pipe()
    os.close(read)
    try:
        proc = subprocess.run([*PES_REF, *[a.format(design=design_file) for a in argv]], stdout=write,
                              stderr=subprocess.PIPE, text=True, env=ENV, timeout=120)
    finally:
        os.close(write)
    assert "Traceback" not in proc.stderr and "Exception ignored" not in proc.stderr, proc.stderr
    assert proc.stderr == "" and proc.returncode == EXIT_PIPE


def _children(pid: int) -> list:
    path = Path(f"/proc/{pid}/task/{pid}/children")
    return [int(p) for p in path.read_text().split()] if path.exists() else []


def _start_design(argv, *, shell=False):
    """Start a design that runs until stopped; return the process (and the pes_ref pid) once its
    loop has started (its first progress line is on stderr)."""
    if shell:
        proc = subprocess.Popen(["sh", "-c", argv], stderr=subprocess.PIPE, text=True, env=ENV)
    else:
        proc = subprocess.Popen([*PES_REF, *argv], stderr=subprocess.PIPE, text=True, env=ENV)
    lines = []
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        line = proc.stderr.readline()
        lines.append(line)
        if line.startswith("design funnel:") or not line:
            break
    assert lines[-1].startswith("design funnel:"), "".join(lines)
    pid = proc.pid
    if shell:
        kids = _children(proc.pid)
        if not kids:
            proc.kill()
            pytest.skip("needs /proc/PID/task/PID/children (Linux) to find the shell's child")
        pid = kids[0]
    return proc, pid


DESIGN = ["design", "funnel", "--smoke", "--iterations", "100000", "--progress", "0"]


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_stopped_design_is_saved_and_exits_130(signum, tmp_path):
    out = tmp_path / "d.npz"
    proc, pid = _start_design([*DESIGN, "--out", str(out)])
    time.sleep(0.3)                         # a few more iterations
    os.kill(pid, signum)
    err = proc.communicate(timeout=60)[1]
    assert proc.returncode == EXIT_INTERRUPTED, err
    assert "Traceback" not in err
    state = load_design(out)                # a valid design, with the work done before the signal
    assert state.status == "interrupted" and state.iteration >= 1
    assert err.strip().splitlines()[-1].startswith("interrupted; saved; continue with: ")
    ev = run("evaluate", out, "--particles", "8")
    assert ev.returncode == 0 and f"iterations: {state.iteration}" in ev.stdout, ev.stderr
    assert sorted(os.listdir(tmp_path)) == ["d.npz"]     # no temporary file left behind


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_design_and_then_evaluate_stops_after_an_interrupted_design(signum, tmp_path):
    out, carried = tmp_path / "d.npz", tmp_path / "carried-on"
    cmd = " ".join([*PES_REF, *DESIGN, "--out", str(out)]) + f" && touch {carried}"
    proc, pid = _start_design(cmd, shell=True)
    os.kill(pid, signum)
    proc.communicate(timeout=60)
    assert proc.returncode == EXIT_INTERRUPTED
    assert out.exists() and not carried.exists()
