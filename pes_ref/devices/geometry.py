"""Planar parts: polygons that move with one degree of freedom, and their overlap test.

A :class:`Part` is a polygon (non-convex allowed) plus one motion relative to the frame:
a :class:`Translation` along a direction or a :class:`Rotation` about a pivot. Two parts
and their coordinates (q0, q1) are a point of a 2D configuration space (paper, section
"Synthesis of higher kinematic pair devices via configuration spaces"); the point is
*blocked* where the posed polygons overlap with positive area and *free* otherwise
(touching is free). :func:`overlap_table` decides this for every pair of poses at once.

Overlap test (exact up to the tolerances below)
-----------------------------------------------
The interiors of two simple polygons A and B intersect iff

1. an edge of A and an edge of B cross *properly* (each edge's end points lie strictly
   on opposite sides of the other edge's line), or
2. a probe point of A lies inside B, or a probe point of B inside A. The probes of a
   polygon are its edge midpoints moved inward by ``PROBE_INSET * scale`` along the
   edge's inward normal, so they lie strictly inside their own polygon.

Case 1 finds every transversal crossing; case 2 finds containment and the aligned,
degenerate contacts that grids hit exactly (collinear overlapping edges, a vertex on an
edge), where no crossing is proper. Orientation values below ``ORIENT_TOL * scale**2``
count as zero ("touching"), so an overlap thinner than about ``PROBE_INSET * scale``
counts as touching; ``scale`` is the largest coordinate magnitude involved.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pes_ref.core import checks

__all__ = ["Polygon", "rectangle", "regular_polygon", "Translation", "Rotation", "Part", "pose",
           "posed_vertices", "overlap", "overlap_table", "bounding_boxes"]

#: Relative size of the orientation values treated as zero (collinear / touching): well above
#: the ~1e-16 relative rounding of posing a vertex, far below any real crossing.
ORIENT_TOL = 1e-12
#: Relative inward offset of the probe points; an overlap thinner than this (times the scale)
#: counts as touching. Must exceed the rounding of posed coordinates (~1e-16).
PROBE_INSET = 1e-9
#: Pairs of (pose, edge, edge) evaluated per chunk in :func:`overlap_table` (memory bound).
CHUNK_ELEMENTS = 2_000_000


# --------------------------------------------------------------------------- polygons

def _cross(ax, ay, bx, by):
    return ax * by - ay * bx


def signed_area(vertices: np.ndarray) -> np.ndarray:
    """Shoelace signed area of polygons (..., V, 2): > 0 counter-clockwise."""
    x, y = vertices[..., 0], vertices[..., 1]
    return 0.5 * np.sum(x * np.roll(y, -1, axis=-1) - np.roll(x, -1, axis=-1) * y, axis=-1)


def _proper_crossings(p1, p2, q1, q2, tol):
    """Proper crossings of segment sets, broadcasting (..., 2) end points; bool (...)."""
    def side(a, b, c):   # sign of the orientation of c with respect to a->b, 0 within tol
        o = _cross(b[..., 0] - a[..., 0], b[..., 1] - a[..., 1], c[..., 0] - a[..., 0], c[..., 1] - a[..., 1])
        return np.where(np.abs(o) <= tol, 0, np.sign(o))
    return (side(p1, p2, q1) * side(p1, p2, q2) < 0) & (side(q1, q2, p1) * side(q1, q2, p2) < 0)


@dataclass(frozen=True)
class Polygon:
    """A simple polygon, non-convex allowed.

    Parameters
    ----------
    vertices : array_like, shape (V, 2), V >= 3
        Finite corners in order (either orientation; stored counter-clockwise). No
        zero-length edge, no self-intersection, positive area.
    """

    vertices: np.ndarray

    def __post_init__(self):
        v = checks.as_float_array("vertices", self.vertices, shape=(None, 2))
        if v.shape[0] < 3:
            raise ValueError(f"vertices must hold at least 3 corners, got shape {v.shape}")
        scale = max(1.0, float(np.max(np.abs(v))))
        edge = np.roll(v, -1, axis=0) - v
        if np.any(np.hypot(edge[:, 0], edge[:, 1]) <= 1e-12 * scale):
            raise ValueError(f"vertices must not repeat consecutively (zero-length edge): {checks._quote(v)}")
        area = float(signed_area(v))
        if abs(area) <= 1e-12 * scale * scale:
            raise ValueError(f"vertices must enclose a positive area, got area {area:g}")
        n = v.shape[0]
        i, j = np.triu_indices(n, k=2)
        keep = ~((i == 0) & (j == n - 1))          # the first and last edges are adjacent
        i, j = i[keep], j[keep]
        if i.size:
            b = np.roll(v, -1, axis=0)
            cross = _proper_crossings(v[i], b[i], v[j], b[j], ORIENT_TOL * scale * scale)
            if np.any(cross):
                k = int(np.argmax(cross))
                raise ValueError(f"vertices must form a simple polygon; edges {int(i[k])} and {int(j[k])} cross")
        if area < 0:
            v = v[::-1].copy()
            v.setflags(write=False)
        object.__setattr__(self, "vertices", v)

    @property
    def area(self) -> float:
        """Enclosed area (> 0)."""
        return float(signed_area(self.vertices))

    def edges(self) -> np.ndarray:
        """Edges as (V, 2, 2): ``edges[i] = (vertex i, vertex i+1)``."""
        return np.stack((self.vertices, np.roll(self.vertices, -1, axis=0)), axis=1)


def rectangle(x0: float, y0: float, x1: float, y1: float) -> Polygon:
    """The axis-aligned box [x0, x1] x [y0, y1] (x1 > x0, y1 > y0)."""
    return Polygon([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])


def regular_polygon(n: int, radius: float, center=(0.0, 0.0), phase: float = 0.0) -> Polygon:
    """A convex regular n-gon of circumradius ``radius``; vertex k at angle ``phase + 2 pi k / n``."""
    n = checks.as_positive_int("n", n)
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
            raise ValueError(f"direction must be non-zero, got {d.tolist()}")
        d = d / norm
        d.setflags(write=False)
        object.__setattr__(self, "direction", d)


@dataclass(frozen=True)
class Rotation:
    """Motion about ``pivot``: a point p moves to pivot + R(q) (p - pivot), R counter-clockwise."""

    pivot: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "pivot", checks.as_float_array("pivot", self.pivot, shape=(2,)))


@dataclass(frozen=True)
class Part:
    """A polygon with one degree of freedom relative to the frame.

    Parameters
    ----------
    polygon : Polygon
        The part's shape at coordinate q = 0.
    motion : Translation or Rotation
    """

    polygon: Polygon
    motion: object

    def __post_init__(self):
        if not isinstance(self.polygon, Polygon):
            raise TypeError(f"polygon must be a pes_ref.devices.geometry.Polygon, got {type(self.polygon).__name__}")
        if not isinstance(self.motion, (Translation, Rotation)):
            raise TypeError(f"motion must be a Translation or a Rotation, got {self.motion!r}")

    @property
    def periodic(self) -> bool:
        """True for a rotation (its coordinate is an angle)."""
        return isinstance(self.motion, Rotation)

    @property
    def period(self):
        """2 pi for a rotation, None for a translation."""
        return 2.0 * np.pi if self.periodic else None


def _pose_points(motion, points: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Points (P, 2) moved to every coordinate of q (...): shape (..., P, 2)."""
    q = q[..., None]
    if isinstance(motion, Translation):
        return points + q[..., None] * motion.direction
    c, s = np.cos(q), np.sin(q)
    rel = points - motion.pivot
    x = motion.pivot[0] + c * rel[:, 0] - s * rel[:, 1]
    y = motion.pivot[1] + s * rel[:, 0] + c * rel[:, 1]
    return np.stack((x, y), axis=-1)


def pose(part: Part, q) -> np.ndarray:
    """The part's vertices at coordinate(s) ``q``.

    Parameters
    ----------
    part : Part
    q : array_like, shape (...)
        Translation distance or rotation angle (radians).

    Returns
    -------
    ndarray, shape (..., V, 2)
    """
    q = checks.as_float_array("q", q)
    return _pose_points(part.motion, part.polygon.vertices, q)


def posed_vertices(part0: Part, part1: Part, q0, q1):
    """Both parts posed at the C-space point (q0, q1), for drawing: ((V0, 2), (V1, 2))."""
    q0 = checks.as_finite_float("q0", q0)
    q1 = checks.as_finite_float("q1", q1)
    return pose(part0, q0), pose(part1, q1)


# --------------------------------------------------------------------------- overlap

def bounding_boxes(v: np.ndarray) -> np.ndarray:
    """Boxes (..., 4) = (xmin, ymin, xmax, ymax) of vertex sets (..., V, 2)."""
    return np.concatenate((v.min(axis=-2), v.max(axis=-2)), axis=-1)


def _probes(v: np.ndarray, inset: float) -> np.ndarray:
    """Edge midpoints moved inward by ``inset``: (..., V, 2) for polygons (..., V, 2)."""
    b = np.roll(v, -1, axis=-2)
    e = b - v
    length = np.maximum(np.hypot(e[..., 0], e[..., 1]), np.finfo(float).tiny)
    orient = np.sign(signed_area(v))[..., None]          # +1 ccw: interior on the left
    normal = np.stack((-e[..., 1], e[..., 0]), axis=-1) * (orient / length)[..., None]
    return 0.5 * (v + b) + inset * normal


def _inside(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Winding-number test, (P, K, 2) points in polygons (P, V, 2) -> bool (P, K)."""
    b1 = poly[:, None, :, :]
    b2 = np.roll(poly, -1, axis=1)[:, None, :, :]
    p = points[:, :, None, :]
    py = p[..., 1]
    o = _cross(b2[..., 0] - b1[..., 0], b2[..., 1] - b1[..., 1], p[..., 0] - b1[..., 0], py - b1[..., 1])
    up = (b1[..., 1] <= py) & (b2[..., 1] > py) & (o > 0)
    down = (b1[..., 1] > py) & (b2[..., 1] <= py) & (o < 0)
    return np.sum(up, axis=-1, dtype=np.int64) != np.sum(down, axis=-1, dtype=np.int64)


def _sides(p, b1, b2, tol) -> np.ndarray:
    """Side of points p (P, K, 2) against edges b1->b2 (P, E, 2): int8 (P, K, E), 0 within tol."""
    o = _cross((b2[:, None, :, 0] - b1[:, None, :, 0]), (b2[:, None, :, 1] - b1[:, None, :, 1]),
               p[:, :, None, 0] - b1[:, None, :, 0], p[:, :, None, 1] - b1[:, None, :, 1])
    return (o > tol).astype(np.int8) - (o < -tol).astype(np.int8)


def _overlap_pairs(a, b, pa, pb, tol) -> np.ndarray:
    """Overlap of P pose pairs: a (P, Va, 2), b (P, Vb, 2), probes pa, pb; bool (P,).

    Stage 1 tests a few probes of each polygon inside the other (cost (Va + Vb) per pair)
    and settles most deep overlaps; stage 2 runs the full test on the rest.
    """
    few = slice(None, None, max(1, min(a.shape[1], b.shape[1]) // 4))
    hit = _inside(pa[:, few], b).any(axis=1) | _inside(pb[:, few], a).any(axis=1)
    idx = np.nonzero(~hit)[0]
    if idx.size == 0:
        return hit
    a, b, pa, pb = a[idx], b[idx], pa[idx], pb[idx]
    a2, b2 = np.roll(a, -1, axis=1), np.roll(b, -1, axis=1)
    s_ab = _sides(a, b, b2, tol)                     # (P, Va, Vb): A's vertices vs B's edges
    s_ba = _sides(b, a, a2, tol)                     # (P, Vb, Va): B's vertices vs A's edges
    cross = ((s_ab * np.roll(s_ab, -1, axis=1)) < 0) & (np.swapaxes(s_ba * np.roll(s_ba, -1, axis=1), 1, 2) < 0)
    rest = cross.any(axis=(1, 2))
    todo = np.nonzero(~rest)[0]
    if todo.size:
        rest[todo] = _inside(pa[todo], b[todo]).any(axis=1) | _inside(pb[todo], a[todo]).any(axis=1)
    hit[idx] = rest
    return hit


def overlap_table(a, b, *, chunk_elements: int = CHUNK_ELEMENTS) -> np.ndarray:
    """Positive-area overlap of every pair of posed polygons.

    Parameters
    ----------
    a : array_like, shape (M, Va, 2)
        M poses of polygon A (simple polygons, either orientation).
    b : array_like, shape (K, Vb, 2)
        K poses of polygon B.
    chunk_elements : int
        Upper bound on the number of (pair, edge, edge) evaluations held in memory at once.

    Returns
    -------
    ndarray of bool, shape (M, K)
        ``out[i, j]`` is True iff ``a[i]`` and ``b[j]`` overlap with positive area (see the
        module docstring for the test and its tolerances). Pairs whose bounding boxes are
        disjoint are decided without the edge tests.
    """
    a = checks.as_float_array("a", a, shape=(None, None, 2))
    b = checks.as_float_array("b", b, shape=(None, None, 2))
    if a.shape[1] < 3 or b.shape[1] < 3:
        raise ValueError(f"polygons need at least 3 vertices, got a {a.shape} and b {b.shape}")
    chunk_elements = checks.as_positive_int("chunk_elements", chunk_elements)
    scale = max(1.0, float(np.max(np.abs(a), initial=0.0)), float(np.max(np.abs(b), initial=0.0)))
    tol = ORIENT_TOL * scale * scale
    ba, bb = bounding_boxes(a), bounding_boxes(b)
    out = np.zeros((a.shape[0], b.shape[0]), dtype=bool)
    boxes = ((ba[:, None, 0] < bb[None, :, 2]) & (bb[None, :, 0] < ba[:, None, 2])
             & (ba[:, None, 1] < bb[None, :, 3]) & (bb[None, :, 1] < ba[:, None, 3]))
    ii, jj = np.nonzero(boxes)
    if ii.size == 0:
        return out
    pa, pb = _probes(a, PROBE_INSET * scale), _probes(b, PROBE_INSET * scale)
    step = max(1, chunk_elements // (a.shape[1] * b.shape[1]))
    for s in range(0, ii.size, step):
        i, j = ii[s:s + step], jj[s:s + step]
        out[i, j] = _overlap_pairs(a[i], b[j], pa[i], pb[j], tol)
    return out


def overlap(a, b) -> bool:
    """True iff polygons ``a`` (Va, 2) and ``b`` (Vb, 2) overlap with positive area (touching is free)."""
    if isinstance(a, Polygon):
        a = a.vertices
    if isinstance(b, Polygon):
        b = b.vertices
    a = checks.as_float_array("a", a, shape=(None, 2))
    b = checks.as_float_array("b", b, shape=(None, 2))
    return bool(overlap_table(a[None], b[None])[0, 0])
