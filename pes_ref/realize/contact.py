"""A contact realization: a design's blocked region as rigid parts, and what the parts keep and lose.

[`realize_contact`][pes_ref.realize.contact.realize_contact] chooses the blocked region
([`pes_ref.realize.regions.contact_region`][pes_ref.realize.regions.contact_region],
by a stated rule), turns it into the two parts of the topology's follower
(`pes_ref.realize.followers.FOLLOWERS`) and writes their device file's tables:

- ``[energy]``: eq. (1) of the distance to the parts' C-space obstacle, with the design
  kind's contact parameters ([`pes_ref.realize.hooks.contact_parameters`][pes_ref.realize.hooks.contact_parameters]: the
  funnel's ``contact_v``, ``contact_r_c``, ``contact_r_min``, a realizable design's own
  eq. (1); a problem file's ``[surface.contact]``; the oscillator's from its grid), and the
  design's springs (its scene's per-axis spring);
- ``[dynamics]``: the design scene's masses, damping and walls;
- ``[start]``: the design kind's start point ([`pes_ref.realize.hooks.start_point`][pes_ref.realize.hooks.start_point]);
- ``[realized] design``: the design's hash (`design_hash`), which ``evaluate --realized``
  checks the design it is given against.

What the parts cannot have is listed in `ContactRealization.lost`, in words: the
energies below the contact level (flat on the device beyond ``r_c`` of an obstacle), and the
area the pin's disc cannot keep (`pes_ref.realize.followers.Parts.lost_share`).
"""
from __future__ import annotations

import dataclasses
import hashlib
from dataclasses import dataclass

import numpy as np

from pes_ref.core import checks
from pes_ref.realize.hooks import contact_parameters, start_point
from pes_ref.synthesis.kinds.registry import kind_of
from pes_ref.realize.followers import DRUM_CAM, DRUM_RADIUS, Parts, follower_for
from pes_ref.realize.regions import Region, contact_region

__all__ = ["ContactRealization", "realize_contact", "CONTACT_DEFAULTS", "design_hash"]

#: The defaults of the contact realization's settings (C-space length units): the pin's
#: radius, the plate's rim beyond its cut-out (a drum's walls' beyond the drawn box at its
#: ends), the plate's (and pin's, and a drum's walls') thickness in the STL, a drum cam's
#: radius (`pes_ref.realize.followers.DRUM_RADIUS`) and the pin's clearance (how much
#: larger than its cut-out the pin is made, `pes_ref.realize.followers.Parts.clearance`).
CONTACT_DEFAULTS = {"pin_radius": 0.02, "rim": 0.1, "thickness": 0.1, "drum_radius": DRUM_RADIUS, "clearance": 0.0,
                    "units": "mm"}


@dataclass(frozen=True)
class ContactRealization:
    """A design realized by contact: its region, its parts, the device file's tables and what is lost.

    ``sensitivity`` holds, for each level beside the chosen one, ``(label, level,
    blocked_share, changed_share)``: the share of the grid blocked at that level and the share
    whose side differs from the chosen level's. ``units``: what one C-space length unit is in
    the DXF (`pes_ref.realize.exports.DXF_UNITS`); ``dowels``: the centres of the dowel
    holes of radius ``dowel_radius`` that locate a plate's pieces on its base
    (`pes_ref.realize.exports.dowel_holes`; none for one piece or a drum).
    """

    region: Region
    parts: Parts
    device: dict
    lost: tuple
    sensitivity: tuple
    thickness: float
    units: str = "mm"
    dowels: tuple = ()
    dowel_radius: float = 0.0


def design_hash(problem, values) -> str:
    """``"sha256:<hex>"`` of a design: its kind, its problem's text (the design file's,
    `pes_ref.synthesis.kinds.registry.DesignKind.to_text`) and its grid values (shape and float64
    bytes, little-endian). Two designs with the same hash run the same."""
    kind = kind_of(problem)
    grid = np.ascontiguousarray(values, dtype="<f8")
    digest = hashlib.sha256()
    for part in (kind.name, kind.to_text(problem), repr(grid.shape)):
        digest.update(part.encode("utf-8") + b"\0")
    digest.update(grid.tobytes())
    return "sha256:" + digest.hexdigest()


def _free_start(parts, region, q) -> tuple:
    """The device's ``[start]``: the design kind's start ``q``, or where the parts block it (a
    start group's box centre inside a drawn shape), the nearest grid node whose pin stands at
    least half a cell clear of the parts; ``(start, line)``, ``line`` saying so (None: kept)."""
    import shapely
    h = float(np.min(region.spacing))
    obstacle = parts.realized_blocked.buffer(parts.clearance) if parts.clearance else parts.realized_blocked
    if not obstacle.buffer(0.5 * h).contains(shapely.Point(parts.in_frame(np.asarray(q, dtype=float)))):
        return q, None
    axes = [np.linspace(region.lower[d], region.upper[d], region.phi.shape[d], endpoint=not region.periodic[d])
            for d in range(2)]
    nodes = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 2)
    at = parts.in_frame(nodes)
    free = ~shapely.contains_xy(obstacle.buffer(0.5 * h), at[:, 0], at[:, 1])
    if not free.any():
        return q, None
    gap = np.hypot(*(nodes - np.asarray(q, dtype=float)).T)
    best = nodes[np.flatnonzero(free)[np.argmin(gap[free])]]
    start = [float(x) for x in best]
    return start, (f"the problem's start ({q[0]:.6g}, {q[1]:.6g}) lies inside the parts: the device file's [start] "
                   f"is the nearest free grid node ({start[0]:.6g}, {start[1]:.6g})")


def _springs(scene) -> list:
    spring = scene.spring
    if spring is None:
        return []
    k = np.broadcast_to(spring.k, (2,)) if np.ndim(spring.k) <= 1 else None
    c = np.broadcast_to(spring.center, (2,)) if np.ndim(spring.center) <= 1 else None
    if k is None or c is None:
        raise checks.InputError("values", "a spring that differs per particle cannot be built into a part")
    return [{"axis": d, "k": float(k[d]), "center": float(c[d])} for d in range(2) if k[d] > 0]


def realize_contact(problem, values, rule: str | None = None, level: float | None = None, *, name: str = "design",
                    pin_radius: float = CONTACT_DEFAULTS["pin_radius"], rim: float = CONTACT_DEFAULTS["rim"],
                    thickness: float = CONTACT_DEFAULTS["thickness"], drum_radius: float | None = None,
                    clearance: float | None = None, restitution: float | None = None,
                    units: str = CONTACT_DEFAULTS["units"]) -> ContactRealization:
    """Realize design ``values`` of ``problem`` by contact (module docstring); ``drum_radius``
    (a cylinder's drum cam only) defaults to `pes_ref.realize.followers.DRUM_RADIUS`.
    ``clearance``: the pin is made that much larger than part 1 is cut for; ``restitution``:
    the parts' coefficient of restitution, written to the device file's ``[rigid]`` table (the
    rigid engine's). Either None: what the design's problem states (a problem file's
    ``[surface.contact]``, `pes_ref.synthesis.kinds.registry.Realizable.parts`), else no clearance
    and no ``[rigid]`` table (inelastic). ``units``: what one C-space length unit is in the DXF
    (`pes_ref.realize.exports.DXF_UNITS`)."""
    from pes_ref.realize.exports import DOWEL_RIM_SHARE, DXF_UNITS, dowel_holes
    units = checks.as_choice("units", units, set(DXF_UNITS))
    stated = kind_of(problem).realizable.parts(problem)
    clearance = stated.get("clearance", CONTACT_DEFAULTS["clearance"]) if clearance is None else clearance
    restitution = stated.get("restitution") if restitution is None else restitution
    v, r_c, r_min = contact_parameters(problem, problem.surface_values(values))
    thickness = checks.as_positive_float("thickness", thickness)
    pin_radius = checks.as_positive_float("pin_radius", pin_radius)
    rim = checks.as_positive_float("rim", rim)
    clearance = checks.as_nonneg_float("clearance", clearance)
    if restitution is not None:
        restitution = checks.as_nonneg_float("restitution", restitution)
        if restitution > 1.0:
            raise checks.InputError("restitution", f"restitution must be in [0, 1], got {restitution:g}")
    sides = np.asarray(problem.scene(values).surface.length, dtype=float)
    # a pin as wide as the domain has no room to move; a rim past the domain's size only
    # grows the plate (and the grid its C-space is checked on) for nothing
    if not 2 * pin_radius < sides.min():
        raise checks.InputError("pin_radius", f"pin_radius must be below half the design's shortest side "
                                              f"({sides.min() / 2:g}), got {pin_radius:g}")
    if not 2 * (pin_radius + clearance) < sides.min():
        raise checks.InputError("clearance", f"pin_radius + clearance must be below half the design's shortest "
                                             f"side ({sides.min() / 2:g}), got {pin_radius + clearance:g}",
                                names=("pin_radius", "clearance"))
    if not rim <= sides.max():
        raise checks.InputError("rim", f"rim must be at most the design's longest side ({sides.max():g}), "
                                       f"got {rim:g}")
    if drum_radius is not None:
        drum_radius = checks.as_positive_float("drum_radius", drum_radius)
        if not drum_radius < float(np.finfo(np.float32).max) / 32:     # the drum's STL stores float32
            raise checks.InputError("drum_radius", f"drum_radius must be below {float(np.finfo(np.float32).max) / 32:g} "
                                                   f"(an STL file stores float32), got {drum_radius:g}")
    if not thickness * 2 < float(np.finfo(np.float32).max):      # STL stores float32 coordinates
        raise checks.InputError("thickness", f"thickness must be below {float(np.finfo(np.float32).max) / 2:g} (an STL file "
                                             f"stores float32), got {thickness:g}")
    follower = follower_for(problem.periodic)
    if drum_radius is not None and follower.name != DRUM_CAM:
        raise checks.InputError("drum_radius", f"drum_radius goes with a cylinder design (a drum cam); this design "
                                               f"is a plane (a {follower.name})")
    region = contact_region(problem, values, rule, level)
    scene = problem.scene(values)
    walled = np.zeros((2, 2), dtype=bool) if scene.walls is None else np.asarray(scene.walls.edges, dtype=bool)
    open_edges = [(d, side) for d in range(2) for side in range(2) if not region.periodic[d] and not walled[d, side]]
    parts = follower.build(region, pin_radius, rim, open_edges, drum_radius)
    parts = dataclasses.replace(parts, clearance=clearance)
    start, moved = _free_start(parts, region, start_point(problem))
    damping = np.broadcast_to(scene.damping if scene.damping is not None else 0.0, (2,))
    mass = np.broadcast_to(scene.mass, (2,))
    dynamics = {"mass": [float(m) for m in mass], "damping": [float(d) for d in damping]}
    if scene.walls is not None:
        dynamics["walls"] = {"k": float(scene.walls.k), "margin": float(scene.walls.margin),
                             "edges": [[bool(e) for e in row] for row in np.asarray(scene.walls.edges)]}
    device = {
        "format": 1,
        "name": f"{name}_contact",
        "description": f"{name} realized by contact: a pin and a {parts.part_name} (rule {region.rule!r}, level "
                       f"{region.level:.6g})",
        "part": parts.device_parts(),
        "cspace": {"lower": [float(x) for x in problem.lower], "upper": [float(x) for x in problem.upper],
                   "shape": [int(n) for n in problem.shape()]},
        "energy": {"v": v, "r_c": r_c, "r_min": r_min, "springs": _springs(scene)},
        "dynamics": dynamics,
        "start": {"q": start},
        "realized": {"design": design_hash(problem, values)},
    }
    if restitution is not None:
        device["rigid"] = {"restitution": restitution}
    free = region.phi >= 0
    below = region.energy[free]
    lost = []
    if region.rule != "level-set" and below.size and float(np.ptp(below)) > 0:   # a level set's surface is eq. (1)
        lost.append(f"the energies below the contact level ({float(below.min()):.4g} .. {float(below.max()):.4g} "
                    f"over {free.mean():.1%} of the grid) are flat on the device beyond r_c = "
                    f"{r_c:g} of the {parts.part_name}")
    lost.append(f"{parts.lost_share:.2%} of the domain changes side (blocked slivers thinner than the pin's "
                f"diameter {2 * parts.pin_radius:g}, sharp free corners)")
    if moved is not None:
        lost.append(moved)
    if clearance > 0:
        lost.append(f"the pin is made {clearance:g} larger (radius {parts.pin_made:g}) than the {parts.part_name} "
                    f"is cut for: the blocked region grows by {clearance:g} on every side")
    blocked = region.phi < 0
    sensitivity = tuple((label, float(e), float(np.mean(phi < 0)), float(np.mean((phi < 0) != blocked)))
                        for label, e, phi in region.neighbours)
    dowel_radius = DOWEL_RIM_SHARE * rim
    dowels = () if follower.name == DRUM_CAM else tuple(dowel_holes(parts.plate, dowel_radius))
    return ContactRealization(region, parts, device, tuple(lost), sensitivity, thickness, units, dowels, dowel_radius)
