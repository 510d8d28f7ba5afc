"""The blocked region of a design: where its surface becomes rigid contact.

A contact realization keeps the design's energy above a *contact level* ``E_c`` as blocked
space (a part's material) and eq. (1) of the distance to it as the energy; everything
below the level is flat, except the springs and walls the design's scene has. The level is
chosen by a stated rule, `CONTACT_RULES` (``docs/realize.md``):

- ``"level-set"`` (the default for a design made realizable, ``--set realizable=true``):
  the design's own shape, ``{values + r_c < 0}`` ([`pes_ref.synthesis.common.level_set`][pes_ref.synthesis.common.level_set]); its
  level is eq. (1)'s energy at distance 0, and the surface it simulated is eq. (1) of this
  very region;
- ``"visited"`` (the default otherwise): the highest energy the design's own particles
  reach, the `VISITED_QUANTILE` quantile of the surface's energy over every state of
  the paths of `VISITED_SEED` (never a held-out seed): rigid contact there leaves what
  the particles do on the design untouched, and everything they do below it is lost;
- ``"value"``: a level given (``--level VALUE``).

Each rule also gives its neighbouring levels (`Region.neighbours`), which the command
reports beside the chosen one: how much of the C-space changes side.

The region is the set ``{phi < 0}`` of a level function ``phi`` on the surface's grid (``E_c - E``,
or the level set plus ``r_c``), drawn as polygons by
[`pes_ref.devices.contours.region_polygons`][pes_ref.devices.contours.region_polygons]. Nodes a
problem holds (its design mask is 0) are free.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pes_ref.core import checks
from pes_ref.core.surface import Surface, spacing as grid_spacing
from pes_ref.devices.cspace import apf_energy
from pes_ref.synthesis.common.resampling import resample

__all__ = ["Region", "contact_region", "CONTACT_RULES", "VISITED_QUANTILE", "VISITED_SEED"]

#: The ``"visited"`` rule's quantile of the energies the design's own particles reach.
VISITED_QUANTILE = 0.99
#: The seed of the paths the ``"visited"`` rule reads (the figures' seed; held-out seeds are others).
VISITED_SEED = 1
#: The ``"visited"`` rule's neighbouring quantiles.
VISITED_NEIGHBOURS = (0.95, 0.999)


@dataclass(frozen=True)
class Region:
    """The blocked region of a design at its contact level.

    Attributes
    ----------
    rule : str
        The rule that chose the level (`CONTACT_RULES`).
    level : float
        The contact level ``E_c`` (energy).
    phi : ndarray (n0, n1)
        The level function on the surface grid: blocked where ``phi < 0``.
    energy : ndarray (n0, n1)
        The design's surface (what the region is cut from).
    lower, upper, periodic
        The surface's domain.
    neighbours : tuple of (label, level, phi)
        The levels beside the chosen one and their level functions.
    """

    rule: str
    level: float
    phi: np.ndarray
    energy: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    periodic: tuple
    neighbours: tuple = ()

    @property
    def spacing(self) -> np.ndarray:
        """Node spacing of the surface grid ``phi`` lies on, shape (2,) (C-space length)."""
        return grid_spacing(self.lower, self.upper, self.phi.shape, np.asarray(self.periodic))

    @property
    def blocked_share(self) -> float:
        """The share of the grid's nodes that are blocked."""
        return float(np.mean(self.phi < 0))


# --------------------------------------------------------------------------- the rules

def _held(problem, shape) -> np.ndarray:
    return problem.mask(shape) == 0


def _spacing(problem, shape) -> np.ndarray:
    return grid_spacing(np.asarray(problem.lower, dtype=np.float64), np.asarray(problem.upper, dtype=np.float64),
                        shape, np.asarray(problem.periodic))


def _free_where_held(problem, phi: np.ndarray) -> np.ndarray:
    held = _held(problem, phi.shape)
    return np.where(held, np.maximum(phi, np.max(_spacing(problem, phi.shape))), phi)


def _level_set_rule(problem, values, energy, level):
    ls = problem.level_set
    if ls is None:
        raise checks.InputError("rule", "contact level 'level-set' needs a design made realizable (design ... "
                                        "--set realizable=true); this design's grid is its energy")
    fine = resample(values, problem.lower, problem.upper, problem.periodic, energy.shape)
    phi = fine + ls.r_c
    e_c = float(apf_energy(np.zeros(1), ls.v, ls.r_c, ls.r_min)[0])
    h = float(np.min(_spacing(problem, energy.shape)))
    return e_c, phi, (("phi - h/2", e_c, phi - 0.5 * h), ("phi + h/2", e_c, phi + 0.5 * h))


def _visited_rule(problem, values, energy, level):
    from pes_ref.realize.hooks import held_out_positions
    x = held_out_positions(problem, values, VISITED_SEED)
    surface = Surface(energy, problem.lower, problem.upper, problem.periodic)
    visited = surface.energy(x.reshape(-1, 2))
    e_c = float(np.quantile(visited, VISITED_QUANTILE))
    out = [(f"quantile {q:g}", float(np.quantile(visited, q))) for q in VISITED_NEIGHBOURS]
    return e_c, _free_where_held(problem, e_c - energy), tuple(
        (label, e, _free_where_held(problem, e - energy)) for label, e in out)


def _value_rule(problem, values, energy, level):
    if level is None:
        raise checks.InputError("level", "contact level 'value' needs the level itself: level is None")
    span = float(np.ptp(energy)) or 1.0
    out = [(f"level {s:+g} x range", level + s * span) for s in (-0.05, 0.05)]
    return level, _free_where_held(problem, level - energy), tuple(
        (label, e, _free_where_held(problem, e - energy)) for label, e in out)


#: The rules that choose the contact level: name -> rule(problem, values, energy, level) ->
#: (level, phi, neighbours) (module docstring).
CONTACT_RULES = {"level-set": _level_set_rule, "visited": _visited_rule, "value": _value_rule}


def contact_region(problem, values, rule: str | None = None, level: float | None = None) -> Region:
    """The blocked region of design ``values`` of ``problem`` by ``rule`` (default: ``"level-set"``
    for a design made realizable, else ``"visited"``; ``level`` is the ``"value"`` rule's)."""
    values = checks.as_float_array("values", values, ndim=2)
    if rule is None:
        rule = "level-set" if problem.level_set is not None else "visited"
    rule = checks.as_choice("rule", rule, set(CONTACT_RULES))
    if level is not None:
        level = checks.as_finite_float("level", level)
    energy = np.asarray(problem.surface_values(values), dtype=np.float64)
    e_c, phi, neighbours = CONTACT_RULES[rule](problem, values, energy, level)
    return Region(rule, float(e_c), phi, energy, np.asarray(problem.lower, dtype=np.float64),
                  np.asarray(problem.upper, dtype=np.float64), tuple(bool(p) for p in problem.periodic), neighbours)


