"""Signals: how every command and loop of the package stops on Ctrl-C and SIGTERM.

Its rules, one function each:

- [`StopFlag`][pes_ref.core.runtime.signals.StopFlag]: a long loop (a design's iterations, the polish's generations)
  turns
  SIGINT (Ctrl-C) and SIGTERM (a batch scheduler preempting the run) into a flag that it
  checks between two steps, so that it stops on a whole state it can save; a second
  signal stops at once (`KeyboardInterrupt`).
- [`sigterm_interrupts`][pes_ref.core.runtime.signals.sigterm_interrupts]: anywhere else in a command, SIGTERM stops the
  process as
  Ctrl-C does (`KeyboardInterrupt`), so that the command's own clean-up runs.
- [`note_interrupts`][pes_ref.core.runtime.signals.note_interrupts],
  [`interrupted`][pes_ref.core.runtime.signals.interrupted]: Ctrl-C while the command line is still
  being imported, noted even where a C extension's import turns it into another error.
- [`ignore_interrupts`][pes_ref.core.runtime.signals.ignore_interrupts]: a worker process (a process pool of the polish,
  a Dask
  worker of a sweep) ignores SIGINT: Ctrl-C in a terminal reaches the whole process
  group, and stopping is the main process's to decide.

Handlers can be installed in the main thread only; elsewhere (a Dask worker's task
thread) [`StopFlag`][pes_ref.core.runtime.signals.StopFlag] and
[`sigterm_interrupts`][pes_ref.core.runtime.signals.sigterm_interrupts] leave the handlers as they are.
"""
from __future__ import annotations

import contextlib
import signal

__all__ = ["StopFlag", "sigterm_interrupts", "ignore_interrupts", "note_interrupts", "interrupted", "STOP_SIGNALS"]

#: The signals that ask a run to stop: Ctrl-C, and a batch scheduler's preemption.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def _install(signum, handler):
    """Install ``handler`` for ``signum``; the handler to give back later (``SIG_DFL`` for
    one not installed from Python), or None outside the main thread, where Python
    installs none."""
    try:
        old = signal.signal(signum, handler)
    except ValueError:                  # "signal only works in main thread of the main interpreter"
        return None
    return signal.SIG_DFL if old is None else old


class StopFlag:
    """Turns SIGINT and SIGTERM into a flag (``stop``) that a loop checks between two
    steps; a second signal raises `KeyboardInterrupt` at once. The previous
    handlers are given back on exit, so nested flags each see their own signals.

    Examples
    --------
    >>> with StopFlag() as flag:              # doctest: +SKIP
    ...     while not flag.stop:
    ...         step()
    """

    def __init__(self):
        self.stop = False
        self._old = {}

    def __enter__(self):
        for signum in STOP_SIGNALS:
            old = _install(signum, self._handle)
            if old is not None:
                self._old[signum] = old
        return self

    def _handle(self, signum, frame):
        if self.stop:                       # a second signal: the user insists
            raise KeyboardInterrupt
        self.stop = True

    def __exit__(self, *exc):
        for signum, old in self._old.items():
            signal.signal(signum, old)
        self._old = {}
        return False


def _interrupt(signum, frame):
    raise KeyboardInterrupt


@contextlib.contextmanager
def sigterm_interrupts():
    """Within the block, SIGTERM raises `KeyboardInterrupt` (as Ctrl-C does); the
    previous handler is given back after it."""
    old = _install(signal.SIGTERM, _interrupt)
    try:
        yield
    finally:
        if old is not None:
            signal.signal(signal.SIGTERM, old)


def ignore_interrupts(*_) -> None:
    """Make this process ignore SIGINT (the initializer of a worker process; any
    arguments, such as the Dask worker a plugin passes, are ignored)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


# --------------------------------------------------------------------------- Ctrl-C while importing

_INTERRUPTS = {"seen": False}


def _note_interrupt(signum, frame):
    _INTERRUPTS["seen"] = True
    raise KeyboardInterrupt


def note_interrupts() -> None:
    """Handle Ctrl-C (SIGINT) as Python does, by `KeyboardInterrupt`, and note that
    it came ([`interrupted`][pes_ref.core.runtime.signals.interrupted]): a C extension being
    imported (NumPy's) may turn the KeyboardInterrupt into another error, which the command line
    then reports as the interruption it is. Python's own handler only is replaced (not a SIGINT
    ignored, as in a shell's background job)."""
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, _note_interrupt)


def interrupted() -> bool:
    """Whether Ctrl-C reached the handler of [`note_interrupts`][pes_ref.core.runtime.signals.note_interrupts] in this process."""
    return _INTERRUPTS["seen"]
