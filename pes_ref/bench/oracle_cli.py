"""What the oracle's command line costs around its computation, on the paper-sized funnel.

The funnel of [`pes_ref.bench.cases.funnel_case`][pes_ref.bench.cases.funnel_case] (200 x 200 grid, 64 particles,
400 steps, every gradient) is written as a case file; then the whole process
``python -m pes_ref oracle CASE RESULT`` is timed against its floor: a bare
``python -c "import numpy"`` plus the computation ([`run_case`][pes_ref.oracle.case.run_case] on the loaded case),
timed both as the oracle process does it (the first call in a fresh process) and warm
(in this process, which has made many calls). The processes are run in turns (one of each per
round, so a busy machine slows all of them alike) with their bytecode cached, as an
installed package has it; medians of wall and CPU (user + system) time are reported,
with the parts in between: the oracle's start-up (its imports, its parser, the
freezing of what they made: [`pes_ref.cli.main`][pes_ref.cli.main]), the computation, and writing the
result stored (the default) or deflated (``--compress``). docs/performance.md has the
numbers.

Run: ``python -m pes_ref.bench.oracle_cli [--repeats N]``; it prints a table and the
ratio (whole process) / (bare numpy + computation), whose target is at most 1.3.
"""
from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pes_ref.bench.cases import funnel_case
from pes_ref.oracle.case import load_case, run_case, save_case, write_result

__all__ = ["funnel_case_keys", "write_funnel_case", "measure", "format_table", "main", "ROWS", "TARGET_RATIO"]

#: The target of the whole process relative to (bare numpy + computation).
TARGET_RATIO = 1.3


def funnel_case_keys(seed: int = 0) -> dict:
    """The paper-sized funnel as the keys of a case (docs/spec.md section 8), its noise
    realized into ``force``."""
    c = funnel_case(seed=seed)
    return dict(values=c.values, lower=c.lower, upper=c.upper, periodic=np.array(c.periodic), dt=c.dt,
                n_steps=np.int64(c.n_steps), mode="dynamic", mass=c.mass, damping=c.damping, x0=c.x0,
                v0=c.v0, force=c.fext, wall_k=c.wall_k, wall_margin=c.wall_margin, walls=c.walls,
                objective="funnel", target=float(c.objective[1]), when="every_step")


def write_funnel_case(path) -> Path:
    """Write the funnel case file to ``path`` (stored, replacing a file there)."""
    save_case(path, overwrite=True, compress=False, **funnel_case_keys())
    return Path(path)


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _child_env(pycache: Path) -> dict:
    """The environment of the timed processes: bytecode is cached (in ``pycache``, not
    beside the sources), as an installed package has it, even if this process was told
    not to write bytecode."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPYCACHEPREFIX"] = str(pycache)
    return env


def time_process(cmd: list, env: dict | None = None) -> tuple:
    """Wall and CPU (user + system) seconds of one process, and its stdout."""
    t, c = time.perf_counter(), _children_cpu()
    out = subprocess.run(cmd, check=True, stdout=subprocess.PIPE, text=True, env=env).stdout
    return time.perf_counter() - t, _children_cpu() - c, out


def time_call(fn) -> tuple:
    """Wall and CPU seconds of ``fn()`` in this process."""
    t, c = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - t, time.process_time() - c


#: Prints the wall and CPU seconds of the first `run_case` of a fresh process.
_FIRST_CALL = """
import sys, time
from pes_ref.oracle.case import load_case, run_case
case = load_case(sys.argv[1])
t, c = time.perf_counter(), time.process_time()
run_case(case)
print(time.perf_counter() - t, time.process_time() - c)
"""

#: The rows of the table, in order.
ROWS = ("bare numpy", "start-up of the oracle", "whole oracle process", "computation, first call",
        "computation, warm", "write result, stored", "write result, deflated")


def measure(folder, repeats: int = 15, python: str = sys.executable) -> dict:
    """Every row of `ROWS`: name -> (wall seconds, CPU seconds), medians over
    ``repeats`` rounds after a warm-up round; ``folder`` holds the files.

    Each round runs every process once and every in-process figure once, so that a
    machine whose load changes slows all of them alike. The computation is timed twice:
    as the oracle process does it (the first call in a fresh process, which also pays
    for touching fresh memory and cold caches) and warm (one more call in this process,
    which has made many)."""
    folder = Path(folder)
    case_path = write_funnel_case(folder / "funnel.case.npz")
    result_path = folder / "funnel.result.npz"
    case = load_case(case_path)
    result = run_case(case)
    env = _child_env(folder / "pycache")
    processes = {
        "bare numpy": [python, "-c", "import numpy"],
        "start-up of the oracle": [python, "-c", "import gc, pes_ref.cli, pes_ref.oracle.case; "
                                                 "pes_ref.cli.build_parser('oracle'); gc.freeze()"],
        "whole oracle process": [python, "-m", "pes_ref", "oracle", str(case_path), str(result_path), "--force"],
    }
    calls = {
        "computation, warm": lambda: run_case(case),
        "write result, stored": lambda: write_result(result, result_path, overwrite=True),
        "write result, deflated": lambda: write_result(result, result_path, overwrite=True, compress=True),
    }
    runs = {name: [] for name in ROWS}
    for round_ in range(repeats + 1):
        got = {name: time_process(cmd, env)[:2] for name, cmd in processes.items()}
        first = time_process([python, "-c", _FIRST_CALL, str(case_path)], env)[2].split()
        got["computation, first call"] = (float(first[0]), float(first[1]))
        got.update({name: time_call(fn) for name, fn in calls.items()})
        if round_:
            for name, pair in got.items():
                runs[name].append(pair)
    return {name: tuple(statistics.median(p[i] for p in runs[name]) for i in (0, 1)) for name in ROWS}


def format_table(medians: dict) -> str:
    """The table (median wall and CPU milliseconds) and the ratios to the target."""
    lines = [f"{'':30s} {'wall':>9s} {'CPU':>9s}"]
    lines += [f"{name:30s} {1e3 * w:6.1f} ms {1e3 * c:6.1f} ms" for name, (w, c) in medians.items()]
    for computation in ("computation, first call", "computation, warm"):
        for i, clock in enumerate(("wall", "CPU")):
            floor = medians["bare numpy"][i] + medians[computation][i]
            whole = medians["whole oracle process"][i]
            lines.append(f"whole / (bare numpy + {computation}), {clock}: {1e3 * whole:.1f} / {1e3 * floor:.1f} "
                         f"= {whole / floor:.2f} (target <= {TARGET_RATIO})")
    return "\n".join(lines)


def main(argv=None) -> int:
    """Time the oracle's process against its floor (``--repeats`` rounds) and print the table;
    returns the exit status 0."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=15, help="runs of each process (default 15)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        print(format_table(measure(tmp, args.repeats)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
