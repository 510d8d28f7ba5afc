"""The registry of time steppers: the one place that maps a scene's ``(mode, integrator)``
to the forward loop and its adjoint.

- ``("dynamic", "verlet")``: the paper's damped velocity Verlet, eqs. (2)-(3)
  ([`pes_ref.core.integrator.simulate_dynamic`][pes_ref.core.integrator.simulate_dynamic], docs/spec.md section 5);
- ``("dynamic", "gjf")``: the second-order damped Gronbech-Jensen-Farago step
  ([`pes_ref.core.gjf`][pes_ref.core.gjf], ``docs/variants.md``);
- ``("quasistatic", "verlet")``: the overdamped step ``X_{n+1} = X_n + mu F_n``
  ([`pes_ref.core.integrator.simulate_quasistatic`][pes_ref.core.integrator.simulate_quasistatic];
  quasistatic mode has one step, filed under the default integrator name).

Every entry has the same call signature ([`Stepper`][pes_ref.core.steppers.Stepper]), with the scene's step
parameters in a [`StepParams`][pes_ref.core.steppers.StepParams]; `MODES` and `INTEGRATORS` are read off
the registry. [`Scene`][pes_ref.core.scene.Scene] validates against it and
[`pes_ref.core.scene`][pes_ref.core.scene] dispatches through [`stepper`][pes_ref.core.steppers.stepper].
"""
from __future__ import annotations

from typing import Callable, NamedTuple

import numpy as np

from pes_ref.core.gjf import adjoint_gjf, simulate_gjf
from pes_ref.core.integrator import adjoint_dynamic, adjoint_quasistatic, simulate_dynamic, simulate_quasistatic

__all__ = ["StepParams", "Stepper", "STEPPERS", "MODES", "INTEGRATORS", "stepper", "modes_of", "mode_gradients",
           "for_particles"]


class StepParams(NamedTuple):
    """A scene's step parameters, as the core takes them (validated by the scene).

    ``dt`` float and ``n_steps`` int (T); ``mass`` broadcastable to (N, 2); ``damping``
    broadcastable to (N, 2), or None for an undamped scene (no damping arithmetic at all);
    ``mobility`` (2,) in quasistatic mode, else None; ``progress`` a callback ``(phase, done,
    total)`` called every few hundred steps of the forward loop and of the adjoint
    ([`pes_ref.core.runtime.progress`][pes_ref.core.runtime.progress]), or None;
    ``refuse_nonfinite`` False returns a trajectory that left the finite numbers instead of raising
    (a population checks each member's part, [`pes_ref.core.population`][pes_ref.core.population]);
    ``out`` a [`Trajectory`][pes_ref.core.integrator.Trajectory] of (T+1, N, 2) arrays to run into,
    or None for fresh ones
    ([`pes_ref.core.integrator.trajectory_arrays`][pes_ref.core.integrator.trajectory_arrays]);
    ``energy`` None, or where a dynamic forward loop puts each state's total energy as it makes the
    state, at the state's own grid lookup: its ``out``, a float64 (T+1, N) array, which a loop that
    fills it marks ``filled``; the NumPy loop computes each state's by ``energy.bind(force, field)``
    ([`pes_ref.core.integrator.simulate_dynamic`][pes_ref.core.integrator.simulate_dynamic]), and
    ``energy.part(sl)`` is the sink of the particles ``sl``
    ([`pes_ref.accel.halves`][pes_ref.accel.halves]). A loop that does not (the GJF and quasistatic
    steps, another grid) leaves it, and the energy to a pass after the run
    ([`pes_ref.core.scene.value_and_grad`][pes_ref.core.scene.value_and_grad]).
    """

    dt: float
    n_steps: int
    mass: np.ndarray
    damping: np.ndarray | None
    mobility: np.ndarray | None
    progress: Callable | None = None
    refuse_nonfinite: bool = True
    out: object = None
    energy: object = None


def for_particles(a, sl: slice, n: int):
    """A per-particle parameter (broadcastable to (N, 2)) of a run of ``n`` particles, for the
    particles ``sl``: an array with a row per particle (N, 2) or (N, 1) sliced, one that is the
    same for every particle (a scalar, (2,), (1, 2)) as it is; None as None."""
    if a is None:
        return None
    arr = np.asarray(a)
    return arr[sl] if arr.ndim == 2 and arr.shape[0] == n and n > 1 else a


class Stepper(NamedTuple):
    """A forward loop and its adjoint, with one call signature for every entry, and the
    gradients of the step's own inputs.

    simulate : ``(field, x0, v0, fext, params) -> Trajectory``
        ``field`` a [`Field`][pes_ref.core.forces.Field]; ``x0, v0`` (N, 2) (``v0`` unused
        in quasistatic mode); ``fext`` (T+1, N, 2) or None; ``params`` a
        [`StepParams`][pes_ref.core.steppers.StepParams].
    adjoint : ``(field, traj, params, gx, gv, want) -> dict``
        The backward pass over the forward's ``traj``, with the objective's direct
        derivatives ``gx, gv`` (T+1, N, 2) or None (``gv`` unused in quasistatic mode) and
        the wanted gradient names; returns the raw gradients (see
        [`pes_ref.core.integrator.adjoint_dynamic`][pes_ref.core.integrator.adjoint_dynamic]).
    gradients : tuple of str
        The differentiable inputs of docs/spec.md section 7 that the step itself adds to those
        of every scene (``values``, ``x0``, ``force``, and a spring's): ``v0``, ``mass``,
        ``damping`` in dynamic mode, ``mobility`` in quasistatic mode (where v0, mass and
        damping play no part).
    """

    simulate: Callable
    adjoint: Callable
    gradients: tuple


def _simulate_verlet(field, x0, v0, fext, p: StepParams):
    return simulate_dynamic(field, x0, v0, fext, p.dt, p.n_steps, p.mass, p.damping, p.progress, p.refuse_nonfinite,
                            p.out, p.energy)


def _adjoint_verlet(field, traj, p: StepParams, gx, gv, want):
    return adjoint_dynamic(field, traj, p.dt, p.mass, p.damping, gx, gv, want, p.progress)


def _simulate_gjf(field, x0, v0, fext, p: StepParams):
    return simulate_gjf(field, x0, v0, fext, p.dt, p.n_steps, p.mass, p.damping, p.progress, p.refuse_nonfinite,
                        p.out)


def _adjoint_gjf(field, traj, p: StepParams, gx, gv, want):
    return adjoint_gjf(field, traj, p.dt, p.mass, p.damping, gx, gv, want, p.progress)


def _simulate_quasistatic(field, x0, v0, fext, p: StepParams):
    return simulate_quasistatic(field, x0, fext, p.mobility, p.n_steps, p.progress, p.refuse_nonfinite, p.out)


def _adjoint_quasistatic(field, traj, p: StepParams, gx, gv, want):
    return adjoint_quasistatic(field, traj, p.mobility, gx, want, p.progress)


_DYNAMIC_GRADIENTS = ("v0", "mass", "damping")

#: Every stepper by ``(mode, integrator)``.
STEPPERS = {
    ("dynamic", "verlet"): Stepper(_simulate_verlet, _adjoint_verlet, _DYNAMIC_GRADIENTS),
    ("dynamic", "gjf"): Stepper(_simulate_gjf, _adjoint_gjf, _DYNAMIC_GRADIENTS),
    ("quasistatic", "verlet"): Stepper(_simulate_quasistatic, _adjoint_quasistatic, ("mobility",)),
}

#: The modes of docs/spec.md section 5, in registry order.
MODES = tuple(dict.fromkeys(mode for mode, _ in STEPPERS))
#: The integrator names, in registry order ("verlet" is the default and the paper's).
INTEGRATORS = tuple(dict.fromkeys(integrator for _, integrator in STEPPERS))


def mode_gradients(mode: str) -> tuple:
    """The gradients the steps of ``mode`` add (`Stepper.gradients`, the same for
    every integrator of a mode); a ValueError that names ``mode`` if no stepper has it."""
    names = [g for (m, _), entry in STEPPERS.items() if m == mode for g in entry.gradients]
    if not names:
        raise ValueError(f"mode must be one of {sorted(MODES)}, got {mode!r}")
    return tuple(dict.fromkeys(names))


def modes_of(integrator: str) -> tuple:
    """The modes that have the integrator ``integrator``, in registry order."""
    return tuple(mode for mode, name in STEPPERS if name == integrator)


def stepper(mode: str, integrator: str) -> Stepper:
    """The registered stepper of ``(mode, integrator)``; a ValueError that names the pair
    (and what the registry has) if there is none."""
    try:
        return STEPPERS[(mode, integrator)]
    except (KeyError, TypeError):
        raise ValueError(f"no stepper for mode={mode!r} with integrator={integrator!r}; "
                         f"the registered ones are {list(STEPPERS)}") from None
