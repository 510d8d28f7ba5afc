"""Conformance of any implementation, in any language, through its command line.

``python -m pes_ref check --cmd "PROGRAM {case} {result}"`` runs a program on cases of
the interchange format (docs/spec.md sections 8-9) and judges what it does by the rules
of docs/spec.md sections 11 and 13:

- **the shipped vectors** ([`pes_ref.oracle.conformance`][pes_ref.oracle.conformance]): each valid case must be
  run and its result must match the shipped one within the tolerances of section 11
  ([`pes_ref.testing.conformance.binding_keys`][pes_ref.testing.conformance.binding_keys]: on a kink
  the gradients bind to the one-sided results the manifest lists); each invalid case must end with a
  non-zero exit status, write no result, and say which key is at fault (the last line it prints on
  stderr for the case names it,
  [`pes_ref.testing.conformance.names_key`][pes_ref.testing.conformance.names_key]; or, with
  ``{refusals}``, its record does);
- **fresh random cases** (``--random N --seed S``): drawn by [`pes_ref.testing.draws`][pes_ref.testing.draws]
  from a `numpy.random.Generator` seeded with ``[S, attempt]`` (no hypothesis
  needed), every topology, mode, effect, objective and broadcast shape, and at the odds
  `pes_ref.testing.draws.CHECK_ODDS` a single wall's margin past half its axis,
  positions snapped near cell edges, flags stored as 0/1 integers, and a step scaled just
  inside or just past the stability rule's limit (a case past it must be refused naming
  ``dt`` or ``mobility``); pes_ref runs each and so does the program. Only well-conditioned
  cases are kept: a perturbation of ``x0`` by `PROBE` (relative) must grow by at most `CONDITION_BOUND`
  anywhere in the trajectory, so that two correct programs, which may differ by an ulp
  per operation, agree within the trajectory tolerance. Long runs on rough bilinear
  grids amplify such differences by about 1.4x per step; the filter keeps them out.

The program is named by a template, split like a shell command line (``shlex``; no
shell is involved):

- ``{case}`` and ``{result}``: the paths of one case and of its result: one process per case;
- ``{pairs}``: ``CASE1 RESULT1 CASE2 RESULT2 ...``: the valid and random cases in one
  process, and the invalid ones in one more. A program answers each invalid case of a
  run by writing nothing for it and printing a line on stderr that holds the case's path
  (``error: <case path>: case key ...``, as pes_ref's oracle prints it); an invalid case
  that no line of the run names (a program that stops at the first refusal, or prints no
  path) is run again in a process of its own, whose exit status is then its answer;
- ``{refusals}`` (optional): the path of a file the program appends one JSON line to per
  case it refuses: ``{"case": "<case path>", "key": "<key or null>", "error":
  "ValueError" | "TypeError"}``. Its record then answers for the case, and strict mode
  (``--strict``) needs it, to tell a ``TypeError`` from a ``ValueError``.

Strict mode also compares every gradient of a kink vector with the reference's own
one-sided choice. ``--lenient-messages`` skips only the check that the refusal names the
key (for programs that conform at levels S and G only).

The same check runs on a Python function ([`check`][pes_ref.testing.check.check] with ``runner`` a callable
``case dict -> result dict`` that raises ``ValueError``/``TypeError`` on an invalid case,
naming the key); vectors whose case file itself is broken (docs/spec.md 8.1) test reading
a file, which a function of a dict does not do, and are left out for it.
"""
from __future__ import annotations

import json
import math
import shlex
import shutil
import subprocess
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from pes_ref.core.runtime.files import atomic_file
from pes_ref.oracle.case import TRAJECTORY_KEYS, CaseError, run_case, save_case, validate_case
from pes_ref.oracle.compare import passes
from pes_ref.oracle.conformance import LATEST, vectors_dir
from pes_ref.oracle.from_scene import case_from_scene
from pes_ref.oracle.tolerances import GRAD_RTOL, TRAJ_RTOL
from pes_ref.testing import draws
from pes_ref.testing.conformance import (binding_keys, compare_vector, iter_vectors, names_key,
                                         one_sided_results)

__all__ = ["CaseOutcome", "CheckReport", "check", "draw_cases", "refusal_key", "condition_number", "write_report",
           "PROBE", "CONDITION_BOUND", "Program"]

#: The relative perturbation of ``x0`` that measures a case's conditioning.
PROBE = 1e-10
#: The largest growth of that perturbation a fresh case may have. One-ulp differences
#: (about 1.1e-16 relative) grown by this stay below 1e-13, a tenth of ``TRAJ_RTOL``.
CONDITION_BOUND = 1e3
#: Gradients a quasistatic result may hold although none is owed; each must then be zero.
_QUASISTATIC_OPTIONAL = ("grad_v0", "grad_mass", "grad_damping")
#: How much of a program's stderr a verdict quotes.
_QUOTE = 300
#: The dtype of every array of a result (docs/spec.md section 9): float64, little-endian.
RESULT_DTYPE = "<f8"


def _tolerance(name: str) -> float:
    """The bound on the normalized error of array ``name`` (docs/spec.md section 11)."""
    return TRAJ_RTOL if name in TRAJECTORY_KEYS else GRAD_RTOL


# =========================================================================== outcomes

@dataclass
class CaseOutcome:
    """The verdict on one case.

    Attributes
    ----------
    case_id : str
    ok : bool
    kind : {"valid", "invalid", "random"}
        A valid or an invalid shipped vector, or a fresh random case (valid).
    array : str
        Valid cases: the array that decided the verdict: the failing one, or the one
        closest to its tolerance.
    error, tolerance : float or None
        That array's normalized error and the bound it is held to (``TRAJ_RTOL`` for
        ``x, v, energy, loss``, ``GRAD_RTOL`` for a gradient); None when nothing was compared.
    key : str or None
        Invalid vectors: the key at fault that the manifest declares (None for a file
        that is not an ``.npz``).
    detail : str
        What happened, in words.
    seconds : float or None
        The wall time of the case's own process (or function call); None when it ran in
        a process with other cases (the batch's time is in `CheckReport.batches`).
    errors : dict of str -> float
        Every array compared and its normalized error.
    batch : int or None
        The index in `CheckReport.batches` of the process whose exit status the
        verdict read (None for a Python function).
    """

    case_id: str
    ok: bool
    kind: str = "valid"
    array: str = ""
    error: float | None = None
    tolerance: float | None = None
    key: str | None = None
    detail: str = ""
    seconds: float | None = None
    errors: dict = field(default_factory=dict)
    batch: int | None = None

    def line(self) -> str:
        """The case's line of ``pes_ref check``'s output: ``ok    ID``, or ``FAIL  ID`` with the array (an
        invalid vector: the key) and what happened."""
        if self.ok:
            return f"ok    {self.case_id}"
        if self.kind == "invalid":
            return f"FAIL  {self.case_id}  {self.key if self.key is not None else '(no key)'}: {self.detail}"
        return f"FAIL  {self.case_id}  {self.array + ': ' if self.array else ''}{self.detail}"


@dataclass
class CheckReport:
    """Every case's outcome, the processes that ran them, and the settings."""

    outcomes: list = field(default_factory=list)
    settings: dict = field(default_factory=dict)
    batches: list = field(default_factory=list)

    @property
    def passed(self) -> int:
        """The number of cases that passed."""
        return sum(o.ok for o in self.outcomes)

    @property
    def failed(self) -> int:
        """The number of cases that failed."""
        return len(self.outcomes) - self.passed

    @property
    def ok(self) -> bool:
        """Whether every case passed, and at least one ran."""
        return self.failed == 0 and bool(self.outcomes)

    def summary(self) -> str:
        """``"P passed, F failed"``, the last line of ``pes_ref check``."""
        return f"{self.passed} passed, {self.failed} failed"

    def to_json(self) -> dict:
        """The report as JSON data (a non-finite error is written as null)."""
        return _finite({"settings": self.settings, "passed": self.passed, "failed": self.failed,
                        "batches": self.batches, "cases": [asdict(o) for o in self.outcomes]})


def _finite(data):
    """``data`` with every non-finite float replaced by None (JSON has no inf or NaN)."""
    if isinstance(data, dict):
        return {k: _finite(v) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return [_finite(v) for v in data]
    if isinstance(data, float) and not math.isfinite(data):
        return None
    return data


# =========================================================================== drawing fresh cases

def condition_number(case: dict) -> float:
    """How much a relative perturbation `PROBE` of ``x0`` grows over the run.

    ``max_n |x'_n - x_n| / (PROBE * scale)`` over positions and velocities, with ``x'``
    the run from ``x0 (1 + PROBE)`` (plus ``PROBE`` times the domain length where x0 is
    0). 1 means a difference stays the size it started; a chaotic run grows it.
    """
    vc = validate_case(case)
    from pes_ref.core.scene import simulate
    scale = np.maximum(np.abs(vc.x0), vc.scene.surface.length)
    delta = PROBE * scale * np.where(np.arange(vc.x0.size).reshape(vc.x0.shape) % 2 == 0, 1.0, -1.0)
    a = simulate(vc.scene, vc.x0, vc.v0, fext=vc.force)
    b = simulate(vc.scene, vc.x0 + delta, vc.v0, fext=vc.force)
    growth = max(float(np.max(np.abs(b.x - a.x) / (PROBE * scale))),
                 float(np.max(np.abs(b.v - a.v) / (PROBE * scale))))
    return growth


def draw_cases(n: int, seed: int, *, bound: float = CONDITION_BOUND, max_draws: int | None = None) -> list:
    """``n`` fresh cases: valid ones each with conditioning <= ``bound``, and (at the odds
    ``near_limit`` of `CHECK_ODDS`, half of them) cases just
    past the stability rule's limit, which the oracle refuses.

    Attempt ``i`` draws one case from [`pes_ref.testing.draws`][pes_ref.testing.draws] with
    ``numpy.random.default_rng([seed, i])``, with the odds of
    `CHECK_ODDS` (wide margins of a single wall, near-edge
    positions, flags as int8 or uint8, a step near the stability limit), so the cases are
    the same for the same seed on any machine, and one attempt does not depend on another.
    Returns a list of ``(case_id, case dict, condition)``; ``condition`` is None for a case
    past the limit (refused: `refusal_key` names its key).
    """
    if seed < 0:
        raise ValueError(f"the seed of the random cases must be >= 0, got {seed}")
    kept = []
    attempts = max_draws or max(4 * n, 20)
    for attempt in range(attempts):
        if len(kept) == n:
            break
        d = draws.GeneratorDraws(np.random.default_rng([seed, attempt]))
        scene, x0, v0 = draws.scene_case(d, max_particles=4, near_edge=draws.CHECK_ODDS["near_edge"],
                                         wide_margin=draws.CHECK_ODDS["wide_margin"])
        obj, reg = draws.objective(d, scene, x0.shape[0])
        case = case_from_scene(scene, x0, v0, obj, regularization=reg)
        flags = draws.flag_dtype(d, draws.CHECK_ODDS["integer_flags"])
        case.update({k: case[k].astype(flags) for k in ("periodic", "walls") if k in case})
        near = draws.near_limit(d, scene, draws.CHECK_ODDS["near_limit"])
        if near is not None:
            key = "dt" if scene.mode == "dynamic" else "mobility"
            case[key] = case[key] * near[1]
            if near[0] == "past":
                if refusal_key(case) == key:
                    kept.append((f"random-{seed}-{len(kept):04d}", case, None))
                continue
        with np.errstate(all="ignore"):
            try:
                cond = condition_number(case)
            except (CaseError, FloatingPointError, ValueError):
                continue
        if np.isfinite(cond) and cond <= bound:
            kept.append((f"random-{seed}-{len(kept):04d}", case, cond))
    if len(kept) < n:
        raise RuntimeError(f"only {len(kept)} of {attempts} drawn cases are within the conditioning bound "
                           f"{bound:g}; ask for fewer (--random) or another --seed")
    return kept


def refusal_key(case: dict):
    """The key the oracle refuses ``case`` naming, or None when it accepts it (before the run)."""
    try:
        validate_case(case)
    except CaseError as exc:
        return exc.key
    return None


# =========================================================================== the cases to run

@dataclass
class _Item:
    """One case to run: its id, kind, case dict (None for a broken file), the shipped
    file it comes from (None for a random case), the reference result (None when
    invalid), the manifest entry, and the other one-sided results of a kink."""

    case_id: str
    kind: str
    case: dict | None
    source: Path | None
    want: dict | None
    entry: dict
    one_sided: list


def _items(version, vectors: bool, random_n: int, seed: int, bound: float, only) -> list:
    """The shipped vectors (valid ones, then invalid ones; only those of ``only`` if
    given), then the random cases."""
    valid, invalid = [], []
    if vectors:
        folder = vectors_dir(version)
        for entry, case, want in iter_vectors(version, "all"):
            if only is not None and entry["id"] not in only:
                continue
            item = _Item(entry["id"], entry["kind"], case, folder / entry["case"], want, entry,
                         one_sided_results(entry, version))
            (valid if entry["kind"] == "valid" else invalid).append(item)
    fresh = []
    for case_id, case, cond in (draw_cases(random_n, seed, bound=bound) if random_n else ()):
        if cond is None:                # past the stability limit: refused, judged as an invalid case
            invalid.append(_Item(case_id, "invalid", case, None, None,
                                 {"id": case_id, "key": refusal_key(case), "error": "ValueError"}, []))
        else:
            fresh.append(_Item(case_id, "random", case, None, run_case(case), {}, []))
    return valid + invalid + fresh


# =========================================================================== verdicts

def _judge_result(item: _Item, got: dict, *, strict: bool) -> CaseOutcome:
    """Compare a result with the reference: the keys that bind (on a kink, against every
    accepted one-sided result unless ``strict``); quasistatic ``grad_v0/mass/damping``
    may be added and must then be zero."""
    want = item.want
    names = binding_keys(item.entry, want, strict=strict)
    errors = compare_vector(got, want, names, () if strict else item.one_sided)
    if str(item.case["mode"]) == "quasistatic":
        for key in _QUASISTATIC_OPTIONAL:
            if key in got and key not in want:
                zeros = {key: np.zeros(np.shape(item.case[key[len("grad_"):]]))}
                errors.update(compare_vector(got, zeros, [key]))
    outcome = CaseOutcome(item.case_id, True, item.kind, errors=errors)
    missing = [k for k in names if k not in got]
    bad = [k for k in errors if not passes(k, errors[k])]
    wrong_dtype = [k for k in errors if k in got and np.asarray(got[k]).dtype.str != RESULT_DTYPE]
    if missing:
        array, detail = missing[0], "missing from the result"
    elif bad:
        array = max(bad, key=lambda k: errors[k] / _tolerance(k))
        err = errors[array]
        detail = ("not finite, or of the wrong shape" if not np.isfinite(err) else
                  f"relative error {err:.2e} > tolerance {_tolerance(array):.0e}")
        if array.startswith("grad_") and _all_zero(got[array]) and not _all_zero(want.get(array, 0.0)):
            detail = f"gradient missing (all zeros): {detail}"
    elif wrong_dtype:
        array = wrong_dtype[0]
        detail = (f"dtype {np.asarray(got[array]).dtype.str}, not float64 little-endian ({RESULT_DTYPE}); "
                  "docs/spec.md section 9")
        bad = wrong_dtype
    else:
        array = max(errors, key=lambda k: errors[k] / _tolerance(k), default="")
        detail = f"worst {array} {errors[array]:.1e} (tolerance {_tolerance(array):.0e})" if array else "nothing compared"
    outcome.ok = not missing and not bad
    outcome.array, outcome.detail = array, detail
    if array:
        outcome.error, outcome.tolerance = errors.get(array, math.inf), _tolerance(array)
    return outcome


def _all_zero(a) -> bool:
    """Whether an array holds only zeros (and at least one entry)."""
    a = np.asarray(a)
    return a.size > 0 and a.dtype.kind in "iuf" and not np.any(a)


def _exit(status, batch_size: int = 1) -> str:
    """``exit 2``, or for a process of several cases ``exit 2 of the process of all 5 cases``:
    one exit status answers for every case of a ``{pairs}`` run (docs/spec.md 13.2)."""
    return f"exit {status}" if batch_size <= 1 else f"exit {status} of the process of all {batch_size} cases"


def _judge_refusal(item: _Item, status, wrote: bool, message: str, record, *, lenient: bool, strict: bool,
                   kind: str | None = None, batch_size: int = 1) -> CaseOutcome:
    """The verdict on an invalid vector: refused (non-zero exit), nothing written, the
    key at fault named by ``record`` (its ``{refusals}`` line) or else by ``message`` (its
    last line on stderr) unless ``lenient``, and in strict mode the declared error kind
    (the record's, or ``kind``, that of the exception a Python function raised).
    ``batch_size``: how many cases the process held, whose one exit status ``status`` is."""
    key, declared = item.entry["key"], item.entry["error"]
    out = CaseOutcome(item.case_id, False, "invalid", key=key)
    quoted = repr(message[-_QUOTE:])
    told = record.get("error") if record is not None else kind
    exit_ = _exit(status, batch_size)
    named = record.get("key") == key if record is not None else names_key(message, key)
    if status is None:
        out.detail = message
    elif status == 0 and wrote:
        out.detail = f"accepted an invalid case ({exit_}, a result written)"
    elif status == 0 and not (message or record is not None):
        out.detail = f"wrote no result and said nothing, but exited 0 ({exit_}): a refusal needs a non-zero exit status"
    elif status == 0:
        said = "naming the key" if named else "without naming the key"
        out.detail = (f"refused ({said}, no result written) but exited 0 ({exit_}): a refusal needs a non-zero "
                      f"exit status (docs/spec.md 8.7): {quoted}")
    elif wrote:
        out.detail = f"wrote a result for an invalid case ({exit_})"
    elif record is not None and not lenient and record.get("key") != key:
        out.detail = f"refused naming key {record.get('key')!r} in {{refusals}}, not {key!r}"
    elif record is None and not lenient and not names_key(message, key):
        out.detail = (f"refused ({exit_}) without naming the key: {quoted}" if key is not None
                      else f"refused ({exit_}) without a message on stderr")
    elif strict and told != declared:
        out.detail = f"refused as {told or 'an unknown kind (nothing in {refusals})'}, the manifest declares {declared}"
    else:
        out.ok = True
        out.detail = f"refused ({exit_}): {quoted}"
    return out


# =========================================================================== running a program

class Program:
    """A command template run on case files (see the module docstring)."""

    def __init__(self, template: str, timeout: float, *, strict: bool = False):
        self.argv = shlex.split(template)
        self.batch = any("{pairs}" in a for a in self.argv)
        self.refusals = any("{refusals}" in a for a in self.argv)
        if not self.batch and not any("{case}" in a for a in self.argv):
            raise ValueError(f"--cmd {template!r} names neither {{case}} (with {{result}}) nor {{pairs}}")
        if not self.batch and not any("{result}" in a for a in self.argv):
            raise ValueError(f"--cmd {template!r} names {{case}} but not {{result}}")
        if strict and not self.refusals:
            raise ValueError("--strict needs {refusals} in --cmd: the program writes there the key and the error "
                             "kind (TypeError or ValueError) of each case it refuses (docs/spec.md section 13)")
        self.template = template
        self.timeout = timeout

    def command(self, pairs, refusals=None) -> list:
        """The argv of one run: the template with ``{pairs}`` expanded to ``CASE1 RESULT1 ...``, or
        ``{case}`` and ``{result}`` to the first pair, and ``{refusals}`` to ``refusals``."""
        out = []
        for a in self.argv:
            if a == "{pairs}":
                out += [str(p) for pair in pairs for p in pair]
                continue
            if "{case}" in a or "{result}" in a:
                case, result = pairs[0]
                a = a.replace("{case}", str(case)).replace("{result}", str(result))
            out.append(a.replace("{refusals}", str(refusals)))
        return out

    def run(self, pairs, timeout: float, refusals=None):
        """``(exit status or None on timeout, stderr, seconds)``."""
        argv = self.command(pairs, refusals)
        t = time.perf_counter()
        try:
            proc = subprocess.run(argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                  timeout=timeout, text=True, errors="replace")
        except subprocess.TimeoutExpired:
            return None, f"timed out after {timeout:g} s", time.perf_counter() - t
        except OSError as exc:
            return -1, f"could not start: {exc}", time.perf_counter() - t
        return proc.returncode, proc.stderr or "", time.perf_counter() - t


def _load_result(path: Path):
    try:
        with np.load(path, allow_pickle=False) as npz:
            return {k: npz[k] for k in npz.files}, ""
    except Exception as exc:   # the program under test may write anything
        return None, f"result is not a readable .npz ({type(exc).__name__}: {exc})"


def _records(path: Path) -> dict:
    """The ``{refusals}`` records by case path (the last one per case; unreadable lines are skipped)."""
    out = {}
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return out
    for line in text.splitlines():
        try:
            record = json.loads(line)
        except ValueError:
            continue
        if isinstance(record, dict) and isinstance(record.get("case"), str):
            out[record["case"]] = record
    return out


def _message_for(stderr: str, case_path: str, alone: bool) -> str:
    """The line of ``stderr`` that answers for a case, without the case's path: the last
    line holding the path, or when the run held this case ``alone`` the last non-empty line."""
    lines = [line.strip() for line in stderr.splitlines() if line.strip()]
    if not alone:
        lines = [line for line in lines if case_path in line]
    return lines[-1].replace(case_path, "<case>") if lines else ""


class _Runner:
    """Runs a [`Program`][pes_ref.testing.check.Program] on `_Item` s in a scratch folder and judges them."""

    def __init__(self, program: Program, tmp: Path, report: CheckReport, items: list, *, strict: bool,
                 lenient: bool):
        self.program, self.tmp, self.report = program, tmp, report
        self.strict, self.lenient = strict, lenient
        self._runs = 0
        self.batch = None
        self._number = {it.case_id: n for n, it in enumerate(items)}

    def paths(self, item: _Item, folder: Path | None = None):
        """The case's files in ``folder`` (the scratch folder by default), named by number (a
        vector's id holds key names, and a message that quotes the path must not name a key by it)."""
        stem = (folder or self.tmp) / f"{self._number[item.case_id]:05d}"
        return stem.with_suffix(".case.npz"), stem.with_suffix(".result.npz")

    def write_case(self, item: _Item) -> None:
        path = self.paths(item)[0]
        if item.source is not None:
            shutil.copyfile(item.source, path)          # a shipped vector, byte for byte
        else:
            save_case(path, overwrite=True, compress=False, **item.case)

    def _run(self, items: list, what: str, folder: Path | None = None):
        """Run the program on ``items`` in one process: ``(status, stderr, records)``."""
        self._runs += 1
        refusals = self.tmp / f"refusals-{self._runs}.jsonl" if self.program.refusals else None
        pairs = [self.paths(it, folder) for it in items]
        status, stderr, seconds = self.program.run(pairs, self.program.timeout * len(items), refusals)
        self.report.batches.append({"cases": len(items), "what": what, "seconds": seconds,
                                    "exit": status})
        self.batch = len(self.report.batches) - 1
        records = _records(refusals) if refusals is not None else {}
        return status, stderr, records, (seconds if len(items) == 1 else None)

    def valid(self, items: list) -> list:
        """Run the valid and random cases: all in one process with ``{pairs}``, else one each."""
        groups = ([items] if items else []) if self.program.batch else [[it] for it in items]
        outcomes = []
        for group in groups:
            status, stderr, records, seconds = self._run(group, "valid" if self.program.batch else "one valid case")
            alone = len(group) == 1
            for item in group:
                case_path, result = (str(p) for p in self.paths(item))
                if status is None:
                    outcome = CaseOutcome(item.case_id, False, item.kind, detail=stderr if alone else
                                          f"{stderr} (the run of all {len(group)} cases)")
                else:
                    outcome = self._valid_outcome(item, Path(result), status, _message_for(stderr, case_path, alone),
                                                  records.get(case_path), len(group))
                outcome.seconds, outcome.batch = seconds, self.batch
                outcomes.append(outcome)
        return outcomes

    def _valid_outcome(self, item, result: Path, status, message: str, record, batch_size: int = 1) -> CaseOutcome:
        fail = CaseOutcome(item.case_id, False, item.kind)
        if not result.exists():
            why = record.get("message") or f"key {record.get('key')}" if record is not None else message
            fail.detail = f"no result written ({_exit(status, batch_size)}){': ' + why[-_QUOTE:] if why else ''}"
            return fail
        got, problem = _load_result(result)
        if got is None:
            fail.detail = problem
            return fail
        return _judge_result(item, got, strict=self.strict)

    def invalid(self, items: list) -> list:
        """Run the invalid vectors: with ``{pairs}`` all in one process first; each case
        that run does not answer (no line or record names it, no result written) runs
        again alone; without ``{pairs}`` each in a process of its own."""
        verdicts = {}
        alone = list(items)
        if self.program.batch and len(items) > 1:
            status, stderr, records, _ = self._run(items, "invalid")
            alone = []
            for item in items:
                case_path, result = (str(p) for p in self.paths(item))
                message, record = _message_for(stderr, case_path, False), records.get(case_path)
                wrote = Path(result).exists()
                if status is None or not (message or record or wrote):
                    alone.append(item)
                else:
                    verdicts[item.case_id] = _judge_refusal(item, status, wrote, message, record, lenient=self.lenient,
                                                            strict=self.strict, batch_size=len(items))
                    verdicts[item.case_id].batch = self.batch
        for item in alone:
            status, stderr, records, seconds = self._run([item], "one invalid case")
            case_path, result = (str(p) for p in self.paths(item))
            message = stderr.strip() if status is None else _message_for(stderr, case_path, True)
            verdicts[item.case_id] = _judge_refusal(item, status, Path(result).exists(), message,
                                                    records.get(case_path), lenient=self.lenient, strict=self.strict)
            verdicts[item.case_id].seconds, verdicts[item.case_id].batch = seconds, self.batch
        return [verdicts[it.case_id] for it in items]


    def mixed(self, valid: list, invalid: list) -> CaseOutcome:
        """docs/spec.md 13.2 on one process of valid and invalid vectors interleaved
        (`_mixed_items`, ending with a valid one): it must exit non-zero, since it
        refuses some; each valid case it answers must have its result, right; no invalid
        case may have one. A valid case a program left unanswered (no result, no line or
        record naming it: it stopped at a refusal) is not judged here; it was run alone."""
        items = _mixed_items(valid, invalid)
        folder = self.tmp / "mixed"
        folder.mkdir()
        for item in items:
            shutil.copyfile(self.paths(item)[0], self.paths(item, folder)[0])
        status, stderr, records, _ = self._run(items, "mixed", folder)
        outcome = CaseOutcome(MIXED_BATCH, False, "batch", batch=self.batch)
        refused = sum(it.kind == "invalid" for it in items)
        faults = []
        for item in items:
            case_path, result = (str(p) for p in self.paths(item, folder))
            answered = Path(result).exists() or records.get(case_path) or _message_for(stderr, case_path, False)
            if item.kind == "invalid" and Path(result).exists():
                faults.append((item.case_id, "wrote a result for an invalid case"))
            elif item.kind != "invalid" and answered:
                verdict = self._valid_outcome(item, Path(result), status, _message_for(stderr, case_path, False),
                                              records.get(case_path), len(items))
                if not verdict.ok:
                    faults.append(("/".join(filter(None, (item.case_id, verdict.array))), verdict.detail))
        if status is None:
            outcome.array, outcome.detail = "exit status", stderr
        elif status == 0:
            outcome.array = "exit status"
            outcome.detail = (f"exited 0 from a process of {len(items)} cases of which {refused} are invalid: a run "
                              f"that refuses any case exits non-zero (docs/spec.md 13.2)")
        elif faults:
            outcome.array, outcome.detail = faults[0]
        else:
            outcome.ok = True
            outcome.detail = f"exit {status}: {refused} of {len(items)} cases refused, every valid one right"
        return outcome


#: The id of the process of valid and invalid cases interleaved (docs/spec.md 13.2).
MIXED_BATCH = "mixed-batch"
#: How many valid and how many invalid vectors it holds (at most).
MIXED_EACH = 3


def _mixed_items(valid: list, invalid: list) -> list:
    """Up to `MIXED_EACH` invalid and valid vectors, spread over their lists,
    interleaved invalid first and valid last (so that neither the first nor the last case
    alone decides the exit status)."""
    def spread(items):
        k = min(MIXED_EACH, len(items))
        return [items[i * len(items) // k] for i in range(k)]
    out = []
    for bad, good in zip(spread(invalid), spread(valid)):
        out += [bad, good]
    return out


def _keep(keep_dir: Path, outcome: CaseOutcome, case_file: Path, program: Program) -> None:
    """Keep a failing case as ``keep_dir/<id>/case.npz`` with ``reproduce.sh``, which runs
    the program on it alone."""
    folder = keep_dir / outcome.case_id
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(case_file, folder / "case.npz")
    cmd = program.command([("case.npz", "result.npz")], "refusals.jsonl")
    (folder / "reproduce.sh").write_text("#!/bin/sh\n# " + outcome.line() + "\ncd \"$(dirname \"$0\")\"\n"
                                         + " ".join(shlex.quote(a) for a in cmd) + "\n")


# =========================================================================== the check

def check(runner, *, vectors: bool = True, random: int = 0, seed: int = 0, timeout: float = 60.0,
          keep=None, version: str = LATEST, bound: float = CONDITION_BOUND, only=None, progress=None,
          strict: bool = False, lenient_messages: bool = False) -> CheckReport:
    """Check an implementation against the vectors and fresh cases.

    Parameters
    ----------
    runner : str or callable
        A command template (``"PROGRAM {case} {result}"`` or ``"PROGRAM {pairs}"``,
        optionally with ``{refusals}``), or a Python function ``case dict -> result
        dict`` that raises ``ValueError`` or ``TypeError`` naming the key on an invalid case.
    vectors : bool
        Run the shipped vectors of ``version``.
    random, seed : int
        How many fresh cases to draw, and from which seed (>= 0).
    timeout : float
        Seconds per case (a run of several cases gets this times their number).
    keep : path, optional
        A folder to keep each failing case in, with ``reproduce.sh``.
    bound : float
        The conditioning bound of fresh cases.
    only : iterable of str, optional
        Run only the vectors with these ids (the random cases are drawn all the same).
    progress : callable, optional
        Called with each [`CaseOutcome`][pes_ref.testing.check.CaseOutcome] as it is decided.
    strict : bool
        docs/spec.md section 11's strict mode: on a kink, the gradients are compared with
        the reference's one-sided choice only; a refusal must declare the manifest's
        error kind (a command template needs ``{refusals}`` for that).
    lenient_messages : bool
        Do not require a refusal to name the key at fault.

    Returns
    -------
    CheckReport
    """
    only = None if only is None else set(only)
    function = callable(runner)
    if not function:
        program = Program(runner, timeout, strict=strict)
    items = _items(version, vectors, random, seed, bound, only)
    report = CheckReport(settings={"runner": runner if isinstance(runner, str) else repr(runner),
                                   "vectors": version if vectors else None, "random": random, "seed": seed,
                                   "condition_bound": bound, "timeout": timeout, "strict": strict,
                                   "lenient_messages": lenient_messages})
    emit = progress or (lambda outcome: None)
    if function:
        skipped = [it.case_id for it in items if it.case is None]
        if skipped:
            report.settings["not_run"] = {"ids": skipped, "why": "the case file itself breaks docs/spec.md 8.1; "
                                          "a function of a case dict does not read files"}
        for item in items:
            if item.case is not None:
                outcome = _check_function(runner, item, strict=strict, lenient=lenient_messages)
                report.outcomes.append(outcome)
                emit(outcome)
        return report
    keep_dir = Path(keep) if keep is not None else None
    with tempfile.TemporaryDirectory(prefix="pes_ref-check-") as tmp:
        tmp = Path(tmp)
        run = _Runner(program, tmp, report, items, strict=strict, lenient=lenient_messages)
        for item in items:
            run.write_case(item)
        by_id = {it.case_id: it for it in items}
        for outcomes in _stages(run, items):
            for outcome in outcomes:
                report.outcomes.append(outcome)
                if keep_dir is not None and not outcome.ok and outcome.case_id in by_id:
                    _keep(keep_dir, outcome, run.paths(by_id[outcome.case_id])[0], program)
                emit(outcome)
    return report


def _stages(run: _Runner, items: list):
    """The outcomes of the valid vectors, then of the invalid ones, then of the random
    cases (with ``{pairs}`` the random cases run in the valid vectors' process)."""
    vector_valid = [it for it in items if it.kind == "valid"]
    invalid = [it for it in items if it.kind == "invalid"]
    fresh = [it for it in items if it.kind == "random"]
    if run.program.batch:
        ran = {o.case_id: o for o in run.valid(vector_valid + fresh)}
        yield [ran[it.case_id] for it in vector_valid]
        yield run.invalid(invalid)
        if vector_valid and invalid:
            yield [run.mixed(vector_valid, invalid)]
        yield [ran[it.case_id] for it in fresh]
    else:
        yield run.valid(vector_valid)
        yield run.invalid(invalid)
        yield run.valid(fresh)


def _check_function(fn, item: _Item, *, strict: bool, lenient: bool) -> CaseOutcome:
    t = time.perf_counter()
    try:
        got = fn({k: v.copy() for k, v in item.case.items()})
    except (ValueError, TypeError) as exc:
        seconds = time.perf_counter() - t
        if item.kind == "invalid":
            outcome = _judge_refusal(item, 2, False, str(exc), None, lenient=lenient, strict=strict,
                                     kind="TypeError" if isinstance(exc, TypeError) else "ValueError")
        else:
            outcome = CaseOutcome(item.case_id, False, item.kind, detail=f"refused a valid case: {exc}")
        outcome.seconds = seconds
        return outcome
    except Exception as exc:   # the implementation under test may raise anything
        return CaseOutcome(item.case_id, False, item.kind, key=item.entry.get("key"),
                           detail=f"raised {type(exc).__name__}: {exc}", seconds=time.perf_counter() - t)
    if item.kind == "invalid":
        return CaseOutcome(item.case_id, False, "invalid", key=item.entry["key"], detail="accepted an invalid case",
                           seconds=time.perf_counter() - t)
    outcome = _judge_result(item, {k: np.asarray(v) for k, v in got.items()}, strict=strict)
    outcome.seconds = time.perf_counter() - t
    return outcome


def write_report(report: CheckReport, path, *, overwrite: bool = True) -> None:
    """The report as JSON (written whole, then moved into place); an existing file is
    replaced only with ``overwrite``."""
    with atomic_file(path, overwrite=overwrite, what="report") as f:
        f.write(json.dumps(report.to_json(), indent=1).encode())
