"""Grid resolution: the surface's error against the analytic potential it samples.

A smooth potential on a torus is sampled on n x n grids; at random points the grid's
energy and force are compared with the analytic ones (expected O(h^2) in energy and
O(h) in force for bilinear interpolation), beside the grid's memory and the time per
force evaluation, and what the error does to a trajectory (Verlet at a small fixed dt
against DOP853 on the analytic force). Bicubic rows appear when the package has
``Surface(interpolation="bicubic")``.

Run: ``python validation/grid.py [--smoke] [--out DIR]``.
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from _common import (Fragment, analytic_force, analytic_potential, fit_order, option_available, parse_args, plt,
                     topic_of, wall_time)
import pes_ref as pr
from pes_ref.core.forces import force


#: Steps of the timing run (M particles): time per particle-step of pr.simulate.
STEP_TIMING = 5


def surface(n, L, interpolation):
    q = np.arange(n) * L / n
    kw = {} if interpolation == "bilinear" else {"interpolation": interpolation}
    return pr.Surface(analytic_potential(q[:, None], q[None, :], L), (0, 0), (L, L), (True, True), **kw)


def analytic_final(x0, v0, t_end, L, gamma=0.0):
    """DOP853 (rtol 1e-12) of x'' = F_analytic(x) - gamma x' (unit mass): the trajectory
    the grid approximates."""
    N = x0.shape[0]

    def rhs(_t, y):
        x = y[: 2 * N].reshape(N, 2)
        return np.concatenate((y[2 * N:], analytic_force(x, L).ravel() - gamma * y[2 * N:]))

    sol = solve_ivp(rhs, (0, t_end), np.concatenate((x0.ravel(), v0.ravel())), method="DOP853",
                    rtol=1e-12, atol=1e-14)
    return sol.y[: 2 * N, -1].reshape(N, 2)


def main(argv=None) -> int:
    args = parse_args(__doc__, argv)
    topic = topic_of(__file__)
    L = 2 * np.pi
    sizes = (8, 16) if args.smoke else (8, 16, 32, 64, 128, 256, 512)
    M = 500 if args.smoke else 20_000
    t_end, dt, N = (0.5, 0.01, 4) if args.smoke else (2.0, 0.002, 16)
    rng = np.random.default_rng(0)
    pts = rng.uniform(0, L, (M, 2))
    U, F = analytic_potential(pts[:, 0], pts[:, 1], L), analytic_force(pts, L)
    x0, v0 = rng.uniform(0, L, (N, 2)), rng.uniform(-1, 1, (N, 2))
    x_true = analytic_final(x0, v0, t_end, L)
    interps = ["bilinear"] + (["bicubic"] if option_available("bicubic") else [])

    frag = Fragment(topic, "Grid resolution: surface error against the sampled analytic potential", args.out,
                    intro=(f"U = cos q0 + cos q1 + sin(q0 + q1)/2 on a 2 pi torus, sampled on n x n nodes; errors are "
                           f"maxima over {M} random points; the time is pr.simulate's per particle and step ({M} particles, "
                           f"{STEP_TIMING} steps); the "
                           f"trajectory error is Verlet at dt = {dt:g} to t = {t_end:g} ({N} particles) against DOP853 "
                           "on the analytic force."))
    results = {}
    for interp in interps:
        rows = []
        for n in sizes:
            s = surface(n, L, interp)
            scene = pr.Scene(s, dt=dt, n_steps=int(round(t_end / dt)))
            fld = scene.field()
            out = np.empty((M, 2))
            e_err = float(np.max(np.abs(pr.energy(pr.Scene(s, dt=1, n_steps=0),
                                                  pr.Trajectory(pts[None], np.zeros((1, M, 2)), None))[0] - U)))
            f_err = float(np.max(np.linalg.norm(force(fld, pts, out) - F, axis=1)))
            step_scene = pr.Scene(s, dt=1e-3, n_steps=STEP_TIMING)
            zeros = np.zeros_like(pts)
            t_force = wall_time(lambda: pr.simulate(step_scene, pts, zeros), repeat=2) / (M * STEP_TIMING)
            traj = pr.simulate(scene, x0, v0)
            x_err = float(np.max(np.linalg.norm(traj.x[-1] - x_true, axis=1)))
            rows.append((n, s.spacing[0], e_err, f_err, x_err, s.values.nbytes, t_force * 1e9))
        results[interp] = np.array(rows, dtype=float)
        frag.table(["n", "h", "max energy error", "max force error", "trajectory error", "memory (bytes)",
                    "simulate time per particle-step (ns)"], rows, caption=f"{interp}:")

    orders = {k: (fit_order(r[:, 1], r[:, 2]), fit_order(r[:, 1], r[:, 3]), fit_order(r[:, 1], r[:, 4]))
              for k, r in results.items()}
    frag.table(["interpolation", "energy order", "force order", "trajectory order"],
               [(k,) + v for k, v in orders.items()], caption="Fitted orders in h:")

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for k, r in results.items():
        axes[0].loglog(r[:, 1], r[:, 2], "o-", label=f"{k} energy")
        axes[0].loglog(r[:, 1], r[:, 3], "s-", label=f"{k} force")
        axes[0].loglog(r[:, 1], r[:, 4], "^--", label=f"{k} trajectory")
        axes[1].loglog(r[:, 5] / 1e3, r[:, 3], "s-", label=f"{k} force")
        axes[1].loglog(r[:, 5] / 1e3, r[:, 2], "o-", label=f"{k} energy")
    axes[0].set_xlabel("grid spacing h")
    axes[0].set_ylabel("max error")
    axes[0].legend(fontsize=7)
    axes[1].set_xlabel("grid memory (kB)")
    axes[1].set_ylabel("max error")
    axes[1].legend(fontsize=7)
    frag.figure(fig, topic, "surface error against grid spacing and memory")

    for k, (eo, fo, xo) in orders.items():
        r = results[k]
        frag.sentence(f"{k}: the energy error falls with order {eo:.2f} in h and the force error with order {fo:.2f} "
                      f"(from {r[0, 3]:.2e} at n = {int(r[0, 0])} to {r[-1, 3]:.2e} at n = {int(r[-1, 0])}); "
                      f"the trajectory error follows with order {xo:.2f}.")
        growth = r[-1, 6] / r[0, 6]
        how = ("about flat: a lookup whose cost does not depend on n" if growth < 2 else
               f"{growth:.0f}x more (a larger grid misses the cache more often, and any per-run setup that "
               "scales with n counts here too)")
        frag.sentence(f"{k}: memory grows as n^2 ({int(r[0, 5])} to {int(r[-1, 5])} bytes); the time per particle-step "
                      f"goes from {r[0, 6]:.0f} ns at n = {int(r[0, 0])} to {r[-1, 6]:.0f} ns at n = {int(r[-1, 0])}, "
                      f"{how}.")
    frag.write()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
