"""Time step: trajectory error of the paper's damped Verlet against a tight DOP853 solution.

A smooth analytic potential is sampled onto a torus grid; the reference is
``scipy.integrate.solve_ivp(method="DOP853", rtol=1e-12)`` of the SAME discrete force
(the grid's interpolation rule, spring, damping), so the error measured is the time
stepping's alone. Sweeps dt, fits the order, measures the energy error per unit time,
and sets it beside solve_ivp's own work-precision (error against wall time at several
tolerances). The accuracy options (``Scene(integrator="gjf")``,
``Surface(interpolation="bicubic")``) get their rows when the package has them.

Run: ``python validation/timestep.py [--smoke] [--out DIR]``.
"""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
from scipy.integrate import solve_ivp

from _common import (Fragment, analytic_potential, fit_order, option_available, parse_args, plt, topic_of,
                     wall_time)
import pes_ref as pr
from pes_ref.core.forces import force

#: The reference's tolerances: rtol 1e-12; atol far below any error measured.
REF_RTOL, REF_ATOL = 1e-12, 1e-14
#: solve_ivp's own work-precision points.
IVP_RTOLS = (1e-3, 1e-5, 1e-7, 1e-9)
DAMPING = 0.5


def make_scene(kind, interpolation, n_nodes, L, damping):
    """kind "grid": the analytic potential sampled on an n x n torus; "spring": a
    constant grid plus a spring (a smooth force: the integrator's own order)."""
    q = np.arange(n_nodes) * L / n_nodes
    if kind == "grid":
        values, spring = analytic_potential(q[:, None], q[None, :], L), None
    else:
        values, spring = np.zeros((n_nodes, n_nodes)), pr.Spring([1.0, 2.0], [0.5 * L, 0.5 * L])
    kw = {} if interpolation == "bilinear" else {"interpolation": interpolation}
    surf = pr.Surface(values, (0.0, 0.0), (L, L), (True, True), **kw)
    return pr.Scene(surf, dt=0.1, n_steps=1, spring=spring, damping=damping)


def reference(scene, x0, v0, t_end, rtol, atol):
    """solve_ivp DOP853 of m x'' = F(x) - gamma x' with the scene's own force function.

    Returns (final positions (N, 2), wall time in s)."""
    fld = scene.field()
    N = x0.shape[0]
    m = np.broadcast_to(scene.mass, (N, 2))
    g = np.zeros((N, 2)) if scene.damping is None else np.broadcast_to(scene.damping, (N, 2))
    out = np.empty((N, 2))

    def rhs(_t, y):
        x, v = y[: 2 * N].reshape(N, 2), y[2 * N:].reshape(N, 2)
        force(fld, x, out)
        return np.concatenate((v.ravel(), ((out - g * v) / m).ravel()))

    t0 = time.perf_counter()
    sol = solve_ivp(rhs, (0.0, t_end), np.concatenate((x0.ravel(), v0.ravel())), method="DOP853",
                    rtol=rtol, atol=atol)
    el = time.perf_counter() - t0
    if not sol.success:
        raise RuntimeError(f"solve_ivp failed: {sol.message}")
    return sol.y[: 2 * N, -1].reshape(N, 2), el


def sweep(scene, x0, v0, t_end, dts, x_ref, integrator):
    """Error at t_end, wall time and energy error per unit time for each dt."""
    rows = []
    for dt in dts:
        sc = replace(scene, dt=dt, n_steps=int(round(t_end / dt)))
        if integrator != "verlet":
            sc = replace(sc, integrator=integrator)
        traj = pr.simulate(sc, x0, v0)
        secs = wall_time(lambda: pr.simulate(sc, x0, v0), repeat=2)
        err = float(np.max(np.linalg.norm(traj.x[-1] - x_ref, axis=1)))
        drift = np.nan
        if scene.damping is None:
            E = pr.energy(sc, traj).sum(axis=1)
            drift = float(np.max(np.abs(E - E[0]))) / t_end
        rows.append((dt, err, secs, drift))
    return rows


def main(argv=None) -> int:
    args = parse_args(__doc__, argv)
    topic = topic_of(__file__)
    if args.smoke:
        n_nodes, N, t_end, dts, ivp_rtols, ref_rtol = 8, 2, 1.0, (0.1, 0.05, 0.025), IVP_RTOLS[:1], 1e-9
    else:
        n_nodes, N, t_end = 24, 4, 5.0
        dts, ivp_rtols, ref_rtol = tuple(0.2 / 2 ** k for k in range(7)), IVP_RTOLS, REF_RTOL
    L = 2 * np.pi
    rng = np.random.default_rng(0)
    x0 = rng.uniform(0, L, (N, 2))
    v0 = rng.uniform(-1.0, 1.0, (N, 2))

    variants = [("verlet", "bilinear")]
    if args.smoke:
        pass                      # the default step only: seconds, not minutes
    elif option_available("gjf"):
        variants.append(("gjf", "bilinear"))
    if not args.smoke and option_available("bicubic"):
        variants.append(("verlet", "bicubic"))
        if option_available("gjf"):
            variants.append(("gjf", "bicubic"))

    frag = Fragment(topic, "Time step: trajectory error against a DOP853 reference", args.out, intro=(
        f"{N} particles on a {n_nodes} x {n_nodes} torus over t = {t_end:g}; the reference is solve_ivp DOP853 "
        f"(rtol {ref_rtol:g}, atol {REF_ATOL:g}) of the same discrete force. Error: largest distance at "
        f"t = {t_end:g}. Orders are least-squares slopes of log error against log dt over dt = "
        f"{dts[0]:g} ... {dts[-1]:g}. Energy error per unit time: max |E_n - E_0| / t (undamped runs)."))

    summary, curves, ivp_curves, refs = [], {}, {}, {}
    for force_kind in ("spring", "grid"):
        for gamma in (None, DAMPING):
            for integ, interp in variants:
                if force_kind == "spring" and interp != "bilinear":
                    continue              # a constant grid: the interpolation plays no part
                scene = make_scene(force_kind, interp, n_nodes, L, gamma)
                key = (force_kind, gamma, interp)          # the reference does not depend on the integrator
                if key not in refs:
                    refs[key] = reference(scene, x0, v0, t_end, ref_rtol, REF_ATOL)
                x_ref, ref_secs = refs[key]
                rows = sweep(scene, x0, v0, t_end, dts, x_ref, integ)
                dt, err, secs, drift = (np.array(c) for c in zip(*rows))
                label = f"{force_kind}, {'gamma=0' if gamma is None else f'gamma={gamma:g}'}, {integ}, {interp}"
                order = fit_order(dt, err)
                drift_order = fit_order(dt, drift) if gamma is None else "n/a"
                summary.append((force_kind, "0" if gamma is None else f"{gamma:g}", integ, interp, order,
                                err[-1], secs[-1], drift[-1] if gamma is None else "n/a", drift_order, ref_secs))
                curves[label] = (secs, err)
                if integ == "verlet" and interp == "bilinear":
                    ivp = [reference(scene, x0, v0, t_end, r, r * 1e-3) for r in ivp_rtols]
                    ivp_err = [float(np.max(np.linalg.norm(x - x_ref, axis=1))) for x, _ in ivp]
                    ivp_curves[label] = (np.array([s for _, s in ivp]), np.array(ivp_err))
                    frag.table(["rtol", "error", "wall time (s)"],
                               [(r, e, s) for r, e, (_, s) in zip(ivp_rtols, ivp_err, ivp)],
                               caption=f"solve_ivp DOP853 work-precision, {label}:")

    frag.table(["force", "gamma", "integrator", "interpolation", "fitted order", f"error at dt={dts[-1]:g}",
                "wall time (s)", "energy error / time", "energy order", "reference time (s)"], summary,
               caption="Fitted orders (error against dt):")

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for ax, kind in zip(axes, ("spring", "grid")):
        for label, (s, e) in curves.items():
            if label.startswith(kind):
                ax.loglog(s, e, "o-", label=label.split(", ", 1)[1])
        for label, (s, e) in ivp_curves.items():
            if label.startswith(kind):
                ax.loglog(s, e, "s--", label="DOP853, " + label.split(", ")[1])
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel(f"position error at t = {t_end:g}")
        ax.set_title(f"{kind}: work-precision")
        ax.legend(fontsize=7)
    frag.figure(fig, topic, "work-precision: error against wall time")

    by = {(r[0], r[1], r[2], r[3]): r for r in summary}
    for key, r in by.items():
        force_kind, gamma, integ, interp, order = key + (r[4],)
        frag.sentence(f"{integ} on the {force_kind} force ({interp}, gamma = {gamma}) converges with fitted order "
                      f"{order:.2f}; at dt = {dts[-1]:g} its error is {r[5]:.2e}.")
    sm0, smg = by.get(("spring", "0", "verlet", "bilinear")), by.get(("spring", f"{DAMPING:g}", "verlet", "bilinear"))
    if sm0 and smg:
        frag.sentence(f"On a smooth force the paper's step is order {sm0[4]:.2f} undamped and {smg[4]:.2f} damped: "
                      "eq. (2) leaves the damping force out of the position update, which costs one order.")
    paper, best = by.get(("grid", f"{DAMPING:g}", "verlet", "bilinear")), by.get(("grid", f"{DAMPING:g}", "gjf", "bicubic"))
    if paper and best:
        frag.sentence(f"Buying the order back on the damped grid: GJF on a bicubic surface converges with order "
                      f"{best[4]:.2f} (the paper's step on the bilinear grid: {paper[4]:.2f}); at dt = {dts[-1]:g} its "
                      f"error is {best[5]:.2e} against {paper[5]:.2e} ({paper[5] / best[5]:.0f}x smaller) for "
                      f"{best[6] / paper[6]:.2f}x the wall time.")
    g0 = by.get(("grid", "0", "verlet", "bilinear"))
    if g0:
        frag.sentence(f"On the bilinear grid the force jumps at cell edges: the undamped error's order is "
                      f"{g0[4]:.2f} and the energy error per unit time falls with order {g0[8]:.2f} in dt.")
    for label, (s, e) in ivp_curves.items():
        vs, ve = curves[label]
        # the cheapest Verlet run at least as accurate as DOP853 at its loosest and tightest tolerances
        for j in (0, len(e) - 1):
            ok = ve <= e[j]
            verdict = (f"Verlet reaches it in {vs[ok].min():.3g} s" if ok.any()
                       else f"no Verlet step of the sweep reaches it (best {ve.min():.2e} in {vs[np.argmin(ve)]:.3g} s)")
            frag.sentence(f"{label}: DOP853 at rtol {ivp_rtols[j]:g} reaches error {e[j]:.2e} in {s[j]:.3g} s; "
                          f"{verdict}.")
    frag.write()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
