"""What a realization needs of each kind of design, read off its entry's realization hooks.

Each kind of design (`pes_ref.synthesis.kinds.registry.KINDS`) states, in its ``realizable``
([`pes_ref.synthesis.kinds.registry.Realizable`][pes_ref.synthesis.kinds.registry.Realizable]), where its particles go (the paths the
``visited`` contact rule and the drawing read), where an analysis of its device starts, and the
eq. (1) its parts' surface takes; the contact realization and the drawing ask here.
"""
from __future__ import annotations

import numpy as np

from pes_ref.synthesis.kinds.registry import kind_of

__all__ = ["contact_parameters", "start_point", "held_out_positions"]


def contact_parameters(problem, energy) -> tuple:
    """Eq. (1)'s ``(v, r_c, r_min)`` of ``problem``'s parts (``energy``: the design's surface grid)."""
    return tuple(float(x) for x in kind_of(problem).realizable.contact(problem, energy))


def start_point(problem) -> list:
    """Where an analysis of ``problem``'s device starts."""
    return kind_of(problem).realizable.start(problem)


def held_out_positions(problem, values, seed: int, n_particles: int = 200) -> np.ndarray:
    """Every state (T+1, N, 2) of ``n_particles`` paths of design ``values`` from ``default_rng(seed)``."""
    return kind_of(problem).realizable.positions(problem, values, seed, n_particles)
