"""Energy conservation, for any ``simulate``: how far a run's energy strays, the
leading-order budget of that error, and how it scales when ``dt`` is halved.

[`energy_drift`][pes_ref.testing.energy.energy_drift] runs ``simulate_fn(scene, x0, v0)`` and
measures its energy error ([`EnergyDrift`][pes_ref.testing.energy.EnergyDrift]);
[`drift_ratio`][pes_ref.testing.energy.drift_ratio] does it at ``dt`` and ``dt / 2`` (about 4 for a
second-order error, 2 for a first-order one);
[`energy_error_budget`][pes_ref.testing.energy.energy_error_budget] bounds it from the run's
crossings of kinks ([`pes_ref.testing.kinks`][pes_ref.testing.kinks]) and the scene's fastest mode
([`max_frequency`][pes_ref.testing.energy.max_frequency]);
[`max_speed`][pes_ref.testing.energy.max_speed] bounds a particle's speed, for a step short enough
to resolve the grid's cells.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from pes_ref.core.scene import Scene
from pes_ref.core.scene import energy as _energy
from pes_ref.core.scene import simulate as _simulate
from pes_ref.core.stability import term_stiffness
from pes_ref.testing.kinks import kink_signature

__all__ = ["max_frequency", "max_speed", "EnergyDrift", "energy_drift", "grid_slope_bound", "energy_error_budget",
           "DriftRatio", "drift_ratio"]


def max_frequency(scene: Scene) -> float:
    """An upper bound on the angular frequency of the stiffest mode, ``omega_max``.

    ``omega_max^2 = K / min m`` with ``K`` the sum over the smooth terms of
    [`pes_ref.core.stability.term_stiffness`][pes_ref.core.stability.term_stiffness] (the grid's
    cross curvature, the springs, the walls) of each one's largest stiffness: a bound of the summed
    Hessian's largest eigenvalue (Weyl's). It leaves out the slope's jumps at cell edges: they are
    kinks, which the energy tests budget for separately
    ([`energy_error_budget`][pes_ref.testing.energy.energy_error_budget]). Velocity Verlet is stable
    for ``omega_max dt < 2`` and its O(dt^2) energy error scales with ``(omega_max dt)^2``. Zero for
    a scene with no position-dependent force.
    """
    K = sum(float(np.max(k)) for k in term_stiffness(scene, edges=False).values())
    return float(np.sqrt(K / float(np.min(scene.mass))))


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
        The run (what ``simulate_fn`` returned), e.g. for
        [`energy_error_budget`][pes_ref.testing.energy.energy_error_budget].
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
    """Run ``simulate_fn(scene, x0, v0)`` and measure its energy error
    ([`EnergyDrift`][pes_ref.testing.energy.EnergyDrift]).

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
      periodic spring), the step that crosses adds ``dE = dF (Delta/2 - s) + dt^2 (F_2^2 - F_1^2) /
      8m``, with ``dF`` the jump, ``Delta`` the step's displacement and ``s`` where in it the jump
      lies. Bounded by ``|dF| (|Delta| / 2 + dt^2 F_max / 4m)``, with ``|dF| <= 2 S_d`` on the grid
      ([`grid_slope_bound`][pes_ref.testing.energy.grid_slope_bound]) and ``k_d L_d`` at a seam. The
      budget adds this for every crossing (``kink_signature`` changes), a worst case: real errors
      have random signs and add up far less.
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

    ``ratio = coarse.max_abs / fine.max_abs`` and ``ensemble_ratio`` (the same for the particle-mean
    error [`EnergyDrift.ensemble_error`][pes_ref.testing.energy.EnergyDrift.ensemble_error]): about
    4 for a second-order error, about 2 for a first-order one. Use ``ratio`` on smooth terms, where
    ``E_n - E_0 = dt^2 g(t_n) + O(dt^4)`` for one fixed function g; use ``ensemble_ratio`` over many
    independent particles where the error comes from kinks, since each contact's error depends on
    its phase within the step and a single trajectory's ratio is then a ratio of two random sums.
    """

    coarse: EnergyDrift
    fine: EnergyDrift

    @property
    def ratio(self) -> float:
        """``coarse.max_abs / fine.max_abs`` (NaN for 0/0, inf for x/0)."""
        return _ratio(self.coarse.max_abs, self.fine.max_abs)

    @property
    def ensemble_ratio(self) -> float:
        """The ratio of the particle-mean errors, ``coarse.ensemble_error() / fine.ensemble_error()``
        (NaN for 0/0, inf for x/0)."""
        return _ratio(self.coarse.ensemble_error(), self.fine.ensemble_error())


def _ratio(a: float, b: float, zero: float = np.nan) -> float:
    """a / b, with 0/0 = ``zero`` and x/0 = inf."""
    if b > 0:
        return a / b
    return zero if a == 0 else np.inf


def drift_ratio(simulate_fn, scene: Scene, x0, v0, *, energy_fn=None) -> DriftRatio:
    """Energy error at ``scene.dt`` over T steps and at ``dt / 2`` over 2T steps (the
    same time interval), as a [`DriftRatio`][pes_ref.testing.energy.DriftRatio]."""
    coarse = energy_drift(simulate_fn, scene, x0, v0, energy_fn=energy_fn)
    fine_scene = replace(scene, dt=scene.dt / 2.0, n_steps=2 * scene.n_steps)
    fine = energy_drift(simulate_fn, fine_scene, x0, v0, energy_fn=energy_fn)
    return DriftRatio(coarse, fine)
