"""The forces of a scene on a device other than the parts' contact: what both the rigid engine
([`pes_ref.rigid.engine`][pes_ref.rigid.engine]) and a drive's pass on eq. (1) of the exact distance
([`pes_ref.devices.drive.drive`][pes_ref.devices.drive.drive]) add to the contact they model themselves."""
from __future__ import annotations

import numpy as np

from pes_ref.core.terms import spring_add_force, wall_add_force, wall_bounds

__all__ = ["scene_forces", "scene_wall_bounds"]


def scene_wall_bounds(scene):
    """``(lo, hi)`` of the scene's walls ([`pes_ref.core.terms.wall_bounds`][pes_ref.core.terms.wall_bounds]), or None without walls."""
    if scene.walls is None:
        return None
    return wall_bounds(scene.surface.lower, scene.surface.upper, scene.walls.margin,
                       np.asarray(scene.walls.edges, dtype=bool))


def scene_forces(device, scene, q, v, lo_hi, out) -> np.ndarray:
    """The generalized force on every particle (N, 2) into ``out`` (and returned): the device's
    springs (``[energy] springs``), the scene's linear spring, its walls (``lo_hi``, from
    `scene_wall_bounds`) and, in dynamic mode, its damping; not the contact's nor the
    external one."""
    out.fill(0.0)
    length = np.asarray(scene.surface.length, dtype=float)
    periodic = scene.surface.periodic
    for s in device.springs:
        out[:, s.axis] += s.force(q[:, s.axis], float(length[s.axis]), bool(periodic[s.axis]))
    if scene.spring is not None:
        spring_add_force(q, np.broadcast_to(scene.spring.k, q.shape), np.broadcast_to(scene.spring.center, q.shape),
                         length, periodic, out)
    if lo_hi is not None:
        wall_add_force(q, scene.walls.k, lo_hi[0], lo_hi[1], out)
    if scene.mode == "dynamic" and scene.damping is not None:
        out -= np.broadcast_to(scene.damping, q.shape) * v
    return out
