"""Particles: the Monte Carlo error of the design gradient against the number of particles.

The design gradient (of the Funnel loss, per particle, with respect to every grid
value) of a noisy funnel-like scene is an average over particles with random starts
and random forcing. Its spread over seeds, relative to its mean, is the Monte Carlo
error; the script measures it, fits its rate in N (1/sqrt(N) expected) and sets it
beside the wall time per gradient.

Run: ``python validation/particles.py [--smoke] [--out DIR]``.
"""
from __future__ import annotations

import numpy as np

from _common import Fragment, fit_order, parse_args, plt, topic_of, wall_time
import pes_ref as pr


def funnel_scene(n_nodes, T, noise_seed):
    """Plane, walls at the side edges (axis 0), constant downward force on axis 1,
    Gaussian noise, damping; the grid is a gentle random slope."""
    rng = np.random.default_rng(12345)
    q = np.linspace(0, 1, n_nodes)
    values = 0.3 * (q[:, None] - 0.5) ** 2 + 0.05 * rng.standard_normal((n_nodes, n_nodes))
    surf = pr.Surface(values, (0, 0), (2, 4), (False, False))
    return pr.Scene(surf, dt=0.02, n_steps=T, damping=1.0,
                    walls=pr.Walls(100.0, 0.1, [[True, True], [False, False]]),
                    effects=(pr.Constant([0.0, -1.0]), pr.Noise([0.5, 0.5], seed=noise_seed)))


def gradient(n_nodes, T, N, seed):
    """Per-particle design gradient (n, n) for one seed (starts and noise)."""
    scene = funnel_scene(n_nodes, T, seed)
    rng = np.random.default_rng(seed)
    x0 = np.column_stack((rng.uniform(0.2, 1.8, N), rng.uniform(3.0, 3.8, N)))
    _, g, _ = pr.value_and_grad(scene, x0, np.zeros((N, 2)), pr.Funnel(1.0), wrt=["values"])
    return g["values"] / N, (scene, x0)


def main(argv=None) -> int:
    args = parse_args(__doc__, argv)
    topic = topic_of(__file__)
    n_nodes = 8 if args.smoke else 16
    T = 30 if args.smoke else 150
    Ns = (4, 16, 64) if args.smoke else (4, 16, 64, 256, 1024, 4096)
    seeds = range(3 if args.smoke else 12)
    frag = Fragment(topic, "Particles: Monte Carlo error of the design gradient", args.out, intro=(
        f"Funnel-like scene ({n_nodes} x {n_nodes} plane, side walls, gravity, noise std 0.5, damping 1), T = {T}; "
        f"gradient of the Funnel loss per particle with respect to all grid values, over {len(seeds)} seeds "
        "(each seed draws the starts and the noise). MC error: root-mean-square deviation over seeds / norm of the mean."))
    rows = []
    for N in Ns:
        gs = [gradient(n_nodes, T, N, s) for s in seeds]
        G = np.array([g for g, _ in gs])
        mean = G.mean(axis=0)
        spread = float(np.sqrt(np.mean(np.sum((G - mean) ** 2, axis=(1, 2)))))
        scene, x0 = gs[0][1]
        secs = wall_time(lambda: pr.value_and_grad(scene, x0, np.zeros_like(x0), pr.Funnel(1.0), wrt=["values"]),
                         repeat=2)
        rows.append((N, spread / float(np.linalg.norm(mean)), spread, secs, secs / N * 1e6))
    r = np.array(rows, dtype=float)
    rate = fit_order(r[:, 0], r[:, 1])
    cost_rate = fit_order(r[1:, 0], r[1:, 3]) if len(r) > 2 else np.nan
    frag.table(["N", "relative MC error", "RMS spread", "time per gradient (s)", "time per particle (us)"], rows)

    fig, ax = plt.subplots(figsize=(6, 4.2))
    ax.loglog(r[:, 3], r[:, 1], "o-")
    for N, e, _, s, _ in rows:
        ax.annotate(f"N={int(N)}", (s, e), fontsize=7)
    ax.set_xlabel("wall time per gradient (s)")
    ax.set_ylabel("relative Monte Carlo error")
    frag.figure(fig, topic, "Monte Carlo error against time per gradient")

    frag.sentence(f"The relative Monte Carlo error falls as N^{rate:.2f} (1/sqrt(N) gives -0.5), from {r[0, 1]:.3f} at "
                  f"N = {int(r[0, 0])} to {r[-1, 1]:.4f} at N = {int(r[-1, 0])}.")
    frag.sentence(f"The time per gradient grows as N^{cost_rate:.2f} (vectorized over particles: "
                  f"{r[0, 3]:.3g} s at N = {int(r[0, 0])}, {r[-1, 3]:.3g} s at N = {int(r[-1, 0])}), so halving the error "
                  f"(N x {2 ** (-1 / rate):.1f}) costs about {2 ** (-cost_rate / rate):.1f}x the time.")
    ok = r[r[:, 1] <= 0.1]
    if len(ok):
        frag.sentence(f"A 10% gradient needs N = {int(ok[0, 0])} particles ({ok[0, 3]:.3g} s per gradient here).")
    else:
        frag.sentence(f"No N up to {int(r[-1, 0])} reaches a 10% gradient (best {r[:, 1].min():.3f}).")
    frag.write()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
