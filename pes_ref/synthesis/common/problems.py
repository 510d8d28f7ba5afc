"""What the paper's two design problems share: a training batch, the base class and the fields' checks.

A *problem* is a frozen dataclass holding the physics of one scene (domain, forces,
damping, objective, particle sampler) at a final grid resolution; `pes_ref.synthesis.kinds.registry.KINDS`
holds them as kinds of design. Each problem draws a training batch ([`Batch`][pes_ref.synthesis.common.problems.Batch]) from a
generator it is given, with the objective that scores it, and scores a batch's trajectory with
its design metric (``batch_metric``). The funnel is [`pes_ref.synthesis.kinds.funnel`][pes_ref.synthesis.kinds.funnel], the
oscillator [`pes_ref.synthesis.kinds.oscillator`][pes_ref.synthesis.kinds.oscillator], a problem file's problem
[`pes_ref.synthesis.problem.design_problem`][pes_ref.synthesis.problem.design_problem]. How a problem is optimized is a plan
([`pes_ref.synthesis.common.plans`][pes_ref.synthesis.common.plans]); see ``docs/synthesis.md`` for the choices the paper leaves open.
"""
from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np

from pes_ref.core import checks
from pes_ref.core.scene import Scene
from pes_ref.synthesis.common.resampling import resample, resample_vjp

__all__ = ["Batch"]


class Batch(NamedTuple):
    """One iteration's particles: starts (N, 2), velocities (N, 2), the scene with their effects,
    the objective that scores their trajectory, and what the grid values cost beyond the
    problem's eq. (7) (``grid_cost(values) -> (value, dL/dG or None)``; None: nothing)."""

    x0: np.ndarray
    v0: np.ndarray
    scene: Scene
    objective: object
    grid_cost: object = None


class _Problem:
    """What both problems share: the initial grid, the flat surface, the design mask, and
    how the grid values become the surface (the values themselves, unless the problem's
    `level_set` makes them a shape: [`pes_ref.synthesis.common.level_set`][pes_ref.synthesis.common.level_set])."""

    #: None: the grid values are the surface's energies.
    level_set = None

    def surface_values(self, values) -> np.ndarray:
        """The surface's grid values of design ``values``: the values, or with a level set
        eq. (1) of their shape on the problem's own grid (`shape`)."""
        if self.level_set is None:
            return values
        fine = resample(values, self.lower, self.upper, self.periodic, self.shape())
        return self.level_set.energy(fine, self.lower, self.upper, self.periodic)

    def values_grad(self, values, grad_surface) -> np.ndarray:
        """dL/d(design values) from dL/d(surface values) (`surface_values` transposed)."""
        if self.level_set is None:
            return grad_surface
        fine = resample(values, self.lower, self.upper, self.periodic, self.shape())
        grad = self.level_set.vjp(fine, grad_surface, self.lower, self.upper, self.periodic)
        return resample_vjp(grad, np.shape(values), self.periodic)

    def mask(self, shape: tuple) -> np.ndarray:
        """1.0 where a grid value is designed (everywhere unless a problem holds some at zero)."""
        return np.ones(shape)

    def initial_values(self, rng, shape: tuple) -> np.ndarray:
        """Small random values (std ``init_scale``) to break symmetry, zero where held."""
        return rng.standard_normal(shape) * self.init_scale * self.mask(shape)

    def final_values(self, values) -> np.ndarray:
        """The grid a finished gradient stage delivers (``values`` itself unless a problem says
        otherwise: a realizable funnel from the ``"envelope"``)."""
        return values

    def flat_values(self, shape: tuple | None = None) -> np.ndarray:
        """The flat starting surface: zeros."""
        return np.zeros(self.shape() if shape is None else shape)

    def plain(self):
        """This problem with its grid values the surface's energies (a realizable design's level
        set turned off): what runs a surface given as energies, such as a realized device's."""
        return self


#: The fields that count grid nodes along an axis (a surface needs 2 at least).
_GRID_FIELDS = ("grid", "grid0", "grid1")
#: The float fields that must be > 0: lengths of the domain, the step, masses, stiffnesses,
#: the target cycle and the gait (each is divided by, or a zero makes the scene meaningless).
_POSITIVE_FIELDS = ("width", "height", "dt", "wall_k", "q0_extent", "amplitude", "omega", "mass", "gait_delta",
                    "shooting_periods", "contact_v", "contact_r_c", "contact_r_min")


def _check_fields(problem) -> None:
    """Validate every numeric field: ints > 0 (grid node counts >= 2), floats finite and
    >= 0 (> 0 for `_POSITIVE_FIELDS`; ``target`` any finite)."""
    for f in dataclasses.fields(problem):
        val = getattr(problem, f.name)
        if isinstance(f.default, bool) or isinstance(f.default, str):
            continue
        if f.name in _GRID_FIELDS:
            object.__setattr__(problem, f.name, checks.as_int_at_least(f.name, val, 2))
        elif isinstance(f.default, int):
            object.__setattr__(problem, f.name, checks.as_positive_int(f.name, val))
        elif f.name == "target":
            object.__setattr__(problem, f.name, checks.as_finite_float(f.name, val))
        elif f.name in _POSITIVE_FIELDS:
            object.__setattr__(problem, f.name, checks.as_positive_float(f.name, val))
        else:
            object.__setattr__(problem, f.name, checks.as_nonneg_float(f.name, val))
