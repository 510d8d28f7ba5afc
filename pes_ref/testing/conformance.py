"""Check another implementation against the shipped conformance vectors.

The vectors ([`pes_ref.oracle.conformance`][pes_ref.oracle.conformance]) are oracle cases with their reference results
(docs/spec.md sections 8-9). An implementation plugs in one function per check:

- [`check_simulate`][pes_ref.testing.conformance.check_simulate]: ``simulate_fn(case) -> {"x", "v", "energy"}``
- [`check_gradients`][pes_ref.testing.conformance.check_gradients]: ``grad_fn(case) -> {"loss", "grad_<name>", ...}``
- [`check_invalid`][pes_ref.testing.conformance.check_invalid]: ``load_fn(path)`` must refuse every invalid case file
  with a
  ``ValueError`` or ``TypeError`` whose message names the key at fault (and accept
  every valid one)

where ``case`` is a dict of NumPy arrays as read by ``np.load(path, allow_pickle=False)``
(strings are 0-d unicode arrays). Each check returns a list of
[`VectorReport`][pes_ref.testing.conformance.VectorReport]
and raises ``AssertionError`` listing every failing vector. The rules that decide a
verdict live here once and ``pes_ref check`` ([`pes_ref.testing.check`][pes_ref.testing.check]) uses them too:
which arrays bind on a vector ([`binding_keys`][pes_ref.testing.conformance.binding_keys]), the one-sided gradients
accepted on
a kink ([`one_sided_results`][pes_ref.testing.conformance.one_sided_results],
[`compare_vector`][pes_ref.testing.conformance.compare_vector]), and whether a refusal's
message names the key at fault ([`names_key`][pes_ref.testing.conformance.names_key]).

Examples
--------
>>> from pes_ref import oracle
>>> from pes_ref.testing import conformance
>>> reports = conformance.check_gradients(oracle.run_case)   # doctest: +SKIP

The comparison is [`pes_ref.oracle.compare`][pes_ref.oracle.compare] (re-exported here:
[`compare_results`][pes_ref.oracle.compare.compare_results],
[`passes`][pes_ref.oracle.compare.passes], `TRAJECTORY_KEYS`). Tolerances
([`pes_ref.oracle.tolerances`][pes_ref.oracle.tolerances]): an entry passes when
``|got - want| <= atol + rtol |want|``. Trajectory keys (``x``, ``v``, ``energy``,
``loss``) use ``TRAJ_RTOL``/``TRAJ_ATOL``; gradients use ``GRAD_RTOL`` and
``GRAD_ATOL * max|want|`` (the largest entry of that gradient, or 1 for an all-zero one).
The single number reported per array is ``max |got - want| / (atol/rtol + |want|)``, a
relative error with a floor; the array passes when it is ``<= rtol``. On vectors
flagged ``kink`` (a state exactly on a node, seam, clip edge or wall onset, where
docs/spec.md 2.5 owes a one-sided value) each gradient entry binds to the result or to one
of the results the manifest entry lists under ``one_sided`` (from v3 on); a kink vector
without that list (v1, v2) binds only the trajectory and the loss.
"""
from __future__ import annotations

import json
import re
from pathlib import Path
from typing import NamedTuple

import numpy as np

from pes_ref.oracle.case import TRAJECTORY_KEYS
from pes_ref.oracle.compare import array_error, compare_results, passes
from pes_ref.oracle.conformance import LATEST, vectors_dir

__all__ = ["VectorReport", "load_manifest", "iter_vectors", "compare_results",
           "passes", "check_simulate", "check_gradients", "check_invalid", "TRAJECTORY_KEYS", "binding_keys",
           "one_sided_results", "compare_vector", "names_key", "is_file_vector"]

_SIMULATE_KEYS = ("x", "v", "energy")
#: Gradients that a quasistatic implementation may omit (docs/spec.md section 7); if given, they must be zero.
_QUASISTATIC_ZERO = ("grad_v0", "grad_mass", "grad_damping")


class VectorReport(NamedTuple):
    """The outcome of one vector in one check.

    Attributes
    ----------
    id : str
    ok : bool
    errors : dict of str -> float
        Normalized error per compared array (inf: missing, wrong shape or not finite).
    note : str
        What failed, or what was skipped.
    """

    id: str
    ok: bool
    errors: dict
    note: str = ""

    def __str__(self):
        worst = max(self.errors.values(), default=0.0)
        return f"{'ok' if self.ok else 'FAIL':4s}  {self.id:40s} max rel err {worst:.1e}  {self.note}".rstrip()


# =========================================================================== reading vectors

def _dir(version: str, directory) -> Path:
    return Path(directory) if directory is not None else vectors_dir(version)


def load_manifest(version: str = LATEST, *, directory=None) -> dict:
    """The ``manifest.json`` of a vector set (``directory`` overrides the shipped folder)."""
    return json.loads((_dir(version, directory) / "manifest.json").read_text(encoding="utf-8"))


_CACHE: dict = {}


def _read(path: Path) -> dict:
    """The arrays of an ``.npz`` file (fresh copies; files are read once per change)."""
    st = path.stat()
    key = (str(path.resolve()), st.st_mtime_ns, st.st_size)
    if key not in _CACHE:
        with np.load(path, allow_pickle=False) as npz:
            _CACHE[key] = {k: npz[k] for k in npz.files}
    return {k: v.copy() for k, v in _CACHE[key].items()}


def is_file_vector(entry: dict) -> bool:
    """Whether a vector's case file itself breaks the container rules (docs/spec.md 8.1:
    not an ``.npz``, a damaged zip, a member that needs pickle or is not an array): it
    has no case dict, only its bytes (manifest flag ``file``)."""
    return "file" in entry.get("flags", ())


def one_sided_results(entry: dict, version: str = LATEST, *, directory=None) -> list:
    """The other one-sided gradients a kink vector accepts besides its result: the
    ``grad_*`` arrays of each file its manifest entry lists under ``one_sided`` (empty
    for a vector without that field)."""
    folder = _dir(version, directory)
    return [_read(folder / name) for name in entry.get("one_sided", ())]


def binding_keys(entry: dict, want: dict, *, strict: bool = False) -> list:
    """The result keys that bind on a valid vector (docs/spec.md 2.5, 7.3, 11).

    Every key of the reference result, except on a vector flagged ``kink`` whose entry
    lists no ``one_sided`` results (the v1 and v2 vectors): there only ``x``, ``v``,
    ``energy`` and ``loss`` bind, unless ``strict`` (then the gradients are compared
    with the reference's one-sided choice).
    """
    if "kink" in entry.get("flags", ()) and "one_sided" not in entry and not strict:
        return [k for k in want if k in TRAJECTORY_KEYS]
    return list(want)


def compare_vector(got: dict, want: dict, names, alternatives=()) -> dict:
    """[`compare_results`][pes_ref.oracle.compare.compare_results] of ``names``, where each gradient entry may instead
    match the same entry of any of ``alternatives`` (the other one-sided results of a kink,
    [`one_sided_results`][pes_ref.testing.conformance.one_sided_results]): per entry, the closest of
    the accepted values is the one compared."""
    errors = compare_results(got, want, names)
    for k in names:
        alts = [a[k] for a in alternatives if k in a]
        if not alts or k not in got or not np.isfinite(errors[k]):
            continue
        g = np.asarray(got[k], dtype=np.float64)
        closest = np.asarray(want[k], dtype=np.float64)
        for alt in alts:
            closest = np.where(np.abs(g - alt) < np.abs(g - closest), alt, closest)
        errors[k] = array_error(k, g, closest)
    return errors


_DECLARED_KEY = re.compile(r"case key '([^']*)'")


def names_key(message: str, key) -> bool:
    """Whether a refusal's message names the key at fault (docs/spec.md 8.7).

    A message that declares a key in the reference's form, ``case key '<name>'``, names
    the first key it so declares; any other message names every key that appears in it
    as a whole word (not inside a longer name: ``v0`` is not named by ``grad_v0``). A
    case refused without a key (``key`` None: a file that is not an ``.npz``) needs only
    a message.
    """
    if key is None:
        return bool(message.strip())
    declared = _DECLARED_KEY.search(message)
    if declared is not None:
        return declared.group(1) == key
    return re.search(rf"(?<![\w]){re.escape(key)}(?![\w])", message) is not None


def iter_vectors(version: str = LATEST, kind: str = "valid", *, directory=None):
    """Yield the vectors of a set.

    Parameters
    ----------
    version : str
        "v1", ...
    kind : {"valid", "invalid", "all"}
    directory : path, optional
        Read this folder instead of the shipped one.

    Yields
    ------
    entry : dict
        The manifest entry (``id``, ``comment``, ``kind``, ``flags``, ``case``, and
        ``result`` (and ``one_sided``) or ``key`` and ``error``).
    case : dict of str -> ndarray, or None
        None for a vector whose case file is not a readable case
        ([`is_file_vector`][pes_ref.testing.conformance.is_file_vector]).
    expected : dict of str -> ndarray, or None for an invalid vector
    """
    if kind not in ("valid", "invalid", "all"):
        raise ValueError(f"kind must be 'valid', 'invalid' or 'all', got {kind!r}")
    folder = _dir(version, directory)
    for entry in load_manifest(version, directory=folder)["vectors"]:
        if kind != "all" and entry["kind"] != kind:
            continue
        case = None if is_file_vector(entry) else _read(folder / entry["case"])
        expected = _read(folder / entry["result"]) if entry["kind"] == "valid" else None
        yield entry, case, expected


# =========================================================================== comparing

# =========================================================================== the checks

def _finish(reports: list, what: str) -> list:
    failed = [r for r in reports if not r.ok]
    if failed:
        lines = "\n".join(str(r) for r in failed)
        raise AssertionError(f"{what}: {len(failed)} of {len(reports)} conformance vectors fail\n{lines}")
    return reports


def _call(fn, arg):
    try:
        return fn(arg), None
    except Exception as exc:   # the implementation under test may raise anything
        return None, f"raised {type(exc).__name__}: {exc}"


def _run_valid(fn, compare, version, directory) -> list:
    """Call ``fn(case)`` on every valid vector; a raise fails that vector, otherwise
    ``compare(entry, case, got, want)`` makes its report."""
    reports = []
    for entry, case, want in iter_vectors(version, "valid", directory=directory):
        got, failure = _call(fn, case)
        reports.append(VectorReport(entry["id"], False, {}, failure) if failure is not None
                       else compare(entry, case, got, want))
    return reports


def _report(vid: str, errors: dict, note: str = "") -> VectorReport:
    bad = [k for k, e in errors.items() if not passes(k, e)]
    if bad:
        note = (f"out of tolerance: {bad} " + note).strip()
    return VectorReport(vid, not bad, errors, note)


def check_simulate(simulate_fn, version: str = LATEST, *, directory=None) -> list:
    """Compare ``simulate_fn(case)``'s ``x``, ``v`` and ``energy`` with every valid vector.

    Returns
    -------
    list of VectorReport

    Raises
    ------
    AssertionError
        Listing every vector whose trajectory is out of ``TRAJ_RTOL``/``TRAJ_ATOL``.
    """
    def compare(entry, case, got, want):
        return _report(entry["id"], compare_results(got, want, _SIMULATE_KEYS))
    return _finish(_run_valid(simulate_fn, compare, version, directory), "check_simulate")


def _gradient_names(entry: dict, want: dict, strict_kinks: bool):
    names = ["loss"] + sorted(k for k in binding_keys(entry, want, strict=strict_kinks) if k.startswith("grad_"))
    if len(names) == 1 and "kink" in entry["flags"]:
        return names, "kink: gradients not binding, only the loss compared"
    return names, ""


def _extra_zero_grads(case: dict, got: dict, want: dict) -> dict:
    """Quasistatic gradients of v0, mass, damping that an implementation chose to return: must be 0."""
    if str(case["mode"]) != "quasistatic":
        return {}
    out = {}
    for key in _QUASISTATIC_ZERO:
        if key in got and key not in want:
            src = np.shape(case[key[len("grad_"):]])
            out[key] = array_error(key, got[key], np.zeros(src))
    return out


def check_gradients(grad_fn, version: str = LATEST, *, directory=None, strict_kinks: bool = False) -> list:
    """Compare ``grad_fn(case)``'s ``loss`` and every ``grad_<name>`` with the valid vectors.

    Parameters
    ----------
    grad_fn : callable, case dict -> dict
        Must return ``loss`` and each ``grad_<name>`` that the expected result holds
        (shaped like the case's input); ``grad_v0``, ``grad_mass``, ``grad_damping``
        of a quasistatic case may be omitted, and must be zero if given. Other extra
        keys are ignored.
    strict_kinks : bool
        On vectors flagged ``kink`` compare the gradients with the reference's one-sided
        choice only. By default a kink vector accepts the one-sided results its manifest
        entry lists (docs/spec.md 7.3), and one that lists none (v1, v2) binds no gradient.

    Returns
    -------
    list of VectorReport

    Raises
    ------
    AssertionError
        Listing every vector out of tolerance.
    """
    folder = _dir(version, directory)

    def compare(entry, case, got, want):
        names, note = _gradient_names(entry, want, strict_kinks)
        others = () if strict_kinks else one_sided_results(entry, directory=folder)
        errors = compare_vector(got, want, names, others)
        errors.update(_extra_zero_grads(case, got, want))
        return _report(entry["id"], errors, note)
    return _finish(_run_valid(grad_fn, compare, version, directory), "check_gradients")


def _refusal(entry: dict, path: Path, load_fn, require_key: bool, strict_types: bool) -> VectorReport:
    try:
        load_fn(str(path))
    except (ValueError, TypeError) as exc:
        message = str(exc)
        if "\n" in message.strip():
            return VectorReport(entry["id"], False, {}, f"message is more than one line: {message!r}")
        if require_key and not names_key(message, entry["key"]):
            return VectorReport(entry["id"], False, {}, f"message does not name key {entry['key']!r}: {message!r}")
        declared = TypeError if entry["error"] == "TypeError" else ValueError
        if strict_types and not isinstance(exc, declared):
            return VectorReport(entry["id"], False, {}, f"raised {type(exc).__name__}, expected {entry['error']}")
        return VectorReport(entry["id"], True, {}, f"refused: {message}")
    except Exception as exc:
        return VectorReport(entry["id"], False, {}, f"raised {type(exc).__name__} (not ValueError/TypeError): {exc}")
    return VectorReport(entry["id"], False, {}, f"accepted an invalid case (key {entry['key']!r})")


def check_invalid(load_fn, version: str = LATEST, *, directory=None, require_key: bool = True,
                  strict_types: bool = False, check_valid: bool = True) -> list:
    """Check that ``load_fn(path)`` refuses every invalid case file, and accepts the valid ones.

    The invalid vectors flagged ``nonfinite`` are valid cases whose run leaves the finite
    numbers (docs/spec.md 12.1): a reader refuses them only by running them, so they are
    left out here (``pes_ref check`` runs them).

    Parameters
    ----------
    load_fn : callable, str -> anything
        Your implementation's reader and validator of a case file (e.g.
        ``lambda p: my_load(dict(np.load(p)))``). It must raise ``ValueError`` or
        ``TypeError`` on an invalid case.
    require_key : bool
        The one-line message must name the key at fault
        ([`names_key`][pes_ref.testing.conformance.names_key], docs/spec.md section 8.7).
    strict_types : bool
        Also require the manifest's error type (``TypeError`` for data of the wrong
        kind, ``ValueError`` otherwise).
    check_valid : bool
        Also require that no valid case is refused (a loader that refuses everything
        fails).

    Returns
    -------
    list of VectorReport

    Raises
    ------
    AssertionError
        Listing every case handled wrongly.
    """
    folder = _dir(version, directory)
    reports = []
    for entry in load_manifest(version, directory=folder)["vectors"]:
        path = folder / entry["case"]
        if entry["kind"] == "invalid":
            if "nonfinite" not in entry["flags"]:
                reports.append(_refusal(entry, path, load_fn, require_key, strict_types))
        elif check_valid:
            _, failure = _call(load_fn, str(path))
            reports.append(VectorReport(entry["id"], failure is None, {},
                                        "accepted" if failure is None else f"valid case refused: {failure}"))
    return _finish(reports, "check_invalid")
