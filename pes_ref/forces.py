"""The conservative force of a scene's energy terms, and its adjoint.

``F(q) = -dU/dq`` with ``U = U_grid + U_spring + U_wall`` (SPEC section 2). A
:class:`Field` holds plain arrays for exactly the terms a scene has: ``spring`` and
``walls`` are ``None`` when the scene lacks them, and then nothing of theirs is ever
evaluated, in :func:`force` or in :func:`force_vjp`.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .surface import grid_energy, grid_slope, grid_slope_vjp_q, grid_slope_vjp_values, locate
from .terms import (spring_add_force, spring_energy, spring_force_vjp, wall_add_force,
                    wall_energy, wall_force_vjp)

__all__ = ["Field", "force", "force_vjp", "potential_energy", "GradAccumulator"]


class Field(NamedTuple):
    """Plain-array description of the energy terms (built by :class:`~pes_ref.scene.Scene`).

    ``values`` (n0, n1), ``lower``/``h``/``length`` (2,), ``periodic`` tuple of 2 bool;
    ``spring`` is ``(k, center)`` or None; ``walls`` is ``(k_w, lo, hi)`` or None
    (see :func:`pes_ref.terms.wall_bounds`).
    """

    values: np.ndarray
    lower: np.ndarray
    h: np.ndarray
    length: np.ndarray
    periodic: tuple
    spring: tuple | None
    walls: tuple | None


class GradAccumulator:
    """Running sums of the parameter gradients that the force's adjoint produces.

    Only the wanted ones are allocated and accumulated: ``values`` as a flat
    (n0*n1,) array, ``spring_k`` and ``spring_center`` as (N, 2) arrays.
    """

    def __init__(self, field: Field, n_particles: int, want: frozenset):
        self.want_values = "values" in want
        self.want_k = "spring_k" in want and field.spring is not None
        self.want_center = "spring_center" in want and field.spring is not None
        self.values = np.zeros(field.values.size) if self.want_values else None
        self.spring_k = np.zeros((n_particles, 2)) if self.want_k else None
        self.spring_center = np.zeros((n_particles, 2)) if self.want_center else None


def potential_energy(field: Field, x: np.ndarray) -> np.ndarray:
    """U(x) per point, shape (N,), for x of shape (N, 2)."""
    u = grid_energy(field.values, locate(x, field.lower, field.h, field.values.shape, field.periodic))
    if field.spring is not None:
        u = u + spring_energy(x, field.spring[0], field.spring[1], field.length, field.periodic)
    if field.walls is not None:
        u = u + wall_energy(x, *field.walls)
    return u


def force(field: Field, x: np.ndarray, out: np.ndarray) -> np.ndarray:
    """Write ``F(x) = -dU/dx`` into ``out`` (N, 2) and return it (eq. (A1), SPEC section 2)."""
    cells = locate(x, field.lower, field.h, field.values.shape, field.periodic)
    grid_slope(field.values, field.h, cells, out=out)
    np.negative(out, out=out)
    if field.spring is not None:
        spring_add_force(x, field.spring[0], field.spring[1], field.length, field.periodic, out)
    if field.walls is not None:
        wall_add_force(x, *field.walls, out)
    return out


def force_vjp(field: Field, x: np.ndarray, w: np.ndarray, xbar: np.ndarray, acc: GradAccumulator) -> None:
    """Adjoint of :func:`force` at ``x`` applied to the cotangent ``w`` (N, 2).

    Adds ``(dF/dx)^T w = -H_U(x) w`` into ``xbar`` and the parameter cotangents
    ``(dF/dG)^T w = -(d slope/dG)^T w`` and the spring's into ``acc``
    (``docs/adjoint.md`` eq. (A6), built from (A2)-(A5)).
    """
    cells = locate(x, field.lower, field.h, field.values.shape, field.periodic)
    xbar -= grid_slope_vjp_q(field.values, field.h, cells, w)
    if acc.want_values:
        acc.values -= grid_slope_vjp_values(field.h, cells, w, field.values.shape[1], field.values.size)
    if field.spring is not None:
        kbar, cbar = spring_force_vjp(x, field.spring[0], field.spring[1], field.length, field.periodic,
                                      w, xbar, acc.want_k, acc.want_center)
        if acc.want_k:
            acc.spring_k += kbar
        if acc.want_center:
            acc.spring_center += cbar
    if field.walls is not None:
        wall_force_vjp(x, *field.walls, w, xbar)
