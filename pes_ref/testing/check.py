"""Conformance of any implementation, in any language, through its command line.

``python -m pes_ref check --cmd "PROGRAM {case} {result}"`` runs a program on cases of
the interchange format (docs/spec.md sections 8-9) and compares what it writes with
the reference:

- **the shipped vectors** (:mod:`pes_ref.oracle.conformance`): each valid case must be
  run and its result must match the shipped one within the tolerances of docs/spec.md
  section 11 (on vectors flagged ``kink`` only ``x``, ``v``, ``energy`` and ``loss``
  bind); each invalid case must end with a non-zero exit status and write no result;
- **fresh random cases** (``--random N --seed S``): drawn from the project's own
  hypothesis strategies (:mod:`pes_ref.testing.strategies`), every topology, mode,
  effect, objective and broadcast shape; pes_ref runs each and so does the program.
  Only well-conditioned cases are kept: a perturbation of ``x0`` by
  :data:`PROBE` (relative) must grow by at most :data:`CONDITION_BOUND` anywhere in the
  trajectory, so that two correct programs, which may differ by an ulp per operation,
  agree within the trajectory tolerance. Long runs on rough bilinear grids amplify such
  differences by about 1.4x per step; the filter keeps them out.

The program is named by a template: ``{case}`` and ``{result}`` are replaced by the
paths of one case and of the result to write (one process per case); or ``{pairs}`` is
replaced by ``CASE1 RESULT1 CASE2 RESULT2 ...`` (one process for all valid cases; each
invalid case still gets its own process, since its exit status is the answer). No shell
is involved: the template is split like a shell command line (``shlex``).

The same check runs on a Python function (:func:`check` with ``runner`` a callable
``case dict -> result dict`` that raises ``ValueError``/``TypeError`` on an invalid case).
"""
from __future__ import annotations

import json
import shlex
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pes_ref.oracle.case import TRAJECTORY_KEYS, CaseError, run_case, save_case, validate_case
from pes_ref.oracle.conformance import LATEST
from pes_ref.oracle.from_scene import case_from_scene
from pes_ref.core.files import atomic_file
from pes_ref.oracle.tolerances import TRAJ_RTOL
from pes_ref.oracle.compare import compare_results, passes
from pes_ref.testing.conformance import iter_vectors

__all__ = ["CaseOutcome", "CheckReport", "check", "draw_cases", "condition_number", "write_report",
           "PROBE", "CONDITION_BOUND", "Program"]

#: The relative perturbation of ``x0`` that measures a case's conditioning.
PROBE = 1e-10
#: The largest growth of that perturbation a fresh case may have. One-ulp differences
#: (about 1.1e-16 relative) grown by this stay below 1e-13, a tenth of ``TRAJ_RTOL``.
CONDITION_BOUND = 1e3
#: Result keys every valid result holds besides the gradients.
_QUASISTATIC_OPTIONAL = ("grad_v0", "grad_mass", "grad_damping")


# =========================================================================== outcomes

@dataclass
class CaseOutcome:
    """The verdict on one case: ``ok``, and if not, the worst key and its error."""

    case_id: str
    ok: bool
    key: str = ""
    error: float = 0.0
    detail: str = ""
    seconds: float = 0.0

    def line(self) -> str:
        if self.ok:
            return f"ok    {self.case_id}"
        what = f"{self.key}: {self.detail}" if self.key else self.detail
        return f"FAIL  {self.case_id}  {what}"


@dataclass
class CheckReport:
    """Every case's outcome, with the settings that produced them."""

    outcomes: list = field(default_factory=list)
    settings: dict = field(default_factory=dict)

    @property
    def passed(self) -> int:
        return sum(o.ok for o in self.outcomes)

    @property
    def failed(self) -> int:
        return len(self.outcomes) - self.passed

    @property
    def ok(self) -> bool:
        return self.failed == 0 and bool(self.outcomes)

    def summary(self) -> str:
        return f"{self.passed} passed, {self.failed} failed"

    def to_json(self) -> dict:
        return {"settings": self.settings, "passed": self.passed, "failed": self.failed,
                "cases": [o.__dict__ for o in self.outcomes]}


# =========================================================================== drawing fresh cases

def condition_number(case: dict) -> float:
    """How much a relative perturbation :data:`PROBE` of ``x0`` grows over the run.

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
    """``n`` fresh valid cases from the project's strategies, each with conditioning <= ``bound``.

    Deterministic in ``seed``. Returns a list of ``(case_id, case dict, condition)``.
    Needs hypothesis (the ``test`` extra).
    """
    try:
        from hypothesis import HealthCheck, Phase, given, settings
        from hypothesis import seed as hseed
        from hypothesis import strategies as st
    except ImportError:
        raise ImportError("--random needs hypothesis: pip install 'pes_ref[test]'") from None
    from pes_ref.testing import strategies as pst

    @st.composite
    def cases(draw):
        scene, x0, v0 = draw(pst.scene_cases(max_particles=4))
        obj, reg = draw(pst.objectives(scene, x0.shape[0]))
        return case_from_scene(scene, x0, v0, obj, regularization=reg)

    drawn, kept = [], []
    budget = max_draws or max(4 * n, 20)

    @hseed(seed)
    @settings(max_examples=budget, database=None, phases=[Phase.generate], deadline=None, derandomize=False,
              suppress_health_check=list(HealthCheck))
    @given(cases())
    def collect(case):
        if len(kept) < n:
            drawn.append(case)
            with np.errstate(all="ignore"):
                try:
                    cond = condition_number(case)
                except (CaseError, FloatingPointError, ValueError):
                    return
            if np.isfinite(cond) and cond <= bound:
                kept.append((f"random-{seed}-{len(kept):04d}", case, cond))

    collect()
    if len(kept) < n:
        raise RuntimeError(f"only {len(kept)} of {len(drawn)} drawn cases are within the conditioning bound "
                           f"{bound:g}; ask for fewer (--random) or another --seed")
    return kept


# =========================================================================== running a program

class Program:
    """A command template run on case files (see the module docstring)."""

    def __init__(self, template: str, timeout: float):
        self.argv = shlex.split(template)
        self.batch = any("{pairs}" in a for a in self.argv)
        if not self.batch and not any("{case}" in a for a in self.argv):
            raise ValueError(f"--cmd {template!r} names neither {{case}} (with {{result}}) nor {{pairs}}")
        if not self.batch and not any("{result}" in a for a in self.argv):
            raise ValueError(f"--cmd {template!r} names {{case}} but not {{result}}")
        self.template = template
        self.timeout = timeout

    def command(self, pairs) -> list:
        out = []
        for a in self.argv:
            if a == "{pairs}":
                out += [str(p) for pair in pairs for p in pair]
            else:
                case, result = pairs[0]
                out.append(a.replace("{case}", str(case)).replace("{result}", str(result)))
        return out

    def run(self, pairs, timeout: float):
        """``(exit status or None on timeout, stderr tail, argv)``."""
        argv = self.command(pairs)
        try:
            proc = subprocess.run(argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                  timeout=timeout, text=True, errors="replace")
        except subprocess.TimeoutExpired:
            return None, f"timed out after {timeout:g} s", argv
        except OSError as exc:
            return -1, f"could not start: {exc}", argv
        return proc.returncode, (proc.stderr or "").strip()[-300:], argv


def _load_result(path: Path):
    try:
        with np.load(path, allow_pickle=False) as npz:
            return {k: npz[k] for k in npz.files}, ""
    except Exception as exc:   # the program under test may write anything
        return None, f"result is not a readable .npz ({type(exc).__name__}: {exc})"


def _judge(case_id, case, got, want, flags) -> CaseOutcome:
    """Compare a result with the reference: every reference key is owed (gradients only
    off kinks); quasistatic grad_v0/mass/damping may be added and must then be zero."""
    names = [k for k in want if k in TRAJECTORY_KEYS or "kink" not in flags]
    errors = compare_results(got, want, names)
    if str(case["mode"]) == "quasistatic":
        for key in _QUASISTATIC_OPTIONAL:
            if key in got and key not in want:
                errors.update(compare_results(got, {key: np.zeros(np.shape(case[key[5:]]))}, [key]))
    missing = [k for k in names if k not in got]
    if missing:
        return CaseOutcome(case_id, False, missing[0], float("inf"), "missing from the result")
    bad = {k: e for k, e in errors.items() if not passes(k, e)}
    if not bad:
        return CaseOutcome(case_id, True, error=max(errors.values(), default=0.0))
    key = max(bad, key=bad.get)
    err = bad[key]
    detail = ("not finite, or wrong shape" if not np.isfinite(err) else
              f"relative error {err:.2e} (tolerance {TRAJ_RTOL if key in TRAJECTORY_KEYS else 1e-9:.0e})")
    return CaseOutcome(case_id, False, key, err, detail)


def _keep(keep_dir: Path, outcome: CaseOutcome, case: dict, argv: list) -> None:
    folder = keep_dir / outcome.case_id
    folder.mkdir(parents=True, exist_ok=True)
    save_case(folder / "case.npz", overwrite=True, **case)
    cmd = [("case.npz" if a.endswith(".case.npz") or a.endswith("case.npz") else a) for a in argv]
    (folder / "reproduce.sh").write_text(
        "#!/bin/sh\n# " + outcome.line() + "\ncd \"$(dirname \"$0\")\"\n"
        + " ".join(shlex.quote(a) for a in cmd).replace(shlex.quote(str(argv[-1])), "result.npz") + "\n")


# =========================================================================== the check

def _items(version, vectors: bool, random_n: int, seed: int, bound: float):
    """``(case_id, case, expected result or None for invalid, flags)`` of every case to run."""
    items = []
    if vectors:
        for entry, case, want in iter_vectors(version, "all"):
            items.append((entry["id"], case, want, tuple(entry.get("flags", ()))))
    for case_id, case, _cond in (draw_cases(random_n, seed, bound=bound) if random_n else ()):
        with np.errstate(all="ignore"):
            want = run_case(case)
        items.append((case_id, case, want, ()))
    return items


def check(runner, *, vectors: bool = True, random: int = 0, seed: int = 0, timeout: float = 60.0,
          keep=None, version: str = LATEST, bound: float = CONDITION_BOUND, only=None, progress=None) -> CheckReport:
    """Check an implementation against the vectors and fresh cases.

    Parameters
    ----------
    runner : str or callable
        A command template (``"PROGRAM {case} {result}"`` or ``"PROGRAM {pairs}"``), or a
        Python function ``case dict -> result dict`` that raises ``ValueError`` or
        ``TypeError`` on an invalid case.
    vectors : bool
        Run the shipped vectors of ``version``.
    random, seed : int
        How many fresh cases to draw, and from which seed.
    timeout : float
        Seconds per case (per batch: this times the number of cases).
    keep : path, optional
        A folder to keep each failing case in, with ``reproduce.sh``.
    bound : float
        The conditioning bound of fresh cases.
    only : iterable of str, optional
        Run only the vectors with these ids.
    progress : callable, optional
        Called with each :class:`CaseOutcome` as it is decided.

    Returns
    -------
    CheckReport
    """
    items = _items(version, vectors, random, seed, bound)
    if only is not None:
        only = set(only)
        items = [it for it in items if it[0] in only]
    report = CheckReport(settings={"runner": runner if isinstance(runner, str) else repr(runner),
                                   "vectors": version if vectors else None, "random": random, "seed": seed,
                                   "condition_bound": bound, "timeout": timeout})
    emit = progress or (lambda outcome: None)
    keep_dir = Path(keep) if keep is not None else None
    if callable(runner):
        for item in items:
            outcome = _check_function(runner, *item)
            report.outcomes.append(outcome)
            emit(outcome)
        return report
    program = Program(runner, timeout)
    with tempfile.TemporaryDirectory(prefix="pes_ref-check-") as tmp:
        tmp = Path(tmp)
        valid = [it for it in items if it[2] is not None]
        invalid = [it for it in items if it[2] is None]
        for outcome, case, argv in _run_program(program, valid, invalid, tmp):
            report.outcomes.append(outcome)
            if keep_dir is not None and not outcome.ok:
                _keep(keep_dir, outcome, case, argv)
            emit(outcome)
    return report


def _check_function(fn, case_id, case, want, flags) -> CaseOutcome:
    t = time.perf_counter()
    try:
        got = fn({k: v.copy() for k, v in case.items()})
    except (ValueError, TypeError) as exc:
        if want is None:
            return CaseOutcome(case_id, True, detail=f"refused: {exc}", seconds=time.perf_counter() - t)
        return CaseOutcome(case_id, False, "", float("inf"), f"refused a valid case: {exc}")
    except Exception as exc:   # the implementation under test may raise anything
        return CaseOutcome(case_id, False, "", float("inf"), f"raised {type(exc).__name__}: {exc}")
    if want is None:
        return CaseOutcome(case_id, False, "", float("inf"), "accepted an invalid case")
    outcome = _judge(case_id, case, {k: np.asarray(v) for k, v in got.items()}, want, flags)
    outcome.seconds = time.perf_counter() - t
    return outcome


def _paths(tmp: Path, case_id: str):
    return tmp / f"{case_id}.case.npz", tmp / f"{case_id}.result.npz"


def _run_program(program: Program, valid: list, invalid: list, tmp: Path):
    """Yield ``(outcome, case, argv)`` for each case."""
    for case_id, case, _want, _flags in valid + invalid:
        save_case(_paths(tmp, case_id)[0], overwrite=True, compress=False, **case)
    if program.batch and valid:
        pairs = [_paths(tmp, it[0]) for it in valid]
        t = time.perf_counter()
        status, err, argv = program.run(pairs, program.timeout * len(valid))
        seconds = (time.perf_counter() - t) / len(valid)
        for (case_id, case, want, flags), (_c, result) in zip(valid, pairs):
            yield _valid_outcome(case_id, case, want, flags, result, status, err, seconds), case, argv
    else:
        for case_id, case, want, flags in valid:
            pair = _paths(tmp, case_id)
            t = time.perf_counter()
            status, err, argv = program.run([pair], program.timeout)
            yield (_valid_outcome(case_id, case, want, flags, pair[1], status, err, time.perf_counter() - t),
                   case, argv)
    for case_id, case, _want, _flags in invalid:
        pair = _paths(tmp, case_id)
        t = time.perf_counter()
        status, err, argv = program.run([pair], program.timeout)
        seconds = time.perf_counter() - t
        if status is None:
            outcome = CaseOutcome(case_id, False, "", float("inf"), err, seconds)
        elif status == 0:
            outcome = CaseOutcome(case_id, False, "", float("inf"), "accepted an invalid case (exit 0)", seconds)
        elif pair[1].exists():
            outcome = CaseOutcome(case_id, False, "", float("inf"),
                                  f"wrote a result for an invalid case (exit {status})", seconds)
        else:
            outcome = CaseOutcome(case_id, True, detail=f"refused (exit {status})", seconds=seconds)
        yield outcome, case, argv


def _valid_outcome(case_id, case, want, flags, result: Path, status, err, seconds) -> CaseOutcome:
    if status is None:
        return CaseOutcome(case_id, False, "", float("inf"), err, seconds)
    if not result.exists():
        return CaseOutcome(case_id, False, "", float("inf"),
                           f"no result written (exit {status}{': ' + err.splitlines()[-1] if err else ''})", seconds)
    got, problem = _load_result(result)
    if got is None:
        return CaseOutcome(case_id, False, "", float("inf"), problem, seconds)
    outcome = _judge(case_id, case, got, want, flags)
    outcome.seconds = seconds
    return outcome


def write_report(report: CheckReport, path, *, overwrite: bool = True) -> None:
    """The report as JSON (written whole, then moved into place); an existing file is
    replaced only with ``overwrite``."""
    with atomic_file(path, overwrite=overwrite, what="report") as f:
        f.write(json.dumps(report.to_json(), indent=1, default=float).encode())

