"""Kinks: where a run's force is not smooth, so that a finite difference across it is no
derivative.

The discrete program is piecewise smooth: the bilinear slope jumps at cell edges (including the clip
edges of a non-periodic axis, where the constant extension begins), a wall's force has a kink at its
onset, and a spring on a periodic axis jumps at its minimum-image seam.
[`kink_distance`][pes_ref.testing.kinks.kink_distance] measures how close a trajectory passes to any
kink (for a cheap ``assume`` before a gradient check);
[`kink_signature`][pes_ref.testing.kinks.kink_signature] records which smooth piece every state is
in, and
[`pes_ref.testing.gradient_check.check_gradient_fd`][pes_ref.testing.gradient_check.check_gradient_fd]
compares it between the base and every perturbed run, so it knows exactly when a difference crossed
a kink.
"""
from __future__ import annotations

import numpy as np

from pes_ref.core.scene import Scene
from pes_ref.core.terms import wall_bounds

__all__ = ["kink_distance", "distance_to_kinks", "kink_signature"]


def _axis_arrays(scene: Scene, x: np.ndarray):
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 2:
        x = x[None]
    return x, x.shape[-2]


def kink_distance(scene: Scene, x, *, grid: bool = True) -> float:
    """The smallest distance from any position in ``x`` to a kink of the scene's force.

    Parameters
    ----------
    scene : Scene
    x : array_like, shape (T+1, N, 2) or (N, 2)
        Positions (unwrapped), e.g. ``traj.x``.
    grid : bool
        Count the grid's cell edges (every node line, and the clip edges where a
        non-periodic axis's constant extension begins). Leave True for gradient
        checks: on a constant grid the lines are not kinks of the force, but they are
        of its derivative with respect to the grid values.

    Returns
    -------
    float
        [`distance_to_kinks`][pes_ref.testing.kinks.distance_to_kinks] of the scene's grid, walls and spring.
    """
    s = scene.surface
    walls = None if scene.walls is None else wall_bounds(s.lower, s.upper, scene.walls.margin, scene.walls.edges)
    spring = None if scene.spring is None else (scene.spring.k, scene.spring.center)
    return distance_to_kinks(x, s.lower, s.spacing, s.shape, s.periodic, s.length,
                             walls=walls, spring=spring, grid=grid)


def distance_to_kinks(x, lower, h, shape, periodic, length, *, walls=None, spring=None,
                      grid: bool = True) -> float:
    """The smallest distance from any position in ``x`` to a kink of a force, given as
    plain arrays ([`kink_distance`][pes_ref.testing.kinks.kink_distance] takes them from a scene; the unit tests of the
    force kernels from their plain-array description).

    Parameters
    ----------
    x : array_like, shape (..., N, 2)
        Positions (unwrapped).
    lower, h, length : array_like (2,)
        The grid's lower corner, node spacing and domain length.
    shape : (n0, n1)
        The grid's shape.
    periodic : sequence of 2 bool
    walls : (lo, hi) of arrays (2,), optional
        The wall positions, ``-inf``/``inf`` where an axis has none
        ([`pes_ref.core.terms.wall_bounds`][pes_ref.core.terms.wall_bounds]).
    spring : (k, center), optional
        Broadcastable to (N, 2); a seam counts on a periodic axis where ``k_d != 0``.
    grid : bool
        Count the grid's cell edges (see [`kink_distance`][pes_ref.testing.kinks.kink_distance]).

    Returns
    -------
    float
        Distance in position units, per axis (the kinks are lines ``q_d = const``):
        cell edges, wall onsets ``a_d``/``b_d``, and the minimum-image seam
        ``c_d + L_d/2 (mod L_d)`` of a spring with ``k_d != 0`` on a periodic axis.
        ``inf`` when there is none.
    """
    x = np.asarray(x, dtype=np.float64)
    N = x.shape[-2]
    best = np.inf
    for d in range(2):
        q = x[..., d]
        if grid:
            u = (q - lower[d]) / h[d]
            if periodic[d]:
                fr = u - np.floor(u)
                dist = h[d] * np.minimum(fr, 1.0 - fr)
            else:
                uc = np.clip(u, 0.0, shape[d] - 1.0)
                fr = uc - np.floor(uc)
                dist = np.where(u != uc, np.abs(u - uc), np.minimum(fr, 1.0 - fr)) * h[d]
            best = min(best, float(dist.min()))
        if walls is not None:
            for b in (walls[0][d], walls[1][d]):
                if np.isfinite(b):
                    best = min(best, float(np.abs(q - b).min()))
        if spring is not None and periodic[d]:
            k = np.broadcast_to(spring[0], (N, 2))[:, d]
            if np.any(k != 0):
                c = np.broadcast_to(spring[1], (N, 2))[:, d]
                L = length[d]
                w = (q - c + 0.5 * L) / L
                fr = w - np.floor(w)
                dist = L * np.minimum(fr, 1.0 - fr)
                best = min(best, float(dist[..., k != 0].min()))
    return best


def kink_signature(scene: Scene, x) -> np.ndarray:
    """Which smooth piece of the force every position is in, shape (..., N, 2, 4) int.

    Per axis: the grid cell (``floor`` of the unwrapped cell coordinate on a periodic
    axis; on a non-periodic one -1 below the span, ``n_d - 1`` above it, else the cell
    ``min(floor(u), n_d - 2)``), whether the lower and the upper wall push, and on a
    periodic axis with a spring the minimum-image branch ``floor((q - c + L/2) / L)``.
    Two runs with equal signatures at every state went through the same polynomial
    pieces, so a finite difference between them is a true derivative.
    """
    x, N = _axis_arrays(scene, x)
    s = scene.surface
    h = s.spacing
    sig = np.zeros(x.shape + (4,), dtype=np.int64)
    for d in range(2):
        q = x[..., d]
        u = (q - s.lower[d]) / h[d]
        if s.periodic[d]:
            sig[..., d, 0] = np.floor(u)
        else:
            n = s.shape[d]
            cell = np.minimum(np.floor(np.clip(u, 0.0, n - 1.0)), n - 2)
            sig[..., d, 0] = np.where(u < 0, -1, np.where(u > n - 1, n - 1, cell))
        if scene.walls is not None:
            if scene.walls.edges[d, 0]:
                sig[..., d, 1] = q < s.lower[d] + scene.walls.margin
            if scene.walls.edges[d, 1]:
                sig[..., d, 2] = q > s.upper[d] - scene.walls.margin
        if scene.spring is not None and s.periodic[d]:
            c = np.broadcast_to(scene.spring.center, (N, 2))[:, d]
            L = s.length[d]
            sig[..., d, 3] = np.floor((q - c + 0.5 * L) / L)
    return sig
