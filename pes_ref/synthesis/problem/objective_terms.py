"""The objective terms of a problem file: what each ``[[objective]]`` entry charges, and its derivative.

A *state term* is a frozen object with the objective method of [`pes_ref.core.objectives`][pes_ref.core.objectives],
``value_and_grad(x, v, t) -> (value, gx, gv)`` on a trajectory's positions and velocities
(T+1, N, 2) and times (T+1,); a *grid term* has ``grid_value_and_grad(values) -> (value,
grad)`` on the grid values instead (eq. (7)). A problem's objective is the sum of its
terms ([`TermSum`][pes_ref.synthesis.problem.objective_terms.TermSum] for the state terms). `OBJECTIVE_TERMS` maps a kind to its
class (dispatch by data): a class declares its file keys (``KEYS``, [`.file_keys`][pes_ref.synthesis.problem.file_keys]) and
builds itself from them (``from_keys``), so a new kind of term, on the states or on the
grid, is one more entry.

Every term is a sum over the particles, like the paper's eq. (5) (``cycle`` keeps eq. (6)'s own
normalization), times its ``weight``. Positions are the unwrapped states of the simulation; a
difference along a periodic axis is taken the short way round (the minimum image,
[`Domain.wrap`][pes_ref.synthesis.problem.objective_terms.Domain.wrap]). Where a term is not smooth
in the states the paper's maths leaves a choice, and the term takes the smooth penalty form:

- ``stay_in`` charges the squared distance to the box (zero inside it), whose derivative is
  continuous at the box's faces, rather than an indicator;
- ``exit`` is eq. (5) at the state where a particle first crosses the edge
  ([`pes_ref.synthesis.common.exits.exit_steps`][pes_ref.synthesis.common.exits.exit_steps]); that step is piecewise constant in the
  grid values, so the derivative holds away from the values where it changes (the
  funnel's exit charge, ``docs/synthesis.md`` decision 8);
- a time (``position_at``, ``speed_at``, a window's ends) is taken at the state nearest to it.

A term whose time lies after the end of the run it is given (a coarse-to-fine stage's
shorter horizon) charges nothing.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import numpy as np

from pes_ref.core.objectives import Custom, Oscillator, regularization
from pes_ref.synthesis.common.exits import exit_steps
from pes_ref.synthesis.problem.file_keys import Key, from_table

__all__ = ["Domain", "EDGES", "OBJECTIVE_TERMS", "TermSum", "FinalPosition", "PositionAt", "StayIn", "SpeedAt",
           "Cycle", "Exit", "Regularization", "CustomTerm", "CustomTermError", "call_user", "excess", "step_at", "window_steps"]

#: The edges a particle may leave by: name -> (axis crossed, side).
EDGES = {"q0_lower": (0, "lower"), "q0_upper": (0, "upper"), "q1_lower": (1, "lower"), "q1_upper": (1, "upper")}


class Domain(NamedTuple):
    """The surface's domain: ``lower``, ``upper`` (2,) and which axes are ``periodic``."""

    lower: tuple
    upper: tuple
    periodic: tuple

    def wrap(self, d: np.ndarray) -> np.ndarray:
        """Differences ``d`` (..., 2) taken the short way round on the periodic axes (a copy)."""
        d = np.array(d, dtype=np.float64)
        for axis in (0, 1):
            if self.periodic[axis]:
                length = self.upper[axis] - self.lower[axis]
                d[..., axis] -= length * np.round(d[..., axis] / length)
        return d

    def wrap_axis(self, d: np.ndarray, axis: int) -> np.ndarray:
        """Differences ``d`` along one ``axis``, the short way round if it is periodic."""
        if not self.periodic[axis]:
            return d
        length = self.upper[axis] - self.lower[axis]
        return d - length * np.round(d / length)

    def edge(self, name: str) -> tuple:
        """``(axis, side, level)`` of edge ``name`` (`EDGES`)."""
        axis, side = EDGES[name]
        return axis, side, (self.lower if side == "lower" else self.upper)[axis]


def excess(d: np.ndarray, half: np.ndarray | float) -> np.ndarray:
    """``d - clip(d, -half, half)``: how far ``d`` lies outside ``[-half, half]`` (0 inside)."""
    return d - np.clip(d, -half, half)


def _dt(t: np.ndarray) -> float:
    return float(t[1] - t[0]) if t.shape[0] > 1 else 0.0


def step_at(t: np.ndarray, time: float):
    """The index of the state nearest to ``time``, or None if ``time`` is after the run's end."""
    t = np.asarray(t)
    if time > t[-1] + 0.5 * _dt(t):
        return None
    return int(np.argmin(np.abs(t - time)))


def window_steps(t: np.ndarray, start: float, end: float) -> slice:
    """The states from the one nearest ``start`` to the one nearest ``end`` (the run's last
    if ``end`` is after it); empty if ``start`` is after the run's end."""
    first = step_at(t, start)
    if first is None:
        return slice(0, 0)
    last = step_at(t, end)
    return slice(first, np.asarray(t).shape[0] if last is None else last + 1)


_WEIGHT = {"weight": Key("nonneg", 1.0)}


# =========================================================================== state terms

@dataclass(frozen=True)
class FinalPosition:
    """``weight sum_i |X_{T,i} - target|^2`` (both axes): particles end near ``target``."""

    KIND: ClassVar[str] = "final_position"
    KEYS: ClassVar[dict] = {"target": Key("point", unit="length"), **_WEIGHT}
    target: tuple
    weight: float
    domain: Domain

    from_keys = classmethod(from_table)

    def value_and_grad(self, x, v, t):
        """The term and its ``gx`` (``gv`` is None); a state term: the objective protocol of
        [`pes_ref.core.objectives`][pes_ref.core.objectives] (this module's docstring)."""
        return _position_cost(x, -1, self.target, self.weight, self.domain)


@dataclass(frozen=True)
class PositionAt:
    """``weight sum_i |X_{n,i} - target|^2`` at the state ``n`` nearest ``time``."""

    KIND: ClassVar[str] = "position_at"
    KEYS: ClassVar[dict] = {"time": Key("nonneg", unit="time"), "target": Key("point", unit="length"), **_WEIGHT}
    time: float
    target: tuple
    weight: float
    domain: Domain

    from_keys = classmethod(from_table)

    def value_and_grad(self, x, v, t):
        """The term and its ``gx`` (``gv`` is None; 0 and no derivative when ``time`` is after the run's end);
        a state term: the objective protocol of [`pes_ref.core.objectives`][pes_ref.core.objectives] (this module's docstring)."""
        n = step_at(t, self.time)
        if n is None:
            return 0.0, None, None
        return _position_cost(x, n, self.target, self.weight, self.domain)


def _position_cost(x, n: int, target, weight: float, domain: Domain):
    e = domain.wrap(x[n] - np.asarray(target))
    gx = np.zeros_like(x)
    gx[n] = 2.0 * weight * e
    return weight * float(np.sum(e * e)), gx, None


@dataclass(frozen=True)
class StayIn:
    """``weight sum_i mean_n |X_{n,i} - box|^2`` over the states from ``start`` to ``end``.

    ``|X - box|`` is the distance from the box ``[lower, upper]`` (zero inside it), per axis
    ``e = d - clip(d, -h, h)`` with ``d`` the offset from the box's centre and ``h`` its half
    size; its derivative ``2 weight e / n_window`` is continuous at the faces. The mean over
    the window's states makes ``weight`` a squared distance whatever the window's length.
    """

    KIND: ClassVar[str] = "stay_in"
    KEYS: ClassVar[dict] = {"lower": Key("point", unit="length"), "upper": Key("point", unit="length"),
                            "from": Key("nonneg", 0.0, unit="time"), "to": Key("nonneg", math.inf, unit="time"),
                            **_WEIGHT}
    lower: tuple
    upper: tuple
    start: float
    end: float
    weight: float
    domain: Domain

    from_keys = classmethod(from_table)

    def offsets(self, x: np.ndarray) -> np.ndarray:
        """How far each state lies outside the box, per axis (..., 2)."""
        lower, upper = np.asarray(self.lower), np.asarray(self.upper)
        return excess(self.domain.wrap(x - 0.5 * (lower + upper)), 0.5 * (upper - lower))

    def value_and_grad(self, x, v, t):
        """The term and its ``gx`` (``gv`` is None; 0 and no derivative when the window holds no state);
        a state term: the objective protocol of [`pes_ref.core.objectives`][pes_ref.core.objectives] (this module's docstring)."""
        w = window_steps(t, self.start, self.end)
        states = x[w]
        if states.shape[0] == 0:
            return 0.0, None, None
        e = self.offsets(states)
        scale = self.weight / states.shape[0]
        gx = np.zeros_like(x)
        gx[w] = 2.0 * scale * e
        return scale * float(np.sum(e * e)), gx, None


@dataclass(frozen=True)
class SpeedAt:
    """``weight sum_i (V_{n,i,axis} - target)^2`` at the state ``n`` nearest ``time``
    (a signed velocity along ``axis``)."""

    KIND: ClassVar[str] = "speed_at"
    KEYS: ClassVar[dict] = {"time": Key("nonneg", unit="time"), "axis": Key("axis"),
                            "target": Key("number", unit="length/time"), **_WEIGHT}
    time: float
    axis: int
    target: float
    weight: float

    from_keys = classmethod(from_table)

    def value_and_grad(self, x, v, t):
        """The term and its ``gv`` (``gx`` is None; 0 and no derivative when ``time`` is after the run's end);
        a state term: the objective protocol of [`pes_ref.core.objectives`][pes_ref.core.objectives] (this module's docstring)."""
        n = step_at(t, self.time)
        if n is None:
            return 0.0, None, None
        e = v[n, :, self.axis] - self.target
        gv = np.zeros_like(v)
        gv[n, :, self.axis] = 2.0 * self.weight * e
        return self.weight * float(np.sum(e * e)), None, gv


@dataclass(frozen=True)
class Cycle:
    """The paper's eq. (6) on ``axis``, times ``weight``: every state is charged its RMS distance
    in phase space from the undamped cycle ``A cos(w t)`` ([`pes_ref.core.objectives.Oscillator`][pes_ref.core.objectives.Oscillator])."""

    KIND: ClassVar[str] = "cycle"
    KEYS: ClassVar[dict] = {"amplitude": Key("positive", unit="length"), "omega": Key("positive", unit="rad/time"),
                            "axis": Key("axis", 0), **_WEIGHT}
    amplitude: float
    omega: float
    axis: int
    weight: float

    from_keys = classmethod(from_table)

    def value_and_grad(self, x, v, t):
        """Eq. (6) on ``axis`` times ``weight``, with its ``gx`` and ``gv``; a state term: the objective
        protocol of [`pes_ref.core.objectives`][pes_ref.core.objectives] (this module's docstring)."""
        # eq. (6) is on axis 0: give the chosen axis that place (a view), and the derivative back
        order = slice(None) if self.axis == 0 else slice(None, None, -1)
        value, gx, gv = Oscillator(self.amplitude, self.omega).value_and_grad(x[..., order], v[..., order], t)
        return self.weight * value, self.weight * gx[..., order], self.weight * gv[..., order]


@dataclass(frozen=True)
class Exit:
    """Eq. (5) where a particle leaves by ``edge``: ``weight sum_i e_i^2`` with ``e_i`` how far
    its position along the edge at its exit step lies outside ``[center - halfwidth,
    center + halfwidth]`` (``halfwidth`` 0: the paper's ``(x_i - x_0)^2``).

    The exit step is the first state at or past the edge
    ([`pes_ref.synthesis.common.exits.exit_steps`][pes_ref.synthesis.common.exits.exit_steps]),
    or the last state for a particle that never leaves; ``dL/dX`` is ``2 weight e_i`` along the
    edge at that state and zero elsewhere, away from the grid values where an exit step changes.
    """

    KIND: ClassVar[str] = "exit"
    KEYS: ClassVar[dict] = {"edge": Key("choice", choices=tuple(EDGES)), "center": Key("number", unit="length"),
                            "halfwidth": Key("nonneg", 0.0, unit="length"), **_WEIGHT}
    edge: str
    center: float
    halfwidth: float
    weight: float
    domain: Domain

    def __post_init__(self):
        if self.domain.periodic[EDGES[self.edge][0]]:
            raise ValueError(f"edge {self.edge!r} is on a periodic axis, which has no edge to leave by")

    from_keys = classmethod(from_table)


    def steps(self, x: np.ndarray):
        """Each particle's exit step and whether it exits ([`pes_ref.synthesis.common.exits.exit_steps`][pes_ref.synthesis.common.exits.exit_steps])."""
        axis, side, level = self.domain.edge(self.edge)
        return exit_steps(x, level, axis, side)

    def value_and_grad(self, x, v, t):
        """The term and its ``gx`` (``gv`` is None); a state term: the objective protocol of
        [`pes_ref.core.objectives`][pes_ref.core.objectives] (this module's docstring)."""
        step, _ = self.steps(x)
        along = 1 - EDGES[self.edge][0]
        particle = np.arange(x.shape[1])
        e = excess(self.domain.wrap_axis(x[step, particle, along] - self.center, along), self.halfwidth)
        gx = np.zeros_like(x)
        gx[step, particle, along] = 2.0 * self.weight * e
        return self.weight * float(np.sum(e * e)), gx, None


class CustomTermError(ValueError):
    """A user's own object (a ``custom`` term or success test) failed; the message names it."""


def call_user(label: str, fn, *args):
    """``fn(*args)`` of a user's own object, whatever it raises reworded as one
    [`CustomTermError`][pes_ref.synthesis.problem.objective_terms.CustomTermError] that starts with ``label``; a
    FloatingPointError (a non-finite run,
    which a design stops on) passes as it is."""
    try:
        return fn(*args)
    except FloatingPointError:
        raise
    except Exception as exc:
        said = str(exc) if isinstance(exc, ValueError) else f"{type(exc).__name__}: {exc}"
        raise CustomTermError(f"{label}: {said}") from exc


@dataclass(frozen=True)
class CustomTerm:
    """A user's own objective, ``object.value_and_grad(x, v, t) -> (value, gx, gv)``, times
    ``weight``; its shapes are checked on every call
    ([`pes_ref.core.objectives.Custom`][pes_ref.core.objectives.Custom]). In a file ``object`` is
    ``"module:object"`` (imported and checked when the file is read,
    [`.file_keys`][pes_ref.synthesis.problem.file_keys]); in code, the object itself. Whatever the
    object raises comes out as one
    [`CustomTermError`][pes_ref.synthesis.problem.objective_terms.CustomTermError] naming the term
    by ``label`` (``objective[1] (custom 'spread', mymod:SPREAD)``), except a FloatingPointError: a
    non-finite run, which the design stops on."""

    KIND: ClassVar[str] = "custom"
    KEYS: ClassVar[dict] = {"object": Key("object"), **_WEIGHT}
    obj: object
    weight: float
    name: str = "custom"
    label: str = "a custom term"

    @classmethod
    def from_keys(cls, keys: dict, domain: Domain, duration: float):
        """The term from its ``[[objective]]`` entry's checked keys (``KEYS``), on ``domain``; how the
        problem file's reader builds every term (this module's docstring)."""
        return cls(keys["object"], keys["weight"])

    def value_and_grad(self, x, v, t):
        """The object's ``value_and_grad`` checked as [`pes_ref.core.objectives.Custom`][pes_ref.core.objectives.Custom]
        checks it, each
        part times ``weight``; what it raises as one
        [`CustomTermError`][pes_ref.synthesis.problem.objective_terms.CustomTermError]; a state term: the objective
        protocol of [`pes_ref.core.objectives`][pes_ref.core.objectives] (this module's docstring)."""
        value, gx, gv = call_user(self.label, Custom(self.obj.value_and_grad, self.name).value_and_grad, x, v, t)
        w = self.weight
        return w * value, None if gx is None else w * gx, None if gv is None else w * gv


# =========================================================================== grid terms

@dataclass(frozen=True)
class Regularization:
    """The paper's eq. (7) on the grid values, ``R sum_ij G_ij^2`` ([`pes_ref.core.objectives.regularization`][pes_ref.core.objectives.regularization])."""

    KIND: ClassVar[str] = "regularization"
    KEYS: ClassVar[dict] = {"R": Key("nonneg", unit="1/energy")}
    R: float

    from_keys = classmethod(from_table)

    def grid_value_and_grad(self, values):
        """``(R sum_ij G_ij^2, 2 R G)`` of the grid ``values`` (``(0.0, None)`` when R is 0); a grid term
        (this module's docstring)."""
        return regularization(values, self.R)


#: The kinds of objective term: ``[[objective]] kind = ...`` -> its class.
OBJECTIVE_TERMS = {cls.KIND: cls for cls in (FinalPosition, PositionAt, StayIn, SpeedAt, Cycle, Exit, CustomTerm,
                                             Regularization)}


def is_grid_term(term) -> bool:
    """Whether ``term`` charges the grid values (a grid term) rather than the states."""
    return hasattr(term, "grid_value_and_grad")


class TermSum:
    """The sum of state terms: one objective (``value_and_grad``) for the adjoint, and each
    term's value on its own ([`values`][pes_ref.synthesis.problem.objective_terms.TermSum.values])."""

    def __init__(self, terms):
        self.terms = tuple(terms)

    def value_and_grad(self, x, v, t):
        """The sum of the terms' values and derivatives (None where every term's is None); the objective
        protocol of [`pes_ref.core.objectives`][pes_ref.core.objectives]."""
        total, gx, gv = 0.0, None, None
        for term in self.terms:
            value, tx, tv = term.value_and_grad(x, v, t)
            total += value
            gx = _add(gx, tx)
            gv = _add(gv, tv)
        return total, gx, gv

    def values(self, x, v, t) -> list:
        """Each term's value on the trajectory, in order."""
        return [term.value_and_grad(x, v, t)[0] for term in self.terms]


def _add(acc, g):
    if g is None:
        return acc
    return g if acc is None else acc + g
