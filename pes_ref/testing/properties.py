"""Plain property checks that any implementation can run with its own simulate and gradient.

Nothing here needs hypothesis: each function takes callables with the signatures of
:func:`pes_ref.simulate` and :func:`pes_ref.value_and_grad`, runs them on a
:class:`pes_ref.Scene`, and returns numbers (errors, ratios, distances) that a test
compares with a tolerance. An implementation under test wraps its own entry points::

    def my_simulate(scene, x0, v0, *, fext="scene"):
        ...   # returns an object with x, v, f of shape (T+1, N, 2)

    def my_value_and_grad(scene, x0, v0, objective, *, regularization_weight=0.0,
                          wrt=None, fext="scene"):
        ...   # returns (loss, {name: gradient}, ...)

and the properties then read, for example::

    check = check_gradient_fd(my_value_and_grad, scene, x0, v0, objective,
                              simulate_fn=my_simulate)
    assert check.valid and check.max_error < FD_RTOL

Kinks. The discrete program is piecewise smooth: the bilinear slope jumps at cell
edges (including the clip edges of a non-periodic axis, where the constant extension
begins), a wall's force has a kink at its onset, and a spring on a periodic axis jumps
at its minimum-image seam. A finite difference that straddles one of them is not a
derivative. :func:`kink_distance` measures how close a trajectory passes to any kink
(for a cheap ``assume`` before the check); :func:`kink_signature` records which smooth
piece every state is in, and :func:`check_gradient_fd` compares it between the base and
every perturbed run, so it knows exactly when a difference crossed a kink.
"""
from __future__ import annotations

from dataclasses import dataclass, field as dc_field, replace

import numpy as np

from pes_ref.core.effects import step_times
from pes_ref.core.scene import Scene
from pes_ref.core.scene import energy as _energy
from pes_ref.core.scene import simulate as _simulate
from pes_ref.core.stability import grid_cross_curvature
from pes_ref.core.surface import Surface
from pes_ref.core.terms import Spring, wall_bounds
from pes_ref.oracle.case import grad_names_for
from pes_ref.oracle.tolerances import FD_EPS

__all__ = ["grid_cross_curvature", "grid_slope_bound", "stiffness_bound", "max_frequency", "max_speed",
           "EnergyDrift", "energy_drift", "energy_error_budget", "DriftRatio", "drift_ratio",
           "kink_distance", "distance_to_kinks", "kink_signature",
           "relative_difference", "ShiftCheck", "check_periodic_shift", "rolled_scene", "check_grid_roll",
           "GradientCheck", "check_gradient_fd", "gradient_names", "get_parameter", "with_parameter",
           "loss_conditioning", "chaotic_case", "gradient_growth_rate"]


# =========================================================================== stiffness

def stiffness_bound(scene: Scene) -> float:
    """``K = c_grid + max k_spring + k_wall``: the stiffness that :func:`max_frequency`
    and the strategies' time steps and mobilities (:mod:`pes_ref.testing.strategies`)
    are scaled by.

    ``c_grid`` is the largest cross curvature of the bilinear grid,
    :func:`pes_ref.core.stability.grid_cross_curvature`. Unlike the core's stability
    limit (:func:`pes_ref.core.stability.axis_stiffness`) it leaves out the slope's
    jumps at cell edges (they are kinks, which the energy tests budget for separately)
    and adds the terms of both axes together. 0 for a scene with no
    position-dependent force.
    """
    K = grid_cross_curvature(scene.surface)
    if scene.spring is not None:
        K += float(np.max(scene.spring.k))
    if scene.walls is not None and scene.walls.edges.any():
        K += scene.walls.k
    return K


def max_frequency(scene: Scene) -> float:
    """An upper bound on the angular frequency of the stiffest term, ``omega_max``.

    ``omega_max^2 = K / min m`` with ``K`` the :func:`stiffness_bound` (``max k_spring +
    k_wall + c_grid``). Velocity Verlet is stable for ``omega_max dt < 2`` and its
    O(dt^2) energy error scales with ``(omega_max dt)^2``. Zero for a scene with no
    position-dependent force.
    """
    return float(np.sqrt(stiffness_bound(scene) / float(np.min(scene.mass))))


def max_speed(scene: Scene, x0, v0) -> float:
    """An upper bound of any particle's speed along a conservative run (no damping gain,
    no external force): ``sqrt(2 max_i (E_i - min G) / min m)``, since springs and
    walls only add energy above the grid's lowest value.

    With it, ``dt = r min(h) / max_speed`` keeps every step shorter than ``r`` cells,
    the resolution the O(dt) energy error at cell edges needs to be in its asymptotic
    regime.
    """
    traj = _simulate(replace(scene, n_steps=0, effects=()), x0, v0)
    e = np.asarray(_energy(scene, traj))[0]
    m = float(np.min(scene.mass))
    return float(np.sqrt(2.0 * max(float(np.max(e - scene.surface.values.min())), 0.0) / m))


# =========================================================================== energy

@dataclass(frozen=True)
class EnergyDrift:
    """How far the energy of one run strays from its start.

    Attributes
    ----------
    energies : ndarray (T+1, N)
        Energy per state and particle.
    max_abs : float
        ``max_n |E_n - E_0|`` of the total (summed over particles) energy.
    max_increase : float
        ``max_n (E_n - E_0)`` of the total energy, never below 0: what damping must
        not produce beyond the discretization error.
    kinetic_scale : float
        ``sum_{i,d} max_n m v_{n,i,d}^2 / 2``: for springs, an upper bound of the
        oscillation energy of every particle and axis, the scale of the O(dt^2) error.
    trajectory : object
        The run (what ``simulate_fn`` returned), e.g. for :func:`energy_error_budget`.
    """

    energies: np.ndarray
    max_abs: float
    max_increase: float
    kinetic_scale: float
    trajectory: object = None

    def total_error(self, fraction: float = 1.0) -> float:
        """``max |E_n - E_0|`` of the total energy over the first ``fraction`` of the run."""
        E = np.sum(self.energies, axis=1)
        return float(np.max(np.abs(E[: _upto(len(E), fraction)] - E[0])))

    def ensemble_error(self, fraction: float = 1.0) -> float:
        """The mean over particles of ``max_n |E_{n,i} - E_{0,i}|`` over the first
        ``fraction`` of the run: independent particles form an ensemble, and the mean
        averages out the phase of each contact with a kink within its step."""
        E = self.energies[: _upto(len(self.energies), fraction)]
        return float(np.mean(np.max(np.abs(E - E[0]), axis=0)))

    def growth(self, fraction: float = 0.25, *, ensemble: bool = True) -> float:
        """The error over the whole run over the error over its first ``fraction``.

        With ``fraction = 1/4``: about 1 for a bounded error, about 2 = sqrt(4) for a
        diffusing one (errors of random sign at each crossing of a kink), about 4 for
        a secular (linear) drift. 1 when both are 0.
        """
        f = self.ensemble_error if ensemble else self.total_error
        return _ratio(f(1.0), f(fraction), zero=1.0)


def _upto(n: int, fraction: float) -> int:
    return max(int(round(fraction * (n - 1))) + 1, 1)


def energy_drift(simulate_fn, scene: Scene, x0, v0, *, energy_fn=None) -> EnergyDrift:
    """Run ``simulate_fn(scene, x0, v0)`` and measure its energy error (:class:`EnergyDrift`).

    Meaningful without external force (energy is conserved by the ODE only then). With
    ``damping = 0``, velocity Verlet keeps the error O(dt^2) and bounded on smooth
    terms (springs); at a wall's onset (a jump of the force's derivative) each contact
    adds an O(dt^2) error whose size depends on where in the step it happens, and at
    a bilinear cell edge (a jump of the force) an O(dt) one of random sign, so there
    the error diffuses. With damping > 0, ``max_increase`` stays within the
    discretization error.
    """
    traj = simulate_fn(scene, x0, v0)
    energy_fn = _energy if energy_fn is None else energy_fn
    Ep = np.asarray(energy_fn(scene, traj), dtype=np.float64)      # (T+1, N)
    E = np.sum(Ep, axis=1)
    m = np.broadcast_to(scene.mass, traj.v.shape[1:])
    kin = 0.5 * m * traj.v * traj.v                                # (T+1, N, 2)
    return EnergyDrift(
        energies=Ep,
        max_abs=float(np.max(np.abs(E - E[0]))),
        max_increase=float(max(np.max(E - E[0]), 0.0)),
        kinetic_scale=float(np.sum(kin.max(axis=0))),
        trajectory=traj,
    )


def grid_slope_bound(surface) -> np.ndarray:
    """``S_d = max |G[next node along d] - G| / h_d``, shape (2,): a bound of the bilinear
    slope along each axis (the slope interpolates these differences)."""
    G = surface.values
    out = np.zeros(2)
    for d in range(2):
        nxt = np.roll(G, -1, axis=d) if surface.periodic[d] else None
        diff = (nxt - G) if nxt is not None else np.diff(G, axis=d)
        out[d] = float(np.max(np.abs(diff))) / surface.spacing[d]
    return out


def energy_error_budget(scene: Scene, traj, *, smooth_c: float = 0.3) -> float:
    """A leading-order bound of ``max_n |E_n - E_0|`` for a run without external force.

    Velocity Verlet's energy error has two parts (docs/spec.md section 5):

    - where the force jumps (a cell edge or clip edge of the grid, the seam of a
      periodic spring), the step that crosses adds
      ``dE = dF (Delta/2 - s) + dt^2 (F_2^2 - F_1^2) / 8m``, with ``dF`` the jump,
      ``Delta`` the step's displacement and ``s`` where in it the jump lies. Bounded
      by ``|dF| (|Delta| / 2 + dt^2 F_max / 4m)``, with ``|dF| <= 2 S_d`` on the grid
      (:func:`grid_slope_bound`) and ``k_d L_d`` at a seam. The budget adds this for
      every crossing (``kink_signature`` changes), a worst case: real errors have
      random signs and add up far less.
    - the smooth part, at most ``smooth_c (omega_max dt)^2 K`` (``K`` the kinetic
      scale; 1/4 for a harmonic oscillator), counted once per contact with a wall or a
      crossing, where the modified energy that keeps it bounded is reset.

    Quasistatic runs have no energy to conserve; this is for dynamic ones.
    """
    x, v, f = np.asarray(traj.x), np.asarray(traj.v), np.asarray(traj.f)
    N = x.shape[1]
    s = scene.surface
    m = np.broadcast_to(scene.mass, (N, 2))
    dt = scene.dt
    change = np.abs(np.diff(kink_signature(scene, x), axis=0))   # (T, N, 2, 4)
    # |dF| (|Delta| / 2 + dt^2 F_max / 4m) per step, particle and axis, per unit jump
    fmax = float(np.max(np.abs(f), initial=0.0))
    per_step = 0.5 * np.abs(np.diff(x, axis=0)) + (dt * dt * fmax / 4.0) / m
    jumps = change[..., 0] * (2.0 * grid_slope_bound(s))          # cell and clip edges
    if scene.spring is not None:                                  # minimum-image seams
        k = np.broadcast_to(scene.spring.k, (N, 2))
        jumps = jumps + change[..., 3] * np.where(s.periodic, k * s.length, 0.0)
    kinks = float(np.sum(jumps * per_step))
    contacts = 1 + int(np.count_nonzero(change))
    kin = 0.5 * m * v * v
    smooth = smooth_c * (max_frequency(scene) * dt) ** 2 * float(np.sum(kin.max(axis=0)))
    return kinks + contacts * smooth


@dataclass(frozen=True)
class DriftRatio:
    """Energy errors of a run at ``dt`` and at ``dt / 2`` over the same time interval.

    ``ratio = coarse.max_abs / fine.max_abs`` and ``ensemble_ratio`` (the same for the
    particle-mean error :attr:`EnergyDrift.ensemble_error`): about 4 for a
    second-order error, about 2 for a first-order one. Use ``ratio`` on smooth
    terms, where ``E_n - E_0 = dt^2 g(t_n) + O(dt^4)`` for one fixed function g; use
    ``ensemble_ratio`` over many independent particles where the error comes from
    kinks, since each contact's error depends on its phase within the step and a
    single trajectory's ratio is then a ratio of two random sums.
    """

    coarse: EnergyDrift
    fine: EnergyDrift

    @property
    def ratio(self) -> float:
        return _ratio(self.coarse.max_abs, self.fine.max_abs)

    @property
    def ensemble_ratio(self) -> float:
        return _ratio(self.coarse.ensemble_error(), self.fine.ensemble_error())


def _ratio(a: float, b: float, zero: float = np.nan) -> float:
    """a / b, with 0/0 = ``zero`` and x/0 = inf."""
    if b > 0:
        return a / b
    return zero if a == 0 else np.inf


def drift_ratio(simulate_fn, scene: Scene, x0, v0, *, energy_fn=None) -> DriftRatio:
    """Energy error at ``scene.dt`` over T steps and at ``dt / 2`` over 2T steps (the
    same time interval), as a :class:`DriftRatio`."""
    coarse = energy_drift(simulate_fn, scene, x0, v0, energy_fn=energy_fn)
    fine_scene = replace(scene, dt=scene.dt / 2.0, n_steps=2 * scene.n_steps)
    fine = energy_drift(simulate_fn, fine_scene, x0, v0, energy_fn=energy_fn)
    return DriftRatio(coarse, fine)


# =========================================================================== kinks

def _axis_arrays(scene: Scene, x: np.ndarray):
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 2:
        x = x[None]
    return x, x.shape[-2]


def kink_distance(scene: Scene, x, *, grid: bool = True) -> float:
    """The smallest distance from any position in ``x`` to a kink of the scene's force.

    Parameters
    ----------
    scene : Scene
    x : array_like, shape (T+1, N, 2) or (N, 2)
        Positions (unwrapped), e.g. ``traj.x``.
    grid : bool
        Count the grid's cell edges (every node line, and the clip edges where a
        non-periodic axis's constant extension begins). Leave True for gradient
        checks: on a constant grid the lines are not kinks of the force, but they are
        of its derivative with respect to the grid values.

    Returns
    -------
    float
        :func:`distance_to_kinks` of the scene's grid, walls and spring.
    """
    s = scene.surface
    walls = None if scene.walls is None else wall_bounds(s.lower, s.upper, scene.walls.margin, scene.walls.edges)
    spring = None if scene.spring is None else (scene.spring.k, scene.spring.center)
    return distance_to_kinks(x, s.lower, s.spacing, s.shape, s.periodic, s.length,
                             walls=walls, spring=spring, grid=grid)


def distance_to_kinks(x, lower, h, shape, periodic, length, *, walls=None, spring=None,
                      grid: bool = True) -> float:
    """The smallest distance from any position in ``x`` to a kink of a force, given as
    plain arrays (:func:`kink_distance` takes them from a scene; the unit tests of the
    force kernels from their plain-array description).

    Parameters
    ----------
    x : array_like, shape (..., N, 2)
        Positions (unwrapped).
    lower, h, length : array_like (2,)
        The grid's lower corner, node spacing and domain length.
    shape : (n0, n1)
        The grid's shape.
    periodic : sequence of 2 bool
    walls : (lo, hi) of arrays (2,), optional
        The wall positions, ``-inf``/``inf`` where an axis has none
        (:func:`pes_ref.core.terms.wall_bounds`).
    spring : (k, center), optional
        Broadcastable to (N, 2); a seam counts on a periodic axis where ``k_d != 0``.
    grid : bool
        Count the grid's cell edges (see :func:`kink_distance`).

    Returns
    -------
    float
        Distance in position units, per axis (the kinks are lines ``q_d = const``):
        cell edges, wall onsets ``a_d``/``b_d``, and the minimum-image seam
        ``c_d + L_d/2 (mod L_d)`` of a spring with ``k_d != 0`` on a periodic axis.
        ``inf`` when there is none.
    """
    x = np.asarray(x, dtype=np.float64)
    N = x.shape[-2]
    best = np.inf
    for d in range(2):
        q = x[..., d]
        if grid:
            u = (q - lower[d]) / h[d]
            if periodic[d]:
                fr = u - np.floor(u)
                dist = h[d] * np.minimum(fr, 1.0 - fr)
            else:
                uc = np.clip(u, 0.0, shape[d] - 1.0)
                fr = uc - np.floor(uc)
                dist = np.where(u != uc, np.abs(u - uc), np.minimum(fr, 1.0 - fr)) * h[d]
            best = min(best, float(dist.min()))
        if walls is not None:
            for b in (walls[0][d], walls[1][d]):
                if np.isfinite(b):
                    best = min(best, float(np.abs(q - b).min()))
        if spring is not None and periodic[d]:
            k = np.broadcast_to(spring[0], (N, 2))[:, d]
            if np.any(k != 0):
                c = np.broadcast_to(spring[1], (N, 2))[:, d]
                L = length[d]
                w = (q - c + 0.5 * L) / L
                fr = w - np.floor(w)
                dist = L * np.minimum(fr, 1.0 - fr)
                best = min(best, float(dist[..., k != 0].min()))
    return best


def kink_signature(scene: Scene, x) -> np.ndarray:
    """Which smooth piece of the force every position is in, shape (..., N, 2, 4) int.

    Per axis: the grid cell (``floor`` of the unwrapped cell coordinate on a periodic
    axis; on a non-periodic one -1 below the span, ``n_d - 1`` above it, else the cell
    ``min(floor(u), n_d - 2)``), whether the lower and the upper wall push, and on a
    periodic axis with a spring the minimum-image branch ``floor((q - c + L/2) / L)``.
    Two runs with equal signatures at every state went through the same polynomial
    pieces, so a finite difference between them is a true derivative.
    """
    x, N = _axis_arrays(scene, x)
    s = scene.surface
    h = s.spacing
    sig = np.zeros(x.shape + (4,), dtype=np.int64)
    for d in range(2):
        q = x[..., d]
        u = (q - s.lower[d]) / h[d]
        if s.periodic[d]:
            sig[..., d, 0] = np.floor(u)
        else:
            n = s.shape[d]
            cell = np.minimum(np.floor(np.clip(u, 0.0, n - 1.0)), n - 2)
            sig[..., d, 0] = np.where(u < 0, -1, np.where(u > n - 1, n - 1, cell))
        if scene.walls is not None:
            if scene.walls.edges[d, 0]:
                sig[..., d, 1] = q < s.lower[d] + scene.walls.margin
            if scene.walls.edges[d, 1]:
                sig[..., d, 2] = q > s.upper[d] - scene.walls.margin
        if scene.spring is not None and s.periodic[d]:
            c = np.broadcast_to(scene.spring.center, (N, 2))[:, d]
            L = s.length[d]
            sig[..., d, 3] = np.floor((q - c + 0.5 * L) / L)
    return sig


# =========================================================================== comparisons

def relative_difference(got, want) -> float:
    """``max |got - want| / max(max |got|, max |want|)`` over whole arrays (0 if both are 0).

    One scale per compared array, so entries near zero are judged against the
    array's largest entry, as rounding errors are.
    """
    got = np.asarray(got, dtype=np.float64)
    want = np.asarray(want, dtype=np.float64)
    diff = float(np.max(np.abs(got - want), initial=0.0))
    if diff == 0.0:
        return 0.0
    scale = max(float(np.max(np.abs(got), initial=0.0)), float(np.max(np.abs(want), initial=0.0)))
    return diff / scale


def _run(simulate_fn, scene, x0, v0, **kw):
    return simulate_fn(scene, np.asarray(x0, dtype=np.float64), np.asarray(v0, dtype=np.float64), **kw)


def _compare_runs(scene_a, a, scene_b, b, shift, energy_fn) -> dict:
    """Relative differences of two runs whose positions should differ by ``shift``."""
    energy_fn = _energy if energy_fn is None else energy_fn
    Ea = np.asarray(energy_fn(scene_a, a))
    Eb = np.asarray(energy_fn(scene_b, b))
    return {
        "force0": relative_difference(b.f[0], a.f[0]),
        "force": relative_difference(b.f, a.f),
        "x": _shifted_difference(a.x, b.x, shift),
        "v": relative_difference(b.v, a.v),
        "energy": relative_difference(Eb, Ea),
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
    """The outcome of :func:`check_periodic_shift` and :func:`check_grid_roll`.

    Attributes
    ----------
    differences : dict str -> float
        Relative differences (:func:`relative_difference`) of ``force0`` (the force at
        state 0), ``force``, ``x`` (after subtracting the shift; scaled by the largest
        position of either run), ``v`` and ``energy`` (per state and particle). All
        are rounding-level (~1e-13) unless a position lies within rounding of a kink.
    kink_distance : float
        :func:`kink_distance` of the unshifted run: within rounding of a kink, the two
        lookups may pick different cells (either one-sided value is allowed there).
    """

    differences: dict
    kink_distance: float

    @property
    def max_difference(self) -> float:
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

    ``values' = np.roll(values, k, axis)`` puts node ``i`` at ``i + k``; moving every
    particle (and the spring centre, :func:`rolled_scene`) by ``k h`` along that axis
    must give the same run, positions shifted by ``k h``.

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


# =========================================================================== gradients

def gradient_names(scene: Scene) -> tuple:
    """The gradients of docs/spec.md section 7 that a scene has, in :data:`pes_ref.GRADIENT_NAMES` order
    (:func:`pes_ref.oracle.case.grad_names_for` of its mode and spring)."""
    return grad_names_for(scene.mode, scene.spring is not None)


#: Each differentiable input: how to read it from ``(scene, x0, v0, fext)`` and how to
#: replace it (``damping`` of an undamped scene reads as the scalar 0).
_PARAMETERS = {
    "values": (lambda s, x0, v0, f: s.surface.values, lambda s, x0, v0, f, u: (s.with_values(u), x0, v0, f)),
    "x0": (lambda s, x0, v0, f: x0, lambda s, x0, v0, f, u: (s, u, v0, f)),
    "v0": (lambda s, x0, v0, f: v0, lambda s, x0, v0, f, u: (s, x0, u, f)),
    "force": (lambda s, x0, v0, f: f, lambda s, x0, v0, f, u: (s, x0, v0, u)),
    "mass": (lambda s, x0, v0, f: s.mass, lambda s, x0, v0, f, u: (replace(s, mass=u), x0, v0, f)),
    "damping": (lambda s, x0, v0, f: 0.0 if s.damping is None else s.damping,
                lambda s, x0, v0, f, u: (replace(s, damping=u), x0, v0, f)),
    "mobility": (lambda s, x0, v0, f: s.mobility, lambda s, x0, v0, f, u: (replace(s, mobility=u), x0, v0, f)),
    "spring_k": (lambda s, x0, v0, f: s.spring.k,
                 lambda s, x0, v0, f, u: (replace(s, spring=Spring(u, s.spring.center)), x0, v0, f)),
    "spring_center": (lambda s, x0, v0, f: s.spring.center,
                      lambda s, x0, v0, f, u: (replace(s, spring=Spring(s.spring.k, u)), x0, v0, f)),
}


def get_parameter(scene: Scene, x0, v0, fext, name: str) -> np.ndarray:
    """The current value of the differentiable input ``name`` (a float64 copy).

    ``fext`` is the realized external force (T+1, N, 2); ``damping`` of an undamped
    scene is the scalar 0.
    """
    getter = _PARAMETERS.get(name)
    if getter is None:
        raise ValueError(f"unknown gradient name {name!r}")
    out = getter[0](scene, x0, v0, fext)
    return np.array(out, dtype=np.float64, copy=True)


def with_parameter(scene: Scene, x0, v0, fext, name: str, value):
    """``(scene, x0, v0, fext)`` with the input ``name`` replaced by ``value``."""
    setter = _PARAMETERS.get(name)
    if setter is None:
        raise ValueError(f"unknown gradient name {name!r}")
    return setter[1](scene, x0, v0, fext, value)


@dataclass
class GradientCheck:
    """The outcome of :func:`check_gradient_fd`.

    Attributes
    ----------
    errors : dict str -> float
        Relative error per gradient name beyond the difference's own rounding noise.
        Directional: ``max(|fd - <g, u>| - noise, 0) / max(|g|, |fd|)`` with ``u`` a
        random unit direction (a dot-product test); full: the same entry by entry,
        over ``max |fd|``.
    raw_errors : dict str -> float
        The same without subtracting the noise: ``|fd - <g, u>| / max(|g|, |fd|)``.
    resolution : dict str -> float
        ``noise / max(|g|, |fd|)``: the smallest relative error this difference can
        see. Above the tolerance, the name was checked only to its rounding noise.
    noise : dict str -> float
        The estimated rounding error of the difference, ``eps_mach * kappa / h`` (four
        times that for the one-sided formula), with ``kappa`` the loss's
        conditioning (:func:`loss_conditioning`) and ``h`` the step. Where the
        gradient is far larger than this (the usual case) ``errors`` equals
        ``raw_errors``; where it is not, no difference can resolve it to 1e-6.
    fd, adjoint : dict str -> float or ndarray
        The finite difference and the adjoint's value (directional derivatives, or
        whole gradients when ``full``).
    crossed : dict str -> bool
        True where a perturbed run went through a different smooth piece than the base
        run (:func:`kink_signature`): that name's finite difference is not a derivative.
    kink_distance : float
        :func:`kink_distance` of the base run.
    near_kink : bool
        The base run came within ``kink_margin`` of a kink; no difference was taken.
    loss : float
        The loss that ``value_and_grad_fn`` returned.
    """

    errors: dict = dc_field(default_factory=dict)
    raw_errors: dict = dc_field(default_factory=dict)
    resolution: dict = dc_field(default_factory=dict)
    noise: dict = dc_field(default_factory=dict)
    fd: dict = dc_field(default_factory=dict)
    adjoint: dict = dc_field(default_factory=dict)
    crossed: dict = dc_field(default_factory=dict)
    kink_distance: float = np.inf
    near_kink: bool = False
    loss: float = np.nan

    @property
    def valid(self) -> bool:
        """No difference was taken across a kink (and the base run kept its margin)."""
        return not self.near_kink and not any(self.crossed.values())

    @property
    def max_error(self) -> float:
        """The largest of :attr:`errors` (0 if none was taken)."""
        return max(self.errors.values(), default=0.0)


_EPS_MACH = float(np.finfo(np.float64).eps)

#: Lower bounds of the parameters that have one: a central difference there would
#: step outside; one-sided differences are used instead (docs/spec.md section 8: m > 0, gamma >= 0, k >= 0, mu > 0).
_LOWER_BOUND = {"mass": 0.0, "damping": 0.0, "spring_k": 0.0, "mobility": 0.0}

#: Inputs with a natural positive scale: their difference step is ``eps * max |p|``.
_RELATIVE_STEP = ("mass", "damping", "spring_k", "mobility")


def _step(name: str, p: np.ndarray, eps: float) -> float:
    """The difference step: ``eps`` times the input's scale for the positive physical
    parameters (a mobility of 1e-3 needs a step of 1e-9, not 1e-6), else ``eps``."""
    if name in _RELATIVE_STEP:
        scale = float(np.max(np.abs(p), initial=0.0))
        if scale > 0.0:
            return eps * scale
    return eps


def loss_conditioning(objective, traj, times, loss: float) -> float:
    """The size of a loss's rounding error in units of the machine epsilon, ``kappa``.

    ``kappa = |L| + (T+1) sum_n (|dL/dX_n| |X_n| + |dL/dV_n| |V_n|)``: every state
    carries rounding relative to its own size, accumulated over up to T+1 steps, and
    reaches the loss through the objective's derivatives. A central difference with
    step ``h`` then carries a rounding error of about ``eps_mach kappa / h``.
    """
    _, gx, gv = objective.value_and_grad(traj.x, traj.v, times)
    kappa = 0.0
    if gx is not None:
        kappa += float(np.sum(np.abs(gx) * np.abs(traj.x)))
    if gv is not None:
        kappa += float(np.sum(np.abs(gv) * np.abs(traj.v)))
    return abs(float(loss)) + traj.x.shape[0] * kappa


def _difference(loss_at, name, p, u, h, bound):
    """``d/ds L(p + s u)`` at 0 with step ``h``: central, or the one-sided second-order
    formula where the central one would step below the input's lower bound.

    Returns ``(derivative, crossed_a_kink, one_sided)``.
    """
    if bound is not None and float(np.min(p - h * u)) <= bound:
        l0, c0 = loss_at(name, p)
        l1, c1 = loss_at(name, p + h * u)
        l2, c2 = loss_at(name, p + 2.0 * h * u)
        return (-3.0 * l0 + 4.0 * l1 - l2) / (2.0 * h), (c0 or c1 or c2), True
    lp, cp = loss_at(name, p + h * u)
    lm, cm = loss_at(name, p - h * u)
    return (lp - lm) / (2.0 * h), (cp or cm), False


def _beyond(diff, noise, scale):
    """``max(diff - noise, 0) / scale``, elementwise, with 0/0 = 0."""
    excess = np.maximum(np.asarray(diff) - noise, 0.0)
    return np.where(excess == 0.0, 0.0, excess / np.maximum(scale, 1e-300))


def check_gradient_fd(value_and_grad_fn, scene: Scene, x0, v0, objective, names=None, *,
                      regularization_weight: float = 0.0, kink_margin: float = 0.0, full: bool = False,
                      seed: int = 0, eps: float = FD_EPS, simulate_fn=None) -> GradientCheck:
    """Check gradients of docs/spec.md section 7 against central finite differences of the loss.

    Parameters
    ----------
    value_and_grad_fn : callable
        ``(scene, x0, v0, objective, *, regularization_weight, wrt, fext) -> (loss, grads, ...)``,
        the signature of :func:`pes_ref.value_and_grad`; ``grads[name]`` shaped like the
        input (``fext`` is passed as the realized (T+1, N, 2) schedule).
    scene, x0, v0 : the case
    objective : an object with ``value_and_grad(x, v, t)`` (:mod:`pes_ref.core.objectives`)
    names : sequence of str, optional
        Gradients to check (default :func:`gradient_names`).
    regularization_weight : float
        R of the paper's eq. (7); the differenced loss includes ``R sum G^2`` (for
        ``values``; for every other input it is a constant and left out, which only
        lowers the rounding noise).
    kink_margin : float
        If the base run passes closer than this to a kink (:func:`kink_distance`), take
        no difference (``near_kink``; a hypothesis test then ``assume``-s it away).
    full : bool
        Entry by entry (2 runs per entry) instead of one random unit direction per name
        (2 runs per name, a dot-product test ``<g, u>`` against ``dL/du``).
    seed : int
        Seeds the directions (``numpy.random.default_rng``).
    eps : float
        The difference step: ``eps`` for ``values``, ``x0``, ``v0``, ``force``,
        ``spring_center``; ``eps * max |p|`` for the positive physical parameters
        ``mass``, ``damping``, ``spring_k``, ``mobility``. Where a central difference
        would step below a lower bound (``damping`` of an undamped scene, say), the
        one-sided second-order ``(-3 L(0) + 4 L(h) - L(2h)) / (2h)`` along ``|u|`` is used.
    simulate_fn : callable, optional
        The forward run for the differences, with the signature of
        :func:`pes_ref.simulate` (default: ``pes_ref.simulate``). Pass your own so that
        your gradient is checked against differences of your own forward program.

    Returns
    -------
    GradientCheck
        Test ``check.valid`` (else the example straddles a kink: skip it) and
        ``check.max_error < FD_RTOL``.
    """
    simulate_fn = _simulate if simulate_fn is None else simulate_fn
    x0 = np.array(x0, dtype=np.float64)
    v0 = np.array(v0, dtype=np.float64)
    N = x0.shape[0]
    fext = scene.schedule(N)
    fext = np.zeros((scene.n_steps + 1, N, 2)) if fext is None else fext
    names = gradient_names(scene) if names is None else tuple(names)
    R = float(regularization_weight)
    times = step_times(scene.n_steps, scene.dt, scene.t0)

    out = GradientCheck()
    base = simulate_fn(scene, x0, v0, fext=fext)
    base_sig = kink_signature(scene, base.x)
    out.kink_distance = kink_distance(scene, base.x)
    if out.kink_distance < kink_margin:
        out.near_kink = True
        return out
    res = value_and_grad_fn(scene, x0, v0, objective, regularization_weight=R, wrt=names, fext=fext)
    out.loss, grads = float(res[0]), res[1]
    reg = R * float(np.sum(scene.surface.values ** 2)) if R else 0.0
    kappa_values = loss_conditioning(objective, base, times, out.loss)
    kappa_other = loss_conditioning(objective, base, times, out.loss - reg)

    def loss_at(name, value):
        sc, a, b, f = with_parameter(scene, x0, v0, fext, name, value)
        traj = simulate_fn(sc, a, b, fext=f)
        crossed = not np.array_equal(kink_signature(sc, traj.x), base_sig)
        val = objective.value_and_grad(traj.x, traj.v, times)[0]
        if R and name == "values":     # R sum G^2 is a constant for every other input
            val += R * float(np.sum(sc.surface.values ** 2))
        return float(val), crossed

    rng = np.random.default_rng(seed)
    for name in names:
        p = get_parameter(scene, x0, v0, fext, name)
        g = np.asarray(grads[name], dtype=np.float64)
        if g.shape != p.shape:
            raise ValueError(f"gradient {name!r} has shape {g.shape}, its input {p.shape}")
        h = _step(name, p, eps)
        bound = _LOWER_BOUND.get(name)
        noise1 = _EPS_MACH * (kappa_values if name == "values" else kappa_other) / h
        if full:
            fd = np.zeros_like(p)
            noise = np.zeros_like(p)
            crossed = False
            for i in np.ndindex(p.shape):
                u = np.zeros_like(p)
                u[i] = 1.0
                fd[i], c, one_sided = _difference(loss_at, name, p, u, h, bound)
                noise[i] = noise1 * (4.0 if one_sided else 1.0)
                crossed |= c
            scale = float(np.max(np.abs(fd), initial=0.0))
            diff = np.abs(g - fd)
            out.fd[name], out.adjoint[name], out.noise[name] = fd, g, noise
            out.raw_errors[name] = float(_beyond(diff.max(initial=0.0), 0.0, scale))
            out.errors[name] = float(np.max(_beyond(diff, noise, scale), initial=0.0))
            out.resolution[name] = float(_beyond(noise.max(initial=0.0), 0.0, scale))
        else:
            u = rng.standard_normal(p.shape)
            u /= max(float(np.linalg.norm(u)), 1e-300)
            if bound is not None and float(np.min(p - h * np.abs(u))) <= bound:
                u = np.abs(u)          # at the bound: step inward only
            fd, crossed, one_sided = _difference(loss_at, name, p, u, h, bound)
            ad = float(np.sum(g * u))
            scale = max(float(np.linalg.norm(g)), abs(fd))
            noise = noise1 * (4.0 if one_sided else 1.0)
            out.fd[name], out.adjoint[name], out.noise[name] = fd, ad, noise
            out.raw_errors[name] = float(_beyond(abs(fd - ad), 0.0, scale))
            out.errors[name] = float(_beyond(abs(fd - ad), noise, scale))
            out.resolution[name] = float(_beyond(noise, 0.0, scale))
        out.crossed[name] = bool(crossed)
    return out


# =========================================================================== chaos

def chaotic_case(dt: float = 0.02):
    """``(scene, x0, v0)``: one particle whose motion is chaotic.

    The smooth torus potential ``cos q0 + cos q1 + cos(q0 + 2 q1) / 2`` sampled on
    16 x 16 nodes (2 pi periods), one particle with more kinetic energy than any
    barrier: the gradient of its final state with respect to its start grows like
    ``exp(lambda t)`` (:func:`gradient_growth_rate`).
    """
    n = 16
    q = np.arange(n) * 2 * np.pi / n
    G = np.cos(q[:, None]) + np.cos(q[None, :]) + 0.5 * np.cos(q[:, None] + 2 * q[None, :])
    scene = Scene(Surface(G, (0, 0), (2 * np.pi, 2 * np.pi), (True, True)), dt=dt, n_steps=1)
    return scene, np.array([[1.0, 2.0]]), np.array([[1.3, 0.7]])


def gradient_growth_rate(value_and_grad_fn, scene: Scene, x0, v0, objective, n_steps_list) -> tuple:
    """How fast ``|dL/dx0|`` grows with the horizon: ``(rate, norms)``.

    ``norms[k] = |dL/dx0|`` at ``T = n_steps_list[k]``; ``rate`` the least-squares slope
    of ``log norms`` against ``t = T dt`` (per unit time): the largest Lyapunov exponent
    seen by the gradient on a chaotic scene, about 0 on an integrable one (polynomial
    growth). A long-horizon gradient is then only as useful as ``exp(-rate t)``
    says; the rate is to be reported, not hidden.
    """
    norms = []
    for T in n_steps_list:
        res = value_and_grad_fn(replace(scene, n_steps=int(T)), x0, v0, objective, wrt=["x0"])
        norms.append(float(np.linalg.norm(res[1]["x0"])))
    t = np.asarray(n_steps_list, dtype=np.float64) * scene.dt
    return float(np.polyfit(t, np.log(norms), 1)[0]), np.asarray(norms)
