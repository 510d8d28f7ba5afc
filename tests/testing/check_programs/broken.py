"""Wrappers around pes_ref's oracle that each break one thing, to show that
``pes_ref check`` catches it: ``python broken.py MODE CASE RESULT [CASE RESULT ...]``.

Modes: ``ok`` (the oracle itself), ``perturb`` (energy off by 1e-9 relative),
``no-damping`` (the velocity update without damping), ``other-side`` (positions on a
cell edge looked up in the cell below), ``omit-gradient`` (no grad_values), ``nan``
(NaN in x), ``accept-invalid`` (an invalid case gets a result and exit 0), ``hang``.
"""
import sys
import time

import numpy as np

from pes_ref.oracle.case import CaseError, load_case, run_case, write_result


def _on_edge_down(case: dict) -> dict:
    """x0 nudged one ulp down where it sits exactly on a grid line: the other side of the edge."""
    values, lower, upper = case["values"], case["lower"].astype(float), case["upper"].astype(float)
    periodic = case["periodic"].astype(bool)
    n = np.array(values.shape, dtype=float)
    h = (upper - lower) / np.where(periodic, n, n - 1)
    x0 = case["x0"].astype(float).copy()
    u = (x0 - lower) / h
    on = np.isclose(u, np.round(u), rtol=0, atol=1e-12)
    x0[on] = np.nextafter(x0[on], -np.inf)
    return {**case, "x0": x0}


def run(mode: str, case_path: str, result_path: str) -> int:
    if mode == "hang":
        time.sleep(3600)
    case = load_case(case_path)
    if mode == "no-damping":
        case = {**case, "damping": np.zeros_like(np.asarray(case["damping"], dtype=float))}
    if mode == "other-side":
        case = _on_edge_down(case)
    try:
        result = run_case(case)
    except CaseError as exc:
        if mode != "accept-invalid":
            print(f"error: {exc}", file=sys.stderr)
            return 2
        result = {"x": np.zeros((1, 1, 2)), "v": np.zeros((1, 1, 2)), "energy": np.zeros((1, 1)),
                  "loss": np.float64(0.0)}
    if mode == "perturb":
        result["energy"] = result["energy"] * (1 + 1e-9)
    if mode == "omit-gradient":
        result.pop("grad_values", None)
    if mode == "nan":
        result["x"] = result["x"].copy()
        result["x"][-1, 0, 0] = np.nan
    write_result(result, result_path, overwrite=True)
    return 0


def main(argv) -> int:
    mode, files = argv[0], argv[1:]
    status = 0
    for case_path, result_path in zip(files[::2], files[1::2]):
        status = max(status, run(mode, case_path, result_path))
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
