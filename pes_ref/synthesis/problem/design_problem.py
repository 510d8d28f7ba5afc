"""A design problem stated by a problem file: any surface, dynamics, starts, force schedule and
sum of objective terms, with the per-particle success test it is judged by.

[`DesignProblem`][pes_ref.synthesis.problem.design_problem.DesignProblem] is what
[`pes_ref.synthesis.problem.problem_file`][pes_ref.synthesis.problem.problem_file] reads a problem file into
(or a dict of the same shape, built in code); it plays the part the funnel and the oscillator
play ([`pes_ref.synthesis.common.problems`][pes_ref.synthesis.common.problems]) for the whole design machinery:
[`batch`][pes_ref.synthesis.problem.design_problem.DesignProblem.batch]
draws a training batch, [`batch_metric`][pes_ref.synthesis.problem.design_problem.DesignProblem.batch_metric] scores it, and
[`run`][pes_ref.synthesis.problem.design_problem.DesignProblem.run] simulates held-out particles for ``evaluate``. Its parts:

- [`Starts`][pes_ref.synthesis.problem.design_problem.Starts]: where particles start (a uniform box, or a list of points) and at
  what velocity;
- [`Force`][pes_ref.synthesis.problem.design_problem.Force]: one entry of the force schedule (`FORCES`: constant, noise,
  per-particle),
  on for a time window if it has one ([`pes_ref.core.effects.Window`][pes_ref.core.effects.Window]): windows give a
  problem its phases;
- [`Scenario`][pes_ref.synthesis.problem.design_problem.Scenario]: another force schedule the design is checked under (does a
  latch hold
  when nobody pulls the trigger?).

Every random draw of a batch comes from the generator it is given, in a fixed order: the
starts (box axes in order, then the velocities), then each force in the file's order.
"""
from __future__ import annotations

import copy
from typing import ClassVar, NamedTuple

import numpy as np

from pes_ref.core.effects import Constant, Noise, PerParticle, Window, step_times
from pes_ref.core.scene import Scene, simulate
from pes_ref.core.surface import Surface, spacing as grid_spacing
from pes_ref.devices.cspace import apf_standoff
from pes_ref.synthesis.problem.file_keys import Key
from pes_ref.synthesis.problem.objective_terms import Domain, TermSum
from pes_ref.synthesis.problem.paths_region import smoothed_values
from pes_ref.synthesis.problem.problem_contact import signed_distance
from pes_ref.synthesis.common.problems import Batch, _Problem
from pes_ref.synthesis.problem.success import passes_all

__all__ = ["DesignProblem", "Starts", "StartGroup", "Force", "Scenario", "FORCES", "HeldOut"]


def _uniform(rng, lower, upper, n: int) -> np.ndarray:
    """(n, 2) uniform in the box; an axis with ``lower == upper`` is that value and draws nothing."""
    out = np.empty((n, 2))
    for axis in (0, 1):
        lo, hi = lower[axis], upper[axis]
        out[:, axis] = rng.uniform(lo, hi, n) if hi > lo else lo
    return out


class Starts(NamedTuple):
    """Where particles start: uniform in ``box`` (lower, upper), or particle ``i`` at
    ``points[i % len(points)]``; velocities uniform in ``velocity`` (lower, upper). Or in start
    ``groups``, each a [`StartGroup`][pes_ref.synthesis.problem.design_problem.StartGroup]: a
    batch's particles in consecutive blocks, one per group, sized by the groups' shares
    ([`counts`][pes_ref.synthesis.problem.design_problem.Starts.counts])."""

    box: tuple | None
    points: tuple | None
    velocity: tuple
    groups: tuple = ()

    def sample(self, rng, n: int):
        """``(x0, v0)``, each (n, 2): a group's draws (its box's axes, then its velocities) after the group's before it."""
        if self.groups:
            parts = [g.starts.sample(rng, k) for g, k in zip(self.groups, self.counts(n))]
            return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
        if self.box is not None:
            x0 = _uniform(rng, *self.box, n)
        else:
            x0 = np.array([self.points[i % len(self.points)] for i in range(n)], dtype=np.float64).reshape(n, 2)
        return x0, _uniform(rng, *self.velocity, n)

    def counts(self, n: int) -> list:
        """Each group's particles of ``n``: ``n share / sum(shares)`` rounded down, the rest one
        each to the groups with the largest remainders (the first on a tie)."""
        shares = np.array([g.share for g in self.groups], dtype=np.float64)
        exact = n * shares / shares.sum()
        counts = np.floor(exact).astype(int)
        for i in np.argsort(-(exact - counts), kind="stable")[: n - int(counts.sum())]:
            counts[i] += 1
        return [int(c) for c in counts]

    def members(self, group: int, n: int) -> np.ndarray:
        """The (n,) mask of group ``group``'s particles in a batch of ``n``."""
        ends = np.cumsum([0] + self.counts(n))
        out = np.zeros(n, dtype=bool)
        out[ends[group]:ends[group + 1]] = True
        return out


class StartGroup(NamedTuple):
    """One start group (``[[starts.group]]``): its ``name``, ``share`` of a batch and [`Starts`][pes_ref.synthesis.problem.design_problem.Starts]."""

    name: str
    share: float
    starts: Starts


#: The kinds of force (``[[forces]] kind = ...``): their keys, and the effect each draws for n particles.
FORCES = {
    "constant": ({"force": Key("point", unit="force")}, lambda keys, rng, n: Constant(keys["force"])),
    "noise": ({"std": Key("nonneg_or_pair", unit="force")},
              lambda keys, rng, n: Noise(std=keys["std"], seed=int(rng.integers(2 ** 63 - 1)))),
    "per_particle": ({"lower": Key("point", unit="force"), "upper": Key("point", unit="force")},
                     lambda keys, rng, n: PerParticle(_uniform(rng, keys["lower"], keys["upper"], n))),
}


class Force(NamedTuple):
    """One force of the schedule: its ``kind`` (`FORCES`), checked ``keys``, optional
    ``name``, and the window ``[start, end)`` it is on for (None: always)."""

    kind: str
    keys: dict
    name: str
    start: float | None
    end: float | None

    def effect(self, rng, n: int):
        """The effect on ``n`` particles, its random part drawn from ``rng``."""
        effect = FORCES[self.kind][1](self.keys, rng, n)
        if self.start is None and self.end is None:
            return effect
        return Window(effect, 0.0 if self.start is None else self.start,
                      np.finfo(np.float64).max if self.end is None else self.end)


class Scenario(NamedTuple):
    """Another run the design is checked under: its ``name``, ``n_steps``, ``forces`` and the
    success ``tests`` (name, test) it must pass; ``objective`` (a
    [`TermSum`][pes_ref.synthesis.problem.objective_terms.TermSum] of its tests' surrogates, or None) charges
    them in training: a problem designed on its tests charges its scenarios too."""

    name: str
    n_steps: int
    forces: tuple
    tests: tuple
    objective: object = None


class HeldOut(NamedTuple):
    """Held-out particles: starts (N, 2), the trajectory and its times (T+1,)."""

    x0: np.ndarray
    traj: object
    times: np.ndarray


class DesignProblem(_Problem):
    """A design problem from a problem file (``docs/problems.md``); build one with
    [`pes_ref.synthesis.problem.problem_file.load_problem`][pes_ref.synthesis.problem.problem_file.load_problem] or
    [`parse_problem`][pes_ref.synthesis.problem.problem_file.parse_problem].

    Two problems are equal when their data (the file's parsed tables) are. ``regularization``
    is 0: eq. (7) is a grid term of the objective here (``[[objective]] kind =
    "regularization"``), charged with the others through the batch's ``grid_cost``.
    """

    kind: ClassVar[str] = "problem"
    #: The name of `batch_metric` in progress lines and summaries.
    metric_name: ClassVar[str] = "success"
    regularization = 0.0

    def __init__(self, *, data: dict, path: str, text: str | None, name: str, description: str, lower, upper,
                 periodic, grid_shape, interpolation, holds, scene_keys: dict, n_steps: int, starts: Starts,
                 forces: tuple, terms: tuple, term_names: tuple, grid_terms: tuple, tests: tuple, scenarios: tuple,
                 eval_particles: int, plan, init_scale: float, contact=None, shares: tuple = (),
                 warnings: tuple = ()):
        self.data, self.path, self.source_text = data, path, text
        self.name, self.description = name, description
        self.lower, self.upper, self.periodic = tuple(lower), tuple(upper), tuple(periodic)
        self.grid_shape, self.interpolation, self.holds = tuple(grid_shape), interpolation, tuple(holds)
        self.scene_keys, self.n_steps = scene_keys, n_steps
        self.starts, self.forces = starts, tuple(forces)
        self.terms, self.term_names, self.grid_terms = tuple(terms), tuple(term_names), tuple(grid_terms)
        self.objective = TermSum(self.terms)
        self.tests, self.scenarios, self.shares = tuple(tests), tuple(scenarios), tuple(shares)
        self.eval_particles, self.plan, self.init_scale = eval_particles, plan, init_scale
        self.contact = contact
        #: What the file's reader warns of (one line each, ``design`` prints them before the run).
        self.warnings = tuple(warnings)
        self.level_set = None if contact is None else contact.level_set()

    def __eq__(self, other):
        return isinstance(other, DesignProblem) and self.data == other.data

    __hash__ = None

    def __repr__(self):
        return f"DesignProblem({self.name!r} from {self.path})"

    # ------------------------------------------------------------------ geometry
    @property
    def domain(self) -> Domain:
        """The surface's domain (``lower``, ``upper``, ``periodic``) as the objective terms take it."""
        return Domain(self.lower, self.upper, self.periodic)

    @property
    def dt(self) -> float:
        """The time step (seconds), the file's ``[dynamics] dt``."""
        return self.scene_keys["dt"]

    @property
    def grid(self) -> int:
        """The final grid's nodes along axis 0 (the built-in problems' ``grid``; what a memory
        refusal names, ``surface.shape`` on the command line)."""
        return self.grid_shape[0]


    def shape(self, grid: int | None = None) -> tuple:
        """The final grid, or ``grid`` nodes along axis 0 and axis 1 in the final grid's proportion."""
        if grid is None:
            return self.grid_shape
        n0, n1 = self.grid_shape
        return (grid, max(2, round(grid * n1 / n0)))

    def nodes(self, shape: tuple, axis: int) -> np.ndarray:
        """The node coordinates of a grid of ``shape`` along ``axis``."""
        lo, hi, n = self.lower[axis], self.upper[axis], shape[axis]
        if self.periodic[axis]:
            return lo + (hi - lo) / n * np.arange(n)
        return np.linspace(lo, hi, n)

    def mask(self, shape: tuple) -> np.ndarray:
        """1.0 where a grid value is designed, 0.0 at the nodes of ``[[surface.hold]]`` boxes (held at zero)."""
        q0, q1 = (self.nodes(shape, d) for d in (0, 1))
        held = np.zeros(shape, dtype=bool)
        for lower, upper in self.holds:
            held |= ((q0 >= lower[0]) & (q0 <= upper[0]))[:, None] & ((q1 >= lower[1]) & (q1 <= upper[1]))[None, :]
        return (~held).astype(np.float64)

    def initial_values(self, rng, shape: tuple) -> np.ndarray:
        """Small random values (std ``init_scale``); a realizable design's: the level set of the
        shapes ``[surface.contact] blocked`` ([`pes_ref.synthesis.problem.problem_contact`][pes_ref.synthesis.problem.problem_contact])."""
        if self.level_set is None:
            return super().initial_values(rng, shape)
        if self.paths_start:
            raise ValueError(f"{self.name}: a realizable design that draws no blocked shapes starts from its smooth "
                             f"design's paths; start it with pes_ref.synthesis.start_design (what design runs)")
        spacing = grid_spacing(np.asarray(self.lower, dtype=np.float64), np.asarray(self.upper, dtype=np.float64),
                               shape, np.asarray(self.periodic))
        d = signed_distance(self.contact.blocked, self.nodes(shape, 0), self.nodes(shape, 1), self.lower, self.upper,
                            self.periodic, spacing)
        return self.level_set.from_distance(d) * self.mask(shape)

    @property
    def paths_start(self) -> bool:
        """Whether the design is a realizable one that draws no starting shape: it starts from
        its smooth design's paths ([`pes_ref.synthesis.engine.paths_start`][pes_ref.synthesis.engine.paths_start])
        and ends on its shape smoothed as that start is."""
        return self.level_set is not None and not self.contact.blocked

    @property
    def parts_clearance(self) -> float:
        """The clearance its realized parts are made with (length): ``[surface.contact]
        clearance`` as stated; unstated, for a design from its paths eq. (1)'s standoff under the
        largest constant push of the schedule
        ([`pes_ref.devices.cspace.apf_standoff`][pes_ref.devices.cspace.apf_standoff]: a rigid pin then
        keeps off the walls where eq. (1) kept the particles, inside the region their passing paths
        covered), and 0 otherwise."""
        contact = self.contact
        if contact.clearance is not None:
            return contact.clearance
        if not self.paths_start:
            return 0.0
        pushes = [np.hypot(*f.keys["force"]) for f in self.forces if f.kind == "constant"]
        return apf_standoff(max(pushes, default=0.0), contact.v, contact.r_c, contact.r_min)

    def final_values(self, values) -> np.ndarray:
        """The grid a finished run delivers: ``values``, or for a design from its paths its shape
        smoothed ([`pes_ref.synthesis.problem.paths_region.smoothed_values`][pes_ref.synthesis.problem.paths_region.smoothed_values])."""
        return smoothed_values(self, values) if self.paths_start else values

    def plain(self) -> "DesignProblem":
        """This problem with its grid values the surface's energies (a realizable design's level
        set turned off): what runs a surface given as energies, such as a realized device's."""
        if self.level_set is None:
            return self
        out = copy.copy(self)
        out.level_set = None
        return out

    def with_spring(self, spring) -> "DesignProblem":
        """This problem with ``spring`` (a [`pes_ref.core.terms.Spring`][pes_ref.core.terms.Spring], or None) for its
        scene's ``[dynamics] spring``: a realized device's springs."""
        out = copy.copy(self)
        out.scene_keys = {**self.scene_keys, "spring": spring}
        return out

    # ------------------------------------------------------------------ runs
    def scene(self, values, effects=(), n_steps: int | None = None) -> Scene:
        """The design's scene on grid ``values`` (a realizable design's: eq. (1) of their shape) with the given effects."""
        return Scene(Surface(self.surface_values(values), self.lower, self.upper, self.periodic, self.interpolation),
                     n_steps=self.n_steps if n_steps is None else n_steps, effects=tuple(effects), **self.scene_keys)

    def times(self, n_steps: int | None = None) -> np.ndarray:
        """The step times ``n dt`` (seconds), n = 0..T; T is ``n_steps``, the problem's own if None."""
        return step_times(self.n_steps if n_steps is None else n_steps, self.dt)

    def grid_cost(self, values):
        """The grid terms' value and gradient on ``values`` (``(0.0, None)`` without any)."""
        total, grad = 0.0, None
        for term in self.grid_terms:
            value, g = term.grid_value_and_grad(values)
            total += value
            if g is not None:
                grad = g if grad is None else grad + g
        return total, grad

    def batch(self, values, rng, n_particles: int, n_steps: int | None = None, forces: tuple | None = None) -> Batch:
        """Particles from `starts`, then the force schedule (``forces``, default the problem's), drawn
        from ``rng``; scored by the sum of the state terms, the grid terms as the batch's ``grid_cost``."""
        x0, v0 = self.starts.sample(rng, n_particles)
        effects = tuple(f.effect(rng, n_particles) for f in (self.forces if forces is None else forces))
        return Batch(x0, v0, self.scene(values, effects, n_steps), self.objective,
                     self.grid_cost if self.grid_terms else None)

    def batch_metric(self, traj) -> float:
        """Share of the batch that passes every success test."""
        return float(np.mean(self.batch_passes(traj)))

    def batch_passes(self, traj, tests: tuple | None = None) -> np.ndarray:
        """(N,) whether each particle of a run passes every one of ``tests`` (name, test), the problem's if None."""
        every, _ = passes_all([test for _, test in (self.tests if tests is None else tests)], traj.x, traj.v,
                              self.times(traj.x.shape[0] - 1))
        return every

    @property
    def charged_scenarios(self) -> tuple:
        """The scenarios training charges and validation judges (those with an ``objective``: a
        problem designed on its tests'; a hand-written ``[[objective]]`` leaves its scenarios as checks)."""
        return tuple(sc for sc in self.scenarios if sc.objective is not None)

    def scenario_batch(self, values, rng, n_particles: int, scenario: Scenario, n_steps: int | None = None) -> Batch:
        """The batch of [`batch`][pes_ref.synthesis.problem.design_problem.DesignProblem.batch] under ``scenario``'s schedule,
        scored by its ``objective``; ``n_steps``
        (a stage's shorter horizon) caps its run."""
        steps = scenario.n_steps if n_steps is None else min(n_steps, scenario.n_steps)
        return self.batch(values, rng, n_particles, steps, scenario.forces)._replace(objective=scenario.objective,
                                                                                      grid_cost=None)

    def phases(self, forces: tuple | None = None, n_steps: int | None = None) -> list:
        """The run's phases: the times where a force's window opens or closes cut it into
        segments ``(start, end, label)``, the label naming the named forces on in it (``""``:
        none). ``forces`` and ``n_steps`` default to the problem's (a scenario's may be given)."""
        forces = self.forces if forces is None else forces
        end = (self.n_steps if n_steps is None else n_steps) * self.dt
        cuts = sorted({0.0, end} | {t for f in forces for t in (f.start, f.end) if t is not None and 0 < t < end})
        out = []
        for start, stop in zip(cuts, cuts[1:]):
            on = [f.name for f in forces if f.name and (f.start or 0.0) <= start
                  and (f.end is None or f.end >= stop)]
            out.append((start, stop, " + ".join(on)))
        return out

    def run(self, values, seed: int, n_particles: int, scenario: Scenario | None = None, engine=None) -> HeldOut:
        """Held-out particles: the training sampler with ``default_rng(seed)`` under the problem's
        schedule, or ``scenario``'s; run by ``engine(scenes, x0s, v0s) -> [Trajectory]`` if given
        ([`pes_ref.synthesis.kinds.analysis`][pes_ref.synthesis.kinds.analysis]), else the surface model."""
        n_steps, forces = (None, None) if scenario is None else (scenario.n_steps, scenario.forces)
        batch = self.batch(np.asarray(values, dtype=np.float64), np.random.default_rng(seed), n_particles, n_steps,
                           forces)
        traj = (simulate(batch.scene, batch.x0, batch.v0) if engine is None
                else engine([batch.scene], [batch.x0], [batch.v0])[0])
        return HeldOut(batch.x0, traj, self.times(batch.scene.n_steps))
