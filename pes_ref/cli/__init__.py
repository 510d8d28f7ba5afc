"""The ``pes_ref`` command line (``python -m pes_ref COMMAND ...``).

One module per command, each with ``add_parser(subparsers)`` (which sets ``func``, a
handler ``args -> exit code``); `COMMANDS` names them, in the order ``--help``
shows them, with the module of each, which is imported only when its command runs (or
when ``--help`` lists them all). Exit codes, the one-line error and the rule for a
closed pipe are in [`pes_ref.cli.common`][pes_ref.cli.common].
"""
from __future__ import annotations

import argparse
import contextlib
import gc
import importlib
import os
import sys

from pes_ref import __version__
from pes_ref.cli.common import (DEBUG_VARIABLE, EXIT_ERROR, EXIT_FAIL, EXIT_INTERRUPTED, EXIT_OK, EXIT_PIPE, Parser,
                                error, watch_pipes)
from pes_ref.core.runtime.signals import interrupted, sigterm_interrupts

__all__ = ["main", "build_parser", "command_module", "COMMANDS", "EXIT_OK", "EXIT_FAIL", "EXIT_ERROR",
           "EXIT_INTERRUPTED", "EXIT_PIPE"]

#: Each command's name and its module, in the order of ``--help``.
COMMANDS = {name: f"pes_ref.cli.{name}"
            for name in ("oracle", "check", "conformance", "analyze", "design", "evaluate", "realize", "sweep",
                                  "bench")}


def command_module(name: str):
    """The module of the command ``name`` (imported on first use)."""
    return importlib.import_module(COMMANDS[name])


def _chosen_command(argv) -> str | None:
    """The command that ``argv`` (None: ``sys.argv[1:]``) names by its first word, or None
    (``--help``, ``--version``, no word, a word that is no command)."""
    words = sys.argv[1:] if argv is None else list(argv)
    return words[0] if words and words[0] in COMMANDS else None


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser with every command of `COMMANDS`, or only with
    ``command`` (one of their names): [`main`][pes_ref.cli.main] imports and builds just the command it
    runs, since importing and building all of them (their help, choices and defaults)
    would cost every run, ``oracle`` included, several milliseconds."""
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
    for name in COMMANDS:
        if command is None or name == command:
            command_module(name).add_parser(sub)
    return parser


def _freeze_start_up() -> None:
    """Move every object that start-up made (NumPy, the parser, ...) to the cyclic
    collector's permanent generation (`gc.freeze`): they live until the process
    ends, so the collector need not walk them again, during the run or at exit. A
    program's run only (``main()`` without ``argv``): ~15 ms, over a tenth, of ``python -m
    pes_ref oracle`` on the paper-sized funnel ([`pes_ref.bench.oracle_cli`][pes_ref.bench.oracle_cli])."""
    gc.freeze()


def main(argv=None) -> int:
    """Run the command line; return the exit status (0 ok, 1 check failed, 2 error, 130
    interrupted, 141 closed pipe).

    No traceback reaches the user: Ctrl-C and SIGTERM end with 130 after the command has
    saved what it can (while the command's modules are imported too: `pes_ref.__main__`);
    a closed pipe (``pes_ref evaluate F | head -1``) follows the one rule of
    [`pes_ref.cli.common.watch_pipes`][pes_ref.cli.common.watch_pipes]; anything unexpected is one ``error:`` line (set
    ``PES_REF_DEBUG=1`` to see the traceback).
    """
    with watch_pipes(program=argv is None) as pipes:
        try:
            status = _run(argv)
            sys.stdout.flush()
        except BrokenPipeError:         # a call with argv: its caller's streams are not watched
            status = EXIT_PIPE
        except KeyboardInterrupt:
            status = _interrupted(pipes)
        except Exception as exc:        # the last line of defence: no traceback for a user
            if interrupted():           # Ctrl-C, which an extension's import turned into another error
                status = _interrupted(pipes)
            elif os.environ.get(DEBUG_VARIABLE, "") not in ("", "0"):
                raise
            else:
                status = error(f"internal error ({type(exc).__name__}: {exc}); please report it, with the "
                               f"command (PES_REF_DEBUG=1 shows the traceback)")
        return EXIT_PIPE if pipes.closed else status


def _interrupted(pipes) -> int:
    if not pipes.closed:
        print("interrupted", file=sys.stderr)
    return EXIT_INTERRUPTED


def _run(argv) -> int:
    parser = build_parser(_chosen_command(argv))
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:   # --help, --version, usage errors
        return exc.code if isinstance(exc.code, int) else EXIT_OK
    if argv is None:
        _freeze_start_up()
    with sigterm_interrupts() if argv is None else contextlib.nullcontext():   # SIGTERM stops as Ctrl-C does
        return args.func(args)
