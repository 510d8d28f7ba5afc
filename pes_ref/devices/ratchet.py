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

The surface is eq. (1) of the C-space (:mod:`pes_ref.devices.cspace`) plus the pawl's torsion
spring baked into the grid; the scene adds only the torque, inertia and damping.
"""
from __future__ import annotations

from dataclasses import dataclass, field as dc_field
import time

import numpy as np

from pes_ref.core import budget, checks
from pes_ref.devices.cspace import CSpaceGrid, GridSpring
from pes_ref.core.effects import PerParticle
from pes_ref.devices.geometry import Part, Polygon, Rotation
from pes_ref.core.stability import grid_stiffness
from pes_ref.devices.probes import steepest_slope, threshold_search
from pes_ref.core.integrator import Trajectory
from pes_ref.core.scene import Scene, simulate
from pes_ref.core.surface import Surface

__all__ = ["RatchetDesign", "ratchet_parts", "ratchet_cspace", "ratchet_surface", "ratchet_start",
           "ratchet_scene", "run_ratchet", "min_advancing_torque", "RatchetReport", "analyze_ratchet",
           "RATCHET_ANALYSIS"]


@dataclass(frozen=True)
class RatchetDesign:
    """Dimensions, stiffnesses and simulation settings of the ratchet (lengths in the parts' unit,
    angles in radians, torques in that unit's force times length, time in seconds).

    The defaults were chosen for a stable, fast run (docs/geometry.md, "Ratchet"): the
    barrier's largest stiffness on the grid keeps ``dt`` well inside the explicit limit.
    """

    n_teeth: int = 10
    root_radius: float = 0.75
    tip_radius: float = 1.0
    steep_width: float = 0.06          # angle from a root to the tip of its steep face
    hook_half_width: float = 0.06
    hook_radius: float = 0.8           # the hook's tip at q1 = 0 sits at (0, hook_radius)
    arm_height: float = 1.08           # the arm's lower edge (above tip_radius: clears the teeth)
    arm_thickness: float = 0.12
    arm_end: float = 1.0               # x of the arm's far end; the pivot is near it
    spring_k: float = 1.0              # torsion spring of the pawl
    spring_center: float = 0.3         # its rest angle (> 0: presses the hook into the teeth)
    v: float = 6e-5                    # eq. (1) strength
    r_c: float = 0.08                  # eq. (1) cut-off (radians)
    shape: tuple = (256, 256)
    dt: float = 1e-3
    mass: tuple = (1.0, 0.1)           # inertia of wheel and pawl
    damping: tuple = (1.0, 0.5)

    def __post_init__(self):
        checks.as_positive_int("n_teeth", self.n_teeth)
        for name in ("root_radius", "tip_radius", "steep_width", "hook_half_width", "hook_radius",
                     "arm_height", "arm_thickness", "arm_end", "r_c", "dt"):
            checks.as_positive_float(name, getattr(self, name))
        for name in ("spring_k", "v"):
            checks.as_nonneg_float(name, getattr(self, name))
        checks.as_finite_float("spring_center", self.spring_center)
        if not self.root_radius < self.hook_radius < self.tip_radius < self.arm_height:
            raise ValueError("need root_radius < hook_radius < tip_radius < arm_height, got "
                             f"{self.root_radius}, {self.hook_radius}, {self.tip_radius}, {self.arm_height}")
        if not self.steep_width < 2 * np.pi / self.n_teeth:
            raise ValueError(f"steep_width must be < the tooth pitch 2 pi / n_teeth, got {self.steep_width}")

    @property
    def pitch(self) -> float:
        """Angle of one tooth, 2 pi / n_teeth."""
        return 2.0 * np.pi / self.n_teeth

    @property
    def pivot(self) -> np.ndarray:
        """The pawl's pivot, in the middle of the arm's far end."""
        return np.array([self.arm_end - 0.5 * self.arm_thickness, self.arm_height + 0.5 * self.arm_thickness])


def _wheel(d: RatchetDesign) -> Polygon:
    i = np.arange(d.n_teeth)
    root = np.pi / 2 + i * d.pitch                 # a root at the top (under the hook) at q0 = 0
    tip = root + d.steep_width
    ang = np.stack((root, tip), axis=1).ravel()
    rad = np.tile([d.root_radius, d.tip_radius], d.n_teeth)
    return Polygon(np.stack((rad * np.cos(ang), rad * np.sin(ang)), axis=1))


def _pawl(d: RatchetDesign) -> Polygon:
    w, y0, y1 = d.hook_half_width, d.arm_height, d.arm_height + d.arm_thickness
    return Polygon([[-w, d.hook_radius], [w, d.hook_radius], [w, y0], [d.arm_end, y0],
                    [d.arm_end, y1], [-w, y1]])


def ratchet_parts(design: RatchetDesign = RatchetDesign()):
    """(wheel, pawl): the wheel turns by q0 about the origin, the pawl by q1 about its pivot."""
    return Part(_wheel(design), Rotation((0.0, 0.0))), Part(_pawl(design), Rotation(design.pivot))


def ratchet_cspace(design: RatchetDesign = RatchetDesign()) -> CSpaceGrid:
    """The torus [0, 2 pi) x [-pi, pi) on ``design.shape`` nodes."""
    wheel, pawl = ratchet_parts(design)
    return CSpaceGrid(wheel, pawl, (0.0, -np.pi), (2 * np.pi, np.pi), tuple(design.shape))


def ratchet_surface(design: RatchetDesign = RatchetDesign(), blocked=None) -> Surface:
    """Eq. (1) of the C-space plus the pawl's torsion spring (on the grid, periodic)."""
    spring = GridSpring(axis=1, k=design.spring_k, center=design.spring_center)
    return ratchet_cspace(design).surface(design.v, design.r_c, springs=(spring,), blocked=blocked)


def ratchet_scene(design: RatchetDesign, torques, duration: float, surface: Surface | None = None) -> Scene:
    """One particle per torque (shape (N,)), each a constant torque on the wheel, for ``duration``
    seconds (refused, naming ``duration``, when the run cannot fit in memory)."""
    torques = checks.as_float_array("torques", np.atleast_1d(torques), ndim=1)
    duration = checks.as_positive_float("duration", duration)
    n_steps = int(np.ceil(duration / design.dt))
    budget.check_memory(n_steps, torques.size, "simulate", steps="duration", fixed_particles=True,
                        length=f"duration = {duration:g} ({n_steps} steps of dt {design.dt:g})")
    surface = ratchet_surface(design) if surface is None else surface
    force = np.stack((torques, np.zeros_like(torques)), axis=1)
    return Scene(surface, dt=design.dt, n_steps=n_steps,
                 mass=np.array(design.mass), damping=np.array(design.damping), effects=(PerParticle(force),))


def ratchet_start(design: RatchetDesign = RatchetDesign(), surface: Surface | None = None,
                  settle: float = 3.0) -> np.ndarray:
    """The engaged rest state, shape (1, 2): the pawl, started lifted clear of the teeth at
    q0 = 0, swings in under its spring and settles for ``settle`` seconds without torque."""
    surface = ratchet_surface(design) if surface is None else surface
    x0 = np.array([[0.0, -0.5]])
    traj = simulate(ratchet_scene(design, [0.0], settle, surface), x0)
    return traj.x[-1].copy()


def run_ratchet(design: RatchetDesign, torques, duration: float, surface: Surface | None = None,
                start=None) -> Trajectory:
    """Run every torque from the engaged rest state; trajectory (T+1, N, 2)."""
    surface = ratchet_surface(design) if surface is None else surface
    torques = np.atleast_1d(np.asarray(torques, dtype=float))
    start = ratchet_start(design, surface) if start is None else np.asarray(start, dtype=float).reshape(1, 2)
    x0 = np.repeat(start, torques.size, axis=0)
    return simulate(ratchet_scene(design, torques, duration, surface), x0)


def _advances(design, surface, start, duration):
    def passes(torques):
        x = run_ratchet(design, torques, duration, surface, start).x
        return x[-1, :, 0] - x[0, :, 0] >= design.pitch
    return passes


def min_advancing_torque(design: RatchetDesign, duration: float, hi: float, tol: float,
                         surface: Surface | None = None, start=None) -> float:
    """Smallest torque that advances the wheel by at least one tooth within ``duration``."""
    surface = ratchet_surface(design) if surface is None else surface
    start = ratchet_start(design, surface) if start is None else start
    return threshold_search(_advances(design, surface, start, duration), 0.0, hi, tol)


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


def analyze_ratchet(design: RatchetDesign = RatchetDesign(), torque: float = RATCHET_ANALYSIS["torque"],
                    duration: float = RATCHET_ANALYSIS["duration"], search_hi: float = RATCHET_ANALYSIS["search_hi"],
                    search_tol: float = RATCHET_ANALYSIS["search_tol"],
                    search_duration: float = RATCHET_ANALYSIS["duration"]) -> RatchetReport:
    """Net rotation under +/- ``torque``, the pawl's swing, and the smallest advancing torque."""
    torque = checks.as_positive_float("torque", torque)
    times = {}
    t = time.perf_counter()
    cs = ratchet_cspace(design)
    blocked = cs.blocked()
    times["cspace"] = time.perf_counter() - t
    t = time.perf_counter()
    surface = ratchet_surface(design, blocked=blocked)
    start = ratchet_start(design, surface)
    times["surface"] = time.perf_counter() - t
    t = time.perf_counter()
    x = run_ratchet(design, [torque, -torque], duration, surface, start).x
    times["runs"] = time.perf_counter() - t
    t = time.perf_counter()
    tmin = min_advancing_torque(design, search_duration, search_hi, search_tol, surface, start)
    times["min_torque_search"] = time.perf_counter() - t
    rot = x[-1, :, 0] - x[0, :, 0]
    k = grid_stiffness(surface)
    return RatchetReport(torque, duration, float(rot[0]), float(rot[1]), float(rot[0] / design.pitch),
                         float(np.ptp(x[:, 0, 1])), float(tmin), search_tol, float(blocked.mean()),
                         tuple(design.shape), design.dt, k, 2.0 * np.sqrt(min(design.mass) / k),
                         steepest_slope(surface, 0), times)
