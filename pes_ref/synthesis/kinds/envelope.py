"""A realizable funnel's start made by design: the convex envelope of a smooth funnel's paths.

A level set moves only its contour ([`pes_ref.synthesis.common.level_set`][pes_ref.synthesis.common.level_set]), so from two thin side
strips gradient descent cannot grow the funnel's walls 0.8 inward (``docs/realize.md``). The
``"envelope"`` start (``init_shape`` of
[`pes_ref.synthesis.kinds.funnel.FunnelProblem`][pes_ref.synthesis.kinds.funnel.FunnelProblem]) is a
shape no one draws, made in four steps from the problem itself:

1. **a smooth funnel**: the same problem with ``realizable`` off, designed by the funnel's
   default plan (`pes_ref.synthesis.common.plans.FUNNEL_PLAN`, the run of ``design funnel``;
   [`smooth_funnel`][pes_ref.synthesis.kinds.envelope.smooth_funnel]);
2. **its paths' envelope**: `ENVELOPE_PARTICLES` of its particles (the training sampler),
   of which those that exit in the band; on every grid row of q1 the q0 range their states
   cover, trimmed by the quantile `ENVELOPE_TRIM` at each end
   ([`path_envelope`][pes_ref.synthesis.kinds.envelope.path_envelope]);
3. **convex walls**: each side's edge replaced by its hull ([`convex_walls`][pes_ref.synthesis.kinds.envelope.convex_walls]:
the left edge
   by its convex minorant in q1, the right by its concave majorant), so the free region is one
   convex channel with no pocket to hold a particle;
4. **the feet in the band**: each wall moved along q0 until its foot, where it meets the exit
   edge, is `FOOT_INSET` inside the band's edge
   ([`feet_in_band`][pes_ref.synthesis.kinds.envelope.feet_in_band]). A particle that slides down a
   rigid wall leaves at its foot (eq. (1) holds it off the wall, a rigid wall does not), so a foot
   outside the band sends every particle that touched that wall out of it; a foot far inside makes a
   narrow exit that particles reach late.

The blocked region is everything outside that channel
([`interval_distance`][pes_ref.synthesis.kinds.envelope.interval_distance]). A design that starts
from it finishes with [`convex_channel`][pes_ref.synthesis.kinds.envelope.convex_channel]: the level
set's free channel after the gradient stage, made convex with its feet in the band again (gradient
steps notch a level set's walls, and a rigid pin stops in the notches).
"""
from __future__ import annotations

import numpy as np

from pes_ref.core.scene import simulate, value_and_grad
from pes_ref.synthesis.common.exits import exit_steps
from pes_ref.synthesis.common.plans import FUNNEL_PLAN
from pes_ref.synthesis.common.validation import on_grid

__all__ = ["ENVELOPE_PARTICLES", "ENVELOPE_TRIM", "FOOT_INSET", "smooth_funnel", "path_envelope", "convex_walls",
           "feet_in_band", "interval_distance", "envelope_start", "convex_channel"]

#: Particles of the smooth funnel whose paths make the envelope.
ENVELOPE_PARTICLES = 1000
#: The share of a row's states left out at each end of its q0 range (a few stray paths).
ENVELOPE_TRIM = 0.005
#: How far inside the band's edge each wall's foot is put (C-space length; chosen by the rigid
#: score on seed 1, docs/realize.md).
FOOT_INSET = 0.02


def smooth_funnel(problem, seed: int, plan=FUNNEL_PLAN, backend: str | None = None) -> np.ndarray:
    """The grid of ``problem`` (a funnel with ``realizable`` off) designed by ``plan`` from run seed
    ``seed``: the iterations of
    [`pes_ref.synthesis.engine.training.run_design`][pes_ref.synthesis.engine.training.run_design]
    (its particles ``default_rng([seed, k])``, initial draw ``default_rng([seed, 2**32])``, the
    stages' resampling and the optimizer's reset), for a plan without validation or smoothing: the
    grid ``design funnel --seed SEED`` writes for the same problem."""
    if plan.validate_every or plan.smoothing:
        raise ValueError("smooth_funnel runs a plan without validation or smoothing")
    values = problem.initial_values(np.random.default_rng([seed, 2 ** 32]), plan.grid_at(0, problem))
    opt = plan.make_optimizer()
    for k in range(plan.iterations):
        shape = plan.grid_at(k, problem)
        if values.shape != shape:
            values = on_grid(problem, values, shape)
            opt.reset()
        batch = problem.batch(values, np.random.default_rng([seed, k]), plan.n_particles, plan.steps_at(k))
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            _, grads, _ = value_and_grad(batch.scene, batch.x0, batch.v0, batch.objective,
                                         regularization_weight=problem.regularization, wrt=("values",),
                                         backend=backend)
        opt.lr = plan.lr_at(k, problem)
        values = opt.step(values, problem.values_grad(values, grads["values"]) * problem.mask(values.shape))
    return on_grid(problem, values, problem.shape())


def path_envelope(problem, values, seed: int, n_particles: int = ENVELOPE_PARTICLES, trim: float = ENVELOPE_TRIM,
                  backend: str | None = None) -> tuple:
    """``(q1, lo, hi)``: the problem grid's rows of q1 and, on each, the q0 range covered by the
    states of the paths that exit in the band (``n_particles`` of the training sampler from
    ``default_rng(seed)`` on the surface ``values``), less the share ``trim`` at each end; a row
    no such state reaches is the whole width."""
    batch = problem.batch(values, np.random.default_rng(seed), n_particles)
    traj = simulate(batch.scene, batch.x0, batch.v0, backend=backend)
    step, exited = exit_steps(traj.x, problem.lower[1])
    exits = np.where(exited, traj.x[step, np.arange(traj.x.shape[1]), 0], np.nan)
    states = traj.x[:, problem.in_band(exits)].reshape(-1, 2)
    q1 = np.linspace(problem.lower[1], problem.upper[1], problem.shape()[1])
    h = q1[1] - q1[0]
    inside = (states[:, 1] >= q1[0] - h / 2) & (states[:, 1] <= q1[-1] + h / 2)
    states = states[inside]
    row = np.clip(np.round((states[:, 1] - q1[0]) / h).astype(int), 0, q1.size - 1)
    lo = np.full(q1.size, float(problem.lower[0]))
    hi = np.full(q1.size, float(problem.upper[0]))
    order = np.argsort(row, kind="stable")
    starts = np.searchsorted(row[order], np.arange(q1.size + 1))
    for j in range(q1.size):
        q0 = states[order[starts[j]:starts[j + 1]], 0]
        if q0.size:
            lo[j], hi[j] = np.quantile(q0, trim), np.quantile(q0, 1.0 - trim)
    return q1, lo, hi


def _concave_majorant(x, y) -> np.ndarray:
    """The least concave function of ``x`` (increasing) at or above the points ``(x, y)``, on ``x``."""
    hull = []
    for i in range(len(x)):
        while len(hull) >= 2:
            a, b = hull[-2], hull[-1]
            if (y[b] - y[a]) * (x[i] - x[a]) <= (y[i] - y[a]) * (x[b] - x[a]):
                hull.pop()
            else:
                break
        hull.append(i)
    return np.interp(x, x[hull], y[hull])


def convex_walls(q1, lo, hi) -> tuple:
    """``(lo, hi)`` made the edges of a convex channel: ``hi`` its concave majorant in q1 and
    ``lo`` its convex minorant (the least convex channel holding every row's range)."""
    q1 = np.asarray(q1, dtype=np.float64)
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    return -_concave_majorant(q1, -lo), _concave_majorant(q1, hi)


def feet_in_band(problem, lo, hi, inset: float = FOOT_INSET) -> tuple:
    """``(lo, hi)`` each moved along q0 (a translation, which keeps a wall's shape) until its foot,
    its value on the exit edge's row (index 0), is ``target -+ (band - inset)`` (``problem.band``:
    the half-width of the band an exit must be in)."""
    half = problem.band - inset
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    return lo + (problem.target - half - lo[0]), hi + (problem.target + half - hi[0])


def interval_distance(q0, lo, hi) -> np.ndarray:
    """The signed distance along q0 (> 0 free) from grid nodes ``q0`` (n0,) to each row's edges
    ``lo``, ``hi`` (n1,): an (n0, n1) grid, free inside ``lo < q0 < hi``."""
    q0 = np.asarray(q0, dtype=np.float64)[:, None]
    return np.minimum(q0 - np.asarray(lo)[None, :], np.asarray(hi)[None, :] - q0)


def envelope_start(problem, rng, shape: tuple, backend: str | None = None) -> np.ndarray:
    """The signed distance (> 0 free) of the ``"envelope"`` start (module docstring) on the nodes of
    a grid of ``shape``: a smooth funnel of ``problem.plain()`` designed from a run seed drawn
    from ``rng``, the envelope of its paths from another seed drawn from it."""
    smooth_seed, path_seed = (int(s) for s in rng.integers(2 ** 31, size=2))
    plain = problem.plain()
    values = smooth_funnel(plain, smooth_seed, backend=backend)
    q1, lo, hi = path_envelope(plain, values, path_seed, backend=backend)
    lo, hi = feet_in_band(problem, *convex_walls(q1, lo, hi))
    q1s = np.linspace(problem.lower[1], problem.upper[1], shape[1])
    return interval_distance(np.linspace(problem.lower[0], problem.upper[0], shape[0]), np.interp(q1s, q1, lo),
                             np.interp(q1s, q1, hi))


def convex_channel(problem, values) -> np.ndarray:
    """A level set's free channel with convex walls: on each row of ``values`` (the level set's
    grid values, ``phi = values + r_c``, free where ``phi >= 0``) the free run of nodes around
    ``problem.target`` (the nearest free node where the target's is blocked) with its ends
    interpolated linearly between nodes (a run to the grid's edge ends ``min(phi, r_c)`` beyond it,
    the signed distance ``phi`` holds there), both edges made convex
    ([`convex_walls`][pes_ref.synthesis.kinds.envelope.convex_walls]) and their
    feet put in the band ([`feet_in_band`][pes_ref.synthesis.kinds.envelope.feet_in_band]); returned
    as the level set's grid values of that channel (``problem.level_set.from_distance``), zero
    where the problem holds them. A row with no free node keeps the whole width."""
    phi = np.asarray(values, dtype=np.float64) + problem.contact_r_c
    n0, n1 = phi.shape
    q0 = np.linspace(problem.lower[0], problem.upper[0], n0)
    q1 = np.linspace(problem.lower[1], problem.upper[1], n1)
    h = q0[1] - q0[0]
    centre = int(np.argmin(np.abs(q0 - problem.target)))
    lo = np.full(n1, float(problem.lower[0]))
    hi = np.full(n1, float(problem.upper[0]))
    for j in range(n1):
        free = phi[:, j] >= 0.0
        if not free.any():
            continue
        idx = np.nonzero(free)[0]
        c = centre if free[centre] else int(idx[np.argmin(np.abs(idx - centre))])
        blocked_left = np.nonzero(~free[:c])[0]
        blocked_right = np.nonzero(~free[c:])[0]
        i0 = blocked_left[-1] + 1 if blocked_left.size else 0
        i1 = c + blocked_right[0] - 1 if blocked_right.size else n0 - 1
        reach = np.minimum(phi[[i0, i1], j], problem.contact_r_c)       # a free run to the grid's edge
        lo[j] = q0[i0] - (h * phi[i0, j] / (phi[i0, j] - phi[i0 - 1, j]) if i0 > 0 else reach[0])
        hi[j] = q0[i1] + (h * phi[i1, j] / (phi[i1, j] - phi[i1 + 1, j]) if i1 < n0 - 1 else reach[1])
    lo, hi = feet_in_band(problem, *convex_walls(q1, lo, hi))
    return problem.level_set.from_distance(interval_distance(q0, lo, hi)) * problem.mask(phi.shape)
