"""The rigid engine: a scene's run with the device's parts in rigid contact instead of eq. (1).

[`simulate`][pes_ref.rigid.engine.simulate] runs the particles of a scene as the device's two parts in pymunk
([`pes_ref.rigid.bodies`][pes_ref.rigid.bodies]), one space per particle. Everything but the contact is the
scene's and is applied as a generalized force on each axis, held over each step:

- the external force of the scene's effects (pushes and noise: the same draws as the
  surface model's run, [`pes_ref.core.scene.Scene.schedule`][pes_ref.core.scene.Scene.schedule], so
  a noise force held over a step is the same impulse ``F dt``), or a given schedule ``fext``;
- the device's springs (``[energy] springs``,
  [`pes_ref.devices.cspace.GridSpring.force`][pes_ref.devices.cspace.GridSpring.force])
  and the scene's linear spring, its walls and its damping (``-c q'``).

The scene's surface is not used: the parts' contact replaces eq. (1) of the distance to
blocked space. The dynamic step is pymunk's (semi-implicit Euler with the contact solved as
velocity constraints, inelastic and frictionless unless the device's ``[rigid]`` table says
otherwise) at the scene's ``dt``, cut into substeps so that no point of a part moves more than
`SUBSTEP_SHARE` of a C-space cell (`pes_ref.rigid.bodies.RigidParts.cell`) in one:
the parts cannot pass through each other. The quasistatic step gives each part, in every
substep, the force that brings it to the velocity the mobility gives the force
(``q' = mobility F``), and the contact takes away what the parts forbid before the parts move
(pymunk moves the bodies with the velocities its last contact solve left; the bodies'
masses are the inverse mobilities). Consecutive quasistatic steps under one external force
that together move a part by at most `BLOCK_SHARE` of a cell are one pymunk step
(`_block`): the scene's mobility is the surface's stable one, far smaller than the
rigid parts need.
"""
from __future__ import annotations

import math

import numpy as np

from pes_ref.core import budget, checks
from pes_ref.core.integrator import Trajectory
from pes_ref.core.runtime.progress import EVERY
from pes_ref.devices.forces import scene_forces, scene_wall_bounds
from pes_ref.devices.geometry import interiors_overlap, pose, require_shapely
from pes_ref.rigid.bodies import rigid_parts

__all__ = ["simulate", "blocked_starts", "SUBSTEP_SHARE", "MAX_SUBSTEPS", "BLOCK_SHARE", "MAX_BLOCK",
           "StartBlockedError"]

#: The largest move of a part's point in one substep, as a share of the C-space cell.
SUBSTEP_SHARE = 0.5
#: How far the parts may overlap at a start, as a share of the C-space cell: a substep's
#: move (`SUBSTEP_SHARE`). Pymunk finds a contact once the parts overlap, within the
#: substep that brought them together, and pushes them apart in the next one: a run stopped
#: there (a drive's chunk) leaves an overlap of up to a substep's move, which the run that
#: goes on from that state must accept.
START_ALLOWANCE = SUBSTEP_SHARE
#: The most substeps one step is cut into (a faster part is refused: its step is too long).
MAX_SUBSTEPS = 256
#: Quasistatic blocks. A quasistatic step moves each part by ``dt`` times the velocity the
#: mobility gives the force; the scene's mobility is the surface's stable one, which its stiff
#: barrier makes small (the Geneva's crank moves 1/200 of a cell a step). The rigid parts have
#: no barrier: consecutive steps that together move a part by at most ``BLOCK_SHARE`` of a cell,
#: under one external force, are one pymunk step under the force at the block's start; the
#: states in between lie on the line between the block's ends (their forces evaluated there).
#: A share well below a substep's: while one part pushes the other along a curved path, the
#: contact comes loose now and then and the parts then overlap by up to one pymunk step's move.
BLOCK_SHARE = 0.05
#: The most steps in one block.
MAX_BLOCK = 64


class StartBlockedError(checks.InputError):
    """A particle starts with the parts overlapping (inside blocked space)."""


_forces = scene_forces          # the generalized force on every particle but the contact's and the external one


def blocked_starts(device, x0, allowance: float | None = None) -> np.ndarray:
    """(N,) bool: where the parts posed at ``x0`` (N, 2) overlap by more than ``allowance`` (a
    length; default `START_ALLOWANCE` of the C-space cell): the starts the engine refuses."""
    shapely = require_shapely()
    x0 = np.asarray(x0, dtype=float)
    if allowance is None:
        allowance = START_ALLOWANCE * rigid_parts(device, (1.0, 1.0)).cell
    tol = device.grid.tolerance
    a = shapely.buffer(pose(device.parts[0], x0[:, 0], tol), -allowance)
    b = pose(device.parts[1], x0[:, 1], tol)
    return np.asarray(interiors_overlap(a, b), dtype=bool)


def check_start(device, x0, allowance: float) -> None:
    """Refuse starts where the posed parts overlap by more than ``allowance`` (a length: the
    contact's own overlap, so that a run can go on from where another stopped)
    ([`StartBlockedError`][pes_ref.rigid.engine.StartBlockedError] naming ``x0``)."""
    bad = np.nonzero(blocked_starts(device, x0, allowance))[0]
    if bad.size:
        i = int(bad[0])
        raise StartBlockedError("x0", f"x0[{i}] = ({x0[i, 0]:.6g}, {x0[i, 1]:.6g}) is inside blocked space (the "
                                      f"parts overlap there; {bad.size} of {x0.shape[0]} starts are): the rigid "
                                      f"engine needs the parts apart at the start")


def simulate(device, scene, x0, v0=None, *, fext="scene", progress=None) -> Trajectory:
    """Run ``scene``'s particles as ``device``'s parts in rigid contact (module docstring).

    Parameters
    ----------
    device : pes_ref.devices.device.Device
        The parts (and their springs, restitution and friction).
    scene : pes_ref.core.scene.Scene
        The step, steps, mode, masses (or mobility), damping, spring, walls and effects; its
        surface is not used. A mass or damping per particle is refused.
    x0, v0 : array_like (N, 2)
        The starts (unwrapped coordinates); ``v0`` zeros if omitted (ignored quasistatically).
    fext : "scene", None or ndarray (T+1, N, 2)
        The external force (default: the scene's effects' schedule).
    progress : callable, optional
        ``progress(phase, done, total)`` with ``phase = "rigid"``.

    Returns
    -------
    Trajectory
        ``x``, ``v`` (zeros quasistatically) and ``f``: the force other than the contact's
        acting at each state, (T+1, N, 2).
    """
    x0 = checks.as_float_array("x0", x0, ndim=2)
    if x0.shape[1] != 2:
        raise checks.InputError("x0", f"x0 must have shape (N, 2), got {x0.shape}")
    n = x0.shape[0]
    v0 = np.zeros_like(x0) if v0 is None else checks.as_float_array("v0", v0, shape=x0.shape)
    quasistatic = scene.mode == "quasistatic"
    per_axis = (1.0 / np.asarray(scene.mobility, dtype=float)) if quasistatic else np.asarray(scene.mass, dtype=float)
    if per_axis.size not in (1, 2) or (scene.damping is not None and np.asarray(scene.damping).size > 2):
        raise checks.InputError("mass", "the rigid engine takes one mass (and damping) per axis, not per particle")
    mass = np.broadcast_to(per_axis.reshape(-1), (2,)).astype(float)
    budget.check_memory(scene.n_steps, n, "simulate")
    if isinstance(fext, str) and fext == "scene":
        fext = scene.schedule(n)
    elif fext is not None:
        fext = checks.as_float_array("fext", fext, shape=(scene.n_steps + 1, n, 2))
    parts = rigid_parts(device, mass, quasistatic)
    check_start(device, x0, START_ALLOWANCE * parts.cell)
    lo_hi = scene_wall_bounds(scene)
    return _run(parts, scene, x0, v0, fext, lo_hi, progress)


def _block(qdot, reach, dt: float, left: int, changes, k: int) -> int:
    """How many quasistatic steps from step ``k`` one pymunk step spans: as many as keep every
    part's free move within `BLOCK_SHARE` of a cell (at most `MAX_BLOCK`, the steps
    ``left``, and up to the next step at which the external force changes, ``changes``)."""
    per_step = float(np.max(np.sum(np.abs(qdot) * reach, axis=1))) * dt * SUBSTEP_SHARE / BLOCK_SHARE
    b = MAX_BLOCK if per_step * MAX_BLOCK <= 1.0 else max(1, int(1.0 / per_step))
    nxt = np.searchsorted(changes, k, side="right")
    if nxt < changes.size:
        b = min(b, int(changes[nxt]) - k)
    return max(1, min(b, left))


def _run(parts, scene, x0, v0, fext, lo_hi, progress) -> Trajectory:
    device = parts.device
    n, steps, dt = x0.shape[0], scene.n_steps, scene.dt
    quasistatic = parts.quasistatic
    x = np.empty((steps + 1, n, 2))
    v = np.zeros((steps + 1, n, 2))
    f = np.empty((steps + 1, n, 2))
    worlds = [parts.space() for _ in range(n)]
    turns = np.zeros((n, 2), dtype=np.int64)
    for i, (space, handles) in enumerate(worlds):
        for d, (entry, body, data) in enumerate(handles):
            turns[i, d] = entry.place(body, data, float(x0[i, d]))
            entry.set_velocity(body, data, 0.0 if quasistatic else float(v0[i, d]))
            space.reindex_shapes_for_body(body)
    x[0] = x0
    if not quasistatic:
        v[0] = v0
    force = np.empty((n, 2))
    reach = parts.levers / (SUBSTEP_SHARE * parts.cell)
    mobility = None if not quasistatic else np.asarray(scene.mobility, dtype=float).reshape(-1)
    # the steps at which the external force changes (a block of quasistatic steps holds one force)
    changes = np.zeros(0, dtype=np.int64) if fext is None else \
        np.flatnonzero(np.any(fext[1:] != fext[:-1], axis=(1, 2))) + 1
    k, told = 0, 0
    if progress is not None:
        progress("rigid", 0, steps)
    while True:
        _forces(device, scene, x[k], v[k], lo_hi, force)
        if fext is not None:
            force += fext[k]
        f[k] = force
        if k == steps:
            break
        qdot = mobility * force if quasistatic else v[k]
        b = _block(qdot, reach, dt, steps - k, changes, k) if quasistatic else 1
        span = b * dt
        for i, (space, handles) in enumerate(worlds):
            move = float(np.sum(np.abs(qdot[i]) * reach)) * span
            if not quasistatic:
                move += float(np.sum(np.abs(force[i]) / parts.mass * reach)) * dt * dt
            sub = max(1, math.ceil(move))
            if sub > MAX_SUBSTEPS:
                raise checks.InputError("dt", f"a part moves {move * SUBSTEP_SHARE:.3g} C-space cells in one step "
                                              f"of dt = {dt:g} (particle {i}, step {k}); the rigid engine allows "
                                              f"{MAX_SUBSTEPS * SUBSTEP_SHARE:g}: use a shorter dt")
            h = span / sub
            for _ in range(sub):
                for d, (entry, body, data) in enumerate(handles):
                    if quasistatic:       # the force that gives the velocity mobility F in one substep
                        now = entry.read(body, data, turns[i, d])[1]
                        entry.push(body, data, float(parts.mass[d] * (qdot[i, d] - now) / h))
                    else:                 # pymunk clears a body's force after every step
                        entry.push(body, data, float(force[i, d]))
                space.step(h)
            for d, (entry, body, data) in enumerate(handles):
                turns[i, d] += entry.rewrap(space, body, data)
                q, qd = entry.read(body, data, turns[i, d])
                x[k + b, i, d] = q
                if not quasistatic:
                    v[k + b, i, d] = qd
        for j in range(1, b):             # the steps within a block: on the line between its ends
            x[k + j] = x[k] + (j / b) * (x[k + b] - x[k])
            _forces(device, scene, x[k + j], v[k + j], lo_hi, f[k + j])
            if fext is not None:
                f[k + j] += fext[k + j]
        k += b
        if progress is not None and k - told >= EVERY:
            told = k
            progress("rigid", k, steps)
    if progress is not None:
        progress("rigid", steps, steps)
    return Trajectory(x, v, f)

