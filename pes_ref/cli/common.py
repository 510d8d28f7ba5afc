"""What every command of the command line shares: exit codes, the one-line error (with
the library's argument names turned into the command's flags), the checks of input and
output paths made before any computing, and how a command's parser is made (help with
defaults and examples; a usage error is one line too)."""
from __future__ import annotations

import argparse
import os
import re
import sys
import textwrap

__all__ = ["EXIT_OK", "EXIT_FAIL", "EXIT_ERROR", "EXIT_INTERRUPTED", "error", "flag_message", "add_command",
           "HelpFormatter", "Parser", "input_file", "input_folder", "output_file", "output_folder"]

EXIT_OK = 0            #: success
EXIT_FAIL = 1          #: a check ran and failed (check, conformance --check), or a design went non-finite
EXIT_ERROR = 2         #: bad input: a refused case, an existing result, a usage error
EXIT_INTERRUPTED = 130  #: stopped by Ctrl-C (SIGINT) or SIGTERM, as shells expect (128 + SIGINT)


def error(exc, flags: dict | None = None) -> int:
    """Print exactly one line ``error: <message>`` to stderr; return :data:`EXIT_ERROR`.

    ``flags`` maps the library's argument names to the command's own (``{"n_particles":
    "--particles"}``): see :func:`flag_message`.
    """
    print("error: " + " ".join(flag_message(exc, flags or {}).split()), file=sys.stderr)
    return EXIT_ERROR


def flag_message(exc, flags: dict) -> str:
    """The message of ``exc`` in the command's words: when ``exc`` is a keyed input error
    (:class:`pes_ref.core.checks.InputError`), every whole-word mention of an argument it
    names (its ``names``: its key, and any other argument the message mentions) that
    ``flags`` maps becomes the flag (``n_particles must be >= 1, got 0`` ->
    ``--particles must be >= 1, got 0``)."""
    text = str(exc)
    names = getattr(exc, "names", None) or (getattr(exc, "key", None),)
    for name in names:
        if name in flags:
            text = re.sub(rf"(?<![\w-]){re.escape(name)}(?![\w-])", flags[name], text)
    return text


# =========================================================================== paths, checked before computing

def input_file(path: str, what: str) -> str:
    """``path`` if it is a file to read; otherwise the one refusal every command makes
    (``case file x.npz does not exist``)."""
    if not os.path.exists(path):
        raise FileNotFoundError(f"{what} {path} does not exist")
    if os.path.isdir(path):
        raise IsADirectoryError(f"{what} {path} is a folder, not a file")
    if not os.access(path, os.R_OK):
        raise PermissionError(f"{what} {path} is not readable")
    return path


def input_folder(path: str, what: str) -> str:
    """``path`` if it is a folder to read; otherwise one refusal, worded as :func:`input_file`'s."""
    if not os.path.exists(path):
        raise FileNotFoundError(f"{what} {path} does not exist")
    if not os.path.isdir(path):
        raise NotADirectoryError(f"{what} {path} is a file, not a folder")
    return path


def _writable_folder(path: str, folder: str) -> None:
    if not os.path.exists(folder):
        raise FileNotFoundError(f"cannot write {path}: folder {folder} does not exist")
    if not os.path.isdir(folder):
        raise NotADirectoryError(f"cannot write {path}: {folder} is a file, not a folder")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise PermissionError(f"cannot write {path}: folder {folder} is not writable")


def output_file(path: str, what: str, *, force: bool = False) -> str:
    """``path`` if a ``what`` file can be written there: its folder exists and is writable,
    it is not a folder, and it does not exist unless ``force``. Checked before computing,
    so a long run never ends in a refusal."""
    if os.path.isdir(path):
        raise IsADirectoryError(f"cannot write {path}: it is a folder")
    _writable_folder(path, os.path.dirname(os.path.abspath(path)) or os.sep)
    if os.path.lexists(path) and not force:
        raise FileExistsError(f"{what} file {path} exists already; refusing to overwrite it (use --force or "
                              f"another name)")
    return path


def output_folder(path: str) -> str:
    """``path`` if it is a writable folder, or one that can be made in a folder that exists."""
    if os.path.isdir(path):
        _writable_folder(path, path)
    elif os.path.exists(path):
        raise NotADirectoryError(f"cannot write into {path}: it is a file, not a folder")
    else:
        _writable_folder(path, os.path.dirname(os.path.abspath(path)) or os.sep)
    return path


# =========================================================================== parsers


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


class Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line, like every other error:
    ``error: pes_ref oracle: the following arguments are required: FILE (see pes_ref oracle --help)``."""

    def error(self, message):
        print(f"error: {self.prog}: {' '.join(message.split())} (see {self.prog} --help)", file=sys.stderr)
        sys.exit(EXIT_ERROR)


def add_command(sub, name: str, *, help: str, description: str, examples=()) -> argparse.ArgumentParser:
    """Add the subcommand ``name`` with an epilog of real invocations."""
    epilog = "examples:\n" + "\n".join(f"  python -m pes_ref {e}" for e in examples) if examples else None
    return sub.add_parser(name, help=help, description=textwrap.fill(description, 88), epilog=epilog,
                          formatter_class=HelpFormatter)
