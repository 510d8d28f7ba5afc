"""``make figures``: every figure of the paper, regenerated from scratch into ``figures/out/``.

Steps, each printed with its elapsed time as it starts, while it runs and when it ends:

1. the designs, computed by the project's own command (:data:`DESIGNS`): the funnel and the
   oscillator with the command's defaults (``python -m pes_ref design funnel|oscillator --out
   figures/out/cache/KIND.npz``), and the oscillator by gradient descent alone
   (``--plan overshoot``), which Fig. 12 draws beside the default, and the latch from its
   shipped problem file (``design latch``, Fig. 13), and the funnel designed realizable
   (``--set realizable=true``, Fig. 14) and the latch made of contact (``design latch_contact``,
   Fig. 15); their own progress lines are passed through. A design is reused from the cache only
   when its inputs are unchanged: the sidecar ``KIND.json`` holds a key hashing every
   source file of the ``pes_ref`` package, the command line, and the Python and NumPy
   versions, plus the SHA-256 of the design file; a file whose run did not finish
   (status other than ``done``) is never reused. ``--fresh`` ignores the cache.
2. one script per figure (``figures/figNN_*.py``, run as ``python -m figures.figNN_*``),
   each as soon as the design it needs exists.

Up to ``--jobs`` steps run at once (default: the CPU count), longest first, so on two
cores the oscillator design runs beside the funnel and the gradient-descent oscillator design and
then the figures. The time
of each step and the total are printed at the end and saved to ``OUT/timings.json``.
Exit status 0 when every step succeeded, 1 otherwise.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import subprocess
import sys
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
if ROOT not in sys.path:          # run as a script: the repository's pes_ref, as the steps use
    sys.path.insert(0, ROOT)
DEFAULT_OUT = os.path.join(HERE, "out")
#: Seconds between the design command's progress lines (display only; not part of the cache key).
PROGRESS_SECONDS = 15
#: The figure scripts, in the order they are started once ready, with the design each draws (``--design``).
FIGURES = (
    ("fig05_funnel_gradient", "funnel"),
    ("fig06_funnel_surface", "funnel"),
    ("fig07_funnel_paths", "funnel"),
    ("fig08_oscillator", "oscillator"),
    ("fig09_phase_torques", "oscillator"),
    ("fig10_grid_paths", "oscillator"),
    ("fig11_grid_cycles", "oscillator"),
    ("fig12_torque_capture", "oscillator"),
    ("fig13_latch", "latch"),
    ("fig14_realized_funnel", "funnel_realizable"),
    ("fig15_realized_latch", "latch_contact"),
    ("fig01_ratchet", None),
    ("fig02_dartgun", None),
    ("fig03_dartgun_cspace", None),
    ("fig04_dartgun_pes", None),
)
#: The designs by name, longest first (the oscillator dominates the run): the design command's arguments.
DESIGNS = {
    "oscillator": ["design", "oscillator"],
    "oscillator_overshoot": ["design", "oscillator", "--plan", "overshoot"],
    "latch": ["design", "latch"],
    "latch_contact": ["design", "latch_contact"],
    "funnel": ["design", "funnel"],
    "funnel_realizable": ["design", "funnel", "--set", "realizable=true", "--set", "linger=20",
                          "--set", "init_shape=vee"],
}
#: Further designs a figure draws: figure -> {option: design name}.
EXTRA_DESIGNS = {"fig12_torque_capture": {"--baseline": "oscillator_overshoot"}}


class Step:
    """One subprocess of the run: a design or a figure script."""

    def __init__(self, name, argv, needs=None, design=None):
        self.name, self.argv, self.design = name, argv, design
        self.needs = () if needs is None else (needs,) if isinstance(needs, str) else tuple(needs)
        self.status, self.seconds, self.started, self.proc, self.reader = "waiting", 0.0, None, None, None
        self.cpu = None          # CPU seconds (user + system) of the step's process


class Log:
    """Thread-safe progress lines ``[elapsed] step: text``."""

    def __init__(self):
        self.t0 = time.perf_counter()
        self.lock = threading.Lock()

    def elapsed(self) -> float:
        return time.perf_counter() - self.t0

    def __call__(self, name: str, text: str) -> None:
        e = self.elapsed()
        with self.lock:
            print(f"[{int(e) // 60:3d}:{e % 60:04.1f}] {name}: {text}", flush=True)


# =========================================================================== cache

def source_hash() -> str:
    """SHA-256 over the path and bytes of every source file of the pes_ref package (its Python
    files and the problem files it ships)."""
    h = hashlib.sha256()
    pkg = os.path.join(ROOT, "pes_ref")
    for folder, dirs, files in sorted(os.walk(pkg)):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        for f in sorted(files):
            if f.endswith((".py", ".toml")):

                path = os.path.join(folder, f)
                h.update(os.path.relpath(path, ROOT).encode() + b"\0")
                with open(path, "rb") as fh:
                    h.update(fh.read())
    return h.hexdigest()


def file_hash(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def cache_key(sources: str, command: list) -> str:
    import numpy
    blob = json.dumps({"sources": sources, "command": command, "python": platform.python_version(),
                       "numpy": numpy.__version__}, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()


def cache_valid(npz: str, sidecar: str, key: str) -> bool:
    """The cached design can be reused: same key, same file bytes, and its run finished."""
    if not (os.path.exists(npz) and os.path.exists(sidecar)):
        return False
    try:
        with open(sidecar) as fh:
            meta = json.load(fh)
        if meta.get("key") != key or meta.get("sha256") != file_hash(npz):
            return False
        from pes_ref.synthesis.engine.design_file import load_design
        return load_design(npz).status == "done"
    except (OSError, ValueError):
        return False


# =========================================================================== run

def design_steps(out: str, smoke: bool, fresh: bool, log: Log) -> list:
    cache = os.path.join(out, "cache")
    os.makedirs(cache, exist_ok=True)
    sources = source_hash()
    steps = []
    for name, args in DESIGNS.items():
        stem = f"{name}-smoke" if smoke else name
        npz, sidecar = os.path.join(cache, stem + ".npz"), os.path.join(cache, stem + ".json")
        command = args + (["--smoke"] if smoke else [])        # the command's own defaults
        key = cache_key(sources, command)
        step = Step(f"design {name}", [sys.executable, "-m", "pes_ref", *command, "--out", npz, "--force",
                                       "--progress", str(PROGRESS_SECONDS)], design=(name, npz, sidecar, key, command))
        if not fresh and cache_valid(npz, sidecar, key):
            with open(sidecar) as fh:
                took = json.load(fh).get("seconds", float("nan"))
            step.status = f"cached (computed in {took:.0f} s)"
            log(step.name, f"reusing {os.path.relpath(npz)}: inputs unchanged (key {key[:12]}), computed in {took:.1f} s")
        steps.append(step)
    return steps


def figure_steps(out: str, smoke: bool, designs: dict, only) -> list:
    steps = []
    for name, kind in FIGURES:
        if only and not any(name.startswith(o) for o in only):
            continue
        argv = [sys.executable, "-m", f"figures.{name}", "--out", out] + (["--smoke"] if smoke else [])
        needs = [kind] if kind is not None else []
        if kind is not None:
            argv += ["--design", designs[kind]]
        for option, design in EXTRA_DESIGNS.get(name, {}).items():
            argv += [option, designs[design]]
            needs.append(design)
        steps.append(Step(name, argv, needs=[f"design {d}" for d in needs]))
    return steps


def _pump(step: Step, log: Log) -> None:
    for line in step.proc.stdout:
        line = line.rstrip()
        if line:
            log(step.name, line)


def start(step: Step, log: Log) -> None:
    env = dict(os.environ, PYTHONUNBUFFERED="1", MPLBACKEND="Agg")
    env["PYTHONPATH"] = os.pathsep.join([ROOT] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
    log(step.name, "start: " + " ".join(os.path.relpath(a, ROOT) if os.path.isabs(a) and a.startswith(ROOT)
                                        else a for a in step.argv[1:]))
    step.started = log.elapsed()
    step.proc = subprocess.Popen(step.argv, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                 text=True, bufsize=1)
    step.reader = threading.Thread(target=_pump, args=(step, log), daemon=True)
    step.reader.start()
    step.status = "running"


def reap(step: Step):
    """The step's exit code if it has ended (else None); records its CPU seconds where the
    system reports them (``os.wait4``), which unlike wall time do not grow with the load."""
    if not hasattr(os, "wait4"):
        return step.proc.poll()
    pid, status, usage = os.wait4(step.proc.pid, os.WNOHANG)
    if pid == 0:
        return None
    step.proc.returncode = os.waitstatus_to_exitcode(status)
    step.cpu = usage.ru_utime + usage.ru_stime
    return step.proc.returncode


def finish(step: Step, code: int, log: Log) -> None:
    step.reader.join()
    step.seconds = log.elapsed() - step.started
    step.status = "done" if code == 0 else f"failed (exit {code})"
    if code == 0 and step.design is not None:
        kind, npz, sidecar, key, command = step.design
        from pes_ref.synthesis.engine.design_file import load_design
        state = load_design(npz)
        if state.status != "done":
            step.status = f"failed (design status {state.status!r})"
        else:
            with open(sidecar, "w") as fh:
                json.dump({"key": key, "sha256": file_hash(npz), "command": ["python", "-m", "pes_ref", *command],
                           "seconds": step.seconds, "iterations": state.iteration}, fh, indent=1)
    cpu = f" ({step.cpu:.1f} s CPU)" if step.cpu is not None else ""
    log(step.name, f"{step.status} in {step.seconds:.1f} s{cpu}")


def succeeded(step: Step) -> bool:
    return step.status == "done" or step.status.startswith("cached")


def schedule(steps: list, jobs: int, log: Log) -> None:
    by_name = {s.name: s for s in steps}
    running = []
    try:
        while True:
            for s in steps:
                if s.status != "waiting":
                    continue
                for name in s.needs:
                    need = by_name.get(name)
                    if need is not None and need.status not in ("waiting", "running") and not succeeded(need):
                        s.status = f"skipped ({name} {need.status})"
                        log(s.name, s.status)
                        break
            for s in steps:
                if len(running) >= jobs:
                    break
                needs = [by_name.get(name) for name in s.needs]
                if s.status == "waiting" and all(need is None or succeeded(need) for need in needs):
                    start(s, log)
                    running.append(s)
            if not running:
                break
            time.sleep(0.2)
            for s in list(running):
                code = reap(s)
                if code is not None:
                    finish(s, code, log)
                    running.remove(s)
    except KeyboardInterrupt:
        log("make_all", "interrupted; waiting for the running steps to stop")
        for s in running:
            s.proc.wait()
            s.status = "interrupted"
        raise


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default=DEFAULT_OUT, metavar="DIR", help="output folder (default figures/out)")
    p.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="steps run at once (default: CPU count)")
    p.add_argument("--fresh", action="store_true", help="recompute the designs even if the cache is valid")
    p.add_argument("--smoke", action="store_true", help="tiny designs and figures (a quick check of the pipeline)")
    p.add_argument("--only", default=None, metavar="fig01,fig05,...", help="run only these figures (and their designs)")
    args = p.parse_args(argv)
    if args.jobs < 1:
        p.error(f"--jobs must be >= 1, got {args.jobs}")
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    log = Log()
    only = args.only.split(",") if args.only else None
    dsteps = design_steps(out, args.smoke, args.fresh, log)
    figs = figure_steps(out, args.smoke, {s.design[0]: s.design[1] for s in dsteps}, only)
    needed = {name for f in figs for name in f.needs}
    steps = [d for d in dsteps if d.name in needed] + figs
    try:
        schedule(steps, args.jobs, log)
    except KeyboardInterrupt:
        return 130
    total = log.elapsed()
    width = max(len(s.name) for s in steps)
    cpu = lambda s: f"{s.cpu:8.1f}" if s.cpu is not None else f"{'-':>8}"  # noqa: E731
    print(f"\n{'step':<{width}}  {'wall s':>8}  {'CPU s':>8}  status")
    for s in steps:
        print(f"{s.name:<{width}}  {s.seconds:8.1f}  {cpu(s)}  {s.status}")
    cpu_total = sum(s.cpu for s in steps if s.cpu is not None)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"{'total':<{width}}  {total:8.1f}  {cpu_total:8.1f}  wall with --jobs {args.jobs} on {os.cpu_count()} "
          f"CPUs (load average at the end {load:.1f})")
    timings = {"total_seconds": total, "total_cpu_seconds": cpu_total, "jobs": args.jobs, "cpus": os.cpu_count(),
               "load_average_at_end": load, "smoke": args.smoke,
               "steps": {s.name: {"seconds": s.seconds, "cpu_seconds": s.cpu, "status": s.status,
                                  "started_at": s.started} for s in steps}}
    with open(os.path.join(out, "timings.json"), "w") as fh:
        json.dump(timings, fh, indent=1)
    print(f"wrote {os.path.join(out, 'timings.json')}")
    return 0 if all(succeeded(s) for s in steps) else 1


if __name__ == "__main__":
    sys.exit(main())
