"""C-space speed: the C-space and surface of a 512 x 512 torus for two parts of about 150 vertices each.

The 4-slot Geneva drive of ``examples/devices/geneva4.toml`` (a crank with a pin and a
locking disc, a wheel with four slots and four locking arcs: both parts are mostly
circles), with its circles drawn at the tolerance that gives each part about ``VERTICES``
vertices, and at the file's own (finer) tolerance. For each, the best of ``REPEAT`` wall
times of ``Device.surface()`` from scratch, split into its steps (posing, the blocked
nodes, the boundary between them, the distance to it, eq. (1) and the springs), with the
CPU count and the load average at the start (the machine may be shared).

Run: ``python validation/cspace_speed.py [--smoke] [--out DIR]``.
"""
from __future__ import annotations

import os
import time

import numpy as np

from _common import ROOT, Fragment, parse_args, plt, topic_of
from pes_ref.devices.device_file import load_device

#: The vertices each part should have (the issue's "about 150").
VERTICES = 150
#: Timed runs per case (the best is reported).
REPEAT = 3


def vertices(device, tolerance) -> tuple:
    import shapely
    return tuple(int(shapely.get_num_coordinates(p.geometry(tolerance))) for p in device.parts)


def tolerance_for(device, target: int) -> float:
    """The circles' tolerance at which the larger part has about ``target`` vertices (bisection in log)."""
    lo, hi = 1e-7, 1e-1
    for _ in range(40):
        mid = np.sqrt(lo * hi)
        if max(vertices(device, mid)) > target:
            lo = mid
        else:
            hi = mid
    return float(hi)


def timed(device) -> dict:
    """Best-of-REPEAT seconds of each step of the surface, from scratch."""
    best = None
    for _ in range(REPEAT):
        d = device.replace()
        t = time.perf_counter()
        cs = d.cspace()
        t_cspace = time.perf_counter() - t
        t = time.perf_counter()
        d.surface()
        row = dict(cs.times, surface=time.perf_counter() - t)
        row["total"] = t_cspace + row["surface"]
        if best is None or row["total"] < best["total"]:
            best = row
    return best


def main(argv=None) -> int:
    args = parse_args(__doc__, argv)
    topic = topic_of(__file__)
    device = load_device(ROOT / "examples" / "devices" / "geneva4.toml")
    n = 64 if args.smoke else 512
    device = device.replace(shape=(n, n))
    device.replace(shape=(8, 8), r_min=0.01).cspace()  # imports (shapely, scipy) outside the timings
    load = os.getloadavg()[0]
    cases = [("~%d vertices" % VERTICES, tolerance_for(device, VERTICES)), ("the default tolerance", None)]
    rows = []
    for label, tol in cases:
        d = device.replace(tolerance=tol)
        nv = vertices(d, d.grid.tolerance)
        t = timed(d)
        rows.append([label, f"{nv[0]} + {nv[1]}", d.grid.tolerance, t["pose"], t["blocked"], t["boundary"],
                     t["distance"], t["surface"], t["total"]])
    frag = Fragment(topic, f"C-space speed: a {n} x {n} torus", args.out,
                    intro=(f"The Geneva drive's C-space and surface on a {n} x {n} torus, best of {REPEAT}, on "
                           f"{os.cpu_count()} CPUs at load average {load:.2f} (1 min) at the start."))
    frag.table(["circles", "vertices (crank + wheel)", "tolerance", "pose (s)", "blocked (s)", "boundary (s)",
                "distance (s)", "eq. (1) + springs (s)", "total (s)"], rows)
    steps = ["pose", "blocked", "boundary", "distance", "eq. (1) + springs"]
    fig, ax = plt.subplots(figsize=(7, 2.8))
    for k, row in enumerate(rows):
        left = 0.0
        for s, value in zip(steps, row[3:8]):
            ax.barh(k, value, left=left, label=s if k == 0 else None, color=f"C{steps.index(s)}")
            left += value
    ax.set_yticks(range(len(rows)), [f"{r[0]} ({r[1]})" for r in rows])
    ax.set_xlabel("seconds (best of %d)" % REPEAT)
    ax.legend(fontsize=7, ncol=5, loc="upper center", bbox_to_anchor=(0.5, 1.3))
    frag.figure(fig, topic, f"where the time of a {n} x {n} C-space goes")
    frag.sentence(f"With about {VERTICES} vertices per part the C-space and surface of {n} x {n} nodes take "
                  f"{rows[0][-1]:.3g} s; at the default tolerance ({rows[1][1]} vertices) {rows[1][-1]:.3g} s "
                  f"(load average {load:.2f} on {os.cpu_count()} CPUs).")
    frag.write()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
