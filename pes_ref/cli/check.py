"""The ``check`` command: conformance of any program, in any language, through its
command line ([`pes_ref.testing.check`][pes_ref.testing.check], docs/spec.md section 13)."""
from __future__ import annotations

import os
import shlex
import shutil
import sys

from pes_ref.cli.common import EXIT_FAIL, EXIT_OK, add_command, error, input_file, output_file, output_folder


def add_parser(sub) -> None:
    p = add_command(sub, "check", help="check another implementation's program against the vectors and fresh random cases",
        description="Run PROGRAM on every shipped conformance vector (valid ones compared with the reference "
                    "result within the tolerances of docs/spec.md section 11; invalid ones must exit non-zero, "
                    "write nothing and name the key at fault on stderr) and on N fresh random cases drawn "
                    "from pes_ref's own distribution (well-conditioned ones only), computed by pes_ref too. "
                    "Prints one line per case (valid vectors, invalid vectors, random cases) and "
                    "'N passed, M failed'; exits 0 only when every case passes. docs/spec.md section 13 "
                    "describes the protocol.",
        examples=['check --cmd "python -m pes_ref oracle {case} {result}" --only plane-dynamic --only mass-zero',
                  'check --cmd "python -m pes_ref oracle {pairs}" --no-vectors --random 5 --seed 1 --report check.json',
                  'check --cmd "python -m pes_ref oracle --refusals {refusals} {pairs}" --strict '
                  '--only wall-onset-dynamic --only mass-bool'])
    p.add_argument("--cmd", default=None, metavar="TEMPLATE",
                   help="the program: {case} and {result} are replaced by one case's paths (one process per "
                        "case), or {pairs} by CASE1 RESULT1 CASE2 RESULT2 ... (one process for the valid cases, "
                        "one for the invalid ones); {refusals} by a file where the program records each case it "
                        "refuses as a JSON line {\"case\", \"key\", \"error\"} (needed by --strict)")
    p.add_argument("--random", type=int, default=0, metavar="N", help="fresh random cases to draw (default 0)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random cases (default 0)")
    p.add_argument("--no-vectors", action="store_true", help="skip the shipped vectors")
    p.add_argument("--only", action="append", default=None, metavar="ID",
                   help="run only this vector (repeatable; --list shows the ids)")
    p.add_argument("--list", action="store_true", help="list the shipped vectors (id, kind, flags, what each "
                   "covers) and exit")
    p.add_argument("--strict", action="store_true",
                   help="docs/spec.md section 11's strict mode: gradients on kinks compared with the reference's "
                        "one-sided choice, and each refusal's error kind (TypeError or ValueError) compared with "
                        "the manifest's (needs {refusals} in --cmd)")
    p.add_argument("--lenient-messages", action="store_true",
                   help="do not require a refusal to name the key at fault (for a program that conforms at "
                        "levels S and G only)")
    p.add_argument("--timeout", type=float, default=60.0, metavar="SECONDS",
                   help="time allowed per case (default 60)")
    p.add_argument("--report", default=None, metavar="FILE.json", help="write a JSON report")
    p.add_argument("--force", action="store_true", help="replace an existing --report file")
    p.add_argument("--keep", default=None, metavar="DIR", help="keep each failing case in DIR with reproduce.sh")
    p.add_argument("--quiet", action="store_true", help="print only failures and the closing line")
    p.set_defaults(func=_run_check)


def _program(template: str) -> None:
    """Refuse a --cmd whose program cannot start, before any case is run."""
    try:
        argv = shlex.split(template)
    except ValueError as exc:
        raise ValueError(f"--cmd {template!r}: {exc}") from None
    if not argv:
        raise ValueError("--cmd is empty; give the program and its arguments, e.g. './my_impl {case} {result}'")
    program = argv[0]
    if os.sep in program:
        input_file(program, "--cmd: program")
    elif shutil.which(program) is None:
        raise FileNotFoundError(f"--cmd: program {program} not found on the PATH")


def _only(ids, version: str) -> None:
    """Refuse an --only id that no shipped vector has, suggesting the closest ids."""
    import difflib

    from pes_ref.testing.conformance import load_manifest
    known = [e["id"] for e in load_manifest(version)["vectors"]]
    for vid in ids:
        if vid not in known:
            close = difflib.get_close_matches(vid, known, n=3)
            hint = f"did you mean {', '.join(close)}? " if close else ""
            raise ValueError(f"--only {vid!r}: no vector of {version} has this id; {hint}"
                             f"'pes_ref check --list' lists them")


def _list(version: str) -> int:
    """Print every shipped vector: id, kind, flags (and the key at fault), what it covers."""
    from pes_ref.testing.conformance import load_manifest
    for e in load_manifest(version)["vectors"]:
        what = e["kind"] + (f" ({e['key'] or 'no key'})" if e["kind"] == "invalid" else "")
        flags = ",".join(e.get("flags", ())) or "-"
        print(f"{e['id']:40s} {what:26s} {flags:12s} {e['comment']}")
    return EXIT_OK


def _run_check(args) -> int:
    from pes_ref.oracle.conformance import LATEST
    from pes_ref.testing import check as chk
    if args.list:
        return _list(LATEST)
    try:
        if args.cmd is None:
            raise ValueError("--cmd is required: the program to check, e.g. --cmd './my_impl {case} {result}'")
        if args.random < 0:
            raise ValueError(f"--random must be >= 0, got {args.random}")
        if args.seed < 0:
            raise ValueError(f"--seed must be >= 0, got {args.seed}")
        if not args.timeout > 0:
            raise ValueError(f"--timeout must be > 0 seconds, got {args.timeout}")
        if args.no_vectors and args.random == 0:
            raise ValueError("--no-vectors with --random 0 leaves nothing to check")
        chk.Program(args.cmd, args.timeout, strict=args.strict)
        _program(args.cmd)
        if args.only:
            _only(args.only, LATEST)
        if args.report:
            output_file(args.report, "report", force=args.force)
        if args.keep:
            output_folder(args.keep)
    except (OSError, ValueError) as exc:
        return error(exc)

    def show(outcome):
        if not args.quiet or not outcome.ok:
            print(outcome.line(), flush=True)
    try:
        if args.random:
            print(f"drawing {args.random} random cases (seed {args.seed}; conditioning bound "
                  f"{chk.CONDITION_BOUND:g}: a {chk.PROBE:g} perturbation of x0 may grow at most that much)",
                  file=sys.stderr, flush=True)
        report = chk.check(args.cmd, vectors=not args.no_vectors, random=args.random, seed=args.seed,
                           timeout=args.timeout, keep=args.keep, only=args.only, progress=show,
                           strict=args.strict, lenient_messages=args.lenient_messages)
        if args.report:
            chk.write_report(report, args.report, overwrite=args.force)
    except (ValueError, ImportError, RuntimeError, OSError) as exc:
        return error(exc)
    seconds = sum(b["seconds"] for b in report.batches)
    print(f"{len(report.outcomes)} cases in {len(report.batches)} processes of the program, {seconds:.1f} s",
          file=sys.stderr)
    print(report.summary())
    return EXIT_OK if report.ok else EXIT_FAIL
