"""A heightfield realization: a plate whose top surface is the energy, and a ball rolling on it.

A ball of mass ``m`` rolling under gravity ``g`` on a surface of height ``h(x, y)`` feels,
for small slopes, the horizontal force ``-m g grad h``: with ``h = (E - min E) / (m g)`` the
design's force ``-grad E`` (Xu & Virgin, J. Appl. Mech. 2019). Two things make the ball differ
from the design's particle (``docs/realize.md``):

- **Rolling inertia.** A solid ball rolling without slipping has kinetic energy
  ``(1/2)(m + I/r^2) |v|^2`` with ``I = (2/5) m r^2``: every force moves it as a mass of
  `ROLLING` ``= 7/5`` times m (the design's push, a tilt of the plate, too).
- **The slope.** Constrained to the surface, the horizontal part of gravity is
  ``-m g grad h / (1 + |grad h|^2)`` (the normal force tilts with the surface): the
  small-slope picture overstates it by ``|grad h|^2``, 1% at a slope of 0.1.

[`rolling_paths`][pes_ref.realize.heightfield.rolling_paths] runs the design's held-out particles as
balls: the design's scene with the mass ``7/5 m`` (pes_ref's own integrator,
[`pes_ref.simulate`][pes_ref.core.scene.simulate]), and with the slope too (the same damped velocity
Verlet, docs/spec.md section 5.1, with the surface's force scaled by ``1 / (1 + |grad h|^2)`` at
each state; the terms of the second order in the velocity, ``v^T H v grad h / (1 + |grad h|^2)``,
are left out). The surface is rebuilt from the exported STL
([`heights_from_mesh`][pes_ref.realize.heightfield.heights_from_mesh]).

[`heightfield_check`][pes_ref.realize.heightfield.heightfield_check] gives the figures of ``realize
--as heightfield``: the design's particle, the rolling ball with and without the slope, and the same
balls in MuJoCo ([`pes_ref.realize.mujoco_ball`][pes_ref.realize.mujoco_ball], the optional extra
``mujoco``), on the same held-out starts, pushes and noise draws, over the design's horizon or
``n_steps`` given.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from pes_ref.core import checks
from pes_ref.core.forces import force
from pes_ref.core.integrator import Trajectory, step_coefficients
from pes_ref.core.scene import simulate
from pes_ref.core.surface import spacing as grid_spacing

__all__ = ["ROLLING", "HeightField", "heightfield", "check_base", "heightfield_mesh", "heights_from_mesh", "rolling_paths",
           "HEIGHTFIELD_DEFAULTS", "HEIGHTFIELD_KINDS", "check_heightfield_kind", "heightfield_check"]

#: A solid ball's effective mass over its mass when it rolls without slipping: 1 + 2/5.
ROLLING = 7.0 / 5.0
#: The defaults of a heightfield realization: gravity (length / time^2 in the design's units)
#: and the plate's thickness below its lowest point (length).
HEIGHTFIELD_DEFAULTS = {"g": 9.81, "base": 0.05}
#: The kinds of design the rolling-ball check covers: its figures are the funnel's exits.
HEIGHTFIELD_KINDS = ("funnel",)


def check_heightfield_kind(problem) -> None:
    """Refuse a design the rolling-ball check does not cover (one line naming its kind)."""
    if problem.kind not in HEIGHTFIELD_KINDS:
        raise checks.InputError("as", f"--as heightfield checks {', '.join(HEIGHTFIELD_KINDS)} designs (a plane, "
                                      f"judged by its exits); this design is a {problem.kind!r} design")


@dataclass(frozen=True)
class HeightField:
    """The heights ``h = (E - min E) / (m g)`` (n0, n1) of design energy ``E`` on its grid."""

    heights: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    mass: float
    g: float

    @property
    def spacing(self) -> np.ndarray:
        """Node spacing of the heights' grid, shape (2,) (C-space length); neither axis is periodic."""
        return grid_spacing(self.lower, self.upper, self.heights.shape, np.array([False, False]))

    def slope(self) -> np.ndarray:
        """|grad h| at the nodes (central differences inside, one-sided at the edges)."""
        g0, g1 = np.gradient(self.heights, *self.spacing)
        return np.hypot(g0, g1)

    def energy(self) -> np.ndarray:
        """The energy the heights give a ball: ``m g h``."""
        return self.mass * self.g * self.heights


def _scalar_mass(scene) -> float:
    m = np.unique(np.asarray(scene.mass, dtype=np.float64))
    if m.size != 1:
        raise checks.InputError("as", "a heightfield needs one mass for every particle and axis")
    return float(m[0])


def heightfield(problem, values, g: float = HEIGHTFIELD_DEFAULTS["g"]) -> HeightField:
    """The heightfield of design ``values`` of ``problem`` (a plane) under gravity ``g``."""
    g = checks.as_positive_float("g", g)
    if any(problem.periodic):
        raise checks.InputError("as", "a heightfield realizes a plane (no periodic axis); this design's surface wraps")
    e = np.asarray(problem.surface_values(values), dtype=np.float64)
    m = _scalar_mass(problem.scene(values))
    heights = (e - e.min()) / (m * g)
    top, f32 = float(heights.max()), np.finfo(np.float32)
    if e.max() > e.min() and not float(f32.tiny) < top < float(f32.max) / 2:     # the STL stores float32 heights
        raise checks.InputError("g", f"g = {g:g} makes the plate's heights span {top:g}, which an STL file "
                                     f"(float32) cannot hold; use a g nearer 1 in the design's units")
    return HeightField(heights, np.asarray(problem.lower, dtype=np.float64),
                       np.asarray(problem.upper, dtype=np.float64), m, g)


def check_base(hf: HeightField, base: float) -> float:
    """``base`` (> 0) checked to leave the plate within an STL file's float32 range."""
    base = checks.as_positive_float("base", base)
    if not base + float(hf.heights.max()) < float(np.finfo(np.float32).max) / 2:
        raise checks.InputError("base", f"base must leave the plate within an STL file's float32 range, got {base:g}")
    return base


def heightfield_mesh(hf: HeightField, base: float):
    """A watertight plate: the heights on the grid's nodes as its top (two triangles per
    cell), a flat bottom ``base`` below height 0, and four side walls."""
    import trimesh
    base = check_base(hf, base)
    n0, n1 = hf.heights.shape
    q0 = np.linspace(hf.lower[0], hf.upper[0], n0)
    q1 = np.linspace(hf.lower[1], hf.upper[1], n1)
    X, Y = np.meshgrid(q0, q1, indexing="ij")
    top = np.stack([X.ravel(), Y.ravel(), hf.heights.ravel()], axis=1)
    bottom = np.stack([X.ravel(), Y.ravel(), np.full(n0 * n1, -base)], axis=1)
    idx = np.arange(n0 * n1).reshape(n0, n1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    faces = [np.stack([a, b, c], 1), np.stack([a, c, d], 1)]                       # top, facing +z
    off = n0 * n1
    faces += [np.stack([a, c, b], 1) + off, np.stack([a, d, c], 1) + off]           # bottom, facing -z
    ring = np.concatenate([idx[:, 0], idx[-1, 1:], idx[-2::-1, -1], idx[0, -2:0:-1]])  # the edge, counter-clockwise
    nxt = np.roll(ring, -1)
    faces += [np.stack([ring, nxt + off, nxt], 1), np.stack([ring, ring + off, nxt + off], 1)]  # sides, outward
    return trimesh.Trimesh(np.concatenate([top, bottom]), np.concatenate(faces), process=True)


def heights_from_mesh(mesh, like: HeightField) -> np.ndarray:
    """The heights of the grid's nodes read back from the top of an exported plate: each node's
    highest vertex (the STL holds float32 coordinates)."""
    v = np.asarray(mesh.vertices, dtype=np.float64)
    h = like.spacing
    i = np.rint((v[:, 0] - like.lower[0]) / h[0]).astype(int)
    j = np.rint((v[:, 1] - like.lower[1]) / h[1]).astype(int)
    out = np.full(like.heights.shape, -np.inf)
    np.maximum.at(out, (i, j), v[:, 2])
    if not np.isfinite(out).all():
        raise checks.InputError("as", "the exported plate lacks a vertex over some grid node")
    return out


def rolling_paths(problem, energy, seed: int, n_particles: int, g: float | None = None,
                  n_steps: int | None = None) -> Trajectory:
    """Held-out funnel particles as rolling balls on grid ``energy``: the design's batch from
    ``default_rng(seed)`` with every mass `ROLLING` times the design's; with ``g`` the
    surface's force is also scaled by ``1 / (1 + |grad h|^2)``, ``h = E / (m g)`` (module docstring).
    ``n_steps`` of the design's ``dt`` (default the design's own)."""
    batch = problem.plain().batch(np.asarray(energy, dtype=np.float64), np.random.default_rng(seed),
                                  n_particles, n_steps=n_steps)
    m = _scalar_mass(batch.scene)
    scene = dataclasses.replace(batch.scene, mass=ROLLING * m)
    if g is None:
        return simulate(scene, batch.x0, batch.v0)
    return _sloped(scene, batch.x0, batch.v0, m * checks.as_positive_float("g", g))


def _sloped(scene, x0, v0, weight: float) -> Trajectory:
    """The damped velocity Verlet of
    [`pes_ref.core.integrator.simulate_dynamic`][pes_ref.core.integrator.simulate_dynamic], the
    surface's force scaled by ``1 / (1 + |F_surface / weight|^2)`` (``weight = m g``)."""
    field = scene.field()
    surface_only = field._replace(spring=None, walls=None)
    fext = scene.schedule(x0.shape[0])
    n, T = x0.shape[0], scene.n_steps
    x, v, f = (np.empty((T + 1, n, 2)) for _ in range(3))
    a, c = step_coefficients(scene.dt, scene.mass, scene.damping, n)
    buf = np.empty((n, 2))

    def total(q, out):
        force(field, q, out)                     # surface + terms
        fs = force(surface_only, q, buf)
        scale = 1.0 / (1.0 + np.sum((fs / weight) ** 2, axis=1, keepdims=True))
        out -= fs * (1.0 - scale)                # the surface's part, shortened by the slope
        return out

    x[0], v[0] = x0, v0
    total(x[0], f[0])
    if fext is not None:
        f[0] += fext[0]
    for k in range(T):
        p = v[k] + a * f[k]
        x[k + 1] = x[k] + scene.dt * p
        total(x[k + 1], f[k + 1])
        if fext is not None:
            f[k + 1] += fext[k + 1]
        v[k + 1] = p + a * f[k + 1] if c is None else (p - c * v[k] + a * f[k + 1]) / (1.0 + c)
    return Trajectory(x, v, f)


def heightfield_check(problem, values, hf: HeightField, seed: int, n_particles: int, n_steps: int | None = None,
                      mujoco: bool | None = None) -> dict:
    """The held-out figures of the design ``values`` realized as heightfield ``hf`` (the heights
    read back from the plate): for the design's particle (``in_band_fraction``,
    ``exited_fraction``), the rolling ball (``rolling_*``), the rolling ball with the slope
    (``sloped_*``, and ``slope_exit_shift``: the mean ``|exit q0|`` change the slope causes over the
    balls exiting in both) and the ball in MuJoCo (``mujoco_*``, and ``mujoco_exit_shift`` against
    the rolling ball, ``mujoco_dt`` its timestep, ``mujoco_radius`` the ball's radius,
    ``mujoco_seconds`` its run's wall time), each on ``n_particles`` of held-out seed ``seed`` over
    ``n_steps`` of the design's ``dt`` (default the design's). ``mujoco``: True runs MuJoCo (its
    absence raises
    [`pes_ref.devices.geometry.MissingExtraError`][pes_ref.core.runtime.extras.MissingExtraError]),
    False leaves it out, None runs it when it is installed and otherwise sets ``mujoco`` to the line
    that installs it. ``exited`` counts the particles that reach the exit edge within the horizon:
    the in-band fraction is at most it."""
    import time
    from pes_ref.synthesis import exit_positions, funnel_paths
    seed = checks.as_nonneg_int("seed", seed)
    n = checks.as_positive_int("n_particles", n_particles)
    if n_steps is not None:
        n_steps = checks.as_positive_int("n_steps", n_steps)
    energy = hf.energy()
    exits = {"": exit_positions(problem, funnel_paths(problem, values, n, seed, n_steps).traj),
             "rolling_": exit_positions(problem, rolling_paths(problem, energy, seed, n, n_steps=n_steps)),
             "sloped_": exit_positions(problem, rolling_paths(problem, energy, seed, n, g=hf.g, n_steps=n_steps))}
    out = {"steps": int(problem.n_steps if n_steps is None else n_steps)}
    extra = {"slope_exit_shift": _shift(exits["sloped_"], exits["rolling_"])}
    if mujoco is not False:
        from pes_ref.devices.geometry import MissingExtraError
        from pes_ref.realize import mujoco_ball
        try:
            start = time.perf_counter()
            exits["mujoco_"] = exit_positions(problem, mujoco_ball.mujoco_paths(problem, hf, seed, n, n_steps))
            extra.update({"mujoco_exit_shift": _shift(exits["mujoco_"], exits["rolling_"]),
                          "mujoco_dt": float(problem.dt / mujoco_ball.substeps(problem.dt, hf.g)),
                          "mujoco_radius": float(mujoco_ball.BALL_RADIUS_SHARE * hf.spacing.min()),
                          "mujoco_seconds": time.perf_counter() - start})
        except MissingExtraError as exc:
            if mujoco:
                raise
            extra["mujoco"] = f"not run: {exc}"
    for prefix, e in exits.items():
        out[f"{prefix}in_band_fraction"] = float(np.mean(problem.in_band(e)))
        out[f"{prefix}exited_fraction"] = float(np.mean(np.isfinite(e)))
    out.update(extra)
    return out


def _shift(a: np.ndarray, b: np.ndarray) -> float:
    """The mean ``|a - b|`` over the particles exiting in both (NaN if none)."""
    both = np.isfinite(a) & np.isfinite(b)
    return float(np.mean(np.abs(a - b)[both])) if both.any() else float("nan")
