"""The polish stage: a gradient-free search on a smooth correction of a designed surface.

After the gradient stage (prescribed-gait shooting for the oscillator) the design is close; the
polish searches ``coef`` in ``values + B coef``
([`legendre_fourier_basis`][pes_ref.synthesis.engine.polish.legendre_fourier_basis], 72 terms by
default) with pycma's CMA-ES (or scipy's differential evolution, for the comparison), on a
forward-only fitness ([`capture_fitness`][pes_ref.synthesis.engine.polish.capture_fitness]): the
capture test of ``python -m pes_ref evaluate``
([`pes_ref.synthesis.kinds.analysis.cycle_figures`][pes_ref.synthesis.kinds.analysis.cycle_figures])
on a fixed set of training particles
([`polish_particles`][pes_ref.synthesis.engine.polish.polish_particles]) drawn from their own seed,
disjoint from every held-out set. [`polish`][pes_ref.synthesis.engine.polish.polish] runs it. The
candidates of a generation are run as one population
([`pes_ref.core.population.simulate_batch`][pes_ref.core.population.simulate_batch],
[`capture_fitnesses`][pes_ref.synthesis.engine.polish.capture_fitnesses]): each candidate's
trajectory, hence its fitness, is bit-identical to its own run, at a fraction of the per-step cost.
They are independent, so an executor (anything with ``map``, e.g. a
`concurrent.futures.ProcessPoolExecutor` or a Dask client's ``get_executor()``) can evaluate a
generation in ``tasks`` parts in parallel, with the same result as serial.

With validation (the plan's ``validation_particles``), the best candidate so far is judged every few
generations on fixed validation particles shaped like the held-out sets
([`validation_particles`][pes_ref.synthesis.engine.polish.validation_particles]) by the share the
capture test passes, and the search stops once that share reaches the plan's ``validation_target``:
the training fitness keeps falling after the held-out share has stopped rising, so a budget of
evaluations alone either stops too early for some seeds or runs long past the point for others.

Seeds: the training particles come from ``default_rng([seed, 2**32 + 1])``, the search's
own draws from ``default_rng([seed, 2**32 + 2])``, the validation particles from
``default_rng([seed, 2**32 + 3])`` (the gradient stage uses ``[seed, k]`` and
``[seed, 2**32]``; a held-out seed is a plain integer); NumPy's global random state is never
touched.
"""
from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Callable, NamedTuple

import numpy as np
from threadpoolctl import threadpool_limits

from pes_ref.core import checks
from pes_ref.core.integrator import Trajectory
from pes_ref.core.population import simulate_batch
from pes_ref.synthesis.kinds.analysis import CYCLE_DRIFT, CYCLE_TOLERANCE, cycle_figures
from pes_ref.synthesis.common.plans import PolishPlan

__all__ = ["legendre_fourier_basis", "PolishParticles", "polish_particles", "validation_particles",
           "capture_fitness", "capture_fitnesses", "captured_share", "Fitness",
           "PolishStep", "PolishResult", "polish", "PARTICLE_SEED", "SEARCH_SEED", "VALIDATION_SEED", "MARGIN_CAP",
           "DEFAULT_WORKERS", "polish_workers", "polish_pool"]

#: The processes of a run with a polish stage when not given (both cores of a 2-core machine):
#: a generation's 16 candidates split in two halves, one per process.
DEFAULT_WORKERS = 2


def polish_workers(workers, inputs, smoke: bool = False) -> int:
    """The processes of a run's polish: ``workers`` when given, else `DEFAULT_WORKERS`
    (at most the machine's cores) for a run with a polish stage, 1 for one without or at the
    smoke size (its polish is a few generations of a few particles: a pool would cost more
    than it saves). The design does not depend on it."""
    import os
    if workers is not None:
        return workers
    if inputs.base_polish is None or smoke:
        return 1
    return max(1, min(DEFAULT_WORKERS, os.cpu_count() or 1))


def polish_pool(workers: int, inputs, kind: str):
    """A process pool for the polish's candidates (None for 1 worker); its workers ignore Ctrl-C,
    which the main process turns into a clean stop. A count below 1, or more than one for a run
    without a polish stage, is refused (key ``workers``)."""
    if workers < 1:
        raise checks.InputError("workers", f"workers must be >= 1, got {workers}")
    if workers == 1:
        return None
    if inputs.base_polish is None:
        raise checks.InputError("workers", f"workers: this {kind} run has no polish stage")
    from concurrent.futures import ProcessPoolExecutor

    from pes_ref.core.runtime.signals import ignore_interrupts
    return ProcessPoolExecutor(workers, initializer=ignore_interrupts)

#: Second entry of the seed pair of the polish's training particles, ``default_rng([seed, PARTICLE_SEED])``.
PARTICLE_SEED = 2 ** 32 + 1
#: Second entry of the seed pair of the search's own draws.
SEARCH_SEED = 2 ** 32 + 2
#: Second entry of the seed pair of the validation particles.
VALIDATION_SEED = 2 ** 32 + 3
#: The margin of a particle without a measurable cycle, and the cap of every margin.
MARGIN_CAP = 3.0


def legendre_fourier_basis(problem, shape: tuple | None = None, fourier_order: int = 4,
                           legendre_terms: int = 8) -> np.ndarray:
    """(n0, n1, M (2K + 1)): ``P_m(q0 / q0_extent)`` times ``1, cos k q1, sin k q1`` at the nodes.

    ``M = legendre_terms`` Legendre polynomials ``P_0 .. P_{M-1}`` on the q0 nodes mapped to
    ``[-1, 1]``, ``K = fourier_order`` harmonics on the q1 nodes (periodic). Term
    ``m (2K + 1) + f`` is ``P_m`` times the ``f``-th of ``1, cos q1, sin q1, cos 2 q1, ...``.
    """
    n0, n1 = problem.shape() if shape is None else shape
    q0 = np.linspace(-1.0, 1.0, n0)
    q1 = problem.lower[1] + np.arange(n1) * (problem.upper[1] - problem.lower[1]) / n1
    P = np.polynomial.legendre.legvander(q0, legendre_terms - 1)
    F = np.array([np.ones_like(q1)] + [f(k * q1) for k in range(1, fourier_order + 1) for f in (np.cos, np.sin)]).T
    return np.einsum("im,jf->ijmf", P, F).reshape(n0, n1, -1)


class PolishParticles(NamedTuple):
    """The polish's fixed training particles: starts at rest (N, 2) and torques (N,)."""

    x0: np.ndarray
    torques: np.ndarray


def polish_particles(problem, rng: np.random.Generator, n: int = 96, rest_share: float = 2 / 3,
                     center_share: float = 1 / 3, center_std: float = 0.05,
                     rest_max_share: float = 0.5) -> PolishParticles:
    """Training particles shaped like the two held-out sets of ``evaluate``, drawn afresh.

    The first ``n - m`` start like the torque sweep (``q0 = A (1 + kick) + start_noise *
    normal``, ``q1 = 0``) with stratified torques, one per equal slice of the range; the
    other ``m = round(rest_share n)`` start at rest anywhere in ``[-1.5 A, 1.5 A] x [0, 2 pi)``
    (like the 5 x 5 grid) with torques uniform over the range (not only the maximum the grid
    uses). The last ``round(center_share n)`` of those start near the spring's rest point,
    ``q0 = center_std * normal``: the hardest self-start, where nothing swings to open a gate.
    A share ``rest_max_share`` of the starts at rest, spread evenly over them, has the
    maximum torque instead, as the 5 x 5 grid of ``evaluate`` has.
    """
    A = problem.amplitude
    m = int(round(rest_share * n))
    ns = n - m
    q0 = A * (1.0 + problem.kick) + problem.start_noise * rng.standard_normal(ns)
    u = (np.arange(ns) + rng.uniform(size=ns)) / max(ns, 1)
    tau_s = problem.torque_min + (problem.torque_max - problem.torque_min) * u
    xs = np.stack([q0, np.zeros(ns)], axis=1)
    xr = np.stack([rng.uniform(-1.5 * A, 1.5 * A, m), rng.uniform(problem.lower[1], problem.upper[1], m)], axis=1)
    tau_r = rng.uniform(problem.torque_min, problem.torque_max, m)
    c = min(m, int(round(center_share * n)))
    if c:
        xr[m - c:, 0] = center_std * rng.standard_normal(c)
    k = np.arange(m)
    tau_r[np.floor((k + 1) * rest_max_share) > np.floor(k * rest_max_share)] = problem.torque_max
    return PolishParticles(np.concatenate([xs, xr]), np.concatenate([tau_s, tau_r]))


def validation_particles(problem, rng: np.random.Generator, n: int = 150) -> PolishParticles:
    """Validation particles shaped like the two held-out sets of ``evaluate``, drawn afresh:
    two thirds start like the torque sweep (stratified torques over the range), one third at
    rest anywhere in ``[-1.5 A, 1.5 A] x [0, 2 pi)`` with the maximum torque, like the 5 x 5
    grid ([`polish_particles`][pes_ref.synthesis.engine.polish.polish_particles] with that mix)."""
    return polish_particles(problem, rng, n, rest_share=1 / 3, center_share=0.0, rest_max_share=1.0)


def captured_share(problem, values, particles: PolishParticles, periods: float | None = None,
                   backend: str | None = None) -> float:
    """The share of ``particles`` the capture test of ``evaluate`` passes on ``values`` after
    ``periods`` target periods (default ``problem.eval_periods``); 0 for a run that leaves
    the finite numbers."""
    periods = problem.eval_periods if periods is None else periods
    scene = problem.torque_scene(values, particles.torques, periods)
    with np.errstate(all="ignore"):
        run = simulate_batch([scene], [particles.x0], backend=backend, return_errors=True)[0]
    if not isinstance(run, Trajectory):
        return 0.0
    return float(np.mean(cycle_figures(problem, run)[3]))


def capture_fitness(problem, values, particles: PolishParticles, periods: float | None = None,
                    margin_weight: float = 0.05, strictness: float = 1.0, backend: str | None = None) -> float:
    """Forward-only fitness of a grid (lower is better): the share *not* captured plus a smooth margin.

    Each particle runs ``periods`` target periods (default ``problem.eval_periods``) and
    [`pes_ref.synthesis.kinds.analysis.cycle_figures`][pes_ref.synthesis.kinds.analysis.cycle_figures]
    judges its last periods exactly as ``evaluate`` does. The margin term ``margin_weight *
    mean(min(3, m_i))``, with ``m_i`` the largest of ``amp_err / 0.25``, ``per_err / 0.25`` and
    ``drift / 0.05`` (3 without a measurable period), ranks candidates that capture as many and
    keeps the captured ones away from the test's edges. With ``strictness < 1`` a particle counts as
    captured only when also ``m_i < strictness`` (the test's tolerances times ``strictness``). A run
    that leaves the finite numbers scores ``1 + margin_weight * 3``, the worst. ``backend`` as in
    [`pes_ref.simulate`][pes_ref.core.scene.simulate] (the fitness does not depend on it).
    """
    return capture_fitnesses(problem, [values], particles, periods, margin_weight, strictness, backend)[0]


def capture_fitnesses(problem, grids, particles: PolishParticles, periods: float | None = None,
                      margin_weight: float = 0.05, strictness: float = 1.0, backend: str | None = None) -> list:
    """[`capture_fitness`][pes_ref.synthesis.engine.polish.capture_fitness] of each grid of ``grids``, their runs as one
    population ([`pes_ref.core.population.simulate_batch`][pes_ref.core.population.simulate_batch]):
    each value is bit-identical to the grid's own
    [`capture_fitness`][pes_ref.synthesis.engine.polish.capture_fitness]."""
    periods = problem.eval_periods if periods is None else periods
    scenes = [problem.torque_scene(values, particles.torques, periods) for values in grids]
    workspace = _WORKSPACES.__dict__.setdefault("arrays", {})
    with np.errstate(all="ignore"):
        runs = simulate_batch(scenes, [particles.x0] * len(scenes), backend=backend, return_errors=True,
                              workspace=workspace)
    return [_fitness(problem, run, margin_weight, strictness) for run in runs]


#: Each thread's population arrays, kept between generations (see `simulate_batch`'s
#: ``workspace``): a generation's trajectories are consumed before the next one runs.
_WORKSPACES = threading.local()


def _fitness(problem, traj, margin_weight: float, strictness: float) -> float:
    """The fitness of one candidate's run (a [`Trajectory`][pes_ref.core.integrator.Trajectory], or the error of one
    that
    left the finite numbers)."""
    if not isinstance(traj, Trajectory):
        return 1.0 + margin_weight * MARGIN_CAP
    amp, per, drift, captured = cycle_figures(problem, traj)
    A, T = problem.amplitude, problem.period
    with np.errstate(invalid="ignore"):
        m = np.maximum.reduce([np.abs(amp - A) / A / CYCLE_TOLERANCE, np.abs(per - T) / T / CYCLE_TOLERANCE,
                               drift / CYCLE_DRIFT])
    m = np.where(np.isfinite(m), np.minimum(m, MARGIN_CAP), MARGIN_CAP)
    if strictness < 1.0:
        captured = captured & (m < strictness)
    return float(np.mean(~captured) + margin_weight * np.mean(m))


@dataclass(frozen=True)
class Fitness:
    """[`capture_fitness`][pes_ref.synthesis.engine.polish.capture_fitness] of one candidate grid (a call) or of several
    ([`batch`][pes_ref.synthesis.engine.polish.Fitness.batch]),
    picklable for executors."""

    problem: object
    particles: PolishParticles
    periods: float | None
    margin_weight: float
    strictness: float = 1.0
    backend: str | None = None

    def __call__(self, values) -> float:
        return self.batch([values])[0]

    def batch(self, grids) -> list:
        """The fitness of each grid, their runs as one population ([`capture_fitnesses`][pes_ref.synthesis.engine.polish.capture_fitnesses])."""
        return capture_fitnesses(self.problem, grids, self.particles, self.periods, self.margin_weight,
                                 self.strictness, self.backend)


class PolishStep(NamedTuple):
    """What [`polish`][pes_ref.synthesis.engine.polish.polish]'s callback receives after each generation: evaluations so far,
    the best
    fitness, the start's fitness, the best coefficients and the last validation share (NaN
    before the first)."""

    evaluations: int
    fitness: float
    fitness_start: float
    coef: np.ndarray
    validation: float = float("nan")


class PolishResult(NamedTuple):
    """What [`polish`][pes_ref.synthesis.engine.polish.polish] found.

    ``coef`` the best coefficients (zeros if nothing beat the start), ``fitness_start`` the
    start's fitness, ``fitness`` the best, ``evaluations`` fitness evaluations made (the start
    included), ``history`` ``(evaluations, best fitness)`` after the start and each
    generation, ``stopped`` True when ``stop`` ended the search early, ``validation``
    ``(evaluations, validation share of the best)`` at each validation (empty without),
    ``reached`` True when a validation reached the plan's ``validation_target``.
    """

    coef: np.ndarray
    fitness_start: float
    fitness: float
    evaluations: int
    history: list
    stopped: bool
    validation: list = []
    reached: bool = False


class _Tracker:
    """The best candidate so far, the evaluation count, and when to stop."""

    def __init__(self, plan: PolishPlan, f0: float, n: int, callback, stop, validate=None):
        self.plan, self.callback, self.stop, self.validate = plan, callback, stop, validate
        self.best = (f0, np.zeros(n))
        self.evaluations = 1
        self.history = [(1, f0)]
        self.stopped = False
        self.validation = []            # (evaluations, share of the best)
        self.validated = None           # the best's fitness when it was last judged
        self.reached = False

    @property
    def done(self) -> bool:
        return (self.stopped or self.reached or self.evaluations >= self.plan.evaluations
                or self.best[0] <= self.plan.target)

    def _validate(self) -> None:
        """Judge the best so far on the validation particles, unless it was judged already."""
        if self.validated is not None and self.validated == self.best[0]:
            return
        share = self.validate(self.best[1])
        self.validated = self.best[0]
        self.validation.append((self.evaluations, share))
        target = self.plan.validation_target
        self.reached = target is not None and share >= target

    def generation(self, xs, fs) -> None:
        self.evaluations += len(fs)
        i = int(np.argmin(fs))
        if fs[i] < self.best[0]:
            self.best = (float(fs[i]), np.array(xs[i], dtype=np.float64))
        self.history.append((self.evaluations, self.best[0]))
        if self.validate is not None and (len(self.history) - 1) % self.plan.validate_every == 0:
            self._validate()
        if self.callback is not None:
            share = self.validation[-1][1] if self.validation else float("nan")
            self.callback(PolishStep(self.evaluations, self.best[0], self.history[0][1], self.best[1], share))
        if self.stop is not None and self.stop():
            self.stopped = True


def _search_cma(evaluate, n: int, plan: PolishPlan, rng: np.random.Generator, tracker: _Tracker) -> None:
    """pycma's CMA-ES from ``coef = 0``, step ``sigma0``; its normal draws from ``rng``."""
    import cma
    opts = {"seed": float("nan"), "randn": lambda *shape: rng.standard_normal(shape), "popsize": plan.popsize,
            "maxfevals": plan.evaluations - 1, "verbose": -9, "verb_log": 0, "verb_disp": 0}
    es = cma.CMAEvolutionStrategy(np.zeros(n), plan.sigma0, opts)
    while not (es.stop() or tracker.done):
        xs = es.ask()
        fs = evaluate(xs)
        es.tell(xs, fs)
        tracker.generation(xs, fs)


def _search_de(evaluate, n: int, plan: PolishPlan, rng: np.random.Generator, tracker: _Tracker) -> None:
    """scipy's differential evolution in ``[-bound, bound]^n``, ``coef = 0`` in its first population."""
    from scipy.optimize import differential_evolution
    multiple = max(1, round(plan.popsize / n))
    maxiter = max(1, (plan.evaluations - 1) // (multiple * n) - 1)      # (maxiter + 1) generations

    def generation(_func, xs):
        xs = [np.asarray(x, dtype=np.float64) for x in xs]
        fs = evaluate(xs)
        tracker.generation(xs, fs)
        return fs

    def halt(intermediate_result):
        if tracker.done:
            raise StopIteration

    differential_evolution(lambda x: 0.0, [(-plan.bound, plan.bound)] * n, popsize=multiple, maxiter=maxiter,
                           rng=rng, polish=False, init="latinhypercube", tol=0.0, x0=np.zeros(n),
                           updating="deferred", workers=generation, callback=halt)


#: The searches by `PolishPlan.method`.
_SEARCHES = {"cma": _search_cma, "de": _search_de}


def polish(problem, values, seed: int, plan: PolishPlan = PolishPlan(), *, executor=None, tasks: int | None = None,
           callback: Callable | None = None, stop: Callable | None = None, backend: str | None = None):
    """Polish a grid: returns ``(values + B coef, PolishResult)`` for the best ``coef`` found.

    The start (``coef = 0``) is evaluated first, so the result is never worse on the training
    particles than ``values``. The search stops after the generation that reaches
    ``plan.evaluations`` evaluations (CMA-ES may exceed it by up to ``popsize - 1``;
    candidates are counted, not seconds, so the result does not depend on the machine), when
    its own stopping rules say so, when the best fitness reaches ``plan.target``, when a
    validation of the best (every ``plan.validate_every`` generations, with
    ``plan.validation_particles``) reaches ``plan.validation_target``, or when ``stop()``
    returns True after a generation.

    Parameters
    ----------
    problem : OscillatorProblem
    values : (n0, n1) array
        The grid to polish.
    seed : int
        The design's seed (see the module docstring for the streams).
    plan : PolishPlan
    executor : object with ``map(fn, iterable)``, optional
        Evaluates a generation's candidates (e.g. a ``concurrent.futures`` executor); the
        result is the same as serial.
    tasks : int, optional
        With an executor, the parts a generation is split into, each run as one population
        (default: one per candidate); without one, a generation is one population.
    callback : callable, optional
        ``callback(PolishStep)`` after each generation.
    stop : callable, optional
        ``stop() -> bool``, asked after each generation (Ctrl-C).
    backend : {"numba", "numpy"} or None
        Which loops run the candidates ([`pes_ref.simulate`][pes_ref.core.scene.simulate]); the result does not
        depend on it.
    """
    values = checks.as_float_array("values", values, ndim=2)
    seed = checks.as_nonneg_int("seed", seed)
    if tasks is not None:
        tasks = checks.as_positive_int("tasks", tasks)
    if not isinstance(plan, PolishPlan):
        raise TypeError(f"plan must be a PolishPlan, got {type(plan).__name__}")
    particles = polish_particles(problem, np.random.default_rng([seed, PARTICLE_SEED]), plan.n_particles,
                                 plan.rest_share, plan.center_share, plan.center_std, plan.rest_max_share)
    B = legendre_fourier_basis(problem, values.shape, plan.fourier_order, plan.legendre_terms)
    fitness = Fitness(problem, particles, plan.periods, plan.margin_weight, plan.strictness, backend)
    validate = None                 # the search's own validation: the captured share on held particles
    if plan.validation_particles:
        held = validation_particles(problem, np.random.default_rng([seed, VALIDATION_SEED]), plan.validation_particles)

        def captured(coef):
            return captured_share(problem, values + B @ coef, held, plan.periods, backend)
        validate = captured

    def evaluate(coefs):
        grids = [values + B @ np.asarray(c, dtype=np.float64) for c in coefs]
        if executor is None:
            return [float(f) for f in fitness.batch(grids)]
        parts = np.array_split(np.arange(len(grids)), min(len(grids), tasks or len(grids)))
        return [float(f) for part in executor.map(fitness.batch, [[grids[i] for i in p] for p in parts])
                for f in part]

    # The search's linear algebra is small (CMA-ES's 72 x 72 eigendecomposition per generation,
    # the basis products): on one BLAS thread it takes a millisecond, where OpenBLAS's second
    # thread, waiting for a core another process holds, made each eigendecomposition take
    # ~130 ms (24 s of a design). One thread also keeps the bits apart from the core count.
    with threadpool_limits(limits=1, user_api="blas"):
        tracker = _Tracker(plan, fitness(values + B @ np.zeros(B.shape[-1])), B.shape[-1], callback, stop, validate)
        if not tracker.done:
            _SEARCHES[plan.method](evaluate, B.shape[-1], plan, np.random.default_rng([seed, SEARCH_SEED]),
                                   tracker)
    f0 = tracker.history[0][1]
    coef = tracker.best[1]
    return values + B @ coef, PolishResult(coef, f0, tracker.best[0], tracker.evaluations, tracker.history,
                                           tracker.stopped, tracker.validation, tracker.reached)
