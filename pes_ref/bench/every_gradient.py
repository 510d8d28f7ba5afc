"""Every gradient a case owes, through [`pes_ref.oracle.case.run_case`][pes_ref.oracle.case.run_case], against JAX.

An implementation checked against the oracle asks for every gradient of its case: ``values``,
``x0``, ``v0``, ``force``, ``mass`` and ``damping`` (and ``spring_k``, ``spring_center`` where the
case has a spring). This module times ``run_case`` on the paper's funnel case (the benchmark's
[`pes_ref.bench.cases.funnel_case`][pes_ref.bench.cases.funnel_case] as case keys, its noise
realized into ``force``) against JAX's ``jit(value_and_grad)`` over the same inputs, all of them
differentiated ([`jax_every_gradient`][pes_ref.bench.every_gradient.jax_every_gradient]), in one
process: the runs are interleaved (one of each per round), and the median wall time of each is
reported with the ratio to JAX's. The ratio is of the medians; beside it the median [min-max] of the
ratios round by round (each run against JAX's of the same round, so that a drift of a shared
machine's speed cancels). JAX's gradients are first checked against the oracle's (100 GRAD_RTOL of
each gradient's largest entry); a mismatch is reported and not timed.

Run: ``python -m pes_ref.bench.every_gradient [--sizes 64,4096,65536] [--rounds R]``; ``make
bench`` prints the same rows ([`measure`][pes_ref.bench.every_gradient.measure],
[`format_rows`][pes_ref.bench.every_gradient.format_rows]). The targets (docs/performance.md):
compiled <= 0.5x JAX at N = 64 and < 1x at N = 4096 and 65,536; NumPy < 1x at N >= 4096.
"""
from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

from pes_ref.bench import with_jax
from pes_ref.bench.cases import DesignCase, funnel_case
from pes_ref.bench.spec import constants, _force
from pes_ref.core.backends import installed
from pes_ref.oracle.case import run_case

__all__ = ["case_keys", "jax_every_gradient", "measure", "format_rows", "target", "main", "SIZES"]

#: (N, T): the sizes of docs/performance.md's table; N = 65,536 at T = 100 (as the scaling section's
#: largest run), so that the oracle's arrays fit in memory.
SIZES = ((64, 400), (4096, 400), (65536, 100))


#: The gradients a funnel case owes (dynamic, no spring), in the order JAX differentiates them.
GRADS = ("values", "x0", "v0", "force", "mass", "damping")


def case_keys(c: DesignCase) -> dict:
    """A [`DesignCase`][pes_ref.bench.cases.DesignCase] (funnel, dynamic) as the keys of a case file (docs/spec.md section 8)."""
    return dict(values=c.values, lower=c.lower, upper=c.upper, periodic=np.array(c.periodic), dt=c.dt,
                n_steps=np.int64(c.n_steps), mode="dynamic", mass=c.mass, damping=c.damping, x0=c.x0,
                v0=c.v0, force=c.fext, wall_k=c.wall_k, wall_margin=c.wall_margin, walls=c.walls,
                objective="funnel", target=float(c.objective[1]), when="every_step")


def jax_every_gradient(c: DesignCase):
    """``run() -> (loss, {name: gradient})``: JAX's ``jit(value_and_grad)`` of the funnel's loss
    with respect to every input the case owes a gradient of (`GRADS`), written from the
    contract as [`pes_ref.bench.spec`][pes_ref.bench.spec] writes it, with ``a = dt / 2m`` and ``c = dt gamma / 2m``
    computed from the differentiated mass and damping."""
    import jax
    jax.config.update("jax_enable_x64", True)
    import jax.numpy as jnp

    k = constants(c)
    target, dt = float(c.objective[1]), c.dt

    def loss(values, x0, v0, fext, mass, damping):
        a = dt / (2.0 * mass)
        cc = dt * damping / (2.0 * mass)

        def force(x):
            return _force(jnp, values, x, k, lambda q: q)

        def state(x):
            e = x[:, 0] - target
            return jnp.sum(e * e)

        def body(carry, fext_next):
            x, v, f, total = carry
            p = v + a * f
            x1 = x + dt * p
            f1 = force(x1) + fext_next
            v1 = (p - cc * v + a * f1) / (1.0 + cc)
            return (x1, v1, f1, total + state(x1)), None

        f0 = force(x0) + fext[0]
        (_, _, _, total), _ = jax.lax.scan(body, (x0, v0, f0, state(x0)), fext[1:])
        return total

    vg = jax.jit(jax.value_and_grad(loss, argnums=tuple(range(len(GRADS)))))
    args = tuple(jnp.asarray(a, dtype=jnp.float64) for a in (c.values, c.x0, c.v0, c.fext, c.mass, c.damping))

    def run():
        value, grads = vg(*args)
        return float(value), {name: np.asarray(g) for name, g in zip(GRADS, grads)}   # waits for the result

    return run


def _check(want: dict, got: dict) -> str | None:
    """None when every gradient agrees to GRAD_RTOL of its largest entry, else the worst."""
    from pes_ref.oracle.tolerances import GRAD_RTOL
    worst = None
    for name in GRADS:
        w, g = np.asarray(want["grad_" + name]), np.broadcast_to(got[name], np.shape(want["grad_" + name]))
        scale = max(float(np.max(np.abs(w))), 1e-300)
        err = float(np.max(np.abs(g - w))) / scale
        if err > GRAD_RTOL * 100 and (worst is None or err > worst[1]):
            worst = (name, err)
    return None if worst is None else f"grad_{worst[0]} differs from the oracle's by {worst[1]:.2e} of its largest entry"


def measure(sizes=SIZES, rounds: int = 7, backends=None, seed: int = 0, log=None, grid: int = 200,
            jax: bool = True) -> list:
    """Per (N, T): the median wall seconds of ``run_case`` on each backend and of JAX, timed in
    turns (one of each per round, after a warm-up of each), and the ratios. Rows are dicts;
    ``jax=False`` leaves JAX out (not imported)."""
    backends = [b for b in (backends or ("numpy", "numba")) if installed(b)]
    rows = []
    for n, t in sizes:
        c = funnel_case(n_particles=n, n_steps=t, grid=grid, seed=seed)
        case = case_keys(c)
        runs = {b: (lambda b=b: run_case(case, backend=b)) for b in backends}
        row = dict(n=n, t=t, grid=grid, rounds=rounds, seconds={}, ratio={}, skipped=None)
        if not jax:
            row["skipped"] = "JAX not run (--no-autodiff)"
        elif with_jax.available():
            jrun = jax_every_gradient(c)
            t0 = time.perf_counter()
            jrun()
            row["jax_compile"] = time.perf_counter() - t0
            mismatch = _check(run_case(case, backend=backends[0]), jrun()[1])
            if mismatch:
                row["skipped"] = "JAX: " + mismatch
            else:
                runs["jax"] = jrun
        else:
            row["skipped"] = "JAX is not installed"
        for fn in runs.values():                        # warm-up: compiled kernels loaded, pages touched
            fn()
        times = {name: [] for name in runs}
        for _ in range(rounds):
            for name, fn in runs.items():
                t0 = time.perf_counter()
                fn()
                times[name].append(time.perf_counter() - t0)
        row["seconds"] = {name: statistics.median(ts) for name, ts in times.items()}
        row["spread"] = {name: (min(ts), max(ts)) for name, ts in times.items()}
        if "jax" in times:
            row["ratio"] = {b: row["seconds"][b] / row["seconds"]["jax"] for b in backends}
            # round by round (each backend's run beside JAX's of the same round): a drift of the
            # machine's speed cancels; the median, min and max of these ratios
            paired = {b: [tb / tj for tb, tj in zip(times[b], times["jax"])] for b in backends}
            row["paired_ratio"] = {b: (statistics.median(r), min(r), max(r)) for b, r in paired.items()}
        rows.append(row)
        if log:
            log(format_rows([row], header=False))
    return rows


#: docs/performance.md's targets against JAX, ``(backend, least N, most N, ratio limit, strict)``:
#: N = 64 compiled at most 0.5x; from N = 4096 on, both backends under 1x.
TARGETS = (("numba", 64, 64, 0.5, False), ("numba", 4096, math.inf, 1.0, True),
           ("numpy", 4096, math.inf, 1.0, True))


def target(backend: str, n: int):
    """``(limit, strict)`` of docs/performance.md for this backend at N particles, or None."""
    return next(((limit, strict) for name, least, most, limit, strict in TARGETS
                 if name == backend and least <= n <= most), None)


def _verdict(backend: str, n: int, ratio: float) -> str:
    """" (<= 0.5: met)" or the like where docs/performance.md sets a target for this backend and N."""
    goal = target(backend, n)
    if goal is None:
        return ""
    limit, strict = goal
    ok = ratio < limit if strict else ratio <= limit
    return f" ({'<' if strict else '<='} {limit:g}: {'met' if ok else 'NOT met'})"


HEADER = ("Every gradient a case owes through oracle.run_case vs JAX jit(value_and_grad) of the same inputs, "
          "funnel (ms, median [min-max] of rounds in turns)")


def format_rows(rows: list, header: bool = True) -> str:
    """The rows as text: N, T, each median in ms [min-max], and each backend's ratio to JAX."""
    lines = [HEADER] if header else []
    for r in rows:
        parts = [f"N={r['n']:>6} T={r['t']:>4}"]
        for name, s in r["seconds"].items():
            lo, hi = r["spread"][name]
            parts.append(f"{name} {1e3 * s:.1f} [{1e3 * lo:.1f}-{1e3 * hi:.1f}]")
        line = " | ".join(parts)
        for b, q in r["ratio"].items():
            pm, plo, phi = r["paired_ratio"][b]
            line += (f"\n    {b}/jax {q:.2f}x{_verdict(b, r['n'], q)}; round by round median {pm:.2f}x "
                     f"[{plo:.2f}-{phi:.2f}]")
        if r["skipped"]:
            line += f"\n    skipped: {r['skipped']}"
        lines.append(line)
    return "\n".join(lines)


def main(argv=None) -> int:
    """Time every gradient against JAX at the sizes asked for and print a row per size and
    backend; returns the exit status 0."""
    ap = argparse.ArgumentParser(prog="python -m pes_ref.bench.every_gradient", description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default=",".join(str(n) for n, _ in SIZES),
                    help="particle counts (T = 400, and 100 from N = 65536 on)")
    ap.add_argument("--steps", type=int, default=None, help="T for every size")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--backends", default="numpy,numba")
    args = ap.parse_args(argv)
    sizes = []
    for s in args.sizes.split(","):
        n = int(s)
        sizes.append((n, args.steps or (100 if n >= 65536 else 400)))
    print(format_rows([], header=True), flush=True)
    measure(sizes, rounds=args.rounds, backends=args.backends.split(","), log=lambda s: print(s, flush=True))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
