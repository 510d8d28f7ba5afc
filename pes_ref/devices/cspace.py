"""Configuration space on a grid, the artificial potential field (eq. (1)) and the surface.

Paper, "Contribution 1": blocked regions of a configuration space become high potential
energy by the artificial potential field

    E(r) = v/2 (1/r - 1/r_c)^2   for r < r_c,     E(r) = 0   for r >= r_c        (1)

with r the distance from a point to blocked space; the result is summed with the
energies of the device's springs into one surface.

Grid. A [`CSpaceGrid`][pes_ref.devices.cspace.CSpaceGrid] samples the coordinates (q0, q1) of two parts on the nodes of
a [`pes_ref.Surface`][pes_ref.core.surface.Surface] of the same ``lower``, ``upper``, shape and topology (periodic
spacing ``L/n``, otherwise ``L/(n-1)``). Each part is posed once per node coordinate of
its axis ([`pes_ref.devices.geometry.pose`][pes_ref.devices.geometry.pose]); a node is blocked where the posed
parts' interiors overlap (shapely's ``intersects`` on every pair, with part 0's poses
prepared, then the DE-9IM test on the intersecting nodes next to a free one, where a
mere touch is free).

Distance. [`CSpaceGrid.compute`][pes_ref.devices.cspace.CSpaceGrid.compute] locates the boundary
between the nodes and takes the exact distance to it
([`pes_ref.devices.boundary`][pes_ref.devices.boundary]): sub-cell accurate, so eq. (1) is smooth
across the grid and a quasistatic drive does not stall in a free channel.

Cap. Eq. (1) diverges at r = 0 and the grid cannot resolve r below about half a spacing,
so [`apf_energy`][pes_ref.devices.cspace.apf_energy] uses eq. (1) only for ``r >= r_min`` (default ``min(h)/2``) and
continues it *linearly* below, with the slope it has at ``r_min``:

    E(r) = E(r_min) + |E'(r_min)| (r_min - r)     for r < r_min (blocked nodes: r < 0).

This is finite for every finite r, continuous with a continuous slope at ``r_min``, and
keeps rising into blocked space so a particle that got in is pushed out. No inf or NaN
ever reaches the integrator.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field as dc_field

import numpy as np

from pes_ref.core import checks
from pes_ref.core.surface import Surface, spacing as grid_spacing
from pes_ref.devices import boundary
from pes_ref.devices.geometry import Part, default_tolerance, pose, require_shapely, tolerance_bound

__all__ = ["CSpaceGrid", "CSpace", "blocked_mask", "apf_energy", "apf_slope", "apf_curvature", "apf_standoff",
           "default_r_min", "GridSpring", "spring_grid", "build_surface", "CHUNK_PAIRS"]

TWO_PI = 2.0 * np.pi
#: Pose pairs tested per call of shapely (bounds the memory of one call; progress between calls).
CHUNK_PAIRS = 65536


# --------------------------------------------------------------------------- blocked region

def _no_progress(phase, done, total):
    return None


def blocked_mask(poses0, poses1, periodic, progress=None) -> np.ndarray:
    """Where the posed parts' interiors overlap, shape (n0, n1) bool.

    Parameters
    ----------
    poses0, poses1 : ndarray of shapely geometries, shapes (n0,), (n1,)
        Part 0 at every node of axis 0, part 1 at every node of axis 1
        ([`pes_ref.devices.geometry.pose`][pes_ref.devices.geometry.pose]); ``poses0`` get prepared.
    periodic : sequence of 2 bool
        For the neighbours of a node across a seam.
    progress : callable, optional
        ``progress("blocked", rows_done, n0)`` after each chunk of rows.
    """
    shapely = require_shapely()
    progress = progress or _no_progress
    shapely.prepare(poses0)
    n0, n1 = poses0.size, poses1.size
    out = np.zeros((n0, n1), dtype=bool)
    rows = max(1, CHUNK_PAIRS // max(n1, 1))
    for s in range(0, n0, rows):
        out[s:s + rows] = shapely.intersects(poses0[s:s + rows, None], poses1[None, :])
        progress("blocked", min(s + rows, n0), n0)
    # an intersecting node next to a free one may only touch: free (interiors must overlap)
    checked = np.zeros_like(out)
    while True:
        todo = out & ~checked & _next_to(~out, periodic)
        i, j = np.nonzero(todo)
        if i.size == 0:
            return out
        checked[i, j] = True
        out[i, j] = shapely.relate_pattern(poses0[i], poses1[j], "T********")


def _next_to(mask: np.ndarray, periodic) -> np.ndarray:
    """Nodes with a 4-neighbour in ``mask`` (across the seam on a periodic axis)."""
    out = np.zeros_like(mask)
    for axis in range(2):
        for step in (1, -1):
            shifted = np.roll(mask, step, axis=axis)
            if not periodic[axis]:
                edge = [slice(None)] * 2
                edge[axis] = 0 if step == 1 else -1
                shifted[tuple(edge)] = False
            out |= shifted
    return out


class _SubPoses:
    """Poses of each part between the nodes, made on demand (each at most once): the
    bisection of [`pes_ref.devices.boundary.locate_crossings`][pes_ref.devices.boundary.locate_crossings] asks for them."""

    def __init__(self, parts, nodes, spacing, tolerance):
        self.parts, self.nodes, self.h, self.tol = parts, nodes, spacing, tolerance

    def overlaps(self, grid_poses, axis, i, j, u, k):
        """Whether part ``axis`` at node coordinate + u/k of a spacing overlaps the other part at its node."""
        shapely = require_shapely()
        start = i if axis == 0 else j
        other = j if axis == 0 else i
        key = start.astype(np.int64) * k + u
        unique, inverse = np.unique(key, return_inverse=True)
        q = self.nodes[axis][unique // k] + self.h[axis] * (unique % k) / k
        moved = pose(self.parts[axis], q, self.tol)
        return shapely.intersects(grid_poses[1 - axis][other], moved[inverse])


@dataclass(frozen=True)
class CSpace:
    """A C-space computed on its grid ([`CSpaceGrid.compute`][pes_ref.devices.cspace.CSpaceGrid.compute]).

    Attributes
    ----------
    grid : CSpaceGrid
    blocked : ndarray of bool, shape (n0, n1)
    distance : ndarray, shape (n0, n1)
        Signed distance to the boundary: > 0 free, < 0 blocked, in C-space units.
    segments : ndarray, shape (M, 2, 2)
        The boundary polyline (unwrapped (q0, q1) end points).
    times : dict
        Seconds spent posing, testing the nodes, locating the boundary and taking distances.
    """

    grid: "CSpaceGrid"
    blocked: np.ndarray
    distance: np.ndarray
    segments: np.ndarray
    times: dict = dc_field(default_factory=dict)

    def surface(self, v: float, r_c: float, springs=(), r_min=None) -> Surface:
        """Eq. (1) of [`distance`][pes_ref.devices.cspace.CSpaceGrid.distance] plus ``springs`` ([`build_surface`][pes_ref.devices.cspace.build_surface])."""
        g = self.grid
        return build_surface(self.distance, g.lower, g.upper, g.periodic, v, r_c, r_min, springs)


# --------------------------------------------------------------------------- eq. (1)

def default_r_min(spacing) -> float:
    """The smallest distance the grid resolves: ``min(h) / 2``."""
    return 0.5 * float(np.min(checks.as_float_array("spacing", spacing, positive=True)))


def _apf_args(r, v, r_c, r_min):
    r = checks.as_float_array("r", r)
    v = checks.as_nonneg_float("v", v)
    r_c = checks.as_positive_float("r_c", r_c)
    r_min = checks.as_positive_float("r_min", r_min)
    if not r_min < r_c:
        raise ValueError(f"r_min must be < r_c, got r_min={r_min:g}, r_c={r_c:g}")
    return r, v, r_c, r_min


def _eq1(r, v, r_c):
    """Eq. (1) and its first two derivatives for r_min <= r < r_c (arrays)."""
    a = 1.0 / r - 1.0 / r_c
    return 0.5 * v * a * a, -v * a / (r * r), v * (3.0 / r ** 4 - 2.0 / (r_c * r ** 3))


def _apf(r, v, r_c, r_min):
    """(E, dE/dr, d2E/dr2) of the capped eq. (1), elementwise."""
    e = np.zeros_like(r)
    de = np.zeros_like(r)
    d2e = np.zeros_like(r)
    mid = (r >= r_min) & (r < r_c)
    e[mid], de[mid], d2e[mid] = _eq1(r[mid], v, r_c)
    low = r < r_min
    e0, de0, _ = _eq1(np.array(r_min), v, r_c)
    e[low] = e0 + de0 * (r[low] - r_min)        # de0 <= 0: rises linearly below r_min
    de[low] = de0
    return e, de, d2e


def apf_energy(r, v: float, r_c: float, r_min: float) -> np.ndarray:
    """Eq. (1), ``E = v/2 (1/r - 1/r_c)^2`` for ``r_min <= r < r_c``, 0 for ``r >= r_c``.

    Below ``r_min`` (including r <= 0, blocked nodes) the linear continuation
    ``E(r_min) + |E'(r_min)| (r_min - r)`` (module docstring: the cap).

    Parameters
    ----------
    r : array_like
        Signed distance to blocked space (surface units), any shape, finite.
    v : float >= 0
        Barrier strength.
    r_c : float > 0
        Cut-off distance.
    r_min : float, 0 < r_min < r_c
        Smallest resolved distance ([`default_r_min`][pes_ref.devices.cspace.default_r_min]).

    Returns
    -------
    ndarray, same shape as r, finite.
    """
    return _apf(*_apf_args(r, v, r_c, r_min))[0]


def apf_slope(r, v: float, r_c: float, r_min: float) -> np.ndarray:
    """dE/dr of [`apf_energy`][pes_ref.devices.cspace.apf_energy]: ``-v (1/r - 1/r_c) / r^2`` on [r_min, r_c), ``E'(r_min)`` below, 0 above."""
    return _apf(*_apf_args(r, v, r_c, r_min))[1]


def apf_standoff(force: float, v: float, r_c: float, r_min: float) -> float:
    """Where eq. (1) holds a particle pushed onto blocked space by ``force`` (>= 0): the distance
    ``d`` in ``[r_min, r_c]`` at which the barrier's force ``|dE/dr| = v (1/d - 1/r_c) / d^2`` meets
    it (decreasing in ``d``: the root of ``force r_c d^3 + v d - v r_c = 0`` there); ``r_c`` for no
    force, ``r_min`` for a force the capped barrier cannot hold (above ``|E'(r_min)|``)."""
    if force <= 0.0:
        return float(r_c)
    if force >= -float(apf_slope(np.array(r_min), v, r_c, r_min)):
        return float(r_min)
    roots = np.roots([force * r_c, 0.0, v, -v * r_c])
    real = roots[np.abs(roots.imag) < 1e-12].real
    return float(real[(real >= r_min) & (real <= r_c)][0])


def apf_curvature(r, v: float, r_c: float, r_min: float) -> np.ndarray:
    """d2E/dr2 of [`apf_energy`][pes_ref.devices.cspace.apf_energy]: ``v (3/r^4 - 2/(r_c r^3))`` on [r_min, r_c), else
    0.

    Its largest value, at ``r = r_min``, is the barrier's stiffness for the explicit
    integrator's stability limit ``dt < 2 sqrt(m / k)``.
    """
    return _apf(*_apf_args(r, v, r_c, r_min))[2]


# --------------------------------------------------------------------------- springs on the grid

SIDES = ("both", "above", "below")


@dataclass(frozen=True)
class GridSpring:
    """A linear spring along one surface axis, baked into the grid values.

    ``U = k/2 d^2`` with ``d = q_axis - center`` (the minimum image on a periodic axis);
    ``side="above"`` acts only where d > 0 (e.g. a compression spring that the part leaves
    at its rest length), ``side="below"`` only where d < 0.
    """

    axis: int
    k: float
    center: float
    side: str = "both"

    def __post_init__(self):
        axis = checks.as_nonneg_int("axis", self.axis)
        if axis > 1:
            raise ValueError(f"axis must be 0 or 1, got {self.axis!r}")
        object.__setattr__(self, "axis", axis)
        object.__setattr__(self, "k", checks.as_nonneg_float("k", self.k))
        object.__setattr__(self, "center", checks.as_finite_float("center", self.center))
        object.__setattr__(self, "side", checks.as_choice("side", self.side, set(SIDES)))

    def extension(self, q: np.ndarray, length: float, periodic: bool) -> np.ndarray:
        """The extension ``d`` at coordinates q along the spring's axis (any shape): ``q - center``
        (the minimum image on a periodic axis), 0 on the side where the spring does not act."""
        d = q - self.center
        if periodic:
            d = np.mod(d + 0.5 * length, length) - 0.5 * length
        if self.side == "above":
            d = np.maximum(d, 0.0)
        elif self.side == "below":
            d = np.minimum(d, 0.0)
        return d

    def energy(self, q: np.ndarray, length: float, periodic: bool) -> np.ndarray:
        """Energy ``k/2 d^2`` at coordinates q along the spring's axis (any shape)."""
        d = self.extension(q, length, periodic)
        return 0.5 * self.k * d * d

    def force(self, q: np.ndarray, length: float, periodic: bool) -> np.ndarray:
        """The force ``-dU/dq = -k d`` at coordinates q along the spring's axis (any shape)."""
        return -self.k * self.extension(q, length, periodic)


def _nodes(lower, upper, shape, periodic, axis):
    h = grid_spacing(lower, upper, shape, np.asarray(periodic))
    return lower[axis] + h[axis] * np.arange(shape[axis])


def spring_grid(springs, lower, upper, shape, periodic) -> np.ndarray:
    """Sum of the springs' energies at the grid's nodes, shape (n0, n1)."""
    lower = checks.as_float_array("lower", lower, shape=(2,))
    upper = checks.as_float_array("upper", upper, shape=(2,))
    periodic = tuple(bool(p) for p in checks.as_bool_array("periodic", periodic, shape=(2,)))
    out = np.zeros(tuple(int(n) for n in shape))
    for s in springs:
        if not isinstance(s, GridSpring):
            raise TypeError(f"springs must be GridSpring objects, got {s!r}")
        q = _nodes(lower, upper, out.shape, periodic, s.axis)
        e = s.energy(q, float(upper[s.axis] - lower[s.axis]), periodic[s.axis])
        out += e[:, None] if s.axis == 0 else e[None, :]
    return out


def build_surface(distance, lower, upper, periodic, v: float, r_c: float, r_min=None, springs=()) -> Surface:
    """The device's surface: eq. (1) of the signed distance plus the grid springs.

    Parameters
    ----------
    distance : array_like, shape (n0, n1)
        Signed distance to blocked space at the nodes (`CSpace.distance`).
    lower, upper, periodic
        The surface's domain, as in [`pes_ref.Surface`][pes_ref.core.surface.Surface].
    v, r_c : float
        Eq. (1)'s strength and cut-off.
    r_min : float, optional
        The cap's distance; default ``min(h)/2`` of this grid.
    springs : sequence of GridSpring

    Returns
    -------
    pes_ref.Surface
    """
    distance = checks.as_float_array("distance", distance, ndim=2)
    lower = checks.as_float_array("lower", lower, shape=(2,))
    upper = checks.as_float_array("upper", upper, shape=(2,))
    periodic = tuple(bool(p) for p in checks.as_bool_array("periodic", periodic, shape=(2,)))
    if r_min is None:
        r_min = default_r_min(grid_spacing(lower, upper, distance.shape, np.asarray(periodic)))
    values = apf_energy(distance, v, r_c, r_min) + spring_grid(springs, lower, upper, distance.shape, periodic)
    return Surface(values, lower, upper, periodic)


# --------------------------------------------------------------------------- the grid object

@dataclass(frozen=True)
class CSpaceGrid:
    """The C-space of two parts sampled on a surface grid.

    Parameters
    ----------
    part0, part1 : pes_ref.devices.geometry.Part
        Part 0's coordinate is q0 (grid axis 0), part 1's is q1 (axis 1).
    lower, upper : array_like, shape (2,)
        The domain (translation distance or angle in radians).
    shape : (n0, n1), each >= 2
    periodic : sequence of 2 bool, optional
        Default: an axis is periodic iff its part rotates and ``upper - lower == 2 pi``.
        A periodic axis must belong to a rotating part and span exactly 2 pi.
    tolerance : float, optional
        The circles' tolerance (a length); default
        [`pes_ref.devices.geometry.default_tolerance`][pes_ref.devices.geometry.default_tolerance] of this grid.
    """

    part0: Part
    part1: Part
    lower: np.ndarray
    upper: np.ndarray
    shape: tuple
    periodic: tuple = None
    tolerance: float = None

    def __post_init__(self):
        parts = (self.part0, self.part1)
        for name, p in zip(("part0", "part1"), parts):
            if not isinstance(p, Part):
                raise checks.InputTypeError(name, f"{name} must be a pes_ref.devices.geometry.Part, "
                                                  f"got {type(p).__name__}")
        lower = checks.as_float_array("lower", self.lower, shape=(2,))
        upper = checks.as_float_array("upper", self.upper, shape=(2,))
        if not np.all(upper > lower):
            raise checks.InputError("upper", f"upper must be > lower on both axes, got lower={lower.tolist()}, "
                                             f"upper={upper.tolist()}", names=("upper", "lower"))
        shape = tuple(checks.as_positive_int(f"shape[{d}]", n) for d, n in enumerate(self.shape)) \
            if np.ndim(self.shape) == 1 and len(self.shape) == 2 else None
        if shape is None or min(shape) < 2:
            raise checks.InputError("shape", f"shape must be two integers >= 2, got {self.shape!r}")
        full = np.isclose(upper - lower, TWO_PI, rtol=1e-12, atol=0.0)
        if self.periodic is None:
            periodic = tuple(bool(p.periodic and f) for p, f in zip(parts, full))
        else:
            periodic = tuple(bool(p) for p in checks.as_bool_array("periodic", self.periodic, shape=(2,)))
            for d in range(2):
                if periodic[d] and not (parts[d].periodic and full[d]):
                    raise checks.InputError("periodic", f"periodic[{d}] needs a rotating part{d} and upper - lower "
                                                        f"= 2 pi, got span {upper[d] - lower[d]:g}")
        object.__setattr__(self, "lower", lower)
        object.__setattr__(self, "upper", upper)
        object.__setattr__(self, "shape", shape)
        object.__setattr__(self, "periodic", periodic)
        tol = default_tolerance(parts, self.spacing) if self.tolerance is None else \
            checks.as_positive_float("tolerance", self.tolerance)
        bound = tolerance_bound(parts, self.spacing)
        if not tol < bound:
            raise checks.InputError("tolerance", f"tolerance must be below {bound:.3g} (the grid spacing times the "
                                                 f"contact's lever, min_d h_d l_d: 20 times the default "
                                                 f"{bound / 20:.3g}), got {tol:g}: a circle's polygon would move "
                                                 f"the C-space boundary by more than a grid spacing")
        object.__setattr__(self, "tolerance", tol)

    @property
    def parts(self) -> tuple:
        """The two parts, ``(part0, part1)``: part 0 moves with q0, part 1 with q1."""
        return (self.part0, self.part1)

    @property
    def spacing(self) -> np.ndarray:
        """Node spacing h, shape (2,) (the [`pes_ref.Surface`][pes_ref.core.surface.Surface] convention)."""
        return grid_spacing(self.lower, self.upper, self.shape, np.asarray(self.periodic))

    def nodes(self, axis: int) -> np.ndarray:
        """Node coordinates along ``axis``, shape (n_axis,)."""
        return _nodes(self.lower, self.upper, self.shape, self.periodic, axis)

    def poses(self) -> tuple:
        """Each part posed at every node of its axis: two arrays of shapely geometries."""
        return tuple(pose(p, self.nodes(d), self.tolerance) for d, p in enumerate(self.parts))

    def blocked(self, progress=None) -> np.ndarray:
        """Blocked nodes, (n0, n1) bool ([`blocked_mask`][pes_ref.devices.cspace.blocked_mask])."""
        return self.posed_blocked(progress)[1]

    def posed_blocked(self, progress=None) -> tuple:
        """The parts posed at every node and the blocked nodes ([`blocked_mask`][pes_ref.devices.cspace.blocked_mask]),
        the first and cheapest part of [`compute`][pes_ref.devices.cspace.CSpaceGrid.compute]:
        ``(poses, mask, times)``, what [`compute`][pes_ref.devices.cspace.CSpaceGrid.compute] takes
        as ``blocked``. A refusal that needs only the mask (a C-space with no free node) comes from
        it before the boundary and the distance are computed."""
        progress = progress or _no_progress
        times = {}
        t = time.perf_counter()
        poses = self.poses()
        times["pose"] = time.perf_counter() - t
        t = time.perf_counter()
        mask = blocked_mask(*poses, self.periodic, progress)
        times["blocked"] = time.perf_counter() - t
        return poses, mask, times

    def compute(self, progress=None, reach: float | None = None, blocked: tuple | None = None) -> CSpace:
        """The blocked nodes, the boundary between them and the signed distance to it.

        Parameters
        ----------
        progress : callable, optional
            ``progress(phase, done, total)``: ``"blocked"`` per chunk of rows, ``"boundary"``
            per bisection step, ``"distance"`` once done.
        reach : float, optional
            The distance is exact within ``reach`` of the boundary (C-space units; default
            `pes_ref.devices.boundary.BAND` spacings), and within about h/2 beyond.
        blocked : tuple, optional
            What [`posed_blocked`][pes_ref.devices.cspace.CSpaceGrid.posed_blocked] returned for this grid (computed
            here when None).

        Returns
        -------
        CSpace
        """
        progress = progress or _no_progress
        poses, mask, times = self.posed_blocked(progress) if blocked is None else blocked
        times = dict(times)
        t = time.perf_counter()
        sub = _SubPoses(self.parts, (self.nodes(0), self.nodes(1)), self.spacing, self.tolerance)
        calls = [0]

        def overlaps(axis, i, j, u, k):
            calls[0] += 1
            progress("boundary", calls[0], 2 * boundary.BISECTION_STEPS)
            return sub.overlaps(poses, axis, i, j, u, k)

        crossings = boundary.locate_crossings(mask, self.periodic, overlaps)
        segments = boundary.boundary_segments(mask, crossings, self.lower, self.spacing, self.periodic)
        times["boundary"] = time.perf_counter() - t
        t = time.perf_counter()
        distance = self._distance(mask, segments, reach)
        times["distance"] = time.perf_counter() - t
        progress("distance", 1, 1)
        return CSpace(self, mask, distance, segments, times)

    def _distance(self, mask, segments, reach=None) -> np.ndarray:
        if segments.shape[0] == 0:
            far = float(np.hypot(*(self.spacing * np.array(self.shape))))
            return np.full(self.shape, -far if mask.all() else far)
        d = boundary.grid_distance(segments, self.lower, self.spacing, self.shape, self.periodic, reach)
        return np.where(mask, -d, d)

    def distance(self) -> np.ndarray:
        """Signed distance to the boundary, (n0, n1) ([`compute`][pes_ref.devices.cspace.CSpaceGrid.compute])."""
        return self.compute().distance

    def surface(self, v: float, r_c: float, springs=(), r_min=None) -> Surface:
        """Eq. (1) of the distance plus ``springs`` ([`build_surface`][pes_ref.devices.cspace.build_surface])."""
        return self.compute().surface(v, r_c, springs, r_min)
