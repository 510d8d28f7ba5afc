"""A sweep file's options, typed: which value each option and scene parameter takes.

A sweep file names each run's *design options* (`pes_ref.synthesis.engine.runs.DESIGN_OPTIONS`,
the flags of ``python -m pes_ref design``) and the problem's parameters as TOML values; these
check that each has its type ([`typed_sets`][pes_ref.sweep.options.typed_sets] for a built-in kind's scene parameters).
What
the options then mean is [`pes_ref.synthesis.engine.runs.design_inputs`][pes_ref.synthesis.engine.runs.design_inputs], the design
command's own.
"""
from __future__ import annotations

import dataclasses
from typing import Mapping

from pes_ref.core.runtime.keyfile import show
from pes_ref.synthesis import DESIGN_OPTIONS, KINDS, DesignInputs, design_inputs, kind_named

__all__ = ["run_inputs", "typed_sets", "scene_parameters", "has_type", "type_name", "BUILT_IN_KINDS"]

#: The kinds a sweep file names with ``kind =``: those with a problem of their own (a problem
#: file's runs name the file with ``problem =``).
BUILT_IN_KINDS = tuple(name for name, kind in KINDS.items() if kind.default_problem is not None)


def run_inputs(kind: str, options: Mapping, problem=None) -> DesignInputs:
    """What a sweep run's ``options`` resolve to
    ([`pes_ref.synthesis.engine.runs.design_inputs`][pes_ref.synthesis.engine.runs.design_inputs]):
    a built-in ``kind``'s scene parameters typed as its fields, or a problem file's dotted keys
    on ``problem``."""
    sets = {k: v for k, v in options.items() if k not in DESIGN_OPTIONS}
    if problem is None:
        return design_inputs(kind_named(kind).default_problem(), options, typed_sets(sets, kind))
    return design_inputs(problem, options, sets)


def scene_parameters(kind: str) -> dict:
    """The scene parameters of the built-in ``kind``: field name -> `dataclasses.Field` of its problem."""
    return {f.name: f for f in dataclasses.fields(kind_named(kind).default_problem)}


def typed_sets(values: Mapping, kind: str) -> dict:
    """Scene parameters given as typed values (a sweep file's) to problem overrides.

    Each value must have its field's type (an int is taken for a float field, as a float).

    Raises
    ------
    ValueError
        Naming the first parameter that ``kind`` lacks or whose value has another type.
    """
    fields = scene_parameters(kind)
    out = {}
    for name, value in values.items():
        if name not in fields:
            raise ValueError(f"{kind} scenes have no parameter {name!r}; expected one of {sorted(fields)}")
        want = type(fields[name].default)
        if not has_type(value, want):
            raise ValueError(f"{name} must be {type_name(want)}, got {show(value)}")
        out[name] = float(value) if want is float else value
    return out


def type_name(want) -> str:
    """``"an int"``, ``"a float"``, ``"a str or a list"``: a type, or types, for a message."""
    wants = want if isinstance(want, tuple) else (want,)
    return " or ".join(("an " if w.__name__[0] in "aeiou" else "a ") + w.__name__ for w in wants)


def has_type(value, want) -> bool:
    """``value`` is a ``want`` (a bool is not a number here; an int is a float)."""
    if want is bool or isinstance(value, bool):
        return want is bool and isinstance(value, bool)
    return isinstance(value, (int, float)) if want is float else isinstance(value, want)
