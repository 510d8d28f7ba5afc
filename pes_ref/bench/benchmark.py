"""The performance benchmark behind ``python -m pes_ref bench`` (``docs/performance.md``).

Measures, on a 200 x 200 surface and in float64:

- ``scaling``: forward, adjoint and forward+adjoint time per step and particle-steps per
  second for N in {1, 16, 256, 4096, 65536}, dynamic and quasistatic, and the ratio
  adjoint / forward, on each installed backend (`pes_ref.core.backends.BACKENDS`);
- ``memory``: the peak of ``value_and_grad`` (``tracemalloc``) against the stored
  trajectory (x, v, f) plus the grid, and the trajectory-sized arrays a run fills with
  zeros beyond those that must hold zeros;
- ``effects``: the step time of a bare scene, of a loop written for that scene alone,
  and with each effect added alone and all together; then, on each backend, terms named
  with zero coefficients (which must cost nothing) and a spring with a zero periodic axis
  (whose minimum image must not be computed);
- ``exponents``: how time grows with N and with T (least-squares slopes in log-log);
- ``design``: the funnel and oscillator design gradients ([`pes_ref.bench.cases`][pes_ref.bench.cases]) on
  each backend against HIPS autograd and JAX where installed, each checked to agree with
  pes_ref's gradient (``GRAD_RTOL``) before it is timed, JAX's compile time apart; and the
  funnel at N = 4096 and N = 65536 against JAX;
- ``every_gradient``: every gradient a case owes (values, x0, v0, force, mass, damping) through
  [`pes_ref.oracle.case.run_case`][pes_ref.oracle.case.run_case] on each backend against JAX's ``jit(value_and_grad)``
  of the same inputs, the funnel at N = 64, 4096 and 65,536
  ([`pes_ref.bench.every_gradient`][pes_ref.bench.every_gradient]);
- ``runs``: the default oscillator design (``python -m pes_ref design oscillator``), whole,
  on each backend;
- ``targets``: the targets of docs/performance.md, each with the measured number and met / not met.

Every timing is the median of repeated wall-clock runs after one warm-up run, with its min and max.
Nothing here is a test: [`pes_ref.bench.targets`][pes_ref.bench.targets] reads the targets off the
results, [`pes_ref.bench.report`][pes_ref.bench.report] prints them and
[`pes_ref.bench.outputs`][pes_ref.bench.outputs] writes them (JSON, with the machine, versions and
date) and a scaling plot.
"""
from __future__ import annotations

import datetime
import os
import platform
import time
import tracemalloc
from dataclasses import dataclass

import numpy as np

from pes_ref import __version__
from pes_ref.bench.cases import CASES, reference_gradient, reference_objective, reference_scene, smooth_surface
from pes_ref.core import backends
from pes_ref.core.effects import Constant, Noise, Window
from pes_ref.core.interpolations import interpolation
from pes_ref.core.integrator import step_coefficients
from pes_ref.core.objectives import Funnel
from pes_ref.core.scene import Scene, simulate, value_and_grad
from pes_ref.core.steppers import StepParams
from pes_ref.core.surface import Surface
from pes_ref.core.terms import Spring, Walls
from pes_ref.synthesis.common.plans import Plan, PolishPlan
from pes_ref.oracle.compare import relative_error
from pes_ref.oracle.tolerances import GRAD_RTOL
from pes_ref.bench.targets import targets

__all__ = ["Config", "FULL", "QUICK", "run"]


@dataclass(frozen=True)
class Config:
    """What the benchmark runs (FULL for ``make bench``, QUICK for a smoke run)."""

    grid: int = 200
    sizes: tuple = (1, 16, 256, 4096, 65536)
    particle_steps: int = 2_000_000     # per timed run: T = clip(particle_steps // N, min_steps, max_steps)
    min_steps: int = 20
    max_steps: int = 2000
    repeats: int = 5
    memory_case: tuple = (4096, 400)    # (N, T)
    effects_case: tuple = (256, 400)
    exponent_sizes: tuple = (256, 4096, 65536)
    exponent_steps: tuple = (100, 200, 400, 800)
    exponent_n: int = 256
    design: dict = None                 # case name -> keyword arguments of its builder
    large: tuple = ()                   # (N, T) of the funnel gradient at scale, against JAX only
    every_gradient: tuple = ()          # (N, T) of run_case's every gradient against JAX's
    every_rounds: int = 7
    autodiff_repeats: int = 3
    jax_repeats: int = 10
    autodiff: bool = True               # False: report autograd and JAX as skipped without importing them
    runs: dict = None                   # new_design keywords of the oscillator design timed whole (None: none)
    run_repeats: int = 1


FULL = Config(design={"funnel": dict(n_particles=64, n_steps=400, grid=200),
                      "oscillator": dict(n_particles=64, n_steps=500, grid=(32, 32))},
              large=((4096, 400), (65536, 100)), every_gradient=((64, 400), (4096, 400), (65536, 100)), runs={})
QUICK = Config(grid=12, sizes=(1, 4), particle_steps=40, min_steps=5, max_steps=10, repeats=1,
               memory_case=(64, 10), effects_case=(4, 6), exponent_sizes=(1, 4), exponent_steps=(5, 10),
               exponent_n=4, design={"funnel": dict(n_particles=3, n_steps=6, grid=10),
                                     "oscillator": dict(n_particles=3, n_steps=6, grid=(6, 6))},
               large=((8, 6),), every_gradient=((4, 6),), every_rounds=1, autodiff_repeats=1, jax_repeats=1,
               runs=dict(grid0=8, grid1=8, n_steps=60, eval_periods=4, plan=Plan(iterations=6, n_particles=4),
                         polish=PolishPlan(evaluations=20, n_particles=6, popsize=8)))


def installed_backends() -> tuple:
    """The backends this machine can run, in `pes_ref.core.backends.BACKENDS` order."""
    return tuple(name for name in backends.BACKENDS if backends.installed(name))

MODES = ("dynamic", "quasistatic")


# =========================================================================== timing

def _timed(fn, repeats: int, warmup: bool = True, clock=time.perf_counter) -> dict:
    """Median, min and max seconds of ``fn()`` over ``repeats`` runs (wall clock, or ``clock``)."""
    if warmup:
        fn()
    ts = []
    for _ in range(repeats):
        t0 = clock()
        fn()
        ts.append(clock() - t0)
    return {"median": float(np.median(ts)), "min": float(min(ts)), "max": float(max(ts)), "repeats": repeats}


def _interleaved(fns: dict, repeats: int, clock=time.perf_counter) -> dict:
    """`_timed` of several functions, their runs interleaved (one run of each in turn,
    after one warm-up run of each), so that a slow spell of a shared machine falls on all of
    them alike: name -> timing."""
    for fn in fns.values():
        fn()
    ts = {name: [] for name in fns}
    for _ in range(repeats):
        for name, fn in fns.items():
            t0 = clock()
            fn()
            ts[name].append(clock() - t0)
    return {name: {"median": float(np.median(t)), "min": float(min(t)), "max": float(max(t)), "repeats": repeats}
            for name, t in ts.items()}


def _per(t: dict, k: float) -> dict:
    """A timing divided by ``k`` (per step, per particle-step)."""
    return {key: (val / k if key != "repeats" else val) for key, val in t.items()}


# =========================================================================== scenes

def _surface(cfg: Config, periodic=(False, False)) -> Surface:
    rng = np.random.default_rng(1)
    lower, upper = np.array([0.0, 0.0]), np.array([1.0, 1.0])
    return Surface(smooth_surface(rng, lower, upper, (cfg.grid, cfg.grid), 0.05), lower, upper, periodic)


def _state(n: int, seed: int = 2):
    rng = np.random.default_rng(seed)
    return rng.uniform(0.1, 0.9, (n, 2)), 0.1 * rng.standard_normal((n, 2))


def _scene(cfg: Config, mode: str, n_steps: int, **kw) -> Scene:
    extra = {"mobility": (1e-3, 1e-3)} if mode == "quasistatic" else {}
    return Scene(_surface(cfg), dt=1e-3, n_steps=n_steps, mode=mode, **extra, **kw)


def _steps_for(cfg: Config, n: int) -> int:
    return int(min(cfg.max_steps, max(cfg.min_steps, cfg.particle_steps // n)))


OBJECTIVE = Funnel(target=0.5, when="every_step")


def _core_adjoint(scene: Scene, x0, v0, backend: str):
    """A closure running only the core adjoint of one stored run on ``backend`` (its
    objective's derivatives computed beforehand)."""
    traj = simulate(scene, x0, v0, backend=backend)
    _, gx, gv = OBJECTIVE.value_and_grad(traj.x, traj.v, scene.times())
    field = scene.field()
    step = backends.stepper(backend, scene.mode, scene.integrator, scene.surface.interpolation)
    params = StepParams(scene.dt, scene.n_steps, scene.mass, None, scene.mobility)
    want = frozenset({"values", "x0", "v0"} if scene.mode == "dynamic" else {"values", "x0"})
    return lambda: step.adjoint(field, traj, params, gx, gv, want)


# =========================================================================== sections

def scaling(cfg: Config, log=print) -> list:
    """Forward, adjoint and forward+adjoint per step for each N, mode and backend."""
    rows = []
    for backend in installed_backends():
        for mode in MODES:
            for n in cfg.sizes:
                T = _steps_for(cfg, n)
                scene = _scene(cfg, mode, T)
                x0, v0 = _state(n)
                fwd = _timed(lambda: simulate(scene, x0, v0, backend=backend), cfg.repeats)
                adj = _timed(_core_adjoint(scene, x0, v0, backend), cfg.repeats)
                both = _timed(lambda: value_and_grad(scene, x0, v0, OBJECTIVE, wrt=("values",), backend=backend),
                              cfg.repeats)
                row = dict(backend=backend, mode=mode, N=n, T=T, forward=_per(fwd, T), adjoint=_per(adj, T),
                           forward_adjoint=_per(both, T), forward_particle_steps_per_s=n * T / fwd["median"],
                           forward_adjoint_particle_steps_per_s=n * T / both["median"],
                           adjoint_over_forward=adj["median"] / fwd["median"])
                rows.append(row)
                log(f"  scaling {backend:5s} {mode:11s} N={n:6d} T={T:5d}: fwd {row['forward']['median'] * 1e6:9.1f} "
                    f"us/step, adj/fwd {row['adjoint_over_forward']:.2f}")
    return rows


def memory(cfg: Config) -> dict:
    """Peak traced memory of one value_and_grad against trajectory + grid (NumPy's loops,
    then each other backend's), and the arrays zero-filled ([`zero_filled`][pes_ref.bench.benchmark.zero_filled]).

    The objective is the funnel at the final step; its derivative array dL/dX
    (T+1, N, 2), an input of the adjoint, is part of the peak (one third of a
    trajectory)."""
    n, T = cfg.memory_case
    scene = _scene(cfg, "dynamic", T)
    x0, v0 = _state(n)
    objective = Funnel(target=0.5, when="final")
    peaks = {}
    for backend in installed_backends():
        value_and_grad(scene, x0, v0, objective, wrt=("values",), backend=backend)   # warm-up (imports, caches)
        tracemalloc.start()
        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        _, _, traj = value_and_grad(scene, x0, v0, objective, wrt=("values",), backend=backend)
        peaks[backend] = tracemalloc.get_traced_memory()[1] - base
        tracemalloc.stop()
    traj_bytes = traj.x.nbytes + traj.v.nbytes + traj.f.nbytes
    grid_bytes = scene.surface.values.nbytes
    ratios = {b: p / (traj_bytes + grid_bytes) for b, p in peaks.items()}
    return dict(N=n, T=T, objective="funnel, final step", peak_bytes=peaks["numpy"], trajectory_bytes=traj_bytes,
                grid_bytes=grid_bytes, peak_over_trajectory_plus_grid=ratios["numpy"], by_backend=ratios,
                zero_filled=zero_filled(cfg))


#: The functions that make an array full of zeros (or ones, or a value): each such array of a
#: trajectory's size is a pass over its memory unless its entries must hold that value.
_FILLED_MAKERS = ("zeros", "zeros_like", "ones", "ones_like", "full", "full_like")

#: The zero-filled (T+1, N, 2) arrays each run needs, because their entries stay 0: the
#: final-step funnel's dL/dX (written at the last state only); quasistatic V (all zeros).
#: An array of that size made by `_FILLED_MAKERS` beyond these is a wasted pass.
_ZEROS_NEEDED = {("dynamic", "simulate"): 0, ("dynamic", "value_and_grad"): 1,
                 ("quasistatic", "simulate"): 1, ("quasistatic", "value_and_grad"): 2}


def _filled_arrays(run, n_bytes: int) -> list:
    """The names of `_FILLED_MAKERS` that made an array of at least ``n_bytes`` while
    ``run()`` ran (NumPy's functions counted in place for the call, then restored)."""
    made, saved = [], {name: getattr(np, name) for name in _FILLED_MAKERS}

    def counted(name, fn):
        def make(*args, **kwargs):
            out = fn(*args, **kwargs)
            if getattr(out, "nbytes", 0) >= n_bytes:
                made.append(name)
            return out
        return make
    try:
        for name, fn in saved.items():
            setattr(np, name, counted(name, fn))
        run()
    finally:
        for name, fn in saved.items():
            setattr(np, name, fn)
    return made


def zero_filled(cfg: Config) -> list:
    """Per backend, mode and call (``simulate``; ``value_and_grad`` with every gradient of the
    scene and the final-step funnel): the (T+1, N, 2) arrays made filled, against
    `_ZEROS_NEEDED`."""
    n, T = cfg.memory_case
    x0, v0 = _state(n)
    rows = []
    for backend in installed_backends():
        for mode in MODES:
            scene = _scene(cfg, mode, T, spring=Spring(1.0, (0.5, 0.5)))
            calls = {"simulate": lambda: simulate(scene, x0, v0, backend=backend),
                     "value_and_grad": lambda: value_and_grad(scene, x0, v0, Funnel(0.5, "final"), backend=backend)}
            for call, run in calls.items():      # larger than the grid's tables too (at least a trajectory's)
                made = _filled_arrays(run, max((T + 1) * n * 2 * 8, 4 * scene.surface.values.nbytes + 1))
                rows.append(dict(backend=backend, mode=mode, call=call, arrays=made,
                                 needed=_ZEROS_NEEDED[(mode, call)]))
    return rows


def _hand_loop(scene: Scene, x0, v0):
    """The bare dynamic scene's forward written for it alone: the same grid kernel (built
    per run, as the engine builds it) and the same six array operations per step, with no
    effect checks, no validation, no finiteness check."""
    field = scene.field()
    T, N = scene.n_steps, x0.shape[0]
    a, _ = step_coefficients(scene.dt, scene.mass, None, N)
    dt = scene.dt

    def run():
        force = interpolation(field.interpolation).forward(field, N).call
        x, v, f = np.empty((T + 1, N, 2)), np.empty((T + 1, N, 2)), np.empty((T + 1, N, 2))
        p = np.empty((N, 2))
        x[0], v[0] = x0, v0
        force(x[0], f[0])
        for xn, xn1, vn, vn1, fn, fn1 in zip(x[:-1], x[1:], v[:-1], v[1:], f[:-1], f[1:]):
            np.multiply(a, fn, out=p)
            np.add(p, vn, out=p)
            np.multiply(p, dt, out=xn1)
            np.add(xn1, xn, out=xn1)
            force(xn1, fn1)
            np.multiply(a, fn1, out=vn1)
            np.add(vn1, p, out=vn1)
        return x, v, f
    return run


def _effect_scenes(cfg: Config, n: int, T: int) -> dict:
    rng = np.random.default_rng(3)
    walls = Walls(100.0, 0.05, np.ones((2, 2), bool))
    spring = Spring(1.0, rng.uniform(0.3, 0.7, (n, 2)))
    const = Constant((0.1, -0.2))
    kw = {
        "bare": {},
        "damping": dict(damping=0.5),
        "springs": dict(spring=spring),
        "walls": dict(walls=walls),
        "constant force": dict(effects=(const,)),
        "noise": dict(effects=(Noise((0.1, 0.1), seed=0),)),
        "time window": dict(effects=(Window(const, 0.0, 0.5 * T * 1e-3),)),
        "per-particle mass": dict(mass=rng.uniform(0.5, 2.0, (n, 1))),
    }
    kw["all together"] = dict(damping=0.5, spring=spring, walls=walls, mass=kw["per-particle mass"]["mass"],
                              effects=(const, Noise((0.1, 0.1), seed=0), Window(const, 0.0, 0.5 * T * 1e-3)))
    return {name: _scene(cfg, "dynamic", T, **k) for name, k in kw.items()}


def _nothing_scenes(cfg: Config, n: int, T: int) -> dict:
    """Scenes that name a term whose coefficients are 0 (each must cost what the bare scene
    costs), and on a cylinder (q1 periodic) a spring on both axes and one whose q1 axis is 0
    (whose minimum image must not be computed: it must cost less than the first)."""
    centers = np.random.default_rng(3).uniform(0.3, 0.7, (n, 2))
    kw = {"bare": {}, "spring, k = 0": dict(spring=Spring(0.0, centers)),
          "constant force (0, 0)": dict(effects=(Constant((0.0, 0.0)),)),
          "noise, std 0": dict(effects=(Noise((0.0, 0.0), seed=0),)), "damping 0": dict(damping=0.0)}
    out = {name: _scene(cfg, "dynamic", T, **k) for name, k in kw.items()}
    cylinder = Surface(out["bare"].surface.values, (0.0, 0.0), (1.0, 1.0), (False, True))
    for name, k in (("cylinder: spring k = (1, 1)", (1.0, 1.0)), ("cylinder: spring k = (1, 0)", (1.0, 0.0))):
        out[name] = Scene(cylinder, dt=1e-3, n_steps=T, spring=Spring(k, centers))
    return out


def _effect_rows(scenes: dict, x0, v0, T: int, repeats: int, backend: str, clock=None) -> list:
    """Per scene: forward and forward+adjoint per step on ``backend``, and as multiples of the
    first scene (the bare one): medians, and the minima (the least disturbed runs). With a
    ``clock``, the scenes' runs are interleaved (`_interleaved`) and timed by it."""
    rows = []
    if clock is not None:
        fwd = _interleaved({name: (lambda s=s: simulate(s, x0, v0, backend=backend)) for name, s in scenes.items()},
                           repeats, clock)
        both = _interleaved({name: (lambda s=s: value_and_grad(s, x0, v0, OBJECTIVE, wrt=("values",),
                                                                 backend=backend)) for name, s in scenes.items()},
                            repeats, clock)
        rows = [dict(effect=name, backend=backend, forward=_per(fwd[name], T), forward_adjoint=_per(both[name], T))
                for name in scenes]
    for name, scene in scenes.items() if clock is None else ():
        fwd = _per(_timed(lambda: simulate(scene, x0, v0, backend=backend), repeats), T)
        both = _per(_timed(lambda: value_and_grad(scene, x0, v0, OBJECTIVE, wrt=("values",), backend=backend),
                           repeats), T)
        rows.append(dict(effect=name, backend=backend, forward=fwd, forward_adjoint=both))
    bare = rows[0]
    for row in rows:
        for key in ("forward", "forward_adjoint"):
            row[f"{key}_over_bare"] = row[key]["median"] / bare[key]["median"]
            row[f"{key}_min_over_bare"] = row[key]["min"] / bare[key]["min"]
    return rows


def effects(cfg: Config, log=print) -> dict:
    """Step time of the bare scene, a loop written for it alone (both on NumPy's loops), and
    each effect on each backend; then the terms named with zero coefficients
    (`_nothing_scenes`) on each backend."""
    n, T = cfg.effects_case
    x0, v0 = _state(n)
    scenes = _effect_scenes(cfg, n, T)
    hand = _per(_timed(_hand_loop(scenes["bare"], x0, v0), cfg.repeats), T)
    by_backend = {b: _effect_rows(scenes, x0, v0, T, cfg.repeats, b) for b in installed_backends()}
    rows = by_backend.pop("numpy")
    bare = rows[0]
    log(f"  effects N={n} T={T}: bare / hand loop = {bare['forward']['median'] / hand['median']:.3f}")
    # interleaved, in CPU time (the runs use one core): on a shared machine it leaves out the waits for a core
    nothing = [row for b in installed_backends()
               for row in _effect_rows(_nothing_scenes(cfg, n, T), x0, v0, T, max(cfg.repeats, 9), b,
                                       time.process_time)]
    return dict(N=n, T=T, hand_loop_forward=hand, bare_over_hand_loop=bare["forward"]["median"] / hand["median"],
                rows=rows, other_backends=by_backend, nothing=nothing)


def _slope(xs, ys) -> float:
    return float(np.polyfit(np.log(xs), np.log(ys), 1)[0])


def exponents(cfg: Config, log=print) -> dict:
    """Slopes of log(time) against log(N) (fixed T) and against log(T) (fixed N)."""
    out = {}
    T = cfg.min_steps * 2
    tn = []
    for n in cfg.exponent_sizes:
        scene = _scene(cfg, "dynamic", T)
        x0, v0 = _state(n)
        tn.append(_timed(lambda: value_and_grad(scene, x0, v0, OBJECTIVE, wrt=("values",)), cfg.repeats)["median"])
    out["N"] = dict(T=T, sizes=list(cfg.exponent_sizes), seconds=tn, exponent=_slope(cfg.exponent_sizes, tn))
    x0, v0 = _state(cfg.exponent_n)
    tt = []
    for T in cfg.exponent_steps:
        scene = _scene(cfg, "dynamic", T)
        tt.append(_timed(lambda: value_and_grad(scene, x0, v0, OBJECTIVE, wrt=("values",)), cfg.repeats)["median"])
    out["T"] = dict(N=cfg.exponent_n, steps=list(cfg.exponent_steps), seconds=tt, exponent=_slope(cfg.exponent_steps, tt))
    log(f"  exponents: time ~ N^{out['N']['exponent']:.2f}, ~ T^{out['T']['exponent']:.2f}")
    return out


def _autodiff_entry(module, case, ref_grad, repeats: int, jitted: bool, enabled: bool = True) -> dict:
    """Check one autodiff backend against the reference gradient, then time it."""
    if not enabled:
        return {"status": "skipped", "reason": "not asked for (--no-autodiff)"}
    if not module.available():
        return {"status": "skipped", "reason": f"{module.NAME} is not installed (pip install '.[bench]')"}
    fn = module.gradient_fn(case)
    t0 = time.perf_counter()
    _, grad = fn(case.values)
    first = time.perf_counter() - t0
    err = relative_error(grad, ref_grad)
    if not err <= GRAD_RTOL:
        return {"status": "mismatch", "relative_error": err, "tolerance": GRAD_RTOL}
    entry = {"status": "ok", "relative_error": err, "first_call_s": first}
    if jitted:
        steady = _timed(lambda: fn(case.values), repeats)
        entry.update(steady=steady, compile_s=max(0.0, first - steady["median"]))
    else:
        steady = _timed(lambda: fn(case.values), repeats - 1, warmup=False) if repeats > 1 else None
        samples = [first] + ([] if steady is None else [steady["min"], steady["median"], steady["max"]])
        entry["steady"] = {"median": float(np.median(samples)), "min": float(min(samples)),
                           "max": float(max(samples)), "repeats": repeats}
    return entry


def design(cfg: Config, log=print) -> list:
    """Funnel and oscillator design gradients: pes_ref on each backend vs autograd vs JAX;
    then the funnel at the sizes of ``cfg.large`` against JAX only (autograd would take
    minutes). ``pes_ref`` is NumPy's loops (the row's first backend), ``backends`` every
    installed backend's time."""
    from pes_ref.bench import with_autograd as bench_autograd
    from pes_ref.bench import with_jax as bench_jax
    cases = [(name, kw, True) for name, kw in cfg.design.items()]
    cases += [("funnel", dict(cfg.design["funnel"], n_particles=n, n_steps=T), False) for n, T in cfg.large]
    rows = []
    for name, kw, with_autograd in cases:
        case = CASES[name](**kw)
        scene, objective = reference_scene(case), reference_objective(case)
        _, ref_grad = reference_gradient(case, scene, objective, backend="numpy")
        times = {b: _timed(lambda: reference_gradient(case, scene, objective, backend=b),
                           max(cfg.repeats, 5) if case.x0.shape[0] < 4096 else 3) for b in installed_backends()}
        ref = times["numpy"]
        autograd = (_autodiff_entry(bench_autograd, case, ref_grad, cfg.autodiff_repeats, False, cfg.autodiff)
                    if with_autograd else {"status": "skipped", "reason": "not run at this size"})
        row = dict(case=name, N=case.x0.shape[0], T=case.n_steps, grid=list(case.values.shape), pes_ref=ref,
                   backends=times, autograd=autograd,
                   jax=_autodiff_entry(bench_jax, case, ref_grad, cfg.jax_repeats, True, cfg.autodiff))
        if row["autograd"]["status"] == "ok":
            row["autograd_over_pes_ref"] = row["autograd"]["steady"]["median"] / ref["median"]
        if row["jax"]["status"] == "ok":
            jax = row["jax"]["steady"]["median"]
            row["pes_ref_over_jax_steady"] = ref["median"] / jax
            row["over_jax_steady"] = {b: t["median"] / jax for b, t in times.items()}
            row["jax_first_call_over_pes_ref"] = row["jax"]["first_call_s"] / ref["median"]
        rows.append(row)
        log(f"  design {name} N={row['N']} T={row['T']}: "
            + ", ".join(f"{b} {t['median'] * 1e3:.1f} ms" for b, t in times.items())
            + f", autograd {row['autograd']['status']}, jax {row['jax']['status']}")
    return rows


def every_gradient(cfg: Config, log=print) -> list:
    """Every gradient a case owes through ``run_case``, each backend against JAX."""
    from pes_ref.bench import every_gradient as every
    grid = cfg.design["funnel"].get("grid", cfg.grid)
    return every.measure(cfg.every_gradient, rounds=cfg.every_rounds, backends=installed_backends(),
                         grid=grid, jax=cfg.autodiff, log=lambda line: log("  " + line.replace("\n", "\n  ")))


def runs(cfg: Config, log=print) -> list:
    """The oscillator design made by ``new_design("oscillator", seed=0, **cfg.runs)`` (``{}``:
    the default of ``python -m pes_ref design oscillator``, gradient stage then polish),
    whole, on each backend: wall and CPU seconds (``run_repeats`` runs, the fastest kept)."""
    if cfg.runs is None:
        return []
    from pes_ref.synthesis import new_design, run_stages
    out = []
    for backend in installed_backends():
        wall, cpu = [], []
        for _ in range(cfg.run_repeats):
            state = new_design("oscillator", seed=0, backend=backend, **cfg.runs)
            t0, c0 = time.perf_counter(), time.process_time()
            state = run_stages(state)
            wall.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
        options = {k: v if isinstance(v, (int, float, str)) else repr(v) for k, v in cfg.runs.items()}
        out.append(dict(backend=backend, options=options, status=state.status, seconds=min(wall),
                        cpu_seconds=min(cpu), fitness=state.polish_history["fitness"][-1:]))
        log(f"  design oscillator on {backend}: {min(wall):.1f} s ({min(cpu):.1f} s CPU)")
    return out


# =========================================================================== run

def _versions() -> dict:
    import importlib.metadata as md
    out = {"python": platform.python_version(), "pes_ref": __version__}
    for pkg in ("numpy", "numba", "scipy", "matplotlib", "autograd", "jax", "jaxlib"):
        try:
            out[pkg] = md.version(pkg)
        except md.PackageNotFoundError:
            out[pkg] = None
    return out


def _machine() -> dict:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            names = [line.split(":", 1)[1].strip() for line in fh if line.startswith("model name")]
        cpu = names[0] if names else cpu
    except OSError:
        pass
    load = os.getloadavg() if hasattr(os, "getloadavg") else None
    return {"system": platform.system(), "release": platform.release(), "machine": platform.machine(),
            "cpu": cpu, "cpu_count": os.cpu_count(), "load_average": load}


def run(cfg: Config = FULL, log=print) -> dict:
    """Run every section; returns the results as a JSON-ready dict."""
    t0 = time.perf_counter()
    res = {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
           "machine": _machine(), "versions": _versions(), "config": {"grid": cfg.grid, "repeats": cfg.repeats}}
    log("scaling ...")
    res["scaling"] = scaling(cfg, log)
    log("memory ...")
    res["memory"] = memory(cfg)
    log("effects ...")
    res["effects"] = effects(cfg, log)
    log("exponents ...")
    res["exponents"] = exponents(cfg, log)
    log("design gradients ...")
    res["design"] = design(cfg, log)
    log("every gradient through run_case ...")
    res["every_gradient"] = every_gradient(cfg, log)
    log("design runs ...")
    res["runs"] = runs(cfg, log)
    res["targets"] = targets(res)
    res["machine"]["load_average_end"] = os.getloadavg() if hasattr(os, "getloadavg") else None
    res["seconds"] = time.perf_counter() - t0
    return res
