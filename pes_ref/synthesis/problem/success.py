"""Per-particle success tests of a problem file (``[[evaluate.success]]``): did each particle do the job?

A test is a frozen object with ``passes(x, v, t, margin=0) -> (N,) bool`` on a trajectory's
positions and velocities (T+1, N, 2) and times (T+1,) (``margin``: whether each particle passes with
that room to spare, the surrogate's notion below; a user's own test takes none). A particle succeeds
when it passes every test of its problem; ``evaluate`` prints the share that does
(``success_fraction``) and the share passing each test. `SUCCESS_TESTS` maps a kind to its class
(dispatch by data); the kinds mirror the objective terms of
[`pes_ref.synthesis.problem.objective_terms`][pes_ref.synthesis.problem.objective_terms], each with
a tolerance where the term has a target. Differences along a periodic axis are taken the short way
round, times at the nearest state, as there.

Beside each test's ``passes`` is its smooth surrogate, ``cost(x, v, t, margin) -> (c, gx,
gv)``: ``c`` (N,) is zero exactly for a particle that passes with room to spare (``passes(...,
margin)``; ``margin`` a fraction of the test's tolerance: its radius, half-width or
half-size) and grows with the squared distance, in tolerances, from passing: every clause
of a test is charged, a window's ends included; ``gx``, ``gv`` (either None) are the
derivatives of ``sum(c)``, each particle's only in its own column. A problem file without
``[[objective]]`` is designed on the sum of its tests' surrogates
([`pes_ref.synthesis.problem.surrogates`][pes_ref.synthesis.problem.surrogates]).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, ClassVar

import numpy as np

from pes_ref.synthesis.problem.file_keys import Key, from_table
from pes_ref.synthesis.problem.objective_terms import (EDGES, CustomTermError, Domain, Exit, StayIn, call_user, excess,
                                                       step_at, window_steps)

__all__ = ["SUCCESS_TESTS", "FinalPositionTest", "PositionAtTest", "StayInTest", "WithinTest", "ExitTest",
           "CrossTest", "SpeedAtTest", "AnyOfTest", "CustomTest", "GroupTest", "ShareCriterion", "passes_all",
           "applies", "outside_domain"]

_WINDOW = {"from": Key("nonneg", 0.0, unit="time"), "to": Key("nonneg", math.inf, unit="time")}


def _near(x: np.ndarray, target, radius: float, domain: Domain) -> np.ndarray:
    d = domain.wrap(x - np.asarray(target))
    return np.sqrt(np.sum(d * d, axis=-1)) <= radius


def _disc_cost(states: np.ndarray, center, radius: float, margin: float, domain: Domain):
    """``((e / radius)^2, its derivative)`` per state, ``e`` how far a state lies outside the
    disc of radius ``radius (1 - margin)`` about ``center``."""
    d = domain.wrap(states - np.asarray(center))
    r = np.sqrt(np.sum(d * d, axis=-1))
    e = np.maximum(r - radius * (1.0 - margin), 0.0)
    return (e / radius) ** 2, (2.0 * e / radius ** 2 / np.where(r > 0.0, r, 1.0))[..., None] * d


def _at_states(x: np.ndarray, n, c: np.ndarray, g: np.ndarray, mean: bool = False):
    """A cost over the states ``x[n]`` (one state, or a window's: averaged) as ``(c, gx, None)``."""
    gx = np.zeros_like(x)
    if mean:
        k = c.shape[0]
        gx[n] = g / k
        return c.mean(axis=0), gx, None
    gx[n] = g
    return c, gx, None


def _disc_region(center, radius: float) -> tuple:
    """``(lower, upper)`` of the box around the disc of ``radius`` about ``center``."""
    return tuple(c - radius for c in center), tuple(c + radius for c in center)


def outside_domain(test, domain: Domain):
    """The region ``(lower, upper)`` ``test`` asks a particle to reach (its ``region()``) if it lies
    wholly outside ``domain`` on a non-periodic axis, where the surface is not designed; else None
    (and for a test with no region: an exit, a speed). A group's test is judged by its own."""
    test = getattr(test, "test", test)
    region = getattr(test, "region", None)
    if region is None:
        return None
    lower, upper = region()
    if any(not periodic and (hi < d_lo or lo > d_hi)
           for lo, hi, d_lo, d_hi, periodic in zip(lower, upper, domain.lower, domain.upper, domain.periodic)):
        return tuple(lower), tuple(upper)
    return None


def _none(x: np.ndarray):
    """Every particle fails (a time after the run's end)."""
    return np.zeros(x.shape[1], dtype=bool)


@dataclass(frozen=True)
class FinalPositionTest:
    """The last state lies within ``radius`` of ``target``."""

    KIND: ClassVar[str] = "final_position"
    KEYS: ClassVar[dict] = {"target": Key("point", unit="length"), "radius": Key("positive", unit="length")}
    target: tuple
    radius: float
    domain: Domain

    from_keys = classmethod(from_table)

    def region(self) -> tuple:
        """``(lower, upper)``: the box around the disc a particle must reach (the domain check's)."""
        return _disc_region(self.target, self.radius)

    def passes(self, x, v, t, margin: float = 0.0):
        """Whether each particle's last state lies within ``radius (1 - margin)`` of ``target``, (N,) bool; the
        success-test protocol of [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]."""
        return _near(x[-1], self.target, self.radius * (1.0 - margin), self.domain)

    def cost(self, x, v, t, margin: float):
        """The squared distance of the last state from the disc of radius ``radius (1 - margin)`` about
        ``target``, in radii; the surrogate protocol of [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]."""
        c, g = _disc_cost(x[-1], self.target, self.radius, margin, self.domain)
        return _at_states(x, -1, c, g)


@dataclass(frozen=True)
class PositionAtTest:
    """The state nearest ``time`` lies within ``radius`` of ``target``."""

    KIND: ClassVar[str] = "position_at"
    KEYS: ClassVar[dict] = {"time": Key("nonneg", unit="time"), "target": Key("point", unit="length"),
                            "radius": Key("positive", unit="length")}
    time: float
    target: tuple
    radius: float
    domain: Domain

    from_keys = classmethod(from_table)

    def region(self) -> tuple:
        """``(lower, upper)``: the box around the disc a particle must reach (the domain check's)."""
        return _disc_region(self.target, self.radius)

    def passes(self, x, v, t, margin: float = 0.0):
        """Whether the state nearest ``time`` lies within ``radius (1 - margin)`` of ``target``, (N,) bool
        (every particle fails when ``time`` is after the run's end); the success-test protocol of
        [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]."""
        n = step_at(t, self.time)
        if n is None:
            return _none(x)
        return _near(x[n], self.target, self.radius * (1.0 - margin), self.domain)

    def cost(self, x, v, t, margin: float):
        """The squared distance of the state nearest ``time`` from the disc of radius ``radius (1 - margin)``
        about ``target``, in radii (0 when ``time`` is after the run's end); the surrogate protocol of
        [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]."""
        n = step_at(t, self.time)
        if n is None:
            return np.zeros(x.shape[1]), None, None
        c, g = _disc_cost(x[n], self.target, self.radius, margin, self.domain)
        return _at_states(x, n, c, g)


@dataclass(frozen=True)
class StayInTest:
    """Every state from ``from`` to ``to`` lies in the box ``[lower, upper]`` (faces included)."""

    KIND: ClassVar[str] = "stay_in"
    KEYS: ClassVar[dict] = {"lower": Key("point", unit="length"), "upper": Key("point", unit="length"), **_WINDOW}
    box: StayIn

    @classmethod
    def from_keys(cls, keys: dict, domain: Domain, duration: float):
        """The test from its ``[[evaluate.success]]`` entry's checked keys (``KEYS``), on ``domain``; how
        the problem file's reader builds every test, as it builds the objective terms
        ([`pes_ref.synthesis.problem.objective_terms`][pes_ref.synthesis.problem.objective_terms])."""
        return cls(StayIn(keys["lower"], keys["upper"], keys["from"], keys["to"], 1.0, domain))

    def region(self) -> tuple:
        """``(lower, upper)``: the box a particle must stay in (the domain check's)."""
        return self.box.lower, self.box.upper

    def _outside(self, states, margin: float):
        """How far each state lies outside the box shrunk by ``margin`` of its half-size, per axis, and the
        larger half-size."""
        lower, upper = np.asarray(self.box.lower), np.asarray(self.box.upper)
        half = 0.5 * (upper - lower)
        return excess(self.box.domain.wrap(states - 0.5 * (lower + upper)), half * (1.0 - margin)), float(half.max())

    def passes(self, x, v, t, margin: float = 0.0):
        """Whether every state of the window lies in the box (shrunk by ``margin`` of its half-size), (N,)
        bool (every particle fails when the window holds no state); the success-test protocol of
        [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]."""
        states = x[window_steps(t, self.box.start, self.box.end)]
        if states.shape[0] == 0:
            return _none(x)
        return np.all(self._outside(states, margin)[0] == 0.0, axis=(0, 2))

    def cost(self, x, v, t, margin: float):
        """The mean over the window of the squared distance from the box shrunk by ``margin`` of
        its half-size on each axis, in half-sizes (the larger axis's)."""
        w = window_steps(t, self.box.start, self.box.end)
        if x[w].shape[0] == 0:
            return np.zeros(x.shape[1]), None, None
        e, scale = self._outside(x[w], margin)
        scale = scale or 1.0
        return _at_states(x, w, np.sum(e * e, axis=-1) / scale ** 2, 2.0 * e / scale ** 2, mean=True)


@dataclass(frozen=True)
class WithinTest:
    """Every state from ``from`` to ``to`` lies within ``radius`` of ``center`` (a disc)."""

    KIND: ClassVar[str] = "within"
    KEYS: ClassVar[dict] = {"center": Key("point", unit="length"), "radius": Key("positive", unit="length"),
                            **_WINDOW}
    center: tuple
    radius: float
    start: float
    end: float
    domain: Domain

    from_keys = classmethod(from_table)

    def region(self) -> tuple:
        """``(lower, upper)``: the box around the disc a particle must reach (the domain check's)."""
        return _disc_region(self.center, self.radius)

    def passes(self, x, v, t, margin: float = 0.0):
        """Whether every state of the window lies within ``radius (1 - margin)`` of ``center``, (N,) bool
        (every particle fails when the window holds no state); the success-test protocol of
        [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]."""
        states = x[window_steps(t, self.start, self.end)]
        if states.shape[0] == 0:
            return _none(x)
        return np.all(_near(states, self.center, self.radius * (1.0 - margin), self.domain), axis=0)

    def cost(self, x, v, t, margin: float):
        """The mean over the window of the squared distance from the disc of radius ``radius (1 - margin)``
        about ``center``, in radii (0 when the window holds no state); the surrogate protocol of
        [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]."""
        w = window_steps(t, self.start, self.end)
        if x[w].shape[0] == 0:
            return np.zeros(x.shape[1]), None, None
        c, g = _disc_cost(x[w], self.center, self.radius, margin, self.domain)
        return _at_states(x, w, c, g, mean=True)


@dataclass(frozen=True)
class ExitTest:
    """The particle leaves by ``edge`` within ``halfwidth`` of ``center`` (strictly: the
    funnel's in-band test), between ``from`` and ``to``, moving out across the edge at least
    ``min_speed`` fast (at its first state past the edge)."""

    KIND: ClassVar[str] = "exit"
    KEYS: ClassVar[dict] = {"edge": Key("choice", choices=tuple(EDGES)), "center": Key("number", unit="length"),
                            "halfwidth": Key("positive", unit="length"),
                            "min_speed": Key("nonneg", 0.0, unit="length/time"), **_WINDOW}
    edge: Exit
    min_speed: float
    start: float
    end: float

    @classmethod
    def from_keys(cls, keys: dict, domain: Domain, duration: float):
        """The test from its ``[[evaluate.success]]`` entry's checked keys (``KEYS``), on ``domain``; how
        the problem file's reader builds every test, as it builds the objective terms
        ([`pes_ref.synthesis.problem.objective_terms`][pes_ref.synthesis.problem.objective_terms])."""
        return cls(Exit(keys["edge"], keys["center"], keys["halfwidth"], 1.0, domain), keys["min_speed"],
                   keys["from"], keys["to"])

    def _judged(self, x):
        """What the verdict and the surrogate share: ``(axis, toward, step, exited, along, past)``, ``along``
        the exit step's position along the edge from ``center`` and ``past`` (T+1, N) how far each state
        lies past the edge (negative short of it)."""
        step, exited = self.edge.steps(x)
        axis, side, level = self.edge.domain.edge(self.edge.edge)
        toward = 1.0 if side == "upper" else -1.0
        particle = np.arange(x.shape[1])
        along = self.edge.domain.wrap_axis(x[step, particle, 1 - axis] - self.edge.center, 1 - axis)
        return axis, toward, step, exited, along, toward * (x[..., axis] - level)

    def passes(self, x, v, t, margin: float = 0.0):
        """Whether each particle leaves by the edge within ``halfwidth`` of ``center``, between ``from`` and
        ``to``, moving out across it at least ``min_speed`` fast, (N,) bool; the success-test protocol of
        [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]. With ``margin`` (room to spare, in the tolerances of
        `cost`): within ``halfwidth (1 - margin)``, at least ``min_speed (1 + margin)`` fast,
        every state before ``from`` short of the edge by ``margin halfwidth``, and some state by ``to``
        past it by as much."""
        axis, toward, step, exited, along, past = self._judged(x)
        hw, t = self.edge.halfwidth, np.asarray(t)
        room = margin * hw
        early = np.all(past[t < self.start] < -room, axis=0)
        by_to = past[t <= self.end]
        late = np.any(by_to >= room, axis=0) if by_to.shape[0] else _none(x)
        ok = exited & early & late & (np.abs(along) < hw * (1.0 - margin))
        if self.min_speed > 0.0:
            ok &= toward * v[step, np.arange(x.shape[1]), axis] >= self.min_speed * (1.0 + margin)
        return ok

    def cost(self, x, v, t, margin: float):
        """At the exit step (the last state for a particle that never leaves): the position along the
        edge outside ``center +- halfwidth (1 - margin)``, in half-widths, and the speed towards the
        edge below ``min_speed (1 + margin)``, in ``min_speed``; the window: before ``from``, how far
        past the line ``margin halfwidth`` short of the edge each state lies (averaged over those
        states: too early), and by ``to``, how far the state deepest past the edge lies short of the
        line ``margin halfwidth`` past it (too late, or never; not charged in a run that ends before
        ``from``, a stage's shorter horizon), both in half-widths; squared."""
        axis, toward, step, exited, along, past = self._judged(x)
        hw, t = self.edge.halfwidth, np.asarray(t)
        room = margin * hw
        particle = np.arange(x.shape[1])
        off = excess(along, hw * (1.0 - margin))
        gx = np.zeros_like(x)
        gx[step, particle, 1 - axis] = 2.0 * off / hw ** 2
        c = off * off / hw ** 2
        before = np.flatnonzero(t < self.start)
        if before.size:                     # too early: past the line short of the edge before `from`
            e = np.maximum(past[before] + room, 0.0)
            c = c + np.mean(e * e, axis=0) / hw ** 2
            gx[before, :, axis] += 2.0 * toward * e / (hw ** 2 * before.size)
        if step_at(t, self.start) is not None:      # a run cut short of `from` (a stage's horizon) asks no exit
            by_to = np.flatnonzero(t <= self.end)
            deepest = by_to[np.argmax(past[by_to], axis=0)]
            e = np.maximum(room - past[deepest, particle], 0.0)      # too late: not out by `to`
            c = c + e * e / hw ** 2
            gx[deepest, particle, axis] += -2.0 * toward * e / hw ** 2
        gv = None
        if self.min_speed > 0.0:
            slow = np.maximum(self.min_speed * (1.0 + margin) - toward * v[step, particle, axis], 0.0)
            c = c + (slow / self.min_speed) ** 2
            gv = np.zeros_like(v)
            gv[step, particle, axis] = -2.0 * toward * slow / self.min_speed ** 2
        return c, gx, gv


@dataclass(frozen=True)
class CrossTest:
    """The path crosses the segment from ``a`` to ``b`` between ``from`` and ``to``: some step's
    straight move from one state to the next meets it (on a periodic axis the states are taken
    in the domain, the segment where it is stated)."""

    KIND: ClassVar[str] = "cross"
    KEYS: ClassVar[dict] = {"a": Key("point", unit="length"), "b": Key("point", unit="length"), **_WINDOW}
    a: tuple
    b: tuple
    start: float
    end: float
    domain: Domain

    def __post_init__(self):
        if self.a == self.b:
            raise ValueError(f"a and b are the same point {list(self.a)}: a segment has two ends")

    from_keys = classmethod(from_table)

    def region(self) -> tuple:
        """``(lower, upper)``: the box around the segment a particle must cross (the domain check's)."""
        return tuple(np.minimum(self.a, self.b).tolist()), tuple(np.maximum(self.a, self.b).tolist())

    def _states(self, x, t):
        w = window_steps(t, self.start, self.end)
        lower = np.asarray(self.domain.lower)
        length = np.asarray(self.domain.upper) - lower
        p = np.where(self.domain.periodic, lower + np.mod(x[w] - lower, length), x[w])
        return w, p, x[w][1:] - x[w][:-1]

    def _along(self, p, r, margin: float):
        """Where each move ``p -> p + r`` meets the segment's line, as a fraction ``u`` of the
        segment, and whether it does within the move and the segment shrunk by ``margin / 2`` at each end."""
        a, s = np.asarray(self.a), np.asarray(self.b) - np.asarray(self.a)
        q = a - p
        cross = r[..., 0] * s[1] - r[..., 1] * s[0]
        safe = np.where(cross != 0.0, cross, 1.0)
        tau = (q[..., 0] * s[1] - q[..., 1] * s[0]) / safe
        u = (q[..., 0] * r[..., 1] - q[..., 1] * r[..., 0]) / safe
        lo = 0.5 * margin
        return (cross != 0.0) & (tau >= 0.0) & (tau <= 1.0) & (u >= lo) & (u <= 1.0 - lo)

    def passes(self, x, v, t, margin: float = 0.0):
        """Whether some step's move within the window meets the segment (shortened by ``margin / 2`` of its
        length at each end), (N,) bool (every particle fails when the window holds no state); the
        success-test protocol of [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]."""
        _, p, r = self._states(x, t)
        if r.shape[0] == 0:
            return _none(x)
        return np.any(self._along(p[:-1], r, margin), axis=0)

    def cost(self, x, v, t, margin: float):
        """Zero for a path across the segment shrunk by ``margin / 2`` of its length at each end;
        otherwise the squared distance, in half-lengths, from that shorter segment at the
        window's state closest to it."""
        w, p, r = self._states(x, t)
        if p.shape[0] == 0:
            return np.zeros(x.shape[1]), None, None
        crossed = np.any(self._along(p[:-1], r, margin), axis=0) if r.shape[0] else np.zeros(x.shape[1], bool)
        a, s = np.asarray(self.a), np.asarray(self.b) - np.asarray(self.a)
        half = 0.5 * float(np.hypot(*s))
        lo = 0.5 * margin
        u = np.clip(np.sum((p - a) * s, axis=-1) / float(s @ s), lo, 1.0 - lo)
        d = p - (a + u[..., None] * s)
        dist2 = np.sum(d * d, axis=-1)
        n = np.argmin(dist2, axis=0)
        particle = np.arange(x.shape[1])
        keep = ~crossed
        c = np.where(keep, dist2[n, particle], 0.0) / half ** 2
        gx = np.zeros_like(x)
        first = w.start
        gx[first + n, particle] = np.where(keep[:, None], 2.0 * d[n, particle], 0.0) / half ** 2
        return c, gx, None


@dataclass(frozen=True)
class SpeedAtTest:
    """At the state nearest ``time`` the velocity along ``axis`` is between ``min`` and ``max``."""

    KIND: ClassVar[str] = "speed_at"
    KEYS: ClassVar[dict] = {"time": Key("nonneg", unit="time"), "axis": Key("axis"),
                            "min": Key("number", -math.inf, unit="length/time"),
                            "max": Key("number", math.inf, unit="length/time")}
    time: float
    axis: int
    low: float
    high: float

    def __post_init__(self):
        if not self.high >= self.low:
            raise ValueError(f"expected max >= min, got min {self.low:g}, max {self.high:g}")

    @classmethod
    def from_keys(cls, keys: dict, domain: Domain, duration: float):
        """The test from its ``[[evaluate.success]]`` entry's checked keys (``KEYS``), on ``domain``; how
        the problem file's reader builds every test, as it builds the objective terms
        ([`pes_ref.synthesis.problem.objective_terms`][pes_ref.synthesis.problem.objective_terms])."""
        return cls(keys["time"], keys["axis"], keys["min"], keys["max"])

    def passes(self, x, v, t, margin: float = 0.0):
        """Whether the velocity along ``axis`` at the state nearest ``time`` lies in ``[min, max]`` (narrowed
        by ``margin`` tolerances, `cost`'s), (N,) bool (every particle fails when ``time`` is after
        the run's end); the success-test protocol of [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]."""
        n = step_at(t, self.time)
        if n is None:
            return _none(x)
        speed, room = v[n, :, self.axis], margin * self._scale()
        return (speed >= self.low + room) & (speed <= self.high - room)

    def _scale(self) -> float:
        """The test's tolerance: half the range, or a one-sided bound's size (1 for a bound of 0)."""
        if math.isfinite(self.low) and math.isfinite(self.high):
            return 0.5 * (self.high - self.low) or 1.0
        bound = self.low if math.isfinite(self.low) else self.high
        return abs(bound) if math.isfinite(bound) and bound != 0.0 else 1.0

    def cost(self, x, v, t, margin: float):
        """The squared amount by which that velocity lies outside the range narrowed by ``margin`` tolerances,
        in tolerances (half the range, or a one-sided bound's size); ``gx`` is None, and the cost 0 when
        ``time`` is after the run's end; the surrogate protocol of [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]."""
        n = step_at(t, self.time)
        if n is None:
            return np.zeros(x.shape[1]), None, None
        scale = self._scale()
        s = v[n, :, self.axis]
        below = np.maximum(self.low + margin * scale - s, 0.0)
        above = np.maximum(s - (self.high - margin * scale), 0.0)
        gv = np.zeros_like(v)
        gv[n, :, self.axis] = 2.0 * (above - below) / scale ** 2
        return (below * below + above * above) / scale ** 2, None, gv


@dataclass(frozen=True)
class AnyOfTest:
    """Passes when any one of ``tests`` passes (a splitter's exits); its surrogate is each
    particle's cheapest alternative."""

    KIND: ClassVar[str] = "any_of"
    KEYS: ClassVar[dict] = {"tests": Key("tables")}
    #: The key whose entries are success tests themselves (read by the problem file's reader).
    CHILDREN: ClassVar[str] = "tests"
    tests: tuple

    @classmethod
    def from_keys(cls, keys: dict, domain: Domain, duration: float):
        """The test from its entry's checked keys, its ``tests`` already built by the reader
        (`CHILDREN`); how the problem file's reader builds every test
        ([`pes_ref.synthesis.problem.objective_terms`][pes_ref.synthesis.problem.objective_terms])."""
        return cls(tuple(keys["tests"]))

    def passes(self, x, v, t, margin: float = 0.0):
        """Whether any one of ``tests`` passes (with ``margin``), (N,) bool; the success-test protocol of
        [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]."""
        return np.logical_or.reduce([test.passes(x, v, t, margin) for test in self.tests])

    def cost(self, x, v, t, margin: float):
        """Each particle's cheapest surrogate among ``tests``, with that one's derivatives; the surrogate
        protocol of [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]."""
        costs = [test.cost(x, v, t, margin) for test in self.tests]
        c = np.stack([k[0] for k in costs])
        best = np.argmin(c, axis=0)
        particle = np.arange(x.shape[1])
        gx = gv = None
        for i, (_, tx, tv) in enumerate(costs):
            chosen = best == i
            if tx is not None:
                gx = (np.zeros_like(x) if gx is None else gx) + np.where(chosen[:, None], tx, 0.0)
            if tv is not None:
                gv = (np.zeros_like(v) if gv is None else gv) + np.where(chosen[:, None], tv, 0.0)
        return c[best, particle], gx, gv


@dataclass(frozen=True)
class CustomTest:
    """A user's own test: ``object.passes(x, v, t) -> (N,) bool`` and, for a design without
    ``[[objective]]``, ``object.cost(x, v, t, margin) -> (c, gx, gv)`` (this module's surrogate
    protocol). In a file ``object`` is ``"module:object"`` (imported and checked when the file is
    read, [`.file_keys`][pes_ref.synthesis.problem.file_keys], from the file's folder first); in code, the object itself."""

    KIND: ClassVar[str] = "custom"
    KEYS: ClassVar[dict] = {"object": Key("test_object")}
    obj: object
    #: What names the test when its object fails (``evaluate.success[0] (custom 'band', mymod:BAND)``).
    label: str = "a custom test"

    def __post_init__(self):
        if isinstance(self.obj, type) or not callable(getattr(self.obj, "passes", None)):
            raise TypeError(f"a custom test is an object with passes(x, v, t), got {self.obj!r}")

    @classmethod
    def from_keys(cls, keys: dict, domain: Domain, duration: float):
        """The test from its ``[[evaluate.success]]`` entry's checked keys (``KEYS``), on ``domain``; how
        the problem file's reader builds every test, as it builds the objective terms
        ([`pes_ref.synthesis.problem.objective_terms`][pes_ref.synthesis.problem.objective_terms])."""
        return cls(keys["object"])

    @property
    def has_cost(self) -> bool:
        """Whether the object has a ``cost`` (a surrogate): a design without ``[[objective]]`` needs one."""
        return callable(getattr(self.obj, "cost", None))

    def passes(self, x, v, t, margin: float = 0.0):
        """The object's ``passes(x, v, t)`` as (N,) bool, refusing another shape; what it raises as one
        [`CustomTermError`][pes_ref.synthesis.problem.objective_terms.CustomTermError]; the success-test protocol of
        [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]. A user's test has no room to spare: ``margin`` is not its."""
        ok = np.asarray(call_user(self.label, self.obj.passes, x, v, t))
        if ok.shape != (x.shape[1],):
            raise CustomTermError(f"{self.label}: passes returned shape {ok.shape}, expected ({x.shape[1]},)")
        return ok.astype(bool)

    def cost(self, x, v, t, margin: float):
        """The object's ``cost(x, v, t, margin)``, ``c`` as float64; what it raises as one
        [`CustomTermError`][pes_ref.synthesis.problem.objective_terms.CustomTermError]; the surrogate protocol of
        [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]."""
        c, gx, gv = call_user(self.label, self.obj.cost, x, v, t, margin)
        return np.asarray(c, dtype=np.float64), gx, gv


@dataclass(frozen=True)
class GroupTest:
    """``test`` for the particles of one start group (``group = "NAME"``); the others pass it.
    ``members(n)`` is the (n,) mask of the group's particles in a batch of ``n``."""

    test: object
    group: str
    members: Callable

    @property
    def KIND(self) -> str:                   # noqa: N802 (the kind of the test it judges with)
        """The kind of ``test``, the test it judges with."""
        return self.test.KIND

    def passes(self, x, v, t, margin: float = 0.0):
        """``test``'s verdict (with ``margin``) for the group's particles, True for the others, (N,) bool; the
        success-test protocol of [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]."""
        return ~self.members(x.shape[1]) | self.test.passes(x, v, t, margin)

    def cost(self, x, v, t, margin: float):
        """``test``'s surrogate for the group's particles, 0 (and no derivative) for the others; the surrogate
        protocol of [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]."""
        mine = self.members(x.shape[1])
        c, gx, gv = self.test.cost(x, v, t, margin)
        return (np.where(mine, c, 0.0), None if gx is None else np.where(mine[:, None], gx, 0.0),
                None if gv is None else np.where(mine[:, None], gv, 0.0))


@dataclass(frozen=True)
class ShareCriterion:
    """A population criterion (``[[evaluate.share]]``): the share of the particles ``test``
    judges that pass it lies in ``[low, high]`` (the share leaving by each of a splitter's exits).

    Its surrogate charges what raises a share below ``low``: the surrogates of the particles
    failing ``test`` that are cheapest to mend, as many as the share lacks; a share above
    ``high`` is charged by [`pes_ref.synthesis.problem.failing`][pes_ref.synthesis.problem.failing]'s ``ShareCeiling``."""

    test: object
    low: float
    high: float

    def share(self, x, v, t) -> float:
        """The share of the particles ``test`` judges that pass it (in [0, 1])."""
        ok = self.test.passes(x, v, t)
        return float(np.mean(ok[applies(self.test, x.shape[1])]))

    def cost(self, x, v, t, margin: float):
        """``test``'s surrogate for the failing particles cheapest to mend, as many as the share lacks of
        ``low``; 0 (and no derivative) for every other particle; the surrogate protocol of
        [`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success]."""
        c, gx, gv = self.test.cost(x, v, t, margin)
        judged = applies(self.test, x.shape[1])
        lacking = math.ceil(self.low * np.count_nonzero(judged) - 1e-9) - np.count_nonzero(judged & (c == 0.0))
        failing = np.flatnonzero(judged & (c > 0.0))
        keep = np.zeros(x.shape[1], dtype=bool)
        if lacking > 0:
            keep[failing[np.argsort(c[failing], kind="stable")[:lacking]]] = True
        return (np.where(keep, c, 0.0), None if gx is None else np.where(keep[:, None], gx, 0.0),
                None if gv is None else np.where(keep[:, None], gv, 0.0))


#: The kinds of success test: ``[[evaluate.success]] kind = ...`` -> its class.
SUCCESS_TESTS = {cls.KIND: cls for cls in (FinalPositionTest, PositionAtTest, StayInTest, WithinTest, ExitTest,
                                           CrossTest, SpeedAtTest, AnyOfTest, CustomTest)}


def applies(test, n: int) -> np.ndarray:
    """The (n,) mask of the particles ``test`` judges: a start group's, or all."""
    members = getattr(test, "members", None)
    return np.ones(n, dtype=bool) if members is None else members(n)


def passes_all(tests, x, v, t) -> tuple:
    """``(every, each)``: (N,) whether each particle passes every test, and the list of each test's (N,)."""
    each = [test.passes(x, v, t) for test in tests]
    every = np.logical_and.reduce(each) if each else np.zeros(x.shape[1], dtype=bool)
    return every, each
