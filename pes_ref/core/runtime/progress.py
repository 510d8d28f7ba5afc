"""Progress and time left: the one type every long loop reports, the one clock that
estimates the time left, and the one line a command prints.

- [`Progress`][pes_ref.core.runtime.progress.Progress]: where a loop is (what is done out of what total, in which
  stage),
  its rate, the time it has run and the time left, and the figures it shows (loss,
  metric, fitness ...). The design loop, the polish, a sweep and a long oracle run all
  report one ([`pes_ref.synthesis.run_stages`][pes_ref.synthesis.engine.stages.run_stages],
  [`pes_ref.sweep.runner.run_sweep`][pes_ref.sweep.runner.run_sweep],
  the ``oracle`` command).
- [`Clock`][pes_ref.core.runtime.progress.Clock]: the rate of each segment of a loop (a stage of a design, the forward
  run and the adjoint of an oracle run) and the time left, summed over the segments
  still to run.
- [`progress_line`][pes_ref.core.runtime.progress.progress_line] and
  [`clock_time`][pes_ref.core.runtime.progress.clock_time]: a
  [`Progress`][pes_ref.core.runtime.progress.Progress] as one line of text, and a duration as
  ``m:ss``, for every command.
- [`ProgressWriter`][pes_ref.core.runtime.progress.ProgressWriter]: how a command shows those lines on stderr: at a
  terminal one
  line rewritten in place, elsewhere (a pipe, a file, a log) plain lines.

The time-stepping loops (the forward run and its adjoint) report through a cheaper
hook: an optional callback ``progress(phase, done, total)`` (``phase`` is ``"forward"``
or ``"adjoint"``, ``done`` the steps finished out of ``total``). [`reporting`][pes_ref.core.runtime.progress.reporting]
wraps a loop's iterable so that the callback is called once before the first step,
then after every `EVERY` steps and after the last: the loop body itself never
checks anything, and without a callback the iterable is returned unchanged, so a run
without progress reports pays nothing; a compiled loop runs in [`blocks`][pes_ref.core.runtime.progress.blocks] of as
many steps. A command that shows such a run turns the calls
into [`Progress`][pes_ref.core.runtime.progress.Progress] (the ``oracle`` command's ``ProgressLines``).
"""
from __future__ import annotations

import math
import os
import re
import sys
from itertools import islice
from typing import Callable, Iterable

__all__ = ["EVERY", "WARMUP", "LONG_RUN", "PERIOD", "reporting", "blocks", "Progress", "Clock", "progress_line",
           "is_progress_line", "figure_text", "clock_time", "ProgressWriter", "ShareLines"]

#: Steps between two calls of a progress callback (a callback that reads a clock reads it
#: this rarely; at ~10 us a step that is every few milliseconds).
EVERY = 256
#: Ticks at the start of each segment of a `Clock` that are not timed: the first
#: iteration of a design stage (or a polish generation, a sweep's first runs, an oracle
#: run's first block of steps) carries one-off costs, compiling the loops, imports,
#: allocating, that made the time left read 11-27 minutes at iteration 1 of runs that took
#: 7-19 seconds.
WARMUP = 1
#: A command whose run may be short (an analysis, an oracle run) stays silent for its first
#: LONG_RUN seconds, then prints at most one progress line every PERIOD seconds. Whether a
#: line is printed therefore depends on the machine's speed: a test compares a command's
#: stderr without its progress lines (`is_progress_line`).
LONG_RUN = 3.0
PERIOD = 2.0


def reporting(steps: Iterable, progress: Callable | None, phase: str, total: int) -> Iterable:
    """``steps`` as they are, calling ``progress(phase, done, total)`` at 0, every
    `EVERY` steps and at ``total``; ``steps`` itself when ``progress`` is None.

    Parameters
    ----------
    steps : iterable
        One item per step, ``total`` of them.
    progress : callable or None
    phase : str
    total : int
    """
    if progress is None:
        return steps
    return _chunks(iter(steps), progress, phase, total)


def _chunks(steps, progress, phase, total):
    progress(phase, 0, total)
    for done in range(EVERY, total + EVERY, EVERY):
        yield from islice(steps, EVERY)
        progress(phase, min(done, total), total)


def blocks(total: int, progress: Callable | None, phase: str) -> Iterable:
    """The steps ``0 .. total`` as ``(done, done_after)`` blocks for a loop that runs a
    block at a time (a compiled one): the whole run in one block when ``progress`` is
    None, else `EVERY` steps per block, with ``progress(phase, done, total)`` called
    as [`reporting`][pes_ref.core.runtime.progress.reporting] calls it; a run of no steps is one empty block ``(0, 0)``."""
    if progress is None:
        return iter([(0, total)])
    return _blocks(total, progress, phase)


def _blocks(total, progress, phase):
    progress(phase, 0, total)
    if total == 0:                 # a run of no steps still has its state 0 to compute
        yield 0, 0
    for done in range(0, total, EVERY):
        yield done, min(done + EVERY, total)
        progress(phase, min(done + EVERY, total), total)


class Progress:
    """Where a long loop is, what a progress callback receives.

    Attributes
    ----------
    label : str
        Who reports (``"design funnel"``, ``"sweep lr"``, a case file's name).
    stage : str
        Where in the run (``"stage 1/2"``, ``"polish"``, ``"forward"``; ``""``: one stage only).
    done, total : int
        Units done, out of the total to do (``done`` may pass ``total`` where the last
        step overshoots, as the polish's last generation may).
    unit : str
        What is counted (``"it"``, ``"evaluations"``, ``"steps"``, ``"runs"``).
    rate : float
        Units per second (0 until measured).
    elapsed : float
        Seconds the loop has run.
    seconds_left : float
        Estimated seconds to the end (``inf`` while unknown).
    figures : tuple of (name, value)
        What else the loop shows, in order: numbers, a grid shape (a tuple of ints) or
        short text; [`figure`][pes_ref.core.runtime.progress.Progress.figure] reads one by name.

    A plain class with slots rather than a named tuple: every run of the ``oracle``
    command imports this module, and a named tuple's class would cost each run a few tenths
    of a millisecond.
    """

    __slots__ = ("label", "stage", "done", "total", "unit", "rate", "elapsed", "seconds_left", "figures")

    def __init__(self, label: str, stage: str, done: int, total: int, unit: str, rate: float, elapsed: float,
                 seconds_left: float, figures: tuple = ()):
        self.label, self.stage, self.done, self.total, self.unit = label, stage, done, total, unit
        self.rate, self.elapsed, self.seconds_left, self.figures = rate, elapsed, seconds_left, tuple(figures)

    def __repr__(self) -> str:
        return "Progress(" + ", ".join(f"{name}={getattr(self, name)!r}" for name in self.__slots__) + ")"

    def figure(self, name: str, default=None):
        """The figure ``name`` (``default`` when the loop does not show it)."""
        return next((value for key, value in self.figures if key == name), default)


class Clock:
    """The rate of each segment of a loop and the time left, summed over the segments
    still to run.

    A segment that has run is timed by its own units; one yet to run, by the seconds
    per cost unit of the latest segment timed, times its own cost. The first ``warmup``
    ticks of a segment that finish units (and the ticks before them) are its warm-up and
    are not timed: they carry one-off costs (`WARMUP`). Before anything is timed
    the time left is unknown (``inf``, shown as ``left ?``) and the rate 0 (``? it/s``).

    Parameters
    ----------
    segments : sequence of ``(start, end)`` or ``(start, end, cost)``
        The parts of the loop in order, each starting where the previous one ends: units
        ``[start, end)``, each costing ``cost`` (default 1; any unit, only the ratios
        between segments count, e.g. a design stage's steps per training run).
    warmup : int
        Ticks of each segment not timed (default `WARMUP`).
    """

    def __init__(self, segments, warmup: int = WARMUP):
        self.segments = [(s[0], s[1], s[2] if len(s) > 2 else 1.0) for s in segments]
        self._seconds = [0.0] * len(self.segments)
        self._units = [0] * len(self.segments)
        self._warm = [max(int(warmup), 0)] * len(self.segments)   # warm-up ticks still to come, per segment
        self._per_cost = None           # seconds per cost unit of the latest segment timed

    def index(self, position: int) -> int:
        """The segment that unit ``position`` is in (the first for one before it)."""
        return max(i for i, (start, _, _) in enumerate(self.segments) if start <= position or i == 0)

    def tick(self, position: int, seconds: float, units: int = 1) -> None:
        """``units`` units from ``position`` on (in one segment) took ``seconds``."""
        i = self.index(position)
        if self._warm[i]:               # the segment's warm-up: not timed
            if units > 0:
                self._warm[i] -= 1
            return
        self._seconds[i] += seconds
        self._units[i] += units
        if self._seconds[i] > 0 and self._units[i] > 0:
            self._per_cost = self._seconds[i] / (self._units[i] * self.segments[i][2])

    def rate(self, i: int) -> float:
        """Units per second of segment ``i`` (0 while it has not been timed)."""
        return self._units[i] / self._seconds[i] if self._seconds[i] > 0 else 0.0

    def seconds_left(self, position: int, total: int | None = None) -> float:
        """Seconds to run units ``position .. total - 1`` (default: to the last segment's end)."""
        total = self.segments[-1][1] if total is None else total
        left = 0.0
        for i, (start, end, cost) in enumerate(self.segments):
            n = max(0, min(end, total) - max(start, position))
            if n == 0:
                continue
            rate = self.rate(i)
            if rate > 0:
                left += n / rate
            elif self._per_cost is not None:
                left += n * cost * self._per_cost
            else:
                return float("inf")
        return left


def clock_time(seconds: float) -> str:
    """A duration as ``m:ss`` (``?`` when unknown: infinite or NaN)."""
    if not seconds < float("inf"):
        return "?"
    seconds = max(int(round(seconds)), 0)
    return f"{seconds // 60}:{seconds % 60:02d}"


def figure_text(value) -> str:
    """A figure of a [`Progress`][pes_ref.core.runtime.progress.Progress] as text: a grid shape as ``25x25``, a float to
    4
    significant digits, anything else as ``str`` gives it."""
    if isinstance(value, tuple):                        # a grid shape
        return "x".join(str(n) for n in value)
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def _rate(rate: float) -> str:
    if not rate > 0:                                    # not measured yet (a clock's warm-up)
        return "?"
    return f"{rate:.0f}" if rate >= 100 else f"{rate:.3g}"


def progress_line(p: Progress) -> str:
    """One line of a [`Progress`][pes_ref.core.runtime.progress.Progress], the same for every command, e.g.
    ``design funnel: stage 1/2 | it 30/300 | grid 25x25 | steps 200 | loss 0.1234 |
    in_band 0.4 | 5.2 it/s | elapsed 0:06 | left 1:10``."""
    head = f"{p.label}: {p.stage}" if p.stage else p.label
    return " | ".join([head, f"{p.unit} {p.done}/{p.total}", *(f"{name} {figure_text(v)}" for name, v in p.figures),
                       f"{_rate(p.rate)} {p.unit}/s", f"elapsed {clock_time(p.elapsed)}",
                       f"left {clock_time(p.seconds_left)}"])


_CLOCK = r"(?:\d+:\d\d|\?)"
#: The shape of a progress line (compiled on first use: the oracle command's start-up pays nothing).
_PROGRESS = r"(?!error: |warning: )[^\n|]+ \| \S+ -?\d+/\d+ \| (?:[^\n|]+ \| )*\S+ \S+/s \| elapsed " + _CLOCK + r" \| left " + _CLOCK


def is_progress_line(line: str) -> bool:
    """Whether ``line`` (without its newline) is one that [`progress_line`][pes_ref.core.runtime.progress.progress_line]
    makes: a
    head, ``unit done/total``, the figures, ``rate unit/s``, ``elapsed m:ss`` and ``left
    m:ss``. What a command prints on stderr is its progress lines and then its own lines
    (``error: ...``, ``warning: ...``, never taken for progress whatever follows); this tells
    them apart."""
    return re.fullmatch(_PROGRESS, line) is not None


def _columns(stream) -> int:
    """The width of the terminal ``stream`` writes to: ``COLUMNS`` if set (as
    `shutil.get_terminal_size` reads it), else the stream's own terminal (not
    stdout's: ``design ... > log`` keeps stderr at the terminal), else 80."""
    try:
        columns = int(os.environ.get("COLUMNS", 0))
    except ValueError:
        columns = 0
    if columns <= 0:
        try:
            columns = os.get_terminal_size(stream.fileno()).columns
        except (AttributeError, ValueError, OSError):
            columns = 0
    return columns if columns > 0 else 80


class ProgressWriter:
    """How a command shows its progress lines ([`progress_line`][pes_ref.core.runtime.progress.progress_line]) on
    stderr.

    At a terminal (``stream.isatty()``, and ``TERM`` not ``dumb``) each line replaces the one before
    in place: a carriage return, the cursor moved up over the rows a line wider than the terminal
    wrapped onto, the old text cleared (to the end of the line, or of the screen after a wrapped
    line), then the new line, without a newline. Anywhere else (a pipe, a file, a CI log) each is a
    plain line, as before. [`note`][pes_ref.core.runtime.progress.ProgressWriter.note] prints a line
    of its own that stays (a change of stage),
    [`end`][pes_ref.core.runtime.progress.ProgressWriter.end] ends the line in place with a newline;
    a command calls it before it prints anything else, so that its last progress line stays on the
    screen, whole.

    Parameters
    ----------
    stream : file or None
        Where to write; None: ``sys.stderr`` as it is at each write (the command line's
        watched stream, a test's captured one).
    """

    def __init__(self, stream=None):
        self.stream = stream
        self._rows = 0                  # the rows the line shown in place takes (0: none shown)

    def _out(self):
        return sys.stderr if self.stream is None else self.stream

    @staticmethod
    def in_place(stream) -> bool:
        """Whether lines on ``stream`` are rewritten in place: it is a terminal that can."""
        try:
            return bool(stream.isatty()) and os.environ.get("TERM") != "dumb"
        except (AttributeError, ValueError, OSError):      # no isatty, or a closed stream
            return False

    def show(self, p) -> None:
        """Show ``p`` (a [`Progress`][pes_ref.core.runtime.progress.Progress], or a line of text) in place of the last line."""
        line = p if isinstance(p, str) else progress_line(p)
        out = self._out()
        if not self.in_place(out):
            print(line, file=out, flush=True)
            return
        if self._rows > 1:              # back over the rows the wrapped line took, and clear them all
            back = f"\r\x1b[{self._rows - 1}A\x1b[J"
        else:
            back = "\r\x1b[K"
        out.write(back + line)
        out.flush()
        self._rows = max(1, math.ceil(len(line) / _columns(out)))

    def note(self, text: str) -> None:
        """``text`` on a line of its own that stays, after the line in place (if any)."""
        self.end()
        print(text, file=self._out(), flush=True)

    def end(self) -> None:
        """End the line shown in place with a newline (nothing if none is shown)."""
        if self._rows:
            self._rows = 0
            out = self._out()
            out.write("\n")
            out.flush()


class ShareLines:
    """The progress lines of a run that knows only the share it has done (an analysis: its
    C-space, then its drive), on stderr: ``cam.toml: drive | percent 40/100 | 8.1 percent/s |
    elapsed 0:07 | left 0:10``. A callback ``progress(phase, done, total)`` (this module's
    signature; ``done`` and ``total`` may be a travel), silent for the first
    `LONG_RUN` seconds, then at most one line every
    `PERIOD` seconds; the time left is the phase's elapsed
    time scaled by the share still to do. ``lines`` shows them (in place at a terminal); ``end``
    it before printing anything else."""

    def __init__(self, label: str, clock=None):
        import time
        self.label, self.clock = label, time.monotonic if clock is None else clock
        self.lines = ProgressWriter()
        self.start = self.last = self.clock()
        self.phase, self.phase_start = None, self.start

    def __call__(self, phase: str, done, total) -> None:
        now = self.clock()
        if phase != self.phase:
            self.phase, self.phase_start = phase, now
        if now - self.start < LONG_RUN or now - self.last < PERIOD:
            return
        self.last = now
        share = min(max(done / total, 0.0), 1.0) if total else 1.0
        elapsed = now - self.phase_start
        percent = round(100 * share)
        rate = percent / elapsed if elapsed > 0 else 0.0
        left = elapsed * (1.0 - share) / share if share > 0 else float("inf")
        self.lines.show(Progress(self.label, phase, percent, 100, "percent", rate, now - self.start, left))
