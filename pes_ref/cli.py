"""The ``pes_ref`` command line (``python -m pes_ref COMMAND ...``).

Commands:

- ``oracle CASE.npz RESULT.npz [--force]``: run one case file (SPEC section 6) and write
  its result; a refused case prints one line ``error: <message>`` and exits 2,
  writing nothing.
- ``conformance --write [DIR] | --check [DIR]``: regenerate the conformance vectors, or
  regenerate them into a scratch folder and compare them with the shipped ones.

Each command is one ``_add_<name>(subparsers)`` function registered with
:func:`command` that sets ``func`` to a handler ``args -> exit code``. Commands of their
own topic live in their own module, imported by :func:`build_parser`:
``pes_ref.cli_analyze`` (``analyze``), ``pes_ref.cli_design`` (``design``,
``evaluate``) and ``pes_ref.cli_bench`` (``bench``).
"""
from __future__ import annotations

import argparse
import importlib
import sys
import tempfile

from . import __version__

__all__ = ["main", "build_parser", "command", "EXIT_OK", "EXIT_FAIL", "EXIT_ERROR"]

EXIT_OK = 0      #: success
EXIT_FAIL = 1    #: a check ran and failed (conformance --check)
EXIT_ERROR = 2   #: bad input: a refused case, an existing result, a usage error

_COMMANDS = []

#: Modules that register further commands with :func:`command` when imported.
COMMAND_MODULES = ("pes_ref.cli_analyze", "pes_ref.cli_design", "pes_ref.cli_bench")


def command(add):
    """Register ``add(subparsers)``, which adds one subcommand to the parser."""
    _COMMANDS.append(add)
    return add


def _error(exc) -> int:
    """Print exactly one line ``error: <message>`` to stderr; return EXIT_ERROR."""
    print("error: " + " ".join(str(exc).split()), file=sys.stderr)
    return EXIT_ERROR


# =========================================================================== oracle

@command
def _add_oracle(sub) -> None:
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
    from . import oracle
    try:
        result = oracle.run_case_file(args.case, args.result, overwrite=args.force)
    except (oracle.CaseError, oracle.ResultExistsError, OSError, ValueError, TypeError) as exc:
        return _error(exc)
    t1, n = result["x"].shape[:2]
    print(f"wrote {args.result}: T = {t1 - 1}, N = {n}, loss = {float(result['loss']):.17g}")
    return EXIT_OK


# =========================================================================== conformance

@command
def _add_conformance(sub) -> None:
    from .conformance.generate import VERSION
    p = sub.add_parser(
        "conformance", help="write or check the shipped conformance vectors",
        description="The conformance vectors are oracle cases with their reference results and invalid "
                    "cases, listed in manifest.json (pes_ref/conformance/<version>/). --write regenerates "
                    "them; --check regenerates them into a temporary folder and compares them with the "
                    "shipped ones (cases identical, results within the SPEC's tolerances), printing one "
                    "line per vector; it exits 1 if any differs.")
    mode = p.add_mutually_exclusive_group(required=True)
    mode.add_argument("--write", nargs="?", const="", default=None, metavar="DIR",
                      help="regenerate the vectors into DIR (default: the package's own folder)")
    mode.add_argument("--check", nargs="?", const="", default=None, metavar="DIR",
                      help="compare freshly generated vectors with those in DIR (default: the shipped ones)")
    p.add_argument("--vectors", default=VERSION, choices=[VERSION],
                   help=f"the vector set version (default {VERSION}; only the newest can be generated)")
    p.add_argument("--quiet", action="store_true", help="print only the summary line")
    p.set_defaults(func=_run_conformance)


def _run_conformance(args) -> int:
    from .conformance import generate, vectors_dir
    if args.write is not None:
        target = args.write or vectors_dir(args.vectors)
        try:
            manifest = generate.write_vectors(target, quiet=args.quiet)
        except OSError as exc:
            return _error(exc)
        entries = manifest["vectors"]
        n_valid = sum(e["kind"] == "valid" for e in entries)
        print(f"wrote {len(entries)} vectors ({n_valid} valid, {len(entries) - n_valid} invalid) to {target}")
        return EXIT_OK
    shipped = args.check or vectors_dir(args.vectors)
    with tempfile.TemporaryDirectory(prefix="pes_ref-conformance-") as fresh:
        generate.write_vectors(fresh)
        try:
            rows = generate.compare_dirs(shipped, fresh)
        except OSError as exc:
            return _error(exc)
    for vid, ok, err, detail in rows:
        if not args.quiet or not ok:
            print(f"{'ok' if ok else 'FAIL':4s}  {vid:40s} max rel err {err:.1e}" + ("" if ok else f"  {detail}"))
    failed = [r for r in rows if not r[1]]
    if failed:
        print(f"conformance check FAILED: {len(failed)} of {len(rows)} vectors differ from {shipped}")
        return EXIT_FAIL
    print(f"conformance check ok: {len(rows)} vectors match {shipped}")
    return EXIT_OK


# =========================================================================== entry point

def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every registered command."""
    parser = argparse.ArgumentParser(
        prog="pes_ref",
        description="Reference implementation of potential energy surfaces (Manion & Fuge, DETC2021): "
                    "the oracle of SPEC.md and its tools.")
    parser.add_argument("--version", action="version", version=f"pes_ref {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", title="commands")
    sub.required = True
    for module in COMMAND_MODULES:
        importlib.import_module(module)
    for add in _COMMANDS:
        add(sub)
    return parser


def main(argv=None) -> int:
    """Run the command line; return the exit status (0 ok, 1 check failed, 2 error)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:   # --help, --version, usage errors
        return exc.code if isinstance(exc.code, int) else EXIT_OK
    return args.func(args)
