"""The ``pes_ref`` command line (``python -m pes_ref COMMAND ...``).

One module per command, each with ``add_parser(subparsers)`` (which sets ``func``, a
handler ``args -> exit code``); :data:`COMMANDS` lists them in the order ``--help``
shows them. Exit codes and the one-line error are in :mod:`pes_ref.cli.common`.
"""
from __future__ import annotations

import argparse

from pes_ref import __version__
from pes_ref.cli import analyze, bench, conformance, design, evaluate, oracle, sweep
from pes_ref.cli.common import EXIT_ERROR, EXIT_FAIL, EXIT_OK

__all__ = ["main", "build_parser", "COMMANDS", "EXIT_OK", "EXIT_FAIL", "EXIT_ERROR"]

#: The commands, in the order of ``--help``.
COMMANDS = (oracle, conformance, analyze, design, evaluate, sweep, bench)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every command of :data:`COMMANDS`."""
    parser = argparse.ArgumentParser(
        prog="pes_ref",
        description="Reference implementation of potential energy surfaces (Manion & Fuge, DETC2021): "
                    "the oracle of docs/spec.md and its tools.")
    parser.add_argument("--version", action="version", version=f"pes_ref {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", title="commands")
    sub.required = True
    for module in COMMANDS:
        module.add_parser(sub)
    return parser


def main(argv=None) -> int:
    """Run the command line; return the exit status (0 ok, 1 check failed, 2 error)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:   # --help, --version, usage errors
        return exc.code if isinstance(exc.code, int) else EXIT_OK
    return args.func(args)
