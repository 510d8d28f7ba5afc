"""The ``bench`` command of ``python -m pes_ref``.

``bench [--quick] [--out FILE.json] [--force] [--no-autodiff]`` runs
[`pes_ref.bench.benchmark`][pes_ref.bench.benchmark], prints its
tables and writes the results as JSON plus a scaling plot beside it. Without ``--out``
the results go to ``bench/out/bench.json`` and ``bench/out/scaling.png``, the bench's own
(git-ignored) output folder, replaced on every run; a file named with ``--out`` that
exists is refused unless ``--force``.
"""
from __future__ import annotations

import os
import sys

from pes_ref.cli.common import EXIT_FAIL, EXIT_OK, add_command, error, output_file

#: Where ``make bench`` leaves its results (git-ignored).
DEFAULT_OUT = os.path.join("bench", "out", "bench.json")


def add_parser(sub) -> None:
    p = add_command(sub, "bench", help="time the engine and write the numbers (what accuracy and each effect cost)",
        description="Time the forward and adjoint passes (N = 1 .. 65536 particles on a 200 x 200 grid, dynamic "
                    "and quasistatic), peak memory, the cost of each effect, the growth with N and T, and the "
                    "funnel and oscillator design gradients against autograd and JAX where installed. Prints "
                    "tables and writes JSON plus a scaling plot. Medians over repeats, with min and max. "
                    f"Default output: {DEFAULT_OUT} (replaced on every run).",
        examples=['bench --quick --out /tmp/bench.json', 'bench'])
    p.add_argument("--quick", action="store_true", help="tiny sizes: a smoke run of every section (seconds)")
    p.add_argument("--out", metavar="FILE.json", default=None,
                   help=f"write the results here (default {DEFAULT_OUT}); the plot goes beside it")
    p.add_argument("--force", action="store_true", help="replace an existing --out file")
    p.add_argument("--no-autodiff", action="store_true",
                   help="do not run the autograd and JAX versions (reported as skipped)")
    p.set_defaults(func=_run_bench)


def _run_bench(args) -> int:
    from pes_ref.bench import benchmark as bench, outputs, report
    out = args.out or DEFAULT_OUT
    overwrite = args.force or args.out is None
    if args.out is not None:            # refused before the (long) run; the default folder is made if missing
        try:
            for path, what in zip(outputs.output_paths(out), ("results", "plot")):
                output_file(path, what, force=args.force)
        except OSError as exc:
            return error(exc)
    import dataclasses
    cfg = bench.QUICK if args.quick else bench.FULL
    if args.no_autodiff:
        cfg = dataclasses.replace(cfg, autodiff=False)
    res = bench.run(cfg)
    print()
    print(report.format_report(res))
    try:
        json_path, png = outputs.write_outputs(res, out, overwrite=overwrite)
    except OSError as exc:
        return error(exc)
    print(f"wrote {json_path} and {png}")
    wrong = [f"{row['case']} by {lib} (relative error {row[lib]['relative_error']:.2g} > {row[lib]['tolerance']:g})"
             for row in res["design"] for lib in ("autograd", "jax") if row[lib]["status"] == "mismatch"]
    if wrong:
        print(f"error: the design gradient differs from pes_ref's: {'; '.join(wrong)}", file=sys.stderr)
        return EXIT_FAIL
    return EXIT_OK
