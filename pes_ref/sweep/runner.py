"""Running a sweep on a Dask client: one task per run, retries, resume, interruption.

[`run_sweep`][pes_ref.sweep.runner.run_sweep] submits every run not finished earlier (``results.csv`` says which,
[`pes_ref.sweep.results.is_finished`][pes_ref.sweep.results.is_finished]) as one task
([`pes_ref.sweep.task.run_task`][pes_ref.sweep.task.run_task]),
collects the outcomes as they come, and rewrites ``results.csv`` after each. A run that
fails (an exception, a design that goes non-finite, a worker that dies under it) is
recorded with its error and submitted once more, on another worker when there is one;
its second outcome is final. Every run ends in the table, so the sweep always finishes.

Ctrl-C (`KeyboardInterrupt`) asks the running tasks to save their design and
return ([`pes_ref.sweep.task.request_stop`][pes_ref.sweep.task.request_stop] on every worker), waits up to
``stop_grace`` seconds for them, records them as ``interrupted`` and the runs not
started as ``pending``; run the same sweep again to resume (a second Ctrl-C stops at once).
"""
from __future__ import annotations

import collections
import os
import time
import uuid
from dataclasses import dataclass, field
from typing import Callable

from pes_ref.core.runtime.progress import Clock, Progress
from pes_ref.sweep import results
from pes_ref.sweep.task import request_stop, run_task

__all__ = ["run_sweep", "SweepReport", "RUNS_FOLDER"]

#: Design files go to ``DIR/runs/<run id>.npz``.
RUNS_FOLDER = "runs"
#: ``results.csv`` is rewritten after the outcomes that arrive, at most once per this many seconds
#: (and at the end): a client killed outright loses at most that much of the table, and the runs
#: lost from it only evaluate again next time, their designs being finished.
WRITE_EVERY = 1.0
#: Seconds the cluster's thread count is trusted before it is asked again.
THREADS_EVERY = 1.0


@dataclass
class SweepReport:
    """How a sweep went: its rows (one per run, in the file's order) and what was run."""

    rows: list
    skipped: list                    #: ids of runs finished earlier, not run again
    submitted: list                  #: ids of runs submitted this time (each once, retries apart)
    retried: list                    #: ids of runs submitted a second time
    interrupted: bool
    elapsed: float
    csv_path: str = ""
    plot_path: str = ""
    counts: dict = field(default_factory=dict)


def run_sweep(sweep, out_dir, client, *, task: Callable = run_task, progress: Callable | None = None,
              progress_every: float = 2.0, stop_grace: float = 60.0, plot: bool = True) -> SweepReport:
    """Run ``sweep`` ([`pes_ref.sweep.spec.Sweep`][pes_ref.sweep.spec.Sweep]) on ``client``; results into ``out_dir``.

    Parameters
    ----------
    sweep : Sweep
    out_dir : path
        Gets ``results.csv``, ``summary.png`` and ``runs/<run id>.npz`` (the design files).
    client : distributed.Client
    task : callable
        ``payload -> outcome dict``, [`pes_ref.sweep.task.run_task`][pes_ref.sweep.task.run_task] (replaceable for
        tests).
    progress : callable, optional
        Called with a
        [`pes_ref.core.runtime.progress.Progress`][pes_ref.core.runtime.progress.Progress] every
        ``progress_every`` seconds and at the end: ``done`` counts the runs ok (this time or
        earlier) out of all, its figures ``running`` (executing on a worker now) and ``failed``
        (failed twice); the time left is this session's pace (``inf`` before a run ends).
    stop_grace : float
        Seconds to wait on Ctrl-C for the running tasks to save and return.
    plot : bool
        Draw ``summary.png`` at the end.
    """
    return _Sweeper(sweep, os.fspath(out_dir), client, task, progress, progress_every, stop_grace).run(plot)


class _Sweeper:
    def __init__(self, sweep, out_dir, client, task, progress, progress_every, stop_grace):
        self.sweep, self.out_dir, self.client, self.task = sweep, out_dir, client, task
        self.progress, self.progress_every, self.stop_grace = progress, progress_every, stop_grace
        self.csv_path = os.path.join(out_dir, results.CSV_NAME)
        self.token = uuid.uuid4().hex[:12]
        self.runs = {run.id: run for run in sweep.runs}
        self.rows, self.attempts, self.failures = {}, {}, {}
        self.pending = {}             # future -> run id
        self.queue = collections.deque()   # (run, worker to avoid) not submitted yet
        self.submitted, self.retried, self.skipped = [], [], []
        self.finished_now = 0
        self.start = time.perf_counter()
        self.last_report = self.last_write = float("-inf")
        self.clock = Clock([(0, len(self.runs))])
        self.ticked = (self.start, 0)               # when the clock was last told, and the runs finished then
        self.threads, self.threads_at = 1, float("-inf")

    # ------------------------------------------------------------------ the sweep
    def run(self, plot: bool) -> SweepReport:
        os.makedirs(os.path.join(self.out_dir, RUNS_FOLDER), exist_ok=True)
        earlier = results.read_results(self.csv_path)
        for run in self.sweep.runs:
            row = earlier.get(run.id)
            if results.is_finished(row, self.sweep):
                self.rows[run.id] = row
                self.skipped.append(run.id)
            else:
                self.rows[run.id] = results.new_row(run, self.sweep, self._design_file(run))
        self._write()
        interrupted = False
        try:
            skipped = set(self.skipped)
            self.queue.extend((run, None) for run in self.sweep.runs if run.id not in skipped)
            self._fill()
            self._collect()
        except KeyboardInterrupt:
            interrupted = True
            self._stop()
        self._report(force=True)
        self._write()
        plot_path = ""
        if plot:
            plot_path = os.path.join(self.out_dir, results.PLOT_NAME)
            results.plot_summary(plot_path, self.sweep, self._ordered_rows())
        rows = self._ordered_rows()
        counts = {}
        for row in rows:
            counts[row["status"]] = counts.get(row["status"], 0) + 1
        return SweepReport(rows, self.skipped, self.submitted, self.retried, interrupted,
                           time.perf_counter() - self.start, self.csv_path, plot_path, counts)

    def _design_file(self, run) -> str:
        return os.path.abspath(os.path.join(self.out_dir, RUNS_FOLDER, f"{run.id}.npz"))

    def _fill(self) -> None:
        """Submit queued runs while fewer are in flight than the cluster has threads.

        No task waits in a worker's own queue, so a worker that dies takes down only the
        run it was executing, and a retry starts at once on the worker it is sent to.
        """
        if not self.queue:
            return
        now = time.perf_counter()
        if now - self.threads_at >= THREADS_EVERY:
            self.threads, self.threads_at = max(1, sum(self.client.nthreads().values())), now
        while self.queue and len(self.pending) < self.threads:
            self._submit(*self.queue.popleft())

    def _submit(self, run, avoid: str | None = None) -> None:
        attempt = self.attempts.get(run.id, 0) + 1
        self.attempts[run.id] = attempt
        payload = {**run.payload(self.sweep, self._design_file(run)), "token": self.token}
        restrict = {}
        if avoid:
            others = [w for w in self.client.nthreads() if w != avoid]
            if others:
                restrict = {"workers": others, "allow_other_workers": True}
        future = self.client.submit(self.task, payload, key=f"pes_ref-sweep-{run.id}-{self.token}-{attempt}",
                                    pure=False, **restrict)
        self.pending[future] = run.id
        (self.retried if attempt > 1 else self.submitted).append(run.id)

    # ------------------------------------------------------------------ collecting
    def _collect(self) -> None:
        from distributed import wait
        while self.pending:
            try:
                done = wait(list(self.pending), timeout=self.progress_every, return_when="FIRST_COMPLETED").done
            except TimeoutError:
                done = ()
            for future in done:
                self._finish(future, retry=True)
            self._fill()
            self._write(force=False)
            self._report()

    def _finish(self, future, retry: bool) -> None:
        run_id = self.pending.pop(future)
        outcome = _outcome(future, run_id)
        attempt = self.attempts[run_id]
        failed = outcome["status"] == "failed"
        if failed:
            self.failures.setdefault(run_id, []).append(
                f"attempt {attempt} on {outcome.get('worker') or '?'}: {outcome['error']}")
        if run_id in self.failures:          # a retried run keeps its first error, whatever the second does
            outcome = {**outcome, "error": " | ".join(self.failures[run_id])}
        self.rows[run_id] = results.record(self.rows[run_id], outcome, attempt)
        if failed and not retry and attempt < 2:     # stopping: this run is run again next time
            self.rows[run_id]["status"] = "interrupted"
        if failed and retry and attempt < 2:
            self.rows[run_id]["status"] = "retrying"
            self.queue.appendleft((self.runs[run_id], outcome.get("worker")))
        else:
            self.finished_now += 1

    def _stop(self) -> None:
        """Ctrl-C: ask running tasks to save and return, wait for them, cancel the rest."""
        from distributed import wait
        try:
            self.client.run(request_stop, self.token, on_error="ignore")
            deadline = time.perf_counter() + self.stop_grace
            while self.pending and time.perf_counter() < deadline:
                try:
                    done = wait(list(self.pending), timeout=min(self.progress_every, deadline - time.perf_counter()),
                                return_when="FIRST_COMPLETED").done
                except TimeoutError:
                    done = ()
                for future in done:
                    self._finish(future, retry=False)
                self._report()
        except KeyboardInterrupt:       # a second Ctrl-C: stop waiting
            pass
        for future, run_id in list(self.pending.items()):
            future.cancel()
            self.rows[run_id]["status"] = "interrupted"
            self.rows[run_id]["error"] = "the sweep stopped before this attempt returned"
        self.pending.clear()
        for run, _ in self.queue:           # never started this time (a retry's first error is kept)
            row = self.rows[run.id]
            row["status"] = "interrupted" if row["status"] == "retrying" else "pending"
        self.queue.clear()

    # ------------------------------------------------------------------ reporting
    def _ordered_rows(self) -> list:
        return [self.rows[run.id] for run in self.sweep.runs]

    def _write(self, force: bool = True) -> None:
        now = time.perf_counter()
        if force or now - self.last_write >= WRITE_EVERY:
            results.write_results(self.csv_path, self.sweep, self._ordered_rows())
            self.last_write = now

    def _report(self, force: bool = False) -> None:
        now = time.perf_counter()
        if self.progress is None or (not force and now - self.last_report < self.progress_every):
            return
        self.last_report = now
        statuses = [row["status"] for row in self.rows.values()]
        done, failed = statuses.count("ok"), statuses.count("failed")
        running = self._running()
        then, finished = self.ticked
        self.clock.tick(0, now - then, self.finished_now - finished)
        self.ticked = (now, self.finished_now)
        self.progress(Progress(f"sweep {self.sweep.name}", "", done, len(statuses), "runs", self.clock.rate(0),
                               now - self.start, self.clock.seconds_left(done + failed),
                               (("running", running), ("failed", failed))))

    def _running(self) -> int:
        """Tasks of this sweep executing on a worker now (asked of the workers)."""
        if not self.pending:
            return 0
        mine = {future.key for future in self.pending}
        try:
            executing = self.client.run(_executing_keys, on_error="ignore")
        except Exception:          # a worker going away mid-question: count what answered
            return 0
        return sum(1 for keys in executing.values() if isinstance(keys, list) for k in keys if k in mine)


def _executing_keys(dask_worker) -> list:
    """The keys this worker is executing (run on every worker by `_Sweeper._running`)."""
    return [ts.key for ts in dask_worker.state.executing]


def _outcome(future, run_id: str) -> dict:
    """A finished future's outcome dict; a task that never returned (dead worker) as a failure."""
    try:
        return future.result()
    except Exception as exc:
        from distributed import KilledWorker
        worker = exc.last_worker.address if isinstance(exc, KilledWorker) else ""
        error = f"the worker died while running it ({worker})" if isinstance(exc, KilledWorker) else \
            " ".join(f"{type(exc).__name__}: {exc}".split())
        return {"id": run_id, "status": "failed", "error": error, "worker": worker}
