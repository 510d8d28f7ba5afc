"""The ``pes_ref`` command line (``python -m pes_ref COMMAND ...``).

One module per command, each with ``add_parser(subparsers)`` (which sets ``func``, a
handler ``args -> exit code``); :data:`COMMANDS` lists them in the order ``--help``
shows them. Exit codes and the one-line error are in :mod:`pes_ref.cli.common`.
"""
from __future__ import annotations

import argparse
import contextlib
import gc
import os
import sys

from pes_ref import __version__
from pes_ref.cli import analyze, bench, check, conformance, design, evaluate, oracle, sweep
from pes_ref.cli.common import EXIT_ERROR, EXIT_FAIL, EXIT_INTERRUPTED, EXIT_OK, Parser, error
from pes_ref.core.signals import sigterm_interrupts

__all__ = ["main", "build_parser", "command_name", "COMMANDS", "EXIT_OK", "EXIT_FAIL", "EXIT_ERROR", "EXIT_INTERRUPTED"]

#: The commands, in the order of ``--help``.
COMMANDS = (oracle, check, conformance, analyze, design, evaluate, sweep, bench)


def command_name(module) -> str:
    """The name of a command: that of its module (``pes_ref.cli.oracle`` -> ``oracle``)."""
    return module.__name__.rpartition(".")[2]


def _chosen_command(argv) -> str | None:
    """The command that ``argv`` (None: ``sys.argv[1:]``) names by its first word, or None
    (``--help``, ``--version``, no word, a word that is no command)."""
    words = sys.argv[1:] if argv is None else list(argv)
    names = {command_name(m) for m in COMMANDS}
    return words[0] if words and words[0] in names else None


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser with every command of :data:`COMMANDS`, or only with
    ``command`` (one of their names): :func:`main` builds just the command it runs, since
    building all of them (their help, choices and defaults) would cost every run,
    ``oracle`` included, several milliseconds."""
    parser = Parser(
        prog="pes_ref", formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Reference implementation of potential energy surfaces (Manion & Fuge, DETC2021): "
                    "the oracle of docs/spec.md and its tools.",
        epilog="examples:\n  python -m pes_ref conformance --check\n  python -m pes_ref design funnel --smoke "
               "--out funnel.npz\n\n'python -m pes_ref COMMAND --help' shows a command's options and examples.")
    parser.add_argument("--version", action="version", version=f"pes_ref {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", title="commands",
                                help="the command to run (see below)")
    sub.required = True
    for module in COMMANDS:
        if command is None or command_name(module) == command:
            module.add_parser(sub)
    return parser


def _freeze_start_up() -> None:
    """Move every object that start-up made (NumPy, the parser, ...) to the cyclic
    collector's permanent generation (:func:`gc.freeze`): they live until the process
    ends, so the collector need not walk them again, during the run or at exit. A
    program's run only (``main()`` without ``argv``): ~15 ms, over a tenth, of ``python -m
    pes_ref oracle`` on the paper-sized funnel (:mod:`pes_ref.bench.oracle_cli`)."""
    gc.freeze()


def main(argv=None) -> int:
    """Run the command line; return the exit status (0 ok, 1 check failed, 2 error, 130 interrupted).

    No traceback reaches the user: a closed pipe (``pes_ref evaluate F | head -1``) ends
    quietly as the Python docs recommend for SIGPIPE; Ctrl-C and SIGTERM end with 130
    after the command has saved what it can; anything unexpected is one ``error:`` line
    (set ``PES_REF_DEBUG=1`` to see the traceback).
    """
    parser = build_parser(_chosen_command(argv))
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:   # --help, --version, usage errors
        return exc.code if isinstance(exc.code, int) else EXIT_OK
    if argv is None:
        _freeze_start_up()
    try:
        with sigterm_interrupts() if argv is None else contextlib.nullcontext():   # SIGTERM stops as Ctrl-C does
            status = args.func(args)
        sys.stdout.flush()
        return status
    except BrokenPipeError:
        devnull = os.open(os.devnull, os.O_WRONLY)   # Python docs, "Note on SIGPIPE"
        os.dup2(devnull, sys.stdout.fileno())
        return EXIT_FAIL
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:   # the last line of defence: no traceback for a user
        if os.environ.get("PES_REF_DEBUG"):
            raise
        return error(f"internal error ({type(exc).__name__}: {exc}); please report it, with the command "
                     f"(PES_REF_DEBUG=1 shows the traceback)")
