"""Held-out analysis of each kind of design: paths, torque sweeps, phase space, cycle figures, figures, panels.

Held-out particles come from seeds training never uses. The funnel's figures are where its particles
exit
([`pes_ref.synthesis.kinds.funnel.exit_positions`][pes_ref.synthesis.kinds.funnel.exit_positions]);
the oscillator's are per-particle amplitude, period and drift over the last `ANALYSIS_PERIODS`
periods ([`cycle_figures`][pes_ref.synthesis.kinds.analysis.cycle_figures]), and whether a particle
reaches the target cycle; a problem file's, its success tests. ``evaluate_KIND`` gives one kind's
figures of several held-out seeds, their runs (design and flat surface, every seed) as one
population ([`pes_ref.core.population.simulate_batch`][pes_ref.core.population.simulate_batch]: each
run's numbers are its own), and ``KIND_panels`` the same held-out particles' paths, each with
whether it passed, for ``evaluate --plot``
([`pes_ref.synthesis.kinds.plots`][pes_ref.synthesis.kinds.plots]).
[`pes_ref.synthesis.kinds.registry`][pes_ref.synthesis.kinds.registry] holds them as each kind's
entry, and its [`evaluate`][pes_ref.synthesis.kinds.registry.evaluate] serves every kind.

The ``evaluate_KIND`` functions take an ``engine``: what runs the scenes on the design's surface,
``engine(scenes, x0s, v0s) -> [Trajectory]`` (as
[`pes_ref.core.population.simulate_batch`][pes_ref.core.population.simulate_batch], one trajectory
per scene), the surface model when None. A layer above supplies another, such as parts in rigid
contact ([`pes_ref.realize.evaluation`][pes_ref.realize.evaluation]); the figures are computed from
its trajectories as from the surface's.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from pes_ref.core.integrator import Trajectory
from pes_ref.core.population import simulate_batch
from pes_ref.core.scene import simulate
from pes_ref.synthesis.problem.design_problem import DesignProblem
from pes_ref.synthesis.kinds.funnel import exit_positions, FunnelProblem, IN_BAND_SHARE
from pes_ref.synthesis.kinds.oscillator import OscillatorProblem
from pes_ref.synthesis.problem.success import applies, passes_all

__all__ = ["Paths", "TorqueSweep", "Panel", "funnel_paths", "oscillator_torque_sweep", "oscillator_grid_starts",
           "phase_space", "cycle_figures", "q1_advance", "evaluate_funnel", "evaluate_oscillator", "evaluate_problem",
           "funnel_panels", "oscillator_panels", "problem_panels", "CYCLE_TOLERANCE", "CYCLE_DRIFT",
           "ANALYSIS_PERIODS"]

#: Oscillator cycle test: a held-out particle "reaches the cycle" when, over the analysis window
#: after the transient, its amplitude and period are within this relative error of the targets ...
CYCLE_TOLERANCE = 0.25
#: ... and its amplitude changes by less than this share of the target amplitude between the
#: first and the last period of the window (a sustained, not a decaying, oscillation).
CYCLE_DRIFT = 0.05
#: Periods at the end of an oscillator evaluation run that are analysed (the rest is transient).
ANALYSIS_PERIODS = 3


class Paths(NamedTuple):
    """Held-out starts (N, 2) and their trajectory."""

    x0: np.ndarray
    traj: Trajectory


class Panel(NamedTuple):
    """One picture of held-out paths: what passing means here (``title``), the paths
    (T+1, N, 2) and whether each passed (N,) bool."""

    title: str
    x: np.ndarray
    passed: np.ndarray


class TorqueSweep(NamedTuple):
    """Torques (N,) evenly over the design range, their starts (N, 2) and trajectory."""

    torques: np.ndarray
    x0: np.ndarray
    traj: Trajectory


def _funnel_run(problem: FunnelProblem, values, n_particles: int, seed: int, n_steps: int | None = None):
    """``(scene, x0, v0)`` of [`funnel_paths`][pes_ref.synthesis.kinds.analysis.funnel_paths]."""
    batch = problem.batch(np.asarray(values, dtype=np.float64), np.random.default_rng(seed), n_particles,
                          n_steps=n_steps)
    return batch.scene, batch.x0, batch.v0


def funnel_paths(problem: FunnelProblem, values, n_particles: int = 200, seed: int = 1,
                 n_steps: int | None = None) -> Paths:
    """Held-out funnel particles: the training sampler with ``default_rng(seed)``, run for
    ``n_steps`` (default the problem's; a longer run's first steps are the same, noise too)."""
    scene, x0, v0 = _funnel_run(problem, values, n_particles, seed, n_steps)
    return Paths(x0, simulate(scene, x0, v0))


def oscillator_torque_sweep(problem: OscillatorProblem, values, n_particles: int = 50, periods: float | None = None,
                            seed: int = 1) -> TorqueSweep:
    """Particles with torques evenly from min to max, started like the training batch (Figs. 8-9).

    Start q0 = amplitude (1 + kick) + start_noise * normal from ``default_rng(seed)``;
    simulated for ``periods`` target periods (default ``problem.eval_periods``).
    """
    torques, x0, scene = _torque_sweep_run(problem, values, n_particles, periods, seed)
    return TorqueSweep(torques, x0, simulate(scene, x0))


def _torque_sweep_run(problem: OscillatorProblem, values, n_particles: int, periods, seed: int):
    """``(torques, x0, scene)`` of [`oscillator_torque_sweep`][pes_ref.synthesis.kinds.analysis.oscillator_torque_sweep]."""
    periods = problem.eval_periods if periods is None else periods
    torques = np.linspace(problem.torque_min, problem.torque_max, n_particles)
    q0 = problem.amplitude * (1.0 + problem.kick) + problem.start_noise * \
        np.random.default_rng(seed).standard_normal(n_particles)
    x0 = np.stack([q0, np.zeros(n_particles)], axis=1)
    return torques, x0, problem.torque_scene(values, torques, periods)


def oscillator_grid_starts(problem: OscillatorProblem, values, periods: float | None = None, n: int = 5) -> Paths:
    """An n x n grid of starts at rest with the maximum torque (Figs. 10-11).

    q0 evenly in ``[-1.5 A, 1.5 A]`` (A the target amplitude), q1 evenly over the
    period ``[0, 2 pi)``.
    """
    x0, scene = _grid_starts_run(problem, values, periods, n)
    return Paths(x0, simulate(scene, x0))


def _grid_starts_run(problem: OscillatorProblem, values, periods, n: int):
    """``(x0, scene)`` of [`oscillator_grid_starts`][pes_ref.synthesis.kinds.analysis.oscillator_grid_starts]."""
    periods = problem.eval_periods if periods is None else periods
    a = np.linspace(-1.5 * problem.amplitude, 1.5 * problem.amplitude, n)
    b = np.arange(n) * (problem.upper[1] - problem.lower[1]) / n
    x0 = np.stack(np.meshgrid(a, b, indexing="ij"), axis=-1).reshape(-1, 2)
    torques = np.full(x0.shape[0], problem.torque_max)
    return x0, problem.torque_scene(values, torques, periods)


def phase_space(problem: OscillatorProblem, traj: Trajectory, after_periods: float):
    """(q0, dq0/dt) of every state after ``after_periods`` target periods, each (T', N)."""
    start = int(math.ceil(after_periods * problem.period / problem.dt))
    return traj.x[start:, :, 0], traj.v[start:, :, 0]


def cycle_figures(problem: OscillatorProblem, traj: Trajectory):
    """Per-particle amplitude, period, drift over the last ``ANALYSIS_PERIODS`` periods.

    Returns ``(amplitude, period, drift, captured)``, each (N,): amplitude ``(max - min)/2``
    of q0 over the window; period the mean spacing of upward crossings of q0's window mean
    (linearly interpolated; NaN with fewer than two); drift ``|a_last - a_first| / A``
    between the window's first and last period; captured where amplitude and period are
    within `CYCLE_TOLERANCE` of the targets and drift below `CYCLE_DRIFT`.
    """
    per = int(round(problem.period / problem.dt))
    q = traj.x[-ANALYSIS_PERIODS * per - 1:, :, 0]
    amp = 0.5 * (q.max(axis=0) - q.min(axis=0))
    first, last = q[:per + 1], q[-per - 1:]
    drift = np.abs(0.5 * (last.max(0) - last.min(0)) - 0.5 * (first.max(0) - first.min(0))) / problem.amplitude
    periods = _crossing_periods(q - q.mean(axis=0), problem.dt)
    with np.errstate(invalid="ignore"):
        amp_err = np.abs(amp - problem.amplitude) / problem.amplitude
        per_err = np.abs(periods - problem.period) / problem.period
        captured = (amp_err < CYCLE_TOLERANCE) & (per_err < CYCLE_TOLERANCE) & (drift < CYCLE_DRIFT)
    return amp, periods, drift, captured


def _crossing_periods(c: np.ndarray, dt: float) -> np.ndarray:
    """Per column of ``c`` (W, N): the mean spacing of its upward zero crossings, linearly
    interpolated (``(k + c_k / (c_k - c_{k+1})) dt`` for ``c_k < 0 <= c_{k+1}``), NaN with
    fewer than two.

    The crossings of every column at once; the mean of a column's m spacings is summed left
    to right as ``np.mean`` sums fewer than 8 numbers (bit-identical to ``np.mean(np.diff(t))``
    per column; ``np.mean`` itself for the rare column with more)."""
    n = c.shape[1]
    periods = np.full(n, np.nan)
    column, k = np.nonzero(((c[:-1] < 0) & (c[1:] >= 0)).T)         # column by column, k ascending
    ck = c[k, column]
    t = (k + ck / (ck - c[k + 1, column])) * dt
    spacings = np.bincount(column, minlength=n) - 1
    d = np.diff(t)                              # d[first[i] + j]: column i's spacing j
    first = np.cumsum(spacings + 1) - (spacings + 1)
    few = np.nonzero((spacings >= 1) & (spacings < 8))[0]
    if few.size:
        start, m = first[few], spacings[few]
        total = d[start]
        for j in range(1, int(m.max())):
            total = np.where(j < m, total + d[np.minimum(start + j, d.size - 1)], total)
        periods[few] = total / m
    for i in np.nonzero(spacings >= 8)[0]:
        periods[i] = np.mean(d[first[i]:first[i] + spacings[i]])
    return periods


def q1_advance(problem: OscillatorProblem, traj: Trajectory) -> np.ndarray:
    """(N,) how far q1 runs down per target period over the last ``ANALYSIS_PERIODS`` periods (rad).

    ``-(q1_end - q1_start) / ANALYSIS_PERIODS`` over the window of
    [`cycle_figures`][pes_ref.synthesis.kinds.analysis.cycle_figures]: an
    escapement holds it to its gait's advance whatever the torque; a free-running q1 turns at
    ``tau / damping1`` per unit time.
    """
    per = int(round(problem.period / problem.dt))
    q1 = traj.x[:, :, 1]
    return -(q1[-1] - q1[-ANALYSIS_PERIODS * per - 1]) / ANALYSIS_PERIODS


def _surfaces(problem, values) -> tuple:
    """The design's surface and the flat starting one, with the prefix of their figures."""
    return ("", values), ("flat_", problem.flat_values(values.shape))


def _population(runs: dict, engine=None) -> dict:
    """``simulate_batch`` of the ``(scene, x0, v0)`` runs of ``runs`` (keyed ``(prefix, ...)``):
    name -> trajectory. With an ``engine`` (module docstring), the runs on the design's surface
    (prefix ``""``) are the engine's; the flat surface's stay the surface model's (a flat
    surface has no parts)."""
    own = {} if engine is None else {key: run for key, run in runs.items() if key[0] == ""}
    rest = {key: run for key, run in runs.items() if key not in own}
    out = {}
    for group, run_all in ((rest, simulate_batch), (own, engine)):
        if group:
            out.update(zip(group, run_all([r[0] for r in group.values()], [r[1] for r in group.values()],
                                          [r[2] for r in group.values()])))
    return {key: out[key] for key in runs}


def evaluate_funnel(problem: FunnelProblem, values, seeds: tuple, n: int, engine=None) -> dict:
    """The funnel's held-out figures: seed -> figures of ``n`` particles per seed, on the design
    and on the flat surface (``flat_``): the share of particles that exit in the band
    ([`in_band`][pes_ref.synthesis.kinds.funnel.FunnelProblem.in_band]), that exit at all, and the
    standard deviation of the exit q0; every run one population. ``engine`` runs the design's
    scenes ([`pes_ref.synthesis.kinds.registry.evaluate`][pes_ref.synthesis.kinds.registry.evaluate]; the flat surface's stay on the surface model)."""
    runs = {(prefix, seed): _funnel_run(problem, vals, n, seed)
            for prefix, vals in _surfaces(problem, values) for seed in seeds}
    paths = _population(runs, engine)
    figures = {}
    for seed in seeds:
        out = figures[seed] = {}
        for prefix, _ in _surfaces(problem, values):
            exits = exit_positions(problem, paths[(prefix, seed)])
            out[prefix + "in_band_fraction"] = float(np.mean(problem.in_band(exits)))
            done = exits[np.isfinite(exits)]
            out[prefix + "exit_spread"] = float(np.std(done)) if done.size else float("nan")
            out[prefix + "exited_fraction"] = float(np.mean(np.isfinite(exits)))
        out["particles"] = float(n)
    return figures


def evaluate_oscillator(problem: OscillatorProblem, values, seeds: tuple, n: int, engine=None) -> dict:
    """The torque sweep of each seed and the 5 x 5 grid (the same for every seed), on the
    design and on the flat surface, as one population."""
    runs = {}
    for prefix, vals in _surfaces(problem, values):
        x0, scene = _grid_starts_run(problem, vals, None, 5)
        runs[(prefix, "grid")] = (scene, x0, None)
        for seed in seeds:
            _, x0, scene = _torque_sweep_run(problem, vals, n, None, seed)
            runs[(prefix, seed)] = (scene, x0, None)
    traj = _population(runs, engine)
    return {seed: _oscillator_figures(problem, {prefix: (traj[(prefix, seed)], traj[(prefix, "grid")])
                                                for prefix, _ in _surfaces(problem, values)}, n)
            for seed in seeds}


def _oscillator_figures(problem: OscillatorProblem, runs: dict, n: int) -> dict:
    """The figures of `evaluate` from the torque sweep's and the grid's trajectories,
    per surface prefix."""
    out = {}
    for prefix, (sweep_traj, grid_traj) in runs.items():
        fig_s, fig_g = cycle_figures(problem, sweep_traj), cycle_figures(problem, grid_traj)
        captured = np.concatenate([fig_s[3], fig_g[3]])
        out[prefix + "captured_fraction"] = float(np.mean(captured))
        if prefix:
            continue
        out["sweep_captured_fraction"] = float(np.mean(fig_s[3]))
        out["grid_captured_fraction"] = float(np.mean(fig_g[3]))
        amp = np.concatenate([fig_s[0], fig_g[0]])[captured]
        per = np.concatenate([fig_s[1], fig_g[1]])[captured]
        amp_err, per_err = np.abs(amp - problem.amplitude), np.abs(per - problem.period)
        out["amplitude_error"] = _reduce(np.max, amp_err) / problem.amplitude
        out["period_error"] = _reduce(np.max, per_err) / problem.period
        out["amplitude_error_median"] = _reduce(np.median, amp_err) / problem.amplitude
        out["period_error_median"] = _reduce(np.median, per_err) / problem.period
        advance = q1_advance(problem, sweep_traj)[fig_s[3]]
        for name, reduce in (("min", np.min), ("median", np.median), ("max", np.max)):
            out[f"q1_advance_{name}"] = _reduce(reduce, advance)
        out["gait_advance"] = float(problem.gait_delta)
    out["particles"] = float(n + 25)
    return out


def _reduce(reduce, x: np.ndarray) -> float:
    """``reduce(x)`` as a float, NaN for an empty ``x``."""
    return float(reduce(x)) if x.size else float("nan")


def evaluate_problem(problem: DesignProblem, values, seeds: tuple, n: int, engine=None) -> dict:
    """A problem file's held-out figures: seed -> figures of ``n`` particles: the success
    fraction (every test) and each test's, each share criterion and whether it is met, each
    objective term's value, each scenario's success fraction and the flat surface's.
    ``engine`` runs the design's scenes ([`pes_ref.synthesis.kinds.registry.evaluate`][pes_ref.synthesis.kinds.registry.evaluate])."""
    return {seed: _evaluate_problem_seed(problem, values, seed, n, engine) for seed in seeds}


def _evaluate_problem_seed(problem: DesignProblem, values, seed: int, n: int, engine=None) -> dict:
    held = problem.run(values, seed, n, engine=engine)
    every, each = passes_all([test for _, test in problem.tests], held.traj.x, held.traj.v, held.times)
    out = {"success_fraction": float(np.mean(every))}
    for (name, test), ok in zip(problem.tests, each):
        out[f"success_{name}"] = float(np.mean(ok[applies(test, ok.shape[0])]))      # a group's test: its share
    for name, criterion in problem.shares:
        share = criterion.share(held.traj.x, held.traj.v, held.times)
        out[f"share_{name}"] = share
        out[f"share_{name}_met"] = float(criterion.low <= share <= criterion.high)
    values_of_terms = problem.objective.values(held.traj.x, held.traj.v, held.times)
    values_of_terms += [term.grid_value_and_grad(values)[0] for term in problem.grid_terms]
    for name, value in zip(problem.term_names, values_of_terms):
        out[f"objective_{name}"] = float(value)
    for scenario in problem.scenarios:
        run = problem.run(values, seed, n, scenario, engine=engine)
        ok, _ = passes_all([test for _, test in scenario.tests], run.traj.x, run.traj.v, run.times)
        out[f"scenario_{scenario.name}_success_fraction"] = float(np.mean(ok))
    flat = problem.run(problem.flat_values(values.shape), seed, n)
    out["flat_success_fraction"] = float(np.mean(
        passes_all([test for _, test in problem.tests], flat.traj.x, flat.traj.v, flat.times)[0]))
    out["particles"] = float(n)
    return out


def funnel_panels(problem: FunnelProblem, values, seed: int, n: int) -> list:
    """The held-out funnel paths of ``seed``, each with whether it exits in the band (one [`Panel`][pes_ref.synthesis.kinds.analysis.Panel])."""
    scene, x0, v0 = _funnel_run(problem, values, n, seed)
    traj = simulate(scene, x0, v0)
    band = problem.in_band(exit_positions(problem, traj))
    return [Panel(f"exit in the band: |q0 - {problem.target:g}| < {IN_BAND_SHARE * problem.width:.3g}", traj.x, band)]


def oscillator_panels(problem: OscillatorProblem, values, seed: int, n: int) -> list:
    """The torque sweep of ``seed`` and the 5 x 5 grid of starts, each path with whether it
    reaches the target cycle (two [`Panel`][pes_ref.synthesis.kinds.analysis.Panel])."""
    _, x0, scene = _torque_sweep_run(problem, values, n, None, seed)
    sweep = simulate(scene, x0)
    x0, scene = _grid_starts_run(problem, values, None, 5)
    grid = simulate(scene, x0)
    return [Panel("torque sweep: captured by the cycle", sweep.x, cycle_figures(problem, sweep)[3]),
            Panel("5 x 5 starts at rest, maximum torque: captured", grid.x, cycle_figures(problem, grid)[3])]


def problem_panels(problem: DesignProblem, values, seed: int, n: int) -> list:
    """The held-out paths of ``seed``: one [`Panel`][pes_ref.synthesis.kinds.analysis.Panel] with whether each passes every
    success
    test, then one per test (a start group's test: its group's paths only)."""
    held = problem.run(values, seed, n)
    every, each = passes_all([test for _, test in problem.tests], held.traj.x, held.traj.v, held.times)
    panels = [Panel("every success test", held.traj.x, every)]
    for (name, test), ok in zip(problem.tests, each):      # a start group's test: its group's paths
        mine = applies(test, n)
        group = f", group {test.group}" if hasattr(test, "group") else ""
        panels.append(Panel(f"success test {name} ({test.KIND}{group})", held.traj.x[:, mine], ok[mine]))
    return panels
