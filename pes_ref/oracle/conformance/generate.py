"""Generate the conformance vectors (``python -m pes_ref conformance --write [DIR]``).

The set is built by [`pes_ref.oracle.conformance.families`][pes_ref.oracle.conformance.families],
written with its results and manifest by
[`pes_ref.oracle.conformance.writer`][pes_ref.oracle.conformance.writer] and compared with another
folder by [`pes_ref.oracle.conformance.compare`][pes_ref.oracle.conformance.compare]; this module is
the command the manifest names as its generator (`pes_ref.oracle.conformance.writer.GENERATOR`).
"""
from __future__ import annotations

import sys

from pes_ref.oracle.conformance.compare import compare_dirs
from pes_ref.oracle.conformance.families import VERSION, Vector, build_vectors
from pes_ref.oracle.conformance.writer import write_vectors

__all__ = ["VERSION", "Vector", "build_vectors", "write_vectors", "compare_dirs", "main"]


def main(argv=None) -> int:
    """``python -m pes_ref.oracle.conformance.generate [DIR]``: write the vectors."""
    argv = sys.argv[1:] if argv is None else argv
    manifest = write_vectors(argv[0] if argv else None, quiet=False)
    n_valid = sum(e["kind"] == "valid" for e in manifest["vectors"])
    print(f"{len(manifest['vectors'])} vectors ({n_valid} valid, {len(manifest['vectors']) - n_valid} invalid)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
