"""A realizable problem's start made from its paths: the region a smooth design's passing particles cover.

A level set's walls grow only from walls
([`pes_ref.synthesis.common.level_set`][pes_ref.synthesis.common.level_set]), so a problem file's
realizable design (``[surface.contact] realizable = true``) starts from a shape. Without drawn
``blocked`` shapes the shape is made from the problem itself (the run that makes it is
[`pes_ref.synthesis.engine.paths_start`][pes_ref.synthesis.engine.paths_start]): a smooth design of the
same problem passes its tests with slopes, and where its passing particles go is a channel that
walls can keep. This module is that channel, in three steps:

1. **the passing paths** ([`passing_paths`][pes_ref.synthesis.problem.paths_region.passing_paths]):
   `PATHS_PARTICLES` particles of the training sampler on the smooth surface, those that pass every
   success test, each path cut at its first state past an edge without a wall (past an exit edge the paths
   spread and nothing is asked of them) and carried on from there `EXIT_REACH` ``r_c`` straight out
   across the edge (the channel stays open through the edge after the smoothing below), and split
   where it wraps on a periodic axis;
2. **the free region** ([`free_region`][pes_ref.synthesis.problem.paths_region.free_region]): the
   paths as tubes `PATHS_BUFFER` ``r_c`` wide each side, joined with the starts (their boxes or
   points grown by `START_BUFFER` ``r_c``: every start is free, whether its particle passed or
   not) and the held boxes (a held value is free); then *closed* and *opened* by `SMOOTHING`
   ``r_c`` (grown and shrunk, then shrunk and grown), which fills the gaps between neighbouring
   tubes and takes out the dents and single stray tubes a rigid pin would stop in, and its holes
   filled (an island no passing path goes round is a post particles land on);
3. **its signed distance** on the grid's nodes
   ([`region_distance`][pes_ref.synthesis.problem.paths_region.region_distance]), the level set's
   start.

A design from that start ends on its delivered shape made smooth the same way
([`smoothed_values`][pes_ref.synthesis.problem.paths_region.smoothed_values]): the gradient steps
notch a level set's walls, and a rigid pin stops in the notches.

The tubes are narrower than the parts' ``clearance`` should be (`docs/realize.md`, "Realizable
design for any problem"): the rigid pin's centre then stays inside the region the passing paths
covered, so a wall's foot at an exit edge lies where passing paths left.
"""
from __future__ import annotations

import numpy as np

from pes_ref.core.surface import spacing as grid_spacing
from pes_ref.synthesis.problem.problem_contact import outside_distance

__all__ = ["PATHS_PARTICLES", "EXIT_REACH", "PATHS_BUFFER", "START_BUFFER", "SMOOTHING", "passing_paths", "free_region",
           "region_distance", "smoothed_values"]

#: Particles of the smooth design whose passing paths make the region.
PATHS_PARTICLES = 400
#: How far past the domain's edge a passing path is kept, in ``r_c``.
EXIT_REACH = 3.0
#: Each passing path's tube, in ``r_c`` each side (measured: docs/realize.md).
PATHS_BUFFER = 0.5
#: How far the starts' boxes and points are grown into the free region, in ``r_c``.
START_BUFFER = 2.0
#: The radius of the region's closing and opening, in ``r_c``.
SMOOTHING = 1.0


def passing_paths(problem, values, seed: int, n_particles: int = PATHS_PARTICLES) -> list:
    """The paths ((k, 2) arrays of states) of the particles of ``problem`` on the surface ``values``
    (``problem.run``: the training sampler from ``default_rng(seed)``) that pass every success
    test, each cut after its first state past an edge of a non-periodic axis that has no wall
    (``[dynamics] walls``) and carried on `EXIT_REACH` ``r_c`` straight out across that edge, and split where it wraps along a periodic
    one."""
    held = problem.run(values, seed, n_particles)
    passes = problem.batch_passes(held.traj)
    x = np.asarray(held.traj.x, dtype=np.float64)
    lower, upper = np.asarray(problem.lower), np.asarray(problem.upper)
    periodic = np.asarray(problem.periodic, dtype=bool)
    period = upper - lower
    walls = problem.scene_keys.get("walls")
    open_edges = ~periodic[:, None] & (True if walls is None else ~np.asarray(walls.edges, dtype=bool))
    paths = []
    for i in np.nonzero(passes)[0]:
        path = x[:, i, :]
        below, above = (path < lower) & open_edges[:, 0], (path > upper) & open_edges[:, 1]
        outside = (below | above).any(axis=1)
        if outside.any():
            k = int(np.argmax(outside))
            out = path[k] + EXIT_REACH * problem.contact.r_c * (above[k].astype(float) - below[k])
            path = np.vstack([path[:k + 1], out])
        jumps = np.nonzero((np.abs(np.diff(path, axis=0)) > period / 2)[:, periodic].any(axis=1))[0]
        paths.extend(p for p in np.split(path, jumps + 1) if len(p))
    return paths


def _start_shapes(shapely, starts, grow: float) -> list:
    """The starts' boxes and points (every group's), grown by ``grow``."""
    if starts.groups:
        return [s for g in starts.groups for s in _start_shapes(shapely, g.starts, grow)]
    if starts.box is not None:
        (a, b), (c, d) = starts.box
        return [shapely.box(a, b, c, d).buffer(grow)]
    return [shapely.Point(p).buffer(grow) for p in starts.points]


def _smoothed(shapely, problem, parts):
    """The union of ``parts`` with the starts and held boxes, closed and opened by `SMOOTHING`
    ``r_c``, its holes filled."""
    r_c = problem.contact.r_c
    parts = list(parts) + _start_shapes(shapely, problem.starts, START_BUFFER * r_c)
    parts += [shapely.box(lo[0], lo[1], hi[0], hi[1]) for lo, hi in problem.holds]
    region = shapely.union_all(parts)
    rho = SMOOTHING * r_c
    region = region.buffer(rho, quad_segs=4).buffer(-2 * rho, quad_segs=4).buffer(rho, quad_segs=4)
    polygons = getattr(region, "geoms", [region])
    return shapely.union_all([shapely.Polygon(p.exterior) for p in polygons if not p.is_empty])


def free_region(problem, paths):
    """The free region (a shapely geometry in the surface's coordinates) of the passing ``paths``:
    their tubes, the starts and the held boxes, closed and opened by `SMOOTHING` ``r_c``, holes filled
    (module docstring)."""
    from pes_ref.devices.geometry import require_shapely
    shapely = require_shapely()
    h = float(np.min(grid_spacing(np.asarray(problem.lower, dtype=np.float64),
                                  np.asarray(problem.upper, dtype=np.float64), problem.grid_shape,
                                  np.asarray(problem.periodic))))
    tubes = [shapely.LineString(p).simplify(h / 4) if len(p) > 1 else shapely.Point(p[0]) for p in paths]
    return _smoothed(shapely, problem, shapely.buffer(tubes, PATHS_BUFFER * problem.contact.r_c, quad_segs=4)
                     if tubes else [])


def smoothed_values(problem, values) -> np.ndarray:
    """The level set ``values`` of a design from its paths made smooth as its start was: its free
    region (``{values + r_c >= 0}`` drawn `EXIT_REACH` ``r_c`` past the grid's edges,
    [`pes_ref.devices.contours.region_polygons`][pes_ref.devices.contours.region_polygons]) joined with
    the starts and held boxes, closed and opened by `SMOOTHING` ``r_c``, its holes filled; returned as
    the level set's grid values of that region. Gradient steps notch a level set's walls, and a rigid
    pin stops in the notches that eq. (1)'s barrier rides over."""
    from pes_ref.devices.contours import region_polygons
    from pes_ref.devices.geometry import require_shapely
    shapely = require_shapely()
    r_c = problem.contact.r_c
    blocked, (lo, hi) = region_polygons(np.asarray(values) + r_c, problem.lower, problem.upper, problem.periodic,
                                        EXIT_REACH * r_c)
    free = shapely.box(lo[0], lo[1], hi[0], hi[1]).difference(blocked)
    region = _smoothed(shapely, problem, [free])
    shape = np.shape(values)
    return problem.level_set.from_distance(region_distance(problem, region, shape)) * problem.mask(shape)


def region_distance(problem, region, shape: tuple) -> np.ndarray:
    """The signed distance (> 0 free) from the nodes of a grid of ``shape`` to the boundary of
    ``region`` (repeated one period either way along a periodic axis)."""
    return -outside_distance(region, problem.nodes(shape, 0), problem.nodes(shape, 1), problem.lower, problem.upper,
                             problem.periodic)
