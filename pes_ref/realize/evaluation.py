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
"""
from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from pes_ref.core import checks
from pes_ref.core.stability import SAFETY, stability_limit
from pes_ref.synthesis.analysis import evaluate, funnel_paths

__all__ = ["RealizedRun", "realized_problem", "plain_problem", "evaluate_realized", "held_out_positions", "REALIZABLE_KINDS"]

#: The design kinds a device can stand in for: their surface is one grid the device replaces.
REALIZABLE_KINDS = ("funnel",)


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
        raise checks.InputError("realized", f"realization covers {', '.join(REALIZABLE_KINDS)} designs (a plane); "
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
    values = np.asarray(device.surface().values, dtype=np.float64)
    plain = plain_problem(problem)
    lim = stability_limit(plain.scene(values), "rule")
    if lim.ratio <= 1.0:
        return RealizedRun(plain, values, plain.dt, plain.n_steps)
    dt = SAFETY * lim.limit
    n_steps = int(math.ceil(plain.n_steps * plain.dt / dt))
    noise = plain.noise * math.sqrt(plain.dt / dt)
    return RealizedRun(dataclasses.replace(plain, dt=dt, n_steps=n_steps, noise=noise), values, dt, n_steps)


def plain_problem(problem):
    """``problem`` with its grid values the surface's energies (a realizable problem's level
    set turned off): what runs a realized surface."""
    return dataclasses.replace(problem, realizable=False) if getattr(problem, "realizable", False) else problem


def evaluate_realized(problem, values, device, seed: int = 12345, n_particles: int | None = None) -> dict:
    """The design's figures and the realized device's, side by side: ``{name: (design, realized)}``,
    plus ``dt`` and ``n_steps`` of each run (the realized run's as the rule allows)."""
    run = realized_problem(problem, device)
    design = evaluate(problem, values, seed=seed, n_particles=n_particles)
    realized = evaluate(run.problem, run.values, seed=seed, n_particles=n_particles)
    out = {name: (value, realized[name]) for name, value in design.items() if not name.startswith("flat_")}
    out["dt"] = (float(problem.dt), run.dt)
    out["n_steps"] = (float(problem.n_steps), float(run.n_steps))
    return out


def held_out_positions(problem, values, seed: int, n_particles: int = 200) -> np.ndarray:
    """Every state (T+1, N, 2) of ``n_particles`` paths of design ``values`` from ``default_rng(seed)``."""
    check_kind(problem)
    return funnel_paths(problem, values, n_particles, seed).traj.x
