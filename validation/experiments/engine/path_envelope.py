"""Prototype (issue 42 item 2): a realizable problem file's start made from the envelope of a
smooth design's passing paths, for any problem file, not only the funnel.

For a problem file with ``[surface.contact]`` (realizable off) and design seed S:

1. ``design PROBLEM --seed S``: the smooth design (default plan);
2. ``n`` held-out particles of it (``problem.run``, seed ``PATH_SEED``), of which those that pass
   every success test; their paths as line strings (whole, or with ``--truncate`` up to where
   they leave the domain: past an exit edge the paths spread), buffered by ``b`` (a multiple of
   r_c);
3. blocked = a box ``MARGIN`` beyond the domain less that buffered union, written as the
   problem file's ``[surface.contact] blocked`` shapes with ``realizable = true``;
4. (a) ``as-is``: the realizable design whose grid is the start's level set (the design file of
   (b) with its values replaced, so realize and evaluate read the same problem text);
   (b) ``planned``: ``design`` of that problem file from the start (its default plan);
   (c) ``refined``: steps 2-3 again on the paths that pass on the as-is start (eq. (1) of it);
5. ``evaluate`` (soft, held-out seed 12345), ``realize --as contact`` and ``evaluate --realized
   --engine both`` (``--clearance C``: the problem's ``[surface.contact] clearance``, the pin made C
   larger than its cut-out). The measurements: ``logs/path_envelope.txt``.

Run (from the worktree): nice -n 19 .venv/bin/python validation/experiments/engine/path_envelope.py
    PROBLEM.toml --out DIR --seeds 0 1 --buffers 1 2 [--set K=V ...]
Prints one row per (variant, buffer, seed).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

import numpy as np
import shapely
import tomli_w
import tomllib

PATH_SEED = 777
MARGIN = 0.5
PY = sys.executable


def run(args, log):
    t = time.time()
    out = subprocess.run([PY, "-m", "pes_ref", *args], capture_output=True, text=True)
    log.write(f"$ pes_ref {' '.join(args)}\n{out.stdout}{out.stderr}[{time.time() - t:.1f} s, rc {out.returncode}]\n")
    log.flush()
    if out.returncode:
        raise RuntimeError(f"pes_ref {args[0]} failed: {out.stderr.strip()[-400:]}")
    return out.stdout, time.time() - t


def figure(text, name):
    for line in text.splitlines():
        if line.startswith(name + ":"):
            return line.split(":", 1)[1].strip().split()[0]
    return "-"


def envelope_blocked(design_path, n, buffer, tol, truncate=False):
    """The blocked shapes (device-file dicts) of the start: the box beyond the domain less the
    buffered union of the passing paths; and the share of particles that passed."""
    from pes_ref.synthesis.engine.design_file import load_design
    state = load_design(design_path)
    problem = state.problem
    held = problem.run(state.values, PATH_SEED, n)
    passes = problem.batch_passes(held.traj)
    x = np.asarray(held.traj.x)                          # (T+1, N, 2)
    lo_d, hi_d = np.asarray(problem.lower), np.asarray(problem.upper)
    lines = []
    for i in np.nonzero(passes)[0]:
        path = x[:, i, :]
        if truncate:                    # up to the first state outside the domain (where it leaves it)
            out = np.nonzero(((path < lo_d) | (path > hi_d))[:, ~np.asarray(problem.periodic)].any(axis=1))[0]
            if out.size:
                path = path[:max(out[0] + 1, 2)]
        lines.append(shapely.simplify(shapely.LineString(path), tol))
    free = shapely.union_all(shapely.buffer(lines, buffer, quad_segs=4))
    lo, hi = np.asarray(problem.lower) - MARGIN, np.asarray(problem.upper) + MARGIN
    blocked = shapely.box(lo[0], lo[1], hi[0], hi[1]).difference(free)
    blocked = shapely.simplify(blocked, tol)
    polys = list(blocked.geoms) if hasattr(blocked, "geoms") else [blocked]
    shapes = []
    for p in polys:
        if p.is_empty or p.area < tol * tol:
            continue
        shape = {"polygon": [[round(a, 5), round(b, 5)] for a, b in p.exterior.coords[:-1]]}
        holes = [{"polygon": [[round(a, 5), round(b, 5)] for a, b in r.coords[:-1]]} for r in p.interiors]
        if holes:
            shape["minus"] = holes
        shapes.append(shape)
    return shapes, float(passes.mean())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("problem")
    ap.add_argument("--out", required=True)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    ap.add_argument("--buffers", type=float, nargs="+", default=[1.0, 2.0], help="buffer radii in units of r_c")
    ap.add_argument("--particles", type=int, default=200, help="particles whose passing paths make the envelope")
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("--rigid", action="store_true", help="also realize and run the parts in the rigid engine")
    ap.add_argument("--truncate", action="store_true", help="passing paths end where they leave the domain")
    ap.add_argument("--clearance", type=float, default=None, help="[surface.contact] clearance of the parts")
    ap.add_argument("--variants", nargs="+", default=["as-is", "planned"], help="as-is, planned, refined (needs as-is)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    log = open(os.path.join(a.out, "log.txt"), "a")
    with open(a.problem, "rb") as f:
        data = tomllib.load(f)
    contact = data["surface"]["contact"]
    if a.clearance is not None:
        contact["clearance"] = a.clearance
    r_c = contact["r_c"]
    sets = [x for s in a.set for x in ("--set", s)]
    smooth_toml = os.path.join(a.out, "smooth.toml")
    with open(smooth_toml, "wb") as f:
        tomli_w.dump(data, f)
    rows = []
    for seed in a.seeds:
        smooth = os.path.join(a.out, f"smooth_s{seed}.npz")
        t0 = time.time()
        if not os.path.exists(smooth):
            run(["design", smooth_toml, "--seed", str(seed), "--out", smooth, "--quiet", *sets], log)
        t_smooth = time.time() - t0
        ev, _ = run(["evaluate", smooth], log)
        rows.append(("smooth", "-", seed, figure(ev, "success_fraction"), "-", f"{t_smooth:.0f}"))
        print(*rows[-1], flush=True)
        from pes_ref.synthesis.engine.design_file import load_design
        h = float(np.min((np.asarray(load_design(smooth).problem.upper) - np.asarray(load_design(smooth).problem.lower))
                         / (np.asarray(load_design(smooth).problem.grid_shape) - 1)))
        for b in a.buffers:
            t0 = time.time()
            shapes, passed = envelope_blocked(smooth, a.particles, b * r_c, h / 2, a.truncate)
            t_env = time.time() - t0
            d = json.loads(json.dumps(data))
            d["surface"]["contact"] = {**contact, "realizable": True, "blocked": shapes}
            tag = f"b{b:g}_s{seed}"
            toml = os.path.join(a.out, f"env_{tag}.toml")
            with open(toml, "wb") as f:
                tomli_w.dump(d, f)
            designs = {}
            notes = {}
            if "planned" in a.variants:
                planned = os.path.join(a.out, f"planned_{tag}.npz")
                t0 = time.time()
                if not os.path.exists(planned):
                    run(["design", toml, "--seed", str(seed), "--out", planned, "--quiet", *sets], log)
                designs["planned"] = (planned, t_env + t_smooth + time.time() - t0)
            if "as-is" in a.variants:
                from pes_ref.synthesis.engine.design_file import save_design
                from pes_ref.synthesis.problem.problem_file import load_problem
                state = load_design(smooth)                 # the smooth run's record, the start's problem and grid
                state.problem = load_problem(toml)
                state.values = state.problem.initial_values(np.random.default_rng(0), state.problem.shape())
                asis = os.path.join(a.out, f"asis_{tag}.npz")
                save_design(asis, state, overwrite=True)
                designs["as-is"] = (asis, t_env + t_smooth)
            if "refined" in a.variants:        # the envelope again, of the paths that pass on the as-is start
                t0 = time.time()
                shapes2, passed2 = envelope_blocked(asis, a.particles, b * r_c, h / 2, a.truncate)
                d2 = json.loads(json.dumps(data))
                d2["surface"]["contact"] = {**contact, "realizable": True, "blocked": shapes2}
                toml2 = os.path.join(a.out, f"refined_{tag}.toml")
                with open(toml2, "wb") as f:
                    tomli_w.dump(d2, f)
                state = load_design(smooth)
                state.problem = load_problem(toml2)
                state.values = state.problem.initial_values(np.random.default_rng(0), state.problem.shape())
                refined = os.path.join(a.out, f"refined_{tag}.npz")
                save_design(refined, state, overwrite=True)
                designs["refined"] = (refined, t_env + t_smooth + time.time() - t0)
                notes["refined"] = f"passed {passed2:.2f}, {len(shapes2)} shapes"
            for variant in [v for v in ("as-is", "refined", "planned") if v in a.variants]:
                path, secs = designs[variant]
                ev, _ = run(["evaluate", path], log)
                rigid = "-"
                if a.rigid:
                    dev = path[:-4] + "_parts"
                    run(["realize", path, "--as", "contact", "--out", dev, "--force"], log)
                    evr, _ = run(["evaluate", path, "--realized", os.path.join(dev, "device.toml"), "--engine",
                                  "both", "--force"], log)
                    rigid = f"{figure(evr, 'realized_success_fraction')}/{figure(evr, 'rigid_success_fraction')}"
                rows.append((variant, f"{b:g} r_c", seed, figure(ev, "success_fraction"), rigid, f"{secs:.0f}",
                             notes.get(variant, f"passed {passed:.2f}, {len(shapes)} shapes")))
                print(*rows[-1], flush=True)
    log.close()


if __name__ == "__main__":
    main()
