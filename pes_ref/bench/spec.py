"""The contract's dynamic run and loss written once over a NumPy-like module, for the benchmark.

The benchmark compares pes_ref's hand-derived adjoint with automatic differentiation of
the same computation, written as directly as docs/spec.md states it (sections 2-6): a
bilinear lookup per step, the damped Verlet step of eqs. (2)-(3), springs, walls, the
realized external force and the objectives of eqs. (5)-(6). [`step_fn`][pes_ref.bench.spec.step_fn] and
[`state_loss_fn`][pes_ref.bench.spec.state_loss_fn] take the array module ``xp`` (``autograd.numpy`` or
``jax.numpy``); [`pes_ref.bench.with_autograd`][pes_ref.bench.with_autograd] drives them with a Python loop,
[`pes_ref.bench.with_jax`][pes_ref.bench.with_jax] with ``jax.lax.scan`` under ``jax.jit``. Neither library is
imported here, and neither is a dependency of pes_ref.
"""
from __future__ import annotations

import numpy as np

from pes_ref.bench.cases import DesignCase

__all__ = ["step_fn", "state_loss_fn", "constants"]

#: Stand-in for an absent wall: finite, so that max(lo - q, 0) has a clean derivative.
NO_WALL = 1e300


def constants(case: DesignCase) -> dict:
    """Plain-array constants of the case (NumPy float64)."""
    lo, hi = case.wall_bounds()
    dt = case.dt
    return dict(lower=case.lower, h=case.h, n=case.values.shape, periodic=case.periodic,
                length=case.upper - case.lower, a=dt / (2.0 * case.mass), c=dt * case.damping / (2.0 * case.mass),
                wall_lo=np.where(np.isfinite(lo), lo, -NO_WALL), wall_hi=np.where(np.isfinite(hi), hi, NO_WALL),
                wall_k=case.wall_k, spring_k=case.spring_k, spring_center=case.spring_center, dt=dt)


def _grid_force(xp, values, x, k, plain):
    """-dE/dx of the bilinear surface (docs/spec.md section 2) at x (N, 2); ``plain`` strips
    autodiff wrappers for the integer cell indices."""
    idx, frac, inside = [], [], []
    for d in range(2):
        n = k["n"][d]
        u = (x[:, d] - k["lower"][d]) / k["h"][d]
        if k["periodic"][d]:
            cell = xp.floor(plain(u))
            f = u - cell
            i0 = xp.mod(cell, n).astype(np.int64)
            i1 = xp.mod(i0 + 1, n)
            s = 1.0
        else:
            uc = xp.clip(u, 0.0, n - 1.0)
            i0 = xp.minimum(xp.floor(plain(uc)), n - 2.0).astype(np.int64)
            f = uc - i0
            i1 = i0 + 1
            s = xp.where((plain(u) >= 0.0) & (plain(u) <= n - 1.0), 1.0, 0.0)
        idx.append((i0, i1))
        frac.append(f)
        inside.append(s)
    (i0, i1), (j0, j1) = idx
    f0, f1 = frac
    g00, g10, g01, g11 = values[i0, j0], values[i1, j0], values[i0, j1], values[i1, j1]
    h = k["h"]
    slope0 = inside[0] / h[0] * ((1 - f1) * (g10 - g00) + f1 * (g11 - g01))
    slope1 = inside[1] / h[1] * ((1 - f0) * (g01 - g00) + f0 * (g11 - g10))
    return -xp.stack([slope0, slope1], axis=1)


def _force(xp, values, x, k, plain):
    """F = -dU/dx: grid, spring (minimum image on a periodic axis) and walls (docs/spec.md section 3)."""
    F = _grid_force(xp, values, x, k, plain)
    if k["spring_k"] is not None:
        cols = []
        for d in range(2):
            delta = x[:, d] - k["spring_center"][:, d]
            if k["periodic"][d]:
                L = k["length"][d]
                delta = xp.mod(delta + 0.5 * L, L) - 0.5 * L
            cols.append(delta)
        F = F - k["spring_k"] * xp.stack(cols, axis=1)
    F = F + k["wall_k"] * (xp.maximum(k["wall_lo"] - x, 0.0) - xp.maximum(x - k["wall_hi"], 0.0))
    return F


def step_fn(xp, case: DesignCase, plain=lambda a: a):
    """``(force, step)``: ``force(values, x) -> F(x)`` and
    ``step(values, x, v, f, fext_next) -> (x1, v1, f1)``, the damped Verlet step of
    docs/spec.md section 5 (``X1 = X + dt (V + a F)``, ``V1 = (V + a F - c V + a F1) / (1 + c)``)."""
    k = constants(case)
    a, c, dt = k["a"], k["c"], k["dt"]

    def force(values, x):
        return _force(xp, values, x, k, plain)

    def step(values, x, v, f, fext_next):
        p = v + a * f
        x1 = x + dt * p
        f1 = force(values, x1) + fext_next
        v1 = (p - c * v + a * f1) / (1.0 + c)
        return x1, v1, f1

    return force, step


def state_loss_fn(xp, case: DesignCase):
    """``l(x, v, t)``: one state's term of the objective (docs/spec.md section 6)."""
    kind = case.objective[0]
    n_particles = case.x0.shape[0]
    if kind == "funnel":
        target = case.objective[1]

        def loss(x, v, t):
            e = x[:, 0] - target
            return xp.sum(e * e)
    else:
        A, w = case.objective[1], case.objective[2]

        def loss(x, v, t):
            ex = x[:, 0] - A * xp.cos(w * t)
            ev = v[:, 0] + A * w * xp.sin(w * t)
            return xp.sqrt(xp.sum(ex * ex + ev * ev)) / n_particles ** 2
    return loss
