"""The kinds of file the package reads, told apart by their contents, and the one refusal of a
file handed to a command that reads another kind.

[`what`][pes_ref.cli.files.what] names a file's kind from its zip's member names and, only when
it has a ``format`` member, that tag: ``"design"``, ``"case"``, ``"result"``, or None for
anything else (a plain zip, a text file, a missing file). Each kind is a small class in
`FILE_KINDS`, which says how the kind is recognized, by the facts its owning module holds
(a design file's tag `pes_ref.synthesis.engine.design_file.FORMAT`, a case's
`pes_ref.oracle.case.REQUIRED_KEYS`, a result's `pes_ref.oracle.case.TRAJECTORY_KEYS`), and
what to tell a user who passed it where another kind belongs. The owners are imported only when
a file is asked about, and a design file's only for a file with a ``format`` member (which no
case has), so ``python -m pes_ref oracle`` imports nothing of synthesis.

The commands call [`expect`][pes_ref.cli.files.expect] at their boundary (``oracle`` for its
cases; ``evaluate``, ``realize`` and ``design --resume`` for design files): a file of another
kind is refused in one line naming what it is and what reads it. It lives in the command line
because it knows both the oracle's formats and synthesis's, which know nothing of each other.
"""
from __future__ import annotations

import zipfile

from pes_ref.cli.common import input_file

__all__ = ["what", "expect", "FILE_KINDS", "FileKind"]


class FileKind:
    """One kind of file the package reads.

    Attributes
    ----------
    name : str
        The kind, as [`what`][pes_ref.cli.files.what] names it.
    noun : str
        The file in a sentence ("a design file").
    label : str
        What a command calls the file when it is missing or unreadable ("design file").
    advice : str
        What to tell a user who passed it where another kind belongs (``{path}``: the file).
    """

    name = ""
    noun = ""
    label = ""
    advice = ""

    def matches(self, members: frozenset, tag: str | None) -> bool:
        """Whether a zip of these member names (``.npy`` left off) with this ``format`` tag
        (None: no ``format`` member, or one that is no text) is of this kind."""
        raise NotImplementedError

    def refusal(self, path: str, wanted: "FileKind") -> str:
        """The one line that refuses ``path``, of this kind, where a ``wanted`` file belongs."""
        return f"{path} is {self.noun}, not {wanted.noun}; {self.advice.format(path=path)}"


class DesignFile(FileKind):
    """A design run (`pes_ref.synthesis.engine.design_file`): its ``format`` tag is `FORMAT`."""

    name, noun, label = "design", "a design file", "design file"
    advice = "evaluate reads it: python -m pes_ref evaluate {path}"

    def matches(self, members, tag):
        if tag is None:
            return False
        from pes_ref.synthesis.engine.design_file import FORMAT
        return tag == FORMAT


class CaseFile(FileKind):
    """An oracle case (docs/spec.md section 8): it holds every key of `REQUIRED_KEYS`."""

    name, noun, label = "case", "an oracle case file", "case file"
    advice = "the oracle runs it: python -m pes_ref oracle {path} RESULT.npz"

    def matches(self, members, tag):
        from pes_ref.oracle.case import REQUIRED_KEYS
        return set(REQUIRED_KEYS) <= members


class ResultFile(FileKind):
    """An oracle result (docs/spec.md section 9): it holds every key of `TRAJECTORY_KEYS`,
    which no case holds."""

    name, noun, label = "result", "an oracle result file", "result file"
    advice = "it holds an oracle run's output (the oracle wrote it)"

    def matches(self, members, tag):
        from pes_ref.oracle.case import TRAJECTORY_KEYS
        return set(TRAJECTORY_KEYS) <= members


#: Every kind of file the package reads, by name, in the order [`what`][pes_ref.cli.files.what] asks them.
FILE_KINDS = {kind.name: kind for kind in (DesignFile(), CaseFile(), ResultFile())}


def _contents(path) -> tuple:
    """The member names of the zip at ``path`` (``.npy`` left off) and its ``format`` tag (None
    without a ``format`` member or when it is no text). Only the zip's directory is read, and
    that one member; a file that is no zip has no members."""
    try:
        with zipfile.ZipFile(path) as z:
            members = frozenset(n[:-4] for n in z.namelist() if n.endswith(".npy"))
            if "format" not in members:
                return members, None
            import numpy as np      # here: --help builds the parsers of the commands that import this module
            try:
                with z.open("format.npy") as member:
                    tag = np.lib.format.read_array(member, allow_pickle=False)
            except Exception:       # damaged, or no plain array: no tag (its reader says what is wrong)
                return members, None
    except (zipfile.BadZipFile, OSError):
        return frozenset(), None
    return members, (str(tag) if tag.dtype.kind == "U" and tag.ndim == 0 else None)


def what(path) -> str | None:
    """The kind of the file ``path`` as the package knows it: a name of `FILE_KINDS`
    (``"design"``, ``"case"``, ``"result"``), or None for anything else (no zip, a zip of none
    of them, a missing file)."""
    members, tag = _contents(path)
    return next((kind.name for kind in FILE_KINDS.values() if kind.matches(members, tag)), None)


def expect(path: str, kind: str, role: str | None = None) -> str:
    """``path`` if it is a file to read and not a file of another kind the package knows.

    Parameters
    ----------
    path : str
    kind : str
        The kind the command reads (a name of `FILE_KINDS`).
    role : str, optional
        What the command calls the file when it is missing or unreadable (default the kind's
        ``label``).

    Raises
    ------
    OSError
        As [`input_file`][pes_ref.cli.common.input_file]: missing, a folder, not readable.
    ValueError
        ``path`` is a file of another kind: one line naming what it is and what reads it
        ("x.npz is an oracle case file, not a design file; the oracle runs it: ..."). A file of
        no known kind is left to the reader of ``kind``, whose refusal says what is wrong with it.
    """
    wanted = FILE_KINDS[kind]
    input_file(path, role or wanted.label)
    found = what(path)
    if found is not None and found != kind:
        raise ValueError(FILE_KINDS[found].refusal(path, wanted))
    return path
