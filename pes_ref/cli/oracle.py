"""The ``oracle`` command: runs case files (docs/spec.md section 8) and writes their
results (section 9). ``oracle CASE.npz RESULT.npz [CASE.npz RESULT.npz ...]`` takes
pairs; ``oracle CASE.npz ... --out-dir DIR`` writes ``DIR/<case name>.result.npz`` for
each case. Many cases in one process pay the start-up once. A refused case prints one
line ``error: <message>`` and writes nothing; the exit status is 2 if any case was
refused."""
from __future__ import annotations

import os

from pes_ref.core.runtime.progress import ProgressWriter
from pes_ref.oracle.conformance import LATEST
from pes_ref.cli.common import EXIT_ERROR, EXIT_OK, add_command, error, output_file
from pes_ref.cli.files import expect


#: The shipped vectors of the newest set, as a path from the repository's root (for the examples).
_VECTORS = f"pes_ref/oracle/conformance/{LATEST}"


def add_parser(sub) -> None:
    p = add_command(sub, "oracle", help="run case files and write their result files (docs/spec.md)",
        description="Run each case with the reference engine and write its result: x, v, energy, loss and "
                    "grad_<name> for every differentiable input the case uses (docs/spec.md sections 8-9). "
                    "A case that breaks the spec is refused with one line 'error: case key ...' on stderr and "
                    "nothing is written for it; the exit status is then 2. Each result is written to a "
                    "temporary file and moved into place.",
        examples=[f"oracle {_VECTORS}/plane-dynamic.case.npz result.npz",
                  f"oracle {_VECTORS}/plane-dynamic.case.npz {_VECTORS}/spring-per-particle-torus.case.npz "
                  "--out-dir ."])
    p.add_argument("files", nargs="+", metavar="FILE",
                   help="CASE.npz RESULT.npz pairs, or (with --out-dir) case files")
    p.add_argument("--out-dir", default=None, metavar="DIR",
                   help="write DIR/<case name>.result.npz for each case file given")
    p.add_argument("--force", action="store_true", help="overwrite results that exist (default: refuse)")
    p.add_argument("--compress", action="store_true",
                   help="deflate the result's arrays (default: stored; float64 data barely compresses and "
                        "deflating costs more than the computation of a paper-sized case)")
    p.add_argument("--refusals", default=None, metavar="FILE.jsonl",
                   help="also append one JSON line per refused case to FILE.jsonl: {\"case\": its path, \"key\": "
                        "the key at fault or null, \"error\": \"ValueError\" or \"TypeError\", \"message\": ...} "
                        "(docs/spec.md section 13; pes_ref check --cmd '... --refusals {refusals} ...')")
    p.add_argument("--allow-unstable", action="store_true",
                   help="run a case past the stability limit of its stiffest term anyway (docs/spec.md section 10; "
                        "not part of the contract, which refuses it)")
    p.add_argument("--backend", choices=["numpy", "numba"], default="numpy",
                   help="the loops that run the cases: 'numpy' (default; imports no compiler) or 'numba' (compiled, "
                        "the extra 'fast'; the same trajectories, gradients to 1e-13 of their largest entry)")
    p.set_defaults(func=_run_oracle)


def _result_name(case_path: str, out_dir: str) -> str:
    name = os.path.basename(case_path)
    for suffix in (".case.npz", ".npz"):
        if name.endswith(suffix):
            name = name[: -len(suffix)]
            break
    return os.path.join(out_dir, name + ".result.npz")


def _pairs(args) -> list:
    if args.out_dir is not None:
        return [(c, _result_name(c, args.out_dir)) for c in args.files]
    if len(args.files) % 2:
        raise ValueError(f"oracle takes CASE.npz RESULT.npz pairs (or case files with --out-dir); got "
                         f"{len(args.files)} file names")
    return list(zip(args.files[::2], args.files[1::2]))


def _check_files(case_path: str, result_path: str, force: bool) -> None:
    """Refuse before computing, once: the case must be a readable file and no file of another
    kind (a design or a result: `pes_ref.cli.files.expect`); the result's folder must exist
    and be writable, an existing result is kept unless ``--force``, and the result is never
    the case file itself."""
    expect(case_path, "case")
    output_file(result_path, "result", force=force)
    if os.path.exists(result_path) and os.path.samefile(case_path, result_path):
        raise ValueError(f"the result path {result_path} is the case file itself")


def _record_refusal(path: str, case_path: str, exc: Exception) -> None:
    """Append the refusal of ``case_path`` to the ``--refusals`` file as one JSON line
    (docs/spec.md section 13): its key (None for a file that is no case, or a result
    that cannot be written) and its kind: ``TypeError`` or ``ValueError`` for a refused
    case, the exception's name for a file that cannot be read or written."""
    import json
    kind = next((k.__name__ for k in (TypeError, ValueError) if isinstance(exc, k)), type(exc).__name__)
    record = {"case": case_path, "key": getattr(exc, "key", None), "error": kind, "message": str(exc)}
    with open(path, "a", encoding="utf-8") as fh:
        fh.write(json.dumps(record) + "\n")


def _run_oracle(args) -> int:
    from pes_ref.oracle import case as oracle
    from pes_ref.oracle.monitor import monitor
    try:
        pairs = _pairs(args)
        if args.refusals is not None:
            output_file(args.refusals, "--refusals file", force=True)     # appended to if it exists
    except (OSError, ValueError) as exc:
        return error(exc)
    status = EXIT_OK
    for case_path, result_path in pairs:
        try:
            _check_files(case_path, result_path, args.force)
            lines = ProgressWriter()
            try:
                result = oracle.run_case(oracle.load_case(case_path), allow_unstable=args.allow_unstable,
                                         monitor=monitor(case_path, lines), backend=args.backend)
            finally:
                lines.end()             # the last progress line stays, whole, before anything else is printed
            oracle.write_result(result, result_path, overwrite=args.force, compress=args.compress)
        except (oracle.CaseError, oracle.ResultExistsError, OSError, ValueError, TypeError) as exc:
            status = error(f"{case_path}: {exc}" if len(pairs) > 1 else exc)
            if args.refusals is not None:
                _record_refusal(args.refusals, case_path, exc)
            continue
        t1, n = result["x"].shape[:2]
        print(f"wrote {result_path}: T = {t1 - 1}, N = {n}, loss = {float(result['loss']):.17g}")
    return status if status == EXIT_OK else EXIT_ERROR
