"""The keys of a problem file: each key's type, default and unit, and the one reader that checks them.

A section of a problem file (``[surface]``, one ``[[objective]]`` term, ...) is declared as a dict
``name -> Key`` ([`pes_ref.core.runtime.keyfile.Key`][pes_ref.core.runtime.keyfile.Key], as every
input file's); `Reader.table` checks a TOML table against it: an unknown key, a missing required one
or a value of the wrong type raises one
[`ProblemFileError`][pes_ref.synthesis.problem.file_keys.ProblemFileError] whose message names the
file and the key (``latch.toml: objective[2].weight: expected a number >= 0, got -1``). The
converters are looked up by the key's type in `TYPES` (dispatch by data): every file's and a problem
file's own. ``docs/problems.md`` documents every key; a test keeps the two equal.
"""
from __future__ import annotations

import dataclasses
import importlib
import os
import sys

from pes_ref.core.runtime.keyfile import REQUIRED, TYPES as FILE_TYPES, Key, KeyFileError, KeyReader, show

__all__ = ["Key", "REQUIRED", "Reader", "ProblemFileError", "TYPES", "import_object", "from_table"]


#: The fields of a table's class whose file key is a Python keyword: ``from`` and ``to``.
FIELD_KEYS = {"start": "from", "end": "to"}


def from_table(cls, keys: dict, domain, duration: float):
    """An instance of ``cls``, a dataclass that declares a table's ``KEYS`` (an objective term, a
    success test), from that table's checked keys: each field takes the key of its name (`FIELD_KEYS`:
    ``start`` and ``end`` take ``from`` and ``to``), a field ``domain`` the problem's ``domain``. A
    class whose fields are not its keys so has a ``from_keys`` of its own; ``duration`` is for those."""
    return cls(**{f.name: domain if f.name == "domain" else keys[FIELD_KEYS.get(f.name, f.name)]
                  for f in dataclasses.fields(cls)})


class ProblemFileError(KeyFileError):
    """A problem file (or problem data) that cannot be used; the message names the file and the key."""


class Reader(KeyReader):
    """Checks the values of one file and raises [`ProblemFileError`][pes_ref.synthesis.problem.file_keys.ProblemFileError] naming ``path`` and the key."""

    error = ProblemFileError
    noun = "a problem file"

    @property
    def folder(self) -> str | None:
        """The folder of the file read (None for data built in code, ``"<...>"``): where its
        ``custom`` modules are looked for first."""
        return None if self.path.startswith("<") else os.path.dirname(os.path.abspath(self.path))


def _points(r, v, w, k):
    if not isinstance(v, list) or not v:
        r.fail(w, f"expected a non-empty list of [q0, q1] points, got {show(v)}")
    return tuple(r.value(p, r.at(w, i), Key("point")) for i, p in enumerate(v))


def _stages(r, v, w, k):
    if not isinstance(v, list) or not v:
        r.fail(w, f"expected a non-empty list of [iteration, grid] or [iteration, grid, n_steps], got {show(v)}")
    out = []
    for i, st in enumerate(v):
        if not isinstance(st, list) or len(st) not in (2, 3):
            r.fail(r.at(w, i), f"expected [iteration, grid] or [iteration, grid, n_steps], got {show(st)}")
        out.append(tuple(r.integer(x, r.at(r.at(w, i), j), 0) for j, x in enumerate(st)))
    return tuple(out)


def _velocity(r, v, w, k):
    """``[v0, v1]`` (every particle), or a box ``{ lower, upper }`` (uniform)."""
    if isinstance(v, dict):
        return r.box(v, w)
    p = r.value(v, w, Key("point"))
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


#: Key type -> converter ``(reader, value, where, key) -> value``: every file's
#: (`pes_ref.core.runtime.keyfile.TYPES`) and a problem file's own.
TYPES = {
    **FILE_TYPES,
    "points": _points,
    "stages": _stages,
    "velocity": _velocity,
    "object": _object_with("value_and_grad"),
    "test_object": _object_with("passes"),
    "shapes": _shapes,
}
Reader.types = TYPES
