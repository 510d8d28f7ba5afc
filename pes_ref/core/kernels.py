"""The hot loop's kernel interfaces: what a forward or adjoint kernel of a force term provides.

A kernel holds one term's tables and buffers for a whole run and is called once per
step, so it has exactly one way to be called: a callable attribute, usually a closure
that the kernel binds once in ``__init__`` over its buffers (no attribute lookups per
step; ``docs/performance.md``). The integrator's loops bind that attribute to a local.

- [`GridForce`][pes_ref.core.kernels.GridForce], [`GridAdjoint`][pes_ref.core.kernels.GridAdjoint]: the grid term, one
  pair per interpolation
  (`pes_ref.core.interpolations.INTERPOLATIONS`).
- [`TermForce`][pes_ref.core.kernels.TermForce], [`TermAdjoint`][pes_ref.core.kernels.TermAdjoint]: a spring or the
  walls
  ([`pes_ref.core.terms`][pes_ref.core.terms]).

[`pes_ref.core.forces.ForceKernel`][pes_ref.core.forces.ForceKernel] and
[`pes_ref.core.forces.ForceAdjoint`][pes_ref.core.forces.ForceAdjoint]
chain them for exactly the terms a scene has, and are called the same way: ``call(x,
out)`` and ``vjp(n, w, xbar)``.
"""
from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["GridForce", "GridAdjoint", "TermForce", "TermAdjoint"]


@runtime_checkable
class GridForce(Protocol):
    """The grid force for a fixed number of particles, built as ``forward(field, n_particles)``."""

    def call(self, x: np.ndarray, out: np.ndarray) -> np.ndarray:
        """Write the grid force ``-dE/dx`` at ``x`` (N, 2) into ``out`` (N, 2) and return it."""


@runtime_checkable
class GridAdjoint(Protocol):
    """The adjoint of a [`GridForce`][pes_ref.core.kernels.GridForce] over stored states ``xs`` (T+1, N, 2), built as
    ``adjoint(field, xs, want_values)``."""

    def vjp(self, n: int, w: np.ndarray, xbar: np.ndarray) -> None:
        """``xbar += (dF/dx)^T w`` at state ``xs[n]``; called for states in descending order.
        Records ``w`` for the grid gradient when it is wanted."""

    def values_grad(self) -> np.ndarray | None:
        """The accumulated ``sum_n (dF(x_n)/dG)^T w_n``, flat (n0*n1,), or None if not wanted."""


@runtime_checkable
class TermForce(Protocol):
    """A spring's or the walls' force for a fixed number of particles."""

    def add_force(self, q: np.ndarray, out: np.ndarray) -> None:
        """``out +=`` the term's force at ``q`` (N, 2)."""


@runtime_checkable
class TermAdjoint(Protocol):
    """The adjoint of a [`TermForce`][pes_ref.core.kernels.TermForce] over stored states ``xs`` (T+1, N, 2)."""

    def force_vjp(self, n: int, w: np.ndarray, xbar: np.ndarray) -> None:
        """``xbar += (dF/dx)^T w`` at state ``xs[n]`` and the wanted parameter cotangents
        accumulated; called for states in descending order."""

    def gradients(self) -> dict:
        """The accumulated parameter gradients that were wanted (name -> array)."""
