"""The kinds of design, as one interface: `KINDS` (kind name -> [`DesignKind`][pes_ref.synthesis.kinds.registry.DesignKind]).

A design's problem is one of three kinds: the paper's funnel and oscillator
([`FunnelProblem`][pes_ref.synthesis.kinds.funnel.FunnelProblem],
[`OscillatorProblem`][pes_ref.synthesis.kinds.oscillator.OscillatorProblem],
whose scene parameters are dataclass fields) or the problem a problem file states
([`DesignProblem`][pes_ref.synthesis.problem.design_problem.DesignProblem], whose keys are the file's). What
the rest of the package asks of a kind is one [`DesignKind`][pes_ref.synthesis.kinds.registry.DesignKind] entry, as scipy's
``solve_ivp`` looks up its ``METHODS``: its problem's text round trip (the design file), how
its parameters are changed, its default plan and polish, its ``--smoke`` preset, its held-out
evaluation (figures, steps, panels), its headline figure, and what realizing it needs
([`Realizable`][pes_ref.synthesis.kinds.registry.Realizable]). [`kind_of`][pes_ref.synthesis.kinds.registry.kind_of] finds a problem's
entry; the held-out functions here
([`evaluate`][pes_ref.synthesis.kinds.registry.evaluate], [`evaluate_seeds`][pes_ref.synthesis.kinds.registry.evaluate_seeds],
[`held_out_steps`][pes_ref.synthesis.kinds.registry.held_out_steps],
[`held_out_panels`][pes_ref.synthesis.kinds.registry.held_out_panels])
serve every kind through it.
"""
from __future__ import annotations

import dataclasses
import json
import math
from typing import Callable, NamedTuple

import numpy as np

from pes_ref.core import budget, checks
from pes_ref.core.surface import spacing as grid_spacing
from pes_ref.synthesis.kinds import analysis
from pes_ref.synthesis.common.plans import (DEFAULT_OSCILLATOR_PLAN, FUNNEL_ENVELOPE_PLAN, FUNNEL_PLAN, OSCILLATOR_PLANS,
                                            OSCILLATOR_POLISH, PolishPlan)
from pes_ref.synthesis.problem.problem_file import (at_step, parse_set, plan_for, problem_from_text, problem_text,
                                                    with_sets)
from pes_ref.synthesis.kinds.funnel import FunnelProblem
from pes_ref.synthesis.kinds.oscillator import OscillatorProblem

__all__ = ["DesignKind", "Realizable", "Smoke", "KINDS", "kind_of", "kind_named", "evaluate", "evaluate_seeds",
           "held_out_steps", "held_out_panels", "HELD_OUT", "GRID_CONTACT", "SMOKE_GRID"]


class Realizable(NamedTuple):
    """What realizing a design as parts needs of its kind ([`pes_ref.realize`][pes_ref.realize]).

    - ``positions(problem, values, seed, n)``: every state (T+1, n, 2) of ``n`` of the design's
      own particles drawn from ``default_rng(seed)`` (the ``visited`` rule, the drawings);
    - ``start(problem)``: where a device's analysis starts (the device file's ``[start] q``);
    - ``contact(problem, energy)``: eq. (1)'s ``(v, r_c, r_min)``, the parts' barrier
      (``energy``: the design's surface grid, for a kind that states none);
    - ``at_step(problem, dt)``: the problem run at step ``dt``, its durations and the noise's
      diffusion per unit time kept;
    - ``with_spring(problem, spring)``: the problem with its scene's spring the device's
      (a [`pes_ref.core.terms.Spring`][pes_ref.core.terms.Spring], or None for none);
    - ``parts(problem)``: what the problem states the parts are made with, ``{"clearance": C,
      "restitution": E}`` (either left out: the realization's defaults).
    """

    positions: Callable
    start: Callable
    contact: Callable
    at_step: Callable
    with_spring: Callable
    parts: Callable = lambda problem: {}


class Smoke(NamedTuple):
    """A kind's ``--smoke`` preset: ``scene(problem)`` its problem overrides (for ``problem``, the
    run's problem before them), the plan's ``iterations``, ``particles`` and ``stages``, and the
    polish plan's overrides (used when the run has a polish stage)."""

    scene: Callable
    iterations: int
    particles: int
    stages: tuple
    polish: dict


@dataclasses.dataclass(frozen=True)
class DesignKind:
    """One kind of design: everything the package asks of it, each answered for its problems.

    Attributes
    ----------
    name : str
        The kind's name: the design file's ``kind`` and a sweep file's ``kind``.
    default_problem : callable
        ``() -> problem``: the kind's problem before any change (a problem file's kind has
        none: its problem is the file's; None).
    with_sets : callable
        ``(problem, sets) -> problem``: ``problem`` with parameters changed, checked again
        (built-in kinds: dataclass fields by name; problem files: keys by dotted name).
    parse_sets : callable
        ``(texts) -> sets``: ``--set NAME=VALUE`` texts to parameters.
    data : callable
        ``problem -> dict``: the problem's parameters as plain data (what a resumed design is compared by).
    whole : bool
        Whether a resumed design's problem must equal the one named in every parameter (a
        problem file: the file is what the user names), or only in those set explicitly (a
        built-in kind: its defaults are the package's).
    to_text, from_text : callable
        ``problem -> str`` and ``(text, path) -> problem``: how a design file holds the problem.
    default_plan : callable
        ``(problem, iterations) -> Plan``: the plan of a run of ``iterations`` (None: the plan's own count).
    default_polish : PolishPlan or None
        The polish stage of the default plan (None: the gradient stage alone).
    named_plans : dict
        ``design --plan NAME``: name -> (problem overrides, Plan, PolishPlan or None).
    smoke : Smoke
        The ``--smoke`` preset.
    evaluate : callable
        ``(problem, values, seeds, n, engine) -> {seed: figures}``: the held-out figures
        ([`evaluate_seeds`][pes_ref.synthesis.kinds.registry.evaluate_seeds]); ``engine`` runs the
        scenes on the design's surface (None: the surface model;
        [`pes_ref.synthesis.kinds.analysis`][pes_ref.synthesis.kinds.analysis]).
    eval_particles : callable
        ``problem -> int``: the held-out particles by default.
    held_out_steps : callable
        ``problem -> int``: the steps of the longest held-out run (what the memory check counts).
    panels : callable
        ``(problem, values, seed, n) -> [Panel]``: the held-out paths with pass or fail (``evaluate --plot``).
    headline : str
        The figure a sweep's closing table shows.
    realizable : Realizable
        What realizing the design needs.
    """

    name: str
    default_problem: Callable | None
    with_sets: Callable
    parse_sets: Callable
    data: Callable
    whole: bool
    to_text: Callable
    from_text: Callable
    default_plan: Callable
    default_polish: PolishPlan | None
    named_plans: dict
    smoke: Smoke
    evaluate: Callable
    eval_particles: Callable
    held_out_steps: Callable
    panels: Callable
    headline: str
    realizable: Realizable



# ---------------------------------------------------------------- the built-in kinds' parameters
#: How ``--set`` names the kind of value a parameter takes.
_KIND_OF_VALUE = {int: "an integer", float: "a number", str: "a word", bool: "true or false"}


def _fields(problem) -> dict:
    return {f.name: getattr(problem, f.name) for f in dataclasses.fields(problem)}


def _parse_fields(cls):
    """``--set NAME=VALUE`` texts to overrides of ``cls``'s fields, each converted to its field's type."""
    fields = {f.name: f for f in dataclasses.fields(cls)}

    def parse(items) -> dict:
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
    return parse


def _replace_fields(problem, sets: dict):
    names = {f.name for f in dataclasses.fields(problem)}
    unknown = [name for name in sets if name not in names]
    if unknown:
        raise ValueError(f"{problem.kind} scenes have no parameter {unknown[0]!r}; expected one of {sorted(names)}")
    return dataclasses.replace(problem, **sets) if sets else problem


def _dataclass_text(problem) -> str:
    return json.dumps(_fields(problem), sort_keys=True)


def _from_json(cls):
    return lambda text, path: cls(**json.loads(text))


# ---------------------------------------------------------------- realization hooks
def _funnel_at_step(problem, dt: float):
    n_steps = int(math.ceil(problem.n_steps * problem.dt / dt))
    return dataclasses.replace(problem, dt=dt, n_steps=n_steps, noise=problem.noise * math.sqrt(problem.dt / dt))


def _funnel_with_spring(problem, spring):
    if spring is not None:
        raise checks.InputError("realized", "the device has springs ([energy] springs); a funnel's scene has none "
                                            "for them to replace")
    return problem


#: The oscillator's eq. (1), which it states none of, from its grid (h the spacings, C-space
#: units): the cut-off ``r_c = 2 max(h)`` (the barrier acts within two cells), the cap
#: ``r_min = min(h) / 2`` (the smallest distance the grid resolves) and the strength ``v`` that
#: makes the barrier at its cap as high as the design's energy range (a state the design's
#: particles could not climb to stays out).
GRID_CONTACT = {"r_c_spacings": 2.0, "r_min_spacings": 0.5}


def _grid_contact(problem, energy) -> tuple:
    h = grid_spacing(np.asarray(problem.lower, dtype=np.float64), np.asarray(problem.upper, dtype=np.float64),
                     np.shape(energy), np.asarray(problem.periodic))
    r_c = GRID_CONTACT["r_c_spacings"] * float(np.max(h))
    r_min = GRID_CONTACT["r_min_spacings"] * float(np.min(h))
    height = float(np.ptp(energy)) or 1.0
    return 2.0 * height / (1.0 / r_min - 1.0 / r_c) ** 2, r_c, r_min


def _oscillator_at_step(problem, dt: float):
    return dataclasses.replace(problem, dt=dt, n_steps=int(math.ceil(problem.n_steps * problem.dt / dt)))


def _oscillator_with_spring(problem, spring):
    """The oscillator with its spring along q0 the device's (its scene has no other)."""
    if spring is None:
        return dataclasses.replace(problem, spring_k=0.0)
    k, center = np.broadcast_to(spring.k, (2,)), np.broadcast_to(spring.center, (2,))
    if k[1] != 0.0 or center[0] != 0.0:
        raise checks.InputError("realized", f"the device's springs (k {k.tolist()}, centre {center.tolist()}) are not "
                                            f"an oscillator's: one spring along q0 centred on 0")
    return dataclasses.replace(problem, spring_k=float(k[0]))


def _problem_contact(problem, energy) -> tuple:
    if problem.contact is None:
        raise checks.InputError("surface.contact", f"{problem.path} states no [surface.contact]: eq. (1)'s v, r_c "
                                                   f"and r_min the parts are built with (docs/problems.md)")
    return problem.contact.v, problem.contact.r_c, problem.contact.r_min


def _problem_parts(problem) -> dict:
    """A problem file's parts: their clearance (`DesignProblem.parts_clearance`) and the restitution
    ``[surface.contact]`` states."""
    contact = problem.contact
    if contact is None:
        return {}
    out = {"clearance": problem.parts_clearance}
    if contact.restitution is not None:
        out["restitution"] = contact.restitution
    return out


def _problem_start(problem) -> list:
    """Where a problem file's device analysis starts: the middle of its starts' box, or its first
    point; with start groups, the first group's (the file's order)."""
    starts = problem.starts
    while starts.groups:
        starts = starts.groups[0].starts
    if starts.box is not None:
        return [float(0.5 * (lo + hi)) for lo, hi in zip(*starts.box)]
    return [float(x) for x in starts.points[0]]


# ---------------------------------------------------------------- smoke presets
#: The largest grid (nodes along axis 0) of a problem file's ``--smoke`` run.
SMOKE_GRID = 12


def _problem_smoke_scene(problem) -> dict:
    """A problem file's ``--smoke`` overrides: its grid at most `SMOKE_GRID` nodes along axis 0
    (it keeps its dynamics and schedule: its phases)."""
    return {"surface.shape": list(problem.shape(min(SMOKE_GRID, problem.shape()[0])))}


def _funnel_plan(problem):
    """The funnel's default plan: `pes_ref.synthesis.common.plans.FUNNEL_PLAN`, or for a realizable
    funnel from the ``"envelope"`` start `pes_ref.synthesis.common.plans.FUNNEL_ENVELOPE_PLAN`."""
    if problem.realizable and problem.init_shape == "envelope":
        return FUNNEL_ENVELOPE_PLAN
    return FUNNEL_PLAN


# ---------------------------------------------------------------- the kinds
_OSCILLATOR_SETS, _OSCILLATOR_PLAN = OSCILLATOR_PLANS[DEFAULT_OSCILLATOR_PLAN]

#: The kinds of design by name.
KINDS = {
    "funnel": DesignKind(
        name="funnel", default_problem=FunnelProblem, with_sets=_replace_fields,
        parse_sets=_parse_fields(FunnelProblem), data=_fields, whole=False,
        to_text=_dataclass_text, from_text=_from_json(FunnelProblem),
        default_plan=lambda problem, iterations=None: _funnel_plan(problem), default_polish=None, named_plans={},
        smoke=Smoke(lambda problem: {"grid": 12, "n_steps": 60, "dt": 0.05}, 6, 8, ((0, 0),), {}),
        evaluate=analysis.evaluate_funnel, eval_particles=lambda problem: 200,
        held_out_steps=lambda problem: problem.n_steps, panels=analysis.funnel_panels,
        headline="in_band_fraction",
        realizable=Realizable(
            positions=lambda problem, values, seed, n: analysis.funnel_paths(problem, values, n, seed).traj.x,
            start=lambda problem: [0.0, float(problem.upper[1] - problem.start_depth)],
            contact=lambda problem, energy: (problem.contact_v, problem.contact_r_c, problem.contact_r_min),
            at_step=_funnel_at_step, with_spring=_funnel_with_spring)),
    "oscillator": DesignKind(
        name="oscillator", default_problem=OscillatorProblem, with_sets=_replace_fields,
        parse_sets=_parse_fields(OscillatorProblem), data=_fields, whole=False,
        to_text=_dataclass_text, from_text=_from_json(OscillatorProblem),
        default_plan=lambda problem, iterations=None: _OSCILLATOR_PLAN,
        default_polish=OSCILLATOR_POLISH[DEFAULT_OSCILLATOR_PLAN],
        named_plans={name: (sets, plan, OSCILLATOR_POLISH[name]) for name, (sets, plan) in OSCILLATOR_PLANS.items()},
        smoke=Smoke(lambda problem: {"grid0": 8, "grid1": 8, "n_steps": 60, "eval_periods": 4}, 6, 4, ((0, 0),),
                    {"evaluations": 20, "n_particles": 6, "popsize": 8}),
        evaluate=analysis.evaluate_oscillator, eval_particles=lambda problem: 50,
        held_out_steps=lambda problem: problem.steps_for(problem.eval_periods), panels=analysis.oscillator_panels,
        headline="captured_fraction",
        realizable=Realizable(
            positions=lambda problem, values, seed, n:
                analysis.oscillator_torque_sweep(problem, values, n, seed=seed).traj.x,
            start=lambda problem: [float(problem.amplitude * (1.0 + problem.kick)), 0.0],
            contact=_grid_contact, at_step=_oscillator_at_step, with_spring=_oscillator_with_spring)),
    "problem": DesignKind(
        name="problem", default_problem=None, with_sets=with_sets,
        parse_sets=lambda items: dict(parse_set(item) for item in items), data=lambda problem: problem.data,
        whole=True, to_text=problem_text,
        from_text=lambda text, path: problem_from_text(text, f"{path} (its problem)"),
        default_plan=plan_for, default_polish=None, named_plans={},
        smoke=Smoke(_problem_smoke_scene, 6, 8, ((0, 0),), {}),
        evaluate=analysis.evaluate_problem, eval_particles=lambda problem: problem.eval_particles,
        held_out_steps=lambda problem: max([problem.n_steps] + [s.n_steps for s in problem.scenarios]),
        panels=analysis.problem_panels, headline="success_fraction",
        realizable=Realizable(
            positions=lambda problem, values, seed, n: problem.run(values, seed, n).traj.x,
            start=_problem_start, contact=_problem_contact, at_step=at_step,
            with_spring=lambda problem, spring: problem.with_spring(spring), parts=_problem_parts)),
}


def kind_named(name) -> DesignKind:
    """The entry of the kind ``name``; another name is refused (one line naming the choices)."""
    return KINDS[checks.as_choice("kind", name, set(KINDS))]


def kind_of(problem) -> DesignKind:
    """The entry of ``problem``'s kind."""
    return KINDS[problem.kind]


# ---------------------------------------------------------------- held-out evaluation, every kind
#: The held-out seeds a design is judged on, which training never draws: ``"seed"``, what
#: `evaluate` (and ``evaluate``, ``realize`` at the command line) takes unless told, and
#: ``"second"``, the one the studies report beside it.
HELD_OUT = {"seed": 12345, "second": 9191}


def evaluate(problem, values, seed: int = HELD_OUT["seed"], n_particles: int | None = None, engine=None) -> dict:
    """Held-out figures of design ``values`` (the figures of ``python -m pes_ref evaluate``).

    Funnel (``n_particles`` default 200, held-out seed ``seed``): ``in_band_fraction``,
    ``exit_spread`` (std of exit q0), ``exited_fraction``, and the same three on the flat
    starting surface (``flat_*``). Oscillator (``n_particles`` default 50 for the torque
    sweep, plus the 5 x 5 grid of starts): ``captured_fraction`` (both sets together),
    ``sweep_captured_fraction``, ``grid_captured_fraction``, ``amplitude_error`` and
    ``period_error`` (relative, worst over the captured particles; NaN if none), their
    medians ``amplitude_error_median`` and ``period_error_median``, ``q1_advance_min``,
    ``q1_advance_median`` and ``q1_advance_max``
    ([`pes_ref.synthesis.kinds.analysis.q1_advance`][pes_ref.synthesis.kinds.analysis.q1_advance]
    over the captured particles of the sweep, rad per period; NaN if none) beside
    ``gait_advance`` (the problem's ``gait_delta``), and ``flat_captured_fraction``. A problem
    file's design: ``success_fraction``, one ``success_NAME`` per test, the share criteria, the
    objective's terms, the scenarios' and the flat surface's success (docs/problems.md).

    ``engine``: what runs the held-out scenes on the design's surface,
    ``engine(scenes, x0s, v0s) -> [Trajectory]`` (None: the surface model; another, such as
    realized parts in rigid contact, gets the same scenes: starts, forces, noise draws, steps).
    """
    seed = checks.as_nonneg_int("seed", seed)
    return evaluate_seeds(problem, values, (seed,), n_particles, engine)[seed]


def _particles(problem, n_particles) -> int:
    if n_particles is None:
        return kind_of(problem).eval_particles(problem)
    return checks.as_positive_int("n_particles", n_particles)


def evaluate_seeds(problem, values, seeds, n_particles: int | None = None, engine=None) -> dict:
    """[`evaluate`][pes_ref.synthesis.kinds.registry.evaluate] on each held-out seed of ``seeds``: seed -> figures, each the same
    numbers as ``evaluate(problem, values, seed, n_particles, engine)``; the runs of every seed
    (and of the flat surface) are one population ([`pes_ref.core.population.simulate_batch`][pes_ref.core.population.simulate_batch])."""
    values = checks.as_float_array("values", values, ndim=2)
    seeds = tuple(dict.fromkeys(checks.as_nonneg_int("seed", s) for s in seeds))
    n = _particles(problem, n_particles)
    steps = held_out_steps(problem)
    # one population: each seed's runs on the design and on the flat surface
    budget.check_memory(steps, n, "simulate", particles="n_particles", fixed_steps=True,
                        length=f"a held-out run of {steps} steps", runs=2 * len(seeds))
    return kind_of(problem).evaluate(problem, values, seeds, n, engine)


def held_out_steps(problem) -> int:
    """The steps of ``problem``'s longest held-out run (at its own ``dt``)."""
    return int(kind_of(problem).held_out_steps(problem))


def held_out_panels(problem, values, seed: int = HELD_OUT["seed"], n_particles: int | None = None) -> list:
    """The held-out particles of [`evaluate`][pes_ref.synthesis.kinds.registry.evaluate] (the same ones, on the design), as
    [`Panel`][pes_ref.synthesis.kinds.analysis.Panel] s, each path with whether it passed: the
    funnel's exits in the band or not; the oscillator's torque sweep and grid of starts
    captured by the cycle or not; a problem file's design, one panel per success test and one
    for all of them."""
    values = checks.as_float_array("values", values, ndim=2)
    seed = checks.as_nonneg_int("seed", seed)
    n = _particles(problem, n_particles)
    steps = held_out_steps(problem)
    budget.check_memory(steps, n, "simulate", particles="n_particles", fixed_steps=True,
                        length=f"a held-out run of {steps} steps")
    return kind_of(problem).panels(problem, values, seed, n)
