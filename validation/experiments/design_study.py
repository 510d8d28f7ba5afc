"""The design study of docs/problems.md: every shipped problem and example on the default plan.

``make design-study`` runs it: each problem file (the shipped ones,
``pes_ref/synthesis/data/*.toml``, and the examples, ``examples/problems/*.toml``) without its
``[train]`` table, so on the default plan with no tuned option, designed for design seeds 0-7 on
each installed backend (``--workers`` designs at a time, one process each), each design
evaluated as ``python -m pes_ref evaluate FILE --seed H`` does on held-out seeds 12345 and 9191.
It writes ``--out``/results.csv (one row per design) and replaces the table between the two
marker lines of docs/problems.md, and nothing else in the file::

    <!-- design-study:begin (make design-study writes what follows) -->
    ...
    <!-- design-study:end -->

The table says what rewrites it, its conditions (CPU, NumPy, load average) and its provenance
(``regenerated: DATE, commit HASH``), and per problem and backend how many design seeds reach
success >= 0.9 on both held-out seeds, each seed's success on the two, the flat surface's and the
design's wall time.

``--smoke`` designs each problem at a smoke size (an 8-node grid, 3 iterations; for the tests).
"""
from __future__ import annotations

import argparse
import contextlib
import csv
import importlib.util
import io
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
_SPEC = importlib.util.spec_from_file_location("oscillator_table", Path(__file__).with_name("oscillator_table.py"))
_table = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(_table)

DEFAULT_DOC = ROOT / "docs" / "problems.md"
DEFAULT_OUT = ROOT / "validation" / "out" / "design_study"
DESIGN_SEEDS = tuple(range(8))
HELD_OUT = (12345, 9191)
#: The bar of the design study: success on both held-out seeds at least this.
BAR = 0.9
BEGIN = "<!-- design-study:begin (make design-study writes what follows) -->"
END = "<!-- design-study:end -->"


def problem_files() -> list:
    """The shipped problem files, then the examples: paths."""
    from pes_ref.synthesis import SHIPPED_PROBLEMS, shipped_problem
    return [shipped_problem(n) for n in SHIPPED_PROBLEMS] + sorted(
        str(p) for p in (ROOT / "examples" / "problems").glob("*.toml"))


def default_plan_problem(path: str, smoke: bool):
    """The problem of ``path`` without its ``[train]`` table (the default plan); at smoke size if ``smoke``."""
    from pes_ref.synthesis import load_problem, parse_problem
    problem = load_problem(path)
    data = {k: v for k, v in problem.data.items() if k != "train"}
    if smoke:
        data["surface"] = {**data["surface"], "shape": list(problem.shape(8))}
        data["train"] = {"iterations": 3, "particles": 4}
        data["evaluate"] = {**data["evaluate"], "particles": 8}
    return parse_problem(data, path)


def design_and_evaluate(path: str, seed: int, backend: str, held_out: tuple, smoke: bool) -> dict:
    """One design of ``path`` on the default plan, and its figures on each held-out seed."""
    from pes_ref.synthesis import design_inputs, evaluate_seeds, run_stages, start_design
    problem = default_plan_problem(path, smoke)
    wall, cpu = time.perf_counter(), time.process_time()
    state = run_stages(start_design(design_inputs(problem, {}), seed=seed, backend=backend))
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    figures = evaluate_seeds(problem, state.values, held_out)
    row = {"problem": problem.name, "file": os.path.relpath(path, ROOT), "backend": backend, "seed": seed,
           "status": state.status, "iterations": state.iteration, "wall_s": round(wall, 2), "cpu_s": round(cpu, 2)}
    for h, f in figures.items():
        row[f"success@{h}"] = f["success_fraction"]
        row[f"flat@{h}"] = f["flat_success_fraction"]
    return row


def table(rows: list, held_out: tuple) -> list:
    """The markdown lines: per problem and backend, the seeds at the bar, then one row per seed."""
    lines = ["| problem | backend | seeds >= 0.9 on both | design seed | success " + " / ".join(map(str, held_out))
             + " | flat | wall s |", "|---|---|---|---|---|---|---|"]
    groups = {}
    for r in rows:
        groups.setdefault((r["problem"], r["backend"]), []).append(r)
    for (problem, backend), runs in groups.items():
        runs.sort(key=lambda r: r["seed"])
        at_bar = sum(all(r[f"success@{h}"] >= BAR for h in held_out) for r in runs)
        for i, r in enumerate(runs):
            head = f"| {problem} | {backend} | {at_bar} of {len(runs)} |" if i == 0 else "| | | |"
            lines.append(f"{head} {r['seed']} | " + " / ".join(f"{r[f'success@{h}']:.3f}" for h in held_out)
                         + f" | {r[f'flat@{held_out[0]}']:.3f} | {r['wall_s']:.1f} |")
    return lines


def write_csv(path: Path, rows: list) -> None:
    from pes_ref.core.runtime.files import atomic_file
    out = io.StringIO(newline="")
    writer = csv.DictWriter(out, fieldnames=list(rows[0]))
    writer.writeheader()
    writer.writerows(rows)
    with atomic_file(path, overwrite=True, what="results") as fh:
        fh.write(out.getvalue().encode())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=_table._seeds, default=DESIGN_SEEDS, help="design seeds, e.g. 0,1,2")
    ap.add_argument("--backends", type=_table._backends, default=None,
                    help="backends, e.g. numba,numpy (default: every installed one)")
    ap.add_argument("--held-out", type=_table._seeds, default=HELD_OUT, help="held-out seeds, e.g. 12345,9191")
    ap.add_argument("--problems", default=None, help="comma-separated problem names (default: every one)")
    ap.add_argument("--workers", type=int, default=2, help="designs run at a time (processes)")
    ap.add_argument("--doc", default=str(DEFAULT_DOC), help="the markdown file whose table is replaced")
    ap.add_argument("--out", default=str(DEFAULT_OUT), help="folder of results.csv")
    ap.add_argument("--smoke", action="store_true", help="a smoke size (seconds; for the tests)")
    ap.add_argument("--print-only", action="store_true", help="print the table; write no document")
    args = ap.parse_args(argv)
    backends = args.backends or _table.installed_backends()
    paths = problem_files()
    if args.problems:
        wanted = args.problems.split(",")
        names = {Path(p).stem: p for p in paths}
        bad = [w for w in wanted if w not in names]
        if bad:
            return _table._error(f"--problems: no problem {bad[0]!r}; expected among {', '.join(names)}")
        paths = [names[w] for w in wanted]
    jobs = [(p, s, b) for p in paths for b in backends for s in args.seeds]
    load0 = os.getloadavg()[0]
    rows = []
    with contextlib.ExitStack() as stack:
        if args.workers > 1:
            pool = stack.enter_context(ProcessPoolExecutor(max_workers=args.workers))
            results = (f.result() for f in [pool.submit(design_and_evaluate, p, s, b, tuple(args.held_out),
                                                        args.smoke) for p, s, b in jobs])
        else:                                   # one at a time, in this process
            results = (design_and_evaluate(p, s, b, tuple(args.held_out), args.smoke) for p, s, b in jobs)
        for i, row in enumerate(results, 1):
            rows.append(row)
            print(f"[{i}/{len(jobs)}] {row['problem']} seed {row['seed']} {row['backend']}: "
                  + " / ".join(f"{row[f'success@{h}']:.3f}" for h in args.held_out) + f" ({row['wall_s']:.1f} s)",
                  file=sys.stderr, flush=True)
    os.makedirs(args.out, exist_ok=True)
    write_csv(Path(args.out) / "results.csv", rows)
    words = (["--smoke"] if args.smoke else []) + ([f"--problems {args.problems}"] if args.problems else []) + \
        ([f"--backends {','.join(args.backends)}"] if args.backends else []) + \
        ([f"--seeds {','.join(map(str, args.seeds))}"] if tuple(args.seeds) != DESIGN_SEEDS else [])
    cmd = " ".join(["python validation/experiments/design_study.py", *words]) if words else "make design-study"
    block = ["", *_table.where_made(cmd, (load0, os.getloadavg()[0]), args.workers), ""] + table(rows, args.held_out) + [""]
    print("\n".join(block))
    if not args.print_only:
        from pes_ref.core.runtime.files import atomic_file
        text = _table.rewrite(Path(args.doc).read_text(), block, BEGIN, END)
        with atomic_file(args.doc, overwrite=True, what="document") as fh:
            fh.write(text.encode())
    return 0


if __name__ == "__main__":
    sys.exit(main())
