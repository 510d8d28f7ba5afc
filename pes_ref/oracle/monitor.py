"""The progress of a long oracle run, as the ``oracle`` command shows it: its estimate, then a
progress line at most every `PERIOD` seconds once the run
is long ([`ProgressLines`][pes_ref.oracle.monitor.ProgressLines]); [`monitor`][pes_ref.oracle.monitor.monitor]
is what [`run_case`][pes_ref.oracle.case.run_case] takes to report through it."""
from __future__ import annotations

import time

from pes_ref.core.runtime import progress
from pes_ref.core.runtime.progress import Clock, Progress, ProgressWriter

__all__ = ["ProgressLines", "monitor"]


class ProgressLines:
    """The progress of one oracle run on stderr, once it is long: the estimate first, then
    at most one line every ``period`` seconds
    ([`pes_ref.core.runtime.progress.progress_line`][pes_ref.core.runtime.progress.progress_line]), e.g.
    ``case.npz: forward | steps 1200/3000 | 250 steps/s | elapsed 0:05 | left 0:12``.

    A progress callback of [`pes_ref.core.runtime.progress`][pes_ref.core.runtime.progress] (called
    every few hundred steps). ``period`` and ``after`` default to
    `pes_ref.core.runtime.progress.PERIOD` and `pes_ref.core.runtime.progress.LONG_RUN`, read when
    the run starts. A run estimated longer than ``after`` seconds
    ([`pes_ref.core.budget.estimate`][pes_ref.core.budget.estimate]) prints its estimate at once;
    one estimated shorter starts printing if it runs past ``after`` seconds all the same. The time
    left is a [`pes_ref.core.runtime.progress.Clock`][pes_ref.core.runtime.progress.Clock] over the
    two phases, the forward run and then the adjoint, each step costing the model's share of its
    phase ([`pes_ref.core.budget.step_cost`][pes_ref.core.budget.step_cost]): a phase not yet timed
    is scaled from the one timed (the model's estimate until then).
    """

    def __init__(self, label: str, estimate, period: float | None = None, clock=time.monotonic,
                 after: float | None = None, lines: ProgressWriter | None = None):
        from pes_ref.core import budget
        self.label, self.clock = label, clock
        self.period = progress.PERIOD if period is None else period
        self.after = progress.LONG_RUN if after is None else after
        self.lines = ProgressWriter() if lines is None else lines      # in place at a terminal
        self.start = self.last = clock()
        self.run = estimate
        forward = budget.estimate_seconds(estimate.n_steps, estimate.n_particles, "simulate")
        total = budget.estimate_seconds(estimate.n_steps, estimate.n_particles, "case")
        share = forward / total if total > 0 else 0.5
        T = estimate.n_steps
        self.pace = Clock([(0, T, share), (T, 2 * T, 1.0 - share)])
        self.ticked = (self.start, 0)                   # when the clock was last told, and the position then
        self.started = estimate.seconds > self.after
        if self.started:
            self._header(0.0, estimate.seconds)

    def _header(self, elapsed: float, seconds: float) -> None:
        """The run's estimate, as a progress line of its own that stays: ``case.npz: estimate | steps
        0/3000 | N 64 | GiB 0.012 | ? steps/s | elapsed 0:00 | left 0:12`` (the steps are the
        forward run's; the adjoint runs as many after it)."""
        self.lines.note(progress.progress_line(Progress(
            self.label, "estimate", 0, self.run.n_steps, "steps", 0.0, elapsed, seconds,
            (("N", self.run.n_particles), ("GiB", float(self.run.gib))))))

    def __call__(self, phase: str, done: int, total: int) -> None:
        now = self.clock()
        elapsed = now - self.start
        position = done if phase == "forward" else self.run.n_steps + done
        then, before = self.ticked
        self.pace.tick(before, now - then, max(position - before, 0))
        self.ticked = (now, position)
        left = self.pace.seconds_left(position)
        if not left < float("inf"):                     # nothing timed yet: the model's estimate
            left = max(self.run.seconds - elapsed, 0.0)
        if not self.started:
            if elapsed < self.after:
                return
            self.started = True
            self._header(elapsed, left)
        if now - self.last < self.period:
            return
        self.last = now
        i = self.pace.index(position)
        self.lines.show(Progress(self.label, phase, done, total, "steps", self.pace.rate(i), elapsed, left))


def monitor(label: str, lines: ProgressWriter):
    """The oracle's ``monitor`` (`run_case`'s argument): the [`ProgressLines`][pes_ref.oracle.monitor.ProgressLines]
    of each run, shown by ``lines``."""
    return lambda estimate: ProgressLines(label, estimate, lines=lines)
