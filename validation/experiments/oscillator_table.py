"""The default oscillator's table in docs/synthesis.md, regenerated from the code.

``make oscillator-table`` runs it: the default ``python -m pes_ref design oscillator
--backend B`` for design seeds 0, 1 and 2 on each installed backend B (``--workers`` designs
at a time, one process each), each design evaluated as ``python -m pes_ref evaluate FILE
--seed H`` does on held-out seeds 12345 and 9191; then the table between the two marker lines
of docs/synthesis.md is replaced, and nothing else in the file::

    <!-- oscillator-table:begin (make oscillator-table writes what follows) -->
    ...
    <!-- oscillator-table:end -->

The design files go to ``--out`` (``validation/out/oscillator_table/oscS-B.npz``, replaced
on each run). The table says what rewrites it, its conditions (CPU, NumPy, load average) and
its provenance (``regenerated: DATE, commit HASH``), the wall and CPU time of each design, and the SHA-256 of each design's grid values: a design is
bit-identical between two runs only on the same backend, CPU kind and libraries
(docs/synthesis.md, "Results"), and the hash shows at a glance whether it was.

``--smoke`` runs the ``design --smoke`` preset instead (seconds, for the tests).
"""
from __future__ import annotations

import argparse
import datetime
import hashlib
import os
import platform
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_DOC = ROOT / "docs" / "synthesis.md"
DEFAULT_OUT = ROOT / "validation" / "out" / "oscillator_table"
DESIGN_SEEDS = (0, 1, 2)
BACKENDS = ("numba", "numpy")
HELD_OUT = (12345, 9191)
BEGIN = "<!-- oscillator-table:begin (make oscillator-table writes what follows) -->"
END = "<!-- oscillator-table:end -->"


def values_sha256(values) -> str:
    """SHA-256 of a grid's float64 values, little-endian, C order (the design's bits)."""
    return hashlib.sha256(np.ascontiguousarray(values, dtype="<f8").tobytes()).hexdigest()


def design_and_evaluate(seed: int, backend: str, held_out: tuple, out: str, smoke: bool) -> dict:
    """One default design (or its smoke preset) on ``backend``, saved to ``out/oscSEED-BACKEND.npz``,
    and its figures on each held-out seed: what ``design oscillator --seed SEED --backend BACKEND``
    then ``evaluate --seed H`` print."""
    from pes_ref.synthesis import OscillatorProblem, design_inputs, evaluate_seeds, run_stages, save_design, start_design

    inputs = design_inputs(OscillatorProblem(), {"smoke": smoke})
    wall, cpu = time.perf_counter(), time.process_time()
    state = start_design(inputs, seed=seed, backend=backend)
    state = run_stages(state, state.plan.iterations)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    path = os.path.join(out, f"osc{seed}-{backend}.npz")
    save_design(path, state, overwrite=True)
    return {"seed": seed, "backend": backend, "status": state.status, "iterations": state.iteration, "evaluations": state.evaluations,
            "wall_s": wall, "cpu_s": cpu, "sha256": values_sha256(state.values), "file": path,
            "figures": evaluate_seeds(state.problem, state.values, held_out)}


def _num(x: float, digits: int) -> str:
    return f"{x:.{digits}f}" if np.isfinite(x) else "-"


def _pair(f: dict, name: str) -> str:
    return f"{_num(f[name + '_median'], 3)} / {_num(f[name], 3)}"


def table(runs: list) -> list:
    """The markdown table's lines: one row per backend, design seed and held-out seed."""
    lines = ["| backend | design seed | held-out seed | captured | sweep | grid | amplitude error median / worst "
             "| period error median / worst | q1 advance min / median / max | wall (CPU) | grid values sha256 |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for run in sorted(runs, key=lambda r: (BACKENDS.index(r["backend"]), r["seed"])):
        for i, (h, f) in enumerate(run["figures"].items()):
            first = i == 0
            cost = f"{run['wall_s']:.0f} s ({run['cpu_s']:.0f} s)" if first else ""
            digest = f"`{run['sha256'][:16]}`" if first else ""
            lines.append(f"| {run['backend'] if first else ''} | {run['seed'] if first else ''} | {h} | {f['captured_fraction']:.3f} "
                         f"| {f['sweep_captured_fraction']:.2f} | {f['grid_captured_fraction']:.2f} "
                         f"| {_pair(f, 'amplitude_error')} | {_pair(f, 'period_error')} "
                         f"| {' / '.join(_num(f['q1_advance_' + k], 2) for k in ('min', 'median', 'max'))} "
                         f"| {cost} | {digest} |")
    return lines


def command(seeds: tuple, held_out: tuple, smoke: bool, backends: tuple) -> str:
    """The command that makes this table again."""
    words = (["--smoke"] if smoke else []) + \
        ([f"--backends {','.join(backends)}"] if tuple(backends) != installed_backends() else []) + \
        ([f"--seeds {','.join(map(str, seeds))}"] if tuple(seeds) != DESIGN_SEEDS else []) + \
        ([f"--held-out {','.join(map(str, held_out))}"] if tuple(held_out) != HELD_OUT else [])
    return " ".join(["python validation/experiments/oscillator_table.py", *words]) if words else "make oscillator-table"


def installed_backends() -> tuple:
    """The backends of :data:`BACKENDS` installed here (NumPy's always)."""
    from pes_ref.core import backends
    return tuple(b for b in BACKENDS if backends.installed(b))


def _backends(text: str) -> tuple:
    names = tuple(dict.fromkeys(text.split(",")))
    bad = [b for b in names if b not in installed_backends()]
    if bad:
        raise argparse.ArgumentTypeError(f"expected installed backends among {', '.join(installed_backends())}, "
                                         f"got {text!r}")
    return names


def where_made(cmd: str, loads: tuple, workers: int) -> list:
    """The block's head: a line naming what rewrites the table and its conditions (CPU, libraries,
    designs at a time, load), a blank line, then ``regenerated: DATE, commit `HASH```, its provenance."""
    commit = _git("rev-parse", "--short", "HEAD") or "unknown"
    if _git("status", "--porcelain", "--", "pes_ref", "setup.cfg"):
        commit += " with uncommitted changes to pes_ref"
    import cma
    today = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d")
    return [f"`{cmd}` rewrites this table. Conditions: {cpu_name()}, "
            f"Python {platform.python_version()}, NumPy {np.__version__}, pycma {cma.__version__}; "
            f"{workers} design(s) at a time, load average {loads[0]:.1f} at the start and {loads[1]:.1f} at the end.",
            "", f"regenerated: {today}, commit `{commit}`"]


def _git(*args) -> str:
    """The output of ``git args`` in the repository ("" without git or a repository)."""
    try:
        return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""


def cpu_name() -> str:
    """The CPU's model and its widest vector extension (AVX-512 changes the last bits of NumPy's and OpenBLAS's
    arithmetic, and with them every design)."""
    try:
        info = Path("/proc/cpuinfo").read_text()
    except OSError:
        return platform.processor() or platform.machine()
    model = next((line.split(":", 1)[1].strip() for line in info.splitlines() if line.startswith("model name")),
                 platform.machine())
    flags = next((line.split(":", 1)[1].split() for line in info.splitlines() if line.startswith("flags")), [])
    widest = "AVX-512" if "avx512f" in flags else "AVX2" if "avx2" in flags else "no AVX2"
    return f"{model} ({widest})"


def rewrite(text: str, block: list, begin_marker: str = BEGIN, end_marker: str = END) -> str:
    """``text`` with the lines between ``begin_marker`` and ``end_marker`` (this table's
    :data:`BEGIN` and :data:`END`) replaced by ``block``.

    Raises
    ------
    ValueError
        If either marker line is missing, appears twice, or they are out of order.
    """
    lines = text.split("\n")
    found = {m: [i for i, line in enumerate(lines) if line.strip() == m] for m in (begin_marker, end_marker)}
    for marker, at in found.items():
        if len(at) != 1:
            raise ValueError(f"expected the line {marker!r} once, found it {len(at)} times")
    begin, end = found[begin_marker][0], found[end_marker][0]
    if end < begin:
        raise ValueError(f"the line {end_marker!r} comes before {begin_marker!r}")
    return "\n".join(lines[:begin + 1] + block + lines[end:])


def _seeds(text: str) -> tuple:
    try:
        seeds = tuple(int(s) for s in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers >= 0, got {text!r}") from None
    if not seeds or min(seeds) < 0:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers >= 0, got {text!r}")
    return seeds


def _error(exc) -> int:
    print(f"error: {' '.join(str(exc).split())}", file=sys.stderr)
    return 2


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=_seeds, default=DESIGN_SEEDS, help="design seeds, e.g. 0,1,2")
    ap.add_argument("--backends", type=_backends, default=None,
                    help="backends, e.g. numba,numpy (default: every installed one)")
    ap.add_argument("--held-out", type=_seeds, default=HELD_OUT, help="held-out seeds, e.g. 12345,9191")
    ap.add_argument("--workers", type=int, default=2, help="designs run at a time (processes)")
    ap.add_argument("--doc", default=str(DEFAULT_DOC), help="the markdown file whose table is replaced")
    ap.add_argument("--out", default=str(DEFAULT_OUT), help="folder of the design files")
    ap.add_argument("--smoke", action="store_true", help="the design --smoke preset (seconds; for the tests)")
    ap.add_argument("--print-only", action="store_true", help="print the table; write no document")
    args = ap.parse_args(argv)
    doc = Path(args.doc)
    if args.workers < 1:
        return _error(f"--workers must be >= 1, got {args.workers}")
    if not args.print_only:
        try:
            rewrite(doc.read_text(), [])        # the markers are checked before the designs run
        except OSError as exc:
            return _error(exc)
        except ValueError as exc:
            return _error(f"{doc}: {exc}")
    os.makedirs(args.out, exist_ok=True)
    start = os.getloadavg()[0]
    backends = args.backends or installed_backends()
    jobs = [(seed, backend, args.held_out, args.out, args.smoke) for backend in backends for seed in args.seeds]
    try:
        if args.workers == 1:
            runs = [design_and_evaluate(*job) for job in jobs]
        else:
            with ProcessPoolExecutor(args.workers) as pool:
                runs = list(pool.map(design_and_evaluate, *zip(*jobs)))
    except KeyboardInterrupt:
        print(f"interrupted; {doc} is unchanged", file=sys.stderr)
        return 130
    unfinished = [f"osc{run['seed']}-{run['backend']}: {run['status']}" for run in runs if run["status"] != "done"]
    if unfinished:
        return _error(f"a design did not finish ({'; '.join(unfinished)}); {doc} is unchanged")
    block = where_made(command(args.seeds, args.held_out, args.smoke, backends), (start, os.getloadavg()[0]),
                       min(args.workers, len(jobs))) + [""] + table(runs)
    if not args.print_only:
        from pes_ref.core.runtime.files import atomic_file
        with atomic_file(doc, overwrite=True, what="document") as fh:
            fh.write(rewrite(doc.read_text(), block).encode())
    print("\n".join(block))
    for run in runs:
        print(f"osc{run['seed']}-{run['backend']}: {run['status']}, {run['iterations']} iterations + {run['evaluations']} "
              f"evaluations, values sha256 {run['sha256']}, {run['file']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
