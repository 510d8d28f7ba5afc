"""Per-particle success tests of a problem file (``[[evaluate.success]]``): did each particle do the job?

A test is a frozen object with ``passes(x, v, t) -> (N,) bool`` on a trajectory's positions
and velocities (T+1, N, 2) and times (T+1,). A particle succeeds when it passes every test
of its problem; ``evaluate`` prints the share that does (``success_fraction``) and the share
passing each test. :data:`SUCCESS_TESTS` maps a kind to its class (dispatch by data); the
kinds mirror the objective terms of :mod:`pes_ref.synthesis.objective_terms`, each with a
tolerance where the term has a target. Differences along a periodic axis are taken the short
way round, times at the nearest state, as there.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from pes_ref.synthesis.file_keys import Key
from pes_ref.synthesis.objective_terms import EDGES, Domain, Exit, StayIn, step_at, window_steps

__all__ = ["SUCCESS_TESTS", "FinalPositionTest", "PositionAtTest", "StayInTest", "ExitTest", "SpeedAtTest",
           "passes_all"]


def _near(x: np.ndarray, target, radius: float, domain: Domain) -> np.ndarray:
    d = domain.wrap(x - np.asarray(target))
    return np.sqrt(np.sum(d * d, axis=-1)) <= radius


@dataclass(frozen=True)
class FinalPositionTest:
    """The last state lies within ``radius`` of ``target``."""

    KIND: ClassVar[str] = "final_position"
    KEYS: ClassVar[dict] = {"target": Key("point", unit="length"), "radius": Key("positive", unit="length")}
    target: tuple
    radius: float
    domain: Domain

    @classmethod
    def from_keys(cls, keys: dict, domain: Domain, duration: float):
        return cls(keys["target"], keys["radius"], domain)

    def passes(self, x, v, t):
        return _near(x[-1], self.target, self.radius, self.domain)


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

    @classmethod
    def from_keys(cls, keys: dict, domain: Domain, duration: float):
        return cls(keys["time"], keys["target"], keys["radius"], domain)

    def passes(self, x, v, t):
        n = step_at(t, self.time)
        if n is None:
            return np.zeros(x.shape[1], dtype=bool)
        return _near(x[n], self.target, self.radius, self.domain)


@dataclass(frozen=True)
class StayInTest:
    """Every state from ``from`` to ``to`` lies in the box ``[lower, upper]`` (faces included)."""

    KIND: ClassVar[str] = "stay_in"
    KEYS: ClassVar[dict] = {"lower": Key("point", unit="length"), "upper": Key("point", unit="length"),
                            "from": Key("nonneg", 0.0, unit="time"), "to": Key("nonneg", math.inf, unit="time")}
    box: StayIn

    @classmethod
    def from_keys(cls, keys: dict, domain: Domain, duration: float):
        return cls(StayIn(keys["lower"], keys["upper"], keys["from"], keys["to"], 1.0, domain))

    def passes(self, x, v, t):
        states = x[window_steps(t, self.box.start, self.box.end)]
        if states.shape[0] == 0:
            return np.zeros(x.shape[1], dtype=bool)
        return np.all(self.box.offsets(states) == 0.0, axis=(0, 2))


@dataclass(frozen=True)
class ExitTest:
    """The particle leaves by ``edge`` within ``halfwidth`` of ``center`` (strictly: the
    funnel's in-band test), between ``from`` and ``to``, at a speed across the edge of at least
    ``min_speed`` (at its first state past the edge)."""

    KIND: ClassVar[str] = "exit"
    KEYS: ClassVar[dict] = {"edge": Key("choice", choices=tuple(EDGES)), "center": Key("number", unit="length"),
                            "halfwidth": Key("positive", unit="length"),
                            "min_speed": Key("nonneg", 0.0, unit="length/time"),
                            "from": Key("nonneg", 0.0, unit="time"), "to": Key("nonneg", math.inf, unit="time")}
    edge: Exit
    min_speed: float
    start: float
    end: float

    @classmethod
    def from_keys(cls, keys: dict, domain: Domain, duration: float):
        return cls(Exit(keys["edge"], keys["center"], keys["halfwidth"], 1.0, domain), keys["min_speed"],
                   keys["from"], keys["to"])

    def passes(self, x, v, t):
        step, exited = self.edge.steps(x)
        axis = EDGES[self.edge.edge][0]
        particle = np.arange(x.shape[1])
        along = self.edge.domain.wrap_axis(x[step, particle, 1 - axis] - self.edge.center, 1 - axis)
        when = np.asarray(t)[step]
        return (exited & (np.abs(along) < self.edge.halfwidth) & (when >= self.start) & (when <= self.end)
                & (np.abs(v[step, particle, axis]) >= self.min_speed))


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

    @classmethod
    def from_keys(cls, keys: dict, domain: Domain, duration: float):
        return cls(keys["time"], keys["axis"], keys["min"], keys["max"])

    def passes(self, x, v, t):
        n = step_at(t, self.time)
        if n is None:
            return np.zeros(x.shape[1], dtype=bool)
        speed = v[n, :, self.axis]
        return (speed >= self.low) & (speed <= self.high)


#: The kinds of success test: ``[[evaluate.success]] kind = ...`` -> its class.
SUCCESS_TESTS = {cls.KIND: cls for cls in (FinalPositionTest, PositionAtTest, StayInTest, ExitTest, SpeedAtTest)}


def passes_all(tests, x, v, t) -> tuple:
    """``(every, each)``: (N,) whether each particle passes every test, and the list of each test's (N,)."""
    each = [test.passes(x, v, t) for test in tests]
    every = np.logical_and.reduce(each) if each else np.zeros(x.shape[1], dtype=bool)
    return every, each
