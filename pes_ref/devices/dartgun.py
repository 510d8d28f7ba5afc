"""The spring-loaded dart gun and trigger of the paper (Figs. 2-4) on a plane.

Part 0 is the dart, a bar that slides along x by q0 (q0 > 0: pushed back into the gun)
with a notch cut into its underside; its compression spring pushes it out (-q0) and
acts only while compressed (q0 > 0), so the dart leaves the spring at q0 = 0. Part 1
is the trigger, a tooth that slides along y by q1, pushed up into the dart's underside
by its spring. The C-space is the plane.

- Reload: a push +q0 carries the notch over the tooth, which pops up into it; when the
  push ends the dart spring drives the notch's wall against the tooth and the dart stays
  latched at an equilibrium (q0 ~ ``latch_q0``).
- Fire: a push -q1 on the trigger lowers the tooth out of the notch; the dart spring
  throws the dart out (q0 decreasing) past the surface's edge q0 = ``lower[0]``, where its
  speed is the exit speed (the paper: "the horizontal speed the particle achieves when it
  exits the potential energy surface").

The device is the shipped file ``pes_ref/devices/data/dartgun.toml``
([`dartgun_device`][pes_ref.devices.dartgun.dartgun_device]):
its surface is eq. (1) of the C-space plus both springs baked into the grid
([`pes_ref.devices.cspace`][pes_ref.devices.cspace]); its scenes have inertia, damping, walls on the edges the dart
and trigger must not leave (q0 upper, q1 lower and upper), and the pushes (Window effects).

Every run goes through ``run(device, scene, x0) -> Trajectory`` (default: the surface model,
[`pes_ref.core.scene.simulate`][pes_ref.core.scene.simulate] of the scene), so the same analysis runs on another
engine (the rigid parts: ``pes_ref.rigid.engines.ENGINES["rigid"].run``).
"""
from __future__ import annotations

from dataclasses import dataclass, field as dc_field
import time

import numpy as np

from pes_ref.core import checks
from pes_ref.core.effects import PerParticle, Window
from pes_ref.core.stability import grid_stiffness
from pes_ref.devices.device import Device
from pes_ref.devices.device_file import shipped_device
from pes_ref.devices.probes import threshold_search
from pes_ref.core.integrator import Trajectory
from pes_ref.core.scene import Scene, simulate

__all__ = ["dartgun_device", "dartgun_start", "reload_scene", "fire_scene", "run_reload", "run_fire",
           "ReloadResult", "FireResult", "min_reload_force", "exit_speeds", "settle", "latched_state",
           "trajectory_bbox", "DartGunReport", "analyze_dartgun", "DARTGUN_ANALYSIS"]


def dartgun_device() -> Device:
    """The shipped dart gun (``pes_ref/devices/data/dartgun.toml``): the dart slides along +x by
    q0, the trigger along +y by q1; ``analysis`` holds the latch and stop positions
    ``latch_q0``, ``stop_q0`` and the ``settle`` time of [`dartgun_start`][pes_ref.devices.dartgun.dartgun_start]."""
    return shipped_device("dartgun")


def _analysis(device: Device) -> dict:
    if device.analysis.get("kind") != "dartgun":
        raise checks.InputError("device", f"device {device.name!r} has no [analysis] of kind 'dartgun' "
                                          f"(its latch and stop positions and settling time)")
    return device.analysis


def _scene(device: Device, forces: np.ndarray, push_time: float, duration: float) -> Scene:
    return device.scene(int(np.ceil(duration / device.stable_dt())),
                        effects=(Window(PerParticle(forces), 0.0, push_time),))


def _simulate(run, device: Device, scene: Scene, x0) -> Trajectory:
    """The scene run by ``run`` (default: the surface model)."""
    return simulate(scene, x0) if run is None else run(device, scene, x0)


def dartgun_start(device: Device, run=None) -> np.ndarray:
    """The unloaded rest state (1, 2): from the device's ``[start]`` (dart out, the tooth just
    below it), settled for ``analysis.settle`` seconds: the tooth pressed against the dart's underside."""
    settle_time = _analysis(device)["settle"]
    return _simulate(run, device, _scene(device, np.zeros((1, 2)), device.stable_dt(), settle_time),
                     device.start[None, :]).x[-1].copy()


def reload_scene(device: Device, forces, push_time: float, duration: float) -> Scene:
    """One particle per reload force (N,): push +q0 for ``push_time``, then free until ``duration``."""
    forces = checks.as_float_array("forces", np.atleast_1d(forces), ndim=1)
    return _scene(device, np.stack((forces, np.zeros_like(forces)), axis=1),
                  checks.as_positive_float("push_time", push_time), checks.as_positive_float("duration", duration))


def fire_scene(device: Device, trigger_forces, push_time: float, duration: float) -> Scene:
    """One particle per trigger force (N,) >= 0: push -q1 with it for ``push_time``."""
    forces = checks.as_float_array("trigger_forces", np.atleast_1d(trigger_forces), ndim=1, nonneg=True)
    return _scene(device, np.stack((np.zeros_like(forces), -forces), axis=1),
                  checks.as_positive_float("push_time", push_time), checks.as_positive_float("duration", duration))


@dataclass(frozen=True)
class ReloadResult:
    """A reload run: ``trajectory`` (T+1, N, 2 arrays), ``latched`` (N,) bool, ``final`` (N, 2)."""

    trajectory: Trajectory
    latched: np.ndarray
    final: np.ndarray


@dataclass(frozen=True)
class FireResult:
    """A fire run: ``fired`` (N,) bool, ``exit_speed`` (N,) (0 where not fired), ``exit_time`` (N,) (nan)."""

    trajectory: Trajectory
    fired: np.ndarray
    exit_speed: np.ndarray
    exit_time: np.ndarray


def run_reload(device: Device, forces, push_time: float = 1.0, duration: float = 3.0,
               start=None, run=None) -> ReloadResult:
    """Reload from the unloaded rest state with each force.

    Latched where the run ends with the tooth up in the notch: ``q1 > 0`` (the tooth is
    above the dart's underside, which only the notch allows) and ``q0`` between the latch
    and the stop (within ``r_c``). From there the dart cannot leave; it comes to rest
    against the notch's wall ([`latched_state`][pes_ref.devices.dartgun.latched_state] finds that equilibrium).
    """
    a = _analysis(device)
    scene = reload_scene(device, forces, push_time, duration)
    n = np.atleast_1d(forces).size
    start = dartgun_start(device, run) if start is None else np.asarray(start, dtype=float).reshape(1, 2)
    traj = _simulate(run, device, scene, np.repeat(start, n, axis=0))
    final = traj.x[-1]
    latched = ((final[:, 1] > 0.0) & (final[:, 0] > a["latch_q0"] - device.r_c)
               & (final[:, 0] < a["stop_q0"] + device.r_c))
    return ReloadResult(traj, latched, final.copy())


def run_fire(device: Device, trigger_forces, push_time: float = 0.3, duration: float = 1.5,
             start=None, run=None) -> FireResult:
    """Fire from ``start`` (default: the latched state of a reload with 1.5x the latch force).

    A particle has fired when it crosses the surface's edge q0 = lower[0]; its exit speed
    is ``-v_q0`` there, linearly interpolated between the two states around the crossing.
    """
    surface = device.surface()
    if start is None:
        start = latched_state(device, run=run)
    start = checks.as_float_array("start", np.asarray(start).reshape(-1, 2)[:1], shape=(1, 2))
    if not start[0, 0] >= surface.lower[0]:
        raise ValueError(f"start {start[0].tolist()} is already past the surface's exit edge "
                         f"q0 = {surface.lower[0]:g}: fire from a state on the surface (a latched state)")
    scene = fire_scene(device, trigger_forces, push_time, duration)
    n = np.atleast_1d(trigger_forces).size
    traj = _simulate(run, device, scene, np.repeat(start, n, axis=0))
    edge = surface.lower[0]
    q0, v0 = traj.x[:, :, 0], traj.v[:, :, 0]
    out = q0 < edge
    fired = out.any(axis=0)
    k = np.argmax(out, axis=0)                      # first state past the edge
    speed = np.zeros(n)
    t_exit = np.full(n, np.nan)
    for i in np.nonzero(fired)[0]:
        j = k[i]
        w = (q0[j - 1, i] - edge) / (q0[j - 1, i] - q0[j, i])
        speed[i] = -((1 - w) * v0[j - 1, i] + w * v0[j, i])
        t_exit[i] = scene.t0 + (j - 1 + w) * scene.dt
    return FireResult(traj, fired, speed, t_exit)


#: Quasistatic steps per round of `settle`, and the most rounds it takes.
SETTLE_STEPS, SETTLE_ROUNDS = 4000, 50


def settle(device: Device, state, tol: float = 0.05, run=None) -> np.ndarray:
    """Relax ``state`` (1, 2) to the nearby equilibrium: rounds of `SETTLE_STEPS`
    quasistatic steps, with mobility ``0.5 / stiffness`` of the stiffest grid term so each
    step is stable, until the mean state of a round's second half moves by less than ``tol``
    grid spacings from the previous round's (a dart still bouncing in the notch after a
    reload needs several rounds; pressed into a corner, the state keeps chattering across
    cell lines, by up to a third of a spacing on a coarse grid); returns the last state,
    or a ValueError after `SETTLE_ROUNDS` rounds."""
    mu = 0.5 / grid_stiffness(device.surface())
    scene = device.scene(SETTLE_STEPS, mode="quasistatic", mobility=(mu, mu))
    x = np.asarray(state, dtype=float).reshape(1, 2)
    mean = None
    for _ in range(SETTLE_ROUNDS):
        xs = _simulate(run, device, scene, x).x[:, 0]
        x = xs[-1:].copy()
        now = xs[SETTLE_STEPS // 2:].mean(axis=0)
        if mean is not None and np.all(np.abs(now - mean) < tol * device.spacing):
            return x
        mean = now
    raise ValueError(f"the state {np.asarray(state).ravel().tolist()} did not settle within "
                     f"{SETTLE_ROUNDS * SETTLE_STEPS} quasistatic steps (now at {x[0].tolist()})")


def latched_state(device: Device, start=None, run=None) -> np.ndarray:
    """The latched equilibrium (1, 2): the end of a reload with 1.5 x the static latch force
    ``dart_k * latch_q0``, relaxed by [`settle`][pes_ref.devices.dartgun.settle]; a ValueError if that reload does not latch."""
    force = 1.5 * _dart_k(device) * _analysis(device)["latch_q0"]
    res = run_reload(device, [force], start=start, run=run)
    if not res.latched[0]:
        raise ValueError(f"the reference reload (force {force:g}) did not latch; final state {res.final[0].tolist()}")
    return settle(device, res.final[:1], run=run)


def min_reload_force(device: Device, push_time: float, hi: float, tol: float, start=None,
                     duration: float = 3.0, run=None) -> float:
    """Smallest reload force that latches ([`pes_ref.devices.probes.threshold_search`][pes_ref.devices.probes.threshold_search])."""
    start = dartgun_start(device, run) if start is None else start
    return threshold_search(lambda f: run_reload(device, f, push_time, duration, start, run).latched, 0.0, hi, tol)


def exit_speeds(device: Device, trigger_forces, push_time: float = 0.3, duration: float = 1.5,
                start=None, run=None) -> np.ndarray:
    """Exit speed per trigger force (0 where the dart does not fire), one batched run."""
    return run_fire(device, trigger_forces, push_time, duration, start, run).exit_speed


def trajectory_bbox(x) -> tuple:
    """Lower and upper corners (2,), (2,) of positions ``x`` of shape (T+1, N, 2) or (T+1, 2)."""
    x = checks.as_float_array("x", x)
    if x.shape[-1] != 2:
        raise ValueError(f"x must end in an axis of length 2, got shape {x.shape}")
    pts = x.reshape(-1, 2)
    return pts.min(axis=0), pts.max(axis=0)


@dataclass(frozen=True)
class DartGunReport:
    """The dart gun's figures (plain numbers and arrays)."""

    reload_force: float
    reload_time: float
    reload_latched: bool
    latched_state: tuple
    min_reload_force: float
    min_reload_force_tol: float
    trigger_forces: tuple
    exit_speeds: tuple
    fire_time: float
    reload_bbox: tuple               # ((q0_min, q1_min), (q0_max, q1_max))
    fire_bbox: tuple
    blocked_fraction: float
    grid: tuple
    dt: float
    stiffness_max: float             # largest barrier curvature on the grid (force/length)
    dt_limit: float                  # 2 sqrt(m_min / stiffness_max)
    times: dict = dc_field(default_factory=dict)

    def warnings(self) -> list:
        """What makes some figures of the report mean something else than they say, one line each."""
        if self.reload_latched:
            return []
        return [f"the reload with force {self.reload_force:.6g} did not latch: latched_q0, latched_q1 and "
                f"the exit speeds are those of the device's reference latch (a reload with 1.5 x the static "
                f"latch force, dartgun.latched_state), not of this reload"]

    def as_lines(self) -> list:
        """``name: value unit`` lines."""
        lines = [
            f"reload_force: {self.reload_force:.6g} force",
            f"reload_time: {self.reload_time:.6g} s",
            f"reload_latched: {self.reload_latched}",
            f"latched_q0: {self.latched_state[0]:.6g} length",
            f"latched_q1: {self.latched_state[1]:.6g} length",
            f"min_reload_force: {self.min_reload_force:.6g} force (+/- {self.min_reload_force_tol:.2g})",
            f"fire_time: {self.fire_time:.6g} s",
        ]
        for f, s in zip(self.trigger_forces, self.exit_speeds):
            lines.append(f"exit_speed[trigger_force={f:.6g}]: {s:.6g} length/s")
        for name, (lo, hi) in (("reload", self.reload_bbox), ("fire", self.fire_bbox)):
            lines.append(f"{name}_bbox_q0: {lo[0]:.6g} .. {hi[0]:.6g} length")
            lines.append(f"{name}_bbox_q1: {lo[1]:.6g} .. {hi[1]:.6g} length")
        lines += [f"blocked_fraction: {self.blocked_fraction:.6g} 1",
                  f"grid: {self.grid[0]}x{self.grid[1]} nodes",
                  f"dt: {self.dt:.6g} s",
                  f"barrier_stiffness_max: {self.stiffness_max:.6g} force/length",
                  f"dt_stability_limit: {self.dt_limit:.6g} s"]
        return lines + [f"time_{k}: {v:.3g} s" for k, v in self.times.items()]


def _dart_k(device: Device) -> float:
    """The dart spring's stiffness: the device's spring on axis 0."""
    return sum(sp.k for sp in device.springs if sp.axis == 0)


#: The analysis' defaults (``analyze dartgun`` uses and shows them): the reload push (force)
#: and how long it lasts (s), the trigger pushes (force) and how long each lasts (s), and the
#: upper end and bracket width of the search for the smallest force that reloads (force).
DARTGUN_ANALYSIS = {"reload_force": 30.0, "reload_time": 1.0, "trigger_forces": (10.0, 20.0, 30.0, 40.0),
                    "fire_time": 0.3, "search_hi": 40.0, "search_tol": 0.1}


def analyze_dartgun(device: Device | None = None, reload_force: float = DARTGUN_ANALYSIS["reload_force"],
                    reload_time: float = DARTGUN_ANALYSIS["reload_time"],
                    trigger_forces=DARTGUN_ANALYSIS["trigger_forces"], fire_time: float = DARTGUN_ANALYSIS["fire_time"],
                    search_hi: float = DARTGUN_ANALYSIS["search_hi"], search_tol: float = DARTGUN_ANALYSIS["search_tol"],
                    progress=None, run=None) -> DartGunReport:
    """Reload with ``reload_force`` for ``reload_time``, the smallest force that reloads, the exit
    speed for each trigger force (fired from the latched state), and the trajectories' bounding
    boxes (``device`` default: [`dartgun_device`][pes_ref.devices.dartgun.dartgun_device];
    ``progress`` is passed to its C-space; ``run``: the engine of every run, default the surface
    model)."""
    device = dartgun_device() if device is None else device
    _analysis(device)
    reload_force = checks.as_positive_float("reload_force", reload_force)
    trigger_forces = checks.as_float_array("trigger_forces", np.atleast_1d(trigger_forces), ndim=1, nonneg=True)
    times = {}
    t = time.perf_counter()
    cs = device.cspace(progress)
    times["cspace"] = time.perf_counter() - t
    t = time.perf_counter()
    surface = device.surface()
    start = dartgun_start(device, run)
    times["surface"] = time.perf_counter() - t
    t = time.perf_counter()
    rel = run_reload(device, [reload_force], reload_time, start=start, run=run)
    latched = settle(device, rel.final[:1], run=run) if rel.latched[0] else latched_state(device, start, run)
    fire = run_fire(device, trigger_forces, fire_time, start=latched, run=run)
    times["runs"] = time.perf_counter() - t
    t = time.perf_counter()
    fmin = min_reload_force(device, reload_time, search_hi, search_tol, start, run=run)
    times["min_force_search"] = time.perf_counter() - t
    k = grid_stiffness(surface)
    fired_x = np.array(fire.trajectory.x[:, fire.fired] if fire.fired.any() else fire.trajectory.x)
    fired_x[..., 0] = np.maximum(fired_x[..., 0], surface.lower[0])     # the device ends at the surface's edge
    rb = trajectory_bbox(rel.trajectory.x)
    fb = trajectory_bbox(fired_x)
    box = lambda b: (tuple(float(v) for v in b[0]), tuple(float(v) for v in b[1]))  # noqa: E731
    return DartGunReport(reload_force, reload_time, bool(rel.latched[0]), tuple(float(v) for v in latched[0]),
                         float(fmin), search_tol, tuple(float(f) for f in trigger_forces),
                         tuple(float(s) for s in fire.exit_speed), fire_time, box(rb), box(fb),
                         float(cs.blocked.mean()), tuple(device.shape), device.stable_dt(), k,
                         2.0 * np.sqrt(float(np.min(device.mass)) / k), times)
