"""Blocked C-space into parts: the follower a realization builds, per topology (`FOLLOWERS`).

A plane (translation-translation) becomes a **pin in a plate**
([`pin_in_plate`][pes_ref.realize.followers.pin_in_plate]): a pin
of radius ``r`` (part 0) slides along x by q0; a plate (part 1) slides along -y by q1, so
the pin's centre sits at (q0, q1) in the plate's own frame and the C-space obstacle is the
plate's material grown by the pin's radius (the Minkowski sum with a disc of radius r). So
the plate is the blocked region shrunk by r: the plate is a frame ``rim`` wide around the
drawn box less the free region grown by r (the pin's cut-out). What is blocked then is the
*closing* of the design's free region by the pin's disc: a blocked sliver thinner than the
pin's diameter, and a sharp free corner, cannot be kept; `Parts.lost_share` is the
share of the grid's area that changes side.

A cylinder (q0 a translation, q1 an angle) becomes a **drum cam**
([`drum_cam`][pes_ref.realize.followers.drum_cam]): a drum of a stated radius R (part 1, ``motion =
"drum"``, ``docs/devices.md``) turns by q1; a pin of radius r (part 0) slides along the drum's axis
by q0. On the drum's surface unrolled (x along its axis, y the arc length round it, one turn ``2 pi
R`` long) the pin's centre sits at (q0, R q1), so the design's region in (q0, q1) is drawn at (q0, R
q1) and the drum's walls (the material standing proud of its surface, between which the groove runs)
are that region shrunk by r, as the plate is. The closing by the pin's disc is round on the unrolled
surface, so in (q0, q1) it is an ellipse r wide in q0 and r / R in q1.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from pes_ref.core import checks
from pes_ref.devices.geometry import Drum
from pes_ref.devices.contours import region_polygons
from pes_ref.realize.regions import Region

__all__ = ["Parts", "Follower", "pin_in_plate", "drum_cam", "FOLLOWERS", "follower_for", "plate_outline_tolerance",
           "DRUM_RADIUS", "PIN_IN_PLATE", "DRUM_CAM"]

#: The drum cam's default radius (C-space length): at R = 1 the unrolled surface's arc length is
#: the angle q1 itself, so the pin's disc is as round in (q0, q1) as on the drum and the C-space
#: distance of eq. (1) is the distance on the drum's surface.
DRUM_RADIUS = 1.0
#: The followers' names (`Parts.follower`; the realize command's files are keyed by them).
PIN_IN_PLATE, DRUM_CAM = "pin-in-plate", "drum-cam"


class Follower(NamedTuple):
    """A contact follower: its ``name`` and ``build(region, pin_radius, rim, open_edges,
    drum_radius) -> Parts``."""

    name: str
    build: object


@dataclass(frozen=True)
class Parts:
    """A realization's two parts in the device-file's terms (``docs/devices.md``).

    Attributes
    ----------
    follower : str
        `FOLLOWERS`' name.
    pin_radius : float
        The pin's radius (C-space length).
    plate : shapely (Multi)Polygon
        Part 1 at q1 = 0 in its own frame: the plate (= C-space coordinates), or the drum's
        walls unrolled (x = q0, y = R q1 in ``[0, 2 pi R]``).
    blocked : shapely geometry
        The design's blocked region, drawn past the grid's edges (in part 1's frame).
    realized_blocked : shapely geometry
        What the parts block: the plate grown by the pin's radius (in part 1's frame).
    box : (lower, upper)
        The box the region is drawn in (in part 1's frame).
    lost_share : float
        The area that changes side (blocked <-> free) inside the grid's domain, over its area.
    motion : dict
        Part 1's motion keys in the device file.
    part_name : str
        Part 1's name.
    y_scale, y_period : float, float or None
        Where the pin's centre (q0, q1) sits in part 1's frame: ``(q0, y_scale q1)``, taken
        modulo ``y_period`` on a drum.
    clearance : float
        How much larger than ``pin_radius`` (the radius part 1 is cut for) the pin is made
        ([`pin_made`][pes_ref.realize.followers.Parts.pin_made]): the parts' C-space obstacle is
        then the region grown by it, so a rigid pin stands that far off the walls as eq. (1)'s
        barrier holds a particle off them.
    """

    follower: str
    pin_radius: float
    plate: object
    blocked: object
    realized_blocked: object
    box: tuple
    lost_share: float
    motion: dict
    part_name: str = "plate"
    y_scale: float = 1.0
    y_period: float | None = None
    clearance: float = 0.0

    @property
    def pin_made(self) -> float:
        """The pin's radius as made: the radius part 1 is cut for plus the clearance."""
        return self.pin_radius + self.clearance

    def device_parts(self) -> list:
        """The two ``[[part]]`` tables of the device file."""
        return [
            {"name": "pin", "motion": "translation", "direction": [1.0, 0.0],
             "shapes": [{"circle": {"center": [0.0, 0.0], "radius": self.pin_made}}]},
            {"name": self.part_name, **self.motion, "shapes": [_shape_table(p) for p in _pieces(self.plate)]},
        ]

    def in_frame(self, q) -> np.ndarray:
        """Where the pin's centre at C-space points ``q`` (..., 2) sits in part 1's frame."""
        q = np.asarray(q, dtype=np.float64)
        y = self.y_scale * q[..., 1]
        if self.y_period is not None:
            y = np.mod(y, self.y_period)
        return np.stack([q[..., 0], y], axis=-1)


def _pieces(geom) -> list:
    return list(geom.geoms) if hasattr(geom, "geoms") else [geom]


def _ring(coords) -> list:
    pts = np.asarray(coords, dtype=np.float64)[:-1]
    return [[float(x), float(y)] for x, y in pts]


def _shape_table(poly) -> dict:
    """A shapely Polygon as a device file's shape: its outline, minus its holes."""
    out = {"polygon": _ring(poly.exterior.coords)}
    if poly.interiors:
        out["minus"] = [{"polygon": _ring(h.coords)} for h in poly.interiors]
    return out


def plate_outline_tolerance(region: Region) -> float:
    """How far the plate's outline may stray from the contour when it is simplified: a
    twentieth of the finer grid spacing (the device files' circle tolerance, ``docs/devices.md``)."""
    return float(np.min(region.spacing)) / 20.0


def _through_rim(shapely, free, lo, hi, edge: tuple, depth: float):
    """The way out through the rim along one edge of the box ``(lo, hi)`` (``edge = (axis, side)``):
    each stretch of the edge that is free, run ``depth`` outward."""
    axis, side = edge
    at = lo[axis] if side == 0 else hi[axis]
    beyond = (at - depth, at) if side == 0 else (at, at + depth)
    line = (shapely.LineString([(at, lo[1]), (at, hi[1])]) if axis == 0
            else shapely.LineString([(lo[0], at), (hi[0], at)]))
    stretches = shapely.intersection(free, line)
    boxes = []
    for piece in getattr(stretches, "geoms", [stretches]):
        if piece.is_empty or piece.length == 0:
            continue
        x0, y0, x1, y1 = piece.bounds
        boxes.append(shapely.box(beyond[0], y0, beyond[1], y1) if axis == 0 else shapely.box(x0, beyond[0], x1, beyond[1]))
    return shapely.union_all(boxes)


def _material(shapely, blocked, lo, hi, frame, r: float, tol: float, open_edges, rim: float):
    """The part's material: ``frame`` less the free part of the box ``(lo, hi)`` (and the ways
    out through its ``open_edges``) grown by ``r``; pieces smaller than ``tol^2`` dropped."""
    box = shapely.box(lo[0], lo[1], hi[0], hi[1])
    free = shapely.difference(box, blocked)
    depth = 2.0 * (r + rim)
    ways_out = [_through_rim(shapely, free, lo, hi, tuple(edge), depth) for edge in open_edges]
    cutout = shapely.buffer(shapely.union_all([free] + ways_out), r, quad_segs=16)
    material = shapely.normalize(shapely.make_valid(shapely.difference(frame, cutout)))
    return shapely.union_all([p for p in _pieces(material) if p.geom_type == "Polygon" and p.area > tol * tol])


def _lost_share(shapely, blocked, grown, domain) -> float:
    """The share of ``domain``'s area on another side in ``grown`` than in ``blocked``."""
    changed = shapely.symmetric_difference(shapely.intersection(blocked, domain), shapely.intersection(grown, domain))
    return float(changed.area / domain.area)


def pin_in_plate(region: Region, pin_radius: float, rim: float, open_edges=(), drum_radius=None) -> Parts:
    """A pin of radius ``pin_radius`` in a plate ``rim`` wide beyond its cut-out (module docstring).

    ``open_edges`` lists the ``(axis, side)`` edges through which the design's particles leave
    the domain (no wall there): the free region along them runs on out through the rim, as the
    design's surface runs on beyond its edge. ``drum_radius`` is a drum cam's
    ([`Follower`][pes_ref.realize.followers.Follower]'s
    common signature); [`pes_ref.realize.contact.realize_contact`][pes_ref.realize.contact.realize_contact] refuses it for a plane."""
    from pes_ref.realize.extra import require_realize
    shapely = require_realize()["shapely"]
    if any(region.periodic):
        raise checks.InputError("as", "a pin in a plate realizes a plane (no periodic axis); this design's "
                                      "surface wraps")
    r = checks.as_positive_float("pin_radius", pin_radius)
    rim = checks.as_positive_float("rim", rim)
    h = float(np.max(region.spacing))
    margin = r + 3.0 * h
    blocked, (lo, hi) = region_polygons(region.phi, region.lower, region.upper, region.periodic, margin)
    tol = plate_outline_tolerance(region)
    blocked = shapely.simplify(blocked, tol, preserve_topology=True)
    box = shapely.box(lo[0], lo[1], hi[0], hi[1])
    frame = shapely.buffer(box, r + rim, join_style="mitre")
    plate = _material(shapely, blocked, lo, hi, frame, r, tol, open_edges, rim)
    grown = shapely.intersection(shapely.buffer(plate, r, quad_segs=16), box)
    domain = shapely.box(region.lower[0], region.lower[1], region.upper[0], region.upper[1])
    return Parts(PIN_IN_PLATE, r, plate, blocked, grown, (lo, hi), _lost_share(shapely, blocked, grown, domain),
                 {"motion": "translation", "direction": [0.0, -1.0]})


def drum_cam(region: Region, pin_radius: float, rim: float, open_edges=(), drum_radius=None) -> Parts:
    """A pin of radius ``pin_radius`` in the groove of a drum of radius ``drum_radius`` (default
    `DRUM_RADIUS`), whose walls run ``rim`` beyond the drawn box at the drum's ends
    (module docstring). ``open_edges`` as for [`pin_in_plate`][pes_ref.realize.followers.pin_in_plate] (the drum's ends only)."""
    from pes_ref.realize.extra import require_realize
    shapely = require_realize()["shapely"]
    if tuple(region.periodic) != (False, True):
        raise checks.InputError("as", f"a drum cam realizes a cylinder whose q1 (the drum's angle) wraps and q0 (the "
                                      f"pin's slide) does not; this design's periodic axes are {list(region.periodic)}")
    radius = checks.as_positive_float("drum_radius", DRUM_RADIUS if drum_radius is None else drum_radius)
    r = checks.as_positive_float("pin_radius", pin_radius)
    rim = checks.as_positive_float("rim", rim)
    turn = 2.0 * np.pi * radius
    h = region.spacing * np.array([1.0, radius])                     # the grid's spacings on the drum's surface
    margin = r + 3.0 * float(np.max(h))
    blocked, (lo, hi) = region_polygons(region.phi, region.lower, region.upper, region.periodic,
                                        max(margin, margin / radius))
    unroll = np.array([1.0, radius])
    blocked = shapely.transform(blocked, lambda xy: xy * unroll)
    lo, hi = lo * unroll, hi * unroll
    tol = float(np.min(h)) / 20.0
    blocked = shapely.simplify(blocked, tol, preserve_topology=True)
    frame = shapely.box(lo[0] - r - rim, 0.0, hi[0] + r + rim, turn)
    walls = _material(shapely, blocked, lo, hi, frame, r, tol, [e for e in open_edges if e[0] == 0], rim)
    box = shapely.box(lo[0], lo[1], hi[0], hi[1])
    grown = shapely.intersection(shapely.buffer(Drum(radius).tiled(walls), r, quad_segs=16), box)
    domain = shapely.box(region.lower[0], 0.0, region.upper[0], turn)
    return Parts(DRUM_CAM, r, walls, blocked, grown, (lo, hi), _lost_share(shapely, blocked, grown, domain),
                 {"motion": "drum", "radius": radius}, "drum", radius, turn)


#: The follower of each topology: periodic axes -> `Follower`.
FOLLOWERS = {(False, False): Follower(PIN_IN_PLATE, pin_in_plate), (False, True): Follower(DRUM_CAM, drum_cam)}


def follower_for(periodic) -> Follower:
    """The follower that realizes a surface with periodic axes ``periodic`` (one line naming
    ``as`` if none does)."""
    follower = FOLLOWERS.get(tuple(bool(p) for p in periodic))
    if follower is None:
        raise checks.InputError("as", f"no contact follower realizes a surface with periodic axes "
                                      f"{[bool(p) for p in periodic]} (a plane: a pin in a plate; a cylinder "
                                      f"wrapping q1: a drum cam)")
    return follower
