"""Runs ``python -m pes_ref ARGV`` in a process forked from one that has imported the command
line already (a :mod:`multiprocessing` forkserver), for the fault tables (``tests/_faults.py``).

A row's process is a process of its own, as ``python -m pes_ref`` would be: its own folder,
environment, standard streams (stdin the null device, stdout and stderr files) and exit status,
running `pes_ref.__main__.run` on ``sys.argv``. What it does not repeat is starting Python and
importing NumPy, SciPy, numba and the command line (about 0.3 s of CPU a row), which the
forkserver did once: the rows' own work is what they cost.
"""
from __future__ import annotations

import multiprocessing
import os
import sys
import threading
from multiprocessing.connection import wait

#: What the forkserver imports before it forks any row.
PRELOAD = ["pes_ref.__main__", "pes_ref.cli", "pes_ref.cli.analyze", "pes_ref.cli.design", "pes_ref.cli.evaluate",
           "pes_ref.cli.oracle", "pes_ref.cli.realize", "pes_ref.synthesis", "pes_ref.oracle", "pes_ref.accel.compiled",
           "_forked"]

_CONTEXT = multiprocessing.get_context("forkserver")
_CONTEXT.set_forkserver_preload(PRELOAD)
#: The rows run on a pool of threads, and multiprocessing is not made for that: starting a
#: process polls every other child (reading its exit status off its pipe), which races a
#: thread reading its own. Every start and every read of a status holds this lock.
_LOCK = threading.Lock()


def _child(argv: list, cwd: str, env: dict, out: str, err: str) -> None:
    os.chdir(cwd)
    os.environ.clear()
    os.environ.update(env)
    for fd, path, flags in ((0, os.devnull, os.O_RDONLY), (1, out, os.O_WRONLY | os.O_CREAT | os.O_TRUNC),
                            (2, err, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)):
        opened = os.open(path, flags)
        os.dup2(opened, fd)
        os.close(opened)
    from pes_ref.__main__ import run
    sys.argv = ["pes_ref", *argv]
    sys.exit(run())


def run(argv: list, cwd, env: dict, out, err, timeout: float) -> int:
    """Run ``argv`` in ``cwd`` with ``env``, stdout into ``out`` and stderr into ``err`` (paths):
    the exit status."""
    proc = _CONTEXT.Process(target=_child, args=(list(argv), str(cwd), dict(env), str(out), str(err)))
    with _LOCK:
        proc.start()
    if not wait([proc.sentinel], timeout):
        proc.kill()
        with _LOCK:
            proc.join()
        raise TimeoutError(f"pes_ref {' '.join(argv)} ran longer than {timeout} s")
    with _LOCK:
        proc.join()
    return proc.exitcode
