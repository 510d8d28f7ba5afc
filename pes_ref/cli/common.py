"""What every command of the command line shares: exit codes, the one-line error, and
how a command's parser is made (help with defaults and examples)."""
from __future__ import annotations

import argparse
import sys
import textwrap

__all__ = ["EXIT_OK", "EXIT_FAIL", "EXIT_ERROR", "EXIT_INTERRUPTED", "error", "add_command", "HelpFormatter"]

EXIT_OK = 0            #: success
EXIT_FAIL = 1          #: a check ran and failed (check, conformance --check), or a design went non-finite
EXIT_ERROR = 2         #: bad input: a refused case, an existing result, a usage error
EXIT_INTERRUPTED = 130  #: stopped by Ctrl-C (SIGINT) or SIGTERM, as shells expect (128 + SIGINT)


def error(exc) -> int:
    """Print exactly one line ``error: <message>`` to stderr; return :data:`EXIT_ERROR`."""
    print("error: " + " ".join(str(exc).split()), file=sys.stderr)
    return EXIT_ERROR


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Descriptions and examples as written; each option's default appended to its help
    (unless the help already states it, or there is none)."""

    def _get_help_string(self, action):
        text = action.help or ""
        default = action.default
        if ("default" in text or default in (None, False, argparse.SUPPRESS) or not action.option_strings
                or isinstance(default, list) and not default):
            return text
        return f"{text} (default: %(default)s)"


def add_command(sub, name: str, *, help: str, description: str, examples=()) -> argparse.ArgumentParser:
    """Add the subcommand ``name`` with an epilog of real invocations."""
    epilog = "examples:\n" + "\n".join(f"  python -m pes_ref {e}" for e in examples) if examples else None
    return sub.add_parser(name, help=help, description=textwrap.fill(description, 88), epilog=epilog,
                          formatter_class=HelpFormatter)
