"""What every command of the command line shares: exit codes, the one-line error (with
the library's argument names turned into the command's flags), the rule for a closed pipe
([`watch_pipes`][pes_ref.cli.common.watch_pipes]), the checks of input and output paths made before any computing,
and how a command's parser is made (help with defaults and examples; a usage error is
one line too)."""
from __future__ import annotations

import argparse
import contextlib
import dataclasses
import importlib
import os
import re
import signal
import sys
import textwrap
import threading
from collections.abc import Callable

__all__ = ["EXIT_OK", "EXIT_FAIL", "EXIT_ERROR", "EXIT_INTERRUPTED", "EXIT_PIPE", "DEBUG_VARIABLE", "error",
           "flag_message",
           "watch_pipes", "add_command",
           "HelpFormatter", "Parser", "input_file", "input_folder", "output_file", "output_folder", "LazyDefault",
           "LazyChoices", "LazyHelp", "option_text"]

EXIT_OK = 0            #: success
EXIT_FAIL = 1          #: a check ran and failed (check, conformance --check), or a design went non-finite
EXIT_ERROR = 2         #: bad input: a refused case, an existing result, a usage error
EXIT_INTERRUPTED = 130  #: stopped by Ctrl-C (SIGINT) or SIGTERM, as shells expect (128 + SIGINT)
EXIT_PIPE = 141        #: stopped because the reader of stdout or stderr closed the pipe (128 + SIGPIPE)


#: The environment variable that shows a caught error's traceback before its line (README, "At the command line").
DEBUG_VARIABLE = "PES_REF_DEBUG"


def error(exc, flags: dict | None = None) -> int:
    """Print exactly one line ``error: <message>`` to stderr; return `EXIT_ERROR`.

    ``flags`` maps the library's argument names to the command's own (``{"n_particles":
    "--particles"}``): see [`flag_message`][pes_ref.cli.common.flag_message]. With
    ``PES_REF_DEBUG=1`` in the environment (`DEBUG_VARIABLE`) an exception's traceback is printed
    first: what was caught and where, for a report.
    """
    if isinstance(exc, BaseException) and os.environ.get(DEBUG_VARIABLE, "") not in ("", "0"):
        import traceback
        traceback.print_exception(type(exc), exc, exc.__traceback__, file=sys.stderr)
    print("error: " + " ".join(flag_message(exc, flags or {}).split()), file=sys.stderr)
    return EXIT_ERROR


def flag_message(exc, flags: dict) -> str:
    """The message of ``exc`` in the command's words: when ``exc`` is a keyed input error
    ([`pes_ref.core.checks.InputError`][pes_ref.core.checks.InputError]), every whole-word mention of an argument it
    names (its ``names``: its key, and any other argument the message mentions) that
    ``flags`` maps becomes the flag (``n_particles must be >= 1, got 0`` ->
    ``--particles must be >= 1, got 0``)."""
    text = str(exc)
    names = getattr(exc, "names", None) or (getattr(exc, "key", None),)
    for name in names:
        if name in flags:
            text = re.sub(rf"(?<![\w-]){re.escape(name)}(?![\w-])", flags[name], text)
    return text


# =========================================================================== a closed pipe

class _Watched:
    """``sys.stdout`` or ``sys.stderr`` of a program run, as [`watch_pipes`][pes_ref.cli.common.watch_pipes] watches it."""

    def __init__(self, stream, pipes):
        self._stream, self._pipes = stream, pipes

    def write(self, text):
        if not self._pipes.closed:
            try:
                return self._stream.write(text)
            except BrokenPipeError:
                self._pipes.close(self._stream)
        return len(text)

    def writelines(self, lines):
        for line in lines:
            self.write(line)

    def flush(self):
        if not self._pipes.closed:
            try:
                self._stream.flush()
            except BrokenPipeError:
                self._pipes.close(self._stream)

    def __getattr__(self, name):
        return getattr(self._stream, name)


class _Pipes:
    """Whether a watched stream met a closed pipe (``closed``), and what follows ([`watch_pipes`][pes_ref.cli.common.watch_pipes])."""

    def __init__(self):
        self.closed = False

    def close(self, stream) -> None:
        self.closed = True
        try:                            # later writes, the interpreter's last flush too, go nowhere
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, stream.fileno())
            os.close(devnull)
        except (OSError, ValueError):
            pass
        handler = signal.getsignal(signal.SIGINT)
        if callable(handler):
            signal.raise_signal(signal.SIGINT)      # stop as Ctrl-C stops the command
        elif threading.current_thread() is threading.main_thread():
            raise KeyboardInterrupt


@contextlib.contextmanager
def watch_pipes(program: bool = True):
    """The one rule for a closed pipe, for every command (``pes_ref ... | head -1``).

    When the reader of stdout or stderr closes its end before the command has written
    all it has to say, the command writes nothing more to either stream and stops as
    Ctrl-C stops it: at its next safe point, keeping what it has saved and leaving no
    file half-written (a design saves its last finished iteration, an oracle result is
    whole or absent, a report is written whole or not at all), then exits with
    `EXIT_PIPE` (141, what a shell reports for a program that SIGPIPE ended)
    without a message. A reader that closes its end after the command's last write
    (``head -1`` of a command that had printed everything) is not noticed, and the
    command exits as it would have.

    Yields the watcher, whose ``closed`` says whether a pipe closed. Only a program's
    run (``program``: [`pes_ref.cli.main`][pes_ref.cli.main] without ``argv``) has its streams watched;
    a call's streams are its caller's.
    """
    pipes = _Pipes()
    if not program:
        yield pipes
        return
    streams = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = _Watched(streams[0], pipes), _Watched(streams[1], pipes)
    try:
        yield pipes
    finally:
        sys.stdout, sys.stderr = streams


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
    """``path`` if it is a folder to read; otherwise one refusal, worded as [`input_file`][pes_ref.cli.common.input_file]'s."""
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

def option_text(value) -> str:
    """The option text that gives ``value`` exactly (``10.0,20.0`` for a tuple)."""
    return ",".join(map(repr, value)) if isinstance(value, tuple) else repr(value)


@dataclasses.dataclass(frozen=True)
class LazyDefault:
    """An option's default: entry ``key`` of the table ``table`` in ``module``, read only when
    it is needed (the help's ``%(default)s``, a run without the option), so that building the
    parser imports none of the library. An option still holding it was not given."""

    module: str
    table: str
    key: str

    def value(self):
        """The default itself: ``module.table[key]``, importing ``module`` now."""
        return getattr(importlib.import_module(self.module), self.table)[self.key]

    def __str__(self) -> str:
        return option_text(self.value())



@dataclasses.dataclass(frozen=True)
class LazyChoices:
    """An option's choices: the keys of the table ``table`` in ``module`` (a registry), read
    only when an argument is checked or the help is shown, as [`LazyDefault`][pes_ref.cli.common.LazyDefault].
    The option needs a ``metavar``: without one, argparse lists the choices as it adds the option."""

    module: str
    table: str

    def _names(self) -> tuple:
        return tuple(getattr(importlib.import_module(self.module), self.table))

    def __contains__(self, name) -> bool:
        return name in self._names()

    def __iter__(self):
        return iter(self._names())


@dataclasses.dataclass(frozen=True)
class LazyHelp:
    """An option's help text that names what the library holds (a registry's entries, a
    dataclass's fields): ``make()`` reads them and writes the text, only when the help is
    shown, as [`LazyDefault`][pes_ref.cli.common.LazyDefault]."""

    make: Callable[[], str]

    def __str__(self) -> str:
        return self.make()

    def strip(self) -> str:
        """The text without its surrounding whitespace (argparse asks whether a help is blank)."""
        return str(self).strip()


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Descriptions and examples as written; each option's default appended to its help
    (unless the help already states it, or there is none)."""

    def _get_help_string(self, action):
        text = str(action.help or "")
        default = action.default
        if ("default" in text or default in (None, False, argparse.SUPPRESS) or not action.option_strings
                or isinstance(default, list) and not default):
            return text
        return f"{text} (default: %(default)s)"


class Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line, like every other error:
    ``error: pes_ref oracle: the following arguments are required: FILE (see pes_ref oracle --help)``.
    An unknown option is refused by the (sub)command it was given to, whose help lists the
    options it has: ``error: pes_ref analyze ratchet: unrecognized arguments: --torqe 2 (see
    pes_ref analyze ratchet --help)``."""

    def error(self, message):
        """Print the usage error as one line naming the (sub)command and its ``--help``, and exit with
        `EXIT_ERROR`."""
        print(f"error: {self.prog}: {' '.join(message.split())} (see {self.prog} --help)", file=sys.stderr)
        sys.exit(EXIT_ERROR)

    def parse_args(self, args=None, namespace=None):
        """`argparse.ArgumentParser.parse_args`, but an unknown argument is refused by the
        innermost (sub)command it was given to, in that command's one-line [`error`][pes_ref.cli.common.error]."""
        args, extras = self.parse_known_args(args, namespace)
        if extras:
            self._chosen(args).error(f"unrecognized arguments: {' '.join(extras)}")
        return args

    def _chosen(self, args) -> argparse.ArgumentParser:
        """The innermost (sub)command parser that ``args`` chose."""
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                chosen = action.choices.get(getattr(args, action.dest, None))
                if chosen is not None:
                    return chosen._chosen(args) if isinstance(chosen, Parser) else chosen
        return self


def add_command(sub, name: str, *, help: str, description: str, examples=()) -> argparse.ArgumentParser:
    """Add the subcommand ``name`` with an epilog of real invocations."""
    epilog = "examples:\n" + "\n".join(f"  python -m pes_ref {e}" for e in examples) if examples else None
    return sub.add_parser(name, help=help, description=textwrap.fill(description, 88), epilog=epilog,
                          formatter_class=HelpFormatter)
