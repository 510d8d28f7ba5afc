"""Planar parts: shapes that move with one degree of freedom, posed and tested through shapely 2.

A [`Part`][pes_ref.devices.geometry.Part] is the union of its shapes ([`Polygon`][pes_ref.devices.geometry.Polygon],
[`Circle`][pes_ref.devices.geometry.Circle],
[`Rectangle`][pes_ref.devices.geometry.Rectangle], each optionally with shapes cut from it, ``minus``), which may be
several disjoint pieces (a crank's pin and its locking disc), plus one motion relative
to the frame: a [`Translation`][pes_ref.devices.geometry.Translation] along a direction, a
[`Rotation`][pes_ref.devices.geometry.Rotation] about a
pivot, or a [`Drum`][pes_ref.devices.geometry.Drum]: a part drawn on a drum's surface unrolled, which turning the
drum moves along the circumference (the drum cam of a pin moving along the drum's axis). Two parts and their coordinates (q0, q1) are a point of a 2D configuration space
(paper, section "Synthesis of higher kinematic pair devices via configuration spaces");
the point is *blocked* where the posed parts' interiors overlap (touching is free).

The planar geometry is shapely 2's (GEOS): unions and differences build a part once,
[`pose`][pes_ref.devices.geometry.pose] moves it to many coordinates in one vectorized call, and
[`interiors_overlap`][pes_ref.devices.geometry.interiors_overlap] decides many pose pairs at once.
shapely is the optional extra ``devices`` (``pip install 'pes_ref[devices]'``); without it, building
a shape raises [`MissingExtraError`][pes_ref.core.runtime.extras.MissingExtraError] naming that
line.

Circles. A circle becomes a regular polygon whose vertices lie just outside it, so that its edge is
within ``tolerance`` (a length) of the true circle everywhere: n sides with ``cos(pi / n) >= (r -
tol) / (r + tol)``, vertices at radius ``2 r / (1 + cos(pi / n))``. The C-space boundary then moves
by at most ``tolerance`` divided by the contact's separation per unit of q (1 for a translation
along the contact normal, the lever arm for a rotation, the drum's radius for a drum).
[`CSpaceGrid`][pes_ref.devices.cspace.CSpaceGrid] chooses the tolerance from its grid
([`default_tolerance`][pes_ref.devices.geometry.default_tolerance]): the error stays below h/20
wherever that lever is at least the smallest circle's radius (a drum's lever is its radius).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pes_ref.core import checks
from pes_ref.core.runtime.extras import MissingExtraError, pip_line, require

__all__ = ["MissingExtraError", "require_shapely", "Polygon", "Circle", "Rectangle", "regular_polygon",
           "Translation", "Rotation", "Drum", "MOTIONS", "Part", "pose", "posed_geometries", "interiors_overlap", "overlap",
           "default_tolerance", "circle_sides", "SHAPES",
           "check_drum_drawing", "tolerance_bound"]

#: The pip line that installs what this module needs.
PIP_LINE = pip_line("devices")


def require_shapely():
    """The ``shapely`` module (version 2 or later), or [`MissingExtraError`][pes_ref.core.runtime.extras.MissingExtraError]
    with the pip line."""
    return require("shapely", "devices", "part geometry", least=(2,))


# --------------------------------------------------------------------------- shapes

def _minus(value) -> tuple:
    shapes = tuple(value) if isinstance(value, (list, tuple)) else (value,)
    for s in shapes:
        if not isinstance(s, SHAPES):
            raise checks.InputTypeError("minus", f"minus must hold shapes (Polygon, Circle, Rectangle), got {s!r}")
    return shapes


def _cut(shape, base, tolerance: float):
    """``base`` minus the union of ``shape.minus`` (shapely geometries)."""
    if not shape.minus:
        return base
    shapely = require_shapely()
    return shapely.difference(base, shapely.union_all([m.geometry(tolerance) for m in shape.minus]))


@dataclass(frozen=True)
class Polygon:
    """A simple polygon (non-convex allowed), optionally with shapes cut from it.

    Parameters
    ----------
    vertices : array_like, shape (V, 2), V >= 3
        Finite corners in order (either orientation); no self-intersection, positive area.
    minus : shape or sequence of shapes, optional
        Cut from the polygon (holes, notches).
    """

    vertices: np.ndarray
    minus: tuple = ()

    def __post_init__(self):
        v = checks.as_float_array("vertices", self.vertices, shape=(None, 2))
        if v.shape[0] < 3:
            raise checks.InputError("vertices", f"vertices must hold at least 3 corners, got shape {v.shape}")
        shapely = require_shapely()
        poly = shapely.Polygon(v)
        tiny = 1e-12 * max(1.0, float(np.max(np.abs(v)))) ** 2
        if not shapely.convex_hull(poly).area > tiny:       # every corner on one line (or one point)
            raise checks.InputError("vertices", f"vertices must enclose a positive area, got area {poly.area:g}")
        crossing = _self_crossing(shapely, v)
        if crossing is not None:                            # a bow tie's halves can cancel to zero area
            raise checks.InputError("vertices", f"vertices must form a simple polygon: the outline is self-crossing "
                                                f"(its edges cross at ({crossing[0]:.6g}, {crossing[1]:.6g})); "
                                                f"give the corners in order around the shape")
        if not poly.area > tiny or not poly.is_valid:
            raise checks.InputError("vertices", f"vertices must form a simple polygon with a positive area "
                                                f"({shapely.is_valid_reason(poly)}, area {poly.area:g})")
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "minus", _minus(self.minus))

    def geometry(self, tolerance: float):
        """The shapely geometry (circles in ``minus`` within ``tolerance``)."""
        return _cut(self, require_shapely().Polygon(self.vertices), tolerance)


def _self_crossing(shapely, v: np.ndarray):
    """Where the closed outline through ``v`` crosses (or runs back over) itself, as (x, y); None
    if it is simple."""
    ring = shapely.LinearRing(v)
    if ring.is_simple:
        return None
    reason = shapely.is_valid_reason(shapely.Polygon(v))
    if "[" in reason:                                       # 'Self-intersection[x y]'
        return tuple(float(t) for t in reason[reason.index("[") + 1:reason.index("]")].split())
    return tuple(float(t) for t in v[0])


@dataclass(frozen=True)
class Rectangle:
    """The axis-aligned box ``lower`` .. ``upper`` (upper > lower on both axes), optionally with cuts."""

    lower: np.ndarray
    upper: np.ndarray
    minus: tuple = ()

    def __post_init__(self):
        lo = checks.as_float_array("lower", self.lower, shape=(2,))
        hi = checks.as_float_array("upper", self.upper, shape=(2,))
        if not np.all(hi > lo):
            raise checks.InputError("upper", f"upper must be > lower on both axes, got lower={lo.tolist()}, "
                                             f"upper={hi.tolist()}", names=("upper", "lower"))
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)
        object.__setattr__(self, "minus", _minus(self.minus))

    def geometry(self, tolerance: float):
        """The shapely geometry (circles in ``minus`` within ``tolerance``)."""
        return _cut(self, require_shapely().box(*self.lower, *self.upper), tolerance)


def circle_sides(radius: float, tolerance: float) -> int:
    """The number of sides of the polygon that stands for a circle of ``radius`` within
    ``tolerance`` (module docstring), at least 8."""
    c = max(-1.0, (radius - tolerance) / (radius + tolerance))
    return max(8, int(np.ceil(np.pi / np.arccos(c))))


@dataclass(frozen=True)
class Circle:
    """A disc of ``radius`` about ``center``, optionally with cuts (see the module docstring for its polygon)."""

    center: np.ndarray
    radius: float
    minus: tuple = ()

    def __post_init__(self):
        object.__setattr__(self, "center", checks.as_float_array("center", self.center, shape=(2,)))
        object.__setattr__(self, "radius", checks.as_positive_float("radius", self.radius))
        object.__setattr__(self, "minus", _minus(self.minus))

    def geometry(self, tolerance: float):
        """The shapely polygon within ``tolerance`` of the disc (minus its cuts)."""
        n = circle_sides(self.radius, tolerance)
        rv = 2.0 * self.radius / (1.0 + np.cos(np.pi / n))
        t = 2.0 * np.pi * np.arange(n) / n
        ring = self.center + rv * np.stack((np.cos(t), np.sin(t)), axis=1)
        return _cut(self, require_shapely().Polygon(ring), tolerance)


#: The shape kinds.
SHAPES = (Polygon, Circle, Rectangle)


def regular_polygon(n: int, radius: float, center=(0.0, 0.0), phase: float = 0.0) -> Polygon:
    """A convex regular n-gon of circumradius ``radius``; vertex k at angle ``phase + 2 pi k / n``."""
    n = checks.as_int_at_least("n", n, 3)
    radius = checks.as_positive_float("radius", radius)
    c = checks.as_float_array("center", center, shape=(2,))
    t = checks.as_finite_float("phase", phase) + 2.0 * np.pi * np.arange(n) / n
    return Polygon(c + radius * np.stack((np.cos(t), np.sin(t)), axis=1))


# --------------------------------------------------------------------------- motions and parts

@dataclass(frozen=True)
class Translation:
    """Motion along ``direction`` (normalized to unit length): a point p moves to p + q d."""

    direction: np.ndarray

    def __post_init__(self):
        d = checks.as_float_array("direction", self.direction, shape=(2,))
        norm = float(np.hypot(d[0], d[1]))
        if norm == 0.0:
            raise checks.InputError("direction", f"direction must be non-zero, got {d.tolist()}")
        d = d / norm
        d.setflags(write=False)
        object.__setattr__(self, "direction", d)

    def apply(self, xy: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Points ``xy`` (P, 2) moved by the coordinates ``q`` (P,) (one per point)."""
        return xy + q[:, None] * self.direction


@dataclass(frozen=True)
class Rotation:
    """Motion about ``pivot``: a point p moves to pivot + R(q) (p - pivot), R counter-clockwise."""

    pivot: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "pivot", checks.as_float_array("pivot", self.pivot, shape=(2,)))

    def apply(self, xy: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Points ``xy`` (P, 2) turned by the angles ``q`` (P,) (one per point)."""
        c, s = np.cos(q), np.sin(q)
        rel = xy - self.pivot
        return self.pivot + np.stack((c * rel[:, 0] - s * rel[:, 1], s * rel[:, 0] + c * rel[:, 1]), axis=1)


@dataclass(frozen=True)
class Drum:
    """A part drawn on the surface of a drum of ``radius`` (a length), unrolled: x along the
    drum's axis, y the arc length round it, one turn ``2 pi radius`` long. Turning the drum by
    q (radians) moves the drawing by ``-radius q`` along y, so a point fixed at (x, 0) in the
    frame (a follower's pin on the line y = 0) sits at ``(x, radius q)`` of the drawing, as a pin
    at (q0, q1) sits in a plate sliding along -y. The drawing repeats every turn: a pose holds
    the copies of the drawing, a turn apart, that cover y in ``[-2 pi radius, 2 pi radius]``
    at every q ([`tiled`][pes_ref.devices.geometry.Drum.tiled]), so a follower within a turn of y = 0 meets all of them."""

    radius: float

    def __post_init__(self):
        object.__setattr__(self, "radius", checks.as_positive_float("radius", self.radius))

    @property
    def circumference(self) -> float:
        """One turn of the drawing along y, ``2 pi radius`` (a length)."""
        return 2.0 * np.pi * self.radius

    def apply(self, xy: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Points ``xy`` (P, 2) moved by the angles ``q`` (P,): ``y - radius (q mod 2 pi)``."""
        shift = -self.radius * np.mod(q, 2.0 * np.pi)
        return xy + np.stack((np.zeros_like(shift), shift), axis=1)

    def tiled(self, geom):
        """The drawing ``geom`` and its copies a turn apart along y, enough that every pose
        (a shift in ``(-2 pi radius, 0]``) covers y in ``[-2 pi radius, 2 pi radius]``."""
        shapely = require_shapely()
        period = self.circumference
        _, y0, _, y1 = geom.bounds
        first = int(np.floor((-period - y1) / period))
        last = int(np.ceil((2.0 * period - y0) / period))
        copies = [shapely.transform(geom, lambda xy, k=k: xy + np.array([0.0, k * period]))
                  for k in range(first, last + 1)]
        return shapely.normalize(shapely.union_all(copies))


#: The motions a part can have.
MOTIONS = (Translation, Rotation, Drum)


@dataclass(frozen=True, eq=False)
class Part:
    """Shapes with one degree of freedom relative to the frame.

    Parameters
    ----------
    shapes : shape or sequence of shapes
        The part at coordinate q = 0 is their union (disjoint pieces allowed).
    motion : Translation, Rotation or Drum
    """

    shapes: tuple
    motion: object

    def __post_init__(self):
        shapes = tuple(self.shapes) if isinstance(self.shapes, (list, tuple)) else (self.shapes,)
        if not shapes:
            raise checks.InputError("shapes", "shapes must hold at least one shape")
        for s in shapes:
            if not isinstance(s, SHAPES):
                raise checks.InputTypeError("shapes", f"shapes must be Polygon, Circle or Rectangle objects, "
                                                      f"got {type(s).__name__}")
        if not isinstance(self.motion, MOTIONS):
            raise checks.InputTypeError("motion", f"motion must be a Translation, a Rotation or a Drum, "
                                                  f"got {self.motion!r}")
        object.__setattr__(self, "shapes", shapes)
        object.__setattr__(self, "_cache", {})

    @property
    def periodic(self) -> bool:
        """True for a rotation or a drum (its coordinate is an angle)."""
        return isinstance(self.motion, (Rotation, Drum))

    @property
    def period(self):
        """2 pi for a rotation or a drum, None for a translation."""
        return 2.0 * np.pi if self.periodic else None

    @property
    def circles(self) -> list:
        """Every circle of the part (cuts included)."""
        out, todo = [], list(self.shapes)
        while todo:
            s = todo.pop()
            out += [s] if isinstance(s, Circle) else []
            todo += list(s.minus)
        return out

    def geometry(self, tolerance: float):
        """The part at q = 0 as one shapely geometry (a Polygon or MultiPolygon), circles within
        ``tolerance``; computed once per tolerance."""
        tolerance = checks.as_positive_float("tolerance", tolerance)
        if tolerance not in self._cache:
            shapely = require_shapely()
            geom = shapely.union_all([s.geometry(tolerance) for s in self.shapes])
            if geom.is_empty or not geom.area > 0:
                raise checks.InputError("shapes", "the part's shapes leave nothing (the cuts remove everything)")
            self._cache[tolerance] = shapely.normalize(geom)
        return self._cache[tolerance]

    def posable(self, tolerance: float):
        """What [`pose`][pes_ref.devices.geometry.pose] moves: `geometry`, tiled a turn apart for a drum ([`Drum.tiled`][pes_ref.devices.geometry.Drum.tiled])."""
        key = ("posable", tolerance)
        if key not in self._cache:
            geom = self.geometry(tolerance)
            self._cache[key] = self.motion.tiled(geom) if isinstance(self.motion, Drum) else geom
        return self._cache[key]


def check_drum_drawing(part: Part, tolerance: float = 1e-3) -> None:
    """Refuse a drum's drawing that spans more than one turn: its shapes must lie within y in
    ``[0, 2 pi R]`` ([`Drum`][pes_ref.devices.geometry.Drum]; a circle's polygon may stray
    ``tolerance`` beyond), else the copies a turn apart overlap each other and the drum is not what
    was drawn. A keyed [`InputError`][pes_ref.core.checks.InputError] (``shapes``) naming the span;
    nothing for another motion."""
    if not isinstance(part.motion, Drum):
        return
    period = part.motion.circumference
    _, y0, _, y1 = part.geometry(tolerance).bounds
    slack = tolerance + 1e-9 * period
    if y0 < -slack or y1 > period + slack:
        raise checks.InputError("shapes", f"the drum's shapes span y from {y0:.4g} to {y1:.4g}, more than one turn "
                                          f"of its surface: they must lie within y in [0, 2 pi R] = [0, {period:.4g}] "
                                          f"(R = {part.motion.radius:g}; the drawing repeats every turn)")


def default_tolerance(parts, spacing) -> float:
    """The circles' tolerance for a grid of ``spacing`` (2,): ``min_d h_d l_d / 20`` with
    ``l_d`` 1 for a translation, the smallest circle radius of the device for a rotation
    (the arc a point at that radius sweeps in one grid step) and the drum's radius for a drum
    (the arc its surface moves in one grid step); without circles it does not matter, and
    1e-3 of the parts' size is returned."""
    radii = [c.radius for p in parts for c in p.circles]
    h = checks.as_float_array("spacing", spacing, shape=(2,), positive=True)
    if not radii:
        return 1e-3
    lever = [_LEVERS[type(p.motion)](p.motion, min(radii)) for p in parts]
    return float(min(h[d] * lever[d] for d in range(2)) / 20.0)


def tolerance_bound(parts, spacing) -> float:
    """The largest circles' tolerance a grid of ``spacing`` (2,) accepts: ``min_d h_d l_d``, 20 times
    [`default_tolerance`][pes_ref.devices.geometry.default_tolerance]: a circle's polygon then moves the C-space
    boundary by less than one
    grid spacing where the contact's lever is at least ``l_d``. Infinite without circles (the
    tolerance is not used)."""
    if not any(p.circles for p in parts):
        return float("inf")
    return 20.0 * default_tolerance(parts, spacing)


#: The lever of each motion (`default_tolerance`): motion, smallest circle radius -> length per unit q.
_LEVERS = {Translation: lambda motion, radius: 1.0, Rotation: lambda motion, radius: radius,
           Drum: lambda motion, radius: motion.radius}


def pose(part: Part, q, tolerance: float) -> np.ndarray:
    """The part posed at every coordinate of ``q``.

    Parameters
    ----------
    part : Part
    q : array_like, shape (K,)
        Translation distances or rotation angles (radians; a drum's too).
    tolerance : float
        The circles' tolerance ([`Part.geometry`][pes_ref.devices.geometry.Part.geometry]).

    Returns
    -------
    ndarray of shapely geometries, shape (K,)
    """
    shapely = require_shapely()
    q = checks.as_float_array("q", q, ndim=1)
    geom = part.posable(tolerance)
    if q.size == 0:
        return np.empty(0, dtype=object)
    nc = shapely.get_num_coordinates(geom)
    per_point = np.repeat(q, nc)
    return shapely.transform(np.full(q.size, geom, dtype=object), lambda xy: part.motion.apply(xy, per_point))


def posed_geometries(part0: Part, part1: Part, q0, q1, tolerance: float = 1e-3):
    """Both parts posed at one C-space point (q0, q1), for drawing: two shapely geometries."""
    q0 = checks.as_finite_float("q0", q0)
    q1 = checks.as_finite_float("q1", q1)
    return pose(part0, [q0], tolerance)[0], pose(part1, [q1], tolerance)[0]


def interiors_overlap(a, b) -> np.ndarray:
    """Whether the interiors of shapely geometries ``a`` and ``b`` intersect (broadcast
    arrays): positive-area overlap, touching is free. ``intersects`` first (fast, and
    faster where ``a`` is prepared), then the DE-9IM test only where they intersect."""
    shapely = require_shapely()
    a, b = np.broadcast_arrays(np.asarray(a, dtype=object), np.asarray(b, dtype=object))
    scalar = a.ndim == 0
    a, b = np.atleast_1d(a), np.atleast_1d(b)
    out = shapely.intersects(a, b)
    hit = np.nonzero(out)
    if hit[0].size:
        out[hit] = shapely.relate_pattern(a[hit], b[hit], "T********")
    return bool(out[0]) if scalar else out


def overlap(a, b, tolerance: float = 1e-3) -> bool:
    """True iff two shapes (or shapely geometries) overlap with positive area (touching is free)."""
    ga = a.geometry(tolerance) if isinstance(a, SHAPES) else a
    gb = b.geometry(tolerance) if isinstance(b, SHAPES) else b
    return bool(interiors_overlap(ga, gb))
