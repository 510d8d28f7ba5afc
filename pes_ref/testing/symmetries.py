"""Symmetries a run must keep, for any ``simulate``: a particle shifted by whole periods
of a periodic axis, and the grid rolled along one with everything moved with it, give
the same run up to the shift ([`check_periodic_shift`][pes_ref.testing.symmetries.check_periodic_shift],
[`check_grid_roll`][pes_ref.testing.symmetries.check_grid_roll]).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from pes_ref.core.scene import Scene
from pes_ref.core.scene import energy as _energy
from pes_ref.core.terms import Spring
from pes_ref.oracle.compare import relative_error
from pes_ref.testing.kinks import kink_distance

__all__ = ["ShiftCheck", "check_periodic_shift", "rolled_scene", "check_grid_roll"]


def _run(simulate_fn, scene, x0, v0, **kw):
    return simulate_fn(scene, np.asarray(x0, dtype=np.float64), np.asarray(v0, dtype=np.float64), **kw)


def _compare_runs(scene_a, a, scene_b, b, shift, energy_fn) -> dict:
    """Relative differences of two runs whose positions should differ by ``shift``."""
    energy_fn = _energy if energy_fn is None else energy_fn
    Ea = np.asarray(energy_fn(scene_a, a))
    Eb = np.asarray(energy_fn(scene_b, b))
    return {
        "force0": relative_error(b.f[0], a.f[0]),
        "force": relative_error(b.f, a.f),
        "x": _shifted_difference(a.x, b.x, shift),
        "v": relative_error(b.v, a.v),
        "energy": relative_error(Eb, Ea),
    }


def _shifted_difference(xa, xb, shift) -> float:
    """``max |(xb - shift) - xa|`` over the largest position of either run: ``xb`` holds
    the shifted coordinates, whose rounding is relative to their own size."""
    xa, xb = np.asarray(xa), np.asarray(xb)
    diff = float(np.max(np.abs((xb - shift) - xa), initial=0.0))
    if diff == 0.0:
        return 0.0
    return diff / max(float(np.max(np.abs(xa))), float(np.max(np.abs(xb))))


@dataclass(frozen=True)
class ShiftCheck:
    """The outcome of [`check_periodic_shift`][pes_ref.testing.symmetries.check_periodic_shift] and
    [`check_grid_roll`][pes_ref.testing.symmetries.check_grid_roll].

    Attributes
    ----------
    differences : dict str -> float
        Relative errors
        ([`pes_ref.oracle.compare.relative_error`][pes_ref.oracle.compare.relative_error]) of
        ``force0`` (the force at state 0), ``force``, ``x`` (after subtracting the shift; scaled by
        the largest position of either run), ``v`` and ``energy`` (per state and particle). All are
        rounding-level (~1e-13) unless a position lies within rounding of a kink.
    kink_distance : float
        [`kink_distance`][pes_ref.testing.kinks.kink_distance] of the unshifted run: within rounding of a kink, the two
        lookups may pick different cells (either one-sided value is allowed there).
    """

    differences: dict
    kink_distance: float

    @property
    def max_difference(self) -> float:
        """The largest of `differences`."""
        return max(self.differences.values())


def check_periodic_shift(simulate_fn, scene: Scene, x0, v0, *, particle: int = 0, axis: int = 0,
                         periods: int = 1, energy_fn=None) -> ShiftCheck:
    """Shift one particle by whole periods on a periodic axis and compare the runs.

    The lookup wraps, so the shifted particle feels the same force and the run has the
    same velocities and energies; its unwrapped positions differ by exactly
    ``periods * L`` (the state is never wrapped, docs/spec.md section 2.1).

    Returns
    -------
    ShiftCheck
    """
    s = scene.surface
    if not s.periodic[axis]:
        raise ValueError(f"axis {axis} is not periodic (periodic={s.periodic})")
    x0 = np.array(x0, dtype=np.float64)
    xs = x0.copy()
    xs[particle, axis] += periods * s.length[axis]
    a = _run(simulate_fn, scene, x0, v0)
    b = _run(simulate_fn, scene, xs, v0)
    shift = np.zeros_like(np.asarray(a.x))
    shift[:, particle, axis] = periods * s.length[axis]
    return ShiftCheck(_compare_runs(scene, a, scene, b, shift, energy_fn), kink_distance(scene, a.x))


def rolled_scene(scene: Scene, axis: int, k: int) -> tuple:
    """``(scene', dq)``: the grid rolled by ``k`` nodes along ``axis``
    (``np.roll(values, k, axis)``) and the spring centre moved by ``dq = k h e_axis``."""
    s = scene.surface
    dq = np.zeros(2)
    dq[axis] = k * s.spacing[axis]
    rolled = scene.with_values(np.roll(s.values, k, axis=axis))
    if scene.spring is not None:
        rolled = replace(rolled, spring=Spring(scene.spring.k, scene.spring.center + dq))
    return rolled, dq


def check_grid_roll(simulate_fn, scene: Scene, x0, v0, *, axis: int = 0, k: int = 1,
                    energy_fn=None) -> ShiftCheck:
    """Roll the grid by ``k`` nodes along a periodic axis and shift everything with it.

    ``values' = np.roll(values, k, axis)`` puts node ``i`` at ``i + k``; moving every particle (and
    the spring centre, [`rolled_scene`][pes_ref.testing.symmetries.rolled_scene]) by ``k h`` along
    that axis must give the same run, positions shifted by ``k h``.

    Returns
    -------
    ShiftCheck
    """
    if not scene.surface.periodic[axis]:
        raise ValueError(f"axis {axis} is not periodic (periodic={scene.surface.periodic})")
    rolled, dq = rolled_scene(scene, axis, k)
    x0 = np.asarray(x0, dtype=np.float64)
    a = _run(simulate_fn, scene, x0, v0)
    b = _run(simulate_fn, rolled, x0 + dq, v0)
    shift = np.broadcast_to(dq, np.shape(a.x))
    return ShiftCheck(_compare_runs(scene, a, rolled, b, shift, energy_fn), kink_distance(scene, a.x))
