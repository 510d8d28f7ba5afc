"""The drive analysis of any device: push one axis, follow the other.

The first question about a mechanism: drive this axis, what does the other one do?
[`drive`][pes_ref.devices.drive.drive] applies a constant force or torque ``load`` on the driven axis (the input)
of a device's surface and runs it, quasistatically (each step moves the state by the
mobility times the net force, the paper's quasistatic mode) or dynamically (the device's
masses, damping and step), until the input has travelled the requested distance or
stalls. From the path it reads the *motion law*: the output at each point of the input's
travel (where the input first gets there), sampled every half input spacing, and:

- ``input_travel``: how far the input got along the load (radians or length);
- ``advance``: the output's change over that travel (whatever it was: a jammed run's is
  over the travel it achieved);
- ``advance_per_cycle_each``: for a periodic input, the output's change over each full
  turn (2 pi of travel) the input completed, in order;
- ``advance_per_cycle``: the steady advance: for a periodic input the last full turn's
  (the first one holds the start's transient: the parts settle from the file's start into
  their play, so the default of `DEFAULT_CYCLES` turns gives a steady one), NaN when
  the input did not complete a turn (a jam: never extrapolated from part of a turn, see
  ``advance``); for a translation, the change per unit of the travel achieved;
- ``moving_fraction``: the share of the input's steady travel during which
  ``|dq_out/dq_in| > threshold`` (default 0.05), the ratio taken across
  `RATIO_CELLS` input spacings;
- ``max_ratio``: the largest ``|dq_out/dq_in|`` over the steady travel;
- ``steady_from``: where the steady travel starts: a periodic input that completed two
  turns or more leaves its first turn out of ``moving_fraction`` and ``max_ratio`` (a
  follower set down at the surface's standoff drops onto a rigid cam at the start, a ratio
  far above the law's); otherwise 0, and the lines say the figures include the start;
- ``jammed``: whether the input stopped short of the requested travel, and where.

Requested travel: ``cycles`` full turns of a periodic input (default `DEFAULT_CYCLES`);
the distance from the start to the grid's edge (in the load's direction) for a translation.

Stall. The run goes in chunks; the input has stalled when, over the last stretch of
steps in which it would move `JAM_CELLS` input spacings without resistance, it
advanced less than `JAM_FRACTION` of a spacing (it moves at under 1% of its free
speed). A run that reaches `MAX_FREE_FACTOR` times the steps of a free run over the
requested travel also stops, as jammed.

Creases. The surface is bilinear in each cell, so its slope along an axis is constant across
a cell and jumps at the cell's edge; near a stiff barrier the jump can pass the load, and a
quasistatic input then stops on the edge where the parts pass (the ratchet's pawl at a tooth's
tip: ``dU/dq0`` 0.40 before the edge, 3.05 after it, under a load of 1; docs/rigid.md). So a
quasistatic drive on the surface that stalls looks again from the stall point with eq. (1) of
the exact distance to the C-space's boundary polyline (`pes_ref.devices.cspace.CSpace.segments`)
in place of the grid, and the same other forces (`pes_ref.devices.forces.scene_forces`):
if the input gets `CREASE_CELLS` spacings past the stall point within a stall window, the
drive goes on from there on the surface (``crease_passes`` counts such passes; the states of the
pass are the law's there); otherwise the stall stands.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field as dc_field

import numpy as np

from pes_ref.core import checks
from pes_ref.core.effects import Constant
from pes_ref.core.scene import simulate
from pes_ref.devices.device import Device

__all__ = ["DriveResult", "drive", "check_drive", "check_free", "drive_scene", "MODES", "JAM_CELLS", "JAM_FRACTION",
           "THRESHOLD", "DEFAULT_CYCLES", "CREASE_CELLS", "ratio"]

#: The drive's modes.
MODES = ("quasistatic", "dynamic")
#: |dq_out/dq_in| above which the output counts as moving.
THRESHOLD = 0.05
#: How far past a stall point (input spacings) a pass on eq. (1) of the exact distance must get
#: for the stall to be the grid's crease (module docstring).
CREASE_CELLS = 2.0
#: The turns of a periodic input a drive makes by default: the first holds the start's
#: transient, the second is steady (module docstring).
DEFAULT_CYCLES = 2
#: The stall window: the steps in which the unresisted input would move this many spacings ...
JAM_CELLS = 10.0
#: ... in which the input advanced less than this share of one spacing.
JAM_FRACTION = 0.1
#: A run stops (jammed) after this many times the steps a free run needs for the requested travel.
MAX_FREE_FACTOR = 200.0
#: States drawn per chunk of steps (the path of `DriveResult`).
PATH_PER_CHUNK = 64
#: Motion-law samples per input spacing.
SAMPLES_PER_CELL = 2
#: dq_out/dq_in is taken across this many input spacings (centred): the state chatters across
#: cell lines by up to a small fraction of a spacing, which over one sample would read as motion.
RATIO_CELLS = 4


def ratio(q_in: np.ndarray, q_out: np.ndarray) -> np.ndarray:
    """``dq_out/dq_in`` at every sample, by differences across `RATIO_CELLS` input spacings
    (one-sided near the ends); empty for fewer than two samples."""
    if q_in.size < 2:
        return np.empty(0)
    m = RATIO_CELLS * SAMPLES_PER_CELL // 2
    k = np.arange(q_in.size)
    lo, hi = np.maximum(k - m, 0), np.minimum(k + m, q_in.size - 1)
    return (q_out[hi] - q_out[lo]) / (q_in[hi] - q_in[lo])


@dataclass(frozen=True)
class DriveResult:
    """The outcome of [`drive`][pes_ref.devices.drive.drive].

    Attributes
    ----------
    q_in, q_out : ndarray, shape (S,)
        The motion law: the output where the input first reaches each sample of its travel.
    path : ndarray, shape (P, 2)
        The states, thinned to `PATH_PER_CHUNK` per chunk of steps (for drawing).
    """

    device: str
    drive: int
    load: float
    mode: str
    periodic_input: bool
    requested_travel: float
    input_travel: float
    advance: float
    advance_per_cycle: float
    advance_per_cycle_each: tuple
    moving_fraction: float
    max_ratio: float
    jammed: bool
    stop_reason: str
    stopped_at: tuple
    threshold: float
    steps: int
    q_in: np.ndarray = dc_field(repr=False)
    q_out: np.ndarray = dc_field(repr=False)
    path: np.ndarray = dc_field(repr=False)
    seconds: float = 0.0
    steady_from: float = 0.0
    crease_passes: int = 0

    def _steady_words(self) -> str:
        """Which travel ``moving_fraction`` and ``max_ratio`` are over."""
        cycles = len(self.advance_per_cycle_each)
        if self.steady_from > 0.0:
            return f"over cycles 2-{cycles} of {cycles}: the first, the start's transient, left out"
        if self.periodic_input:
            return "over the whole travel: it includes the start's transient (--cycles 2 or more leaves it out)"
        return "over the whole travel from the start"
    angle_input: bool = False       # the input part rotates: its travel is in rad, a whole turn or not

    def summary(self) -> dict:
        """The figures as plain JSON-able values."""
        return {"device": self.device, "drive": self.drive, "load": self.load, "mode": self.mode,
                "periodic_input": self.periodic_input, "requested_travel": self.requested_travel,
                "input_travel": self.input_travel, "advance": self.advance,
                "advance_per_cycle": None if np.isnan(self.advance_per_cycle) else self.advance_per_cycle,
                "advance_per_cycle_each": list(self.advance_per_cycle_each),
                "moving_fraction": self.moving_fraction, "moving_threshold": self.threshold,
                "max_ratio": self.max_ratio, "jammed": self.jammed, "stop_reason": self.stop_reason,
                "stopped_at": list(self.stopped_at), "steps": self.steps, "samples": int(self.q_in.size),
                "steady_from": self.steady_from, "crease_passes": self.crease_passes, "seconds": self.seconds}

    def as_lines(self) -> list:
        """``name: value unit`` lines; a figure that is a name, a flag or text (the device, the axis,
        the mode, jammed, the stop reason, the state q0,q1 where it stopped) has no unit."""
        u_in = "rad" if self.periodic_input or self.angle_input else "length"
        stop = f"{self.stopped_at[0]:.6g},{self.stopped_at[1]:.6g}"
        if self.periodic_input:
            each = ",".join(f"{a:.6g}" for a in self.advance_per_cycle_each) or "none"
            n = len(self.advance_per_cycle_each)
            per = [f"advance_per_cycle: {self.advance_per_cycle:.6g} output-unit per cycle ("
                   + (f"cycle {n} of {n}; cycle 1, the start's transient, left out)" if n >= 2
                      else "cycle 1 of 1: it includes the start's transient; --cycles 2 or more gives a steady one)"
                      if n == 1 else "no full cycle: the input stopped short of a turn; see advance)"),
                   f"advance_per_cycle_each: {each} output-unit per cycle"]
        else:
            per = [f"advance_per_cycle: {self.advance_per_cycle:.6g} output-unit per length (over the travel achieved)"]
        return [f"device: {self.device}",
                f"drive: q{self.drive}",
                f"load: {self.load:.6g} force-or-torque",
                f"mode: {self.mode}",
                f"requested_travel: {self.requested_travel:.6g} {u_in}",
                f"input_travel: {self.input_travel:.6g} {u_in}",
                f"advance: {self.advance:.6g} output-unit over the input's travel"
                + (" (jammed: not extrapolated)" if self.jammed else ""),
                *per,
                f"moving_fraction: {self.moving_fraction:.6g} 1 (|dq_out/dq_in| > {self.threshold:g}; "
                f"{self._steady_words()})",
                f"max_ratio: {self.max_ratio:.6g} 1 ({self._steady_words()})",
                f"jammed: {self.jammed}",
                f"stop_reason: {self.stop_reason}",
                f"stopped_at: {stop}",
                *([f"crease_passes: {self.crease_passes} passes (where the surface's bilinear slope held the "
                   f"input, eq. (1) of the exact distance to the boundary carried it on)"] if self.crease_passes else []),
                f"steps: {self.steps} steps",
                f"time_drive: {self.seconds:.3g} s"]


class _Law:
    """The motion law, built chunk by chunk: the output where the input's progress first
    reaches each multiple of ``spacing``."""

    def __init__(self, spacing: float, first_out: float):
        self.spacing, self.best, self.k = spacing, 0.0, 1
        self.s, self.out = [0.0], [first_out]

    def feed(self, p: np.ndarray, out: np.ndarray) -> None:
        """Progress ``p`` and output ``out`` of consecutive states (the first is the previous chunk's last)."""
        run = np.maximum.accumulate(np.maximum(p, self.best))
        targets = self.spacing * np.arange(self.k, int(np.floor(run[-1] / self.spacing)) + 1)
        if targets.size:
            i = np.searchsorted(run, targets, side="left")         # first state at or past each target (i >= 1)
            w = (targets - p[i - 1]) / (p[i] - p[i - 1])
            self.s += targets.tolist()
            self.out += (out[i - 1] + w * (out[i] - out[i - 1])).tolist()
            self.k += targets.size
        self.best = float(run[-1])


def _requested(device: Device, axis: int, sign: float, start: np.ndarray, cycles):
    if device.periodic[axis]:
        cycles = DEFAULT_CYCLES if cycles is None else checks.as_positive_int("cycles", cycles)
        return 2.0 * np.pi * cycles
    if cycles is not None:
        raise checks.InputError("cycles", f"cycles counts turns of a periodic input; q{axis} is not periodic "
                                          f"(the input travels to the grid's edge)")
    edge = device.upper[axis] if sign > 0 else device.lower[axis]
    travel = sign * (edge - start[axis])
    if not travel > 0:
        raise checks.InputError("start", f"start q{axis} = {start[axis]:g} is at or past the grid's edge "
                                         f"{edge:g} in the load's direction: nothing to drive")
    return float(travel)


def check_drive(device: Device, axis: int, load: float, mode: str = "quasistatic", cycles=None, start=None,
                threshold: float = THRESHOLD) -> tuple:
    """The arguments of [`drive`][pes_ref.devices.drive.drive], checked without computing anything (a keyed
    [`InputError`][pes_ref.core.checks.InputError] for a bad one): ``(axis, load, mode, requested
    travel, start (2,), threshold)``."""
    axis = checks.as_nonneg_int("axis", axis)
    if axis > 1:
        raise checks.InputError("axis", f"axis must be 0 or 1, got {axis}")
    load = checks.as_finite_float("load", load)
    if load == 0.0:
        raise checks.InputError("load", "load must be non-zero (its sign is the direction of travel), got 0")
    mode = checks.as_choice("mode", mode, set(MODES))
    threshold = checks.as_positive_float("threshold", threshold)
    start = device.start if start is None else checks.as_float_array("start", start, shape=(2,))
    for d in range(2):
        if not device.periodic[d] and not device.lower[d] <= start[d] <= device.upper[d]:
            raise checks.InputError("start", f"start q{d} = {start[d]:g} is outside the grid "
                                             f"[{device.lower[d]:g}, {device.upper[d]:g}]")
    requested = _requested(device, axis, 1.0 if load > 0 else -1.0, start, cycles)
    return axis, load, mode, requested, start, threshold


def check_free(device: Device, start) -> None:
    """Refuse a drive that has nowhere to go (a keyed [`InputError`][pes_ref.core.checks.InputError]):
    a C-space blocked at every node (key ``cspace``), or a start inside blocked space, where the
    posed parts' interiors overlap (key ``start``; a touch is free). Needs only the blocked nodes
    ([`Device.blocked`][pes_ref.devices.device.Device.blocked]), not the distance: it refuses before
    the costly part of the C-space is computed. The start is tested on the exact geometry."""
    from pes_ref.devices.geometry import interiors_overlap, posed_geometries

    if device.blocked().all():
        raise checks.InputError("cspace", f"no configuration is free: the parts' interiors overlap at every node "
                                          f"of the C-space grid (q0 in [{device.lower[0]:g}, {device.upper[0]:g}], "
                                          f"q1 in [{device.lower[1]:g}, {device.upper[1]:g}], "
                                          f"{device.shape[0]} x {device.shape[1]} nodes)")
    start = checks.as_float_array("start", start, shape=(2,))
    if interiors_overlap(*posed_geometries(*device.parts, start[0], start[1], device.grid.tolerance)):
        raise checks.InputError("start", f"start q = [{start[0]:g}, {start[1]:g}] is inside blocked space: the "
                                         f"parts' interiors overlap there; start from a free configuration")


def drive(device: Device, axis: int, load: float, mode: str = "quasistatic", cycles=None, start=None,
          threshold: float = THRESHOLD, progress=None, chunk: int = 4096, engine=None) -> DriveResult:
    """Drive ``axis`` of ``device`` with a constant ``load`` and follow the other axis.

    Parameters
    ----------
    device : Device
    axis : {0, 1}
        The driven axis (the input); the other is the output.
    load : float, non-zero
        The constant force (translation) or torque (rotation) on the input; its sign is
        the direction of travel.
    mode : {"quasistatic", "dynamic"}
    cycles : int, optional
        Full turns of a periodic input (default 1); refused for a translation, which
        travels to the grid's edge.
    start : array_like (2,), optional
        Default: the device's ``[start]``.
    threshold : float > 0
        ``|dq_out/dq_in|`` above which the output counts as moving.
    progress : callable, optional
        ``progress("drive", travelled, requested)`` after each chunk of steps.
    chunk : int
        Steps per chunk.
    engine : callable, optional
        ``engine(device, scene, x, v) -> Trajectory`` runs each chunk; default the surface
        model ([`pes_ref.core.scene.simulate`][pes_ref.core.scene.simulate] of the device's scene). The rigid engine
        ([`pes_ref.rigid.engine.simulate`][pes_ref.rigid.engine.simulate]) runs the parts in rigid contact instead.

    Returns
    -------
    DriveResult

    Raises
    ------
    pes_ref.core.checks.InputError
        A bad argument ([`check_drive`][pes_ref.devices.drive.check_drive]), a C-space with no free
        node or a start inside blocked space ([`check_free`][pes_ref.devices.drive.check_free]).
    """
    t_wall = time.perf_counter()
    axis, load, mode, requested, start, threshold = check_drive(device, axis, load, mode, cycles, start, threshold)
    check_free(device, start)
    sign = 1.0 if load > 0 else -1.0
    out_axis = 1 - axis
    h = float(device.spacing[axis])
    scene, free_steps = drive_scene(device, axis, load, mode, chunk)    # steps per spacing, unresisted
    window = max(1, int(np.ceil(JAM_CELLS * free_steps)))
    max_steps = int(np.ceil(MAX_FREE_FACTOR * free_steps * (requested / h + JAM_CELLS)))
    law = _Law(h / SAMPLES_PER_CELL, float(start[out_axis]))
    x = start[None, :].copy()
    v = np.zeros((1, 2))
    history = [0.0]                          # progress at the end of each chunk (for the stall test)
    path = [x.copy()]
    steps, reason, creases = 0, "done", 0
    every = max(1, chunk // PATH_PER_CHUNK)  # states between two drawn ones
    while True:
        traj = simulate(scene, x, v) if engine is None else engine(device, scene, x, v)
        xs = traj.x[:, 0]
        p = sign * (xs[:, axis] - start[axis])
        done = np.nonzero(p >= requested)[0]
        end = int(done[0]) + 1 if done.size else p.size
        law.feed(p[:end], xs[:end, out_axis])
        path.append(xs[1:end:every])
        if done.size:                                     # arrived within this chunk
            steps += int(done[0])
            x = xs[done[0]][None, :]
            break
        steps += chunk
        x, v = traj.x[-1], traj.v[-1]
        history.append(float(p[-1]))
        if progress is not None:
            progress("drive", min(law.best, requested), requested)
        back = int(np.ceil(window / chunk))
        if len(history) > back and history[-1] - history[-1 - back] < JAM_FRACTION * h:
            passed = _crease_pass(device, scene, x, axis, sign, load, h, window) \
                if engine is None and mode == "quasistatic" else None
            if passed is None:
                reason = "stalled"
                break
            p = sign * (passed[:, axis] - start[axis])
            law.feed(p, passed[:, out_axis])
            path.append(passed[1::every])
            steps += passed.shape[0] - 1
            creases += 1
            x, v = passed[-1][None, :], np.zeros((1, 2))
            history = [float(p[-1])]              # a new stall window from here
            continue
        if steps >= max_steps:
            reason = "step limit"
            break
    path.append(x)
    s = np.array(law.s)
    q_in = start[axis] + sign * s
    q_out = np.array(law.out)
    travel = float(sign * (x[0, axis] - start[axis]))
    jammed = reason != "done"
    advance, per_cycle, each = _advances(s, q_out, bool(device.periodic[axis]), requested, jammed)
    steady_from = 2.0 * np.pi if len(each) >= 2 else 0.0
    steady = ratio(q_in, q_out)[s >= steady_from * (1 - 1e-9)]      # the steady travel (module docstring)
    moving = float(np.mean(np.abs(steady) > threshold)) if steady.size else 0.0
    max_ratio = float(np.max(np.abs(steady))) if steady.size else 0.0
    return DriveResult(device.name, axis, load, mode, bool(device.periodic[axis]), requested, travel, advance,
                       per_cycle, each, moving, max_ratio, jammed, reason, tuple(float(q) for q in x[0]), threshold,
                       steps, q_in, q_out, np.concatenate(path), time.perf_counter() - t_wall, steady_from, creases,
                       bool(device.parts[axis].periodic))


def _exact_distance_each(segments, q, length, periodic) -> tuple:
    """The distance from ``q`` (2,) to each segment of ``segments`` (M, 2, 2), the nearest image
    across a periodic axis, and the vector from the segment's nearest point to ``q``: (M,), (M, 2)."""
    a, ab = segments[:, 0], segments[:, 1] - segments[:, 0]
    ab2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    dist, vec = np.full(segments.shape[0], np.inf), np.zeros((segments.shape[0], 2))
    for k0 in ((-1, 0, 1) if periodic[0] else (0,)):
        for k1 in ((-1, 0, 1) if periodic[1] else (0,)):
            qq = q + np.array([k0, k1]) * length
            t = np.clip(np.einsum("ij,ij->i", qq - a, ab) / ab2, 0.0, 1.0)
            diff = qq - (a + t[:, None] * ab)
            d = np.hypot(diff[:, 0], diff[:, 1])
            closer = d < dist
            dist[closer], vec[closer] = d[closer], diff[closer]
    return dist, vec


def _exact_distance(segments, q, length, periodic) -> tuple:
    """The distance from ``q`` (2,) to the polyline ``segments`` and its gradient, the unit vector
    from the nearest point to ``q``."""
    dist, vec = _exact_distance_each(segments, q, length, periodic)
    i = int(np.argmin(dist))
    return float(dist[i]), vec[i] / max(float(dist[i]), 1e-300)


def _crease_pass(device: Device, scene, x, axis: int, sign: float, load: float, h: float, window: int):
    """Quasistatic steps from the stall state ``x`` (1, 2) on eq. (1) of the exact distance to the
    C-space's boundary, the load and the scene's other forces (module docstring, "Creases"):
    the states (K, 2) up to the first one `CREASE_CELLS` input spacings past ``x``, or
    None when the input does not get there within ``window`` steps (the stall stands), or the
    state leaves free space."""
    from pes_ref.core.surface import Surface
    from pes_ref.devices.cspace import apf_slope, default_r_min
    from pes_ref.devices.forces import scene_forces, scene_wall_bounds
    cspace = device.cspace()
    if cspace.segments.size == 0:
        return None
    side = Surface(cspace.distance, device.lower, device.upper, device.periodic)   # the grid's signed distance
    length = np.asarray(device.upper, dtype=float) - np.asarray(device.lower, dtype=float)
    periodic = tuple(bool(p) for p in device.periodic)
    r_min = device.r_min if device.r_min is not None else default_r_min(device.spacing)
    mobility = np.broadcast_to(np.asarray(scene.mobility, dtype=float).reshape(-1), (2,))
    lo_hi = scene_wall_bounds(scene)
    push = np.zeros(2)
    push[axis] = load
    q = np.array(x[0], dtype=float)
    # the segments that eq. (1) can see (within r_c) of any state within ``margin`` of ``ref``,
    # chosen again once the state has moved farther
    margin = (CREASE_CELLS + 2.0) * float(np.max(device.spacing))
    ref = q.copy()
    segments = cspace.segments[_exact_distance_each(cspace.segments, q, length, periodic)[0] <= device.r_c + margin]
    goal = sign * q[axis] + CREASE_CELLS * h
    states, other = [q.copy()], np.zeros((1, 2))
    for _ in range(window):
        if np.hypot(*(q - ref)) > margin:
            ref = q.copy()
            segments = cspace.segments[_exact_distance_each(cspace.segments, q, length, periodic)[0] <= device.r_c + margin]
        if segments.size == 0:                  # nothing within r_c: eq. (1) is flat here
            d, grad = np.inf, np.zeros(2)
        else:
            d, grad = _exact_distance(segments, q, length, periodic)
        if d <= 0.0 or float(side.energy(q[None, :])[0]) < -0.5 * h:      # on or into blocked space
            return None
        slope = float(apf_slope(np.array([d]), device.v, device.r_c, r_min)[0]) if np.isfinite(d) else 0.0
        scene_forces(device, scene, q[None, :], np.zeros((1, 2)), lo_hi, other)
        q = q + mobility * (push + other[0] - slope * grad)
        states.append(q.copy())
        if sign * q[axis] >= goal:
            return np.array(states)
    return None


def _advances(s: np.ndarray, q_out: np.ndarray, periodic: bool, requested: float, jammed: bool) -> tuple:
    """(advance, advance_per_cycle, advance_per_cycle_each) of a motion law: the output ``q_out``
    at the input's travel ``s`` (module docstring). A periodic input's cycles end where its
    travel reaches each multiple of 2 pi (the output interpolated there); a run that was not
    jammed completed every requested cycle (its last sample may fall a rounding short)."""
    advance = float(q_out[-1] - q_out[0]) if s.size else 0.0
    span = float(s[-1]) if s.size else 0.0
    if not periodic:
        return advance, (advance / span if span > 0 else 0.0), ()
    turn = 2.0 * np.pi
    full = int(round(requested / turn)) if not jammed else int(np.floor(span / turn * (1 + 1e-9)))
    ends = np.interp(turn * np.arange(full + 1), s, q_out) if full else np.empty(0)
    each = tuple(float(a) for a in np.diff(ends))
    return advance, (each[-1] if each else float("nan")), each


def drive_scene(device: Device, axis: int, load: float, mode: str, n_steps: int) -> tuple:
    """The scene [`drive`][pes_ref.devices.drive.drive] runs (the constant ``load`` on ``axis``, in ``mode``,
    ``n_steps``
    steps) and the steps in which the unresisted input moves one input spacing: ``(scene,
    steps_per_spacing)``: quasistatically, a spacing over the mobility's step; dynamically, the
    longer of the damped drift's and the free fall's time per spacing from rest. [`drive`][pes_ref.devices.drive.drive]
    runs it, and so does a run that goes on from a drive's state (the rigid engine's look at a
    stall, [`pes_ref.rigid.engines`][pes_ref.rigid.engines])."""
    h = float(device.spacing[axis])
    force = np.zeros(2)
    force[axis] = load
    effects = (Constant(force),)
    if mode == "quasistatic":
        mobility = device.stable_mobility()
        scene = device.scene(n_steps, effects, mode="quasistatic", dt=1.0, mobility=mobility)
        return scene, h / (mobility[axis] * abs(load))
    scene = device.scene(n_steps, effects)
    m, c, f = device.mass[axis], device.damping[axis], abs(load)
    return scene, max(h * c / f, np.sqrt(2.0 * h * m / f)) / scene.dt
