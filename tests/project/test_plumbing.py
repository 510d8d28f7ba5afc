"""Process plumbing has one home each: signals in pes_ref/core/runtime/signals.py, progress, time
left, m:ss and a line rewritten in place at a terminal in pes_ref/core/runtime/progress.py, atomic writes in pes_ref/core/runtime/files.py, reading a
TOML input file in pes_ref/core/runtime/keyfile.py. A module
elsewhere that installs a signal handler, renames a file into place or formats minutes
itself is a second copy that would drift; this reads the package's source for them."""
import re

import pytest

from _helpers import ROOT

PACKAGE = ROOT / "pes_ref"

#: Each piece of plumbing: its home, and what only its home may write.
HOMES = {
    "signals": ("core/runtime/signals.py", re.compile(r"\bsignal\.signal\(|\bsignal\.SIG_IGN\b")),
    "m:ss and time left": ("core/runtime/progress.py", re.compile(r"//\s*60\b|divmod\([^)]*,\s*60\)|seconds_left\s*=")),
    "a line rewritten in place": ("core/runtime/progress.py", re.compile(r"\\r|\\x1b\[|\\033\[")),
    "atomic writes": ("core/runtime/files.py", re.compile(r"\bos\.replace\(|\bos\.rename\(|\bmkstemp\(|\bos\.link\(")),
    "reading a TOML input file": ("core/runtime/keyfile.py", re.compile(r"TOMLDecodeError as|not valid TOML|\.decode\(\"utf-8\"\)")),
}


def _sources():
    return sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


@pytest.mark.parametrize("what", list(HOMES))
def test_only_its_home_does_it(what):
    home, pattern = HOMES[what]
    found = [f"{p.relative_to(PACKAGE)}:{n}: {line.strip()}" for p in _sources() if p != PACKAGE / home
             for n, line in enumerate(p.read_text().splitlines(), 1) if pattern.search(line)]
    assert not found, f"{what} belong in pes_ref/{home}; also done here:\n" + "\n".join(found)


@pytest.mark.parametrize("what", list(HOMES))
def test_its_home_does_it(what):
    """The pattern finds what it looks for (else the test above could not fail)."""
    home, pattern = HOMES[what]
    assert pattern.search((PACKAGE / home).read_text())
