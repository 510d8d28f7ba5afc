"""The benchmark's targets (docs/performance.md): each with the measured number and whether it is met."""
from __future__ import annotations

__all__ = ["targets", "JAX_TARGETS", "RUN_TARGETS", "NOTHING_TARGET", "ZERO_AXIS_TARGET"]

#: The speed targets of the compiled loops and the populations (docs/performance.md):
#: (backend, design gradient, N, largest multiple of JAX's steady-state time, inclusive).
JAX_TARGETS = (("numba", 64, 0.5, True), ("numpy", 64, 1.8, True), ("numba", 4096, 1.0, False),
               ("numpy", 4096, 1.0, False), ("numba", 65536, 1.0, False), ("numpy", 65536, 1.0, False))
#: Seconds of the default oscillator design (``runs`` with no options) per backend.
RUN_TARGETS = {"numba": 45.0, "numpy": 70.0}
#: Largest multiple of the bare scene that a term with zero coefficients may cost (minimum
#: of the repeats), and largest ratio of the cylinder's spring k = (1, 0) to k = (1, 1)
#: (the zero axis's minimum image skipped).
NOTHING_TARGET, ZERO_AXIS_TARGET = 1.05, 0.95


def _compiled_targets(res: dict, add) -> None:
    """The targets of the compiled loops, the populations and the scenes that pay only for
    what they name."""
    for backend, n, goal, inclusive in JAX_TARGETS:
        row = next((r for r in res["design"] if r["case"] == "funnel" and r["N"] == n), None)
        name = f"funnel gradient N = {n}: {backend} / JAX steady"
        goal_text = f"{'<=' if inclusive else '<'} {goal:g}"
        if row is None or "over_jax_steady" not in row or backend not in row["over_jax_steady"]:
            add(name, None, goal_text, None)
            continue
        v = row["over_jax_steady"][backend]
        add(name, v, goal_text, v <= goal if inclusive else v < goal)
    for run in res.get("runs", []):
        if not run["options"] and run["backend"] in RUN_TARGETS:
            goal = RUN_TARGETS[run["backend"]]
            add(f"default oscillator design on {run['backend']} (s)", run["seconds"], f"<= {goal:g}",
                run["seconds"] <= goal)
    rows = res["effects"]["nothing"]
    for row in rows:
        if row["effect"] not in ("bare",) and not row["effect"].startswith("cylinder"):
            v = row["forward_min_over_bare"]
            add(f"{row['backend']}: {row['effect']} / bare", v, f"<= {NOTHING_TARGET:g}", v <= NOTHING_TARGET)
    for backend in dict.fromkeys(r["backend"] for r in rows):
        cyl = {r["effect"]: r["forward"]["min"] for r in rows if r["backend"] == backend}
        v = cyl["cylinder: spring k = (1, 0)"] / cyl["cylinder: spring k = (1, 1)"]
        add(f"{backend}: cylinder spring k = (1, 0) / (1, 1)", v, f"<= {ZERO_AXIS_TARGET:g}", v <= ZERO_AXIS_TARGET)
    from pes_ref.bench.every_gradient import target
    for row in res.get("every_gradient", []):
        for backend in row["seconds"]:
            goal = target(backend, row["n"])
            if goal is None:
                continue
            limit, strict = goal
            v = row["ratio"].get(backend)
            add(f"every gradient, run_case N = {row['n']}: {backend} / JAX", v, f"{'<' if strict else '<='} {limit:g}",
                None if v is None else (v < limit if strict else v <= limit))
    extra = sum(max(0, len(r["arrays"]) - r["needed"]) for r in res["memory"]["zero_filled"])
    add("trajectory-sized arrays filled, not needed", extra, "0", extra == 0)


def targets(res: dict) -> list:
    """The targets with the measured numbers: (name, measured, goal, met or None if not
    measured). First NumPy's loops' (the scaling, memory and effects of NumPy's
    loops); then `_compiled_targets`."""
    out = []

    def add(name, value, goal, met):
        out.append(dict(target=name, measured=value, goal=goal, met=met))

    sc = [r for r in res["scaling"] if r.get("backend", "numpy") == "numpy"]
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
    for row in res["design"][:1]:
        if "autograd_over_pes_ref" in row:
            v = row["autograd_over_pes_ref"]
            add("funnel gradient: autograd / pes_ref", v, ">= 20", v >= 20)
        else:
            add("funnel gradient: autograd / pes_ref", None, ">= 20", None)
    _compiled_targets(res, add)
    return out
