"""Hypothesis strategies that draw valid pes_ref scenes, states and objectives.

Another implementation (JAX, PyTorch, C++ through bindings, ...) imports these to run
its own property tests on the same distribution of inputs that ``pes_ref`` is tested
on, and compares with ``pes_ref`` or checks the plain properties of
:mod:`pes_ref.testing`. Importing this module needs ``hypothesis`` (the
``test`` extra).

The distribution itself is :mod:`pes_ref.testing.draws` (which ``pes_ref check --random``
draws from with a NumPy Generator, no hypothesis needed); each strategy here is one of its
functions with hypothesis as the source of draws, so that a failing example replays and
shrinks. Examples are small, cheap and numerically tame: grids of 2..12 nodes per axis, a
handful of particles, short runs, bounded grid values, and a time step (or mobility)
safely inside the explicit stability limit of the stiffest term (see
:func:`pes_ref.testing.energy.max_frequency`). Random arrays are filled from
``numpy.random.default_rng(seed)`` with the seed drawn by hypothesis (``st.integers``),
never from NumPy's global random state.

Example
-------
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
           "objectives", "exit_paths"]

#: The four topologies as ``periodic`` pairs: plane, the two cylinders, torus.
TOPOLOGIES = draws.TOPOLOGIES


def seeds():
    """Seeds for ``numpy.random.default_rng`` (and for :class:`pes_ref.Noise`).

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
        One of :data:`TOPOLOGIES`: ``(False, False)`` plane, ``(True, False)`` and
        ``(False, True)`` the two cylinders, ``(True, True)`` torus. Shrinks toward the plane.
    """
    return st.sampled_from(TOPOLOGIES)


def _floats(lo, hi):
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False, width=64)


class _Draws:
    """hypothesis's ``draw`` as a source of draws of :mod:`pes_ref.testing.draws`."""

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
    """The hypothesis strategy of a function of :mod:`pes_ref.testing.draws`. (The name
    is a keyword default so that each strategy has its own label: hypothesis labels a
    composite by its code and defaults, and mutates examples span by label.)"""
    def definition(draw, *args, _draws_function=fn.__name__, **kwargs):
        return getattr(draws, _draws_function)(_Draws(draw), *args, **kwargs)
    return st.composite(definition)


surfaces = _strategy(draws.surface)
surfaces.__doc__ = "Strategy of :func:`pes_ref.testing.draws.surface` (same parameters): a valid Surface."
states = _strategy(draws.state)
states.__doc__ = ("Strategy of :func:`pes_ref.testing.draws.state` (same parameters): initial positions and "
                  "velocities ``(x0, v0)``, each (N, 2).")
scenes = _strategy(draws.scene)
scenes.__doc__ = "Strategy of :func:`pes_ref.testing.draws.scene` (same parameters): a full valid Scene."
scene_cases = _strategy(draws.scene_case)
scene_cases.__doc__ = ("Strategy of :func:`pes_ref.testing.draws.scene_case` (same parameters): "
                       "``(scene, x0, v0)``.")
objectives = _strategy(draws.objective)
objectives.__doc__ = ("Strategy of :func:`pes_ref.testing.draws.objective` (same parameters): "
                      "``(objective, R)``, an objective of docs/spec.md section 6 and a regularization weight.")
#: The strategy that draws each function of :mod:`pes_ref.testing.draws` nested in another.
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
