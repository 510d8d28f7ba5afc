"""Comparing two vector folders (a regenerated set against the shipped one)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from pes_ref.oracle import case as oracle
from pes_ref.oracle.compare import compare_results, passes

__all__ = ["compare_dirs"]


def _same_case(a: dict, b: dict) -> str | None:
    if sorted(a) != sorted(b):
        return f"case keys differ: {sorted(set(a) ^ set(b))}"
    for k in a:
        same_kind = a[k].dtype == b[k].dtype and a[k].shape == b[k].shape
        if not (same_kind and np.array_equal(a[k], b[k], equal_nan=a[k].dtype.kind in "fc")):
            return f"case key {k!r} differs"
    return None


def _compare_vector(entry: dict, other, want_dir: Path, got_dir: Path) -> tuple:
    vid = entry["id"]
    if other is None:
        return vid, False, float("inf"), "missing from the regenerated set"
    if other != entry:
        return vid, False, float("inf"), "manifest entry differs"
    if "file" in entry["flags"]:
        same = (want_dir / entry["case"]).read_bytes() == (got_dir / entry["case"]).read_bytes()
        detail = None if same else "case file differs"
    else:
        detail = _same_case(oracle.load_case(want_dir / entry["case"]), oracle.load_case(got_dir / entry["case"]))
    if detail is not None:
        return vid, False, float("inf"), detail
    if entry["kind"] != "valid":
        return vid, True, 0.0, "invalid case identical"
    errors = {}
    for name in [entry["result"]] + entry.get("one_sided", []):
        for k, e in compare_results(oracle.read_npz(got_dir / name, what="result"),
                                    oracle.read_npz(want_dir / name, what="result")).items():
            errors[k if name == entry["result"] else f"{name}:{k}"] = e
    bad = [k for k, e in errors.items() if not passes(k.rpartition(":")[2], e)]
    worst = max(errors.values(), default=0.0)
    return vid, not bad, worst, f"out of tolerance: {bad}" if bad else "ok"


def compare_dirs(want_dir, got_dir) -> list:
    """Compare a vector folder ``got_dir`` with ``want_dir`` (e.g. fresh against shipped).

    Cases must be identical; results must agree within the contract's tolerances.

    Returns
    -------
    list of (id, ok, max_error, detail)
        ``max_error`` is the largest normalized error of the result (see
        [`pes_ref.oracle.compare.compare_results`][pes_ref.oracle.compare.compare_results]); ``detail`` explains a
        failure.
    """
    want_dir, got_dir = Path(want_dir), Path(got_dir)
    want_m = json.loads((want_dir / "manifest.json").read_text(encoding="utf-8"))
    got_m = json.loads((got_dir / "manifest.json").read_text(encoding="utf-8"))
    rows = []
    got_entries = {e["id"]: e for e in got_m["vectors"]}
    for entry in want_m["vectors"]:
        other = got_entries.pop(entry["id"], None)
        try:
            rows.append(_compare_vector(entry, other, want_dir, got_dir))
        except (OSError, oracle.CaseError) as exc:
            rows.append((entry["id"], False, float("inf"), f"cannot read: {exc}"))
    for vid in got_entries:
        rows.append((vid, False, float("inf"), "not in the shipped set"))
    return rows
