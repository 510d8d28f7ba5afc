"""Populations: many scenes of one shape run forward as one simulation.

A search that evaluates many candidate surfaces on the same particles (a generation of the
polish's CMA-ES, a parameter study) pays the hot loop's per-step cost once per run; at small
N that cost is most of a run (``docs/performance.md``). [`simulate_batch`][pes_ref.core.population.simulate_batch] runs
the
scenes together instead: their grids are stacked, each particle carries its scene's grid as
the row offset of that grid in the stacked per-cell tables (``Field.offsets``), added to the
cell index after the lookup, and the springs, walls, mass, damping, mobility and external
force become per-particle arrays, so each scene keeps its own. Particles never interact, so
each member's trajectory is the one its own [`pes_ref.simulate`][pes_ref.core.scene.simulate] gives, bit for bit
(``tests/core/test_population.py``; a member without a term another member has gets that
term with a zero coefficient, which changes no value).

The scenes share what one run shares: the grid's shape, domain, topology and
interpolation, and ``dt``, ``n_steps``, ``mode``, ``integrator`` and ``t0``. The grid values,
springs, walls, mass, damping, mobility, effects and the particles (their number too) may
differ. Gradients are not batched: [`pes_ref.value_and_grad`][pes_ref.core.scene.value_and_grad] runs one scene.

Examples
--------
>>> import numpy as np, pes_ref as pr
>>> scenes = [pr.Scene(pr.Surface(np.full((8, 8), c), (0, 0), (1, 1), (True, False)), dt=0.01, n_steps=5)
...           for c in (0.0, 1.0)]
>>> a, b = pr.simulate_batch(scenes, [[[0.2, 0.5]], [[0.3, 0.4], [0.6, 0.7]]])
>>> a.x.shape, b.x.shape
((6, 1, 2), (6, 2, 2))
"""
from __future__ import annotations

import numpy as np

from pes_ref.core import backends, budget, checks, stability
from pes_ref.core.effects import all_zero, build_schedule
from pes_ref.core.forces import Field
from pes_ref.core.integrator import NonFiniteError, Trajectory
from pes_ref.core.runtime import pages
from pes_ref.core.scene import Scene, _check_state, _step_params
from pes_ref.core.steppers import StepParams

__all__ = ["simulate_batch", "SHARED"]

#: What the scenes of a population share: the scene's fields, then the surface's.
SHARED = (("dt", "n_steps", "mode", "integrator", "t0"), ("shape", "lower", "upper", "periodic", "interpolation"))


def _same(a, b) -> bool:
    return np.array_equal(a, b) if isinstance(a, np.ndarray) or isinstance(b, np.ndarray) else a == b


def _check_scenes(scenes) -> tuple:
    try:
        scenes = tuple(scenes)
    except TypeError:
        raise checks.InputTypeError("scenes", f"scenes must be a sequence of pes_ref.Scene, got {scenes!r}") from None
    if not scenes:
        raise checks.InputError("scenes", "scenes must hold at least one pes_ref.Scene, got none")
    first = scenes[0]
    for i, scene in enumerate(scenes):
        if not isinstance(scene, Scene):
            raise checks.InputTypeError("scenes", f"scenes[{i}] must be a pes_ref.Scene, got {type(scene).__name__}")
        for owner, names in ((lambda s: s, SHARED[0]), (lambda s: s.surface, SHARED[1])):
            for name in names:
                mine, theirs = getattr(owner(scene), name), getattr(owner(first), name)
                if not _same(mine, theirs):
                    raise checks.InputError("scenes", f"scenes[{i}] has {name} = {mine!r}, scenes[0] {theirs!r}: "
                                                      f"the scenes of a population share {', '.join(SHARED[0])} "
                                                      f"and their surface's {', '.join(SHARED[1])}")
    return scenes


def _states(scenes, x0s, v0s) -> list:
    """``(x0, v0)`` of each scene, checked as [`pes_ref.simulate`][pes_ref.core.scene.simulate] checks them; an error
    names the member (``x0s[i]``)."""
    x0s = list(x0s)
    v0s = [None] * len(scenes) if v0s is None else list(v0s)
    for name, given in (("x0s", x0s), ("v0s", v0s)):
        if len(given) != len(scenes):
            raise checks.InputError(name, f"{name} must hold one state per scene ({len(scenes)}), got {len(given)}")
    out = []
    for i, (scene, x0, v0) in enumerate(zip(scenes, x0s, v0s)):
        try:
            out.append(_check_state(scene, x0, v0))
        except checks.InputError as err:
            raise type(err)(f"{err.key}s", f"{err.key}s[{i}]: {err}") from None
        except ValueError as err:
            raise ValueError(f"scenes[{i}]: {err}") from None
    return out


def _stack(arrays: list, counts: list) -> np.ndarray:
    """Per-member arrays broadcast to (n_i, 2), one after another: (N, 2)."""
    return np.concatenate([np.broadcast_to(np.asarray(a, dtype=np.float64), (n, 2)) for a, n in zip(arrays, counts)])


def _population_field(scenes, counts) -> Field:
    """One [`Field`][pes_ref.core.forces.Field] for every member: stacked grids, each
    particle's grid offset, and the terms as per-particle arrays (zero where a member has
    no such term)."""
    fields = [scene.field() for scene in scenes]
    first = fields[0]
    size = int(np.prod(first.values.shape))
    offsets = np.repeat(np.arange(len(scenes), dtype=np.intp) * size, counts)
    spring = walls = None
    if any(f.spring is not None for f in fields):
        spring = tuple(_stack([0.0 if f.spring is None else f.spring[j] for f in fields], counts) for j in range(2))
    if any(f.walls is not None for f in fields):
        none = (0.0, -np.inf, np.inf)
        walls = tuple(_stack([(none if f.walls is None else f.walls)[j] for f in fields], counts) for j in range(3))
    return first._replace(values=np.stack([f.values for f in fields]), spring=spring, walls=walls, offsets=offsets)


def _population_params(scenes, counts, progress, out) -> StepParams:
    params = [_step_params(scene) for scene in scenes]
    damping = None
    if any(p.damping is not None for p in params):
        damping = _stack([0.0 if p.damping is None else p.damping for p in params], counts)
    mobility = None if params[0].mobility is None else _stack([p.mobility for p in params], counts)
    return StepParams(params[0].dt, params[0].n_steps, _stack([p.mass for p in params], counts), damping, mobility,
                      progress, refuse_nonfinite=False, out=out)


def _population_fext(scenes, counts, sched):
    """Each member's external force (its effects' schedule, zeros without or when they all
    push with 0) realized side by side into ``sched`` (T+1, N, 2); None when no member has
    one (as [`pes_ref.simulate`][pes_ref.core.scene.simulate] gives the core none)."""
    if all(all_zero(scene.effects) for scene in scenes):
        return None
    start = 0
    for scene, n in zip(scenes, counts):
        part = sched[:, start:start + n]
        if all_zero(scene.effects):
            part.fill(0.0)
        else:
            build_schedule(scene.effects, n, scene.n_steps, scene.dt, scene.t0, out=part)
        start += n
    return sched


def _workspace(workspace, n_steps: int, n: int) -> tuple:
    """``(trajectory, schedule)`` arrays (T+1, N, 2) for a population: kept in ``workspace``
    (a dict) between calls of one size, else fresh."""
    shape = (n_steps + 1, n, 2)
    if workspace is None:
        return None, pages.empty(shape)
    if workspace.get("shape") != shape:
        workspace.clear()
        workspace.update(shape=shape, out=Trajectory(pages.empty(shape), pages.empty(shape), pages.empty(shape)),
                         fext=pages.empty(shape))
    return workspace["out"], workspace["fext"]


def _member(traj: Trajectory, start: int, stop: int) -> Trajectory:
    return Trajectory(traj.x[:, start:stop], traj.v[:, start:stop], traj.f[:, start:stop])


def _nonfinite(scene: Scene, i: int, traj: Trajectory):
    """The [`NonFiniteError`][pes_ref.core.integrator.NonFiniteError] of member ``i`` if its part left the finite numbers, else None."""
    last = (traj.x[-1], traj.v[-1], traj.f[-1])
    if all(np.isfinite(a).all() for a in last):
        return None
    finite = np.isfinite(traj.x).all(axis=(1, 2)) & np.isfinite(traj.v).all(axis=(1, 2)) & \
        np.isfinite(traj.f).all(axis=(1, 2))
    bad = int(np.argmax(~finite))
    return NonFiniteError(f"scenes[{i}]: the trajectory became non-finite at step {bad}; "
                          f"{stability.advice(scene)}")


def simulate_batch(scenes, x0s, v0s=None, *, allow_unstable: bool = False, progress=None,
                   backend: str | None = None, return_errors: bool = False, workspace: dict | None = None) -> list:
    """Run many scenes of one shape forward as one simulation (see the module docstring).

    Parameters
    ----------
    scenes : sequence of Scene
        They share ``dt``, ``n_steps``, ``mode``, ``integrator``, ``t0`` and their surface's
        shape, ``lower``, ``upper``, ``periodic`` and ``interpolation`` (`SHARED`).
    x0s : sequence of array_like (N_i, 2)
        Each scene's initial positions.
    v0s : sequence of array_like (N_i, 2) or None, optional
        Each scene's initial velocities (zeros where None).
    allow_unstable, progress, backend
        As in [`pes_ref.simulate`][pes_ref.core.scene.simulate] (each scene is checked against the stability rule;
        the memory of the whole population is checked once).
    return_errors : bool
        A member whose trajectory leaves the finite numbers raises its
        [`NonFiniteError`][pes_ref.core.integrator.NonFiniteError] (naming ``scenes[i]``); with True
        the error takes its place in the list and the others are returned.
    workspace : dict, optional
        Keeps the population's (T+1, N, 2) arrays between calls (pass the same empty dict
        to every call of a loop that runs many populations of one size): a fresh large
        array costs its page faults every time. The trajectories returned are then valid
        until the next call with that workspace. One workspace per thread.

    Returns
    -------
    list of Trajectory
        One per scene, in order, each bit-identical to ``pes_ref.simulate(scene, x0, v0)``.
        Their arrays are views of the population's (T+1, N, 2) arrays.
    """
    scenes = _check_scenes(scenes)
    states = _states(scenes, x0s, v0s)
    backend = backends.check_backend(backend)
    if not isinstance(allow_unstable, (bool, np.bool_)):
        raise checks.InputTypeError("allow_unstable", f"allow_unstable must be True or False, got {allow_unstable!r}")
    if progress is not None and not callable(progress):
        raise checks.InputTypeError("progress", f"progress must be a callable (phase, done, total) or None, "
                                                f"got {progress!r}")
    if workspace is not None and not isinstance(workspace, dict):
        raise checks.InputTypeError("workspace", f"workspace must be a dict or None, got {type(workspace).__name__}")
    if not allow_unstable:
        for i, scene in enumerate(scenes):
            try:
                stability.check_stable(scene, backend)
            except stability.UnstableStepError as err:
                raise stability.UnstableStepError(err.key, f"scenes[{i}]: {err}") from None
    counts = [x0.shape[0] for x0, _ in states]
    budget.check_memory(scenes[0].n_steps, sum(counts), "simulate")
    out, sched = _workspace(workspace, scenes[0].n_steps, sum(counts))
    field = _population_field(scenes, counts)
    params = _population_params(scenes, counts, progress, out)
    fext = _population_fext(scenes, counts, sched)
    x0 = np.concatenate([x0 for x0, _ in states])
    v0 = np.concatenate([v0 for _, v0 in states])
    first = scenes[0]
    run = backends.stepper(backend, first.mode, first.integrator, first.surface.interpolation)
    traj = run.simulate(field, x0, v0, fext, params)
    out, start = [], 0
    for i, (scene, n) in enumerate(zip(scenes, counts)):
        member = _member(traj, start, start + n)
        err = _nonfinite(scene, i, member)
        if err is not None and not return_errors:
            raise err
        out.append(member if err is None else err)
        start += n
    return out
