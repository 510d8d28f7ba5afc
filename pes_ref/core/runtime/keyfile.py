"""What the strict TOML input files share: reading one, its keys declared, and refusing a bad key
in one line.

Device files (``docs/devices.md``), problem files (``docs/problems.md``) and sweep files
(``docs/sweeps.md``) are read the same way: the text (UTF-8), then the TOML, then every key checked,
and every refusal is one [`KeyFileError`][pes_ref.core.runtime.keyfile.KeyFileError] line naming the
file and the key at fault, ``"PATH: KEY: what was expected, got VALUE"``. A section of a file is
declared as a dict ``name -> Key`` (the key's type, default and unit);
[`KeyReader.table`][pes_ref.core.runtime.keyfile.KeyReader.table] checks a TOML table against it: an
unknown key, a missing required one or a value of the wrong type is refused naming the key. The
converters are looked up by the key's type in the reader's `KeyReader.types` (dispatch by data):
`TYPES` here, which each kind of file extends with its own (and subclasses the error and the
reader).
"""
from __future__ import annotations

import math
import os
import tomllib
from typing import NamedTuple

__all__ = ["KeyFileError", "KeyReader", "Key", "REQUIRED", "TYPES", "read_text", "parse_toml", "show"]


class KeyFileError(ValueError):
    """An input file that cannot be used; the message names the file and the key."""


class _Required:
    def __repr__(self):
        return "REQUIRED"


#: The default of a key that must be given.
REQUIRED = _Required()


class Key(NamedTuple):
    """One key of a section: its type (a name in the reader's `KeyReader.types`), default
    (`REQUIRED`: none), unit (for the docs) and, for ``"choice"`` keys, the choices."""

    type: str
    default: object = REQUIRED
    unit: str = ""
    choices: tuple = ()


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
    [`KeyFileError`][pes_ref.core.runtime.keyfile.KeyFileError]) for a missing file, a folder, or a file that cannot be read."""
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
    """Checks the values of one file and raises `error` naming ``path`` and the key.

    ``noun`` names the file's top level in a message about its keys (``"a device file"``)."""

    error: type = KeyFileError
    noun: str = "the file"

    def __init__(self, path: str):
        self.path = path

    def fail(self, key: str, message: str):
        """Raise `error` with ``"PATH: KEY: message"``, the one line of every refusal."""
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

    # ------------------------------------------------------------------ declared sections
    #: Key type -> converter ``(reader, value, where, key) -> value`` (a subclass extends it).
    types: dict = {}

    def table(self, value, where: str, keys: dict, *, also=()) -> dict:
        """The table ``value`` at ``where`` checked against ``keys`` (name ->
        [`Key`][pes_ref.core.runtime.keyfile.Key]): every
        key converted by its type, defaults filled in. ``also`` names further keys the caller
        reads itself."""
        self.check_keys(value, where, tuple(keys) + tuple(also))
        out = {}
        for name, key in keys.items():
            if name in value:
                out[name] = self.value(value[name], self.at(where, name), key)
            elif key.default is REQUIRED:
                self.fail(self.at(where, name), "missing")
            else:
                out[name] = key.default
        return out

    def value(self, value, where: str, key: Key):
        """One value converted by its key's type."""
        return self.types[key.type](self, value, where, key)

    @staticmethod
    def at(where: str, name) -> str:
        """The path of key or index ``name`` under ``where`` in a message: ``where[i]``, ``where.name``, or
        ``name`` at the top level (``where`` "")."""
        if isinstance(name, int):
            return f"{where}[{name}]"
        return f"{where}.{name}" if where else name

    def pair(self, value, where: str, item, what: str = "numbers") -> tuple:
        """A list of exactly two ``what``, each checked by ``item(value, where)`` at ``where[0]``,
        ``where[1]``; a tuple."""
        if not isinstance(value, list) or len(value) != 2:
            self.fail(where, f"expected a list of two {what}, got {show(value)}")
        return tuple(item(v, self.at(where, i)) for i, v in enumerate(value))

    def box(self, value, where: str) -> tuple:
        """``{ lower = [a, b], upper = [c, d] }`` with upper >= lower: ``(lower, upper)``."""
        t = self.table(value, where, {"lower": Key("point"), "upper": Key("point")})
        self.ordered(t["lower"], t["upper"], where)
        return t["lower"], t["upper"]


# --------------------------------------------------------------------------- the converters

def _axis(r, v, w, k):
    if isinstance(v, bool) or not isinstance(v, int) or v not in (0, 1):
        r.fail(w, f"expected an axis, 0 or 1, got {show(v)}")
    return v


def _point(r, v, w, k):
    return r.pair(v, w, r.number)


def _either(item):
    """A number (the same on both axes) or a list of two."""
    def convert(r, v, w, k):
        if isinstance(v, list):
            return r.pair(v, w, lambda x, where: item(r, x, where, k))
        one = item(r, v, w, k)
        return (one, one)
    return convert


def _text(r, v, w, k):
    if not isinstance(v, str) or (k.choices and v not in k.choices):
        want = f"one of {', '.join(repr(c) for c in k.choices)}" if k.choices else "a string"
        r.fail(w, f"expected {want}, got {show(v)}")
    return v


def _boolean(r, v, w, k):
    return r.boolean(v, w)


def _edges(r, v, w, k):
    """``[[lower0, upper0], [lower1, upper1]]`` of booleans: which walls are on."""
    if not (isinstance(v, list) and len(v) == 2 and all(isinstance(e, list) and len(e) == 2 for e in v)):
        r.fail(w, f"expected [[lower0, upper0], [lower1, upper1]] of true/false, got {show(v)}")
    return tuple(tuple(r.boolean(b, r.at(r.at(w, d), s)) for s, b in enumerate(e)) for d, e in enumerate(v))


def _fraction(r, v, w, k):
    """A number in [0, 1)."""
    x = r.number(v, w, least=0.0)
    if not x < 1.0:
        r.fail(w, f"expected a number >= 0 and < 1, got {show(v)}")
    return x


def _share(r, v, w, k):
    """A share of particles: a number in [0, 1]."""
    x = r.number(v, w, least=0.0)
    if not x <= 1.0:
        r.fail(w, f"expected a share, a number >= 0 and <= 1, got {show(v)}")
    return x


def _unit(r, v, w, k):
    """A coefficient in [0, 1] (a restitution)."""
    x = r.number(v, w, least=0.0)
    if not x <= 1.0:
        r.fail(w, f"expected a number in [0, 1], got {show(v)}")
    return x


def _table(r, v, w, k):
    """A table (its keys read by the caller)."""
    if not isinstance(v, dict):
        r.fail(w, f"expected a table, got {show(v)}")
    return v


def _tables(r, v, w, k):
    """A non-empty list of tables (their keys read by the caller)."""
    if not isinstance(v, list) or not v or not all(isinstance(t, dict) for t in v):
        r.fail(w, f"expected a non-empty list of tables, got {show(v)}")
    return v


def _table_list(r, v, w, k):
    """A list of tables, possibly empty (their keys read by the caller)."""
    if not isinstance(v, list) or not all(isinstance(t, dict) for t in v):
        r.fail(w, f"expected a list of tables, got {show(v)}")
    return v


#: The converters every file shares: key type -> ``(reader, value, where, key) -> value``.
TYPES = {
    "number": lambda r, v, w, k: r.number(v, w),
    "positive": lambda r, v, w, k: r.number(v, w, above=0.0),
    "nonneg": lambda r, v, w, k: r.number(v, w, least=0.0),
    "count": lambda r, v, w, k: r.integer(v, w, 1),
    "seed": lambda r, v, w, k: r.integer(v, w, 0),
    "grid": lambda r, v, w, k: r.integer(v, w, 2),
    "axis": _axis,
    "bool": _boolean,
    "text": _text,
    "choice": _text,
    "point": _point,
    "positive_pair": lambda r, v, w, k: r.pair(v, w, lambda x, at: r.number(x, at, above=0.0)),
    "nonneg_pair": lambda r, v, w, k: r.pair(v, w, lambda x, at: r.number(x, at, least=0.0)),
    "bool_pair": lambda r, v, w, k: r.pair(v, w, lambda b, at: r.boolean(b, at), "booleans"),
    "grid_pair": lambda r, v, w, k: r.pair(v, w, lambda n, at: r.integer(n, at, 2), "integers >= 2"),
    "positive_or_pair": _either(lambda r, v, w, k: r.number(v, w, above=0.0)),
    "nonneg_or_pair": _either(lambda r, v, w, k: r.number(v, w, least=0.0)),
    "edges": _edges,
    "box": lambda r, v, w, k: r.box(v, w),
    "table": _table,
    "tables": _tables,
    "table_list": _table_list,
    "share": _share,
    "unit": _unit,
    "fraction": _fraction,
}
KeyReader.types = TYPES
