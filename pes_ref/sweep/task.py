"""One run of a sweep, as one task on a worker: design, then evaluate on each held-out seed.

[`run_task`][pes_ref.sweep.task.run_task] takes the plain data of
[`pes_ref.sweep.spec.Run.payload`][pes_ref.sweep.spec.Run.payload] and returns a small dict (status,
figures, wall time, worker, the design file's path), never trajectories or grids. The design file,
written by the project's atomic writer
([`pes_ref.synthesis.engine.design_file.save_design`][pes_ref.synthesis.engine.design_file.save_design])
every `CHECKPOINT_SECONDS` and at the end, is the run's checkpoint: a task that finds it resumes
from it (a finished design is only evaluated again).

A task never raises: an exception, a design that goes non-finite or figures it cannot
compute come back as ``status = "failed"`` with the error text. [`request_stop`][pes_ref.sweep.task.request_stop]
(run on every worker by the sweep on Ctrl-C) makes the running tasks save and come
back as ``"interrupted"`` after their current iteration.
"""
from __future__ import annotations

import os
import time

from pes_ref.synthesis import evaluate_seeds, load_design, problem_from_text, run_stages, save_design, start_design
from pes_ref.sweep.options import run_inputs

__all__ = ["run_task", "request_stop", "CHECKPOINT_SECONDS", "STOP_POLL_SECONDS"]

#: Seconds of design between two checkpoints (at most this much work is lost to a dead worker).
CHECKPOINT_SECONDS = 5.0
#: Seconds between two looks at the stop request.
STOP_POLL_SECONDS = 0.5

#: Sweeps (their tokens) asked to stop, in this worker process.
_STOP_REQUESTS: set = set()


class _Stopped(Exception):
    """Raised from the design loop's callback when this task's sweep is asked to stop."""


def request_stop(token: str) -> None:
    """Ask this process's running tasks of sweep ``token`` to save and return (run on every worker)."""
    _STOP_REQUESTS.add(token)


def run_task(payload: dict) -> dict:
    """Design (or resume) one run, evaluate it on each held-out seed; never raises.

    Returns
    -------
    dict
        ``id``, ``status`` (``"ok"``, ``"failed"``, ``"interrupted"``), ``error`` (text,
        empty when ok), ``figures`` (held-out seed -> figure name -> float), ``from_iteration``
        (where this attempt started: > 0 when it resumed a design file), ``iterations``
        (where it ended), ``wall_s`` (this attempt), ``worker`` (address) and ``design_file``.
    """
    start = time.perf_counter()
    out = {"id": payload["id"], "status": "ok", "error": "", "figures": {}, "iterations": 0,
           "worker": _worker_address(), "design_file": os.path.abspath(payload["design_file"])}
    try:
        state = _design(payload, out)
        if state is not None:
            out["figures"] = evaluate_seeds(state.problem, state.values, payload["eval_seeds"],
                                            payload["eval_particles"])
    except Exception as exc:        # any failure is a result of the run, reported with its error
        out.update(status="failed", error=" ".join(f"{type(exc).__name__}: {exc}".split()))
    out["wall_s"] = time.perf_counter() - start
    return out


def _design(payload: dict, out: dict):
    """Run the design to its plan's end; the state to evaluate, or None if stopped or non-finite."""
    kind, options, path = payload["kind"], payload["options"], payload["design_file"]
    token = payload.get("token")
    if token in _STOP_REQUESTS:                        # the sweep stopped before this run began
        out.update(status="interrupted", error="not started: the sweep was stopped")
        return None
    text = payload.get("problem_text")
    base = None if text is None else problem_from_text(text, payload["problem_path"])   # a problem file's run
    inputs = run_inputs(kind, options, base)
    plan = inputs.plan()
    saved = load_design(path) if os.path.exists(path) else None       # this run's checkpoint, if any
    state = start_design(inputs, seed=payload["seed"], backend=options.get("backend"), resume=saved, where=path,
                         exact=True)

    out["from_iteration"] = state.iteration
    if state.iteration >= plan.iterations and state.status == "done":
        out["iterations"] = state.iteration
        return state                                   # finished earlier: evaluate only
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)

    def check_stop(_progress):
        if token in _STOP_REQUESTS:
            raise _Stopped

    def checkpoint(s):
        save_design(path, s, overwrite=True)

    try:
        state = run_stages(state, plan.iterations, callback=check_stop, progress_every=STOP_POLL_SECONDS,
                           checkpoint=checkpoint, checkpoint_every=CHECKPOINT_SECONDS)
    except _Stopped:                 # raised between iterations: the state is whole
        if state.status == "running":
            state.status = "interrupted"
    save_design(path, state, overwrite=True)
    out["iterations"] = state.iteration
    if state.status == "interrupted":
        out.update(status="interrupted", error=f"stopped at iteration {state.iteration}")
        return None
    if state.status != "done":
        out.update(status="failed", error=state.status)
        return None
    return state


def _worker_address() -> str:
    """This worker's address, or ``"local"`` outside a Dask worker."""
    try:
        from distributed import get_worker
        return get_worker().address
    except (ImportError, ValueError):
        return "local"
