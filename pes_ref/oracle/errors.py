"""The oracle's errors: a refused case names its key.

[`CaseError`][pes_ref.oracle.errors.CaseError] is a
[`pes_ref.core.checks.InputError`][pes_ref.core.checks.InputError] (so a ``ValueError``) whose
``key`` is the case key at fault; the core's own keyed errors become case errors without any parsing
of their messages ([`pes_ref.oracle.case`][pes_ref.oracle.case]).
"""
from __future__ import annotations

from pes_ref.core.checks import InputError, InputTypeError

__all__ = ["CaseError", "CaseTypeError"]


class CaseError(InputError):
    """A case that breaks docs/spec.md section 8.

    The message is ``"case key '<key>': <reason>"``, one line.

    Parameters
    ----------
    key : str or None
        The case key at fault (None for a file that is not a readable ``.npz`` at all).
    reason : str
        What is wrong with it.
    """

    def __init__(self, key: str | None, reason: str):
        self.reason = " ".join(str(reason).split())
        super().__init__(key, self.reason if key is None else f"case key {key!r}: {self.reason}")


class CaseTypeError(CaseError, InputTypeError):
    """A case key holding the wrong kind of data (a string where a number belongs, a
    float ``n_steps``, an object array ...). Both a [`CaseError`][pes_ref.oracle.errors.CaseError] and a ``TypeError``."""
