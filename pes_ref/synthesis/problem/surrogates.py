"""The objective a problem derives from its success tests, when its file states none.

A problem file may leave out ``[[objective]]``: it is then designed on what success means. Each
``[[evaluate.success]]`` test becomes one state term,
[`Surrogate`][pes_ref.synthesis.problem.surrogates.Surrogate], that charges the test's smooth
surrogate ([`pes_ref.synthesis.problem.success`][pes_ref.synthesis.problem.success], each test's
``cost``) summed over the particles: zero for a particle that passes with room to spare
(``[evaluate] margin``, a fraction of each test's tolerance), growing with the squared distance from
passing in units of the test's tolerance, so the terms of tests of different sizes are comparable.
The terms are named ``surrogate_NAME`` after their tests.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Surrogate", "derived_terms", "has_cost", "DEFAULT_MARGIN"]

#: The default ``[evaluate] margin``: the share of a test's tolerance a particle keeps as room to spare.
DEFAULT_MARGIN = 0.25


@dataclass(frozen=True)
class Surrogate:
    """The state term ``sum_i c_i`` of one success test's surrogate ``cost`` with ``margin``."""

    test: object
    margin: float
    name: str

    def value_and_grad(self, x, v, t):
        """``sum(c)`` of the test's ``cost`` with ``margin``, and its ``gx``, ``gv``; the objective
        protocol of [`pes_ref.core.objectives`][pes_ref.core.objectives]."""
        c, gx, gv = self.test.cost(x, v, t, self.margin)
        return float(np.sum(c)), gx, gv


def has_cost(test) -> bool:
    """Whether ``test`` has a surrogate: every test but a custom one without ``cost``, and the
    group and any-of tests made of such."""
    if hasattr(test, "members"):
        return has_cost(test.test)
    if hasattr(test, "CHILDREN"):
        return all(has_cost(child) for child in getattr(test, test.CHILDREN))
    return getattr(test, "has_cost", True)


def derived_terms(tests, margin: float = DEFAULT_MARGIN) -> list:
    """``[(name, Surrogate)]``, one per success test ``(name, test)``."""
    return [(f"surrogate_{name}", Surrogate(test, margin, f"surrogate_{name}")) for name, test in tests]
