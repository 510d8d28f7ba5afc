"""The performance benchmark behind ``python -m pes_ref bench`` (``docs/performance.md``).

Measures, on a 200 x 200 surface and in float64:

- ``scaling``: forward, adjoint and forward+adjoint time per step and particle-steps per
  second for N in {1, 16, 256, 4096, 65536}, dynamic and quasistatic, and the ratio
  adjoint / forward;
- ``memory``: the peak of ``value_and_grad`` (``tracemalloc``) against the stored
  trajectory (x, v, f) plus the grid;
- ``effects``: the step time of a bare scene, of a loop written for that scene alone,
  and with each effect added alone and all together;
- ``exponents``: how time grows with N and with T (least-squares slopes in log-log);
- ``design``: the funnel and oscillator design gradients (:mod:`pes_ref.bench.cases`)
  against HIPS autograd and JAX where installed, each checked to agree with pes_ref's
  gradient (``GRAD_RTOL``) before it is timed, JAX's compile time apart;
- ``targets``: the targets of docs/performance.md, each with the measured number and met / not met.

Every timing is the median of repeated wall-clock runs after one warm-up run, with its
min and max. Nothing here is a test: it prints numbers and writes them (JSON, with the
machine, versions and date) and a scaling plot.
"""
from __future__ import annotations

import datetime
import json
import os
import platform
import time
import tracemalloc
from dataclasses import dataclass

import numpy as np

from pes_ref import __version__
from pes_ref.bench.cases import CASES, reference_gradient, reference_objective, reference_scene, smooth_surface
from pes_ref.core.effects import Constant, Noise, Window
from pes_ref.core.files import atomic_file
from pes_ref.core.interpolations import interpolation
from pes_ref.core.integrator import adjoint_dynamic, adjoint_quasistatic, step_coefficients
from pes_ref.core.objectives import Funnel
from pes_ref.core.scene import Scene, simulate, value_and_grad
from pes_ref.core.surface import Surface
from pes_ref.core.terms import Spring, Walls
from pes_ref.oracle.compare import relative_error
from pes_ref.oracle.tolerances import GRAD_RTOL

__all__ = ["Config", "FULL", "QUICK", "run", "format_report", "write_outputs"]


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
    autodiff_repeats: int = 3
    jax_repeats: int = 10
    autodiff: bool = True               # False: report autograd and JAX as skipped without importing them


FULL = Config(design={"funnel": dict(n_particles=64, n_steps=400, grid=200),
                      "oscillator": dict(n_particles=64, n_steps=500, grid=(32, 32))})
QUICK = Config(grid=12, sizes=(1, 4), particle_steps=40, min_steps=5, max_steps=10, repeats=1,
               memory_case=(4, 10), effects_case=(4, 6), exponent_sizes=(1, 4), exponent_steps=(5, 10),
               exponent_n=4, design={"funnel": dict(n_particles=3, n_steps=6, grid=10),
                                     "oscillator": dict(n_particles=3, n_steps=6, grid=(6, 6))},
               autodiff_repeats=1, jax_repeats=1)

MODES = ("dynamic", "quasistatic")


# =========================================================================== timing

def _timed(fn, repeats: int, warmup: bool = True) -> dict:
    """Median, min and max wall-clock seconds of ``fn()`` over ``repeats`` runs."""
    if warmup:
        fn()
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return {"median": float(np.median(ts)), "min": float(min(ts)), "max": float(max(ts)), "repeats": repeats}


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


def _core_adjoint(scene: Scene, x0, v0):
    """A closure running only the core adjoint of one stored run (its objective's
    derivatives computed beforehand)."""
    traj = simulate(scene, x0, v0)
    _, gx, gv = OBJECTIVE.value_and_grad(traj.x, traj.v, scene.times())
    field = scene.field()
    if scene.mode == "dynamic":
        want = frozenset({"values", "x0", "v0"})
        return lambda: adjoint_dynamic(field, traj, scene.dt, scene.mass, None, gx, gv, want)
    want = frozenset({"values", "x0"})
    return lambda: adjoint_quasistatic(field, traj, scene.mobility, gx, want)


# =========================================================================== sections

def scaling(cfg: Config, log=print) -> list:
    """Forward, adjoint and forward+adjoint per step for each N and mode."""
    rows = []
    for mode in MODES:
        for n in cfg.sizes:
            T = _steps_for(cfg, n)
            scene = _scene(cfg, mode, T)
            x0, v0 = _state(n)
            fwd = _timed(lambda: simulate(scene, x0, v0), cfg.repeats)
            adj = _timed(_core_adjoint(scene, x0, v0), cfg.repeats)
            both = _timed(lambda: value_and_grad(scene, x0, v0, OBJECTIVE, wrt=("values",)), cfg.repeats)
            row = dict(mode=mode, N=n, T=T, forward=_per(fwd, T), adjoint=_per(adj, T), forward_adjoint=_per(both, T),
                       forward_particle_steps_per_s=n * T / fwd["median"],
                       forward_adjoint_particle_steps_per_s=n * T / both["median"],
                       adjoint_over_forward=adj["median"] / fwd["median"])
            rows.append(row)
            log(f"  scaling {mode:11s} N={n:6d} T={T:5d}: fwd {row['forward']['median'] * 1e6:9.1f} us/step, "
                f"adj/fwd {row['adjoint_over_forward']:.2f}")
    return rows


def memory(cfg: Config) -> dict:
    """Peak traced memory of one value_and_grad against trajectory + grid.

    The objective is the funnel at the final step; its derivative array dL/dX
    (T+1, N, 2), an input of the adjoint, is part of the peak (one third of a
    trajectory)."""
    n, T = cfg.memory_case
    scene = _scene(cfg, "dynamic", T)
    x0, v0 = _state(n)
    objective = Funnel(target=0.5, when="final")
    value_and_grad(scene, x0, v0, objective, wrt=("values",))     # warm-up (imports, caches)
    tracemalloc.start()
    tracemalloc.reset_peak()
    base = tracemalloc.get_traced_memory()[0]
    _, _, traj = value_and_grad(scene, x0, v0, objective, wrt=("values",))
    peak = tracemalloc.get_traced_memory()[1] - base
    tracemalloc.stop()
    traj_bytes = traj.x.nbytes + traj.v.nbytes + traj.f.nbytes
    grid_bytes = scene.surface.values.nbytes
    return dict(N=n, T=T, objective="funnel, final step", peak_bytes=peak, trajectory_bytes=traj_bytes,
                grid_bytes=grid_bytes,
                peak_over_trajectory_plus_grid=peak / (traj_bytes + grid_bytes))


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


def effects(cfg: Config, log=print) -> dict:
    """Step time of the bare scene, a loop written for it alone, and each effect."""
    n, T = cfg.effects_case
    x0, v0 = _state(n)
    rows = []
    scenes = _effect_scenes(cfg, n, T)
    hand = _per(_timed(_hand_loop(scenes["bare"], x0, v0), cfg.repeats), T)
    for name, scene in scenes.items():
        fwd = _per(_timed(lambda: simulate(scene, x0, v0), cfg.repeats), T)
        both = _per(_timed(lambda: value_and_grad(scene, x0, v0, OBJECTIVE, wrt=("values",)), cfg.repeats), T)
        rows.append(dict(effect=name, forward=fwd, forward_adjoint=both))
    bare = rows[0]
    for row in rows:
        row["forward_over_bare"] = row["forward"]["median"] / bare["forward"]["median"]
        row["forward_adjoint_over_bare"] = row["forward_adjoint"]["median"] / bare["forward_adjoint"]["median"]
    log(f"  effects N={n} T={T}: bare / hand loop = {bare['forward']['median'] / hand['median']:.3f}")
    return dict(N=n, T=T, hand_loop_forward=hand, bare_over_hand_loop=bare["forward"]["median"] / hand["median"],
                rows=rows)


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
    """Funnel and oscillator design gradients: pes_ref vs autograd vs JAX."""
    from pes_ref.bench import with_autograd as bench_autograd
    from pes_ref.bench import with_jax as bench_jax
    rows = []
    for name, kw in cfg.design.items():
        case = CASES[name](**kw)
        scene, objective = reference_scene(case), reference_objective(case)
        _, ref_grad = reference_gradient(case, scene, objective)
        ref = _timed(lambda: reference_gradient(case, scene, objective), max(cfg.repeats, 5))
        row = dict(case=name, N=case.x0.shape[0], T=case.n_steps, grid=list(case.values.shape), pes_ref=ref,
                   autograd=_autodiff_entry(bench_autograd, case, ref_grad, cfg.autodiff_repeats, False, cfg.autodiff),
                   jax=_autodiff_entry(bench_jax, case, ref_grad, cfg.jax_repeats, True, cfg.autodiff))
        if row["autograd"]["status"] == "ok":
            row["autograd_over_pes_ref"] = row["autograd"]["steady"]["median"] / ref["median"]
        if row["jax"]["status"] == "ok":
            row["pes_ref_over_jax_steady"] = ref["median"] / row["jax"]["steady"]["median"]
            row["jax_first_call_over_pes_ref"] = row["jax"]["first_call_s"] / ref["median"]
        rows.append(row)
        log(f"  design {name}: pes_ref {ref['median'] * 1e3:.1f} ms, autograd {row['autograd']['status']}, "
            f"jax {row['jax']['status']}")
    return rows


# =========================================================================== targets

def targets(res: dict) -> list:
    """Issue 6's targets with the measured numbers: (name, measured, goal, met or None if not measured)."""
    out = []

    def add(name, value, goal, met):
        out.append(dict(target=name, measured=value, goal=goal, met=met))

    sc = res["scaling"]
    big = [r["adjoint_over_forward"] for r in sc if r["N"] >= 64]
    if big:
        add("adjoint / forward, N >= 64 (worst)", max(big), "<= 1.5", max(big) <= 1.5)
    for r in sc:
        if r["N"] == 65536 and r["mode"] == "dynamic":
            add("forward particle-steps/s at N = 65536", r["forward_particle_steps_per_s"], ">= 1e7",
                r["forward_particle_steps_per_s"] >= 1e7)
            add("forward+adjoint particle-steps/s at N = 65536", r["forward_adjoint_particle_steps_per_s"], ">= 4e6",
                r["forward_adjoint_particle_steps_per_s"] >= 4e6)
        if r["N"] == 1 and r["mode"] == "dynamic":
            us = r["forward"]["median"] * 1e6
            add("forward step at N = 1 (us)", us, "< 25", us < 25)
    eff = res["effects"]["bare_over_hand_loop"]
    add("bare scene / loop written for it alone", eff, "<= 1.05", eff <= 1.05)
    mem = res["memory"]["peak_over_trajectory_plus_grid"]
    add("peak memory / (trajectory + grid)", mem, "<= 1.5", mem <= 1.5)
    for row in res["design"]:
        if row["case"] != "funnel":
            continue
        if "autograd_over_pes_ref" in row:
            v = row["autograd_over_pes_ref"]
            add("funnel gradient: autograd / pes_ref", v, ">= 20", v >= 20)
        else:
            add("funnel gradient: autograd / pes_ref", None, ">= 20", None)
        if "pes_ref_over_jax_steady" in row:
            v = row["pes_ref_over_jax_steady"]
            add("funnel gradient: pes_ref / JAX steady state", v, "<= 2", v <= 2)
        else:
            add("funnel gradient: pes_ref / JAX steady state", None, "<= 2", None)
    return out


# =========================================================================== run, report, write

def _versions() -> dict:
    import importlib.metadata as md
    out = {"python": platform.python_version(), "pes_ref": __version__}
    for pkg in ("numpy", "scipy", "matplotlib", "autograd", "jax", "jaxlib"):
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
    res["targets"] = targets(res)
    res["machine"]["load_average_end"] = os.getloadavg() if hasattr(os, "getloadavg") else None
    res["seconds"] = time.perf_counter() - t0
    return res


def _fmt_t(t: dict, scale: float = 1e6) -> str:
    """'median [min-max]' in microseconds (default)."""
    return f"{t['median'] * scale:9.1f} [{t['min'] * scale:.1f}-{t['max'] * scale:.1f}]"


def _fmt_v(v) -> str:
    if v is None:
        return "n/a"
    return f"{v:.3g}"


def format_report(res: dict) -> str:
    """The human-readable tables."""
    L = [f"pes_ref bench  {res['date']}  {res['machine']['cpu']} x{res['machine']['cpu_count']}  "
         f"load {res['machine']['load_average']}  numpy {res['versions']['numpy']}", ""]
    L.append(f"Scaling on a {res['config']['grid']}x{res['config']['grid']} grid: us per step, median [min-max] "
             f"of {res['config']['repeats']} runs")
    L.append(f"{'mode':11s} {'N':>6s} {'T':>5s} {'forward':>26s} {'adjoint':>26s} {'fwd+adj':>26s} "
             f"{'fwd p-s/s':>10s} {'f+a p-s/s':>10s} {'adj/fwd':>7s}")
    for r in res["scaling"]:
        L.append(f"{r['mode']:11s} {r['N']:6d} {r['T']:5d} {_fmt_t(r['forward']):>26s} {_fmt_t(r['adjoint']):>26s} "
                 f"{_fmt_t(r['forward_adjoint']):>26s} {r['forward_particle_steps_per_s']:10.3g} "
                 f"{r['forward_adjoint_particle_steps_per_s']:10.3g} {r['adjoint_over_forward']:7.2f}")
    m = res["memory"]
    L += ["", f"Memory (value_and_grad, N={m['N']}, T={m['T']}): peak {m['peak_bytes'] / 2**20:.1f} MiB, trajectory "
          f"{m['trajectory_bytes'] / 2**20:.1f} MiB + grid {m['grid_bytes'] / 2**20:.2f} MiB -> "
          f"ratio {m['peak_over_trajectory_plus_grid']:.2f}"]
    e = res["effects"]
    L += ["", f"Effects (dynamic, N={e['N']}, T={e['T']}): us per step; loop written for the bare scene alone: "
          f"{_fmt_t(e['hand_loop_forward'])}; bare / that loop = {e['bare_over_hand_loop']:.3f}",
          f"{'effect':18s} {'forward':>26s} {'x bare':>7s} {'fwd+adj':>26s} {'x bare':>7s}"]
    for r in e["rows"]:
        L.append(f"{r['effect']:18s} {_fmt_t(r['forward']):>26s} {r['forward_over_bare']:7.2f} "
                 f"{_fmt_t(r['forward_adjoint']):>26s} {r['forward_adjoint_over_bare']:7.2f}")
    x = res["exponents"]
    L += ["", f"Exponents (fwd+adj): time ~ N^{x['N']['exponent']:.2f} (N = {x['N']['sizes']}, T = {x['N']['T']}), "
          f"~ T^{x['T']['exponent']:.2f} (T = {x['T']['steps']}, N = {x['T']['N']})"]
    L += ["", "Design gradients (ms, median [min-max]); autodiff versions checked against pes_ref first"]
    for r in res["design"]:
        L.append(f"  {r['case']} ({r['grid'][0]}x{r['grid'][1]}, N={r['N']}, T={r['T']}): "
                 f"pes_ref {_fmt_t(r['pes_ref'], 1e3)}")
        for lib in ("autograd", "jax"):
            d = r[lib]
            if d["status"] != "ok":
                L.append(f"    {lib:8s} {d['status']}: {d.get('reason', '')}{d.get('relative_error', '')}")
                continue
            extra = f", compile {d['compile_s']:.2f} s, first call {d['first_call_s']:.2f} s" if lib == "jax" else ""
            L.append(f"    {lib:8s} {_fmt_t(d['steady'], 1e3)}  (rel. err {d['relative_error']:.1e}{extra})")
        if "autograd_over_pes_ref" in r:
            L.append(f"    autograd / pes_ref = {r['autograd_over_pes_ref']:.1f}")
        if "pes_ref_over_jax_steady" in r:
            L.append(f"    pes_ref / JAX steady = {r['pes_ref_over_jax_steady']:.2f}; "
                     f"JAX first call (compile included) / pes_ref = {r['jax_first_call_over_pes_ref']:.0f}")
    L += ["", "Targets (docs/performance.md)"]
    for t in res["targets"]:
        status = {True: "met", False: "NOT met", None: "not measured"}[t["met"]]
        L.append(f"  {t['target']:48s} {_fmt_v(t['measured']):>10s}  goal {t['goal']:8s} {status}")
    L.append(f"\n(total {res['seconds']:.0f} s)")
    return "\n".join(L)


def plot_scaling(res: dict, path: str, overwrite: bool = True) -> None:
    """Time per step against N, forward and forward+adjoint, both modes (log-log)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4.2))
    for mode, ls in (("dynamic", "-"), ("quasistatic", "--")):
        rows = [r for r in res["scaling"] if r["mode"] == mode]
        n = [r["N"] for r in rows]
        for key, marker, label in (("forward", "o", "forward"), ("forward_adjoint", "s", "forward + adjoint")):
            med = np.array([r[key]["median"] for r in rows]) * 1e6
            lo = med - np.array([r[key]["min"] for r in rows]) * 1e6
            hi = np.array([r[key]["max"] for r in rows]) * 1e6 - med
            ax.errorbar(n, med, yerr=[lo, hi], ls=ls, marker=marker, ms=4, capsize=2, label=f"{label}, {mode}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("particles N")
    ax.set_ylabel("time per step (us)")
    ax.set_title(f"pes_ref on a {res['config']['grid']}x{res['config']['grid']} grid "
                 f"(median of {res['config']['repeats']}, bars min-max)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    with atomic_file(path, overwrite=overwrite, what="plot") as fh:
        fig.savefig(fh, format="png", dpi=150)
    plt.close(fig)


def _jsonable(o):
    """NumPy scalars and arrays as plain Python values for ``json.dump``."""
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not JSON serializable: {type(o).__name__}")


def output_paths(json_path: str) -> tuple:
    """The files :func:`write_outputs` writes for ``json_path``: it, and beside it the plot
    ``scaling.png`` (or ``<stem>-scaling.png``)."""
    folder = os.path.dirname(os.path.abspath(json_path))
    stem = os.path.splitext(os.path.basename(json_path))[0]
    return json_path, os.path.join(folder, "scaling.png" if stem == "bench" else f"{stem}-scaling.png")


def write_outputs(res: dict, json_path: str, overwrite: bool) -> tuple:
    """Write the JSON and, beside it, ``scaling.png`` (or ``<stem>-scaling.png``), each
    atomically (:func:`pes_ref.core.files.atomic_file`).

    Refuses (FileExistsError) to replace an existing file unless ``overwrite``: both are
    checked before anything is written, and each again as it is published."""
    folder = os.path.dirname(os.path.abspath(json_path))
    png = output_paths(json_path)[1]
    for path in (json_path, png):
        if os.path.exists(path) and not overwrite:
            raise FileExistsError(f"{path} exists; pass --force to replace it")
    os.makedirs(folder, exist_ok=True)
    text = json.dumps(res, indent=1, default=_jsonable)
    with atomic_file(json_path, overwrite=overwrite, what="benchmark") as fh:
        fh.write(text.encode("utf-8"))
    plot_scaling(res, png, overwrite=overwrite)
    return json_path, png
