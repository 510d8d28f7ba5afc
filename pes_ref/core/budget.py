"""What a run costs before it runs: its memory, refused when it cannot fit, and its time.

Memory. A run of T steps and N particles holds its whole trajectory: ``x``, ``v``, ``f``,
each (T+1, N, 2) float64, and the external force schedule (T+1, N, 2); its adjoint adds
the objective's direct derivatives ``dL/dX``, ``dL/dV``, ``grad_force`` and the grid
adjoint's per-state tables; the oracle adds the case's ``force``, the energy and the
result's copies. All of these scale with ``(T+1) N``, so a run needs about

    bytes = ARRAYS[kind] * (T+1) * N * 2 * 8  (+ the kept lookups of a small run, LOOKUP_BYTES each)

with `ARRAYS` the number of (T+1, N, 2) float64 arrays alive at the run's peak
(measured with ``tracemalloc`` and rounded up: ``tests/core/test_budget.py`` checks that the
formula bounds the measured peak). The grid, the parameters and the per-particle buffers
are small beside it and left out, except where a user chooses the grid's size (a design's
``grid``): [`check_grid_memory`][pes_ref.core.budget.check_grid_memory] refuses a grid whose `GRID_ARRAYS` copies
cannot fit. [`check_memory`][pes_ref.core.budget.check_memory] refuses a run whose estimate is
more than the memory available (``MemAvailable`` of ``/proc/meminfo``, or
``os.sysconf`` where there is none) with [`RunTooLargeError`][pes_ref.core.budget.RunTooLargeError], naming ``n_steps``,
N and the size, before anything of that size is allocated; it is called at the public
boundary ([`pes_ref.simulate`][pes_ref.core.scene.simulate],
[`pes_ref.value_and_grad`][pes_ref.core.scene.value_and_grad],
[`pes_ref.oracle.case.validate_case`][pes_ref.oracle.case.validate_case]).

Time. A step costs about ``a + b N`` seconds forward and ``a' + b' N`` in the adjoint
(the per-step overhead of the loop's calls, plus the work per particle), and a large
run also pays for its memory the first time it touches it (the page faults of its
[`run_bytes`][pes_ref.core.budget.run_bytes], ``c`` seconds per byte; on a loaded machine this can dominate)::

    seconds = T (a + b N) + T (a' + b' N) + c * run_bytes(T, N, kind)

(without the adjoint's term for ``kind = "simulate"``). The five constants are measured
once per process, on first use, by [`step_cost`][pes_ref.core.budget.step_cost] (a 64-step run at N = 1 and N = 256
on a small grid, and filling a fresh 32 MiB array; ~50 ms); [`estimate_seconds`][pes_ref.core.budget.estimate_seconds]
scales them to a run. A run that the documented constants `TYPICAL_COST` put under
a second is estimated with those, so that a short run never pays for the measurement. It is an estimate (springs, walls, damping and the bicubic surface
change the cost by tens of percent), used to decide whether a run is long enough to
report its progress and to say roughly how long it will take.
"""
from __future__ import annotations

import functools
import os
import time
from typing import NamedTuple

import numpy as np

from pes_ref.core import checks
from pes_ref.core.runtime import pages

__all__ = ["ARRAYS", "LOOKUP_STATES", "LOOKUP_BYTES", "GRID_ARRAYS", "RunTooLargeError", "RunEstimate", "StepCost",
           "TYPICAL_COST", "run_bytes", "available_memory", "check_memory", "check_grid_memory", "step_cost", "estimate_seconds", "estimate"]

#: The (T+1, N, 2) float64 arrays (or their size in other dtypes) alive at the peak of
#: each kind of run, as measured with ``tracemalloc`` plus a margin: ``simulate`` (x, v,
#: f, the force schedule: 4.1 measured); ``value_and_grad`` (that, the objective's dL/dX
#: and dL/dV, grad_force, the grid adjoint's per-state corner indices and weights: 14.4
#: measured); ``case`` (an oracle run: that, the case's force, then the energy's
#: temporaries and the result's copies: 19.9 measured).
ARRAYS = {"simulate": 5, "value_and_grad": 15, "case": 21}

#: A compiled dynamic run of at most this many particle-states ((T+1) N) keeps each state's
#: grid lookup for its adjoint (`pes_ref.accel.compiled._lookups`), ``LOOKUP_BYTES``
#: each (its position, two fractions, the cell, its row and column and switches): at most
#: 3.1 MB, which `run_bytes` counts.
LOOKUP_STATES = 1 << 16
LOOKUP_BYTES = 48

#: The grid-sized float64 arrays alive at the peak of a design's gradient iteration (the
#: values, their gradient, the optimizer's moments, the surface's and the grid adjoint's
#: tables and the temporaries: at most 15.5 measured with ``tracemalloc`` over a
#: coarse-to-fine run on a 600 x 600 grid, both problems, both optimizers;
#: ``tests/core/test_budget.py`` checks that it bounds the measured peak), plus a margin.
GRID_ARRAYS = 24

_GIB = 2.0 ** 30


class RunTooLargeError(checks.InputError):
    """A run whose arrays cannot fit in the available memory; ``key`` names what sets its
    length (``"n_steps"`` unless the caller says otherwise, [`check_memory`][pes_ref.core.budget.check_memory])."""


class RunEstimate(NamedTuple):
    """What a run will cost: ``n_steps`` (T), ``n_particles`` (N), ``gib`` (its memory,
    GiB, [`run_bytes`][pes_ref.core.budget.run_bytes]) and ``seconds`` ([`estimate_seconds`][pes_ref.core.budget.estimate_seconds])."""

    n_steps: int
    n_particles: int
    gib: float
    seconds: float


def run_bytes(n_steps: int, n_particles: int, kind: str) -> int:
    """``ARRAYS[kind] * (T+1) * N * 2 * 8``: the bytes a run of ``kind`` holds at its peak,
    plus ``LOOKUP_BYTES`` a particle-state for a run of at most `LOOKUP_STATES` (the
    lookups a compiled dynamic run keeps)."""
    states = (int(n_steps) + 1) * int(n_particles)
    return ARRAYS[kind] * states * 2 * 8 + (LOOKUP_BYTES * states if states <= LOOKUP_STATES else 0)


def available_memory() -> int | None:
    """The memory a new run can take, in bytes: ``MemAvailable`` of ``/proc/meminfo``, or
    the free physical pages (``os.sysconf``), plus the idle maps that a new run reuses or gives
    back first ([`pes_ref.core.runtime.pages.idle_bytes`][pes_ref.core.runtime.pages.idle_bytes]); None when neither is known."""
    system = _system_memory()
    return None if system is None else system + pages.idle_bytes()


def _system_memory() -> int | None:
    """``MemAvailable`` of ``/proc/meminfo``, or the free physical pages; None when neither is known."""
    try:                                    # one read of the raw bytes (it is the third line)
        fd = os.open("/proc/meminfo", os.O_RDONLY)
        try:
            data = os.read(fd, 4096)
        finally:
            os.close(fd)
        at = data.find(b"\nMemAvailable:") + 1
        if at > 0:
            return int(data[at + 13:data.index(b"\n", at)].split()[0]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, OSError, ValueError):
        return None


def check_memory(n_steps: int, n_particles: int, kind: str, *, steps: str = "n_steps", particles: str | None = None,
                 length: str | None = None, fixed_particles: bool = False, fixed_steps: bool = False,
                 runs: int = 1) -> int:
    """Refuse a run that cannot fit in the available memory; return its bytes.

    ``steps`` and ``particles`` name the arguments that set T and N as the caller's user
    knows them (``particles`` None: N is the number of particles of the state); ``length``
    says how T reads (default ``"<steps> = T"``, e.g. ``"duration = 1e9 (5e11 steps of dt 0.002)"``);
    ``fixed_particles``: N is not the user's to change, and the refusal says to reduce T alone;
    ``fixed_steps``: T is not (a saved design's), and the refusal names and says to reduce N alone.
    ``runs``: that many runs of this size held at once (a population of them).

    Raises
    ------
    RunTooLargeError
        ``runs * run_bytes(n_steps, n_particles, kind)`` exceeds
        [`available_memory`][pes_ref.core.budget.available_memory]; one
        line naming ``steps`` (its key), N and both sizes in GiB (a ``ValueError``).
    """
    need = runs * run_bytes(n_steps, n_particles, kind)
    avail = available_memory()
    if avail is not None and need > avail:
        count = f"{particles} = {n_particles}" if particles else f"N = {n_particles} particles"
        reduce = ([] if fixed_steps else [steps]) + ([] if fixed_particles else [particles or "the number of particles"])
        raise RunTooLargeError(
            particles if fixed_steps else steps,
            f"{length or f'{steps} = {n_steps}'} with {count}{f' ({runs} runs at once)' if runs > 1 else ''} needs about {need / _GIB:.3g} GiB "
            f"({ARRAYS[kind]} arrays of (T+1, N, 2) float64), more than the {avail / _GIB:.3g} GiB of "
            f"memory available; reduce {' or '.join(reduce)}",
            names=(steps, particles) if particles else (steps,))
    return need


def check_grid_memory(shape: tuple, key: str, arrays: int = GRID_ARRAYS, length: str | None = None) -> int:
    """Refuse a grid of ``shape`` (n0, n1) whose ``arrays`` float64 copies cannot fit in the
    available memory; return their bytes. ``key`` names what sets the grid's size (a design's
    ``grid``), in the one-line [`RunTooLargeError`][pes_ref.core.budget.RunTooLargeError];
    ``length`` says how it reads (default: ``key``, e.g. ``"grid = 100000"``)."""
    n0, n1 = (int(n) for n in shape)
    need = arrays * n0 * n1 * 8
    avail = available_memory()
    if avail is not None and need > avail:
        raise RunTooLargeError(key, f"{length or key} makes a surface of {n0} x {n1} nodes that needs about {need / _GIB:.3g} GiB ({arrays} "
                                    f"arrays of its size, float64), more than the {avail / _GIB:.3g} GiB of memory "
                                    f"available; reduce {key}")
    return need


class StepCost(NamedTuple):
    """Seconds per step, forward ``forward + forward_n N`` and adjoint ``adjoint + adjoint_n N``,
    and ``per_byte``, the seconds to touch a byte of fresh memory for the first time."""

    forward: float
    forward_n: float
    adjoint: float
    adjoint_n: float
    per_byte: float


#: The per-step cost measured on the project's 2-core test machine (forward ~5 us + 60 ns
#: per particle, adjoint ~7 us + 70 ns per particle, ~2 ns per byte touched).
TYPICAL_COST = StepCost(5e-6, 6e-8, 7e-6, 7e-8, 2e-9)

#: Runs that `TYPICAL_COST` puts under this many seconds are not measured.
_MEASURE_ABOVE = 1.0

#: The calibration of `step_cost`: steps, the two particle counts, the fresh bytes touched.
_CALIBRATION_STEPS, _CALIBRATION_N, _CALIBRATION_BYTES = 64, (1, 256), 32 * 2 ** 20


@functools.lru_cache(maxsize=None)
def step_cost() -> StepCost:
    """The per-step cost model, measured once per process (see the module docstring)."""
    from pes_ref.core.forces import Field
    from pes_ref.core.integrator import adjoint_dynamic, simulate_dynamic
    rng = np.random.default_rng(0)
    values = rng.uniform(0.0, 0.01, (16, 16))
    field = Field(values, np.zeros(2), np.full(2, 1.0 / 15), np.ones(2), (False, False), None, None)
    T, want = _CALIBRATION_STEPS, frozenset({"values", "x0", "v0"})
    seconds = []
    for n in _CALIBRATION_N:
        x0 = rng.uniform(0.2, 0.8, (n, 2))
        best = [np.inf, np.inf]
        for _ in range(2):
            t0 = time.perf_counter()
            traj = simulate_dynamic(field, x0, np.zeros((n, 2)), None, 1e-3, T, np.ones(2), np.full(2, 0.1))
            t1 = time.perf_counter()
            adjoint_dynamic(field, traj, 1e-3, np.ones(2), np.full(2, 0.1), traj.x, None, want)
            t2 = time.perf_counter()
            best = [min(best[0], t1 - t0), min(best[1], t2 - t1)]
        seconds.append([b / T for b in best])
    (f1, a1), (f2, a2) = seconds
    dn = _CALIBRATION_N[1] - _CALIBRATION_N[0]
    fn, an = max(f2 - f1, 0.0) / dn, max(a2 - a1, 0.0) / dn
    t0 = time.perf_counter()
    np.empty(_CALIBRATION_BYTES // 8).fill(1.0)
    per_byte = (time.perf_counter() - t0) / _CALIBRATION_BYTES
    return StepCost(max(f1 - fn * _CALIBRATION_N[0], 0.0), fn, max(a1 - an * _CALIBRATION_N[0], 0.0), an, per_byte)


def estimate_seconds(n_steps: int, n_particles: int, kind: str = "case") -> float:
    """Roughly how long a run of ``kind`` (`ARRAYS`) takes: its forward steps, its
    adjoint's unless ``kind`` is ``"simulate"``, and its first touch of its memory (with
    the measured [`step_cost`][pes_ref.core.budget.step_cost], or `TYPICAL_COST` for a run that is short by it)."""
    seconds = _seconds(TYPICAL_COST, n_steps, n_particles, kind)
    return seconds if seconds < _MEASURE_ABOVE else _seconds(step_cost(), n_steps, n_particles, kind)


def _seconds(c: StepCost, n_steps: int, n_particles: int, kind: str) -> float:
    per_step = c.forward + c.forward_n * n_particles
    if kind != "simulate":
        per_step += c.adjoint + c.adjoint_n * n_particles
    return float(n_steps) * per_step + c.per_byte * run_bytes(n_steps, n_particles, kind)


def estimate(n_steps: int, n_particles: int, kind: str) -> RunEstimate:
    """A [`RunEstimate`][pes_ref.core.budget.RunEstimate] of a run of ``kind`` (see `ARRAYS`)."""
    return RunEstimate(int(n_steps), int(n_particles), run_bytes(n_steps, n_particles, kind) / _GIB,
                       estimate_seconds(n_steps, n_particles, kind))
