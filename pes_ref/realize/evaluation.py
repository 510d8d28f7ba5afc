"""The design's own held-out evaluation on a realized device (``evaluate DESIGN.npz --realized DEVICE.toml``).

The realized device is rebuilt from its file (:func:`pes_ref.devices.device_file.load_device`):
its C-space from the exported parts, eq. (1) of the distance to it and its kept springs give
the surface; everything else is the design's (its forces, noise, damping, masses and walls,
its held-out starts and its figures). The realized surface's barriers are stiffer than the
design's smooth slopes, so the run takes the step the stability rule allows
(:func:`pes_ref.core.stability.check_stable`, ``docs/spec.md`` section 10):

- the design's own ``dt`` where the rule accepts it on the realized scene;
- otherwise :data:`pes_ref.core.stability.SAFETY` times the limit of the realized scene's
  stiffest term, with the number of steps raised to cover the design's duration
  (``ceil(n_steps dt / dt_realized)``) and the noise's per-step std scaled by
  ``sqrt(dt / dt_realized)``, so that the noise's diffusion (its variance per unit time) is
  the design's.

What a realization needs of each design kind is data, :data:`REALIZABLE_KINDS` (kind ->
:class:`Realizable`): its held-out positions (the ``visited`` rule's paths and the drawing's),
its ``[start]`` row, its eq. (1) parameters, and how its problem runs at another step.

The realized grid is eq. (1) of the device's C-space alone: the design's scene adds its own
springs (the device file keeps them, for the device tools), so they are not counted twice.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Callable, NamedTuple

import numpy as np

from pes_ref.core import checks
from pes_ref.core.stability import SAFETY, stability_limit
from pes_ref.core.surface import spacing as grid_spacing
from pes_ref.synthesis.analysis import evaluate, funnel_paths, held_out_steps, oscillator_torque_sweep

__all__ = ["RealizedRun", "Realizable", "realized_problem", "plain_problem", "evaluate_realized", "held_out_positions",
           "contact_parameters", "start_row", "REALIZABLE_KINDS", "GRID_CONTACT"]


class Realizable(NamedTuple):
    """What realizing and re-simulating a design kind needs (:data:`REALIZABLE_KINDS`).

    positions(problem, values, seed, n) -> (T+1, n, 2)
        Every state of ``n`` of the design's own paths from ``default_rng(seed)``.
    start(problem) -> [q0, q1]
        The device file's ``[start]`` row.
    contact(problem, energy) -> (v, r_c, r_min)
        Eq. (1)'s parameters of the realization (``energy``: the design's surface grid).
    retime(problem, dt) -> problem
        The problem at step ``dt``, its runs as long in time and its noise as strong per unit time.
    """

    positions: Callable
    start: Callable
    contact: Callable
    retime: Callable


#: The oscillator's eq. (1), which it has none of, from its grid (h the spacings, C-space units):
#: the cut-off ``r_c = 2 max(h)`` (the barrier acts within two cells), the cap ``r_min = min(h) / 2``
#: (the smallest distance the grid resolves) and the strength ``v`` that makes the barrier at its
#: cap as high as the design's energy range (a state the design could not reach stays out).
GRID_CONTACT = {"r_c_spacings": 2.0, "r_min_spacings": 0.5}


def _grid_contact(problem, energy) -> tuple:
    h = grid_spacing(np.asarray(problem.lower, dtype=np.float64), np.asarray(problem.upper, dtype=np.float64),
                     np.shape(energy), np.asarray(problem.periodic))
    r_c = GRID_CONTACT["r_c_spacings"] * float(np.max(h))
    r_min = GRID_CONTACT["r_min_spacings"] * float(np.min(h))
    height = float(np.ptp(energy)) or 1.0
    return 2.0 * height / (1.0 / r_min - 1.0 / r_c) ** 2, r_c, r_min


def _funnel_retime(problem, dt: float):
    n_steps = int(math.ceil(problem.n_steps * problem.dt / dt))
    return dataclasses.replace(problem, dt=dt, n_steps=n_steps, noise=problem.noise * math.sqrt(problem.dt / dt))


def _oscillator_retime(problem, dt: float):
    return dataclasses.replace(problem, dt=dt, n_steps=int(math.ceil(problem.n_steps * problem.dt / dt)))


#: The design kinds a device can stand in for (their surface is one grid the device replaces):
#: kind -> :class:`Realizable`.
REALIZABLE_KINDS = {
    "funnel": Realizable(
        positions=lambda problem, values, seed, n: funnel_paths(problem, values, n, seed).traj.x,
        start=lambda problem: [0.0, float(problem.upper[1] - problem.start_depth)],
        contact=lambda problem, energy: (float(problem.contact_v), float(problem.contact_r_c),
                                         float(problem.contact_r_min)),
        retime=_funnel_retime),
    "oscillator": Realizable(
        positions=lambda problem, values, seed, n: oscillator_torque_sweep(problem, values, n, seed=seed).traj.x,
        start=lambda problem: [float(problem.amplitude * (1.0 + problem.kick)), 0.0],
        contact=_grid_contact,
        retime=_oscillator_retime),
}


class RealizedRun(NamedTuple):
    """The design's problem on the realized surface: ``problem`` (the design's, at the step the
    rule allows), the realized grid ``values``, and the step ``dt`` and ``n_steps`` it takes."""

    problem: object
    values: np.ndarray
    dt: float
    n_steps: int


def check_kind(problem) -> None:
    """Refuse a design whose kind no realization covers yet (one line naming the kind)."""
    if problem.kind not in REALIZABLE_KINDS:
        raise checks.InputError("realized", f"realization covers {', '.join(REALIZABLE_KINDS)} designs; "
                                            f"this design is a {problem.kind!r} design")


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
    plain = plain_problem(problem)
    lim = stability_limit(plain.scene(values), "rule")
    if lim.ratio <= 1.0:
        return RealizedRun(plain, values, plain.dt, plain.n_steps)
    run = REALIZABLE_KINDS[problem.kind].retime(plain, SAFETY * lim.limit)
    return RealizedRun(run, values, run.dt, run.n_steps)


def plain_problem(problem):
    """``problem`` with its grid values the surface's energies (a realizable problem's level
    set turned off): what runs a realized surface."""
    return dataclasses.replace(problem, realizable=False) if getattr(problem, "realizable", False) else problem


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
    check_kind(problem)
    return REALIZABLE_KINDS[problem.kind].positions(problem, values, seed, n_particles)


def start_row(problem) -> list:
    """The device file's ``[start]`` row of a design of ``problem``."""
    check_kind(problem)
    return REALIZABLE_KINDS[problem.kind].start(problem)


def contact_parameters(problem, energy) -> tuple:
    """``(v, r_c, r_min)`` of eq. (1) of a contact realization of ``problem``'s design surface ``energy``."""
    check_kind(problem)
    return REALIZABLE_KINDS[problem.kind].contact(problem, energy)
