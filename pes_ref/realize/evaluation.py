"""The design's own held-out evaluation on a realized device (``evaluate DESIGN.npz --realized DEVICE.toml``).

The realized device is rebuilt from its file (:func:`pes_ref.devices.device_file.load_device`):
its C-space from the exported parts and eq. (1) of the distance to it give the surface, and
its kept springs (``[energy] springs``) act as the scene's linear springs (:func:`device_spring`;
the device analyses bake them into the grid, where a stiff spring's force becomes a staircase
of the grid's cells); everything else is the design's (its forces, noise, damping, masses and walls,
its held-out starts and its figures). The realized surface's barriers are stiffer than the
design's smooth slopes, so the run takes the step the stability rule allows
(:func:`pes_ref.core.stability.check_stable`, ``docs/spec.md`` section 10):

- the design's own ``dt`` where the rule accepts it on the realized scene;
- otherwise :data:`pes_ref.core.stability.SAFETY` times the limit of the realized scene's
  stiffest term, with the number of steps raised to cover the design's duration
  (``ceil(n_steps dt / dt_realized)``) and the noise's per-step std scaled by
  ``sqrt(dt / dt_realized)``, so that the noise's diffusion (its variance per unit time) is
  the design's.

What a realization needs of each kind of design is data, :data:`REALIZABLE` (kind ->
:class:`Realizable`).
"""
from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from pes_ref.core import checks
from pes_ref.core.stability import SAFETY, stability_limit
from pes_ref.core.surface import spacing as grid_spacing
from pes_ref.synthesis.analysis import evaluate, funnel_paths, held_out_steps, oscillator_torque_sweep

__all__ = ["RealizedRun", "realized_problem", "evaluate_realized", "held_out_positions",
           "Realizable", "REALIZABLE", "check_kind", "contact_parameters", "start_point", "device_spring",
           "GRID_CONTACT"]


class RealizedRun(NamedTuple):
    """The design's problem on the realized surface: ``problem`` (the design's, at the step the
    rule allows), the realized grid ``values``, and the step ``dt`` and ``n_steps`` it takes."""

    problem: object
    values: np.ndarray
    dt: float
    n_steps: int


class Realizable(NamedTuple):
    """What a realization needs of one kind of design (:data:`REALIZABLE`).

    - ``positions(problem, values, seed, n)``: every state (T+1, n, 2) of ``n`` of the design's
      own particles drawn from ``default_rng(seed)`` (the ``visited`` rule, the drawings);
    - ``start(problem)``: where a device's analysis starts (the device file's ``[start] q``);
    - ``contact(problem, energy)``: eq. (1)'s ``(v, r_c, r_min)``, the parts' barrier
      (``energy``: the design's surface grid, for a kind that states none);
    - ``at_step(problem, dt)``: the problem run at step ``dt``, its durations and the noise's
      diffusion per unit time kept;
    - ``with_spring(problem, spring)``: the problem with its scene's spring the device's
      (a :class:`pes_ref.core.terms.Spring`, or None for none).
    """

    positions: object
    start: object
    contact: object
    at_step: object
    with_spring: object


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


def _problem_start(problem) -> list:
    starts = problem.starts
    if starts.box is not None:
        return [float(0.5 * (lo + hi)) for lo, hi in zip(*starts.box)]
    return [float(x) for x in starts.points[0]]


def _problem_at_step(problem, dt: float):
    from pes_ref.synthesis.problem_file import at_step
    return at_step(problem, dt)


#: The kinds of design a device can stand in for (their surface is one grid the device
#: replaces): kind -> :class:`Realizable`.
REALIZABLE = {
    "funnel": Realizable(
        positions=lambda problem, values, seed, n: funnel_paths(problem, values, n, seed).traj.x,
        start=lambda problem: [0.0, float(problem.upper[1] - problem.start_depth)],
        contact=lambda problem, energy: (problem.contact_v, problem.contact_r_c, problem.contact_r_min),
        at_step=_funnel_at_step, with_spring=_funnel_with_spring),
    "oscillator": Realizable(
        positions=lambda problem, values, seed, n: oscillator_torque_sweep(problem, values, n, seed=seed).traj.x,
        start=lambda problem: [float(problem.amplitude * (1.0 + problem.kick)), 0.0],
        contact=_grid_contact, at_step=_oscillator_at_step, with_spring=_oscillator_with_spring),
    "problem": Realizable(
        positions=lambda problem, values, seed, n: problem.run(values, seed, n).traj.x,
        start=_problem_start, contact=_problem_contact, at_step=_problem_at_step,
        with_spring=lambda problem, spring: problem.with_spring(spring)),
}


def check_kind(problem) -> Realizable:
    """The realization's entry for ``problem``'s kind; a kind none covers is refused (one line naming it)."""
    entry = REALIZABLE.get(problem.kind)
    if entry is None:
        raise checks.InputError("realized", f"realization covers {', '.join(REALIZABLE)} designs; this design is a "
                                            f"{problem.kind!r} design")
    return entry


def contact_parameters(problem, energy) -> tuple:
    """Eq. (1)'s ``(v, r_c, r_min)`` of ``problem``'s parts (``energy``: the design's surface grid)."""
    return tuple(float(x) for x in check_kind(problem).contact(problem, energy))


def start_point(problem) -> list:
    """Where an analysis of ``problem``'s device starts."""
    return check_kind(problem).start(problem)


def realized_problem(problem, device) -> RealizedRun:
    """The design ``problem`` on ``device``'s surface, at the step the stability rule allows
    (module docstring). The device's grid must be the design's surface grid."""
    check_kind(problem)
    shape = tuple(problem.shape())
    if tuple(device.shape) != shape or not (np.allclose(device.lower, problem.lower)
                                            and np.allclose(device.upper, problem.upper)):
        raise checks.InputError("realized", f"the device's grid ({device.shape[0]} x {device.shape[1]} on "
                                            f"{list(map(float, device.lower))} .. {list(map(float, device.upper))}) "
                                            f"is not the design's ({shape[0]} x {shape[1]} on "
                                            f"{list(map(float, problem.lower))} .. {list(map(float, problem.upper))})")
    values = np.asarray(device.cspace().surface(device.v, device.r_c, (), device.r_min).values, dtype=np.float64)
    entry = check_kind(problem)
    spring = device_spring(device)
    plain = entry.with_spring(problem.plain(), spring)
    lim = stability_limit(plain.scene(values), "rule")
    if lim.ratio <= 1.0:
        return RealizedRun(plain, values, plain.dt, plain.n_steps)
    dt = SAFETY * lim.limit
    slow = entry.with_spring(entry.at_step(problem, dt).plain(), spring)
    return RealizedRun(slow, values, dt, slow.n_steps)


def device_spring(device):
    """The device file's springs (``[energy] springs``) as the scene's linear spring per axis:
    the sum of an axis's springs is one spring (``k = sum k_i``, ``center = sum k_i c_i / k``);
    None without any. A one-sided spring (``side`` above or below) is refused: a scene's
    spring acts both ways."""
    from pes_ref.core.terms import Spring
    if not device.springs:
        return None
    k, moment = np.zeros(2), np.zeros(2)
    for i, s in enumerate(device.springs):
        if s.side != "both":
            raise checks.InputError("realized", f"the device's spring {i} acts on one side only (side = {s.side!r}); "
                                                f"the design's run has springs that act both ways")
        k[s.axis] += s.k
        moment[s.axis] += s.k * s.center
    return Spring(k, np.divide(moment, k, out=np.zeros(2), where=k > 0))


def evaluate_realized(problem, values, device, seed: int = 12345, n_particles: int | None = None) -> dict:
    """The design's figures and the realized device's, side by side: ``{name: (design, realized)}``,
    plus ``dt`` and the held-out run's steps ``n_steps`` of each (the realized run's as the rule allows)."""
    run = realized_problem(problem, device)
    design = evaluate(problem, values, seed=seed, n_particles=n_particles)
    realized = evaluate(run.problem, run.values, seed=seed, n_particles=n_particles)
    out = {name: (value, realized[name]) for name, value in design.items() if not name.startswith("flat_")}
    out["dt"] = (float(problem.dt), run.dt)
    out["n_steps"] = (float(held_out_steps(problem)), float(held_out_steps(run.problem)))
    return out


def held_out_positions(problem, values, seed: int, n_particles: int = 200) -> np.ndarray:
    """Every state (T+1, N, 2) of ``n_particles`` paths of design ``values`` from ``default_rng(seed)``."""
    return check_kind(problem).positions(problem, values, seed, n_particles)
