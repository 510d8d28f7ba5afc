"""The oracle on extreme finite numbers: every float key of a case set to the largest, the
smallest (subnormal) and other extreme finite values, each sign, in the whole array or
one entry. Every outcome must be a finite result or one keyed, one-line refusal
(:class:`pes_ref.oracle.case.CaseError`), never another exception, and never a NumPy
warning (which a command line would print as more lines), under NumPy's default error
handling, as the command line runs."""
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pes_ref.oracle import conformance, load_case
from pes_ref.core.stability import check_stable
from pes_ref.oracle.case import CASE_KEYS, CaseError, run_case, validate_case
from pes_ref.oracle.from_scene import case_from_scene
from pes_ref.testing import draws
from pes_ref.testing import strategies as pst
from pes_ref.testing.conformance import load_manifest

VECTORS = {e["id"]: e for e in load_manifest(conformance.LATEST)["vectors"]}
#: Valid vectors that hold every float key between them: every objective, both modes,
#: springs, walls, a force schedule, t0, per-particle and per-axis masses.
BASES = ["everything-cylinder-q1", "walls-all-quasistatic", "force-window", "plane-dynamic",
         "spring-cylinder-q0-quasistatic", "torus-quasistatic", "mass-damping-per-particle-axis", "torus-dynamic"]
#: The keys of a case that hold floats (the others are strings, flags and n_steps).
FLOAT_KEYS = tuple(k for k in CASE_KEYS if k not in ("mode", "objective", "when", "periodic", "walls", "n_steps"))
EXTREMES = (1e308, -1e308, 5e-324, -5e-324, 1e-300, -1e-300, 1e300, -1e300)


def clean_outcome(case: dict):
    """``(outcome, fault)``: ``"result"`` or ``"refused"``, and what is wrong with it (``""``
    when nothing is): a result holding a non-finite number, a refusal without a case key or
    of more than one line, another exception, or a NumPy warning (under NumPy's default
    error handling, as the command line runs)."""
    fault = ""
    with np.errstate(over="warn", divide="warn", invalid="warn", under="ignore"), \
            warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = run_case(case)
        except CaseError as exc:
            outcome = "refused"
            if exc.key not in CASE_KEYS or "\n" in str(exc):
                fault = f"refusal {exc.key!r} {str(exc)!r}"
        except Exception as exc:   # noqa: BLE001 - what this test is watching for
            outcome, fault = "refused", f"{type(exc).__name__}: {exc}"
        else:
            outcome = "result"
            bad = [k for k, a in result.items() if not np.isfinite(a).all()]
            if bad:
                fault = f"a result with non-finite {bad}"
    if caught and not fault:
        fault = f"warned {caught[0].category.__name__}: {caught[0].message}"
    return outcome, fault


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
            outcome, fault = clean_outcome(case)
            outcomes[outcome] += 1
            if fault:
                faults.append(f"{key} = {value!r} ({where}): {fault}")
    assert not faults, "\n".join(faults[:20]) + f"\n({len(faults)} in all)"
    assert outcomes["result"] and outcomes["refused"], outcomes      # the table reaches both outcomes


# --------------------------------------------------------------------------- the fuzzed files and their classes

#: The fuzzed case files that once broke the oracle, and how each must end now: a result
#: finite everywhere, or a refusal naming the key (tests/oracle/fuzz-cases/README.md).
FUZZED = {"denormal-dt": ("result", None), "huge-force": ("refused", "dt"), "huge-weight": ("refused", "mobility")}
FUZZ_DIR = Path(__file__).resolve().parent / "fuzz-cases"


@pytest.mark.parametrize("name", sorted(FUZZED))
def test_fuzzed_files_end_cleanly(name):
    case = load_case(FUZZ_DIR / f"{name}.case.npz")
    outcome, fault = clean_outcome(case)
    assert (outcome, fault) == (FUZZED[name][0], "")
    if outcome == "refused":
        with pytest.raises(CaseError) as err:
            run_case(case)
        assert err.value.key == FUZZED[name][1]


@st.composite
def valid_cases(draw, kinds=draws.OBJECTIVE_KINDS, periodic: bool = False):
    """A valid case dict of the distribution of :mod:`pes_ref.testing.draws` that takes 2 to
    12 steps (a fault within a run needs a run); with ``periodic``, on a cylinder or a torus."""
    topology = draw(st.sampled_from(draws.TOPOLOGIES[1:])) if periodic else None
    scene, x0, v0 = draw(pst.scene_cases(max_particles=3, min_steps=2, max_steps=12, topology=topology))
    obj, reg = draw(pst.objectives(scene, x0.shape[0], kinds=kinds))
    return case_from_scene(scene, x0, v0, obj, regularization=reg)


#: The largest finite float64.
BIGGEST = float(np.finfo(np.float64).max)


def _huge(lowest: int = 10):
    """A finite number of magnitude 10**lowest to the largest float64, log-uniform, either sign."""
    return st.builds(lambda e, m, sign: sign * min(m * 10.0 ** e, BIGGEST),
                     st.integers(lowest, 308), st.floats(1.0, 10.0), st.sampled_from((1.0, -1.0)))


#: Tiny positive numbers: the smallest subnormals (a few times 5e-324, where ``dt sqrt(K/m) / 2``
#: or ``mobility K / 2`` rounds to 0), any subnormal, and the smallest normals.
TINY = st.one_of(st.integers(1, 8).map(lambda k: k * 5e-324), st.floats(5e-324, 1e-290),
                 st.sampled_from((2.2250738585072014e-308,)))


#: Examples per class (a quarter of the profile's: ``make test-thorough`` draws 10x as many).
CLASS_EXAMPLES = settings.default.max_examples // 4


def _assert_clean(case: dict) -> None:
    outcome, fault = clean_outcome(case)
    assert not fault, fault


@settings(max_examples=CLASS_EXAMPLES)
@given(case=valid_cases(), tiny=TINY, aim=st.one_of(st.none(), st.integers(1, 4)), both=st.booleans())
def test_tiny_steps_end_cleanly(case, tiny, aim, both):
    """Class of ``denormal-dt``: a subnormal or tiny dt (dynamic) or mobility (quasistatic);
    with ``aim``, one whose reach into the stability limit, ``dt sqrt(K/m)`` or ``mobility K``,
    is ``aim`` times the smallest subnormal (where half of it rounds to 0)."""
    key = "dt" if str(case["mode"]) == "dynamic" else "mobility"
    value = np.full(np.shape(case[key]), tiny)
    if aim is not None:
        reach = 2.0 * check_stable(validate_case(case).scene).ratio / np.max(case[key])   # per unit step
        if reach > 0.0:
            value[...] = aim * 5e-324 / reach
    if key == "mobility" and not both:
        value[1] = case["mobility"][1]
    case[key] = value
    _assert_clean(case)


@settings(max_examples=2 * CLASS_EXAMPLES)
@given(case=valid_cases(periodic=True), value=_huge(), where=st.sampled_from(("force", "v0", "x0")),
       every_step=st.booleans(), pick=st.integers(0, 5))
def test_positions_that_overflow_end_cleanly(case, value, where, every_step, pick):
    """Class of ``huge-force``: a huge external force (at one step or at every step), velocity
    or position of one particle, on a periodic axis if the case has one, sends a state
    far out (where a cell index loses its precision), or past float64, within the run."""
    axes = [d for d in range(2) if case["periodic"][d]] or [0, 1]
    i, d = pick % np.shape(case["x0"])[0], axes[pick % len(axes)]
    if where == "force":
        force = np.zeros((int(case["n_steps"]) + 1,) + np.shape(case["x0"]))
        force += case.get("force", 0.0)
        force[slice(None) if every_step else force.shape[0] // 2, i, d] = value
        case["force"] = force
    else:
        case[where] = np.array(case[where], dtype=np.float64)
        case[where][i, d] = value
    _assert_clean(case)


@settings(max_examples=CLASS_EXAMPLES)
@given(case=valid_cases(kinds=("quadratic",)), value=st.floats(1e306, BIGGEST),
       key=st.sampled_from(("wx", "wv", "regularization")), every=st.booleans())
def test_results_that_overflow_end_cleanly(case, value, key, every):
    """Class of ``huge-weight``: quadratic weights (in every entry or one) or a regularization
    so large that a loss term, the energy or a gradient leaves float64 while the trajectory
    stays finite, e.g. a sum of products of forces and weights."""
    if key == "regularization":
        case[key] = np.float64(abs(value))
    else:
        weights = np.zeros((int(case["n_steps"]) + 1,) + np.shape(case["x0"]))
        weights += case[key]
        weights[(...,) if every else (-1, 0, 0)] = value
        case[key] = weights
    _assert_clean(case)
