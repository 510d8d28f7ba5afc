"""The funnel of the paper's Figs. 6-7: particles pushed down a plane to exit near a target.

Its design metric is the share of the batch that exits within `IN_BAND_SHARE` of the domain width
from the target ([`exit_positions`][pes_ref.synthesis.kinds.funnel.exit_positions]); its objective
is eq. (5), charged where each particle leaves the domain by default (`FUNNEL_OBJECTIVES`). Made
realizable, its grid values are a level set that starts from one of `INIT_SHAPES`.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from pes_ref.core import checks
from pes_ref.core.effects import Constant, Noise
from pes_ref.core.integrator import Trajectory
from pes_ref.core.objectives import Funnel
from pes_ref.core.scene import Scene
from pes_ref.core.surface import Surface
from pes_ref.core.terms import Walls
from pes_ref.synthesis.kinds.envelope import convex_channel, envelope_start
from pes_ref.synthesis.common.exits import FunnelExit, exit_steps
from pes_ref.synthesis.common.level_set import LevelSet
from pes_ref.synthesis.common.problems import Batch, _check_fields, _Problem

__all__ = ["FunnelProblem", "IN_BAND_SHARE", "exit_positions", "FUNNEL_OBJECTIVES", "INIT_SHAPES"]

#: A funnel particle is "in band" when its exit |q0 - target| is below this share of the width.
IN_BAND_SHARE = 0.10


@dataclass(frozen=True)
class FunnelProblem(_Problem):
    """The funnel of the paper's Figs. 6-7 on the plane ``[-width/2, width/2] x [0, height]``.

    Particles start at uniform random q0 across the top, ``start_depth`` below it, inside a strip of
    depth ``start_zone`` held at zero energy; a constant force ``-force`` along q1 plus Gaussian
    noise of std ``noise`` per step and axis push them down; walls of stiffness ``wall_k`` stand
    ``wall_margin`` inside the two side edges (q0). The objective is eq. (5) with
    weight-``regularization`` eq. (7) added, charged where it is chosen by ``when``
    (`FUNNEL_OBJECTIVES`): ``"exit"`` (the default) at the q0 where each particle leaves the domain
    ([`pes_ref.synthesis.common.exits.FunnelExit`][pes_ref.synthesis.common.exits.FunnelExit]),
    ``"final"`` at the last step, ``"every_step"`` summed over every step. A strip of depth
    ``exit_zone`` at the bottom is held at zero energy (0 by default: none). ``"final"`` needs one
    (docs/synthesis.md measures it with ``exit_zone = 0.05``): the surface extends as a constant
    beyond the bottom edge, so without it a design charged at the last step can keep steering
    particles after they leave the domain. Grid axis 0 is q0, axis 1 is q1; ``grid`` nodes per axis.
    ``linger`` weighs a term of the exit cost on the time particles spend above the exit edge
    ([`pes_ref.synthesis.common.exits.FunnelExit`][pes_ref.synthesis.common.exits.FunnelExit]).

    ``realizable`` makes the design realizable as designed (``docs/realize.md``): the grid values
    become a level set
    ([`pes_ref.synthesis.common.level_set.LevelSet`][pes_ref.synthesis.common.level_set.LevelSet]),
    the shape ``{values + contact_r_c < 0}``, and the surface is eq. (1) with strength
    ``contact_v``, cut-off ``contact_r_c`` and cap ``contact_r_min`` of the exact distance to that
    shape, on the ``grid`` x ``grid`` surface whatever the stage's grid of values. The shape starts
    as ``init_shape`` (`INIT_SHAPES`): the convex envelope of a smooth funnel's paths, made by
    design (``"envelope"``, the default:
    [`pes_ref.synthesis.kinds.envelope`][pes_ref.synthesis.kinds.envelope]), two strips
    ``init_strip`` wide along the walled sides (``"strips"``), or a V whose gap at the exit edge is
    ``2 init_gap`` wide (``"vee"``). A design from the envelope ends on its channel with convex
    walls ([`final_values`][pes_ref.synthesis.kinds.funnel.FunnelProblem.final_values]).
    """

    kind: ClassVar[str] = "funnel"
    #: The name of `batch_metric` in progress lines and summaries.
    metric_name: ClassVar[str] = "in_band"
    grid: int = 200
    width: float = 2.0
    height: float = 2.0
    start_zone: float = 0.3
    exit_zone: float = 0.0
    start_depth: float = 0.1
    force: float = 1.0
    noise: float = 0.3
    damping: float = 1.0
    dt: float = 0.01
    n_steps: int = 350
    target: float = 0.0
    wall_k: float = 1000.0
    wall_margin: float = 0.02
    init_scale: float = 1e-3
    when: str = "exit"
    regularization: float = 0.0
    linger: float = 0.0
    realizable: bool = False
    contact_v: float = 1.08e-4
    contact_r_c: float = 0.06
    contact_r_min: float = 0.02
    init_strip: float = 0.03
    init_shape: str = "envelope"
    init_gap: float = 0.15

    def __post_init__(self):
        _check_fields(self)
        checks.as_choice("when", self.when, set(FUNNEL_OBJECTIVES))
        if self.linger and self.when != "exit":
            raise checks.InputError("linger", f"linger is a term of the exit cost (when = 'exit'), got when = "
                                              f"{self.when!r}", names=("linger", "when"))
        if not isinstance(self.realizable, bool):
            raise checks.InputTypeError("realizable", f"realizable must be true or false, got {self.realizable!r}")
        checks.as_choice("init_shape", self.init_shape, set(INIT_SHAPES))
        checks.as_positive_float("init_gap", self.init_gap)
        checks.as_nonneg_float("init_strip", self.init_strip)
        if self.realizable:
            object.__setattr__(self, "level_set", LevelSet(self.contact_v, self.contact_r_c, self.contact_r_min))

    def plain(self) -> "FunnelProblem":
        """This problem with ``realizable`` off (itself when it is off): the grid values are the surface's
        energies (a realized device's surface)."""
        return dataclasses.replace(self, realizable=False) if self.realizable else self

    # ------------------------------------------------------------------ geometry
    @property
    def lower(self):
        """The domain's lower corner ``(-width / 2, 0)`` (C-space length)."""
        return (-self.width / 2, 0.0)

    @property
    def upper(self):
        """The domain's upper corner ``(width / 2, height)`` (C-space length)."""
        return (self.width / 2, self.height)

    periodic = (False, False)

    def shape(self, grid: int | None = None) -> tuple:
        """The grid shape ``(n, n)``: n the problem's ``grid``, or the ``grid`` given (a stage's)."""
        n = self.grid if grid is None else grid
        return (n, n)

    def initial_values(self, rng, shape: tuple) -> np.ndarray:
        """Small random values (std ``init_scale``); with ``realizable``, the starting shape
        ``init_shape`` (`INIT_SHAPES`) below the start strip (a level set's shape only
        moves where its contour is: the walls grow from it). The ``"envelope"`` designs a
        smooth funnel first, from seeds drawn from ``rng``
        ([`pes_ref.synthesis.kinds.envelope.envelope_start`][pes_ref.synthesis.kinds.envelope.envelope_start])."""
        if not self.realizable:
            return super().initial_values(rng, shape)
        if self.init_shape == "envelope":
            free = envelope_start(self, rng, shape)
        else:
            q0 = np.linspace(self.lower[0], self.upper[0], shape[0])[:, None]
            q1 = np.linspace(self.lower[1], self.upper[1], shape[1])[None, :]
            free = np.broadcast_to(INIT_SHAPES[self.init_shape](self, q0, q1), shape)
        return self.level_set.from_distance(free) * self.mask(shape)

    def final_values(self, values) -> np.ndarray:
        """The grid a finished run delivers: ``values``, or for a design from the ``"envelope"``
        its free channel with convex walls ([`pes_ref.synthesis.kinds.envelope.convex_channel`][pes_ref.synthesis.kinds.envelope.convex_channel])."""
        if self.realizable and self.init_shape == "envelope":
            return convex_channel(self, values)
        return values

    def mask(self, shape: tuple) -> np.ndarray:
        """1.0 where a grid value is designed, 0.0 in the start and exit strips held at zero energy."""
        q1 = np.linspace(self.lower[1], self.upper[1], shape[1])
        free = ((q1 < self.height - self.start_zone) & (q1 >= self.exit_zone)).astype(np.float64)
        return np.broadcast_to(free[None, :], shape).copy()

    def scene(self, values, effects=()) -> Scene:
        """The design's scene on grid ``values`` with the given per-batch effects."""
        return Scene(Surface(self.surface_values(values), self.lower, self.upper, self.periodic), dt=self.dt,
                     n_steps=self.n_steps, damping=(self.damping, self.damping),
                     walls=Walls(k=self.wall_k, margin=self.wall_margin, edges=[[True, True], [False, False]]),
                     effects=tuple(effects))

    def objective(self):
        """Eq. (5) charged where ``when`` says (`FUNNEL_OBJECTIVES`)."""
        return FUNNEL_OBJECTIVES[self.when](self)

    def batch(self, values, rng, n_particles: int, n_steps: int | None = None) -> Batch:
        """Particles uniformly across the top, constant downward force plus seeded noise."""
        half = self.width / 2 - self.wall_margin
        q0 = rng.uniform(-half, half, n_particles)
        x0 = np.stack([q0, np.full(n_particles, self.height - self.start_depth)], axis=1)
        effects = (Constant((0.0, -self.force)),
                   Noise(std=(self.noise, self.noise), seed=int(rng.integers(2 ** 63 - 1))))
        scene = self.scene(values, effects)
        if n_steps is not None:
            scene = dataclasses.replace(scene, n_steps=n_steps)
        return Batch(x0, np.zeros_like(x0), scene, self.objective())

    def batch_metric(self, traj: Trajectory) -> float:
        """Share of the batch whose exit |q0 - target| < 10% of the width."""
        return float(np.mean(self.in_band(exit_positions(self, traj))))

    @property
    def band(self) -> float:
        """The band's half-width: an exit is in band within `IN_BAND_SHARE` of the width from the target."""
        return IN_BAND_SHARE * self.width

    def in_band(self, exits: np.ndarray) -> np.ndarray:
        """Where an exit q0 is within `IN_BAND_SHARE` of the width from the target (False for NaN)."""
        with np.errstate(invalid="ignore"):
            return np.abs(exits - self.target) < self.band


def _strips(p: FunnelProblem, q0, q1):
    """Two strips ``init_strip`` wide along the walled sides: the signed distance (> 0 free)."""
    return p.width / 2 - p.init_strip - np.abs(q0) + 0.0 * q1


def _vee(p: FunnelProblem, q0, q1):
    """A V: free within ``|q0| < init_gap + (width/2 - init_gap) q1 / h`` (``h`` the height below
    the start strip), blocked outside; the signed distance to its two straight walls."""
    h = p.height - p.start_zone
    slope = (p.width / 2 - p.init_gap) / h
    return (p.init_gap + slope * q1 - np.abs(q0)) / np.hypot(1.0, slope)


#: The starting shapes of a realizable funnel: name -> signed distance (> 0 free) on the nodes
#: (None: made by design, `pes_ref.synthesis.kinds.envelope.envelope_start`).
INIT_SHAPES = {"envelope": None, "strips": _strips, "vee": _vee}


def exit_positions(problem: FunnelProblem, traj: Trajectory) -> np.ndarray:
    """q0 at the first state at or below the bottom edge (q1 <= 0), NaN if a path never gets there."""
    step, exited = exit_steps(traj.x, problem.lower[1])
    exits = traj.x[step, np.arange(traj.x.shape[1]), 0]
    return np.where(exited, exits, np.nan)


#: The funnel's objective for each ``when``: eq. (5) at each particle's exit (the default), at
#: the final step, or summed over every step (`pes_ref.core.objectives.Funnel`).
FUNNEL_OBJECTIVES = {
    "exit": lambda p: FunnelExit(target=p.target, level=p.lower[1], linger=p.linger),
    "final": lambda p: Funnel(target=p.target, when="final"),
    "every_step": lambda p: Funnel(target=p.target, when="every_step"),
}
