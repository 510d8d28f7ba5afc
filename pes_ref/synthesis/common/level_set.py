"""Designs realizable as designed: the grid values are a level set, the surface eq. (1) of its shape.

A design's grid of energies is a smooth surface that parts cannot have: a pin in a plate
with cut-outs, or a follower in a drum's groove, gives eq. (1) of the distance to the
blocked part of the C-space and nothing in between (``docs/realize.md``). With a
[`LevelSet`][pes_ref.synthesis.common.level_set.LevelSet] the design variables are a *shape* instead:

- the grid values ``psi`` (one per node, like a design's energies) define the blocked
  region ``{phi < 0}``, ``phi = psi + r_c``, as the zero contour of ``phi`` interpolated
  linearly along the grid's edges (marching squares,
  [`pes_ref.devices.boundary.boundary_segments`][pes_ref.devices.boundary.boundary_segments]);
- the surface is eq. (1) of the exact distance from every node to that contour
  ([`pes_ref.devices.boundary.grid_distance`][pes_ref.devices.boundary.grid_distance], negative at blocked nodes),
  ``E = apf(d; v, r_c, r_min)`` ([`pes_ref.devices.cspace.apf_energy`][pes_ref.devices.cspace.apf_energy]).

So the simulated surface is always eq. (1) of some geometry, the one
[`pes_ref.realize`][pes_ref.realize] turns into parts. A held grid value 0 is free (``phi = r_c``, at
eq. (1)'s cut-off: no energy), so the flat surface, the held strips of a problem and
coarse-to-fine resampling keep their meaning. Only the nodes next to the contour move the
surface: a node's value moves the contour's crossing on each grid edge it ends, and the
crossing moves the distance of every node whose nearest contour point is on a segment
ending there.

The gradient ([`LevelSet.vjp`][pes_ref.synthesis.common.level_set.LevelSet.vjp]) is exact for that
map: with ``t = phi_a / (phi_a - phi_b)`` the crossing's fraction of a spacing on the edge a -> b,
``c`` a node's nearest point on segment (p, q) at parameter ``s`` (clipped to [0, 1]) and ``u`` the
unit vector from ``c`` to the node, ``d dist / d p = -u (1 - s)`` and ``d dist / d q = -u s`` (the
nearest point's own motion is second order), ``d p / d phi_a = -h e phi_b / (phi_a - phi_b)^2``, ``d
p / d phi_b = h e phi_a / (phi_a - phi_b)^2`` (``e`` the edge's unit vector, ``h`` its spacing). It
is piecewise smooth: it has kinks where a node's nearest segment changes (the medial axis), where a
nearest point reaches a segment's end, and where a node changes sign (the contour's topology), and
it is zero away from the contour (the shape only moves; a wall appears only where the contour
reaches: `LevelSet.initial_values` starts from one).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pes_ref.core import checks
from pes_ref.core.surface import spacing as grid_spacing

__all__ = ["LevelSet", "LevelSetTape"]

#: The last forward map (its key, grid and tape): one entry, reused only for an equal grid.
_LAST: dict = {}


@dataclass(frozen=True)
class LevelSetTape:
    """What [`LevelSet.vjp`][pes_ref.synthesis.common.level_set.LevelSet.vjp] needs of a forward map: phi, the blocked mask,
    the contour's
    segments and end crossings, each node's nearest segment (-1 beyond the band) and its
    signed distance."""

    phi: np.ndarray
    mask: np.ndarray
    segments: np.ndarray
    ids: np.ndarray
    nearest: np.ndarray
    distance: np.ndarray


@dataclass(frozen=True)
class LevelSet:
    """Eq. (1) of the shape ``{psi + r_c < 0}``: the parameters of the barrier a realized part gives.

    Parameters
    ----------
    v : float > 0
        Eq. (1)'s strength (energy x C-space length^2).
    r_c : float > 0
        Eq. (1)'s cut-off (C-space units): the barrier acts within r_c of blocked space.
    r_min : float, 0 < r_min < r_c
        Eq. (1)'s cap: below it the energy rises linearly with the slope it has there
        ([`pes_ref.devices.cspace.apf_energy`][pes_ref.devices.cspace.apf_energy]).
    """

    v: float
    r_c: float
    r_min: float

    def __post_init__(self):
        object.__setattr__(self, "v", checks.as_positive_float("contact_v", self.v))
        object.__setattr__(self, "r_c", checks.as_positive_float("contact_r_c", self.r_c))
        object.__setattr__(self, "r_min", checks.as_positive_float("contact_r_min", self.r_min))
        if not self.r_min < self.r_c:
            raise checks.InputError("contact_r_min", f"contact_r_min must be < contact_r_c = {self.r_c:g}, got "
                                                     f"{self.r_min:g}", names=("contact_r_min", "contact_r_c"))

    # ------------------------------------------------------------------ the map
    def forward(self, psi, lower, upper, periodic) -> LevelSetTape:
        """[`trace`][pes_ref.synthesis.common.level_set.LevelSet.trace], remembered for the last grid (a design iteration asks
        for its surface,
        then for the gradient through it)."""
        key = (self, tuple(np.asarray(lower, dtype=np.float64)), tuple(np.asarray(upper, dtype=np.float64)),
               tuple(bool(p) for p in periodic))
        psi = np.asarray(psi, dtype=np.float64)
        last = _LAST.get("tape")
        if last is not None and last[0] == key and last[1].shape == psi.shape and np.array_equal(last[1], psi):
            return last[2]
        tape = self.trace(psi, lower, upper, periodic)
        _LAST["tape"] = (key, psi.copy(), tape)
        return tape

    def trace(self, psi, lower, upper, periodic) -> LevelSetTape:
        """The signed distance (> 0 free) from every node to the contour of ``phi = psi + r_c``,
        exact out to ``r_c`` and two spacings beyond; farther, ``r_c`` plus two spacings on the
        free side (eq. (1) is zero there) and the distance to the nearest free node inside."""
        from pes_ref.devices import boundary          # the layer below: devices' contour and distance
        phi = np.asarray(psi, dtype=np.float64) + self.r_c
        lower = np.asarray(lower, dtype=np.float64)
        periodic = tuple(bool(p) for p in periodic)
        h = grid_spacing(lower, np.asarray(upper, dtype=np.float64), phi.shape, np.asarray(periodic))
        mask = phi < 0.0
        crossings = [_crossings(phi, mask, axis, periodic[axis]) for axis in range(2)]
        segments, ids = boundary.boundary_segments(mask, crossings, lower, h, periodic, corners=False,
                                                   return_ids=True)
        if segments.shape[0] == 0:
            far = float(np.hypot(*(h * np.array(phi.shape))))
            distance = np.full(phi.shape, -far if mask.all() else far)
            return LevelSetTape(phi, mask, segments, ids, np.full(phi.shape, -1), distance)
        reach = self.r_c + 2.0 * float(np.max(h))
        dist, nearest = boundary.grid_distance(segments, lower, h, phi.shape, periodic, reach, return_nearest=True,
                                               propagate=False)
        far = ~np.isfinite(dist)
        if far.any():        # beyond the band: eq. (1) is 0 on the free side; inside, the depth to a free node
            dist[far & ~mask] = reach
            deep = far & mask
            if deep.any():
                dist[deep] = np.maximum(_depth(mask, h, periodic)[deep], reach)
        return LevelSetTape(phi, mask, segments, ids, nearest, np.where(mask, -dist, dist))

    def energy(self, psi, lower, upper, periodic) -> np.ndarray:
        """The surface's grid values: eq. (1) of the signed distance to the shape of ``psi``."""
        from pes_ref.devices.cspace import apf_energy
        return apf_energy(self.forward(psi, lower, upper, periodic).distance, self.v, self.r_c, self.r_min)

    def vjp(self, psi, grad_energy, lower, upper, periodic) -> np.ndarray:
        """dL/dpsi from dL/dE (both shaped like the grid): the exact gradient of
        [`energy`][pes_ref.synthesis.common.level_set.LevelSet.energy]
        (module docstring), transposed."""
        from pes_ref.devices.cspace import apf_slope
        lower = np.asarray(lower, dtype=np.float64)
        tape = self.forward(psi, lower, upper, periodic)
        g_dist = np.asarray(grad_energy, dtype=np.float64) * apf_slope(tape.distance, self.v, self.r_c, self.r_min)
        g_dist = np.where(tape.mask, -g_dist, g_dist)            # d = -dist at blocked nodes
        return distance_vjp(tape, g_dist, lower, upper, periodic)

    # ------------------------------------------------------------------ shapes
    def project(self, psi, lower, upper, periodic) -> np.ndarray:
        """The same shape with ``phi`` its signed distance (capped at r_c: ``psi <= 0``), the
        level set's values well scaled again (the contour moves by at most a rounding where it
        is straight within a cell)."""
        return np.minimum(self.forward(psi, lower, upper, periodic).distance, self.r_c) - self.r_c

    def from_distance(self, distance) -> np.ndarray:
        """The grid values of the shape whose signed distance (> 0 free) is ``distance``."""
        return np.minimum(np.asarray(distance, dtype=np.float64), self.r_c) - self.r_c


def _depth(mask, h, periodic) -> np.ndarray:
    """Each blocked node's distance to the nearest free node (scipy's distance transform; a
    periodic axis wrapped once on each side): the depth of a node far inside blocked space."""
    from scipy import ndimage
    pad = [(n, n) if p else (0, 0) for n, p in zip(mask.shape, periodic)]
    d = ndimage.distance_transform_edt(np.pad(mask, pad, mode="wrap"), sampling=h)
    return d[tuple(slice(p[0], p[0] + n) for p, n in zip(pad, mask.shape))]


def _crossings(phi, mask, axis: int, periodic: bool) -> np.ndarray:
    """The contour's crossing on each grid edge from node (i, j) along ``axis``: its fraction of
    a spacing past the node, NaN where the edge's two nodes are on one side."""
    nxt = np.roll(phi, -1, axis=axis)
    diff = mask != (nxt < 0.0)
    if not periodic:
        last = [slice(None)] * 2
        last[axis] = -1
        diff[tuple(last)] = False
    t = np.full(phi.shape, np.nan)
    t[diff] = phi[diff] / (phi[diff] - nxt[diff])
    return t


def distance_vjp(tape: LevelSetTape, g_dist, lower, upper, periodic) -> np.ndarray:
    """dL/dphi from dL/d(unsigned distance) at every node (the transpose of the distance's
    derivative through the nearest segments' end crossings, module docstring)."""
    phi = tape.phi
    out = np.zeros(phi.size)
    band = np.nonzero((tape.nearest.ravel() >= 0) & (g_dist.ravel() != 0.0))[0]
    if band.size == 0:
        return out.reshape(phi.shape)
    lower = np.asarray(lower, dtype=np.float64)
    periodic = tuple(bool(p) for p in periodic)
    shape = np.array(phi.shape)
    h = grid_spacing(lower, np.asarray(upper, dtype=np.float64), phi.shape, np.asarray(periodic))
    node = np.stack(np.unravel_index(band, phi.shape), axis=1)
    x = lower + h * node
    k = tape.nearest.ravel()[band]
    a, b = tape.segments[k, 0], tape.segments[k, 1]
    e = b - a
    rel = x - a
    for ax in range(2):                          # the node as the segment (unwrapped) sees it
        if periodic[ax]:
            length = h[ax] * shape[ax]
            rel[:, ax] -= length * np.round((rel[:, ax] - 0.5 * e[:, ax]) / length)
    ee = np.einsum("ij,ij->i", e, e)
    s = np.clip(np.einsum("ij,ij->i", rel, e) / np.where(ee > 0, ee, 1.0), 0.0, 1.0)
    off = rel - s[:, None] * e
    dist = np.hypot(off[:, 0], off[:, 1])
    ok = dist > 0.0
    u = np.zeros_like(off)
    u[ok] = off[ok] / dist[ok, None]
    g = g_dist.ravel()[band]
    size = phi.size
    for end, weight in ((0, 1.0 - s), (1, s)):
        gp = -(g * weight)[:, None] * u          # dL/d(end point)
        cid = tape.ids[k, end]
        axis, start = cid // size, cid % size
        i, j = np.unravel_index(start, phi.shape)
        ni = np.where(axis == 0, (i + 1) % shape[0], i)
        nj = np.where(axis == 1, (j + 1) % shape[1], j)
        pa, pb = phi.ravel()[start], phi[ni, nj]
        along = gp[np.arange(gp.shape[0]), axis] * h[axis]      # dL/dt of the crossing
        den = (pa - pb) ** 2
        np.add.at(out, start, along * (-pb) / den)
        np.add.at(out, ni * phi.shape[1] + nj, along * pa / den)
    return out.reshape(phi.shape)
