"""A problem file's contact: eq. (1) of blocked space, and a design made of it (``[surface.contact]``).

A problem file may state the contact its designs are realized by (``docs/problems.md``,
``docs/realize.md``): eq. (1)'s strength ``v``, cut-off ``r_c`` and cap ``r_min``, and the
parts' ``clearance`` (the pin made that much larger than its cut-out) and ``restitution`` (the
rigid engine's), what the realized parts are made with. With
``realizable = true`` the design's grid values are a level set
([`pes_ref.synthesis.common.level_set.LevelSet`][pes_ref.synthesis.common.level_set.LevelSet]): the simulated surface is always eq.
(1) of
the shape ``{values + r_c < 0}``, and the design starts from the shapes ``blocked`` (drawn as
a device file's shapes, in the surface's coordinates), since a level set's shape only moves
where it has a contour: a wall grows only from a wall.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from pes_ref.synthesis.common.level_set import LevelSet

__all__ = ["Contact", "signed_distance", "outside_distance"]


class Contact(NamedTuple):
    """``[surface.contact]``: eq. (1)'s ``v``, ``r_c``, ``r_min``, whether the design is a level set
    (``realizable``), its starting shapes ``blocked`` ([`pes_ref.devices.geometry`][pes_ref.devices.geometry] shapes;
    ``()``: none),
    and the realized parts' ``clearance`` and ``restitution`` (None: not stated; the clearance then
    follows from the problem, `DesignProblem.parts_clearance`)."""

    v: float
    r_c: float
    r_min: float
    realizable: bool
    blocked: tuple
    clearance: float | None = None
    restitution: float | None = None

    def level_set(self) -> LevelSet | None:
        """The level set of a realizable design (None: the grid values are energies)."""
        return LevelSet(self.v, self.r_c, self.r_min) if self.realizable else None


def signed_distance(shapes, q0, q1, lower, upper, periodic, spacing) -> np.ndarray:
    """The signed distance (> 0 free, < 0 inside) from the nodes ``q0 x q1`` to the union of
    ``shapes`` (repeated one period either way along a periodic axis), circles drawn within a
    twentieth of the finer ``spacing`` (the device files' rule)."""
    from pes_ref.devices.geometry import require_shapely
    shapely = require_shapely()
    tolerance = float(np.min(spacing)) / 20.0
    return outside_distance(shapely.union_all([s.geometry(tolerance) for s in shapes]), q0, q1, lower, upper,
                            periodic)


def outside_distance(geom, q0, q1, lower, upper, periodic) -> np.ndarray:
    """The signed distance (> 0 outside, < 0 inside) from the nodes ``q0 x q1`` to the shapely
    geometry ``geom``, repeated one period either way along a periodic axis."""
    from pes_ref.devices.geometry import require_shapely
    shapely = require_shapely()
    shifts = [(0.0,) if not periodic[d] else (-(upper[d] - lower[d]), 0.0, upper[d] - lower[d]) for d in range(2)]
    geom = shapely.union_all([shapely.affinity.translate(geom, a, b) for a in shifts[0] for b in shifts[1]])
    x, y = np.meshgrid(np.asarray(q0, dtype=np.float64), np.asarray(q1, dtype=np.float64), indexing="ij")
    d = shapely.distance(geom.boundary, shapely.points(x.ravel(), y.ravel()))
    inside = shapely.contains_xy(geom, x.ravel(), y.ravel())
    return np.where(inside, -d, d).reshape(x.shape)
