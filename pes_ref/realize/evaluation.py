"""The design's own held-out evaluation on a realized device (``evaluate DESIGN.npz --realized DEVICE.toml``).

The realized device is rebuilt from its file
([`pes_ref.devices.device_file.load_device`][pes_ref.devices.device_file.load_device]):
its C-space from the exported parts and eq. (1) of the distance to it give the surface, and
its kept springs (``[energy] springs``) act as the scene's linear springs
([`device_spring`][pes_ref.realize.evaluation.device_spring];
the device analyses bake them into the grid, where a stiff spring's force becomes a staircase
of the grid's cells); everything else is the design's (its forces, noise, damping, masses and walls,
its held-out starts and its figures). The realized surface's barriers are stiffer than the
design's smooth slopes, so the run takes the step the stability rule allows
([`pes_ref.core.stability.check_stable`][pes_ref.core.stability.check_stable], ``docs/spec.md`` section 10):

- the design's own ``dt`` where the rule accepts it on the realized scene;
- otherwise `pes_ref.core.stability.SAFETY` times the limit of the realized scene's
  stiffest term, with the number of steps raised to cover the design's duration
  (``ceil(n_steps dt / dt_realized)``) and the noise's per-step std scaled by
  ``sqrt(dt / dt_realized)``, so that the noise's diffusion (its variance per unit time) is
  the design's.

The same held-out evaluation runs on the parts in rigid contact too
([`rigid_problem`][pes_ref.realize.evaluation.rigid_problem],
the rigid engine [`pes_ref.rigid.simulate`][pes_ref.rigid.engine.simulate] as the kinds' ``engine``): the same starts,
force schedules and noise draws, steps and figures, with the parts' contact in place of
eq. (1). That engine needs no step for the barriers (it cuts each step into substeps that
move no part more than half a C-space cell), so it runs at the design's own ``dt`` unless the
springs, walls or damping need less by the same rule (the rule applied to the scene on a flat
surface). `pes_ref.rigid.engines.ENGINES` names both; [`evaluate_realized`][pes_ref.realize.evaluation.evaluate_realized] runs the ones asked
for.

What a realization needs of each kind of design is its kind's entry,
`pes_ref.synthesis.kinds.registry.DesignKind.realizable`.
"""
from __future__ import annotations

from typing import Callable, NamedTuple

import numpy as np

from pes_ref.core import checks
from pes_ref.core.stability import SAFETY, stability_limit
from pes_ref.synthesis.kinds.registry import HELD_OUT, evaluate, held_out_steps, kind_of

__all__ = ["RealizedRun", "RigidRuns", "realized_run", "realized_problem", "rigid_problem", "evaluate_realized",
           "headline_scores", "device_spring", "check_design"]


class RealizedRun(NamedTuple):
    """The design's problem on the realized device: ``problem`` (the design's, at the step the
    rule allows), the grid ``values`` its scenes are built on, the step ``dt`` and ``n_steps``
    it takes, and the ``engine`` that runs its scenes (None: the surface model; see
    [`pes_ref.synthesis.kinds.registry.evaluate`][pes_ref.synthesis.kinds.registry.evaluate])."""

    problem: object
    values: np.ndarray
    dt: float
    n_steps: int
    engine: Callable | None = None


def _check_grid(problem, device) -> None:
    """Refuse a device whose grid is not the design's surface grid (key ``realized``)."""
    shape = tuple(problem.shape())
    if tuple(device.shape) != shape or not (np.allclose(device.lower, problem.lower)
                                            and np.allclose(device.upper, problem.upper)):
        raise checks.InputError("realized", f"the device's grid ({device.shape[0]} x {device.shape[1]} on "
                                            f"{list(map(float, device.lower))} .. {list(map(float, device.upper))}) "
                                            f"is not the design's ({shape[0]} x {shape[1]} on "
                                            f"{list(map(float, problem.lower))} .. {list(map(float, problem.upper))})")


def check_design(problem, values, device) -> None:
    """Refuse (key ``realized``) a device a realization made from another design: its
    ``[realized] design`` hash is not this design's (`pes_ref.realize.contact.design_hash`).
    A device without one (not written by ``realize``) is not checked."""
    from pes_ref.realize.contact import design_hash
    if device.design is None:
        return
    mine = design_hash(problem, values)
    if device.design != mine:
        raise checks.InputError("realized", f"the parts were made from another design ([realized] design = "
                                            f"{device.design[:19]}..., this design's {mine[:19]}...): realize this "
                                            f"design, or give --force to evaluate it on these parts anyway")


def realized_problem(problem, device) -> RealizedRun:
    """The design ``problem`` on ``device``'s surface, at the step the stability rule allows
    (module docstring). The device's grid must be the design's surface grid."""
    _check_grid(problem, device)
    values = np.asarray(device.cspace().surface(device.v, device.r_c, (), device.r_min).values, dtype=np.float64)
    entry = kind_of(problem).realizable
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


def rigid_problem(problem, device) -> RealizedRun:
    """The design ``problem`` on ``device``'s parts in rigid contact (module docstring): the
    design's scenes, at its own ``dt`` unless the springs, walls or damping need less, run by
    [`pes_ref.rigid.simulate`][pes_ref.rigid.engine.simulate]. The device's springs act in the
    engine ([`pes_ref.devices.cspace.GridSpring.force`][pes_ref.devices.cspace.GridSpring.force]),
    so the scenes have none of their own; their surface (flat) is not used."""
    from pes_ref.rigid import require_pymunk
    require_pymunk()                           # refused before any run, with the pip line
    _check_grid(problem, device)
    entry = kind_of(problem).realizable
    values = np.zeros(tuple(problem.shape()))
    lim = stability_limit(entry.with_spring(problem.plain(), device_spring(device)).scene(values), "rule")
    base = problem if lim.ratio <= 1.0 else entry.at_step(problem, SAFETY * lim.limit)
    run = entry.with_spring(base.plain(), None)
    return RealizedRun(run, values, float(run.dt), int(run.n_steps), RigidRuns(device))


class RigidRuns:
    """The kinds' ``engine`` of the rigid engine: each scene's run on ``device``'s parts.

    A start where the parts overlap (a design's start inside what the parts block: the
    surface model pushes it out, a rigid part cannot be put there) is not run: its path is
    NaN throughout, so it passes no test, and `blocked` counts such starts of the
    `starts` it was given (every scene's)."""

    def __init__(self, device):
        self.device = device
        self.blocked = 0
        self.starts = 0

    def __call__(self, scenes, x0s, v0s) -> list:
        from pes_ref.core.integrator import Trajectory
        from pes_ref.rigid import blocked_starts, simulate
        out = []
        for scene, x0, v0 in zip(scenes, x0s, v0s):
            x0 = np.asarray(x0, dtype=float)
            v0 = np.zeros_like(x0) if v0 is None else np.asarray(v0, dtype=float)
            free = ~blocked_starts(self.device, x0)
            self.blocked += int(np.sum(~free))
            self.starts += int(free.size)
            full = [np.full((scene.n_steps + 1,) + x0.shape, np.nan) for _ in range(3)]
            if free.any():
                fext = scene.schedule(x0.shape[0])               # every particle's own draws and pushes
                fext = None if fext is None else fext[:, free]
                traj = simulate(self.device, scene, x0[free], v0[free], fext=fext)
                for whole, part in zip(full, (traj.x, traj.v, traj.f)):
                    whole[:, free] = part
            out.append(Trajectory(*full))
        return out


def realized_run(problem, device, engine: str) -> RealizedRun:
    """The design ``problem`` on ``device`` as engine ``engine`` of the one registry
    (`pes_ref.rigid.engines.ENGINES`) runs it: in contact (the
    rigid parts, `rigid_problem`) or on eq. (1) of the distance to the parts (`realized_problem`)."""
    from pes_ref.rigid.engines import ENGINES
    name = checks.as_choice("engine", engine, set(ENGINES))
    return (rigid_problem if ENGINES[name].contact else realized_problem)(problem, device)


def evaluate_realized(problem, values, device, seed: int = HELD_OUT["seed"], n_particles: int | None = None,
                      engines=("surface",)) -> dict:
    """The design's figures and the realized device's under each of ``engines`` (names of
    `pes_ref.rigid.engines.ENGINES`), side by side: ``{name: (design, engine 1, ...)}``, plus ``dt`` and the
    held-out run's steps ``n_steps`` of each (a realized run's as its engine's rule allows).
    The flat surface's figures (the same for all) are left out."""
    runs = [realized_run(problem, device, name) for name in engines]
    columns = [evaluate(problem, values, seed=seed, n_particles=n_particles)]
    columns += [evaluate(run.problem, run.values, seed=seed, n_particles=n_particles, engine=run.engine)
                for run in runs]
    out = {name: tuple(column[name] for column in columns) for name in columns[0] if not name.startswith("flat_")}
    out["dt"] = (float(problem.dt),) + tuple(float(run.dt) for run in runs)
    if any(isinstance(run.engine, RigidRuns) for run in runs):        # starts a rigid part cannot be put at
        out["starts_blocked"] = (0.0,) + tuple(float(getattr(run.engine, "blocked", 0)) for run in runs)
        out["starts_run"] = (0.0,) + tuple(float(getattr(run.engine, "starts", 0)) for run in runs)
    out["n_steps"] = (float(held_out_steps(problem)),) + tuple(float(held_out_steps(run.problem)) for run in runs)
    return out


def headline_scores(problem, values, device, seed: int = HELD_OUT["seed"], n_particles: int | None = None) -> dict:
    """The design's headline figure (its kind's, `pes_ref.synthesis.kinds.registry.KINDS`) on held-out
    ``seed`` beside the parts' under eq. (1) (``realized_``) and in rigid contact (``rigid_``; without
    pymunk its value says it was not run, with the pip line), with ``score_seed`` and ``score_particles``,
    and how many of the rigid run's starts (every scene's) lie inside the parts (``rigid_starts_blocked``)."""
    from pes_ref.core.runtime.extras import MissingExtraError
    from pes_ref.rigid import require_pymunk
    from pes_ref.rigid.engines import ENGINES
    try:
        require_pymunk()
        engines, missing = ("surface", "rigid"), None
    except MissingExtraError as exc:
        engines, missing = ("surface",), str(exc)
    figures = evaluate_realized(problem, values, device, seed=seed, n_particles=n_particles, engines=engines)
    name = kind_of(problem).headline
    out = {"score_seed": seed, "score_particles": int(figures["particles"][0]), name: figures[name][0]}
    out.update({ENGINES[e].prefix + name: x for e, x in zip(engines, figures[name][1:])})
    if missing is not None:
        out[ENGINES["rigid"].prefix + name] = f"not run ({missing})"
    else:
        blocked, starts = int(figures["starts_blocked"][-1]), int(figures["starts_run"][-1])
        out[ENGINES["rigid"].prefix + "starts_blocked"] = (
            f"{blocked} of {starts} starts lie inside the parts (not run in rigid contact: each fails every test; "
            f"eq. (1) pushes them out)")
    return out
