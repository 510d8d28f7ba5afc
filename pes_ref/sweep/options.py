"""Design options: from what a user names to a problem and a plan.

One design run is named by *design options*, the flags of ``python -m pes_ref design``
(:data:`DESIGN_OPTIONS`: ``iterations``, ``lr``, ``plan``, ``smoke``, ...), and by
*scene parameters*, the fields of the kind's problem (``--set NAME=VALUE``).
:func:`design_inputs` turns them into the problem overrides and the plan; the ``design``
command and every run of a sweep go through it, so a sweep file's options mean exactly
what the same flags mean on the command line.
"""
from __future__ import annotations

import dataclasses
from typing import Mapping, NamedTuple

from pes_ref.core.checks import InputError
from pes_ref.core.keyfile import show
from pes_ref.synthesis import (DEFAULT_PLANS, DEFAULT_POLISH, OSCILLATOR_PLANS, OSCILLATOR_POLISH, PROBLEMS, Plan,
                               plan_for, with_sets)

__all__ = ["SMOKE", "SMOKE_GRID", "smoke_sets", "smoke_scene", "DESIGN_OPTIONS", "DesignInputs", "design_inputs",
           "parse_sets", "parse_stages", "plan_overrides", "typed_sets", "scene_parameters", "has_type", "type_name"]

#: The ``--smoke`` preset: problem overrides per kind, and the plan's (iterations, particles, stages).
#: A problem file keeps its dynamics and schedule (its phases), on a grid of at most
#: :data:`SMOKE_GRID` nodes along axis 0 (:func:`smoke_sets`).
SMOKE = {
    "funnel": ({"grid": 12, "n_steps": 60, "dt": 0.05}, (6, 8, ((0, 0),))),
    "oscillator": ({"grid0": 8, "grid1": 8, "n_steps": 60, "eval_periods": 4}, (6, 4, ((0, 0),))),
    "problem": ({}, (6, 8, ((0, 0),))),
}
SMOKE_GRID = 12
#: The plan fields of the ``--smoke`` preset and the problem-file key that sets each: a key set
#: explicitly (``--set train.iterations=20``) wins over the preset.
_SMOKE_TRAIN_KEYS = {"iterations": "train.iterations", "n_particles": "train.particles", "stages": "train.stages"}
#: The ``--smoke`` preset of the polish plan (used when the run has a polish stage).
SMOKE_POLISH = {"funnel": {}, "oscillator": {"evaluations": 20, "n_particles": 6, "popsize": 8}}
#: The polish options and the polish plan's fields they set.
POLISH_OPTIONS = {"evaluations": "evaluations", "polish_particles": "n_particles"}

#: The design options and the value types they take (a float option takes an int too);
#: ``stages`` is ``"IT:GRID[:STEPS],..."`` text or a list of ``[it, grid(, n_steps)]``.
DESIGN_OPTIONS = {
    "iterations": int, "lr": float, "lr_final": float, "optimizer": str, "clip": float, "particles": int,
    "stages": (str, list), "no_stages": bool, "plan": str, "smoke": bool, "backend": str,
}
#: The plan field each plain plan option sets.
_PLAN_FIELDS = {"iterations": "iterations", "lr": "lr", "lr_final": "lr_final", "optimizer": "optimizer",
                "clip": "clip", "particles": "n_particles"}


class DesignInputs(NamedTuple):
    """What a run's options resolve to: problem overrides, plan overrides and the plan they apply
    to; for a problem file, also the problem with the overrides (``problem``)."""

    sets: dict
    plan_overrides: dict
    base_plan: Plan
    base_polish: object = None
    polish_overrides: dict = {}
    problem: object = None

    def plan(self) -> Plan:
        """The run's plan: :attr:`base_plan` with :attr:`plan_overrides`."""
        return dataclasses.replace(self.base_plan, **self.plan_overrides)

    def polish(self):
        """The run's polish plan (None: the run has no polish stage)."""
        if self.base_polish is None:
            return None
        return dataclasses.replace(self.base_polish, **self.polish_overrides)


def scene_parameters(kind: str) -> dict:
    """The scene parameters of ``kind``: field name -> :class:`dataclasses.Field` of its problem."""
    return {f.name: f for f in dataclasses.fields(PROBLEMS[kind])}


#: How ``--set`` names the kind of value a parameter takes.
_KIND_OF_VALUE = {int: "an integer", float: "a number", str: "a word", bool: "true or false"}


def parse_sets(items, problem_cls) -> dict:
    """``--set NAME=VALUE`` texts to problem overrides, each converted to its field's type."""
    fields = {f.name: f for f in dataclasses.fields(problem_cls)}
    out = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep or name not in fields:
            raise ValueError(f"--set {item!r}: expected NAME=VALUE with NAME one of {sorted(fields)}")
        default = fields[name].default
        try:
            out[name] = type(default)(text) if not isinstance(default, bool) else text.lower() in ("1", "true")
        except ValueError:
            raise ValueError(f"--set {item!r}: {text!r} is not {_KIND_OF_VALUE[type(default)]}") from None
    return out


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


def parse_stages(text: str) -> tuple:
    """``--stages`` text ``IT:GRID[:STEPS],...`` to the plan's stage tuples."""
    try:
        return tuple(tuple(int(x) for x in part.split(":")) for part in text.split(","))
    except ValueError:
        raise ValueError(f"--stages {text!r}: expected IT:GRID pairs separated by commas, e.g. 0:25,100:0") from None


def plan_overrides(options: Mapping) -> dict:
    """The plan fields the design options in ``options`` set (``None`` means not given)."""
    out = {field: options[name] for name, field in _PLAN_FIELDS.items() if options.get(name) is not None}
    stages = options.get("stages")
    if stages is not None:
        out["stages"] = parse_stages(stages) if isinstance(stages, str) else tuple(tuple(st) for st in stages)
    if options.get("no_stages"):
        out["stages"] = ((0, 0),)
    return out


def smoke_sets(problem) -> dict:
    """The ``--smoke`` overrides of a problem file: its grid at most :data:`SMOKE_GRID` nodes along axis 0."""
    return {"surface.shape": list(problem.shape(min(SMOKE_GRID, problem.shape()[0])))}


def smoke_scene(kind: str, problem=None) -> dict:
    """The problem overrides of the ``--smoke`` preset of a ``kind`` run (of the problem file ``problem``)."""
    return smoke_sets(problem) if kind == "problem" else dict(SMOKE[kind][0])


def design_inputs(kind: str, options: Mapping, sets: Mapping | None = None, problem=None) -> DesignInputs:
    """Resolve design ``options`` and problem overrides ``sets`` for a ``kind`` run (for kind
    ``"problem"``, of the problem file ``problem``: ``sets`` are its dotted keys).

    The order is the design command's: the kind's default plan (a problem file's own
    ``[train]``, with the ``train.*`` keys of ``sets``), or the named oscillator ``plan`` (its
    problem overrides, plan and polish); then the ``smoke`` preset; then the explicit options and
    ``sets``, which win over both. A problem file without ``train.stages`` has the default stages
    of the run's iteration count (:func:`pes_ref.synthesis.plan_for`).

    Raises
    ------
    ValueError
        For a ``plan`` the kind does not have.
    """
    sets = dict(sets or {})
    plan_over = plan_overrides(options)
    if kind == "problem":
        base_plan, base_polish = None, None                 # the plan of the problem with the sets, below
    else:
        base_plan, base_polish = DEFAULT_PLANS[kind], DEFAULT_POLISH[kind]
    polish_over = {field: options[name] for name, field in POLISH_OPTIONS.items() if options.get(name) is not None}
    name = options.get("plan")
    if name is not None:
        if kind != "oscillator":
            raise InputError("plan", f"plan {name}: only the oscillator has named plans")
        if name not in OSCILLATOR_PLANS:
            raise ValueError(f"plan {name!r}: expected one of {sorted(OSCILLATOR_PLANS)}")
        plan_sets, base_plan = OSCILLATOR_PLANS[name]
        base_polish = OSCILLATOR_POLISH[name]
        sets = {**plan_sets, **sets}
    if options.get("smoke"):
        its, parts, stages = SMOKE[kind][1]
        sets = {**smoke_scene(kind, problem), **sets}

        preset_plan = {"iterations": its, "n_particles": parts, "stages": stages}
        plan_over = {**{k: v for k, v in preset_plan.items() if _SMOKE_TRAIN_KEYS[k] not in sets}, **plan_over}
        if base_polish is not None:
            polish_over = {**SMOKE_POLISH[kind], **polish_over}
    if base_polish is None and polish_over:
        given = [name for name in POLISH_OPTIONS if options.get(name) is not None]
        raise InputError(given[0], f"{', '.join(given)}: this {kind} run has no polish stage")
    if kind == "problem":
        problem = with_sets(problem, sets)
        base_plan = plan_for(problem, plan_over.get("iterations"))
    return DesignInputs(sets, plan_over, base_plan, base_polish, polish_over, problem)
