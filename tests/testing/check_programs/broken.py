"""Implementations of the case format that each break one promise of docs/spec.md, to
show that ``pes_ref check`` catches every kind of wrong implementation:

    python broken.py MODE [--refusals FILE] CASE RESULT [CASE RESULT ...]

``ok`` is pes_ref's oracle itself, ``reference`` the readable reference
(:mod:`pes_ref.core.reference`) run the way the oracle runs a case, and
``first-refusal-only`` the oracle ending a run at its first refusal; every other mode
(:data:`MODES`) but ``hang`` is one of them with one bug: a changed case before the run, a changed
result after it, a sub-step of the readable reference replaced by a wrong one, a rule of
its own that refuses a valid case, or a wrong way of refusing. Pairs are run one after the other, like the oracle does; a
refusal prints ``error: <case path>: <message>`` (``error: <message>`` for one pair).
"""
import json
import sys
import time
from contextlib import ExitStack, contextmanager

import numpy as np

from pes_ref.core import reference
from pes_ref.oracle.case import CaseError, CaseTypeError, load_case, run_case, validate_case, write_result

# =========================================================================== the reference, patchable


def _reference_run(case: dict) -> dict:
    """A case run by the readable reference, as the oracle runs it (validated first; a
    run that leaves the finite numbers refused naming dt or mobility)."""
    vc = validate_case(case)
    blame = "dt" if vc.scene.mode == "dynamic" else "mobility"
    try:
        with np.errstate(over="raise", invalid="raise", divide="raise", under="ignore"):
            loss, grads, run = reference.value_and_grad(vc.scene, vc.x0, vc.v0, vc.objective,
                                                        regularization_weight=vc.regularization,
                                                        wrt=vc.grad_names, fext=vc.force)
            energy = reference.energy(vc.scene, run)
    except FloatingPointError as exc:
        raise CaseError(blame, f"the run left the finite numbers ({exc})") from None
    result = {"x": run.x, "v": run.v, "energy": energy, "loss": np.float64(loss)}
    result.update({"grad_" + name: grads[name] for name in vc.grad_names})
    if not all(np.all(np.isfinite(a)) for a in result.values()):
        raise CaseError(blame, "the run left the finite numbers")
    return {k: np.array(v, dtype=np.float64) for k, v in result.items()}


@contextmanager
def _patched(name: str, fn):
    """``pes_ref.core.reference.<name>`` replaced by ``fn(original)`` for the run."""
    original = getattr(reference, name)
    setattr(reference, name, fn(original))
    if name in ("bilinear_force", "bilinear_force_T"):
        reference.GRID["bilinear"] = (reference.bilinear_energy, reference.bilinear_force, reference.bilinear_force_T)
    try:
        yield
    finally:
        setattr(reference, name, original)
        reference.GRID["bilinear"] = (reference.bilinear_energy, reference.bilinear_force, reference.bilinear_force_T)


# --- sub-steps with one bug each

def _strict_clip(lookup):
    """The in-range switch taken strictly: s = 0 on the clip edge u = 0, u = n - 1 (forward and adjoint)."""
    def wrong(terms, q):
        c = lookup(terms, q)
        s = [c.s0.copy(), c.s1.copy()]
        for d in range(2):
            if not terms.periodic[d]:
                u = (q[..., d] - terms.lower[d]) / terms.h[d]
                s[d] = ((u > 0.0) & (u < terms.values.shape[d] - 1.0)).astype(np.float64)
        return c._replace(s0=s[0], s1=s[1])
    return wrong


def _float32_inverse_spacing(bilinear_force):
    """The grid force with ``-1/h`` rounded to float32."""
    def wrong(terms, c):
        # the spacing whose -1/h (as the force computes it) is the float32 one, to within an ulp
        h = np.array([-1.0 / np.float64(np.float32(-1.0 / h)) for h in terms.h])
        return bilinear_force(terms._replace(h=h), c)
    return wrong


def _wrong_period(spring_delta):
    """The minimum image with the period (n - 1) h, the node span of a non-periodic axis."""
    def wrong(terms, q):
        span = terms.h * (np.array(terms.values.shape) - 1.0)
        return spring_delta(terms._replace(length=np.where(terms.periodic, span, terms.length)), q)
    return wrong


def _damping_denominator(coefficients):
    """``V_{n+1} = [...] / (1 + dt gamma / m)``: the damped step's denominator without its 2."""
    def wrong(dt, mass, damping, n):
        a, c, d, e = coefficients(dt, mass, damping, n)
        return a, c, 1.0 / (1.0 + 2.0 * c), e
    return wrong


def _split_wall_onset(wall_force_T):
    """A wall's stiffness counted half at its onset q = a or q = b (a clamp with tensor
    bounds splits the derivative 0.5 / 0.5 there): neither one-sided value."""
    def wrong(terms, q, w, xbar):
        k_w, a, b = terms.walls
        wall_force_T(terms, q, w, xbar)
        xbar -= 0.5 * k_w * np.where((q == a) | (q == b), w, 0.0)
    return wrong


def _outside_edge_derivative(bilinear_force_T):
    """The adjoint takes s = 0 on the closed grid edge (the derivative from outside), while
    the forward takes s = 1 there."""
    def wrong(terms, c, w, xbar, gvalues):
        s = [c.s0.copy(), c.s1.copy()]
        for d, (lo, hi, f) in enumerate(((c.i0, c.i1, c.f0), (c.j0, c.j1, c.f1))):
            if not terms.periodic[d]:
                n = terms.values.shape[d]
                edge = ((lo == 0) & (f == 0.0)) | ((hi == n - 1) & (f == 1.0))
                s[d] = np.where(edge, 0.0, s[d])
        return bilinear_force_T(terms, c._replace(s0=s[0], s1=s[1]), w, xbar, gvalues)
    return wrong


def _float32_cell_index(lookup):
    """The cell index ``k = floor(u)`` taken from ``u`` rounded to float32 (the fraction
    ``f = u - k`` still in float64): within half a float32 ulp below an edge, the cell above."""
    def wrong(terms, q):
        c = lookup(terms, q)
        out = []
        for d in range(2):
            n = terms.values.shape[d]
            u = (q[..., d] - terms.lower[d]) / terms.h[d]
            if terms.periodic[d]:
                k = np.floor(u.astype(np.float32)).astype(np.float64)
                f, lo, hi = u - k, np.mod(k, n), np.mod(k + 1, n)
            else:
                uc = np.clip(u, 0.0, n - 1.0)
                k = np.minimum(np.floor(uc.astype(np.float32)).astype(np.float64), n - 2)
                f, lo, hi = uc - k, k, k + 1
            out.append((lo.astype(np.intp), hi.astype(np.intp), f))
        (i0, i1, f0), (j0, j1, f1) = out
        return c._replace(i0=i0, i1=i1, j0=j0, j1=j1, f0=f0, f1=f1)
    return wrong


# --- cases changed before the run, results after it

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


def _force_shifted(case: dict) -> dict:
    """``F_ext[n]`` where ``F_ext[n+1]`` belongs: the force acts one step late."""
    if "force" not in case:
        return case
    force = np.asarray(case["force"], dtype=np.float64)
    return {**case, "force": np.concatenate((force[:1], force[:-1]))}


def _final_force_dropped(case: dict) -> dict:
    """``F_ext[T]`` left out of the last kick."""
    if "force" not in case or str(case["mode"]) != "dynamic":
        return case
    force = np.array(case["force"], dtype=np.float64)
    force[-1] = 0.0
    return {**case, "force": force}


def _t0_ignored(case: dict) -> dict:
    return {k: v for k, v in case.items() if k != "t0"}


def _n_steps_truncated(case: dict) -> dict:
    """A float ``n_steps`` accepted and truncated (10.5 -> 10) instead of refused."""
    n = np.asarray(case.get("n_steps", 0))
    return {**case, "n_steps": np.int64(np.trunc(n))} if n.dtype.kind == "f" and np.all(np.isfinite(n)) else case


def _room_rule_for_one_wall(case: dict) -> None:
    """The room rule ``2 wall_margin < L`` applied to every axis with a wall, where docs/spec.md
    8.6 applies it only to an axis with both walls."""
    if "walls" not in case:
        return
    walls = np.asarray(case["walls"]).astype(bool)
    length = np.asarray(case["upper"], dtype=float) - np.asarray(case["lower"], dtype=float)
    margin = float(case["wall_margin"])
    for d in range(2):
        if walls[d].any() and 2.0 * margin >= length[d]:
            raise CaseError("wall_margin", f"wall_margin = {margin:g} leaves no room on axis {d} "
                                           f"(2 wall_margin >= L = {length[d]:g})")


def _bool_flags_only(case: dict) -> None:
    """Flags refused unless their dtype is bool, where docs/spec.md 8.4 accepts 0/1 integers too."""
    for key in ("periodic", "walls"):
        if key in case and np.asarray(case[key]).dtype != np.bool_:
            raise CaseTypeError(key, f"{key} must be a bool array, got dtype {np.asarray(case[key]).dtype}")


def _no_regularization_gradient(case, result):
    result["grad_values"] = result["grad_values"] - 2.0 * float(case.get("regularization", 0.0)) * case["values"]


def _quasistatic_grad_v0(case, result):
    if str(case["mode"]) == "quasistatic":
        result["grad_v0"] = result["grad_x0"] * float(case["dt"])


def _spring_center_sign(case, result):
    if "grad_spring_center" in result:
        result["grad_spring_center"] = -result["grad_spring_center"]


def _perturb_energy(case, result):
    result["energy"] = result["energy"] * (1 + 1e-9)


def _omit_grad_values(case, result):
    result.pop("grad_values", None)


def _zero_grad_values(case, result):
    result["grad_values"] = np.zeros_like(result["grad_values"])


def _big_endian(case, result):
    """Every array stored big-endian: float64 of the same values, but not ``<f8``."""
    for key in result:
        result[key] = np.asarray(result[key]).astype(">f8")


def _nan_in_x(case, result):
    result["x"] = result["x"].copy()
    result["x"][-1, 0, 0] = np.nan


# --- the stability rule (docs/spec.md section 10), misread

def rule_value(case: dict, *, mass="min", wall="any", seam=True, summed=False, edges=False,
               mobility="own") -> float:
    """docs/spec.md section 10's ``max dt sqrt(K/m_d)`` or ``max mobility_d K``, written out
    on its own, or under one misreading of it: ``mass`` "own" (each particle's spring with
    its own mass), "max", "other-axis" or "all" (the smallest of both axes); ``wall``
    "every-axis" (a wall is a term of both axes) or "both" (only of an axis with both walls);
    ``seam`` False (no cells across a periodic seam); ``summed`` (the terms of an axis added);
    ``edges`` (the second differences added, the bound of 10.2); ``mobility`` "max" or
    "other-axis". (tests/oracle/test_conformance.py holds the v5 vectors to it too.)"""
    G = np.asarray(case["values"], dtype=float)
    per = np.asarray(case["periodic"]).astype(bool)
    n_nodes = np.array(G.shape, dtype=float)
    h = (np.asarray(case["upper"], dtype=float) - np.asarray(case["lower"], dtype=float)) / np.where(
        per, n_nodes, n_nodes - 1)
    closed = G
    for d in range(2):
        if per[d] and seam:
            closed = np.concatenate((closed, np.take(closed, [0], axis=d)), axis=d)
    c = np.max(np.abs(closed[1:, 1:] - closed[1:, :-1] - closed[:-1, 1:] + closed[:-1, :-1])) / (h[0] * h[1])
    n = np.shape(case["x0"])[0]
    k = np.broadcast_to(np.asarray(case.get("spring_k", 0.0), dtype=float), (n, 2))
    terms = [np.full(2, c), k.max(axis=0)]
    if "walls" in case:
        walls = np.asarray(case["walls"]).astype(bool)
        on = {"any": walls.any(axis=1), "both": walls.all(axis=1), "every-axis": np.repeat(walls.any(), 2)}[wall]
        terms.append(np.where(on, float(case["wall_k"]), 0.0))
    if edges:
        second = [np.roll(G, -1, d) - 2 * G + np.roll(G, 1, d) if per[d] else np.diff(G, 2, axis=d) for d in range(2)]
        terms.append(np.array([np.max(np.abs(second[d])) / h[d] ** 2 if second[d].size else 0.0 for d in range(2)]))
    K = np.array([sum(terms)] if summed or edges else terms)                      # (terms, 2)
    if str(case["mode"]) == "quasistatic":
        mu = np.asarray(case["mobility"], dtype=float)
        mu = {"own": mu, "max": np.full(2, mu.max()), "other-axis": mu[::-1]}[mobility]
        return float(np.max(mu * K))
    m = np.broadcast_to(np.asarray(case["mass"], dtype=float), (n, 2))
    md = {"min": m.min(axis=0), "max": m.max(axis=0), "other-axis": m.min(axis=0)[::-1],
          "all": np.full(2, m.min()), "own": m.min(axis=0)}[mass]
    omega2 = K / md
    if mass == "own":          # each particle's spring over its own mass
        omega2[1] = np.max(k / m, axis=0)
    return float(np.max(float(case["dt"]) * np.sqrt(omega2)))


def _misread_rule(limit=2.0, **misreading):
    """A stability rule of its own: ``rule_value`` under ``misreading`` past ``limit``."""
    def rule(case):
        if int(case["n_steps"]) > 0 and rule_value(case, **misreading) > limit:
            key = "dt" if str(case["mode"]) == "dynamic" else "mobility"
            raise CaseError(key, f"{key} is past the stability limit (as this program reads the rule)")
    return rule


def _t0_unchecked(case: dict) -> dict:
    """A t0 that is not finite read as 0 (the key left unchecked, as the step times' origin)."""
    t0 = np.asarray(case.get("t0", 0.0))
    return case if t0.dtype.kind not in "f" or np.all(np.isfinite(t0)) else {**case, "t0": np.float64(0.0)}


def _spring_skipped_at_zero(case: dict) -> dict:
    """A spring whose every stiffness is 0 taken as no spring (so no grad_spring_k, grad_spring_center)."""
    if "spring_k" in case and not np.any(np.asarray(case["spring_k"], dtype=float)):
        return {k: v for k, v in case.items() if k not in ("spring_k", "spring_center")}
    return case


# =========================================================================== the modes

#: mode -> (what is wrong, settings). Settings: ``run`` "oracle" (pes_ref's oracle) or
#: "reference" (the readable one), ``patch`` (name, replacement) of a reference sub-step,
#: ``before`` a case -> case, ``after`` a (case, result) -> None, ``rule`` a case -> None
#: that raises a ``CaseError`` (a rule of its own, checked on a case the oracle finds
#: valid), ``refuse`` how a refusal goes wrong, ``skip`` a case -> bool (write nothing, exit 0).
MODES = {
    "ok": ("nothing: pes_ref's oracle", {}),
    "reference": ("nothing: the readable reference run as the oracle runs it", {"run": "reference"}),
    "perturb": ("energy off by 1e-9 relative", {"after": _perturb_energy}),
    "no-damping": ("the velocity update without damping",
                   {"before": lambda c: {**c, "damping": np.zeros_like(np.asarray(c["damping"], dtype=float))}}),
    "other-side": ("a position on a cell edge looked up in the cell below", {"before": _on_edge_down}),
    "omit-gradient": ("no grad_values", {"after": _omit_grad_values}),
    "nan": ("NaN in x", {"after": _nan_in_x}),
    "accept-invalid": ("an invalid case gets a result and exit 0", {"refuse": "accept"}),
    "strict-clip-edge": ("the in-range switch s taken strictly (s = 0 on the clip edge)",
                         {"run": "reference", "patch": ("lookup", _strict_clip)}),
    "no-regularization-gradient": ("the regularization's gradient 2 R G left out of grad_values",
                                   {"after": _no_regularization_gradient}),
    "float32-inverse-spacing": ("the grid force with -1/h in float32",
                                {"run": "reference", "patch": ("bilinear_force", _float32_inverse_spacing)}),
    "force-index-shifted": ("F_ext[n] in place of F_ext[n+1]", {"before": _force_shifted}),
    "wrong-seam-period": ("the spring's minimum image with period (n - 1) h",
                          {"run": "reference", "patch": ("spring_delta", _wrong_period)}),
    "wrong-damping-denominator": ("the damped kick divided by 1 + dt gamma / m",
                                  {"run": "reference", "patch": ("coefficients", _damping_denominator)}),
    "no-final-force": ("F_ext[T] left out of the last kick", {"before": _final_force_dropped}),
    "quasistatic-grad-v0": ("a non-zero grad_v0 in quasistatic mode", {"after": _quasistatic_grad_v0}),
    "t0-ignored": ("the step times start at 0 whatever t0", {"before": _t0_ignored}),
    "truncated-n-steps": ("a float n_steps truncated to an integer instead of refused",
                          {"before": _n_steps_truncated}),
    "missing-torus-result": ("no result written for a torus case (exit 0)",
                             {"skip": lambda c: bool(np.all(np.asarray(c["periodic"])))}),
    "spring-center-sign": ("grad_spring_center with the wrong sign", {"after": _spring_center_sign}),
    "refusal-without-key": ("a refusal that does not name the key", {"refuse": "no-key"}),
    "wrong-key": ("a refusal that names another key", {"refuse": "wrong-key"}),
    "result-opened-early": ("the result file opened after validation, before the run: a run that leaves "
                            "the finite numbers leaves an empty file", {"refuse": "open-early"}),
    "error-kinds-swapped": ("refusals recorded with TypeError and ValueError swapped", {"refuse": "swap-kinds"}),
    "wall-onset-split": ("a wall's stiffness counted half at its onset",
                         {"run": "reference", "patch": ("wall_force_T", _split_wall_onset)}),
    "outside-edge-derivative": ("the adjoint's s = 0 on the closed grid edge",
                                {"run": "reference", "patch": ("bilinear_force_T", _outside_edge_derivative)}),
    "single-wall-room-rule": ("the room rule 2 wall_margin < L applied to an axis with one wall",
                              {"rule": _room_rule_for_one_wall}),
    "bool-flags-only": ("periodic and walls of 0/1 integers refused as a type error", {"rule": _bool_flags_only}),
    "float32-cell-index": ("the cell index from a float32 u",
                           {"run": "reference", "patch": ("lookup", _float32_cell_index)}),
    "zero-gradient": ("grad_values written as zeros (a gradient left out)", {"after": _zero_grad_values}),
    "big-endian-result": ("every result array stored big-endian (>f8), the values exact", {"after": _big_endian}),
    "refusal-exits-0": ("a refusal printed and recorded as it should be, but exit status 0", {"refuse": "exit-0"}),
    "last-exit-status": ("a run of several cases exits with the status of its last case, not non-zero if "
                         "it refused any", {"status": "last"}),
    "lenient-limit": ("the stability rule refuses only past 2.12, not 2", {"stability": _misread_rule(2.12)}),
    "seamless-curvature": ("the grid's curvature without the cells across a periodic seam",
                           {"stability": _misread_rule(seam=False)}),
    "own-particle-mass": ("each particle's spring paired with its own mass in the stability rule",
                          {"stability": _misread_rule(mass="own")}),
    "t0-unchecked": ("a t0 that is NaN or infinite read as 0", {"before": _t0_unchecked}),
    "spring-skipped-at-zero": ("a spring of stiffness 0 everywhere taken as no spring (no gradients of it)",
                               {"before": _spring_skipped_at_zero}),
    "first-refusal-only": ("nothing wrong, but a run ends at its first refusal", {"stop": True}),
    "hang": ("never answers", {}),
}


def _before(how: dict, case: dict) -> dict:
    """The mode's change of the case, or the case as it is where the change does not
    apply (an invalid case whose arrays it cannot read: the run refuses it)."""
    try:
        return how.get("before", lambda c: c)(case)
    except (KeyError, ValueError, TypeError, IndexError, AttributeError):
        return case


def _record(refusals, case_path: str, exc: CaseError, swap: bool) -> None:
    if refusals is None:
        return
    kind = "TypeError" if isinstance(exc, TypeError) != swap else "ValueError"
    with open(refusals, "a", encoding="utf-8") as fh:
        fh.write(json.dumps({"case": case_path, "key": exc.key, "error": kind}) + "\n")


def _wrong_key(exc: CaseError) -> str:
    return "dt" if exc.key != "dt" else "mass"


def run(mode: str, case_path: str, result_path: str, prefix: str, refusals) -> int:
    if mode == "hang":
        time.sleep(3600)
    how = MODES[mode][1]
    try:
        with ExitStack() as stack:
            if "patch" in how:
                stack.enter_context(_patched(*how["patch"]))
            case = load_case(case_path)
            if "skip" in how and "periodic" in case and how["skip"](case):
                return 0
            case = _before(how, case)
            if "rule" in how:
                validate_case(case)
                how["rule"](case)
            if "stability" in how:          # the rule of its own in place of the oracle's
                validate_case(case, allow_unstable=True)
                how["stability"](case)
            if how.get("refuse") == "open-early":
                validate_case(case)
                open(result_path, "wb").close()
            if "stability" in how:
                result = run_case(case, allow_unstable=True)
            else:
                result = (_reference_run if how.get("run") == "reference" else run_case)(case)
    except CaseError as exc:
        refuse = how.get("refuse")
        if refuse == "accept":
            result = {"x": np.zeros((1, 1, 2)), "v": np.zeros((1, 1, 2)), "energy": np.zeros((1, 1)),
                      "loss": np.float64(0.0)}
        else:
            if refuse == "no-key":
                print(f"{prefix}invalid case", file=sys.stderr)
                return 2
            if refuse == "wrong-key":
                exc = (CaseTypeError if isinstance(exc, TypeError) else CaseError)(_wrong_key(exc), "refused")
            print(f"{prefix}{exc}", file=sys.stderr)
            _record(refusals, case_path, exc, swap=refuse == "swap-kinds")
            return 0 if refuse == "exit-0" else 2
    how.get("after", lambda c, r: None)(case, result)
    write_result(result, result_path, overwrite=True)
    return 0


def main(argv) -> int:
    mode, files = argv[0], argv[1:]
    refusals = None
    if files[:1] == ["--refusals"]:
        refusals, files = files[1], files[2:]
    pairs = list(zip(files[::2], files[1::2]))
    status = 0
    last = MODES[mode][1].get("status") == "last"
    for case_path, result_path in pairs:
        prefix = "error: " if len(pairs) == 1 else f"error: {case_path}: "
        answer = run(mode, case_path, result_path, prefix, refusals)
        status = answer if last else max(status, answer)
        if status and MODES[mode][1].get("stop"):
            break
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
