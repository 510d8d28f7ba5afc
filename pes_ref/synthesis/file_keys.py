"""The keys of a problem file: each key's type, default and unit, and the one reader that checks them.

A section of a problem file (``[surface]``, one ``[[objective]]`` term, ...) is declared as
a dict ``name -> Key``; :meth:`Reader.table` checks a TOML table against it: an unknown
key, a missing required one or a value of the wrong type raises one :class:`ProblemFileError`
whose message names the file and the key (``latch.toml: objective[2].weight: expected a
number >= 0, got -1``). The converters are looked up by the key's type in :data:`TYPES`
(dispatch by data). ``docs/problems.md`` documents every key; a test keeps the two equal.
"""
from __future__ import annotations

import importlib
import os
import sys
from typing import NamedTuple

from pes_ref.core.runtime.keyfile import KeyFileError, KeyReader, show

__all__ = ["Key", "REQUIRED", "Reader", "ProblemFileError", "TYPES", "import_object"]


class ProblemFileError(KeyFileError):
    """A problem file (or problem data) that cannot be used; the message names the file and the key."""


class _Required:
    def __repr__(self):
        return "REQUIRED"


#: The default of a key that must be given.
REQUIRED = _Required()


class Key(NamedTuple):
    """One key of a section: its type (a name in :data:`TYPES`), default (:data:`REQUIRED`:
    none), unit (for the docs) and, for ``"choice"`` keys, the choices."""

    type: str
    default: object = REQUIRED
    unit: str = ""
    choices: tuple = ()


class Reader(KeyReader):
    """Checks the values of one file and raises :class:`ProblemFileError` naming ``path`` and the key."""

    error = ProblemFileError
    noun = "a problem file"

    @property
    def folder(self) -> str | None:
        """The folder of the file read (None for data built in code, ``"<...>"``): where its
        ``custom`` modules are looked for first."""
        return None if self.path.startswith("<") else os.path.dirname(os.path.abspath(self.path))

    def table(self, value, where: str, keys: dict, *, also=()) -> dict:
        """The table ``value`` at ``where`` checked against ``keys``: every key converted by
        its type, defaults filled in. ``also`` names further keys the caller reads itself."""
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
        return TYPES[key.type](self, value, where, key)

    @staticmethod
    def at(where: str, name) -> str:
        """The path of key or index ``name`` under ``where`` in a message: ``where[i]``, ``where.name``, or
        ``name`` at the top level (``where`` "")."""
        if isinstance(name, int):
            return f"{where}[{name}]"
        return f"{where}.{name}" if where else name

    # ------------------------------------------------------------------ compounds
    def pair(self, value, where: str, item) -> tuple:
        """A list of exactly two values, each checked by ``item(value, where)`` at ``where[0]``, ``where[1]``;
        a tuple."""
        if not isinstance(value, list) or len(value) != 2:
            self.fail(where, f"expected a list of two values, got {show(value)}")
        return tuple(item(v, self.at(where, i)) for i, v in enumerate(value))

    def box(self, value, where: str) -> tuple:
        """``{ lower = [a, b], upper = [c, d] }`` with upper >= lower: ``(lower, upper)``."""
        t = self.table(value, where, {"lower": Key("point"), "upper": Key("point")})
        self.ordered(t["lower"], t["upper"], where)
        return t["lower"], t["upper"]


def _number(r, v, w, k):
    return r.number(v, w)


def _positive(r, v, w, k):
    return r.number(v, w, above=0.0)


def _nonneg(r, v, w, k):
    return r.number(v, w, least=0.0)


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
    if not isinstance(v, bool):
        r.fail(w, f"expected true or false, got {show(v)}")
    return v


def _edges(r, v, w, k):
    return r.pair(v, w, lambda row, where: r.pair(row, where, lambda b, at: _boolean(r, b, at, k)))


def _points(r, v, w, k):
    if not isinstance(v, list) or not v:
        r.fail(w, f"expected a non-empty list of [q0, q1] points, got {show(v)}")
    return tuple(_point(r, p, r.at(w, i), k) for i, p in enumerate(v))


def _stages(r, v, w, k):
    if not isinstance(v, list) or not v:
        r.fail(w, f"expected a non-empty list of [iteration, grid] or [iteration, grid, n_steps], got {show(v)}")
    out = []
    for i, st in enumerate(v):
        if not isinstance(st, list) or len(st) not in (2, 3):
            r.fail(r.at(w, i), f"expected [iteration, grid] or [iteration, grid, n_steps], got {show(st)}")
        out.append(tuple(r.integer(x, r.at(r.at(w, i), j), 0) for j, x in enumerate(st)))
    return tuple(out)


def _fraction(r, v, w):
    """A number in [0, 1)."""
    x = r.number(v, w, least=0.0)
    if not x < 1.0:
        r.fail(w, f"expected a number >= 0 and < 1, got {show(v)}")
    return x


def _table(r, v, w, k):
    """A table (its keys read by the caller)."""
    if not isinstance(v, dict):
        r.fail(w, f"expected a table, got {show(v)}")
    return v


def _share(r, v, w):
    """A share of particles: a number in [0, 1]."""
    x = r.number(v, w, least=0.0)
    if not x <= 1.0:
        r.fail(w, f"expected a share, a number >= 0 and <= 1, got {show(v)}")
    return x


def _tables(r, v, w, k):
    """A non-empty list of tables (their keys read by the caller)."""
    if not isinstance(v, list) or not v or not all(isinstance(t, dict) for t in v):
        r.fail(w, f"expected a non-empty list of tables, got {show(v)}")
    return v


def _box(r, v, w, k):
    return r.box(v, w)


def _velocity(r, v, w, k):
    """``[v0, v1]`` (every particle), or a box ``{ lower, upper }`` (uniform)."""
    if isinstance(v, dict):
        return r.box(v, w)
    p = _point(r, v, w, k)
    return p, p


def import_object(spec: str, folder: str | None = None):
    """The object named ``"module:name"`` (``name`` may be dotted), imported; ``folder`` (a
    problem file's) is searched first, and is on ``sys.path`` for this import only."""
    module, _, name = spec.partition(":")
    if folder is not None:
        sys.path.insert(0, folder)
    try:
        obj = importlib.import_module(module)
    finally:
        if folder is not None:
            sys.path.remove(folder)
    for part in name.split("."):
        obj = getattr(obj, part)
    return obj


def _object_with(method: str):
    """The converter of an object with ``method(x, v, t)``: named ``"module:object"`` (imported,
    from the file's folder first: a module beside the problem file), or (in a problem built in
    code) itself; a class, or an object without the method, is refused naming the key."""
    def convert(r, v, w, k):
        if isinstance(v, str):
            module, sep, name = v.partition(":")
            if not (sep and module and name):
                r.fail(w, f"expected 'module:object' (an importable module and a name in it), got {show(v)}")
            try:
                obj = import_object(v, r.folder)
            except ImportError as exc:
                r.fail(w, f"cannot import it: {exc}")
            except AttributeError as exc:
                r.fail(w, f"not found: {exc}")
            except Exception as exc:                      # the user's module failed while it was imported
                r.fail(w, f"importing {v!r} raised {type(exc).__name__}: {exc}")
        else:
            obj = v
        what = repr(v) if isinstance(v, str) else show(v)
        if isinstance(obj, type):
            r.fail(w, f"{what} is a class; expected an object with {method}(x, v, t), such as an instance of it")
        if not callable(getattr(obj, method, None)):
            kind = type(obj).__name__
            r.fail(w, f"{what} ({'an' if kind[0] in 'aeiou' else 'a'} {kind}) has no {method}(x, v, t)")
        return obj
    return convert


def _shapes(r, v, w, k):
    """A non-empty list of shape tables, as a device file's part draws them (``docs/devices.md``)."""
    from pes_ref.devices.device_file import read_shapes      # the layer below; shapely is needed only here
    return read_shapes(v, w, r.path, r.error)


#: Key type -> converter ``(reader, value, where, key) -> value``.
TYPES = {
    "number": _number,
    "positive": _positive,
    "nonneg": _nonneg,
    "count": lambda r, v, w, k: r.integer(v, w, 1),
    "grid": lambda r, v, w, k: r.integer(v, w, 2),
    "axis": _axis,
    "bool": _boolean,
    "text": _text,
    "choice": _text,
    "point": _point,
    "positive_pair": lambda r, v, w, k: r.pair(v, w, lambda x, at: r.number(x, at, above=0.0)),
    "bool_pair": lambda r, v, w, k: r.pair(v, w, lambda b, at: _boolean(r, b, at, k)),
    "grid_pair": lambda r, v, w, k: r.pair(v, w, lambda n, at: r.integer(n, at, 2)),
    "positive_or_pair": _either(_positive),
    "nonneg_or_pair": _either(_nonneg),
    "edges": _edges,
    "points": _points,
    "stages": _stages,
    "box": _box,
    "tables": _tables,
    "table": _table,
    "share": lambda r, v, w, k: _share(r, v, w),
    "fraction": lambda r, v, w, k: _fraction(r, v, w),
    "velocity": _velocity,
    "object": _object_with("value_and_grad"),
    "test_object": _object_with("passes"),
    "shapes": _shapes,
}
