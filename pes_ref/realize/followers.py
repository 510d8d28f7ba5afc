"""Blocked C-space into parts: the follower a realization builds, per topology (:data:`FOLLOWERS`).

A plane (translation-translation) becomes a **pin in a plate** (:func:`pin_in_plate`): a pin
of radius ``r`` (part 0) slides along x by q0; a plate (part 1) slides along -y by q1, so
the pin's centre sits at (q0, q1) in the plate's own frame and the C-space obstacle is the
plate's material grown by the pin's radius (the Minkowski sum with a disc of radius r). So
the plate is the blocked region shrunk by r: the plate is a frame ``rim`` wide around the
drawn box less the free region grown by r (the pin's cut-out). What is blocked then is the
*closing* of the design's free region by the pin's disc: a blocked sliver thinner than the
pin's diameter, and a sharp free corner, cannot be kept; :attr:`Parts.lost_share` is the
share of the grid's area that changes side.

A cylinder (a drum cam) is refused for now: a groove at one drum radius is not built yet.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pes_ref.core import checks
from pes_ref.realize.regions import Region, region_polygons

__all__ = ["Parts", "pin_in_plate", "FOLLOWERS", "plate_outline_tolerance"]


@dataclass(frozen=True)
class Parts:
    """A realization's two parts in the device-file's terms (``docs/devices.md``).

    Attributes
    ----------
    follower : str
        :data:`FOLLOWERS`' name.
    pin_radius : float
        The pin's radius (C-space length).
    plate : shapely (Multi)Polygon
        The plate at q1 = 0, in the plate's frame (= C-space coordinates).
    blocked : shapely geometry
        The design's blocked region, drawn past the grid's edges.
    realized_blocked : shapely geometry
        What the parts block: the plate grown by the pin's radius.
    box : (lower, upper)
        The box the region is drawn in.
    lost_share : float
        The area that changes side (blocked <-> free) inside the grid's domain, over its area.
    """

    follower: str
    pin_radius: float
    plate: object
    blocked: object
    realized_blocked: object
    box: tuple
    lost_share: float

    def device_parts(self) -> list:
        """The two ``[[part]]`` tables of the device file."""
        return [
            {"name": "pin", "motion": "translation", "direction": [1.0, 0.0],
             "shapes": [{"circle": {"center": [0.0, 0.0], "radius": self.pin_radius}}]},
            {"name": "plate", "motion": "translation", "direction": [0.0, -1.0],
             "shapes": [_shape_table(p) for p in _pieces(self.plate)]},
        ]


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


def pin_in_plate(region: Region, pin_radius: float, rim: float, open_edges=()) -> Parts:
    """A pin of radius ``pin_radius`` in a plate ``rim`` wide beyond its cut-out (module docstring).

    ``open_edges`` lists the ``(axis, side)`` edges through which the design's particles leave
    the domain (no wall there): the free region along them runs on out through the rim, as the
    design's surface runs on beyond its edge."""
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
    free = shapely.difference(box, blocked)
    depth = 2.0 * (r + rim)
    ways_out = [_through_rim(shapely, free, lo, hi, tuple(edge), depth) for edge in open_edges]
    cutout = shapely.buffer(shapely.union_all([free] + ways_out), r, quad_segs=16)
    frame = shapely.buffer(box, r + rim, join_style="mitre")
    plate = shapely.normalize(shapely.make_valid(shapely.difference(frame, cutout)))
    plate = shapely.union_all([p for p in _pieces(plate) if p.geom_type == "Polygon" and p.area > tol * tol])
    grown = shapely.intersection(shapely.buffer(plate, r, quad_segs=16), box)
    domain = shapely.box(region.lower[0], region.lower[1], region.upper[0], region.upper[1])
    changed = shapely.symmetric_difference(shapely.intersection(blocked, domain), shapely.intersection(grown, domain))
    return Parts("pin-in-plate", r, plate, blocked, grown, (lo, hi), float(changed.area / domain.area))


#: The follower of each topology (periodic axes -> builder(region, pin_radius, rim, open_edges) -> Parts).
FOLLOWERS = {(False, False): pin_in_plate}
