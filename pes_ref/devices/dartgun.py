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

The surface is eq. (1) of the C-space plus both springs baked into the grid
(:mod:`pes_ref.devices.cspace`); the scenes name inertia, damping, walls on the edges the dart and
trigger must not leave (q0 upper, q1 lower and upper) and the pushes (Window effects).
"""
from __future__ import annotations

from dataclasses import dataclass, field as dc_field
import time

import numpy as np

from pes_ref.core import checks
from pes_ref.devices.cspace import CSpaceGrid, GridSpring
from pes_ref.core.effects import PerParticle, Window
from pes_ref.devices.geometry import Part, Polygon, Translation, rectangle
from pes_ref.core.stability import grid_stiffness
from pes_ref.devices.probes import threshold_search
from pes_ref.core.integrator import Trajectory
from pes_ref.core.scene import Scene, simulate
from pes_ref.core.surface import Surface
from pes_ref.core.terms import Walls

__all__ = ["DartGunDesign", "dartgun_parts", "dartgun_cspace", "dartgun_surface", "dartgun_start",
           "reload_scene", "fire_scene", "run_reload", "run_fire", "ReloadResult", "FireResult",
           "min_reload_force", "exit_speeds", "settle", "latched_state", "trajectory_bbox", "DartGunReport", "analyze_dartgun",
           "DARTGUN_ANALYSIS"]


@dataclass(frozen=True)
class DartGunDesign:
    """Dimensions, springs and simulation settings of the dart gun (consistent units:
    length, force, mass, seconds). Defaults chosen for stable, fast runs (docs/geometry.md)."""

    dart_length: float = 6.0
    dart_height: float = 1.0
    notch_start: float = 1.0           # x of the notch's left wall on the dart (q0 = 0)
    notch_width: float = 1.0
    notch_depth: float = 0.4
    tooth_x: float = 3.0               # the trigger tooth spans [tooth_x, tooth_x + tooth_width]
    tooth_width: float = 0.6
    tooth_length: float = 1.5          # the tooth reaches down to -tooth_length at q1 = 0
    dart_k: float = 10.0               # dart spring (compression, rest at q0 = 0)
    trigger_k: float = 20.0            # trigger spring
    trigger_center: float = 0.8        # its rest position (> notch_depth: presses the tooth up)
    v: float = 7e-4                    # eq. (1) strength
    r_c: float = 0.08                  # eq. (1) cut-off
    lower: tuple = (-0.5, -1.0)
    upper: tuple = (2.5, 1.0)
    shape: tuple = (241, 161)
    dt: float = 2e-4
    mass: tuple = (1.0, 0.2)           # dart, trigger
    damping: tuple = (0.5, 4.0)
    wall_k: float = 2000.0
    wall_margin: float = 0.05

    def __post_init__(self):
        for name in ("dart_length", "dart_height", "notch_start", "notch_width", "notch_depth", "tooth_x",
                     "tooth_width", "tooth_length", "r_c", "dt", "wall_k"):
            checks.as_positive_float(name, getattr(self, name))
        for name in ("dart_k", "trigger_k", "v", "wall_margin"):
            checks.as_nonneg_float(name, getattr(self, name))
        if not self.notch_depth < self.dart_height:
            raise ValueError(f"notch_depth must be < dart_height, got {self.notch_depth} >= {self.dart_height}")
        if not self.tooth_width < self.notch_width:
            raise ValueError(f"the tooth (width {self.tooth_width}) must fit the notch (width {self.notch_width})")
        if not self.notch_start + self.notch_width < self.tooth_x < self.dart_length - self.tooth_width:
            raise ValueError("at q0 = 0 the tooth must sit under the dart, right of the notch: need "
                             "notch_start + notch_width < tooth_x < dart_length - tooth_width")

    @property
    def latch_q0(self) -> float:
        """q0 at which the notch's right wall meets the tooth (the latched position)."""
        return self.tooth_x + self.tooth_width - self.notch_start - self.notch_width

    @property
    def stop_q0(self) -> float:
        """q0 at which the notch's left wall meets the tooth (the reload stop)."""
        return self.tooth_x - self.notch_start


def dartgun_parts(design: DartGunDesign = DartGunDesign()):
    """(dart, trigger): the dart slides along +x by q0, the trigger along +y by q1."""
    d = design
    a, b, h = d.notch_start, d.notch_start + d.notch_width, d.notch_depth
    dart = Polygon([[0, 0], [a, 0], [a, h], [b, h], [b, 0], [d.dart_length, 0], [d.dart_length, d.dart_height],
                    [0, d.dart_height]])
    tooth = rectangle(d.tooth_x, -d.tooth_length, d.tooth_x + d.tooth_width, 0.0)
    return Part(dart, Translation((1.0, 0.0))), Part(tooth, Translation((0.0, 1.0)))


def dartgun_cspace(design: DartGunDesign = DartGunDesign()) -> CSpaceGrid:
    """The plane ``design.lower`` .. ``design.upper`` on ``design.shape`` nodes."""
    dart, trigger = dartgun_parts(design)
    return CSpaceGrid(dart, trigger, design.lower, design.upper, tuple(design.shape))


def dartgun_surface(design: DartGunDesign = DartGunDesign(), blocked=None) -> Surface:
    """Eq. (1) of the C-space plus the dart spring (q0 > 0 only) and the trigger spring."""
    springs = (GridSpring(0, design.dart_k, 0.0, side="above"),
               GridSpring(1, design.trigger_k, design.trigger_center))
    return dartgun_cspace(design).surface(design.v, design.r_c, springs=springs, blocked=blocked)


def _scene(design: DartGunDesign, surface: Surface, forces: np.ndarray, push_time: float, duration: float) -> Scene:
    walls = Walls(design.wall_k, design.wall_margin, [[False, True], [True, True]])
    return Scene(surface, dt=design.dt, n_steps=int(np.ceil(duration / design.dt)), mass=np.array(design.mass),
                 damping=np.array(design.damping), walls=walls,
                 effects=(Window(PerParticle(forces), 0.0, push_time),))


def dartgun_start(design: DartGunDesign = DartGunDesign(), surface: Surface | None = None,
                  settle: float = 0.5) -> np.ndarray:
    """The unloaded rest state (1, 2): dart out (q0 = 0), tooth pressed against its underside."""
    surface = dartgun_surface(design) if surface is None else surface
    x0 = np.array([[0.0, -design.r_c]])
    return simulate(_scene(design, surface, np.zeros((1, 2)), design.dt, settle), x0).x[-1].copy()


def reload_scene(design: DartGunDesign, forces, push_time: float, duration: float,
                 surface: Surface | None = None) -> Scene:
    """One particle per reload force (N,): push +q0 for ``push_time``, then free until ``duration``."""
    forces = checks.as_float_array("forces", np.atleast_1d(forces), ndim=1)
    surface = dartgun_surface(design) if surface is None else surface
    return _scene(design, surface, np.stack((forces, np.zeros_like(forces)), axis=1),
                  checks.as_positive_float("push_time", push_time), checks.as_positive_float("duration", duration))


def fire_scene(design: DartGunDesign, trigger_forces, push_time: float, duration: float,
               surface: Surface | None = None) -> Scene:
    """One particle per trigger force (N,) >= 0: push -q1 with it for ``push_time``."""
    forces = checks.as_float_array("trigger_forces", np.atleast_1d(trigger_forces), ndim=1, nonneg=True)
    surface = dartgun_surface(design) if surface is None else surface
    return _scene(design, surface, np.stack((np.zeros_like(forces), -forces), axis=1),
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


def run_reload(design: DartGunDesign, forces, push_time: float = 1.0, duration: float = 3.0,
               surface: Surface | None = None, start=None) -> ReloadResult:
    """Reload from the unloaded rest state with each force.

    Latched where the run ends with the tooth up in the notch: ``q1 > 0`` (the tooth is
    above the dart's underside, which only the notch allows) and ``q0`` between the latch
    and the stop (within ``r_c``). From there the dart cannot leave; it comes to rest
    against the notch's wall (:func:`latched_state` finds that equilibrium).
    """
    surface = dartgun_surface(design) if surface is None else surface
    scene = reload_scene(design, forces, push_time, duration, surface)
    n = np.atleast_1d(forces).size
    start = dartgun_start(design, surface) if start is None else np.asarray(start, dtype=float).reshape(1, 2)
    traj = simulate(scene, np.repeat(start, n, axis=0))
    final = traj.x[-1]
    latched = ((final[:, 1] > 0.0) & (final[:, 0] > design.latch_q0 - design.r_c)
               & (final[:, 0] < design.stop_q0 + design.r_c))
    return ReloadResult(traj, latched, final.copy())


def run_fire(design: DartGunDesign, trigger_forces, push_time: float = 0.3, duration: float = 1.5,
             start=None, surface: Surface | None = None) -> FireResult:
    """Fire from ``start`` (default: the latched state of a reload with 1.5x the latch force).

    A particle has fired when it crosses the surface's edge q0 = lower[0]; its exit speed
    is ``-v_q0`` there, linearly interpolated between the two states around the crossing.
    """
    surface = dartgun_surface(design) if surface is None else surface
    if start is None:
        start = latched_state(design, surface)
    start = checks.as_float_array("start", np.asarray(start).reshape(-1, 2)[:1], shape=(1, 2))
    if not start[0, 0] >= surface.lower[0]:
        raise ValueError(f"start {start[0].tolist()} is already past the surface's exit edge "
                         f"q0 = {surface.lower[0]:g}: fire from a state on the surface (a latched state)")
    scene = fire_scene(design, trigger_forces, push_time, duration, surface)
    n = np.atleast_1d(trigger_forces).size
    traj = simulate(scene, np.repeat(start, n, axis=0))
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
        t_exit[i] = scene.t0 + (j - 1 + w) * design.dt
    return FireResult(traj, fired, speed, t_exit)


def settle(design: DartGunDesign, state, surface: Surface | None = None, steps: int = 4000) -> np.ndarray:
    """Relax ``state`` (1, 2) to the nearby equilibrium by ``steps`` quasistatic steps, with
    mobility ``0.5 / stiffness`` of the stiffest grid term so each step is stable."""
    surface = dartgun_surface(design) if surface is None else surface
    mu = 0.5 / grid_stiffness(surface)
    walls = Walls(design.wall_k, design.wall_margin, [[False, True], [True, True]])
    scene = Scene(surface, dt=design.dt, n_steps=steps, mode="quasistatic", mobility=(mu, mu), walls=walls)
    return simulate(scene, np.asarray(state, dtype=float).reshape(1, 2)).x[-1].copy()


def latched_state(design: DartGunDesign, surface: Surface | None = None, start=None) -> np.ndarray:
    """The latched equilibrium (1, 2): the end of a reload with 1.5 x the static latch force
    ``dart_k * latch_q0``, relaxed by :func:`settle`; a ValueError if that reload does not latch."""
    surface = dartgun_surface(design) if surface is None else surface
    force = 1.5 * design.dart_k * design.latch_q0
    res = run_reload(design, [force], surface=surface, start=start)
    if not res.latched[0]:
        raise ValueError(f"the reference reload (force {force:g}) did not latch; final state {res.final[0].tolist()}")
    return settle(design, res.final[:1], surface)


def min_reload_force(design: DartGunDesign, push_time: float, hi: float, tol: float,
                     surface: Surface | None = None, start=None, duration: float = 3.0) -> float:
    """Smallest reload force that latches (:func:`pes_ref.devices.probes.threshold_search`)."""
    surface = dartgun_surface(design) if surface is None else surface
    start = dartgun_start(design, surface) if start is None else start
    return threshold_search(lambda f: run_reload(design, f, push_time, duration, surface, start).latched,
                            0.0, hi, tol)


def exit_speeds(design: DartGunDesign, trigger_forces, push_time: float = 0.3, duration: float = 1.5,
                start=None, surface: Surface | None = None) -> np.ndarray:
    """Exit speed per trigger force (0 where the dart does not fire), one batched run."""
    return run_fire(design, trigger_forces, push_time, duration, start, surface).exit_speed


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
            f"reload_latched: {self.reload_latched} bool",
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


#: The analysis' defaults (``analyze dartgun`` uses and shows them): the reload push (force)
#: and how long it lasts (s), the trigger pushes (force) and how long each lasts (s), and the
#: upper end and bracket width of the search for the smallest force that reloads (force).
DARTGUN_ANALYSIS = {"reload_force": 30.0, "reload_time": 1.0, "trigger_forces": (10.0, 20.0, 30.0, 40.0),
                    "fire_time": 0.3, "search_hi": 40.0, "search_tol": 0.1}


def analyze_dartgun(design: DartGunDesign = DartGunDesign(), reload_force: float = DARTGUN_ANALYSIS["reload_force"],
                    reload_time: float = DARTGUN_ANALYSIS["reload_time"],
                    trigger_forces=DARTGUN_ANALYSIS["trigger_forces"], fire_time: float = DARTGUN_ANALYSIS["fire_time"],
                    search_hi: float = DARTGUN_ANALYSIS["search_hi"],
                    search_tol: float = DARTGUN_ANALYSIS["search_tol"]) -> DartGunReport:
    """Reload with ``reload_force`` for ``reload_time``, the smallest force that reloads, the exit
    speed for each trigger force (fired from the latched state), and the trajectories' bounding boxes."""
    reload_force = checks.as_positive_float("reload_force", reload_force)
    trigger_forces = checks.as_float_array("trigger_forces", np.atleast_1d(trigger_forces), ndim=1, nonneg=True)
    times = {}
    t = time.perf_counter()
    blocked = dartgun_cspace(design).blocked()
    times["cspace"] = time.perf_counter() - t
    t = time.perf_counter()
    surface = dartgun_surface(design, blocked)
    start = dartgun_start(design, surface)
    times["surface"] = time.perf_counter() - t
    t = time.perf_counter()
    rel = run_reload(design, [reload_force], reload_time, surface=surface, start=start)
    latched = settle(design, rel.final[:1], surface) if rel.latched[0] else latched_state(design, surface, start)
    fire = run_fire(design, trigger_forces, fire_time, start=latched, surface=surface)
    times["runs"] = time.perf_counter() - t
    t = time.perf_counter()
    fmin = min_reload_force(design, reload_time, search_hi, search_tol, surface, start)
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
                         float(blocked.mean()), tuple(design.shape), design.dt, k, 2.0 * np.sqrt(min(design.mass) / k),
                         times)
