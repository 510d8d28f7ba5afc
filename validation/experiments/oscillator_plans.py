"""Oscillator training plans tried beyond the package's named plans (``design oscillator --plan``).

Every row of the tables "Plans tried in the third session" in ``docs/synthesis.md``
is one named plan here (:data:`PLANS`); this script regenerates it. A plan is the
package's oscillator problem (:class:`pes_ref.synthesis.kinds.oscillator.OscillatorProblem`) and plan
machinery (:class:`pes_ref.synthesis.common.plans.Plan`: RMSprop, learning-rate decay, coarse-to-fine
stages) plus the training variations that are not package options:

- ``cost="window"``: :class:`WindowPhase`, eq. (6) with its reference phase refitted per
  particle in each period-long window (a phase slip between windows costs nothing, a
  period error within a window does);
- ``init="escapement"``: the hand-drawn escapement surface (:func:`pes_ref.synthesis.kinds.escapement.escapement_values`);
- ``torque_widen``: the batch's torque range grows from a narrow band to the full range;
- ``cycle_share``: that share of each batch starts on the target cycle at a random phase
  and a random q1;
- ``rest_share``: that share starts at rest anywhere in ``[-1.5 A, 1.5 A] x [0, 2 pi)``;
- ``basis=(K, M)``: the surface is ``B theta``, Legendre polynomials ``P_0..P_{M-1}`` in
  ``q0 / q0_extent`` times ``1, cos(k q1), sin(k q1)`` for ``k = 1..K``; RMSprop runs on
  ``theta`` with the gradient ``B^T dL/dE`` (a parametrization coarser than the grid);
- ``fixed_batch``: every iteration draws iteration 0's batch (a fixed sample-average
  objective), and ``backtrack``: a step that raises the loss is undone and the step scale
  halved (grown by 1.2, up to 1, after each accepted one), so the loss on that sample can
  only fall;
- ``tbptt_periods``: each batch first runs ``L`` periods without a gradient (``L`` uniform
  in ``0..tbptt_periods``) and the training window starts from where it got to
  (truncated back-propagation through time).

Iteration ``k`` draws from ``default_rng([seed, k])`` exactly as the package's design
loop does, so ``PLANS["default"]`` reproduces ``python -m pes_ref design oscillator``
(captured 0.413 at 3,000 iterations with seed 0). At every checkpoint the script prints
and records the held-out figures of ``python -m pes_ref evaluate`` (torque sweep and
5 x 5 grid, seed 12345) and a validation share on other particles (random torques, half
of them started at rest anywhere; seed 777) that no training or held-out set uses.

Run: ``python validation/experiments/oscillator_plans.py PLAN [--seed S] [--iterations N]
[--out DIR] [--force] [--smoke]``; ``--list`` prints the plans. Each writes
``DIR/PLAN_sS.json`` (settings, checkpoints, losses) and ``DIR/PLAN_sS.npz`` (the grid
at every checkpoint); an existing file is refused unless ``--force``. A full plan takes
2-7 minutes (measured two at a time on 2 cores). The plans that are design options are also
the variants of the sweep file ``oscillator_plans.toml`` beside this script (:data:`SWEPT`);
``make oscillator-plans`` runs that file through ``python -m pes_ref sweep``, then ``--all``
here, which runs the other plans (about an hour in all).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from pes_ref.synthesis import (OSCILLATOR_PLANS, OscillatorProblem, Plan, cycle_figures, escapement_values,  # noqa: E402
                               oscillator_grid_starts, oscillator_torque_sweep, resample)
from pes_ref.core.objectives import Oscillator, OscillatorCycle  # noqa: E402
from pes_ref.core.scene import simulate, value_and_grad  # noqa: E402

DEFAULT_OUT = ROOT / "validation" / "out" / "oscillator_plans"
#: The plans that are design options: the variants of this sweep file, run by ``python -m pes_ref sweep``.
SWEEP_FILE = Path(__file__).resolve().with_name("oscillator_plans.toml")
SWEPT = tuple(v["name"] for v in tomllib.loads(SWEEP_FILE.read_text())["variants"])
#: Seeds of the two evaluation sets: the held-out one of ``evaluate`` and a validation set.
HELD_OUT_SEED, VALIDATION_SEED = 12345, 777


@dataclass(frozen=True)
class WindowPhase:
    """Eq. (6) with its reference phase refitted per particle in every period-long window.

    With ``c_{n,i} = (X_{n,i,0} - i V_{n,i,0} / w) e^{-i w t_n}`` (the state demodulated at
    the target frequency; a harmonic oscillation of amplitude a and phase phi has
    ``c = a e^{i phi}``), window ``k`` holds the steps with ``floor(t_n / period) = k``, and
    ``phi_{k,i} = arg sum_{n in k} c_{n,i}`` (the phase that best fits the window). The cost
    is ``sum_n sqrt(sum_i |c_{n,i} - A e^{i phi_{k(n),i}}|^2) / N^2``: eq. (6) (for w = 1
    its terms are exactly eq. (6)'s errors with the reference shifted by phi). The
    gradient runs through phi too: ``dphi / dc = i S / |S|^2`` with ``S`` the window sum.
    """

    amplitude: float
    omega: float
    period: float

    def value_and_grad(self, x, v, t):
        A, w = self.amplitude, self.omega
        n_particles = x.shape[1]
        t = np.asarray(t, dtype=np.float64)
        u = np.exp(-1j * w * t)[:, None]
        c = (x[:, :, 0] - 1j * v[:, :, 0] / w) * u
        win = np.floor(t / self.period + 1e-9).astype(np.intp)
        S = np.zeros((win.max() + 1, n_particles), dtype=complex)
        np.add.at(S, win, c)
        absS = np.abs(S)
        absS[absS == 0] = 1.0
        ref = A * (S / absS)[win]                                   # A e^{i phi_{k(n),i}}
        d = c - ref
        root = np.sqrt(np.sum(np.abs(d) ** 2, axis=1))
        scale = n_particles ** 2
        inv = np.divide(1.0, root * scale, out=np.zeros_like(root), where=root > 0)[:, None]
        dphi = np.zeros(S.shape)
        np.add.at(dphi, win, np.real(np.conj(d) * (-1j * ref)) * inv)   # dL/dphi per window
        dphi_dS = 1j * S / absS ** 2
        g = d * inv + (dphi * dphi_dS)[win]                         # dL/dc (as dRe + i dIm)
        gz = g * np.conj(u)
        gx, gv = np.zeros_like(x), np.zeros_like(v)
        gx[:, :, 0] = np.real(gz)
        gv[:, :, 0] = -np.imag(gz) / w
        return float(np.sum(root) / scale), gx, gv


@dataclass(frozen=True)
class Setting:
    """One plan: problem fields, the package's plan fields, and the variations above."""

    cost: str = "eq6"                   # "eq6", "cycle" (OscillatorCycle) or "window" (WindowPhase)
    target_scale: float = 1.4
    torque_min: float = 0.5
    torque_max: float = 1.0
    damping0: float = 0.05
    damping1: float = 2.0
    iterations: int = 3000
    lr: float = 5e-4
    lr_final: float = 5e-5
    stages: tuple = ((0, 16, 250), (500, 32, 400), (1000, 32, 600), (2000, 32, 1000))
    n_particles: int = 16
    every: int = 500
    init: str = "random"                # or "escapement"
    torque_widen: tuple = ()            # (half width at 0, iterations to the full range, centre)
    cycle_share: float = 0.0
    cycle_spread: float = 0.2
    rest_share: float = 0.0
    tbptt_periods: int = 0
    settle_periods: float = 1.0         # cost="cycle" only
    fixed_batch: bool = False           # the same batch (iteration 0's draws) every iteration
    backtrack: bool = False             # reject a step whose loss is higher; halve the step scale
    basis: tuple = ()                   # (K, M): E = sum of Legendre P_m(q0 / extent) x {1, cos k q1, sin k q1}


PLANS = {
    "default": Setting(),
    "window": Setting(cost="window", target_scale=1.0),
    "torque_widen": Setting(torque_widen=(0.05, 2000, 0.75)),
    "torque_widen_from_max": Setting(torque_widen=(0.05, 2500, 0.95)),
    "cycle_starts": Setting(cost="window", target_scale=1.0, cycle_share=1.0, stages=((0, 16, 380), (500, 32, 380))),
    "cycle_starts_4p": Setting(cost="window", target_scale=1.15, cycle_share=1.0, stages=((0, 16, 250), (500, 32, 500))),
    "big_batch": Setting(n_particles=128, lr=1e-3, lr_final=1e-4),
    "big_batch_window": Setting(n_particles=128, lr=1e-3, lr_final=1e-4, cost="window", target_scale=1.15),
    "coarse_big_batch": Setting(n_particles=128, lr=1e-3, lr_final=1e-4, every=250,
                                stages=((0, 16, 250), (500, 16, 400), (1000, 16, 600), (2000, 16, 1000))),
    "coarse_big_batch_slow": Setting(n_particles=128, lr=1e-3, lr_final=2e-5, every=250,
                                     stages=((0, 16, 250), (1000, 16, 400), (2000, 16, 600))),
    "coarse_big_batch_window": Setting(n_particles=128, lr=1e-3, lr_final=2e-5, cost="window", target_scale=1.15,
                                       stages=((0, 16, 250), (1000, 16, 400), (2000, 16, 600))),
    "tbptt": Setting(n_particles=64, cost="window", target_scale=1.1, tbptt_periods=12, every=250,
                     stages=((0, 16, 250), (500, 32, 250))),
    "tbptt_rest": Setting(n_particles=64, cost="window", target_scale=1.1, tbptt_periods=12, rest_share=0.25,
                          lr=1e-3, lr_final=1e-4, every=250, stages=((0, 16, 380),)),
    "narrow_torque": Setting(torque_min=0.8),
    "escapement_window": Setting(init="escapement", cost="window", target_scale=1.0, lr=1e-4, lr_final=1e-5,
                                 every=250, iterations=2000, stages=((0, 32, 500), (1000, 32, 1000))),
    "basis_fourier_legendre": Setting(basis=(4, 8)),
    "fixed_batch_backtrack": Setting(fixed_batch=True, backtrack=True, n_particles=32, cost="window",
                                     target_scale=1.0),
    "escapement_fixed_backtrack": Setting(init="escapement", fixed_batch=True, backtrack=True, n_particles=32,
                                          cost="window", target_scale=1.0, lr=1e-4, lr_final=1e-5, every=250,
                                          iterations=2000, stages=((0, 32, 500), (1000, 32, 1000))),
    "rescaled_scene": Setting(torque_min=0.2, torque_max=0.4, damping1=0.8),
    "rescaled_scene_slow": Setting(torque_min=0.2, torque_max=0.4, damping1=0.8, lr=2.5e-4, lr_final=2.5e-5),
}


def basis_matrix(shape, K: int, M: int) -> np.ndarray:
    """(n0, n1, M (2K + 1)): Legendre ``P_m`` on ``linspace(-1, 1, n0)`` times ``1, cos k q1, sin k q1``."""
    q0 = np.linspace(-1.0, 1.0, shape[0])
    q1 = np.arange(shape[1]) * 2 * np.pi / shape[1]
    P = np.polynomial.legendre.legvander(q0, M - 1)
    F = np.array([np.ones_like(q1)] + [f(k * q1) for k in range(1, K + 1) for f in (np.cos, np.sin)]).T
    return np.einsum("im,jf->ijmf", P, F).reshape(shape[0], shape[1], -1)


#: The scene these plans were measured on: eq. (6) + eq. (7) aimed at 1.4 A from the paper's
#: starts, the package's named plan "overshoot".
PAPER_SCENE = OSCILLATOR_PLANS["overshoot"][0]


def problem_of(s: Setting) -> OscillatorProblem:
    return OscillatorProblem(**{**PAPER_SCENE, "target_scale": s.target_scale, "torque_min": s.torque_min,
                                "torque_max": s.torque_max, "damping0": s.damping0, "damping1": s.damping1})


def plan_of(s: Setting) -> Plan:
    """The package's plan: RMSprop, lr decaying over the whole run, the stages."""
    return Plan(iterations=s.iterations, lr=s.lr, lr_final=s.lr_final, decay_iterations=s.iterations,
                stages=s.stages, n_particles=s.n_particles)


def objective_of(s: Setting, problem):
    amp = problem.amplitude * s.target_scale
    if s.cost == "window":
        return WindowPhase(amp, problem.omega, problem.period)
    if s.cost == "cycle":
        return OscillatorCycle(amp, problem.omega, settle=s.settle_periods * problem.period)
    return Oscillator(amp, problem.omega)


def batch(s: Setting, problem, values, rng, k: int, n_steps):
    """Iteration k's starts, velocities and scene (the package's draws first, in its order)."""
    n, A = s.n_particles, problem.amplitude
    q0 = A * (1.0 + problem.kick) + problem.start_noise * rng.standard_normal(n)
    x0 = np.stack([q0, np.zeros(n)], axis=1)
    v0 = np.zeros_like(x0)
    m = int(round(s.cycle_share * n))
    if m:
        ph = rng.uniform(0, 2 * np.pi, m)
        amp = A * (1 + s.cycle_spread * rng.uniform(-1, 1, m))
        x0[-m:, 0], v0[-m:, 0] = amp * np.cos(ph), -amp * problem.omega * np.sin(ph)
        x0[-m:, 1] = rng.uniform(0, 2 * np.pi, m)
    if s.torque_widen:
        w0, its, centre = s.torque_widen
        full = (problem.torque_max - problem.torque_min) / 2
        w = w0 + (full - w0) * min(1.0, k / its)
        c = centre if k < its else (problem.torque_max + problem.torque_min) / 2
        c = min(max(c, problem.torque_min + w), problem.torque_max - w)
        torques = rng.uniform(c - w, c + w, n)
    else:
        torques = rng.uniform(problem.torque_min, problem.torque_max, n)
    g = int(round(s.rest_share * n))
    if g:
        x0[:g, 0] = rng.uniform(-1.5 * A, 1.5 * A, g)
        x0[:g, 1] = rng.uniform(0, 2 * np.pi, g)
    effect = (problem.torque_effect(torques),)
    if s.tbptt_periods:
        periods = int(rng.integers(0, s.tbptt_periods + 1))
        if periods:
            pre = simulate(problem.scene(values, effect, int(round(periods * problem.period / problem.dt))), x0, v0)
            x0, v0 = pre.x[-1].copy(), pre.v[-1].copy()
    return x0, v0, problem.scene(values, effect, n_steps)


def held_out(problem, values, n_sweep=50, periods=None) -> dict:
    """The captured shares of ``python -m pes_ref evaluate`` (sweep and 5 x 5 grid, seed 12345)."""
    sweep = oscillator_torque_sweep(problem, values, n_sweep, periods, seed=HELD_OUT_SEED)
    grid = oscillator_grid_starts(problem, values, periods)
    s, g = cycle_figures(problem, sweep.traj)[3], cycle_figures(problem, grid.traj)[3]
    return {"captured": float(np.mean(np.concatenate([s, g]))), "sweep": float(np.mean(s)), "grid": float(np.mean(g))}


def validation_share(problem, values, n=50, periods=None) -> float:
    """Captured share of a validation set: random torques, half started at rest anywhere (seed 777)."""
    rng = np.random.default_rng(VALIDATION_SEED)
    torques = rng.uniform(problem.torque_min, problem.torque_max, n)
    A = problem.amplitude
    x0 = np.stack([A * (1 + problem.kick) + problem.start_noise * rng.standard_normal(n), np.zeros(n)], axis=1)
    m = n // 2
    x0[:m, 0] = rng.uniform(-1.5 * A, 1.5 * A, m)
    x0[:m, 1] = rng.uniform(0, 2 * np.pi, m)
    periods = problem.eval_periods if periods is None else periods
    traj = simulate(problem.torque_scene(values, torques, periods), x0)
    return float(np.mean(cycle_figures(problem, traj)[3]))


def initial_surface(s: Setting, problem, shape, seed: int):
    """The plan's starting grid and, for a basis plan, its coefficients (else None)."""
    rng = np.random.default_rng([seed, 2 ** 32])
    if s.basis:
        theta = rng.standard_normal(s.basis[1] * (2 * s.basis[0] + 1)) * 1e-3
        return basis_matrix(shape, *s.basis) @ theta, theta
    if s.init == "escapement":
        return escapement_values(problem, shape), None
    return problem.initial_values(rng, shape), None


def run(s: Setting, seed: int = 0, progress=print, eval_periods=None, n_eval=50, stop=None) -> dict:
    """Train plan ``s`` from seed ``seed``; returns the record (checkpoints, losses, grids).

    ``stop`` ends the run early at that iteration without changing the learning-rate
    schedule (which decays over ``s.iterations``)."""
    end = s.iterations if stop is None else min(stop, s.iterations)
    problem, plan = problem_of(s), plan_of(s)
    objective = objective_of(s, problem)
    shape = plan.grid_at(0, problem)
    opt = plan.make_optimizer()
    values, theta = initial_surface(s, problem, shape, seed)
    bases = {}

    def surface(shape):                     # basis plans: the grid of the current coefficients
        if shape not in bases:
            bases[shape] = basis_matrix(shape, *s.basis)
        return bases[shape] @ theta
    record = {"checkpoints": [], "loss": [], "grids": {}}
    t0 = time.perf_counter()
    kept, scale = None, 1.0                 # backtracking: (values, optimizer state, loss, stage), step scale
    for k in range(end + 1):
        if (k and k % s.every == 0) or (k == 0 and s.init != "random") or k == end:
            fig = held_out(problem, values, n_eval, eval_periods)
            fig.update(iteration=k, validation=validation_share(problem, values, n_eval, eval_periods),
                       seconds=round(time.perf_counter() - t0, 1))
            record["checkpoints"].append(fig)
            record["grids"][f"it{k}"] = values.copy()
            progress(f"it {k}: captured {fig['captured']:.3f} (sweep {fig['sweep']:.2f}, grid {fig['grid']:.2f}), "
                     f"validation {fig['validation']:.2f}, {fig['seconds']:.0f} s")
        if k == end:
            break
        target = plan.grid_at(k, problem)
        if theta is not None:
            values = surface(target)
        elif values.shape != target:
            values = resample(values, problem.lower, problem.upper, problem.periodic, target)
            opt.reset()
        draw = 0 if s.fixed_batch else k
        x0, v0, scene = batch(s, problem, values, np.random.default_rng([seed, draw]), draw, plan.steps_at(k))
        loss, grads, _ = value_and_grad(scene, x0, v0, objective, regularization_weight=problem.regularization,
                                        wrt=("values",))
        if s.backtrack:
            stage = plan.stage_at(k)
            if kept is None or kept[3] != stage:
                kept, scale = (values.copy(), opt.state_dict(), loss, stage), 1.0
            elif loss > kept[2]:                # undo the last step, try again with half the scale
                values = kept[0].copy()
                opt.load_state_dict(kept[1])
                scale *= 0.5
                record["loss"].append(float(loss))
                continue
            else:
                kept, scale = (values.copy(), opt.state_dict(), loss, stage), min(1.0, scale * 1.2)
        if theta is None:
            opt.lr = plan.lr_at(k, problem) * (scale if s.backtrack else 1.0)
            values = opt.step(values, grads["values"])
        else:                                   # no grid-ratio factor: theta does not change with the grid
            opt.lr = s.lr * (s.lr_final / s.lr) ** min(1.0, k / s.iterations)
            theta = opt.step(theta, np.tensordot(bases[target], grads["values"], axes=([0, 1], [0, 1])))
            values = surface(target)
        record["loss"].append(float(loss))
    return record


def gradient_snr(s: Setting, n_batches: int = 8, seed: int = 99) -> dict:
    """How much of one batch's design gradient is signal, on the plan's starting surface.

    The gradient of ``n_batches`` independent batches (seeds ``[seed, b]``) at the first
    stage; returns ``rms(mean) / rms(std)`` over the nodes (``snr``) beside what pure noise
    gives, ``1 / sqrt(n_batches)`` (``noise_level``), and the rms gradient (``rms``)."""
    problem, plan = problem_of(s), plan_of(s)
    shape = plan.grid_at(0, problem)
    values = initial_surface(s, problem, shape, 0)[0]
    grads = []
    for b in range(n_batches):
        x0, v0, scene = batch(s, problem, values, np.random.default_rng([seed, b]), 0, plan.steps_at(0))
        grads.append(value_and_grad(scene, x0, v0, objective_of(s, problem), wrt=("values",))[1]["values"])
    g = np.array(grads)
    mean, std = g.mean(axis=0), g.std(axis=0)
    return {"snr": float(np.sqrt(np.mean(mean ** 2)) / np.sqrt(np.mean(std ** 2))),
            "noise_level": 1.0 / math.sqrt(n_batches), "rms": float(np.sqrt(np.mean(g ** 2)))}


def rank(surfaces: dict, n_steps: int = 1000, n_batches: int = 16, n_particles: int = 16) -> list:
    """How the training costs rank surfaces: each cost summed over ``n_batches`` batches of the
    default sampler (seeds ``[7, b]``) run for ``n_steps`` steps, without eq. (7).

    Returns rows ``(name, eq6 at A, eq6 at 1.4 A, window at A)``."""
    problem = OscillatorProblem(**PAPER_SCENE)
    costs = (Oscillator(problem.amplitude, problem.omega), Oscillator(1.4 * problem.amplitude, problem.omega),
             WindowPhase(problem.amplitude, problem.omega, problem.period))
    rows = []
    for name, values in surfaces.items():
        totals = np.zeros(len(costs))
        for b in range(n_batches):
            batch_ = problem.batch(values, np.random.default_rng([7, b]), n_particles, n_steps)
            traj = simulate(batch_.scene, batch_.x0, batch_.v0)
            t = np.arange(traj.x.shape[0]) * problem.dt
            totals += [c.value_and_grad(traj.x, traj.v, t)[0] for c in costs]
        rows.append((name, *totals))
    return rows


def smoke_setting(s: Setting) -> Setting:
    """A few iterations on tiny grids and short runs (for make test)."""
    return dataclasses.replace(s, iterations=4, every=2, n_particles=4,
                               stages=((0, 8, 40), (2, 8, 60)), tbptt_periods=min(s.tbptt_periods, 1))


def summary(folder: Path) -> str:
    """A markdown table of every record in ``folder``: captured share (sweep / grid) per checkpoint,
    the final one, and the checkpoint the validation set would pick."""
    rows = ["| plan | seed | captured at checkpoints (iteration: share) | final: captured (sweep / grid) "
            "| best on validation -> captured |", "|---|---|---|---|---|"]
    for path in sorted(Path(folder).glob("*_s*.json")):
        r = json.loads(path.read_text())
        cps = r["checkpoints"]
        last = cps[-1]
        best = max(cps, key=lambda c: c["validation"])
        seq = " ".join(f"{c['iteration']}: {c['captured']:.2f}" for c in cps)
        rows.append(f"| {r['plan']} | {r['seed']} | {seq} | {last['captured']:.3f} ({last['sweep']:.2f} / "
                    f"{last['grid']:.2f}) at {last['iteration']} | {best['iteration']} ({best['validation']:.2f}) "
                    f"-> {best['captured']:.3f} |")
    return "\n".join(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument("plan", nargs="?", help="a plan name (see --list)")
    ap.add_argument("--list", action="store_true", help="print the plans and exit")
    ap.add_argument("--all", action="store_true",
                    help="run every plan not in oscillator_plans.toml (seed 0) whose record is missing, then --summary")
    ap.add_argument("--summary", action="store_true", help="print a markdown table of the records in --out and exit")
    ap.add_argument("--rank", nargs="*", metavar="FILE.npz:KEY",
                    help="print how the training costs rank the flat surface, the escapement and these saved grids")
    ap.add_argument("--snr", action="store_true",
                    help="print the gradient's signal-to-noise ratio of every plan's first stage and exit")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--iterations", type=int, help="override the plan's iteration count (and its lr decay)")
    ap.add_argument("--stop", type=int, help="stop at this iteration, keeping the plan's lr schedule")
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    ap.add_argument("--force", action="store_true", help="overwrite existing result files")
    ap.add_argument("--smoke", action="store_true", help="tiny sizes (seconds), for make test")
    args = ap.parse_args(argv)
    if args.list:
        for name, s in PLANS.items():
            changed = {f.name: getattr(s, f.name) for f in dataclasses.fields(s) if getattr(s, f.name) != f.default}
            print(f"{name}: {changed or 'the package default'}")
        return 0
    if args.summary:
        print(summary(args.out))
        return 0
    if args.rank is not None:
        problem = OscillatorProblem(**PAPER_SCENE)
        surfaces = {"flat": problem.flat_values(), "escapement": escapement_values(problem)}
        for spec in args.rank:
            path, _, key = spec.rpartition(":")
            if not path:
                ap.error(f"--rank takes FILE.npz:KEY, got {spec!r}")
            with np.load(path) as grids:
                if key not in grids.files:
                    ap.error(f"{path} has no grid {key!r} (it has {', '.join(grids.files)})")
                surfaces[spec] = resample(grids[key], problem.lower, problem.upper, problem.periodic,
                                          problem.shape())
        steps, batches = (60, 2) if args.smoke else (1000, 16)
        print(f"Training costs over {steps} steps, {batches} batches of 16 (the default sampler, seeds [7, b]):\n")
        print("| surface | eq. (6) at A | eq. (6) at 1.4 A | window at A |")
        print("|---|---|---|---|")
        for name, *vals in rank(surfaces, n_steps=steps, n_batches=batches):
            print(f"| {name} | " + " | ".join(f"{v:.2f}" for v in vals) + " |", flush=True)
        return 0
    if args.snr:
        print("| plan | first stage (iteration, grid, steps) | particles | snr | pure noise | rms gradient |")
        print("|---|---|---|---|---|---|")
        for name, s in PLANS.items():
            s = smoke_setting(s) if args.smoke else s
            r = gradient_snr(s, n_batches=2 if args.smoke else 8)
            print(f"| {name} | {s.stages[0]} | {s.n_particles} | {r['snr']:.2f} | {r['noise_level']:.2f} "
                  f"| {r['rms']:.3g} |", flush=True)
        return 0
    if args.all:
        for name, seed in [(n, 0) for n in PLANS if n not in SWEPT]:
            if not (args.out / f"{name}_s{seed}.json").exists():
                code = main([name, "--seed", str(seed), "--out", str(args.out)] + (["--smoke"] if args.smoke else []))
                if code:
                    return code
        print(summary(args.out))
        return 0
    if args.plan not in PLANS:
        ap.error(f"plan must be one of {', '.join(PLANS)}, got {args.plan!r}")
    if args.seed < 0:
        ap.error(f"--seed must be >= 0, got {args.seed}")
    s = PLANS[args.plan]
    if args.iterations is not None:
        if args.iterations < 1:
            ap.error(f"--iterations must be >= 1, got {args.iterations}")
        s = dataclasses.replace(s, iterations=args.iterations)
    if args.stop is not None and args.stop < 1:
        ap.error(f"--stop must be >= 1, got {args.stop}")
    if args.smoke:
        s = smoke_setting(s)
    stem = args.out / f"{args.plan}_s{args.seed}"
    files = [stem.with_suffix(".json"), stem.with_suffix(".npz")]
    if not args.force and any(f.exists() for f in files):
        ap.error(f"{files[0]} exists; pass --force to overwrite it")
    args.out.mkdir(parents=True, exist_ok=True)
    print(f"plan {args.plan} (seed {args.seed}): {s}", flush=True)
    record = run(s, args.seed, progress=lambda line: print(line, flush=True),
                 eval_periods=4 if args.smoke else None, n_eval=4 if args.smoke else 50,
                 stop=None if args.smoke else args.stop)
    np.savez(files[1], **record.pop("grids"))
    files[0].write_text(json.dumps({"plan": args.plan, "seed": args.seed, "setting": dataclasses.asdict(s),
                                    **record}, indent=1))
    best = max(record["checkpoints"], key=lambda c: c["validation"])
    last = record["checkpoints"][-1]
    print(f"final (it {last['iteration']}): captured {last['captured']:.3f}; best on validation: it {best['iteration']}"
          f" (validation {best['validation']:.2f}) -> captured {best['captured']:.3f}")
    print(f"wrote {files[0]} and {files[1]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
