"""Configuration space on a grid, the artificial potential field (eq. (1)) and the surface.

Paper, "Contribution 1": blocked regions of a configuration space become high potential
energy by the artificial potential field

    E(r) = v/2 (1/r - 1/r_c)^2   for r < r_c,     E(r) = 0   for r >= r_c        (1)

with r the distance from a point to blocked space; the result is summed with the
energies of the device's springs into one surface.

Grid. A :class:`CSpaceGrid` samples the coordinates (q0, q1) of two parts on the nodes of
a :class:`pes_ref.Surface` of the same ``lower``, ``upper``, shape and topology (periodic
spacing ``L/n``, otherwise ``L/(n-1)``); a node is blocked where the posed parts overlap
with positive area (:func:`pes_ref.devices.geometry.overlap_table`).

Distance. :func:`signed_distance` is the Euclidean distance transform
(``scipy.ndimage.distance_transform_edt`` with the grid's spacing) from every free node to
the nearest blocked node, minus ``min(h)/2`` (the boundary is taken halfway between the
two nodes); blocked nodes get minus the same construction from the free side. Periodic
axes are made seamless by wrapping the mask one full period on each side before the
transform, so distances are the minimum over periodic images. The estimate is within
about one spacing of the exact distance to the continuous boundary
(``validation/cspace_minkowski.py`` measures it).

Cap. Eq. (1) diverges at r = 0 and the grid cannot resolve r below about half a spacing,
so :func:`apf_energy` uses eq. (1) only for ``r >= r_min`` (default ``min(h)/2``) and
continues it *linearly* below, with the slope it has at ``r_min``:

    E(r) = E(r_min) + |E'(r_min)| (r_min - r)     for r < r_min (blocked nodes: r < 0).

This is finite for every finite r, continuous with a continuous slope at ``r_min``, and
keeps rising into blocked space so a particle that got in is pushed out. No inf or NaN
ever reaches the integrator.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pes_ref.core import checks
from pes_ref.devices.geometry import Part, overlap_table, pose, CHUNK_ELEMENTS
from pes_ref.core.surface import Surface, spacing as grid_spacing

__all__ = ["CSpaceGrid", "blocked_mask", "signed_distance", "apf_energy", "apf_slope", "apf_curvature",
           "default_r_min", "GridSpring", "spring_grid", "build_surface"]

TWO_PI = 2.0 * np.pi


# --------------------------------------------------------------------------- blocked region

def blocked_mask(part0: Part, part1: Part, q0_nodes, q1_nodes, *, chunk_elements: int = CHUNK_ELEMENTS) -> np.ndarray:
    """Where the two parts overlap with positive area, shape (n0, n1) bool.

    Parameters
    ----------
    part0, part1 : pes_ref.devices.geometry.Part
        Part 0 moves with coordinate q0 (grid axis 0), part 1 with q1 (axis 1).
    q0_nodes, q1_nodes : array_like, shape (n0,), (n1,)
    chunk_elements : int
        Memory bound of :func:`pes_ref.devices.geometry.overlap_table`.
    """
    for name, p in (("part0", part0), ("part1", part1)):
        if not isinstance(p, Part):
            raise TypeError(f"{name} must be a pes_ref.devices.geometry.Part, got {type(p).__name__}")
    q0 = checks.as_float_array("q0_nodes", q0_nodes, ndim=1)
    q1 = checks.as_float_array("q1_nodes", q1_nodes, ndim=1)
    return overlap_table(pose(part0, q0), pose(part1, q1), chunk_elements=chunk_elements)


def _edt(inside: np.ndarray, spacing: np.ndarray, periodic) -> np.ndarray:
    """Distance from each True node to the nearest False node, seamless on periodic axes."""
    from scipy import ndimage     # imported here: ``import pes_ref`` stays light
    pad = [(n, n) if p else (0, 0) for n, p in zip(inside.shape, periodic)]
    tiled = np.pad(inside, pad, mode="wrap")
    d = ndimage.distance_transform_edt(tiled, sampling=spacing)
    crop = tuple(slice(p[0], p[0] + n) for p, n in zip(pad, inside.shape))
    return d[crop]


def signed_distance(mask, spacing, periodic) -> np.ndarray:
    """Signed distance to the C-space boundary at every node, shape (n0, n1).

    Parameters
    ----------
    mask : array_like of bool, shape (n0, n1)
        True where blocked.
    spacing : array_like, shape (2,)
        Node spacing h of each axis.
    periodic : sequence of 2 bool

    Returns
    -------
    ndarray, shape (n0, n1)
        ``d_free - min(h)/2`` (> 0) at free nodes, ``-(d_blocked - min(h)/2)`` (< 0) at
        blocked nodes, where ``d_free`` is the Euclidean distance to the nearest blocked
        node and ``d_blocked`` to the nearest free node (module docstring). Without any
        blocked (free) node every node gets + (-) the domain's diagonal ``|h * n|``.
    """
    shape = np.shape(mask)
    if len(shape) != 2 or min(shape) < 1:
        raise ValueError(f"mask must be a 2-d boolean grid, got shape {shape}")
    mask = checks.as_bool_array("mask", mask, shape=shape)
    h = checks.as_float_array("spacing", spacing, shape=(2,), positive=True)
    periodic = tuple(bool(p) for p in checks.as_bool_array("periodic", periodic, shape=(2,)))
    half = 0.5 * float(np.min(h))
    far = float(np.hypot(*(h * np.array(mask.shape))))
    out = np.empty(mask.shape)
    free = ~mask
    if not mask.any():
        out[:] = far
        return out
    if not free.any():
        out[:] = -far
        return out
    out[free] = _edt(free, h, periodic)[free] - half
    out[mask] = half - _edt(mask, h, periodic)[mask]
    return out


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
        Smallest resolved distance (:func:`default_r_min`).

    Returns
    -------
    ndarray, same shape as r, finite.
    """
    return _apf(*_apf_args(r, v, r_c, r_min))[0]


def apf_slope(r, v: float, r_c: float, r_min: float) -> np.ndarray:
    """dE/dr of :func:`apf_energy`: ``-v (1/r - 1/r_c) / r^2`` on [r_min, r_c), ``E'(r_min)`` below, 0 above."""
    return _apf(*_apf_args(r, v, r_c, r_min))[1]


def apf_curvature(r, v: float, r_c: float, r_min: float) -> np.ndarray:
    """d2E/dr2 of :func:`apf_energy`: ``v (3/r^4 - 2/(r_c r^3))`` on [r_min, r_c), else 0.

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

    def energy(self, q: np.ndarray, length: float, periodic: bool) -> np.ndarray:
        """Energy at coordinates q along the spring's axis (any shape)."""
        d = q - self.center
        if periodic:
            d = np.mod(d + 0.5 * length, length) - 0.5 * length
        if self.side == "above":
            d = np.maximum(d, 0.0)
        elif self.side == "below":
            d = np.minimum(d, 0.0)
        return 0.5 * self.k * d * d


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
        Signed distance to blocked space at the nodes (:func:`signed_distance`).
    lower, upper, periodic
        The surface's domain, as in :class:`pes_ref.Surface`.
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
    """

    part0: Part
    part1: Part
    lower: np.ndarray
    upper: np.ndarray
    shape: tuple
    periodic: tuple = None

    def __post_init__(self):
        parts = (self.part0, self.part1)
        for name, p in zip(("part0", "part1"), parts):
            if not isinstance(p, Part):
                raise TypeError(f"{name} must be a pes_ref.devices.geometry.Part, got {type(p).__name__}")
        lower = checks.as_float_array("lower", self.lower, shape=(2,))
        upper = checks.as_float_array("upper", self.upper, shape=(2,))
        if not np.all(upper > lower):
            raise ValueError(f"upper must be > lower on both axes, got lower={lower.tolist()}, upper={upper.tolist()}")
        shape = tuple(checks.as_positive_int(f"shape[{d}]", n) for d, n in enumerate(self.shape)) \
            if np.ndim(self.shape) == 1 and len(self.shape) == 2 else None
        if shape is None or min(shape) < 2:
            raise ValueError(f"shape must be two integers >= 2, got {self.shape!r}")
        full = np.isclose(upper - lower, TWO_PI, rtol=1e-12, atol=0.0)
        if self.periodic is None:
            periodic = tuple(bool(p.periodic and f) for p, f in zip(parts, full))
        else:
            periodic = tuple(bool(p) for p in checks.as_bool_array("periodic", self.periodic, shape=(2,)))
            for d in range(2):
                if periodic[d] and not (parts[d].periodic and full[d]):
                    raise ValueError(f"periodic[{d}] needs a rotating part{d} and upper - lower = 2 pi, "
                                     f"got span {upper[d] - lower[d]:g}")
        object.__setattr__(self, "lower", lower)
        object.__setattr__(self, "upper", upper)
        object.__setattr__(self, "shape", shape)
        object.__setattr__(self, "periodic", periodic)

    @property
    def spacing(self) -> np.ndarray:
        """Node spacing h, shape (2,) (the :class:`pes_ref.Surface` convention)."""
        return grid_spacing(self.lower, self.upper, self.shape, np.asarray(self.periodic))

    def nodes(self, axis: int) -> np.ndarray:
        """Node coordinates along ``axis``, shape (n_axis,)."""
        return _nodes(self.lower, self.upper, self.shape, self.periodic, axis)

    def blocked(self) -> np.ndarray:
        """Blocked nodes, (n0, n1) bool (:func:`blocked_mask`)."""
        return blocked_mask(self.part0, self.part1, self.nodes(0), self.nodes(1))

    def distance(self, blocked=None) -> np.ndarray:
        """Signed distance to the boundary, (n0, n1) (:func:`signed_distance`)."""
        mask = self.blocked() if blocked is None else blocked
        return signed_distance(mask, self.spacing, self.periodic)

    def surface(self, v: float, r_c: float, springs=(), r_min=None, blocked=None) -> Surface:
        """Eq. (1) of :meth:`distance` plus ``springs`` (:func:`build_surface`)."""
        return build_surface(self.distance(blocked), self.lower, self.upper, self.periodic, v, r_c, r_min, springs)
