"""Conformance vectors: versioned oracle cases with their reference results.

In the style of Project Wycheproof, each version folder (``v1/``, ...) holds a
``manifest.json`` and, per vector, ``<id>.case.npz`` and (for valid vectors)
``<id>.result.npz`` in the interchange format of docs/spec.md sections 8-9
([`pes_ref.oracle.case`][pes_ref.oracle.case]). Valid vectors pin down trajectories and gradients; invalid
vectors are cases that a conforming reader must refuse, naming the key at fault.

A version, once shipped, is frozen: a change of docs/spec.md, of the format or of the vector set
makes a new folder (the next ``v<k>/``), and old folders stay readable. The files are made by
[`pes_ref.oracle.conformance.generate`][pes_ref.oracle.conformance.generate] (``python -m pes_ref
conformance --write``) and used by [`pes_ref.testing.conformance`][pes_ref.testing.conformance].
"""
from pathlib import Path

__all__ = ["LATEST", "vectors_dir"]

#: The newest vector set (v1 to v4, frozen, are still shipped and readable).
LATEST = "v5"


def vectors_dir(version: str = LATEST) -> Path:
    """The folder of a shipped vector set, e.g. ``.../pes_ref/oracle/conformance/v1``."""
    if not (isinstance(version, str) and version.startswith("v") and version[1:].isdigit()):
        raise ValueError(f"a vector version is 'v' plus a number, e.g. 'v1'; got {version!r}")
    return Path(__file__).resolve().parent / version
