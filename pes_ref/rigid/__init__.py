"""The rigid engine: a device's parts in rigid contact (pymunk 7, Chipmunk2D), the second opinion
on every device file and every realized design (``docs/rigid.md``).

The optional extra ``rigid`` (``pip install 'pes_ref[rigid]'``); without it, building the
bodies raises [`pes_ref.devices.geometry.MissingExtraError`][pes_ref.core.runtime.extras.MissingExtraError] naming that
line.
"""
from pes_ref.rigid.bodies import MOTION_BODIES, RigidParts, require_pymunk, rigid_parts
from pes_ref.rigid.engine import StartBlockedError, blocked_starts, simulate

__all__ = ["MOTION_BODIES", "RigidParts", "require_pymunk", "rigid_parts", "StartBlockedError", "blocked_starts",
           "simulate"]
