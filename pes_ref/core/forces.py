"""The conservative force of a scene's energy terms, and its adjoint.

``F(q) = -dU/dq`` with ``U = U_grid + U_spring + U_wall`` (docs/spec.md section 3). A
[`Field`][pes_ref.core.forces.Field] holds plain arrays for exactly the terms a scene has: ``spring`` and
``walls`` are ``None`` when the scene lacks them, and then nothing of theirs is ever
evaluated or built, in [`force`][pes_ref.core.forces.force], [`force_vjp`][pes_ref.core.forces.force_vjp] or the hot
loop's kernels.

The grid term is reached through the interpolation registry
([`pes_ref.core.interpolations.interpolation`][pes_ref.core.interpolations.interpolation] of ``Field.interpolation``):
its point
functions for single calls ([`force`][pes_ref.core.forces.force], [`force_vjp`][pes_ref.core.forces.force_vjp],
[`potential_energy`][pes_ref.core.forces.potential_energy]),
its kernels for the integrator's loops. [`ForceKernel`][pes_ref.core.forces.ForceKernel] and
[`ForceAdjoint`][pes_ref.core.forces.ForceAdjoint]
chain the grid's kernel with the spring's and the walls' ([`pes_ref.core.terms`][pes_ref.core.terms]),
each holding its tables and buffers for a whole run ([`pes_ref.core.kernels`][pes_ref.core.kernels]).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from pes_ref.core.interpolations import interpolation
from pes_ref.core.terms import (SpringAdjoint, SpringKernel, WallAdjoint, WallKernel, spring_add_force, spring_axes,
                                spring_energy, spring_force_vjp, wall_add_force, wall_energy, wall_force_vjp)

__all__ = ["Field", "force", "force_vjp", "potential_energy", "GradAccumulator", "ForceKernel",
           "ForceAdjoint"]


class Field(NamedTuple):
    """Plain-array description of the energy terms (built by [`Scene`][pes_ref.core.scene.Scene]).

    ``values`` (n0, n1), ``lower``/``h``/``length`` (2,), ``periodic`` tuple of 2 bool;
    ``spring`` is ``(k, center)`` or None; ``walls`` is ``(k_w, lo, hi)`` or None
    (see [`pes_ref.core.terms.wall_bounds`][pes_ref.core.terms.wall_bounds]; ``k_w``, ``lo``, ``hi`` broadcastable to
    (N, 2)); ``interpolation`` names the grid interpolation (a key of
    `pes_ref.core.interpolations.INTERPOLATIONS`; ``"bilinear"`` is docs/spec.md
    section 2).

    A population ([`pes_ref.core.population`][pes_ref.core.population]) runs many grids of one shape at once:
    ``values`` is then a stack (K, n0, n1) and ``offsets`` (N,) intp holds each particle's
    grid as the row offset ``c n0 n1`` of grid ``c`` in the stacked per-cell tables
    ([`pes_ref.core.grid.stacked_table`][pes_ref.core.grid.stacked_table]), added to the cell index after the lookup;
    None for a single grid. Only the forward kernels take a population.
    """

    values: np.ndarray
    lower: np.ndarray
    h: np.ndarray
    length: np.ndarray
    periodic: tuple
    spring: tuple | None
    walls: tuple | None
    interpolation: str = "bilinear"
    offsets: np.ndarray | None = None


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
    u = interpolation(field.interpolation).point_energy(field.values, field.lower, field.h, field.periodic, x)
    if field.spring is not None:
        u = u + spring_energy(x, field.spring[0], field.spring[1], field.length, field.periodic)
    if field.walls is not None:
        u = u + wall_energy(x, *field.walls)
    return u


def force(field: Field, x: np.ndarray, out: np.ndarray) -> np.ndarray:
    """Write ``F(x) = -dU/dx`` into ``out`` (N, 2) and return it (eq. (A1), docs/spec.md section 3)."""
    interpolation(field.interpolation).point_force(field.values, field.lower, field.h, field.periodic, x, out)
    _terms_add_force(field, x, out)
    return out


def _terms_add_force(field: Field, x: np.ndarray, out: np.ndarray) -> None:
    """``out +=`` the spring and wall forces, each only if the field has it."""
    if field.spring is not None:
        spring_add_force(x, field.spring[0], field.spring[1], field.length, field.periodic, out)
    if field.walls is not None:
        wall_add_force(x, *field.walls, out)


def force_vjp(field: Field, x: np.ndarray, w: np.ndarray, xbar: np.ndarray, acc: GradAccumulator) -> None:
    """Adjoint of [`force`][pes_ref.core.forces.force] at ``x`` applied to the cotangent ``w`` (N, 2).

    Adds ``(dF/dx)^T w = -H_U(x) w`` into ``xbar`` and the parameter cotangents
    ``(dF/dG)^T w = -(d slope/dG)^T w`` and the spring's into ``acc``
    (``docs/adjoint.md`` eq. (A6), built from (A2)-(A5)).
    """
    interpolation(field.interpolation).point_force_vjp(field.values, field.lower, field.h, field.periodic, x, w,
                                                       xbar, acc.values)
    _terms_force_vjp(field, x, w, xbar, acc)


def _terms_force_vjp(field: Field, x, w, xbar, acc: GradAccumulator) -> None:
    """The spring's and walls' part of [`force_vjp`][pes_ref.core.forces.force_vjp] (eqs. (A4)-(A5)), each only if present."""
    if field.spring is not None:
        kbar, cbar = spring_force_vjp(x, field.spring[0], field.spring[1], field.length, field.periodic,
                                      w, xbar, acc.want_k, acc.want_center)
        if acc.want_k:
            acc.spring_k += kbar
        if acc.want_center:
            acc.spring_center += cbar
    if field.walls is not None:
        wall_force_vjp(x, *field.walls, w, xbar)


# =========================================================================== the hot loop's force

def _term_kernels(field: Field, n_particles: int) -> tuple:
    """Forward kernels of the spring and the walls, only for the terms the field has (a
    spring whose ``k`` is 0 on both axes has no force: ``out -= 0 delta`` changes no value)."""
    out = []
    if field.spring is not None and spring_axes(field.spring[0]):
        out.append(SpringKernel(field.spring[0], field.spring[1], field.length, field.periodic, n_particles))
    if field.walls is not None:
        out.append(WallKernel(*field.walls, n_particles))
    return tuple(out)


def _term_adjoints(field: Field, xs: np.ndarray, want: frozenset) -> tuple:
    """Adjoint kernels of the spring and the walls, only for the terms the field has (a
    spring with ``k`` 0 everywhere only when its gradients are wanted)."""
    out = []
    if field.spring is not None and (spring_axes(field.spring[0]) or {"spring_k", "spring_center"} & want):
        out.append(SpringAdjoint(field.spring[0], field.spring[1], field.length, field.periodic, xs,
                                 "spring_k" in want, "spring_center" in want))
    if field.walls is not None:
        out.append(WallAdjoint(*field.walls, xs))
    return tuple(out)


def _chain_forward(grid, adds: tuple):
    """``call(x, out)``: ``grid(x, out)`` then each of ``adds`` (``grid`` itself when there
    are none: no extra call in the hot loop)."""
    if not adds:
        return grid
    if len(adds) == 1:
        add0 = adds[0]

        def call(x, out):
            grid(x, out)
            add0(x, out)
            return out
        return call

    def call(x, out):
        grid(x, out)
        for add in adds:
            add(x, out)
        return out
    return call


def _chain_adjoint(grid, vjps: tuple):
    """``vjp(n, w, xbar)``: ``grid(n, w, xbar)`` then each of ``vjps`` (``grid`` itself when
    there are none)."""
    if not vjps:
        return grid
    if len(vjps) == 1:
        vjp0 = vjps[0]

        def vjp(n, w, xbar):
            grid(n, w, xbar)
            vjp0(n, w, xbar)
        return vjp

    def vjp(n, w, xbar):
        grid(n, w, xbar)
        for term in vjps:
            term(n, w, xbar)
    return vjp


class ForceKernel:
    """``F(x) = -dU/dx`` for a fixed number of particles, tables and buffers built once
    (the integrator's forward loop). Same numbers as [`force`][pes_ref.core.forces.force]; the spring and wall
    kernels are built only when the field has the term.

    ``call(x, out) -> out``, bound once here: the grid kernel's call (the interpolation's
    [`GridForce`][pes_ref.core.kernels.GridForce]), then each term's ``add_force``.
    """

    def __init__(self, field: Field, n_particles: int):
        self.grid = interpolation(field.interpolation).forward(field, n_particles)
        self.terms = _term_kernels(field, n_particles)
        self.call = _chain_forward(self.grid.call, tuple(t.add_force for t in self.terms))


class ForceAdjoint:
    """The adjoint of [`ForceKernel`][pes_ref.core.forces.ForceKernel] over stored states ``xs`` (T+1, N, 2) (eq. (A6)).

    ``vjp(n, w, xbar)``, bound once here, for states in descending order: adds
    ``(dF/dx)^T w`` at ``xs[n]`` into ``xbar`` (the grid's
    [`GridAdjoint`][pes_ref.core.kernels.GridAdjoint], then each term's
    [`TermAdjoint`][pes_ref.core.kernels.TermAdjoint]) and accumulates the wanted parameter
    gradients (``values``, ``spring_k``, ``spring_center``), returned by
    [`result`][pes_ref.core.forces.ForceAdjoint.result].
    """

    def __init__(self, field: Field, xs: np.ndarray, want: frozenset):
        self.want_values = "values" in want
        self.grid = interpolation(field.interpolation).adjoint(field, xs, self.want_values)
        self.terms = _term_adjoints(field, xs, want)
        self.vjp = _chain_adjoint(self.grid.vjp, tuple(t.force_vjp for t in self.terms))

    def result(self) -> dict:
        """The accumulated parameter gradients that were wanted."""
        out = {}
        if self.want_values:
            out["values"] = self.grid.values_grad()
        for term in self.terms:
            out.update(term.gradients())
        return out
