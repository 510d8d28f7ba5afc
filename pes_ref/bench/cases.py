"""The two design gradients that the benchmark times: the paper's funnel and oscillator.

A [`DesignCase`][pes_ref.bench.cases.DesignCase] is one gradient evaluation written as plain arrays
(surface, per-particle mass and damping, spring, walls, the realized external force schedule,
initial state, objective), so that the reference
([`reference_gradient`][pes_ref.bench.cases.reference_gradient]) and the benchmark's autograd and
JAX versions ([`pes_ref.bench.spec`][pes_ref.bench.spec]) compute exactly the same thing from the
same inputs. The scenes follow the paper's design problems (funnel: a plane, walls at the side
edges, a constant downward force plus noise, eq. (5) summed over every step; oscillator: a cylinder,
a spring along q0, low damping along q0 and high along q1, a per-particle torque, eq. (6));
``docs/performance.md`` lists their parameters.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from pes_ref.core.effects import Constant, Noise, PerParticle, build_schedule
from pes_ref.core.objectives import Funnel, Oscillator
from pes_ref.core.scene import Scene, value_and_grad
from pes_ref.core.surface import Surface
from pes_ref.core.terms import Spring, Walls, wall_bounds

__all__ = ["DesignCase", "smooth_surface", "funnel_case", "oscillator_case", "reference_gradient", "CASES"]


class DesignCase(NamedTuple):
    """One design-gradient evaluation as plain float64 arrays (shapes: N particles, T steps)."""

    name: str
    values: np.ndarray          # (n0, n1)
    lower: np.ndarray           # (2,)
    upper: np.ndarray           # (2,)
    periodic: tuple             # 2 bool
    dt: float
    n_steps: int
    mass: np.ndarray            # (N, 2)
    damping: np.ndarray         # (N, 2)
    spring_k: np.ndarray | None       # (N, 2) or None
    spring_center: np.ndarray | None  # (N, 2) or None
    wall_k: float
    wall_margin: float
    walls: np.ndarray           # (2, 2) bool
    fext: np.ndarray            # (T+1, N, 2), realized
    x0: np.ndarray              # (N, 2)
    v0: np.ndarray              # (N, 2)
    objective: tuple            # ("funnel", target) or ("oscillator", amplitude, omega)

    @property
    def h(self) -> np.ndarray:
        """Node spacing h, shape (2,): ``(upper - lower) / n`` on a periodic axis, ``/ (n - 1)``
        otherwise (C-space length)."""
        n = np.array(self.values.shape, dtype=np.float64)
        return (self.upper - self.lower) / np.where(self.periodic, n, n - 1.0)

    def wall_bounds(self):
        """Wall positions (lo, hi), each (2,), +-inf where an edge has no wall."""
        return wall_bounds(self.lower, self.upper, self.wall_margin, self.walls)


def smooth_surface(rng, lower, upper, shape: tuple, amplitude: float, modes: int = 3) -> np.ndarray:
    """A smooth random surface: ``amplitude`` times a sum of ``modes`` x ``modes`` Fourier
    modes per axis (wavelengths >= the domain's length / modes), random phases and weights.

    Smooth on purpose: on a rough random grid the bilinear surface's Hessian is large
    and the dynamics hyperbolic, so two correct implementations' rounding differences
    grow ~1.4x per step and their gradients part ways; design surfaces are smooth."""
    q = [np.linspace(lower[d], upper[d], shape[d], endpoint=False) for d in range(2)]
    t = [2 * math.pi * (q[d] - lower[d]) / (upper[d] - lower[d]) for d in range(2)]
    out = np.zeros(shape)
    for k0 in range(1, modes + 1):
        for k1 in range(1, modes + 1):
            p0, p1 = rng.uniform(0, 2 * math.pi, 2)
            out += rng.standard_normal() / (k0 * k1) * np.outer(np.cos(k0 * t[0] + p0), np.cos(k1 * t[1] + p1))
    return amplitude * out


def funnel_case(n_particles: int = 64, n_steps: int = 400, grid: int = 200, seed: int = 0) -> DesignCase:
    """The funnel: plane [-1, 1] x [0, 2], walls at q0 = +-0.98, force (0, -1), noise 0.3,
    damping 1, dt 0.01; particles start across the top at q1 = 1.9; loss eq. (5) summed
    over every step with target 0. The surface is a valley ``0.3 q0^2`` plus a smooth
    random one ([`smooth_surface`][pes_ref.bench.cases.smooth_surface], amplitude 0.05)."""
    rng = np.random.default_rng(seed)
    N, T = n_particles, n_steps
    lower, upper = np.array([-1.0, 0.0]), np.array([1.0, 2.0])
    x0 = np.stack([rng.uniform(-0.95, 0.95, N), np.full(N, 1.9)], axis=1)
    effects = (Constant((0.0, -1.0)), Noise((0.3, 0.3), seed=int(rng.integers(2 ** 31))))
    q0 = np.linspace(lower[0], upper[0], grid)
    values = 0.3 * q0[:, None] ** 2 + smooth_surface(rng, lower, upper, (grid, grid), 0.05)
    return DesignCase(
        "funnel", values, lower, upper, (False, False), 0.01, T,
        np.ones((N, 2)), np.ones((N, 2)), None, None, 1000.0, 0.02, np.array([[True, True], [False, False]]),
        build_schedule(effects, N, T, 0.01), x0, np.zeros((N, 2)), ("funnel", 0.0))


def oscillator_case(n_particles: int = 64, n_steps: int = 500, grid: tuple = (32, 32), seed: int = 0) -> DesignCase:
    """The oscillator: cylinder [-2.5, 2.5] x [0, 2 pi) (q1 periodic), spring k = (1, 0) to
    q0 = 0, damping (0.05, 2), walls at q0 = +-2.45, torque -tau along q1 with tau uniform
    in [0.5, 1], dt 0.05; particles start at rest at q0 ~ 1.2, q1 = 0; loss eq. (6) with
    amplitude 1, omega 1. The surface is a smooth random one ([`smooth_surface`][pes_ref.bench.cases.smooth_surface],
    amplitude 0.05)."""
    rng = np.random.default_rng(seed)
    N, T = n_particles, n_steps
    lower, upper = np.array([-2.5, 0.0]), np.array([2.5, 2 * math.pi])
    x0 = np.stack([1.2 + 0.05 * rng.standard_normal(N), np.zeros(N)], axis=1)
    tau = rng.uniform(0.5, 1.0, N)
    effects = (PerParticle(np.stack([np.zeros(N), -tau], axis=1)),)
    return DesignCase(
        "oscillator", smooth_surface(rng, lower, upper, tuple(grid), 0.05), lower, upper, (False, True), 0.05, T,
        np.ones((N, 2)), np.tile([0.05, 2.0], (N, 1)), np.tile([1.0, 0.0], (N, 1)), np.zeros((N, 2)),
        100.0, 0.05, np.array([[True, True], [False, False]]),
        build_schedule(effects, N, T, 0.05), x0, np.zeros((N, 2)), ("oscillator", 1.0, 1.0))


CASES = {"funnel": funnel_case, "oscillator": oscillator_case}


def reference_scene(case: DesignCase) -> Scene:
    """The case as a [`pes_ref.Scene`][pes_ref.core.scene.Scene] (its external force is passed as ``fext``)."""
    spring = None if case.spring_k is None else Spring(case.spring_k, case.spring_center)
    return Scene(Surface(case.values, case.lower, case.upper, case.periodic), dt=case.dt, n_steps=case.n_steps,
                 mass=case.mass, damping=case.damping, spring=spring,
                 walls=Walls(case.wall_k, case.wall_margin, case.walls))


def reference_objective(case: DesignCase):
    if case.objective[0] == "funnel":
        return Funnel(target=case.objective[1], when="every_step")
    return Oscillator(amplitude=case.objective[1], omega=case.objective[2])


def reference_gradient(case: DesignCase, scene: Scene | None = None, objective=None, backend: str | None = None):
    """``(loss, dL/dvalues)`` by pes_ref's adjoint (``value_and_grad(..., wrt="values")``) on
    ``backend`` (None: the default, [`pes_ref.core.backends.default_backend`][pes_ref.core.backends.default_backend])."""
    scene = reference_scene(case) if scene is None else scene
    objective = reference_objective(case) if objective is None else objective
    loss, grads, _ = value_and_grad(scene, case.x0, case.v0, objective, wrt=("values",), fext=case.fext,
                                    backend=backend)
    return loss, grads["values"]
