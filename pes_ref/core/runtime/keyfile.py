"""What the strict TOML input files share: reading one, and refusing a bad key in one line.

Device files (``docs/devices.md``), problem files (``docs/problems.md``) and sweep files
(``docs/sweeps.md``) are read the same way: the text (UTF-8), then the TOML, then every key
checked, and every refusal is one :class:`KeyFileError` line naming the file and the key at
fault, ``"PATH: KEY: what was expected, got VALUE"``. Each kind of file subclasses the error
and, for its own value types, :class:`KeyReader`.
"""
from __future__ import annotations

import math
import os
import tomllib

__all__ = ["KeyFileError", "KeyReader", "read_text", "parse_toml", "show"]


class KeyFileError(ValueError):
    """An input file that cannot be used; the message names the file and the key."""


def show(value) -> str:
    """A bad value for a message, as the file spells it (TOML: ``true``, ``[1, 2]``,
    ``{ k = 1 }``; anything else by its repr), at most 60 characters."""
    text = _toml(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _toml(value) -> str:
    """``value`` in TOML's spelling where it differs from Python's (booleans, tables, lists of them)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + " }" if value else "{}"
    return repr(value)


def read_text(path, error: type, what: str) -> str:
    """The UTF-8 text of the ``what`` (e.g. ``"device file"``) at ``path``; ``error`` (a
    :class:`KeyFileError`) for a missing file, a folder, or a file that cannot be read."""
    path = os.fspath(path)
    try:
        with open(path, "rb") as fh:
            return fh.read().decode("utf-8")
    except FileNotFoundError:
        raise error(f"{what} {path} does not exist") from None
    except IsADirectoryError:
        raise error(f"{what} {path} is a folder, not a file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise error(f"{path}: cannot read the {what} ({exc})") from None


def parse_toml(text: str, path: str, error: type) -> dict:
    """The tables of a TOML ``text`` read from ``path``; ``error`` when it is not TOML."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{path}: not valid TOML: {exc}") from None


class KeyReader:
    """Checks the values of one file and raises :attr:`error` naming ``path`` and the key.

    ``noun`` names the file's top level in a message about its keys (``"a device file"``)."""

    error: type = KeyFileError
    noun: str = "the file"

    def __init__(self, path: str):
        self.path = path

    def fail(self, key: str, message: str):
        """Raise :attr:`error` with ``"PATH: KEY: message"``, the one line of every refusal."""
        raise self.error(f"{self.path}: {key}: {message}")

    def check_keys(self, value, where: str, allowed) -> dict:
        """``value``, a table at ``where`` ("" for the top level) whose keys are all in ``allowed``."""
        if not isinstance(value, dict):
            self.fail(where, f"expected a table, got {show(value)}")
        for name in value:
            if name not in allowed:
                self.fail(f"{where}.{name}" if where else name,
                          f"unknown key; {'[' + where + ']' if where else self.noun} has {', '.join(allowed)}")
        return value

    def number(self, value, where: str, *, least=None, above=None) -> float:
        """A finite number (not a boolean), at least ``least`` and above ``above`` when given."""
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            self.fail(where, f"expected a finite number, got {show(value)}")
        if least is not None and not value >= least:
            self.fail(where, f"expected a number >= {least:g}, got {show(value)}")
        if above is not None and not value > above:
            self.fail(where, f"expected a number > {above:g}, got {show(value)}")
        return float(value)

    def integer(self, value, where: str, least: int) -> int:
        """An integer (not a boolean) >= ``least``."""
        if isinstance(value, bool) or not isinstance(value, int) or value < least:
            self.fail(where, f"expected an integer >= {least}, got {show(value)}")
        return int(value)

    def ordered(self, lower, upper, where: str, *, strict: bool = False) -> None:
        """Refuse corners ``lower``, ``upper`` of a box at ``where`` unless ``upper >= lower`` on
        every axis (``>`` if ``strict``), naming the axis: ``WHERE.upper[1]: expected upper >=
        lower, got lower 0.5, upper 0.2``."""
        relation = ">" if strict else ">="
        for d, (lo, hi) in enumerate(zip(lower, upper)):
            if not (hi > lo or (hi == lo and not strict)):
                self.fail(f"{where}.upper[{d}]" if where else f"upper[{d}]",
                          f"expected upper {relation} lower, got lower {lo:g}, upper {hi:g}")

    def boolean(self, value, where: str) -> bool:
        """A TOML boolean (``true`` or ``false``; not a number)."""
        if not isinstance(value, bool):
            self.fail(where, f"expected true or false, got {show(value)}")
        return value
