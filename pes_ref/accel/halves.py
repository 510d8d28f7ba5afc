"""A NumPy run of many particles as two halves on two threads.

Particles never interact, so a run of N particles is two runs, of particles ``0 .. N//2 - 1`` and
``N//2 .. N - 1``, on the same grid. NumPy releases the GIL inside each whole-array operation, so
from `MIN_PARTICLES` on (where an operation on half the particles takes far longer than handing the
GIL over) the two halves run side by side on the machine's two cores: the forward loops, then the
adjoints. [`stepper`][pes_ref.accel.halves.stepper] wraps a NumPy
[`Stepper`][pes_ref.core.steppers.Stepper] so;
[`pes_ref.core.backends.stepper`][pes_ref.core.backends.stepper] is where a run gets it.

Each half runs the stepper's own loop on its particles, written into views of the whole run's
arrays, so every per-particle number (the trajectory, the energy, the gradients of ``x0``,
``v0``, the force, the masses and dampings, a spring's ``k`` and centre per particle) is the
one-thread run's, bit for bit. The gradients that are sums over particles (the grid's and the
mobility's, `SUMMED`) are each half's sum, the first half's plus the second's: the same
sum in another order, and the same order on any machine (the halves are fixed by N, not by
the threads).

The first half runs on the calling thread, the second on a worker that runs in a copy of the
caller's context (NumPy's ``errstate`` is a context variable). The caller's progress callback
sees the first half's reports. A run that left the finite numbers is refused as the one-thread
run refuses it, naming the first bad step of either half; an error in one half (Ctrl-C on the
calling thread, a floating-point error the caller's ``errstate`` raises) stops the other at its
next block of `pes_ref.core.runtime.progress.EVERY` steps, and that error is raised.
"""
from __future__ import annotations

import contextvars
import threading

import numpy as np

from pes_ref.core.integrator import NonFiniteError, Trajectory, trajectory_arrays
from pes_ref.core.runtime import pages
from pes_ref.core.steppers import Stepper, StepParams, for_particles

__all__ = ["MIN_PARTICLES", "SUMMED", "split", "stepper"]

#: From this many particles on, a NumPy run is two halves on two threads (docs/performance.md,
#: 'Every gradient through the oracle': a run of 100 steps takes 0.78x its one-thread time at
#: 32,768 particles and 0.68x at 65,536, but 0.95x at 16,384 and 1.09x at 8,192, where the
#: halves' operations are too short to outweigh the threads' turns at the GIL).
MIN_PARTICLES = 32768

#: The raw gradients (`Stepper.adjoint`'s dict) that are sums over the particles: the
#: halves' are added, the first's plus the second's. Every other is per particle, along axis 0
#: but ``force``'s (T+1, N, 2), along axis 1 (`PARTICLE_AXIS`).
SUMMED = ("values", "mobility")

#: The particle axis of a per-particle raw gradient, where it is not 0.
PARTICLE_AXIS = {"force": 1}


def split(n: int) -> tuple:
    """The two halves of ``n`` particles, as slices: ``0 .. n//2 - 1`` and ``n//2 .. n - 1``."""
    return slice(0, n // 2), slice(n // 2, n)


def _field_part(field, sl: slice, n: int):
    """``field`` with its spring's and walls' per-particle arrays cut to the particles ``sl``."""
    spring = None if field.spring is None else tuple(for_particles(a, sl, n) for a in field.spring)
    walls = None if field.walls is None else tuple(for_particles(a, sl, n) for a in field.walls)
    return field._replace(spring=spring, walls=walls)


def _params_part(p: StepParams, sl: slice, n: int, out: Trajectory, energy, progress) -> StepParams:
    """``p`` for the particles ``sl``, with the half's progress callback, arrays and energy sink."""
    return p._replace(mass=for_particles(p.mass, sl, n), damping=for_particles(p.damping, sl, n),
                      mobility=for_particles(p.mobility, sl, n),
                      progress=progress, out=out, energy=energy)


class _Stopped(Exception):
    """Raised in a half's progress report when the other half failed: it stops there."""


def _both(first, second, progress):
    """``[first(report), second(report)]``: ``second`` on a worker thread in a copy of the
    caller's context, ``first`` here; ``report`` is each half's progress callback (the first half's
    passes its reports on to ``progress``). An error in either half stops the other at its next
    report and is raised once both have ended (the first half's if both failed), except a
    [`NonFiniteError`][pes_ref.core.integrator.NonFiniteError], which ends a half only after its
    loop: the other half runs on, and the error of the earlier bad step is raised (the one-thread
    run's)."""
    stop = threading.Event()
    results, errors = [None, None], [None, None]

    def reporter(forward):
        def report(phase, done, total):
            if stop.is_set():
                raise _Stopped
            if forward is not None:
                forward(phase, done, total)
        return report

    def run(i, fn, report):
        try:
            results[i] = fn(report)
        except BaseException as exc:          # every error ends its half; all but a refusal stop the other
            errors[i] = exc
            if not isinstance(exc, NonFiniteError):
                stop.set()

    worker = threading.Thread(target=contextvars.copy_context().run, args=(run, 1, second, reporter(None)),
                              name="pes_ref-half", daemon=True)
    worker.start()
    try:
        run(0, first, reporter(progress))
    finally:
        if errors[0] is not None and not isinstance(errors[0], NonFiniteError):
            stop.set()
        worker.join()
    failed = [e for e in errors if e is not None and not isinstance(e, _Stopped)]
    other = [e for e in failed if not isinstance(e, NonFiniteError)]
    if other:
        raise other[0]
    if failed:
        raise min(failed, key=lambda e: e.step)
    return results


def _views(arrays, sl: slice) -> Trajectory:
    return Trajectory(*(a[:, sl] for a in arrays))


def stepper(inner: Stepper) -> Stepper:
    """``inner`` (a NumPy stepper) with its forward loop and adjoint each run as two halves
    on two threads; the same call signature ([`Stepper`][pes_ref.core.steppers.Stepper])."""

    def simulate(field, x0, v0, fext, p: StepParams) -> Trajectory:
        n = x0.shape[0]
        out = Trajectory(*trajectory_arrays(p.n_steps, n, p.out))
        halves = split(n)
        sinks = [None if p.energy is None else p.energy.part(sl) for sl in halves]

        def half(i):
            sl = halves[i]

            def run(report):
                view = _views(out, sl)
                traj = inner.simulate(_field_part(field, sl, n), x0[sl], v0[sl], None if fext is None else fext[:, sl],
                                      _params_part(p, sl, n, view, sinks[i], report))
                for mine, got in zip(view, traj):
                    if got is not mine:           # a loop that returns an array of its own: into the run's
                        mine[...] = got
                return traj
            return run

        _both(half(0), half(1), p.progress)
        if p.energy is not None:
            p.energy.filled = all(s.filled for s in sinks)
            p.energy.errors_ignored = any(s.errors_ignored for s in sinks)
        return out

    def adjoint(field, traj: Trajectory, p: StepParams, gx, gv, want) -> dict:
        n = traj.x.shape[1]
        halves = split(n)

        def half(i):
            sl = halves[i]

            def run(report):
                return inner.adjoint(_field_part(field, sl, n), _views(traj, sl),
                                     _params_part(p, sl, n, None, None, report),
                                     None if gx is None else gx[:, sl], None if gv is None else gv[:, sl], want)
            return run

        first, second = _both(half(0), half(1), p.progress)
        return {name: first[name] + second[name] if name in SUMMED else _joined(first[name], second[name], name)
                for name in first}

    return Stepper(simulate, adjoint, inner.gradients)


def _joined(first: np.ndarray, second: np.ndarray, name: str) -> np.ndarray:
    """The two halves' per-particle gradient ``name`` as one array, in memory of its own
    ([`pes_ref.core.runtime.pages.empty`][pes_ref.core.runtime.pages.empty]: ``force``'s is as large as the trajectory)."""
    axis = PARTICLE_AXIS.get(name, 0)
    shape = list(first.shape)
    shape[axis] += second.shape[axis]
    return np.concatenate((first, second), axis=axis, out=pages.empty(tuple(shape)))
