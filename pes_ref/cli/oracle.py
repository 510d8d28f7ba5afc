"""The ``oracle`` command: runs case files (docs/spec.md section 8) and writes their
results (section 9). ``oracle CASE.npz RESULT.npz [CASE.npz RESULT.npz ...]`` takes
pairs; ``oracle CASE.npz ... --out-dir DIR`` writes ``DIR/<case name>.result.npz`` for
each case. Many cases in one process pay the start-up once. A refused case prints one
line ``error: <message>`` and writes nothing; the exit status is 2 if any case was
refused."""
from __future__ import annotations

import os
import zipfile

from pes_ref.oracle.conformance import LATEST
from pes_ref.cli.common import EXIT_ERROR, EXIT_OK, add_command, error, input_file, output_file


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
    """Refuse before computing: the case must be a readable file and not a design file;
    the result's folder must exist and be writable, and an existing result is kept
    unless ``--force``."""
    from pes_ref.synthesis.design_file import is_design_file
    input_file(case_path, "case file")
    if is_design_file(case_path):
        raise ValueError(f"{case_path} is a design file, not a case; evaluate reads it: "
                         f"python -m pes_ref evaluate {case_path}")
    if _is_result_file(case_path):
        raise ValueError(f"{case_path} is an oracle result file, not a case (the oracle wrote it)")
    output_file(result_path, "result", force=force)


#: Members every result file holds and no case does.
_RESULT_MEMBERS = {"x.npy", "v.npy", "energy.npy", "loss.npy"}


def _is_result_file(path: str) -> bool:
    """Whether ``path`` is a zip holding a result's members (only its directory is read)."""
    try:
        with zipfile.ZipFile(path) as z:
            return _RESULT_MEMBERS <= set(z.namelist())
    except (zipfile.BadZipFile, OSError):
        return False


def _run_oracle(args) -> int:
    from pes_ref.oracle import case as oracle
    try:
        pairs = _pairs(args)
    except ValueError as exc:
        return error(exc)
    status = EXIT_OK
    for case_path, result_path in pairs:
        try:
            _check_files(case_path, result_path, args.force)
            result = oracle.run_case_file(case_path, result_path, overwrite=args.force)
        except (oracle.CaseError, oracle.ResultExistsError, OSError, ValueError, TypeError) as exc:
            status = error(f"{case_path}: {exc}" if len(pairs) > 1 else exc)
            continue
        t1, n = result["x"].shape[:2]
        print(f"wrote {result_path}: T = {t1 - 1}, N = {n}, loss = {float(result['loss']):.17g}")
    return status if status == EXIT_OK else EXIT_ERROR
