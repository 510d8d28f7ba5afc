"""How ``design`` shows its progress: rewritten in place when stderr is a terminal (a
pseudo-terminal here), plain lines when it is not."""
import fcntl
import os
import pty
import struct
import subprocess
import sys
import termios

import pes_ref
from pathlib import Path

ROOT = Path(pes_ref.__file__).resolve().parent.parent
ENV = {k: v for k, v in os.environ.items() if k != "COLUMNS"}
ENV.update(PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), OMP_NUM_THREADS="1", TERM="xterm")
DESIGN = ["design", "funnel", "--smoke", "--progress", "0", "--out"]


def _at_a_terminal(argv, cwd, columns=250) -> tuple:
    """Run ``pes_ref ARGV`` with stderr a terminal ``columns`` wide; return (status, stdout, what the terminal got)."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, columns, 0, 0))
    proc = subprocess.Popen([sys.executable, "-m", "pes_ref", *argv], cwd=cwd, env=ENV, stdin=subprocess.DEVNULL,
                            stdout=subprocess.PIPE, stderr=slave)
    os.close(slave)
    got = b""
    while True:
        try:
            chunk = os.read(master, 65536)
        except OSError:                 # the terminal's other end closed: the command is done
            break
        if not chunk:
            break
        got += chunk
    os.close(master)
    out = proc.stdout.read().decode()
    return proc.wait(timeout=120), out, got.decode()


def test_at_a_terminal_the_progress_line_is_rewritten_in_place(tmp_path):
    code, out, err = _at_a_terminal([*DESIGN, "f.npz"], tmp_path)
    assert code == 0, err
    shows = err.split("\r\x1b[K")
    assert shows[0] == "" and len(shows) == 7, repr(err)          # six iterations, each over the last
    assert all(s.startswith("design funnel: stage 1/1 | it ") for s in shows[1:])
    assert all("\n" not in s for s in shows[1:-1])                # one line, rewritten
    assert shows[-1].endswith("\r\n") and shows[-1].count("\n") == 1   # the last one ends with a newline
    assert "| it 1/6 | " in shows[1] and "? it/s" in shows[1] and shows[1].rstrip().endswith("left ?")
    assert out.startswith("wrote f.npz: funnel, iteration 6/6")


def test_elsewhere_each_report_is_a_plain_line(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "pes_ref", *DESIGN, "f.npz"], cwd=tmp_path, env=ENV,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 6 and "\r" not in proc.stderr and "\x1b" not in proc.stderr
    assert all(line.startswith(f"design funnel: stage 1/1 | it {k}/6 | ") for k, line in enumerate(lines, 1))
