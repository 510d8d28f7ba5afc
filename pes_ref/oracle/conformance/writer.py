"""Writing a vector set: each vector's case file, its results from the oracle, and the manifest.

Valid vectors are run through [`pes_ref.oracle.case.run_case`][pes_ref.oracle.case.run_case] (the only source of
expected results); invalid ones through the oracle too, to check that it refuses them with
the declared key and error type. Every file is made in a hidden folder beside the target and
moved in once all are made, the manifest last.
"""
from __future__ import annotations

import json
import shutil
import tempfile
from pathlib import Path

from pes_ref.core.runtime.files import atomic_file, move_into
from pes_ref.oracle import case as oracle
from pes_ref.oracle import tolerances
from pes_ref.oracle.compare import compare_results, passes
from pes_ref.oracle.conformance import vectors_dir
from pes_ref.oracle.conformance.families import VERSION, Vector, build_vectors

__all__ = ["GENERATOR", "manifest_header", "write_vectors"]

#: The generator named in the manifest: this module. (The frozen v1 manifest names the
#: module path of the layout it was written in, ``pes_ref.conformance.generate``.)
GENERATOR = "pes_ref.oracle.conformance.generate"

def _expected_refusal(vec: Vector, path: Path) -> str:
    """Run the oracle on an invalid vector's file (reading, validating, and running if
    it gets that far) and check that it refuses as declared."""
    try:
        oracle.run_case(path)
    except oracle.CaseError as exc:
        got = "TypeError" if isinstance(exc, TypeError) else "ValueError"
        if exc.key != vec.key or got != vec.error:
            raise RuntimeError(f"invalid vector {vec.id}: the oracle refused key {exc.key!r} with {got}, "
                               f"declared {vec.key!r} with {vec.error} ({exc})") from None
        return str(exc)
    raise RuntimeError(f"invalid vector {vec.id}: the oracle accepted it")


def _entry(tc_id: int, vec: Vector) -> dict:
    entry = {"tc_id": tc_id, "id": vec.id, "comment": vec.comment, "kind": vec.kind,
             "flags": list(vec.flags), "case": f"{vec.id}.case.npz"}
    if vec.kind == "valid":
        entry["result"] = f"{vec.id}.result.npz"
        if "kink" in vec.flags:
            entry["one_sided"] = [f"{vec.id}.{name}.result.npz" for name in vec.other_sides]
    else:
        entry["key"] = vec.key
        entry["error"] = vec.error
    return entry


def manifest_header() -> dict:
    """The manifest's fixed part: format, version, tolerances, flags."""
    return {
        "format": "pes_ref conformance vectors (docs/spec.md sections 8-9 case/result .npz files)",
        "version": VERSION,
        "spec": f"docs/spec.md (spec {VERSION})",
        "generator": GENERATOR,
        "tolerances": {
            "TRAJ_RTOL": tolerances.TRAJ_RTOL, "TRAJ_ATOL": tolerances.TRAJ_ATOL,
            "GRAD_RTOL": tolerances.GRAD_RTOL, "GRAD_ATOL": tolerances.GRAD_ATOL,
            "rule": "|got - want| <= atol + rtol |want| per entry; trajectory keys (x, v, energy, loss) "
                    "use TRAJ_*, gradient keys (grad_*) use GRAD_RTOL and GRAD_ATOL * max|want| "
                    "(max|want| taken as 1 for an all-zero gradient)",
            "kink": "on vectors flagged 'kink' x, v, energy and loss bind as everywhere; each gradient entry "
                    "must match the result or any file listed under 'one_sided' (the other one-sided "
                    "gradients, docs/spec.md 7.3); strict mode compares with the result only",
        },
        "flags": {
            "kink": "a state sits exactly on a kink of docs/spec.md 7.3 (node, seam, clip edge, wall onset)",
            "zero-root": "the oscillator's root argument is exactly 0 at some step (its derivative is 0 there)",
            "dtype": "integer inputs: numbers read as float64, flags (periodic, walls) of 0 and 1",
            "wide-margin": "a single wall of an axis with wall_margin >= half the axis's length, valid: the room "
                           "rule binds only two walls of one axis (docs/spec.md 8.6)",
            "near-edge": "a state 1e-9 below or above an interior cell edge, off it: looked up in the cell floor "
                         "picks from the float64 u (docs/spec.md 2.3), where a float32 u rounds onto the edge",
            "limit": "a case 1% inside (valid) or past (refused) the stability rule of docs/spec.md section 10, "
                     "or exactly at it (valid), built so that a misreading of the rule lands on the wrong side",
            "edge": "a value at the edge of its key's valid range (a stiffness or margin of 0, a subnormal "
                    "dt, mobility or wall_k, one ulp inside the room rule, one particle and no step)",
            "file": "the case file itself breaks docs/spec.md 8.1: written byte for byte, it has no case dict",
            "nonfinite": "valid by sections 8 and 10, refused when run: its numbers leave the finite range (12.1)",
        },
    }


def _write_case(vec: Vector, path: Path) -> None:
    if vec.file is not None:
        with atomic_file(path, overwrite=True, what="case") as fh:
            fh.write(vec.file)
    else:
        oracle.save_case(path, overwrite=True, compress=True, **vec.case)   # shipped deflated, as in v1


def _other_side(vec: Vector, name: str, result: dict, case: dict) -> dict:
    """The gradients of the case with its kink state moved to the other side (``name``),
    checked to keep the trajectory within tolerance (the nudge is one ulp)."""
    other = oracle.run_case(vec.other_sides[name](case))
    errors = compare_results(other, result, ["x", "v", "energy", "loss"])
    if not all(passes(k, e) for k, e in errors.items()):
        raise RuntimeError(f"kink vector {vec.id}: the {name} side moves the trajectory by {errors}")
    return {k: v for k, v in other.items() if k.startswith("grad_")}


def write_vectors(directory=None, *, quiet: bool = True) -> dict:
    """Build every vector, write its files and the manifest into ``directory``.

    Parameters
    ----------
    directory : path, optional
        Default: the shipped folder of this version, ``pes_ref/oracle/conformance/v5``.
        Created if missing; vector files of this naming scheme that are no longer
        part of the set are removed. Every file is made in a hidden folder beside it
        first and moved in once all are made, the manifest last: a run stopped part-way
        (Ctrl-C, a closed pipe) leaves ``directory`` as it was.

    Returns
    -------
    dict
        The manifest.
    """
    directory = Path(vectors_dir(VERSION) if directory is None else directory)
    directory.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{directory.name}.", suffix=".tmp", dir=directory.parent))
    try:
        entries = []
        for tc_id, vec in enumerate(build_vectors(), start=1):
            entry = _entry(tc_id, vec)
            path = staging / entry["case"]
            _write_case(vec, path)
            if vec.kind == "invalid":
                _expected_refusal(vec, path)
            else:
                case = oracle.load_case(path)
                result = oracle.run_case(case)
                oracle.write_result(result, staging / entry["result"], overwrite=True, compress=True)
                for name, file in zip(vec.other_sides, entry.get("one_sided", ())):
                    oracle.write_result(_other_side(vec, name, result, case), staging / file, overwrite=True,
                                        compress=True)
            entries.append(entry)
            if not quiet:
                print(f"wrote {vec.kind:7s} {vec.id}")
        directory.mkdir(exist_ok=True)
        move_into(sorted(staging.glob("*.npz")), directory)
        keep = {e["case"] for e in entries} | {e["result"] for e in entries if "result" in e}
        keep |= {f for e in entries for f in e.get("one_sided", ())}
        stale = [p for p in sorted(directory.glob("*.npz")) if p.name not in keep
                 and (p.name.endswith(".case.npz") or p.name.endswith(".result.npz"))]
        for path in stale:
            path.unlink()
        manifest = dict(manifest_header(), vectors=entries)
        with atomic_file(directory / "manifest.json", overwrite=True, what="manifest") as fh:
            fh.write((json.dumps(manifest, indent=1) + "\n").encode("utf-8"))
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    for path in stale if not quiet else ():
        print(f"removed stale {path.name}")
    return manifest


