"""Other accuracy knobs: integrator, interpolation order, adjoint checkpointing.

Each option the package offers beside the paper's defaults gets a row: the error it
leaves at a fixed grid and step against the analytic trajectory it approximates, and
what it costs in wall time (and memory, for checkpointing). Options the package does
not have (yet) are listed as such, so the table never silently drops a row.

Run: ``python validation/knobs.py [--smoke] [--out DIR]``.
"""
from __future__ import annotations

import inspect
import tracemalloc

import numpy as np

from _common import Fragment, analytic_potential, option_available, parse_args, plt, topic_of, wall_time
from grid import analytic_final
import pes_ref as pr

CHECKPOINT_ARGS = ("checkpoint", "checkpoints", "checkpoint_every")
#: Damping of the knob comparison (GJF differs from the paper's step only with damping).
DAMPING = 0.5


def scene_for(integrator, interpolation, n, L, dt, T, damping):
    q = np.arange(n) * L / n
    kw = {} if interpolation == "bilinear" else {"interpolation": interpolation}
    surf = pr.Surface(analytic_potential(q[:, None], q[None, :], L), (0, 0), (L, L), (True, True), **kw)
    skw = {} if integrator == "verlet" else {"integrator": integrator}
    return pr.Scene(surf, dt=dt, n_steps=T, damping=damping, **skw)


def peak_memory(fn) -> int:
    """Peak bytes allocated (tracemalloc) while ``fn()`` runs."""
    tracemalloc.start()
    try:
        fn()
        return int(tracemalloc.get_traced_memory()[1])
    finally:
        tracemalloc.stop()


def main(argv=None) -> int:
    args = parse_args(__doc__, argv)
    topic = topic_of(__file__)
    L = 2 * np.pi
    n, dt, t_end, N = (12, 0.05, 1.0, 2) if args.smoke else (32, 0.02, 4.0, 8)
    T = int(round(t_end / dt))
    rng = np.random.default_rng(0)
    x0, v0 = rng.uniform(0, L, (N, 2)), rng.uniform(-1, 1, (N, 2))
    truth = analytic_final(x0, v0, t_end, L, DAMPING)
    avail = {k: option_available(k) for k in ("gjf", "bicubic")}
    frag = Fragment(topic, "Other accuracy knobs", args.out, intro=(
        f"{N} particles, damping {DAMPING:g}, on the analytic potential of grid.md sampled {n} x {n}, dt = {dt:g}, t = {t_end:g}. "
        "Error: largest distance at t from the DOP853 trajectory of the analytic (not sampled) force, i.e. grid and "
        "time-step error together."))
    rows = []
    for integ in ("verlet", "gjf"):
        for interp in ("bilinear", "bicubic"):
            if (integ == "gjf" and not avail["gjf"]) or (interp == "bicubic" and not avail["bicubic"]):
                rows.append((integ, interp, "not available", "", ""))
                continue
            sc = scene_for(integ, interp, n, L, dt, T, DAMPING)
            traj = pr.simulate(sc, x0, v0)
            err = float(np.max(np.linalg.norm(traj.x[-1] - truth, axis=1)))
            rows.append((integ, interp, err, wall_time(lambda: pr.simulate(sc, x0, v0), repeat=2),
                         wall_time(lambda: pr.value_and_grad(sc, x0, v0, pr.Funnel(0.0)), repeat=2)))
    frag.table(["integrator", "interpolation", "error at t", "simulate (s)", "value_and_grad (s)"], rows,
               caption="Integrator and interpolation at a fixed grid and step:")

    # adjoint checkpointing: memory against recomputation, when value_and_grad offers it
    params = inspect.signature(pr.value_and_grad).parameters
    ck = next((a for a in CHECKPOINT_ARGS if a in params), None)
    sc = scene_for("verlet", "bilinear", n, L, dt, T, 0.3)
    base_t = wall_time(lambda: pr.value_and_grad(sc, x0, v0, pr.Funnel(0.0)), repeat=2)
    base_m = peak_memory(lambda: pr.value_and_grad(sc, x0, v0, pr.Funnel(0.0)))
    crow = [("none (store every state)", base_m, base_t, "")]
    if ck is None:
        crow.append(("checkpointing", "not available", "", f"value_and_grad has none of {', '.join(CHECKPOINT_ARGS)}"))
    else:
        for every in (int(np.sqrt(T)), T // 4):
            kw = {ck: every}
            _, g_ref, _ = pr.value_and_grad(sc, x0, v0, pr.Funnel(0.0))
            _, g, _ = pr.value_and_grad(sc, x0, v0, pr.Funnel(0.0), **kw)
            same = all(np.array_equal(g[k], g_ref[k]) for k in g_ref)
            crow.append((f"{ck}={every}", peak_memory(lambda: pr.value_and_grad(sc, x0, v0, pr.Funnel(0.0), **kw)),
                         wall_time(lambda: pr.value_and_grad(sc, x0, v0, pr.Funnel(0.0), **kw), repeat=2),
                         "bit-identical gradients" if same else "gradients differ"))
    frag.table(["adjoint storage", "peak memory (bytes)", "value_and_grad (s)", "note"], crow,
               caption=f"Adjoint checkpointing (T = {T}, damped):")

    ok = [r for r in rows if not isinstance(r[2], str)]
    fig, ax = plt.subplots(figsize=(6, 4.2))
    for r in ok:
        ax.loglog(r[3], r[2], "o", label=f"{r[0]}, {r[1]}")
    ax.set_xlabel("simulate wall time (s)")
    ax.set_ylabel("error against the analytic trajectory")
    ax.legend(fontsize=8)
    frag.figure(fig, topic, "accuracy knobs: error against time")

    base = ok[0]
    for r in ok[1:]:
        frag.sentence(f"{r[0]} with {r[1]} interpolation leaves error {r[2]:.2e} against {base[2]:.2e} for the paper's "
                      f"default (ratio {base[2] / r[2]:.2g}) at {r[3] / base[3]:.2f}x its simulation time and "
                      f"{r[4] / base[4]:.2f}x its gradient time.")
    if len(ok) == 1:
        frag.sentence(f"Only the paper's default is available: error {base[2]:.2e} in {base[3]:.3g} s.")
    missing = [f"{r[0]}/{r[1]}" for r in rows if isinstance(r[2], str)]
    if missing:
        frag.sentence(f"Not available in this build: {', '.join(missing)}.")
    if ck is None:
        frag.sentence(f"value_and_grad stores all T+1 states (peak {base_m / 1e3:.0f} kB here); it has no checkpointing "
                      "option, so memory grows linearly with T.")
    else:
        frag.sentence(f"Checkpointing ({ck}) trades peak memory {crow[1][1] / 1e3:.0f} kB against {base_m / 1e3:.0f} kB "
                      f"for {crow[1][2] / base_t:.2f}x the time.")
    frag.write()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
