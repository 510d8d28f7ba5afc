"""The benchmark's report: its results as human-readable tables."""
from __future__ import annotations

__all__ = ["format_report"]


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
         f"load {res['machine']['load_average']}  numpy {res['versions']['numpy']}  "
         f"numba {res['versions'].get('numba')}", ""]
    L.append(f"Scaling on a {res['config']['grid']}x{res['config']['grid']} grid: us per step, median [min-max] "
             f"of {res['config']['repeats']} runs")
    L.append(f"{'backend':7s} {'mode':11s} {'N':>6s} {'T':>5s} {'forward':>26s} {'adjoint':>26s} {'fwd+adj':>26s} "
             f"{'fwd p-s/s':>10s} {'f+a p-s/s':>10s} {'adj/fwd':>7s}")
    for r in res["scaling"]:
        L.append(f"{r.get('backend', 'numpy'):7s} {r['mode']:11s} {r['N']:6d} {r['T']:5d} "
                 f"{_fmt_t(r['forward']):>26s} {_fmt_t(r['adjoint']):>26s} "
                 f"{_fmt_t(r['forward_adjoint']):>26s} {r['forward_particle_steps_per_s']:10.3g} "
                 f"{r['forward_adjoint_particle_steps_per_s']:10.3g} {r['adjoint_over_forward']:7.2f}")
    m = res["memory"]
    L += ["", f"Memory (value_and_grad, N={m['N']}, T={m['T']}): peak {m['peak_bytes'] / 2**20:.1f} MiB, trajectory "
          f"{m['trajectory_bytes'] / 2**20:.1f} MiB + grid {m['grid_bytes'] / 2**20:.2f} MiB -> "
          f"ratio {m['peak_over_trajectory_plus_grid']:.2f}"
          + "".join(f"; {b}: {v:.2f}" for b, v in m.get("by_backend", {}).items() if b != "numpy"),
          "Arrays of a trajectory's size made filled (zeros, ones, full) per run, and how many must be "
          "(their entries stay 0):"]
    for r in m.get("zero_filled", []):
        flag = "" if len(r["arrays"]) <= r["needed"] else "   <- more than needed"
        L.append(f"  {r['backend']:6s} {r['mode']:11s} {r['call']:15s} {len(r['arrays'])} ({', '.join(r['arrays']) or '-'})"
                 f", needed {r['needed']}{flag}")
    e = res["effects"]
    header = f"{'effect':28s} {'forward':>26s} {'x bare':>7s} {'fwd+adj':>26s} {'x bare':>7s}"

    def effect_lines(rows, mins=False):
        for r in rows:
            a, b = ("forward_min_over_bare", "forward_adjoint_min_over_bare") if mins else \
                ("forward_over_bare", "forward_adjoint_over_bare")
            yield (f"{r['effect']:28s} {_fmt_t(r['forward']):>26s} {r[a]:7.2f} "
                   f"{_fmt_t(r['forward_adjoint']):>26s} {r[b]:7.2f}")
    L += ["", f"Effects (dynamic, N={e['N']}, T={e['T']}): us per step; loop written for the bare scene alone: "
          f"{_fmt_t(e['hand_loop_forward'])}; bare / that loop = {e['bare_over_hand_loop']:.3f}",
          "numpy:", header, *effect_lines(e["rows"])]
    for backend, rows in e.get("other_backends", {}).items():
        L += [f"{backend}:", header, *effect_lines(rows)]
    if e.get("nothing"):
        L += ["", "Named with zero coefficients (must cost what the bare scene costs), and a cylinder's spring with "
                  "a zero q1 axis (must cost less than k = (1, 1)): CPU time, x bare from the minima of the repeats"]
        for backend in dict.fromkeys(r["backend"] for r in e["nothing"]):
            L += [f"{backend}:", header, *effect_lines([r for r in e["nothing"] if r["backend"] == backend], True)]
    x = res["exponents"]
    L += ["", f"Exponents (fwd+adj): time ~ N^{x['N']['exponent']:.2f} (N = {x['N']['sizes']}, T = {x['N']['T']}), "
          f"~ T^{x['T']['exponent']:.2f} (T = {x['T']['steps']}, N = {x['T']['N']})"]
    L += ["", "Design gradients (ms, median [min-max]); autodiff versions checked against pes_ref first"]
    for r in res["design"]:
        L.append(f"  {r['case']} ({r['grid'][0]}x{r['grid'][1]}, N={r['N']}, T={r['T']}):")
        for backend, t in r.get("backends", {"numpy": r["pes_ref"]}).items():
            ratio = r.get("over_jax_steady", {}).get(backend)
            L.append(f"    {backend:8s} {_fmt_t(t, 1e3)}" + ("" if ratio is None else f"  (/ JAX steady = {ratio:.2f})"))
        for lib in ("autograd", "jax"):
            d = r[lib]
            if d["status"] != "ok":
                L.append(f"    {lib:8s} {d['status']}: {d.get('reason', '')}{d.get('relative_error', '')}")
                continue
            extra = f", compile {d['compile_s']:.2f} s, first call {d['first_call_s']:.2f} s" if lib == "jax" else ""
            L.append(f"    {lib:8s} {_fmt_t(d['steady'], 1e3)}  (rel. err {d['relative_error']:.1e}{extra})")
        if "autograd_over_pes_ref" in r:
            L.append(f"    autograd / numpy = {r['autograd_over_pes_ref']:.1f}")
    if res.get("every_gradient"):
        from pes_ref.bench.every_gradient import format_rows
        L += ["", format_rows(res["every_gradient"])]
    if res.get("runs"):
        L += ["", "Design runs: the oscillator design, gradient stage then polish"
                  + (f" (options {res['runs'][0]['options']})" if res["runs"][0]["options"] else " (the default)")]
        for r in res["runs"]:
            L.append(f"  {r['backend']:8s} {r['seconds']:7.1f} s  ({r['cpu_seconds']:.1f} s CPU), {r['status']}")
    L += ["", "Targets (docs/performance.md)"]
    for t in res["targets"]:
        status = {True: "met", False: "NOT met", None: "not measured"}[t["met"]]
        L.append(f"  {t['target']:52s} {_fmt_v(t['measured']):>10s}  goal {t['goal']:8s} {status}")
    L.append(f"\n(total {res['seconds']:.0f} s)")
    return "\n".join(L)
