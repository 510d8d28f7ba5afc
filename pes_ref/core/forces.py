"""The conservative force of a scene's energy terms, and its adjoint.

``F(q) = -dU/dq`` with ``U = U_grid + U_spring + U_wall`` (SPEC section 2). A
:class:`Field` holds plain arrays for exactly the terms a scene has: ``spring`` and
``walls`` are ``None`` when the scene lacks them, and then nothing of theirs is ever
evaluated, in :func:`force` or in :func:`force_vjp`.

The grid term is reached through one dispatch point on ``Field.interpolation``:
:func:`_grid_force`, :func:`_grid_force_vjp` and :func:`_grid_energy` for single calls,
and :func:`grid_kernels` for the integrator's hot loop (:class:`ForceKernel` and
:class:`ForceAdjoint`, which hold per-surface tables and buffers for a whole run).
An interpolation without a fast kernel of its own runs the hot loop through the single
call functions (:class:`_PointwiseGrid`), slower but with the same numbers.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from pes_ref.core import bicubic
from pes_ref.core import bilinear
from pes_ref.core.surface import grid_energy, grid_slope_vjp_q, grid_slope_vjp_values, locate
from pes_ref.core.terms import (SpringKernel, WallKernel, spring_add_force, spring_energy, spring_force_vjp,
                    wall_add_force, wall_energy, wall_force_vjp)

__all__ = ["Field", "force", "force_vjp", "potential_energy", "GradAccumulator", "ForceKernel",
           "ForceAdjoint", "grid_kernels"]


class Field(NamedTuple):
    """Plain-array description of the energy terms (built by :class:`~pes_ref.core.scene.Scene`).

    ``values`` (n0, n1), ``lower``/``h``/``length`` (2,), ``periodic`` tuple of 2 bool;
    ``spring`` is ``(k, center)`` or None; ``walls`` is ``(k_w, lo, hi)`` or None
    (see :func:`pes_ref.core.terms.wall_bounds`); ``interpolation`` names the grid
    interpolation (``"bilinear"``, SPEC section 1).
    """

    values: np.ndarray
    lower: np.ndarray
    h: np.ndarray
    length: np.ndarray
    periodic: tuple
    spring: tuple | None
    walls: tuple | None
    interpolation: str = "bilinear"


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
    u = _grid_energy(field, x)
    if field.spring is not None:
        u = u + spring_energy(x, field.spring[0], field.spring[1], field.length, field.periodic)
    if field.walls is not None:
        u = u + wall_energy(x, *field.walls)
    return u


def force(field: Field, x: np.ndarray, out: np.ndarray) -> np.ndarray:
    """Write ``F(x) = -dU/dx`` into ``out`` (N, 2) and return it (eq. (A1), SPEC section 2)."""
    _grid_force(field, x, out)
    _terms_add_force(field, x, out)
    return out


def _terms_add_force(field: Field, x: np.ndarray, out: np.ndarray) -> None:
    """``out +=`` the spring and wall forces, each only if the field has it."""
    if field.spring is not None:
        spring_add_force(x, field.spring[0], field.spring[1], field.length, field.periodic, out)
    if field.walls is not None:
        wall_add_force(x, *field.walls, out)


def force_vjp(field: Field, x: np.ndarray, w: np.ndarray, xbar: np.ndarray, acc: GradAccumulator) -> None:
    """Adjoint of :func:`force` at ``x`` applied to the cotangent ``w`` (N, 2).

    Adds ``(dF/dx)^T w = -H_U(x) w`` into ``xbar`` and the parameter cotangents
    ``(dF/dG)^T w = -(d slope/dG)^T w`` and the spring's into ``acc``
    (``docs/adjoint.md`` eq. (A6), built from (A2)-(A5)).
    """
    _grid_force_vjp(field, x, w, xbar, acc.values)
    _terms_force_vjp(field, x, w, xbar, acc)


def _terms_force_vjp(field: Field, x, w, xbar, acc: GradAccumulator) -> None:
    """The spring's and walls' part of :func:`force_vjp` (eqs. (A4)-(A5)), each only if present."""
    if field.spring is not None:
        kbar, cbar = spring_force_vjp(x, field.spring[0], field.spring[1], field.length, field.periodic,
                                      w, xbar, acc.want_k, acc.want_center)
        if acc.want_k:
            acc.spring_k += kbar
        if acc.want_center:
            acc.spring_center += cbar
    if field.walls is not None:
        wall_force_vjp(x, *field.walls, w, xbar)


# =========================================================================== grid dispatch

def _unknown(field: Field):
    return ValueError(f"interpolation must be 'bilinear' or 'bicubic', got {field.interpolation!r}")


def _grid_energy(field: Field, x: np.ndarray) -> np.ndarray:
    """The grid's energy at points x (N, 2), shape (N,)."""
    if field.interpolation == "bilinear":
        return grid_energy(field.values, locate(x, field.lower, field.h, field.values.shape, field.periodic))
    if field.interpolation == "bicubic":      # docs/adjoint.md (C1)-(C2)
        return bicubic.point_energy(field.values, field.lower, field.h, field.periodic, x)
    raise _unknown(field)


def _grid_force(field: Field, x: np.ndarray, out: np.ndarray) -> None:
    """``out = -dU_grid/dx`` at points x (N, 2) (eq. (A1))."""
    if field.interpolation == "bilinear":
        bilinear.point_force(field.values, field.lower, field.h, field.periodic, x, out)
        return
    if field.interpolation == "bicubic":      # docs/adjoint.md (C3)
        bicubic.point_force(field.values, field.lower, field.h, field.periodic, x, out)
        return
    raise _unknown(field)


def _grid_force_vjp(field: Field, x: np.ndarray, w: np.ndarray, xbar: np.ndarray, gvalues) -> None:
    """``xbar += -H w`` and, if ``gvalues`` (flat n0*n1) is given, ``gvalues += (dF/dG)^T w``
    (eqs. (A2)-(A3))."""
    if field.interpolation == "bilinear":
        cells = locate(x, field.lower, field.h, field.values.shape, field.periodic)
        xbar -= grid_slope_vjp_q(field.values, field.h, cells, w)
        if gvalues is not None:
            gvalues -= grid_slope_vjp_values(field.h, cells, w, field.values.shape[1], field.values.size)
        return
    if field.interpolation == "bicubic":      # docs/adjoint.md (C4), (CB2)-(CB3)
        bicubic.point_force_vjp(field.values, field.lower, field.h, field.periodic, x, w, xbar, gvalues)
        return
    raise _unknown(field)


class _PointwiseGrid:
    """The hot loop's grid term through the single-call functions (no tables): what
    :func:`grid_kernels` can return, as ``(_PointwiseGrid, _PointwiseGrid)``, for an
    interpolation without kernels of its own (same numbers, slower).

    Built as the forward ``(field, n_particles)`` or as the adjoint
    ``(field, xs, want_values)``; ``xs`` (T+1, N, 2) is used by the adjoint only."""

    def __init__(self, field: Field, xs=None, want_values=False):
        self.field = field
        self.xs = xs if isinstance(xs, np.ndarray) else None
        self.gvalues = np.zeros(field.values.size) if want_values else None

    def __call__(self, x, out):
        _grid_force(self.field, x, out)
        return out

    def vjp(self, n, w, xbar):
        _grid_force_vjp(self.field, self.xs[n], w, xbar, self.gvalues)

    def values_grad(self):
        return self.gvalues


def grid_kernels(field: Field):
    """``(forward, adjoint)`` classes of the grid term for ``field.interpolation``.

    ``forward(field, n_particles)`` is a callable ``(x, out) -> out`` writing the grid
    force; ``adjoint(field, xs, want_values)`` has ``vjp(n, w, xbar)`` (called for
    states n in descending order) and ``values_grad()`` (flat n0*n1, or None).
    """
    if field.interpolation == "bilinear":
        return bilinear.forward_kernel, bilinear.BilinearAdjoint
    if field.interpolation == "bicubic":      # tables built once per run (pes_ref/bicubic.py)
        return bicubic.BicubicForce, bicubic.BicubicAdjoint
    raise _unknown(field)


# =========================================================================== the hot loop's force

def _term_kernels(field: Field, n_particles: int) -> tuple:
    """Buffered kernels of the spring and the walls, only for the terms the field has."""
    out = []
    if field.spring is not None:
        out.append(SpringKernel(field.spring[0], field.spring[1], field.length, field.periodic, n_particles))
    if field.walls is not None:
        out.append(WallKernel(*field.walls, n_particles))
    return tuple(out)


class ForceKernel:
    """``F(x) = -dU/dx`` for a fixed number of particles, tables and buffers built once
    (the integrator's forward loop). Same numbers as :func:`force`; the spring and wall
    terms are evaluated only when the field has them."""

    def __init__(self, field: Field, n_particles: int):
        self.grid = grid_kernels(field)[0](field, n_particles)
        self.terms = _term_kernels(field, n_particles)
        self.call = self._bind()

    def _bind(self):
        """``call(x, out)``: the force as one closure over the kernels' bound calls (a hot
        loop calls it instead of :meth:`__call__`, without the attribute lookups)."""
        grid = getattr(self.grid, "call", self.grid)
        adds = tuple(t.bind_add_force() if hasattr(t, "bind_add_force") else t.add_force for t in self.terms)
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

    def __call__(self, x: np.ndarray, out: np.ndarray) -> np.ndarray:
        return self.call(x, out)


class ForceAdjoint:
    """The adjoint of :class:`ForceKernel` over stored states ``xs`` (T+1, N, 2).

    ``vjp(n, w, xbar)`` for states in descending order adds ``(dF/dx)^T w`` at ``xs[n]``
    into ``xbar`` and accumulates the wanted parameter gradients (``values``,
    ``spring_k``, ``spring_center``), returned by :meth:`result` (eq. (A6)).
    """

    def __init__(self, field: Field, xs: np.ndarray, want: frozenset):
        self.xs = xs
        self.acc = GradAccumulator(field, xs.shape[1], want - {"values"})
        self.want_values = "values" in want
        self.grid = grid_kernels(field)[1](field, xs, self.want_values)
        self.spring = self.walls = None
        for term in _term_kernels(field, xs.shape[1]):
            if isinstance(term, SpringKernel):
                self.spring = term
            else:
                self.walls = term
        self.call = self._bind()

    def _bind(self):
        """``call(n, w, xbar)``: :meth:`vjp` as a closure over the kernels' bound calls
        (the grid's and the walls' alone when the field has no spring)."""
        grid = getattr(self.grid, "call", self.grid.vjp)
        if self.spring is not None:
            return self.vjp
        if self.walls is None:
            return grid
        walls = self.walls.bind_force_vjp(self.xs)

        def call(n, w, xbar):
            grid(n, w, xbar)
            walls(n, w, xbar)
        return call

    def vjp(self, n: int, w: np.ndarray, xbar: np.ndarray) -> None:
        self.grid.vjp(n, w, xbar)
        if self.spring is not None:
            acc = self.acc
            kbar, cbar = self.spring.force_vjp(self.xs[n], w, xbar, acc.want_k, acc.want_center)
            if acc.want_k:
                acc.spring_k += kbar
            if acc.want_center:
                acc.spring_center += cbar
        if self.walls is not None:
            self.walls.force_vjp(self.xs[n], w, xbar)

    def result(self) -> dict:
        """The accumulated parameter gradients that were wanted."""
        out = {}
        if self.want_values:
            out["values"] = self.grid.values_grad()
        if self.acc.want_k:
            out["spring_k"] = self.acc.spring_k
        if self.acc.want_center:
            out["spring_center"] = self.acc.spring_center
        return out
