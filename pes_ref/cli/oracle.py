"""The ``oracle`` command: ``oracle CASE.npz RESULT.npz [--force]`` runs one case file
(docs/spec.md) and writes its result; a refused case prints one line ``error: <message>``
and exits 2, writing nothing."""
from __future__ import annotations

from pes_ref.cli.common import EXIT_OK, error


def add_parser(sub) -> None:
    p = sub.add_parser(
        "oracle", help="run one case file and write its result file (SPEC section 6)",
        description="Run the case CASE.npz with the reference engine and write RESULT.npz: x, v, energy, "
                    "loss and grad_<name> for every differentiable input the case uses. A case that breaks "
                    "the SPEC is refused with one line 'error: case key ...' on stderr and exit status 2, "
                    "and nothing is written. The result is written to a temporary file and moved into place.")
    p.add_argument("case", metavar="CASE.npz", help="the case file to run")
    p.add_argument("result", metavar="RESULT.npz", help="the result file to write")
    p.add_argument("--force", action="store_true", help="overwrite RESULT.npz if it exists (default: refuse)")
    p.set_defaults(func=_run_oracle)


def _run_oracle(args) -> int:
    from pes_ref.oracle import case as oracle
    try:
        result = oracle.run_case_file(args.case, args.result, overwrite=args.force)
    except (oracle.CaseError, oracle.ResultExistsError, OSError, ValueError, TypeError) as exc:
        return error(exc)
    t1, n = result["x"].shape[:2]
    print(f"wrote {args.result}: T = {t1 - 1}, N = {n}, loss = {float(result['loss']):.17g}")
    return EXIT_OK
