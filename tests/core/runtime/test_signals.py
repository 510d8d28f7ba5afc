"""pes_ref.core.runtime.signals: the one home of signal handling. A loop's StopFlag turns Ctrl-C
and SIGTERM into a flag (a second signal stops at once), the command line's SIGTERM acts
as Ctrl-C, and worker processes ignore Ctrl-C; every handler is given back."""
import os
import signal
import subprocess
import sys
import threading

import pytest

from pes_ref.core.runtime.signals import StopFlag, sigterm_interrupts


@pytest.fixture
def own_sigterm():
    """A harmless SIGTERM handler of the test's own: a signal that reached no handler of
    the code under test fails the test instead of ending the session."""
    def own(signum, frame):
        pass
    before = signal.signal(signal.SIGTERM, own)
    yield own
    signal.signal(signal.SIGTERM, before)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_sets_the_flag_and_a_second_stops_at_once(signum, own_sigterm):
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    with StopFlag() as flag:
        os.kill(os.getpid(), signum)
        assert flag.stop
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signum)
    assert {s: signal.getsignal(s) for s in before} == before


def test_outside_the_main_thread_the_flag_leaves_the_handlers_alone():
    seen = []

    def run():
        with StopFlag() as flag:
            seen.append((flag.stop, signal.getsignal(signal.SIGINT)))
    before = signal.getsignal(signal.SIGINT)
    t = threading.Thread(target=run)
    t.start()
    t.join()
    assert seen == [(False, before)]


def test_sigterm_interrupts_like_ctrl_c_within_the_block(own_sigterm):
    with pytest.raises(KeyboardInterrupt):
        with sigterm_interrupts():
            os.kill(os.getpid(), signal.SIGTERM)
    assert signal.getsignal(signal.SIGTERM) is own_sigterm


def test_a_worker_ignores_ctrl_c():
    code = ("import os, signal, sys; from pes_ref.core.runtime.signals import ignore_interrupts; ignore_interrupts(); "
            "os.kill(os.getpid(), signal.SIGINT); print(signal.getsignal(signal.SIGINT) == signal.SIG_IGN)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and proc.stdout.strip() == "True", proc.stderr
