#!/usr/bin/env python3
"""Run pes_jax.py on every shipped conformance vector and compare with the shipped results.

    python compare.py [--vectors DIR] [--separate] [--python PY] [--keep DIR] [--only ID ...]

Valid vectors: the result must have exactly the reference's keys and shapes, and each
array must pass ``|got - want| <= atol + rtol |want|`` entrywise, with the tolerances of
pes_ref/oracle/tolerances.py (read from the file, pes_ref is not imported):
trajectory keys (x, v, energy, loss) TRAJ_RTOL with the floor TRAJ_ATOL; gradients
GRAD_RTOL with the floor GRAD_ATOL * max|want| (1 for an all-zero gradient). The number
shown per array is ``max |got - want| / (atol/rtol + |want|)`` (passes when <= rtol). On
vectors flagged ``kink`` each gradient entry may instead match the same entry of a file
the manifest lists under ``one_sided`` (its other one-sided values, docs/spec.md 2.5); a
kink vector that lists none (sets v1, v2) binds only x, v, energy and loss.

Invalid vectors: the program must exit non-zero, print one ``error:`` line naming the
manifest's key (any line where the manifest's key is null: a file that is no .npz), and
write no result file.

By default all valid vectors run in one process and all invalid ones in another
(pes_jax.py takes several CASE RESULT pairs); ``--separate`` runs one process per
vector, as a harness calling the program once per case would.

Prints one line per vector and a closing ``N passed, M failed``; exit status 1 on any failure.
"""
from __future__ import annotations

import argparse
import ast
import json
import os
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.abspath(os.path.join(HERE, "..", ".."))
PROGRAM = os.path.join(HERE, "pes_jax.py")
TRAJECTORY_KEYS = ("x", "v", "energy", "loss")
NAMES = ("TRAJ_RTOL", "TRAJ_ATOL", "GRAD_RTOL", "GRAD_ATOL")


def find_vectors() -> str:
    """The latest shipped vector set: the highest-numbered folder ``v<k>`` with a manifest."""
    root = os.path.join(REPO, "pes_ref", "oracle", "conformance")
    if os.path.isdir(root):
        sets = [(int(name[1:]), os.path.join(root, name)) for name in os.listdir(root)
                if re.fullmatch(r"v[0-9]+", name) and os.path.isfile(os.path.join(root, name, "manifest.json"))]
        if sets:
            return max(sets)[1]
    sys.exit("compare.py: cannot find the conformance vectors; pass --vectors DIR")


def read_tolerances(manifest: dict) -> tuple:
    """The constants of pes_ref/oracle/tolerances.py, parsed (not imported); else the
    manifest's record of them."""
    rel = "pes_ref/oracle/tolerances.py"
    path = os.path.join(REPO, rel)
    if os.path.isfile(path):
        found = {}
        for node in ast.parse(open(path).read()).body:
            if isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant):
                for t in node.targets:
                    if isinstance(t, ast.Name) and t.id in NAMES:
                        found[t.id] = float(node.value.value)
        if all(n in found for n in NAMES):
            return tuple(found[n] for n in NAMES), rel
    tol = manifest["tolerances"]
    return tuple(float(tol[n]) for n in NAMES), "manifest.json"


def normalized_error(got, want, rtol, atol) -> float:
    """max |got - want| / (atol/rtol + |want|); passes when <= rtol. inf if not comparable."""
    got, want = np.asarray(got, dtype=np.float64), np.asarray(want, dtype=np.float64)
    if got.shape != want.shape or not np.all(np.isfinite(got)):
        return float("inf")
    if got.size == 0:
        return 0.0
    return float(np.max(np.abs(got - want) / (atol / rtol + np.abs(want))))


def compare(got: dict, want: dict, tols: tuple, kink: bool, others=None):
    """(ok, {key: normalized error}, problems). ``others``: on a kink vector, the other
    one-sided results it accepts (None: its gradients do not bind)."""
    traj_rtol, traj_atol, grad_rtol, grad_atol = tols
    errors, problems, ok = {}, [], True
    for k in sorted(set(got) ^ set(want)):
        problems.append(f"{'missing' if k in want else 'extra'} key {k}")
        ok = False
    for k in want:
        if k not in got:
            continue
        w = want[k]
        if k in TRAJECTORY_KEYS:
            rtol, atol, binding = traj_rtol, traj_atol, True
        else:
            scale = float(np.max(np.abs(w))) if w.size and np.any(w) else 1.0
            rtol, atol, binding = grad_rtol, grad_atol * scale, not kink or others is not None
        if got[k].shape != w.shape:
            problems.append(f"{k} shape {got[k].shape} != {w.shape}")
        e = normalized_error(got[k], w, rtol, atol)
        alternatives = [o[k] for o in (others or ()) if k in o and o[k].shape == w.shape == got[k].shape]
        if alternatives and np.all(np.isfinite(got[k])):
            g = np.asarray(got[k], dtype=np.float64)
            per_entry = np.abs(g - w) / (atol / rtol + np.abs(w))
            for o in alternatives:
                o_scale = float(np.max(np.abs(o))) if o.size and np.any(o) else 1.0
                per_entry = np.minimum(per_entry, np.abs(g - o) / (grad_atol * o_scale / rtol + np.abs(o)))
            e = float(np.max(per_entry, initial=0.0))
        errors[k] = e
        if e > rtol and binding:
            ok = False
            problems.append(f"{k} {e:.2e} > {rtol:g}")
    return ok, errors, problems


def run_program(py: str, pairs: list) -> tuple:
    cmd = [py, PROGRAM] + [p for pair in pairs for p in pair]
    r = subprocess.run(cmd, capture_output=True, text=True)
    return r.returncode, r.stderr


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--vectors", default=None, help="folder with manifest.json (default: the latest shipped set)")
    ap.add_argument("--python", default=sys.executable, help="the Python that has jax (default: this one)")
    ap.add_argument("--separate", action="store_true", help="one process per vector")
    ap.add_argument("--keep", default=None, help="write the results here instead of a temporary folder")
    ap.add_argument("--only", nargs="*", default=None, help="vector ids to run")
    args = ap.parse_args()
    vdir = args.vectors or find_vectors()
    manifest = json.load(open(os.path.join(vdir, "manifest.json")))
    tols, tol_source = read_tolerances(manifest)
    vectors = [v for v in manifest["vectors"] if args.only is None or v["id"] in args.only]
    out_dir = args.keep or tempfile.mkdtemp(prefix="pes_jax_compare.")
    os.makedirs(out_dir, exist_ok=True)
    print(f"vectors {vdir} ({len(vectors)}); tolerances from {tol_source}: "
          + ", ".join(f"{n}={t:g}" for n, t in zip(NAMES, tols)))
    t_start = time.perf_counter()

    def res_path(v):
        return os.path.join(out_dir, v["id"] + ".result.npz")

    for v in vectors:
        if os.path.exists(res_path(v)):
            os.unlink(res_path(v))
    valid = [v for v in vectors if v["kind"] == "valid"]
    invalid = [v for v in vectors if v["kind"] != "valid"]
    status, stderr = {}, {}
    if args.separate:
        for v in vectors:
            status[v["id"]], stderr[v["id"]] = run_program(args.python, [(os.path.join(vdir, v["case"]), res_path(v))])
    else:
        for group in (valid, invalid):
            if group:
                rc, err = run_program(args.python, [(os.path.join(vdir, v["case"]), res_path(v)) for v in group])
                for v in group:
                    status[v["id"]] = rc
                    stderr[v["id"]] = err

    passed = failed = 0
    worst = {"traj": (0.0, ""), "grad": (0.0, ""), "kink-grad": (0.0, "")}
    for v in vectors:
        vid, case = v["id"], os.path.join(vdir, v["case"])
        if v["kind"] == "valid":
            if not os.path.exists(res_path(v)):
                lines = [ln for ln in stderr[vid].splitlines() if not args.separate and case in ln] or stderr[vid].splitlines()[-1:]
                ok, info = False, "no result written: " + (lines[0] if lines else f"exit {status[vid]}")
            else:
                got = dict(np.load(res_path(v), allow_pickle=False))
                want = dict(np.load(os.path.join(vdir, v["result"]), allow_pickle=False))
                kink = "kink" in v.get("flags", [])
                others = ([dict(np.load(os.path.join(vdir, f), allow_pickle=False)) for f in v["one_sided"]]
                          if "one_sided" in v else None)
                ok, errs, problems = compare(got, want, tols, kink, others)
                if args.separate and status[vid] != 0:
                    ok = False
                    problems.append(f"exit status {status[vid]}")
                tr = max(((e, k) for k, e in errs.items() if k in TRAJECTORY_KEYS), default=(0.0, "-"))
                gr = max(((e, k) for k, e in errs.items() if k not in TRAJECTORY_KEYS), default=(0.0, "-"))
                slot = "kink-grad" if kink and others is None else "grad"
                if tr[0] >= worst["traj"][0]:
                    worst["traj"] = (tr[0], f"{vid} {tr[1]}")
                if gr[0] >= worst[slot][0]:
                    worst[slot] = (gr[0], f"{vid} {gr[1]}")
                info = (f"traj {tr[0]:.1e} ({tr[1]})  grad {gr[0]:.1e} ({gr[1]})"
                        + ("  [kink: gradients not binding]" if kink and others is None else "")
                        + ("  " + "; ".join(problems) if problems else ""))
        else:
            if args.separate:
                lines = [ln for ln in stderr[vid].splitlines() if ln.strip()]
                line = lines[0] if len(lines) == 1 else None
            else:
                lines = [ln for ln in stderr[vid].splitlines() if ln.startswith(f"error: {case}: ")]
                line = lines[0] if len(lines) == 1 else None
            problems = []
            if status[vid] == 0:
                problems.append("exit status 0")
            if line is None:
                problems.append(f"expected one error line, got {len(lines)}")
            elif v["key"] is not None and f"'{v['key']}'" not in line:
                problems.append(f"message does not name key {v['key']!r}")
            if os.path.exists(res_path(v)):
                problems.append("a result file was written")
            ok = not problems
            info = (line.split(": ", 2)[-1] if (line and not args.separate) else (line or "")) if ok else "; ".join(problems)
        passed += ok
        failed += not ok
        print(f"{'PASS' if ok else 'FAIL'} {v['tc_id']:3d} {vid:34s} {v['kind']:7s} {info}")
    elapsed = time.perf_counter() - t_start
    print(f"worst binding trajectory error {worst['traj'][0]:.2e} ({worst['traj'][1]}); "
          f"worst binding gradient error {worst['grad'][0]:.2e} ({worst['grad'][1]}); "
          f"worst kink-vector gradient error (not binding) {worst['kink-grad'][0]:.2e} ({worst['kink-grad'][1]})")
    print(f"run time {elapsed:.1f} s ({'one process per vector' if args.separate else 'two processes'})")
    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
