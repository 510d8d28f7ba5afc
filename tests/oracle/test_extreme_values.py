"""The oracle on extreme finite numbers: every float key of a case set to the largest, the
smallest (subnormal) and other extreme finite values, each sign, in the whole array or
one entry. Every outcome must be a finite result or one keyed, one-line refusal
(:class:`pes_ref.oracle.case.CaseError`), never another exception, and never a NumPy
warning (which a command line would print as more lines), under NumPy's default error
handling, as the command line runs."""
import warnings

import numpy as np
import pytest

from pes_ref.oracle import conformance, load_case
from pes_ref.oracle.case import CASE_KEYS, CaseError, run_case
from pes_ref.testing.conformance import load_manifest

VECTORS = {e["id"]: e for e in load_manifest(conformance.LATEST)["vectors"]}
#: Valid vectors that hold every float key between them: every objective, both modes,
#: springs, walls, a force schedule, t0, per-particle and per-axis masses.
BASES = ["everything-cylinder-q1", "walls-all-quasistatic", "force-window", "plane-dynamic",
         "spring-cylinder-q0-quasistatic", "torus-quasistatic", "mass-damping-per-particle-axis", "torus-dynamic"]
#: The keys of a case that hold floats (the others are strings, flags and n_steps).
FLOAT_KEYS = tuple(k for k in CASE_KEYS if k not in ("mode", "objective", "when", "periodic", "walls", "n_steps"))
EXTREMES = (1e308, -1e308, 5e-324, -5e-324, 1e-300, -1e-300, 1e300, -1e300)


def _base(cid: str) -> dict:
    return load_case(conformance.vectors_dir(conformance.LATEST) / VECTORS[cid]["case"])


def _variants(case: dict, key: str):
    """``(value, where, changed case)`` for every extreme value, in the whole array and in one entry."""
    arr = np.array(case[key], dtype=np.float64)
    for value in EXTREMES:
        for where in ("all", "one") if arr.size > 1 else ("all",):
            new = np.full_like(arr, value) if where == "all" else arr.copy()
            if where == "one":
                new.flat[arr.size // 2] = value
            yield value, where, dict(case, **{key: new})


def test_the_bases_hold_every_float_key():
    held = set().union(*(_base(cid) for cid in BASES))
    assert set(FLOAT_KEYS) <= held, sorted(set(FLOAT_KEYS) - held)


@pytest.mark.parametrize("cid", BASES)
def test_extreme_values_give_a_result_or_a_keyed_one_line_refusal(cid):
    base = _base(cid)
    outcomes = {"result": 0, "refused": 0}
    faults = []
    for key in FLOAT_KEYS:
        if key not in base:
            continue
        for value, where, case in _variants(base, key):
            label = f"{key} = {value!r} ({where})"
            with np.errstate(over="warn", divide="warn", invalid="warn", under="ignore"), \
                    warnings.catch_warnings(record=True) as caught:      # NumPy's defaults
                warnings.simplefilter("always")
                try:
                    result = run_case(case)
                except CaseError as exc:
                    outcomes["refused"] += 1
                    if not exc.key or "\n" in str(exc) or not str(exc):
                        faults.append(f"{label}: refusal {exc.key!r} {str(exc)!r}")
                except Exception as exc:   # noqa: BLE001 - what this test is watching for
                    faults.append(f"{label}: {type(exc).__name__}: {exc}")
                else:
                    outcomes["result"] += 1
                    bad = [k for k, a in result.items() if not np.isfinite(a).all()]
                    if bad:
                        faults.append(f"{label}: a result with non-finite {bad}")
            if caught:
                faults.append(f"{label}: warned {caught[0].category.__name__}: {caught[0].message}")
    assert not faults, "\n".join(faults[:20]) + f"\n({len(faults)} in all)"
    assert outcomes["result"] and outcomes["refused"], outcomes      # the table reaches both outcomes
