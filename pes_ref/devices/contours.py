"""A region ``{phi < 0}`` of a level function on a grid, as polygons.

The region's boundary is the zero contour of ``phi`` interpolated linearly along the grid's edges
(contourpy's filled contours, the same marching squares as
[`pes_ref.devices.boundary.boundary_segments`][pes_ref.devices.boundary.boundary_segments] apart
from the choice in a cell with two blocked corners on a diagonal), drawn past the grid's edges by
repeating the edge values (a surface extends as a constant beyond a non-periodic edge) and round a
periodic axis by wrapping. A contact realization draws its blocked region so
([`pes_ref.realize.regions`][pes_ref.realize.regions]), and a realizable problem file's design
from its paths ends on its shape so drawn and smoothed
([`pes_ref.synthesis.problem.paths_region`][pes_ref.synthesis.problem.paths_region]).
"""
from __future__ import annotations

import math

import numpy as np

from pes_ref.core.runtime.extras import found
from pes_ref.core.surface import spacing as grid_spacing
from pes_ref.devices.geometry import require_shapely

__all__ = ["region_polygons"]


def region_polygons(phi, lower, upper, periodic, margin: float):
    """The region ``{phi < 0}`` as shapely polygons in (q0, q1), drawn ``margin`` past the grid's
    edges (repeating the edge values on a non-periodic axis, wrapping a periodic one).

    Returns ``(geometry, box)``: a (Multi)Polygon (empty if nothing is blocked) and the box
    ``(lower, upper)`` it is drawn in.
    """
    shapely = require_shapely()
    found("contourpy", "realize", "a region's contour")
    import contourpy
    phi = np.asarray(phi, dtype=np.float64)
    lower = np.asarray(lower, dtype=np.float64)
    h = grid_spacing(lower, np.asarray(upper, dtype=np.float64), phi.shape, np.asarray(periodic))
    pads = [int(math.ceil(margin / h[d])) + 1 for d in range(2)]
    padded = phi
    for d in range(2):
        width = [(0, 0), (0, 0)]
        width[d] = (pads[d], pads[d])
        padded = np.pad(padded, width, mode="wrap" if periodic[d] else "edge")
    nodes = [lower[d] + h[d] * (np.arange(padded.shape[d]) - pads[d]) for d in range(2)]
    box_lo = np.array([nodes[0][0], nodes[1][0]])
    box_hi = np.array([nodes[0][-1], nodes[1][-1]])
    if not (padded < 0).any():
        return shapely.Polygon(), (box_lo, box_hi)
    gen = contourpy.contour_generator(nodes[0], nodes[1], padded.T, fill_type="OuterOffset")
    points, offsets = gen.filled(-np.inf, 0.0)
    polys = []
    for pts, off in zip(points, offsets):
        rings = [pts[a:b] for a, b in zip(off[:-1], off[1:])]
        poly = shapely.Polygon(rings[0], rings[1:])
        polys.append(poly if poly.is_valid else shapely.make_valid(poly))
    geom = shapely.union_all(polys)
    return shapely.normalize(geom), (box_lo, box_hi)
