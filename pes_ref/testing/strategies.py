"""Hypothesis strategies that draw valid pes_ref scenes, states and objectives.

Another implementation (JAX, PyTorch, C++ through bindings, ...) imports these to run
its own property tests on the same distribution of inputs that ``pes_ref`` is tested
on, and compares with ``pes_ref`` or checks the plain properties of
[`pes_ref.testing`][pes_ref.testing]. Importing this module needs ``hypothesis`` (the
``test`` extra).

The distribution itself is [`pes_ref.testing.draws`][pes_ref.testing.draws] (which ``pes_ref check --random``
draws from with a NumPy Generator, no hypothesis needed); each strategy here is one of its
functions with hypothesis as the source of draws, so that a failing example replays and
shrinks. Examples are small, cheap and numerically tame: grids of 2..12 nodes per axis, a
handful of particles, short runs, bounded grid values, and a time step (or mobility)
safely inside the explicit stability limit of the stiffest term (see
[`pes_ref.testing.energy.max_frequency`][pes_ref.testing.energy.max_frequency]). Random arrays are filled from
``numpy.random.default_rng(seed)`` with the seed drawn by hypothesis (``st.integers``),
never from NumPy's global random state.

Examples
--------
>>> from hypothesis import given
>>> from pes_ref.testing import strategies as pst
>>> @given(pst.scene_cases(mode="dynamic"))
... def test_runs(case):
...     scene, x0, v0 = case
...     my_simulate(scene, x0, v0)   # doctest: +SKIP
"""
from __future__ import annotations

import numpy as np
from hypothesis import strategies as st

from pes_ref.testing import draws

__all__ = ["TOPOLOGIES", "topologies", "seeds", "surfaces", "states", "scenes", "scene_cases",
           "objectives", "exit_paths", "term_cases", "TERM_MARGIN"]

#: The four topologies as ``periodic`` pairs: plane, the two cylinders, torus.
TOPOLOGIES = draws.TOPOLOGIES


def seeds():
    """Seeds for ``numpy.random.default_rng`` (and for [`pes_ref.Noise`][pes_ref.core.effects.Noise]).

    Returns
    -------
    SearchStrategy[int]
        Integers in ``[0, 2**32 - 1]``.
    """
    return st.integers(0, draws.SEED_MAX)


def topologies():
    """The ``periodic`` pair of a surface.

    Returns
    -------
    SearchStrategy[tuple[bool, bool]]
        One of `TOPOLOGIES`: ``(False, False)`` plane, ``(True, False)`` and
        ``(False, True)`` the two cylinders, ``(True, True)`` torus. Shrinks toward the plane.
    """
    return st.sampled_from(TOPOLOGIES)


def _floats(lo, hi):
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False, width=64)


class _Draws:
    """hypothesis's ``draw`` as a source of draws of [`pes_ref.testing.draws`][pes_ref.testing.draws]."""

    def __init__(self, draw):
        self._draw = draw

    def integer(self, lo, hi):
        return self._draw(st.integers(lo, hi))

    def real(self, lo, hi):
        return self._draw(_floats(lo, hi))

    def flag(self):
        return self._draw(st.booleans())

    def choice(self, options):
        return self._draw(st.sampled_from(tuple(options)))

    def sample(self, options, min_size, max_size):
        return self._draw(st.lists(st.sampled_from(tuple(options)), min_size=min_size, max_size=max_size))

    def subset(self, options, min_size=1):
        return self._draw(st.lists(st.sampled_from(tuple(options)), min_size=min_size, unique=True))

    def seed(self):
        return self._draw(seeds())

    def nested(self, fn, *args, **kwargs):
        return self._draw(_STRATEGY[fn](*args, **kwargs))


def _strategy(fn):
    """The hypothesis strategy of a function of [`pes_ref.testing.draws`][pes_ref.testing.draws]. (The name
    is a keyword default so that each strategy has its own label: hypothesis labels a
    composite by its code and defaults, and mutates examples span by label.)"""
    def definition(draw, *args, _draws_function=fn.__name__, **kwargs):
        return getattr(draws, _draws_function)(_Draws(draw), *args, **kwargs)
    return st.composite(definition)


surfaces = _strategy(draws.surface)
surfaces.__doc__ = "Strategy of `pes_ref.testing.draws.surface` (same parameters): a valid Surface."
states = _strategy(draws.state)
states.__doc__ = ("Strategy of `pes_ref.testing.draws.state` (same parameters): initial positions and "
                  "velocities ``(x0, v0)``, each (N, 2).")
scenes = _strategy(draws.scene)
scenes.__doc__ = "Strategy of `pes_ref.testing.draws.scene` (same parameters): a full valid Scene."
scene_cases = _strategy(draws.scene_case)
scene_cases.__doc__ = ("Strategy of `pes_ref.testing.draws.scene_case` (same parameters): "
                       "``(scene, x0, v0)``.")
objectives = _strategy(draws.objective)
objectives.__doc__ = ("Strategy of `pes_ref.testing.draws.objective` (same parameters): "
                      "``(objective, R)``, an objective of docs/spec.md section 6 and a regularization weight.")
#: The strategy that draws each function of `pes_ref.testing.draws` nested in another.
_STRATEGY = {draws.surface: surfaces, draws.state: states, draws.scene: scenes, draws.scene_case: scene_cases,
             draws.objective: objectives}


@st.composite
def exit_paths(draw, *, max_states: int = 8, max_particles: int = 4, margin: float = 1e-3):
    """Positions ``x`` (T+1, N, 2) whose q1 falls through a level, and the level: ``(x, level)``.

    Each particle's q1 decreases from state to state; some particles cross ``level``, some
    may not; no q1 lies within ``margin`` of it (away from the kink where a particle's exit
    step changes, for finite differences of the funnel's exit cost). q0 is uniform in [-1, 1].
    """
    n_states = draw(st.integers(2, max_states))
    n = draw(st.integers(1, max_particles))
    rng = np.random.default_rng(draw(seeds()))
    level = float(rng.uniform(-1.0, 1.0))
    x = np.empty((n_states, n, 2))
    x[:, :, 0] = rng.uniform(-1.0, 1.0, (n_states, n))
    d = np.sort(rng.uniform(-1.0, 1.0, (n_states, n)), axis=0)[::-1]     # q1 - level, falling
    x[:, :, 1] = level + np.where(np.abs(d) < margin, np.copysign(2.0 * margin, d), d)
    return x, level


#: The margin kept from a term's kinks (a box face, an exit level, the minimum-image seam), far
#: beyond the finite-difference step.
TERM_MARGIN = 1e-3


def _away(offset: np.ndarray, half, margin: float = TERM_MARGIN) -> np.ndarray:
    """``offset`` with every ``|offset|`` within ``margin`` of ``half`` moved ``2 margin`` away from it."""
    near = np.abs(np.abs(offset) - half) < margin
    return np.where(near, offset + np.sign(offset) * 2 * margin, offset)


@st.composite
def term_cases(draw, *, max_states: int = 7, max_particles: int = 3):
    """A state term of a problem file (`pes_ref.synthesis.problem.objective_terms.OBJECTIVE_TERMS`,
    every kind but the grid's) on a random domain of any topology, with a trajectory away from
    its kinks: ``(term, x, v, t)``.

    Positions lie within 0.45 of a period of the term's target, box centre or edge centre (plus
    whole periods on a periodic axis, to exercise the minimum image), and no coordinate lies
    within `TERM_MARGIN` of a box face or an exit level; a time is one of the states' (or
    after the run's end, where a term charges nothing).
    """
    from pes_ref.core.objectives import Quadratic
    from pes_ref.synthesis.problem.objective_terms import EDGES, OBJECTIVE_TERMS, Domain

    periodic = draw(topologies())
    kinds = [k for k, cls in OBJECTIVE_TERMS.items() if not hasattr(cls, "grid_value_and_grad")
             and (k != "exit" or not all(periodic))]
    kind = draw(st.sampled_from(sorted(kinds)))
    rng = np.random.default_rng(draw(seeds()))
    lower = rng.uniform(-2.0, 0.0, 2)
    length = rng.uniform(1.0, 3.0, 2)
    domain = Domain(tuple(lower), tuple(lower + length), tuple(periodic))
    n_states, n = draw(st.integers(2, max_states)), draw(st.integers(1, max_particles))
    t = 0.1 * np.arange(n_states)
    shape = (n_states, n, 2)
    v = rng.normal(0.0, 1.0, shape)
    laps = np.where(periodic, rng.integers(-1, 2, shape), 0) * length      # whole periods on periodic axes
    weight = float(rng.uniform(0.1, 3.0))
    time = float(t[rng.integers(n_states)] if rng.uniform() < 0.85 else t[-1] + 0.3)
    point = lambda: tuple(lower + rng.uniform(0, 1, 2) * length)  # noqa: E731

    def near(center, half=0.0):
        return np.asarray(center) + _away(rng.uniform(-0.45, 0.45, shape) * length, half) + laps

    if kind in ("final_position", "position_at"):
        keys = {"target": point(), "weight": weight, "time": time}
        x = near(keys["target"])
    elif kind == "stay_in":
        a, b = point(), point()
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        start, end = sorted(rng.uniform(0.0, t[-1] + 0.2, 2))
        keys = {"lower": tuple(lo), "upper": tuple(hi), "from": float(start), "to": float(end), "weight": weight}
        x = near(0.5 * (lo + hi), 0.5 * (hi - lo))
    elif kind == "speed_at":
        keys = {"time": time, "axis": int(rng.integers(2)), "target": float(rng.normal()), "weight": weight}
        x = near(point())
    elif kind == "cycle":
        keys = {"amplitude": float(rng.uniform(0.2, 2.0)), "omega": float(rng.uniform(0.5, 3.0)),
                "axis": int(rng.integers(2)), "weight": weight}
        x = near(point())
    elif kind == "exit":
        edge = draw(st.sampled_from([e for e, (axis, _) in EDGES.items() if not periodic[axis]]))
        axis, side, level = domain.edge(edge)
        keys = {"edge": edge, "center": float(point()[1 - axis]), "halfwidth": float(rng.uniform(0.0, 0.3)),
                "weight": weight}
        x = near(np.where(np.arange(2) == axis, level, keys["center"]), keys["halfwidth"])
        d = np.sort(rng.uniform(-1.0, 1.0, (n_states, n)), axis=0)                 # distance past the level
        d = d[::-1] if side == "lower" else d
        x[:, :, axis] = level + _away(d, 0.0)
    else:                                                                           # custom
        keys = {"object": Quadratic(wx=float(rng.uniform(0.5, 2)), xref=float(rng.normal()),
                                    wv=float(rng.uniform(0.5, 2)), vref=float(rng.normal())), "weight": weight}
        x = near(point())
    cls = OBJECTIVE_TERMS[kind]
    term = cls.from_keys({k: keys[k] for k in cls.KEYS}, domain, float(t[-1]))
    return term, x, v, t
