"""A ratchet and pawl on a torus (paper, Fig. 1 and "Contribution 1").

Part 0 is a saw-toothed wheel turning by q0 about the origin; part 1 is a hooked pawl
turning by q1 about its pivot above the wheel, held into the teeth by a torsion spring.
Both coordinates are angles over a full turn, so the C-space is a torus. Each tooth rises
steeply at its root angle and falls along a ramp to the next root; the pawl's hook sits
at the top of the wheel and its arm runs to the pivot on the +x side, so that

- a torque +tau on the wheel (counter-clockwise) drives the ramps under the hook, which
  lifts the pawl (q1 decreases) against its spring until it clicks over the tip into the
  next valley: the wheel advances tooth by tooth;
- a torque -tau drives a steep face into the hook along the arm, which pushes the pawl
  deeper (q1 increases): the wheel is blocked.

The device is the shipped file ``pes_ref/devices/data/ratchet.toml``
([`ratchet_device`][pes_ref.devices.ratchet.ratchet_device]):
the surface is eq. (1) of the C-space ([`pes_ref.devices.cspace`][pes_ref.devices.cspace]) plus the pawl's torsion
spring baked into the grid; the scene adds only the torque, inertia and damping.

Every run goes through ``run(device, scene, x0) -> Trajectory`` (default: the surface model,
[`pes_ref.core.scene.simulate`][pes_ref.core.scene.simulate] of the scene), so the same analysis runs on another
engine (the rigid parts: ``pes_ref.rigid.engines.ENGINES["rigid"].run``).
"""
from __future__ import annotations

from dataclasses import dataclass, field as dc_field
import time

import numpy as np

from pes_ref.core import budget, checks
from pes_ref.core.effects import PerParticle
from pes_ref.core.stability import grid_stiffness
from pes_ref.devices.device import Device
from pes_ref.devices.device_file import shipped_device
from pes_ref.devices.probes import steepest_slope, threshold_search
from pes_ref.core.integrator import NonFiniteError, Trajectory
from pes_ref.core.scene import Scene, simulate

__all__ = ["ratchet_device", "ratchet_start", "ratchet_scene", "run_ratchet",
           "min_advancing_torque", "RatchetReport", "analyze_ratchet", "RATCHET_ANALYSIS"]


def ratchet_device() -> Device:
    """The shipped ratchet (``pes_ref/devices/data/ratchet.toml``): the wheel turns by q0 about
    the origin, the pawl by q1 about its pivot; ``analysis`` holds the tooth ``pitch`` and the
    ``settle`` time of [`ratchet_start`][pes_ref.devices.ratchet.ratchet_start]."""
    return shipped_device("ratchet")


def _pitch(device: Device) -> float:
    if device.analysis.get("kind") != "ratchet":
        raise checks.InputError("device", f"device {device.name!r} has no [analysis] of kind 'ratchet' "
                                          f"(its tooth pitch and settling time)")
    return device.analysis["pitch"]


def ratchet_scene(device: Device, torques, duration: float) -> Scene:
    """One particle per torque (shape (N,)), each a constant torque on the wheel, for ``duration``
    seconds (refused, naming ``duration``, when the run cannot fit in memory)."""
    torques = checks.as_float_array("torques", np.atleast_1d(torques), ndim=1)
    duration = checks.as_positive_float("duration", duration)
    dt = device.stable_dt()
    n_steps = int(np.ceil(duration / dt))
    budget.check_memory(n_steps, torques.size, "simulate", steps="duration", fixed_particles=True,
                        length=f"duration = {duration:g} ({n_steps} steps of dt {dt:g})")
    force = np.stack((torques, np.zeros_like(torques)), axis=1)
    return device.scene(n_steps, effects=(PerParticle(force),))


def _simulate(run, device: Device, scene: Scene, x0) -> Trajectory:
    """The scene run by ``run`` (default: the surface model)."""
    return simulate(scene, x0) if run is None else run(device, scene, x0)


def ratchet_start(device: Device, run=None) -> np.ndarray:
    """The engaged rest state, shape (1, 2): the pawl, started from the device's ``[start]``
    (lifted clear of the teeth), swings in under its spring and settles for the
    ``analysis.settle`` seconds without torque."""
    _pitch(device)
    traj = _simulate(run, device, ratchet_scene(device, [0.0], device.analysis["settle"]), device.start[None, :])
    return traj.x[-1].copy()


def run_ratchet(device: Device, torques, duration: float, start=None, run=None) -> Trajectory:
    """Run every torque from the engaged rest state; trajectory (T+1, N, 2) (``run``: the engine)."""
    torques = np.atleast_1d(np.asarray(torques, dtype=float))
    start = ratchet_start(device, run) if start is None else np.asarray(start, dtype=float).reshape(1, 2)
    x0 = np.repeat(start, torques.size, axis=0)
    return _simulate(run, device, ratchet_scene(device, torques, duration), x0)


def _advances(device, start, duration, run=None):
    pitch = _pitch(device)

    def passes(torques):
        x = run_ratchet(device, torques, duration, start, run).x
        return x[-1, :, 0] - x[0, :, 0] >= pitch
    return passes


def min_advancing_torque(device: Device, duration: float, hi: float, tol: float, start=None, run=None) -> float:
    """Smallest torque that advances the wheel by at least one tooth within ``duration``."""
    start = ratchet_start(device, run) if start is None else start
    return threshold_search(_advances(device, start, duration, run), 0.0, hi, tol)


@dataclass(frozen=True)
class RatchetReport:
    """The ratchet's figures (plain numbers)."""

    torque: float
    duration: float
    rotation_plus: float           # net wheel rotation under +torque (rad)
    rotation_minus: float          # net wheel rotation under -torque (rad)
    teeth_plus: float              # rotation_plus / pitch
    pawl_swing_plus: float         # range of the pawl angle under +torque (rad)
    min_torque: float              # smallest advancing torque (bisection)
    min_torque_tol: float
    blocked_fraction: float
    grid: tuple
    dt: float
    stiffness_max: float           # largest barrier curvature on the grid (core.stability.grid_stiffness)
    dt_limit: float                # 2 sqrt(m_min / stiffness_max)
    barrier_torque_max: float      # the largest torque the grid can hold back (probes.steepest_slope along q0)
    times: dict = dc_field(default_factory=dict)

    def warnings(self) -> list:
        """What makes some figures of the report mean something else than they say, one line each."""
        if self.torque <= self.barrier_torque_max:
            return []
        return [f"the torque {self.torque:.6g} torque-unit exceeds the largest the barrier can hold back "
                f"(barrier_torque_max: {self.barrier_torque_max:.6g} torque-unit): the push overwhelms the "
                f"barrier, the pawl holds the wheel in neither direction, and the net rotations are those of "
                f"a free wheel"]

    def as_lines(self) -> list:
        """``name: value unit`` lines."""
        return [
            f"torque: {self.torque:.6g} torque-unit",
            f"duration: {self.duration:.6g} s",
            f"net_rotation_plus: {self.rotation_plus:.6g} rad",
            f"net_rotation_minus: {self.rotation_minus:.6g} rad",
            f"teeth_advanced_plus: {self.teeth_plus:.6g} teeth",
            f"pawl_swing_plus: {self.pawl_swing_plus:.6g} rad",
            f"min_advancing_torque: {self.min_torque:.6g} torque-unit (+/- {self.min_torque_tol:.2g})",
            f"blocked_fraction: {self.blocked_fraction:.6g} 1",
            f"grid: {self.grid[0]}x{self.grid[1]} nodes",
            f"dt: {self.dt:.6g} s",
            f"barrier_stiffness_max: {self.stiffness_max:.6g} torque-unit/rad",
            f"dt_stability_limit: {self.dt_limit:.6g} s",
            f"barrier_torque_max: {self.barrier_torque_max:.6g} torque-unit",
        ] + [f"time_{k}: {v:.3g} s" for k, v in self.times.items()]


#: The analysis' defaults (``analyze ratchet`` uses and shows them): the torque on the wheel
#: (torque-unit), each run's duration (s), and the upper end and bracket width of the search
#: for the smallest advancing torque (torque-unit), whose runs last ``duration`` too.
RATCHET_ANALYSIS = {"torque": 1.0, "duration": 10.0, "search_hi": 2.0, "search_tol": 0.01}


def analyze_ratchet(device: Device | None = None, torque: float = RATCHET_ANALYSIS["torque"],
                    duration: float = RATCHET_ANALYSIS["duration"], search_hi: float = RATCHET_ANALYSIS["search_hi"],
                    search_tol: float = RATCHET_ANALYSIS["search_tol"],
                    search_duration: float = RATCHET_ANALYSIS["duration"], progress=None, run=None) -> RatchetReport:
    """Net rotation under +/- ``torque``, the pawl's swing, and the smallest advancing torque
    (``device`` default: [`ratchet_device`][pes_ref.devices.ratchet.ratchet_device]; ``progress`` is
    passed to its C-space; ``run``: the engine of every run, default the surface model)."""
    device = ratchet_device() if device is None else device
    pitch = _pitch(device)
    torque = checks.as_positive_float("torque", torque)
    times = {}
    t = time.perf_counter()
    cs = device.cspace(progress)
    times["cspace"] = time.perf_counter() - t
    t = time.perf_counter()
    surface = device.surface()
    start = ratchet_start(device, run)
    times["surface"] = time.perf_counter() - t
    t = time.perf_counter()
    try:
        x = run_ratchet(device, [torque, -torque], duration, start, run).x
    except NonFiniteError:
        raise checks.InputError("torque", f"torque = {torque:g} torque-unit drives the wheel out of the range "
                                          f"where the surface can be looked up (it overwhelms the barrier, which "
                                          f"holds back at most {steepest_slope(surface, 0):.6g} torque-unit, and "
                                          f"spins the wheel freely beyond 2**52 cells in duration = {duration:g}): "
                                          f"give a smaller torque") from None
    times["runs"] = time.perf_counter() - t
    t = time.perf_counter()
    tmin = min_advancing_torque(device, search_duration, search_hi, search_tol, start, run)
    times["min_torque_search"] = time.perf_counter() - t
    rot = x[-1, :, 0] - x[0, :, 0]
    k = grid_stiffness(surface)
    dt = device.stable_dt()
    return RatchetReport(torque, duration, float(rot[0]), float(rot[1]), float(rot[0] / pitch),
                         float(np.ptp(x[:, 0, 1])), float(tmin), search_tol, float(cs.blocked.mean()),
                         tuple(device.shape), dt, k, 2.0 * np.sqrt(float(np.min(device.mass)) / k),
                         steepest_slope(surface, 0), times)
