"""Design files: one ``.npz`` holding a design run, to evaluate, plot or resume it.

Keys (all plain arrays; loaded with ``allow_pickle=False``):

==================  =====================================================================
``format``          the string ``"pes_ref.design"``
``version``         int, `VERSION`
``kind``            ``"funnel"``, ``"oscillator"`` or ``"problem"`` (a problem file's design)
``problem``         JSON text of the problem's fields (the scene parameters); for kind
                    ``"problem"``, the TOML text of its problem file (``docs/problems.md``)
``plan``            JSON text of the plan's fields (optimizer, learning rates, stages, ...)
``seed``            int, the run's seed
``iteration``       int, iterations finished
``values``          (n0, n1) float64, the grid after ``iteration`` iterations
``loss``            (iteration,) float64, loss per iteration
``metric``          (iteration,) float64, design metric per iteration
``status``          ``"done"``, ``"interrupted"``, ``"non-finite: ..."``, ...
``elapsed``         float, wall seconds spent so far (information only)
``opt_<name>``      the optimizer's `state_dict` entries
``method``          ``"gradient"`` or ``"gradient+polish"`` (version 2)
``stage``           the stage the run is in, ``"gradient"`` or ``"polish"`` (version 2)
``polish``          JSON text of the polish plan's fields, ``null`` without one (version 2)
``base_values``     the gradient stage's final grid, where the polish starts ((0,) before it)
``evaluations``     int, polish fitness evaluations made (version 2)
``polish_evals``    (G,) int64, evaluations after the start and each polish generation
``polish_fitness``  (G,) float64, the best fitness at those counts
``backend``         the loops that ran it, ``"numba"`` or ``"numpy"`` (version 3;
                    `pes_ref.core.backends.BACKENDS`): a run resumes on its own
``valid_iters``     (V,) int64, the iterations after which the grid was validated (version 4;
                    [`pes_ref.synthesis.common.validation`][pes_ref.synthesis.common.validation])
``valid_success``   (V,) float64, the validation success there
``best_iteration``  int, the best validation's iteration (-1: none yet)
``best_success``    float, its success (NaN: none yet)
``best_values``     the best validated grid ((0,) without one)
``screened``        (2,) int64, a population's screening: the starts screened and the iterations they
                    ran together (0, 0: none; a file without it reads as that)
==================  =====================================================================

Version 1 files (before the polish stage) are read as gradient-only runs, version 1
and 2 files (before the compiled loops) as runs of the ``"numpy"`` backend, and version 1-3
files (before validation) as runs with no validation made. Version 5 adds no required key: its plan may
hold ``smoothing`` and ``smoothing_draws`` ([`Plan`][pes_ref.synthesis.common.plans.Plan]), which a
version 1-4 file's plan reads as 0 and 4 (no smoothing). A plan may hold ``starts`` and ``screen``
(a population of starts, [`pes_ref.synthesis.engine.population`][pes_ref.synthesis.engine.population]), which a file
without them reads as 1 and 0 (one start), and a file without ``screened`` as a run that screened none.

The members are stored uncompressed. The file is written by the package's one atomic
``.npz`` writer ([`write_npz`][pes_ref.core.runtime.npz.write_npz]): a crash never leaves half a design, and the
writer, not a check here beforehand, refuses an existing file unless ``overwrite=True``.

A file is a design file by its ``format`` tag, `FORMAT`; this module knows no other format.
What else a file may be (an oracle case or result) is told by the command line's
[`pes_ref.cli.files`][pes_ref.cli.files], which refuses it before it gets here.
"""
from __future__ import annotations

import dataclasses
import json
import os

import numpy as np

from pes_ref.core.backends import BACKENDS
from pes_ref.core.runtime.keyfile import show
from pes_ref.core.runtime.npz import NpzError, read_npz, write_npz
from pes_ref.synthesis.common.optimizers import optimizer_from_state
from pes_ref.synthesis.common.plans import Plan, PolishPlan
from pes_ref.synthesis.problem.problem_file import ProblemFileError
from pes_ref.synthesis.kinds.registry import KINDS, kind_of
from pes_ref.synthesis.engine.design_state import STAGES, DesignState
from pes_ref.synthesis.common.validation import Best

__all__ = ["save_design", "load_design", "design_arrays", "first_difference", "DesignFileError",
           "FORMAT", "VERSION", "READABLE_VERSIONS"]

#: The ``format`` tag of a design file: what tells it from any other ``.npz``.
FORMAT = "pes_ref.design"
VERSION = 5
#: The versions this package reads.
READABLE_VERSIONS = (1, 2, 3, 4, 5)
_REQUIRED = ("format", "version", "kind", "problem", "plan", "seed", "iteration", "values", "loss", "metric",
             "status", "elapsed")
#: Keys a version-2 file has beyond version 1's.
_REQUIRED_V2 = ("method", "stage", "polish", "base_values", "evaluations", "polish_evals", "polish_fitness")
#: Keys a version-4 file has beyond version 3's.
_REQUIRED_V4 = ("valid_iters", "valid_success", "best_iteration", "best_success", "best_values")


class DesignFileError(ValueError):
    """A file that is not a readable design, or one from another scene."""


def _fields(obj) -> dict:
    return {f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)}


def save_design(path, state: DesignState, *, overwrite: bool = False) -> None:
    """Write ``state`` to ``path`` (``.npz``); refuse an existing file unless ``overwrite``.

    Raises
    ------
    FileExistsError
        If ``path`` exists and ``overwrite`` is False (the file is left as it was).
    """
    write_npz(path, design_arrays(state), overwrite=overwrite, compress=False, what="design")


def design_arrays(state: DesignState) -> dict:
    """The named arrays of a design file (the keys of the module docstring) holding ``state``."""
    arrays = {
        "format": np.array(FORMAT), "version": np.array(VERSION, dtype=np.int64),
        "kind": np.array(state.kind),
        "problem": np.array(kind_of(state.problem).to_text(state.problem)),
        "plan": np.array(json.dumps(_fields(state.plan), sort_keys=True)),
        "seed": np.array(state.seed, dtype=np.int64), "iteration": np.array(state.iteration, dtype=np.int64),
        "values": np.asarray(state.values, dtype=np.float64),
        "loss": np.asarray(state.history["loss"], dtype=np.float64).reshape(-1),
        "metric": np.asarray(state.history["metric"], dtype=np.float64).reshape(-1),
        "status": np.array(state.status), "elapsed": np.array(float(state.elapsed)),
        "method": np.array(state.method), "stage": np.array(state.stage),
        "polish": np.array(json.dumps(None if state.polish is None else _fields(state.polish), sort_keys=True)),
        "base_values": np.zeros(0) if state.base_values is None else np.asarray(state.base_values, dtype=np.float64),
        "evaluations": np.array(state.evaluations, dtype=np.int64),
        "polish_evals": np.asarray(state.polish_history["evaluations"], dtype=np.int64).reshape(-1),
        "polish_fitness": np.asarray(state.polish_history["fitness"], dtype=np.float64).reshape(-1),
        "backend": np.array(state.backend),
        "valid_iters": np.asarray(state.validation["iteration"], dtype=np.int64).reshape(-1),
        "valid_success": np.asarray(state.validation["success"], dtype=np.float64).reshape(-1),
        "best_iteration": np.array(-1 if state.best is None else state.best.iteration, dtype=np.int64),
        "best_success": np.array(np.nan if state.best is None else state.best.success, dtype=np.float64),
        "best_values": np.zeros(0) if state.best is None else np.asarray(state.best.values, dtype=np.float64),
        "screened": np.array([state.screened["starts"], state.screened["iterations"]], dtype=np.int64),
    }
    for k, v in state.optimizer.state_dict().items():
        arrays["opt_" + k] = v
    return arrays


def load_design(path) -> DesignState:
    """Read a design file back into a [`DesignState`][pes_ref.synthesis.engine.design_state.DesignState] (bit-exact).

    Raises
    ------
    DesignFileError
        If ``path`` is not an ``.npz`` design file of a version this package reads.
    FileNotFoundError
        If it does not exist.
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise FileNotFoundError(f"design file {path} does not exist")
    try:
        data = read_npz(path, what="design")
    except NpzError as exc:           # not an .npz, a damaged one, pickled members
        raise DesignFileError(str(exc)) from None
    if str(data.get("format", "")) != FORMAT:
        raise DesignFileError(f"{path} is not a design file (no format tag {FORMAT!r}; keys {sorted(data)[:8]})")
    missing = [k for k in _REQUIRED if k not in data]
    if missing:
        raise DesignFileError(f"{path} is a damaged design file: missing keys {missing}")
    version = int(data["version"])
    if version not in READABLE_VERSIONS:
        raise DesignFileError(f"{path} is a design file of version {version}; this pes_ref reads versions "
                              f"{', '.join(map(str, READABLE_VERSIONS))}")
    missing = [k for k in (_REQUIRED_V2 if version >= 2 else ()) + (_REQUIRED_V4 if version >= 4 else ())
               if k not in data]
    if missing:
        raise DesignFileError(f"{path} is a damaged design file: missing keys {missing}")
    kind = str(data["kind"])
    if kind not in KINDS:
        raise DesignFileError(f"{path} has unknown design kind {kind!r}; expected one of {sorted(KINDS)}")
    try:
        problem = KINDS[kind].from_text(str(data["problem"]), path)
    except ProblemFileError as exc:              # its problem file's text: one line naming the key
        raise DesignFileError(str(exc)) from None
    except (TypeError, KeyError, ValueError) as exc:
        raise DesignFileError(f"{path} is a damaged design file: {exc}") from None
    try:

        plan_fields = json.loads(str(data["plan"]))
        plan_fields["stages"] = tuple(tuple(s) for s in plan_fields["stages"])
        plan = Plan(**plan_fields)
        opt = optimizer_from_state({k[4:]: v for k, v in data.items() if k.startswith("opt_")})
    except (TypeError, KeyError, ValueError) as exc:
        raise DesignFileError(f"{path} is a damaged design file: {exc}") from None
    iteration = int(data["iteration"])
    loss, metric = data["loss"], data["metric"]
    if loss.shape != (iteration,) or metric.shape != (iteration,):
        raise DesignFileError(f"{path} is a damaged design file: history lengths {loss.shape}, {metric.shape} "
                              f"for iteration {iteration}")
    state = DesignState(problem, plan, int(data["seed"]), np.array(data["values"], dtype=np.float64), opt,
                        iteration, {"loss": loss.tolist(), "metric": metric.tolist()}, str(data["status"]),
                        float(data["elapsed"]))
    if version >= 2:
        _read_polish(path, data, state)
    if version >= 3:
        backend = str(data.get("backend", ""))
        if backend not in BACKENDS:
            raise DesignFileError(f"{path} is a damaged design file: backend {backend!r}, expected one of "
                                  f"{sorted(BACKENDS)}")
        state.backend = backend
    if version >= 4:
        _read_validation(path, data, state)
    if "screened" in data:
        screened = data["screened"]
        if screened.shape != (2,) or (screened < 0).any():
            raise DesignFileError(f"{path} is a damaged design file: screened {screened.tolist()}, expected two "
                                  f"counts >= 0")
        state.screened = {"starts": int(screened[0]), "iterations": int(screened[1])}
    return state


def _read_validation(path, data: dict, state: DesignState) -> None:
    """The version-4 fields: the validations made and the best grid."""
    iters, success = data["valid_iters"], data["valid_success"]
    if iters.shape != success.shape:
        raise DesignFileError(f"{path} is a damaged design file: validation history lengths {iters.shape}, "
                              f"{success.shape}")
    state.validation = {"iteration": [int(i) for i in iters], "success": success.tolist()}
    best = int(data["best_iteration"])
    if best >= 0:
        state.best = Best(best, float(data["best_success"]), np.array(data["best_values"], dtype=np.float64))


def _read_polish(path, data: dict, state: DesignState) -> None:
    """The version-2 fields: the polish plan, the stage and the polish's progress."""
    try:
        fields = json.loads(str(data["polish"]))
        state.polish = None if fields is None else PolishPlan(**fields)
    except (TypeError, ValueError) as exc:
        raise DesignFileError(f"{path} is a damaged design file: polish plan: {exc}") from None
    stage, method = str(data["stage"]), str(data["method"])
    if stage not in STAGES or method != state.method or (stage == "polish" and state.polish is None):
        polish = "none" if state.polish is None else repr(state.polish.method)
        raise DesignFileError(f"{path} is a damaged design file: stage {stage!r}, method {method!r} with polish "
                              f"{polish}")
    state.stage = stage
    base = np.array(data["base_values"], dtype=np.float64)
    state.base_values = base if stage == "polish" else None
    if stage == "polish" and base.shape != state.values.shape:
        raise DesignFileError(f"{path} is a damaged design file: base_values {base.shape}, values "
                              f"{state.values.shape}")
    state.evaluations = int(data["evaluations"])
    evals, fitness = data["polish_evals"], data["polish_fitness"]
    if evals.shape != fitness.shape:
        raise DesignFileError(f"{path} is a damaged design file: polish history lengths {evals.shape}, "
                              f"{fitness.shape}")
    state.polish_history = {"evaluations": [int(e) for e in evals], "fitness": fitness.tolist()}


def first_difference(a, b, where: str = "") -> str | None:
    """Where the plain data ``b`` first differs from ``a`` (a design's problem): its dotted key
    and both values (None: equal)."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in list(a) + [k for k in b if k not in a]:
            at = f"{where}.{key}" if where else str(key)
            if key not in b:
                return f"{at} is not given there, {show(a[key])} in the design's problem"
            if key not in a:
                return f"{at} = {show(b[key])} there, not given in the design's problem"
            found = first_difference(a[key], b[key], at)
            if found:
                return found
        return None
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return next((d for i, (x, y) in enumerate(zip(a, b)) if (d := first_difference(x, y, f"{where}[{i}]"))),
                    None)
    return None if a == b else f"{where} = {show(b)} there, {show(a)} in the design's problem"
