"""The surrogate of failing a success test, and the share ceiling it charges (``[[evaluate.share]] max``).

A population criterion's share above its ``max`` is mended by making particles that pass its
test fail it. `fail_cost` is the mirror of a test's surrogate (``cost``,
[`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]): ``(c, gx, gv)`` with ``c`` (N,) zero exactly for a
particle that fails with room to spare (does not pass with the test's tolerance widened by
``margin``: ``passes(x, v, t, -margin)``) and otherwise the squared distance, in tolerances, to
the cheapest way of failing so (the nearest rim of the widened disc or box, the nearest bound of
a widened speed range, an exit moved out of the widened band, slowed, made too early or too
late). An any-of fails when all its tests fail (the sum of theirs); a group's test charges its
group's particles. `FAIL_COSTS` maps a kind to its function (dispatch by data); a kind without one
(``cross``, and a ``custom`` object without ``fail_cost(x, v, t, margin)``) has no surrogate of
failing, and a problem designed on its tests refuses a share ``max`` below 1 on it
([`has_fail_cost`][pes_ref.synthesis.problem.failing.has_fail_cost]).

[`ShareCeiling`][pes_ref.synthesis.problem.failing.ShareCeiling] charges a criterion's excess: the surrogates of
failing of the passing particles cheapest to turn, as many as the share exceeds ``max`` by,
as [`ShareCriterion`][pes_ref.synthesis.problem.success.ShareCriterion] charges the failing ones a share lacks of ``min``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pes_ref.synthesis.problem.objective_terms import window_steps, step_at
from pes_ref.synthesis.problem.success import applies

__all__ = ["FAIL_COSTS", "fail_cost", "has_fail_cost", "ShareCeiling"]


def _zero(x):
    return np.zeros(x.shape[1]), None, None


def _deepest(depth: np.ndarray):
    """Per particle the smallest ``depth`` over the leading axis (``depth`` (K, N): how far each of
    K states or faces lies inside what the particle must leave), clipped at 0 (one outside
    already fails), and its index."""
    k = np.argmin(depth, axis=0)
    return np.maximum(depth[k, np.arange(depth.shape[-1])], 0.0), k


def _disc(test, x, w, center, radius: float, margin: float):
    """Fail by leaving the disc of radius ``radius (1 + margin)`` at one of the states ``x[w]``:
    the state nearest its rim, ``((radius (1 + margin) - r) / radius)^2``."""
    states = x[w]
    if states.shape[0] == 0:
        return _zero(x)
    d = test.domain.wrap(states - np.asarray(center))
    r = np.sqrt(np.sum(d * d, axis=-1))
    depth, k = _deepest(radius * (1.0 + margin) - r)
    particle = np.arange(x.shape[1])
    dk, rk = d[k, particle], r[k, particle]
    gx = np.zeros_like(x)
    first = np.arange(x.shape[0])[w][k]
    gx[first, particle] = (-2.0 * depth / radius ** 2 / np.where(rk > 0.0, rk, 1.0))[:, None] * dk
    return (depth / radius) ** 2, gx, None


def _final_position(test, x, v, t, margin):
    return _disc(test, x, slice(x.shape[0] - 1, x.shape[0]), test.target, test.radius, margin)


def _position_at(test, x, v, t, margin):
    n = step_at(t, test.time)
    return _zero(x) if n is None else _disc(test, x, slice(n, n + 1), test.target, test.radius, margin)


def _within(test, x, v, t, margin):
    return _disc(test, x, window_steps(t, test.start, test.end), test.center, test.radius, margin)


def _stay_in(test, x, v, t, margin):
    """Fail by leaving the box grown by ``margin`` of its half-size: the state and axis nearest its
    face, in half-sizes (the larger axis's)."""
    w = window_steps(t, test.box.start, test.box.end)
    states = x[w]
    if states.shape[0] == 0:
        return _zero(x)
    lower, upper = np.asarray(test.box.lower), np.asarray(test.box.upper)
    half = 0.5 * (upper - lower)
    d = test.box.domain.wrap(states - 0.5 * (lower + upper))               # (S, N, 2)
    room = half * (1.0 + margin) - np.abs(d)
    depth, k = _deepest(np.moveaxis(room, 2, 1).reshape(-1, x.shape[1]))   # (S * 2, N)
    scale = float(half.max()) or 1.0
    particle = np.arange(x.shape[1])
    step, axis = np.divmod(k, 2)
    gx = np.zeros_like(x)
    first = np.arange(x.shape[0])[w][step]
    gx[first, particle, axis] = -2.0 * depth * np.sign(d[step, particle, axis]) / scale ** 2
    return (depth / scale) ** 2, gx, None


def _speed_at(test, x, v, t, margin):
    """Fail by a velocity outside the range widened by ``margin`` tolerances: the nearer bound."""
    n = step_at(t, test.time)
    if n is None:
        return _zero(x)
    scale = test._scale()
    s = v[n, :, test.axis]
    below = s - (test.low - margin * scale)                 # inf for an unbounded side
    above = (test.high + margin * scale) - s
    inside = (below >= 0.0) & (above >= 0.0)
    low_side = below <= above
    depth = np.where(inside, np.where(low_side, below, above), 0.0)
    depth = np.where(np.isfinite(depth), depth, 0.0)        # a range unbounded both ways: never fails
    gv = np.zeros_like(v)
    gv[n, :, test.axis] = np.where(low_side, 2.0, -2.0) * depth / scale ** 2
    return (depth / scale) ** 2, None, gv


def _exit(test, x, v, t, margin):
    """Fail by the cheapest of: the exit step's position along the edge out of ``center +-
    halfwidth (1 + margin)``; its speed out below ``min_speed (1 - margin)``; a state before
    ``from`` past the line ``margin halfwidth`` beyond the edge (too early); every state by ``to``
    short of the line ``margin halfwidth`` before it (too late, or never). Each squared, in
    half-widths (the speed in ``min_speed``)."""
    axis, toward, step, exited, along, past = test._judged(x)
    hw, t = test.edge.halfwidth, np.asarray(t)
    n, particle = x.shape[1], np.arange(x.shape[1])
    room = margin * hw
    options = []                                            # (depth, scale, gx entry, gv entry)
    band = hw * (1.0 + margin) - np.abs(along)
    options.append((band, hw, ("x", step, 1 - axis, -np.sign(along)), None))
    if test.min_speed > 0.0:
        fast = toward * v[step, particle, axis] - test.min_speed * (1.0 - margin)
        options.append((fast, test.min_speed, None, ("v", step, axis, toward * np.ones(n))))
    before = np.flatnonzero(t < test.start)
    if before.size:
        k = before[np.argmax(past[before], axis=0)]
        options.append((room - past[k, particle], hw, ("x", k, axis, -toward * np.ones(n)), None))
    by_to = np.flatnonzero(t <= test.end)
    if by_to.size:
        k = by_to[np.argmax(past[by_to], axis=0)]
        options.append((past[k, particle] + room, hw, ("x", k, axis, toward * np.ones(n)), None))
    if not by_to.size:
        return _zero(x)                                     # no state by `to`: every particle fails
    cost = np.stack([np.where(o[0] > 0.0, o[0] / o[1], 0.0) ** 2 for o in options])
    cost[:, ~exited] = 0.0                                  # one that never leaves fails already
    best = np.argmin(cost, axis=0)
    c = cost[best, particle]
    gx, gv = np.zeros_like(x), None
    for i, (depth, scale, at_x, at_v) in enumerate(options):
        chosen = (best == i) & (depth > 0.0) & exited
        kind, where, ax, sign = at_x or at_v
        g = np.where(chosen, 2.0 * depth * sign / scale ** 2, 0.0)
        if kind == "x":
            np.add.at(gx, (where, particle, ax), g)
        else:
            gv = np.zeros_like(v) if gv is None else gv
            np.add.at(gv, (where, particle, ax), g)
    return c, gx, gv


def _any_of(test, x, v, t, margin):
    """All its tests must fail: the sum of their surrogates of failing."""
    c, gx, gv = np.zeros(x.shape[1]), None, None
    for child in test.tests:
        cc, cx, cv = fail_cost(child, x, v, t, margin)
        c = c + cc
        gx = cx if gx is None else (gx if cx is None else gx + cx)
        gv = cv if gv is None else (gv if cv is None else gv + cv)
    return c, gx, gv


def _custom(test, x, v, t, margin):
    c, gx, gv = test.obj.fail_cost(x, v, t, margin)
    return np.asarray(c, dtype=np.float64), gx, gv


#: The kinds with a surrogate of failing: ``kind`` -> ``f(test, x, v, t, margin) -> (c, gx, gv)``.
FAIL_COSTS = {"final_position": _final_position, "position_at": _position_at, "within": _within,
              "stay_in": _stay_in, "speed_at": _speed_at, "exit": _exit, "any_of": _any_of, "custom": _custom}


def has_fail_cost(test) -> bool:
    """Whether ``test`` has a surrogate of failing (a group's: its test's; an any-of: all of its tests')."""
    if hasattr(test, "members"):
        return has_fail_cost(test.test)
    if test.KIND == "custom":
        return callable(getattr(test.obj, "fail_cost", None))
    if hasattr(test, "CHILDREN"):
        return all(has_fail_cost(child) for child in getattr(test, test.CHILDREN))
    return test.KIND in FAIL_COSTS


def fail_cost(test, x, v, t, margin: float):
    """``test``'s surrogate of failing with ``margin``, ``(c, gx, gv)`` (module docstring); a group's
    test charges its group's particles only."""
    members = getattr(test, "members", None)
    if members is None:
        return FAIL_COSTS[test.KIND](test, x, v, t, margin)
    mine = members(x.shape[1])
    c, gx, gv = fail_cost(test.test, x, v, t, margin)
    return (np.where(mine, c, 0.0), None if gx is None else np.where(mine[:, None], gx, 0.0),
            None if gv is None else np.where(mine[:, None], gv, 0.0))


@dataclass(frozen=True)
class ShareCeiling:
    """The upper bound ``high`` of a population criterion on ``test``, charged: the surrogates of
    failing of the passing particles cheapest to turn, as many as the share exceeds ``high`` by
    (a particle counts as passing unless it fails with room to spare); 0 for every other."""

    test: object
    high: float

    def cost(self, x, v, t, margin: float):
        """The surrogate protocol of [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]."""
        c, gx, gv = fail_cost(self.test, x, v, t, margin)
        judged = applies(self.test, x.shape[1])
        passing = np.flatnonzero(judged & (c > 0.0))
        excess = passing.size - math.floor(self.high * np.count_nonzero(judged) + 1e-9)
        keep = np.zeros(x.shape[1], dtype=bool)
        if excess > 0:
            keep[passing[np.argsort(c[passing], kind="stable")[:excess]]] = True
        return (np.where(keep, c, 0.0), None if gx is None else np.where(keep[:, None], gx, 0.0),
                None if gv is None else np.where(keep[:, None], gv, 0.0))
