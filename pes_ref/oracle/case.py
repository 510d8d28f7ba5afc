"""The oracle: the case/result ``.npz`` interchange format of docs/spec.md sections 8-9.

A *case* is one ``.npz`` file naming a scene, its initial state, an objective and a
regularization weight; the oracle runs it with the reference engine and writes a
*result* ``.npz`` holding the trajectory, the energy, the loss and one ``grad_<name>``
per differentiable input the case uses. Any implementation, in any language, can read
and write both, so a case is the unit of cross-implementation testing (the shipped
conformance vectors of [`pes_ref.oracle.conformance`][pes_ref.oracle.conformance] are cases plus their results).

The format is ``docs/spec.md`` sections 8-9 (``docs/oracle.md`` keeps the history of its decisions).
This module holds the format (which keys, which kinds of data), the validation of a
case and running it; the ``.npz`` files are read and written by
[`pes_ref.core.runtime.npz`][pes_ref.core.runtime.npz], whose refusals [`read_npz`][pes_ref.oracle.case.read_npz]
turns into the oracle's own errors ([`pes_ref.oracle.errors`][pes_ref.oracle.errors]).

Examples
--------
>>> import numpy as np, tempfile, os
>>> from pes_ref import oracle
>>> case = dict(values=np.zeros((5, 7)), lower=[0.0, 0.0], upper=[1.0, 1.5],
...             periodic=[False, False], dt=0.05, n_steps=10, mode="dynamic",
...             mass=1.0, damping=0.0, x0=[[0.3, 0.4]], v0=[[0.1, 0.0]],
...             objective="funnel", target=0.5, when="final")
>>> result = oracle.run_case(case)
>>> sorted(result)[:4]
['energy', 'grad_damping', 'grad_force', 'grad_mass']
>>> result["x"].shape
(11, 1, 2)
"""
from __future__ import annotations

import os
from collections.abc import Mapping
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from pes_ref.core import backends, budget, checks, stability
from pes_ref.core.runtime import npz, pages
from pes_ref.core.runtime.files import ResultExistsError
from pes_ref.core.integrator import LOOKUP_RANGE, NonFiniteError
from pes_ref.core.objectives import Funnel, Oscillator, Quadratic
from pes_ref.core.scene import MODES, Scene, gradient_names, value_and_grad
from pes_ref.core.surface import Surface
from pes_ref.core.terms import Spring, Walls
from pes_ref.oracle.errors import CaseError, CaseTypeError
from pes_ref.core.runtime.npz import write_npz

__all__ = [
    "CaseError", "CaseTypeError", "ResultExistsError", "ValidCase",
    "REQUIRED_KEYS", "OPTIONAL_KEYS", "OBJECTIVE_PARAMS", "CASE_KEYS", "KEY_GROUPS",
    "load_case", "validate_case", "run_case", "write_result", "run_case_file", "save_case",
    "read_npz", "write_npz", "result_keys", "TRAJECTORY_KEYS",
]

#: Keys every case must hold (docs/spec.md section 8.2: those marked required). ``v0``, ``mass``
#: and ``damping`` are required in quasistatic mode too, although they play no part there.
REQUIRED_KEYS = ("values", "lower", "upper", "periodic", "dt", "n_steps", "mode",
                 "mass", "damping", "x0", "v0", "objective")

#: Optional keys. ``mobility`` is required in quasistatic mode and refused in dynamic mode.
OPTIONAL_KEYS = ("t0", "mobility", "force", "spring_k", "spring_center",
                 "wall_k", "wall_margin", "walls", "regularization")

#: Each objective's parameters; all of them are required with that objective, and a
#: parameter of another objective is refused.
OBJECTIVE_PARAMS = {
    "funnel": ("target", "when"),
    "oscillator": ("amplitude", "omega"),
    "quadratic": ("wx", "wv", "xref", "vref"),
}

#: Keys that come all together or not at all.
KEY_GROUPS = (("spring_k", "spring_center"), ("wall_k", "wall_margin", "walls"))

#: Every key a case may hold (docs/spec.md section 8.2): required, optional, objective parameters.
CASE_KEYS = REQUIRED_KEYS + OPTIONAL_KEYS + tuple(p for ps in OBJECTIVE_PARAMS.values() for p in ps)

#: The names the core's errors carry (`pes_ref.core.checks.InputError.key`) that
#: are not case keys, and the case key each stands for. The core names every argument
#: the oracle hands it after its case key (``wall_margin``, ``walls``, ``spring_k`` ...),
#: so only the names of whole objects, which a case never holds, need translating.
CORE_NAME_TO_CASE_KEY = {
    "surface": "values",        # the Surface built from values, lower, upper, periodic
    "spring": "spring_k",       # the Spring built from spring_k, spring_center
    "effects": "force",         # the external force (a case holds it as the force schedule)
}


# =========================================================================== files

def read_npz(path, *, what: str = "case") -> dict:
    """Every array of the ``.npz`` file ``path``, read without pickle
    ([`pes_ref.core.runtime.npz.read_npz`][pes_ref.core.runtime.npz.read_npz]), its refusals the oracle's.

    Raises
    ------
    OSError
        The file cannot be opened.
    CaseError
        Not an ``.npz`` archive, a damaged one, or a member that cannot be read (keyed by it; a
        [`CaseTypeError`][pes_ref.oracle.errors.CaseTypeError] if only pickle could read it).
    """
    try:
        return npz.read_npz(path, what=what)
    except npz.NpzError as exc:
        error = CaseTypeError if isinstance(exc, TypeError) else CaseError
        raise error(exc.key, exc.reason) from None


def load_case(path) -> dict:
    """Read a case file: ``np.load(path, allow_pickle=False)`` into a plain dict.

    The arrays are not validated here; see [`validate_case`][pes_ref.oracle.case.validate_case].

    Raises
    ------
    OSError
        The file cannot be opened.
    CaseError
        Not an ``.npz`` archive, or a member needs pickle.
    """
    return read_npz(path, what="case")


def save_case(path, *, overwrite: bool = False, compress: bool = True, **keys) -> None:
    """Write a case file from keyword arrays (strings stored as 0-d unicode arrays).

    The keys are written as given and not validated, so that invalid cases can be
    written too (the conformance vectors need them); run [`validate_case`][pes_ref.oracle.case.validate_case] first to
    check a case. Like [`write_result`][pes_ref.oracle.case.write_result], an existing file is refused
    ([`ResultExistsError`][pes_ref.core.runtime.files.ResultExistsError]) unless ``overwrite``.

    Examples
    --------
    >>> save_case("c.npz", values=np.zeros((2, 2)), mode="dynamic", ...)  # doctest: +SKIP
    """
    write_npz(path, keys, overwrite=overwrite, compress=compress, what="case")


# =========================================================================== validation

@dataclass(frozen=True)
class ValidCase:
    """A validated case, ready to run.

    Attributes
    ----------
    scene : Scene
    x0, v0 : ndarray (N, 2)
    force : ndarray (T+1, N, 2)
        The external force schedule (zeros when the case has no ``force``), read-only: a view
        of the case's own array when that is float64 and C-contiguous already.
    objective : Funnel, Oscillator or Quadratic
    regularization : float
    grad_names : tuple of str
        The differentiable inputs the case uses, in `pes_ref.GRADIENT_NAMES` order.
    """

    scene: Scene
    x0: np.ndarray
    v0: np.ndarray
    force: np.ndarray
    objective: object
    regularization: float
    grad_names: tuple

    def __iter__(self):
        """Unpack as ``scene, x0, v0, objective, regularization, force, grad_names``."""
        return iter((self.scene, self.x0, self.v0, self.objective, self.regularization,
                     self.force, self.grad_names))


@contextmanager
def _core_checks():
    """Turn the core's keyed [`InputError`][pes_ref.core.checks.InputError] into a
    [`CaseError`][pes_ref.oracle.errors.CaseError] naming the case key (`CORE_NAME_TO_CASE_KEY`); a
    [`InputTypeError`][pes_ref.core.checks.InputTypeError] becomes a [`CaseTypeError`][pes_ref.oracle.errors.CaseTypeError]."""
    try:
        yield
    except CaseError:
        raise
    except checks.InputError as exc:
        key = CORE_NAME_TO_CASE_KEY.get(exc.key, exc.key)
        raise (CaseTypeError if isinstance(exc, TypeError) else CaseError)(key, str(exc)) from None


# ---------------------------------------------------------------- the file format: kinds of data

def _describe(value) -> str:
    arr = np.asarray(value) if not isinstance(value, (str, bytes)) else None
    if arr is None:
        return f"the {type(value).__name__} {value!r}"
    return f"dtype {arr.dtype}, shape {arr.shape}"


def _numeric(key: str, value) -> np.ndarray:
    """The value as a NumPy array of integer or float dtype (nothing else is a number here)."""
    if isinstance(value, (str, bytes)):
        raise CaseTypeError(key, f"{key} must be a real number array, got {_describe(value)}")
    try:
        arr = np.asarray(value)
    except Exception as exc:
        raise CaseTypeError(key, f"{key} must be a real number array ({exc})") from None
    if arr.dtype.kind not in "iuf":
        raise CaseTypeError(key, f"{key} must be a real number array of integer or float dtype, "
                                 f"got {_describe(arr)}")
    return arr


def _scalar(key: str, value) -> np.ndarray:
    """A 0-d integer or float array (its value is checked by whoever takes it)."""
    arr = _numeric(key, value)
    if arr.ndim != 0:
        raise CaseError(key, f"{key} must be a scalar (a 0-d array), got shape {arr.shape}")
    return arr


def _integer(key: str, value) -> np.ndarray:
    if isinstance(value, (str, bytes)) or np.asarray(value).dtype.kind not in "iu":
        raise CaseTypeError(key, f"{key} must be an integer (a 0-d integer array), got {_describe(value)}")
    if np.asarray(value).ndim != 0:
        raise CaseError(key, f"{key} must be a scalar (a 0-d array), got shape {np.asarray(value).shape}")
    return np.asarray(value)


def _flags(key: str, value) -> np.ndarray:
    """A bool (or 0/1 integer) array; its shape and values are checked by whoever takes it."""
    arr = np.asarray(value) if not isinstance(value, (str, bytes)) else None
    if arr is None or arr.dtype.kind not in "biu":
        raise CaseTypeError(key, f"{key} must be a bool array, got {_describe(value)}")
    return arr


def _string(key: str, value, choices) -> str:
    """A string stored as a 0-d unicode array (a Python ``str`` in memory is the same)."""
    if isinstance(value, np.ndarray) and value.dtype.kind == "U" and value.ndim == 0:
        value = str(value)
    if not isinstance(value, str):
        raise CaseTypeError(key, f"{key} must be a string stored as a 0-d unicode array, got {_describe(value)}")
    if choices is not None and value not in choices:
        raise CaseError(key, f"{key} must be one of {list(choices)}, got {value!r}")
    return value


# ---------------------------------------------------------------- which keys a case holds

def _check_key_names(raw: Mapping) -> None:
    for key in raw:
        if not isinstance(key, str):
            raise CaseTypeError(str(key), f"case keys must be strings, got {key!r}")
    for key in sorted(raw):
        if key not in CASE_KEYS:
            raise CaseError(key, f"unknown key; a case holds only {list(CASE_KEYS)}")
    for key in REQUIRED_KEYS:
        if key not in raw:
            raise CaseError(key, "missing required key")


def _check_key_rules(raw: Mapping, mode: str, objective: str) -> None:
    """Keys that depend on the mode, the objective and each other."""
    for name, params in OBJECTIVE_PARAMS.items():
        for p in params:
            if name != objective and p in raw and p not in OBJECTIVE_PARAMS[objective]:
                raise CaseError(p, f"is a parameter of objective {name!r}, not of this case's "
                                   f"objective {objective!r} (which takes {list(OBJECTIVE_PARAMS[objective])})")
    for p in OBJECTIVE_PARAMS[objective]:
        if p not in raw:
            raise CaseError(p, f"missing required key (objective {objective!r} takes "
                               f"{list(OBJECTIVE_PARAMS[objective])})")
    if mode == "quasistatic" and "mobility" not in raw:
        raise CaseError("mobility", "missing required key (mode 'quasistatic' needs a mobility, shape (2,), > 0)")
    if mode == "dynamic" and "mobility" in raw:
        raise CaseError("mobility", "is only for mode 'quasistatic'; this case is dynamic")
    for group in KEY_GROUPS:
        present = [k for k in group if k in raw]
        if present and len(present) < len(group):
            missing = [k for k in group if k not in raw][0]
            raise CaseError(missing, f"missing: the keys {list(group)} come together, and the case has "
                                     f"only {present}")


# ---------------------------------------------------------------- the shapes that N and T set

def _state(raw: Mapping):
    """x0 (N, 2) with N >= 1 and v0 like it, as float64: the initial state is no part of a
    scene, so it is checked here (with [`pes_ref.core.checks.as_float_array`][pes_ref.core.checks.as_float_array])."""
    with _core_checks():
        x0 = checks.as_float_array("x0", _numeric("x0", raw["x0"]), shape=(None, 2))
        if x0.shape[0] < 1:
            raise CaseError("x0", "x0 must hold at least one particle, got shape (0, 2)")
        n = x0.shape[0]
        v0 = checks.as_float_array("v0", _numeric("v0", raw["v0"]))
    if v0.shape != (n, 2):
        raise CaseError("v0", f"v0 must have shape (N, 2) = ({n}, 2) like x0, got shape {v0.shape}")
    return x0, v0


def _check_lookup_range(x0: np.ndarray, surface: Surface) -> None:
    """x0 on a periodic axis within `LOOKUP_RANGE` cells of
    ``lower`` (docs/spec.md section 8.6): farther, float64 holds no fraction of a cell."""
    with np.errstate(over="ignore"):        # a reach beyond float64 is no limit; x0 - lower beyond it is past
        reach = LOOKUP_RANGE * surface.spacing
        far_out = [np.abs(x0[:, d] - surface.lower[d]) >= reach[d] for d in range(2)]
    for d, far in enumerate(far_out):
        if surface.periodic[d] and far.any():
            i = int(np.argmax(far))
            raise CaseError("x0", f"x0[{i}, {d}] = {x0[i, d]:.3g} lies 2**52 cells (h = {reach[d] / LOOKUP_RANGE:.3g}) "
                                  f"or more from lower on periodic axis {d}, where float64 holds no fraction of a cell")


def _per_particle(key: str, value, n: int) -> np.ndarray:
    """mass, damping, spring_k, spring_center: numbers that broadcast to the case's (N, 2)
    (a scalar, (2,), (N, 1), (N, 2), or (1,), (1, 1), (1, 2)). Their values are the
    core's to check."""
    arr = _numeric(key, value)
    try:
        fits = np.broadcast_shapes(arr.shape, (n, 2)) == (n, 2)
    except ValueError:
        fits = False
    if not fits:
        raise CaseError(key, f"{key} must broadcast to (N, 2) = ({n}, 2), got shape {arr.shape}")
    return arr


# ---------------------------------------------------------------- building what the core checks

def _surface(raw: Mapping) -> Surface:
    arrays = [_numeric(k, raw[k]) for k in ("values", "lower", "upper")]
    return Surface(*arrays, _flags("periodic", raw["periodic"]))


def _spring(raw: Mapping, n: int):
    if "spring_k" not in raw:
        return None
    return Spring(_per_particle("spring_k", raw["spring_k"], n), _per_particle("spring_center", raw["spring_center"], n))


def _walls(raw: Mapping):
    if "walls" not in raw:
        return None
    return Walls(_scalar("wall_k", raw["wall_k"]), _scalar("wall_margin", raw["wall_margin"]),
                 _flags("walls", raw["walls"]))


def _scene(raw: Mapping, mode: str, n: int) -> Scene:
    """The scene; its keys' kinds and N-shapes are checked in the order of the arguments
    below, their values by [`Surface`][pes_ref.core.surface.Surface], [`Spring`][pes_ref.core.terms.Spring],
    [`Walls`][pes_ref.core.terms.Walls] as each is
    built and then by [`Scene`][pes_ref.core.scene.Scene] (dt, n_steps, t0, mass, damping, mobility, walls)."""
    return Scene(_surface(raw), dt=_scalar("dt", raw["dt"]), n_steps=_integer("n_steps", raw["n_steps"]),
                 mode=mode, mass=_per_particle("mass", raw["mass"], n),
                 damping=_per_particle("damping", raw["damping"], n),
                 mobility=_numeric("mobility", raw["mobility"]) if mode == "quasistatic" else None,
                 spring=_spring(raw, n), walls=_walls(raw), t0=_scalar("t0", raw.get("t0", 0.0)))


def _funnel(raw: Mapping, shape: tuple):
    return Funnel(_scalar("target", raw["target"]), _string("when", raw["when"], None))


def _oscillator(raw: Mapping, shape: tuple):
    return Oscillator(_scalar("amplitude", raw["amplitude"]), _scalar("omega", raw["omega"]))


def _quadratic(raw: Mapping, shape: tuple):
    objective = Quadratic(**{p: _numeric(p, raw[p]) for p in OBJECTIVE_PARAMS["quadratic"]})
    objective.check_shape(shape)            # each parameter broadcasts to the run's (T+1, N, 2)
    return objective


#: How each objective is built from its parameters, for a run of states shaped ``shape``.
_OBJECTIVES = {"funnel": _funnel, "oscillator": _oscillator, "quadratic": _quadratic}


#: Force entries checked finite at a time (a bool temporary of this many stays in cache).
FINITE_CHUNK = 1 << 16


def _force(raw: Mapping, shape: tuple) -> np.ndarray:
    """The force schedule, read-only: a float64 C-contiguous force is a read-only view of the
    case's own array, checked finite a chunk at a time (a copy of a large run's force costs
    more than the run's additions of it); any other is converted, a copy."""
    if "force" not in raw:
        return pages.zeros(shape)
    force = _numeric("force", raw["force"])
    if force.shape != shape:
        raise CaseError("force", f"force must have shape (T+1, N, 2) = {shape}, got shape {force.shape}")
    if force.dtype == np.float64 and force.flags.c_contiguous:
        view = force.view()
        view.setflags(write=False)
        if _all_finite(view):
            return view
    return checks.as_float_array("force", force)      # (a non-finite force: refused with its message)


def _all_finite(a: np.ndarray) -> bool:
    """Whether every entry of a C-contiguous array is finite, `FINITE_CHUNK` entries at a time."""
    flat = a.reshape(-1)
    return all(np.isfinite(flat[i:i + FINITE_CHUNK]).all() for i in range(0, flat.size, FINITE_CHUNK))


#: The keys every result holds before its gradients (docs/spec.md section 9): the trajectory,
#: the energy and the loss.
TRAJECTORY_KEYS = ("x", "v", "energy", "loss")


def result_keys(grad_names) -> tuple:
    """The keys of a result: `TRAJECTORY_KEYS` and ``grad_<name>`` per name."""
    return TRAJECTORY_KEYS + tuple("grad_" + g for g in grad_names)


def validate_case(raw: Mapping, *, allow_unstable: bool = False, backend: str = "numpy") -> ValidCase:
    """Check a case against docs/spec.md section 8 and build what the engine runs.

    The oracle checks what is particular to the file format: which keys a case holds,
    the kind of data in each (numbers of integer or float dtype, 0-d scalars, integer
    ``n_steps``, bool flags, 0-d unicode strings) and the shapes that the case's N and
    T set. The values themselves (finite, signs, shapes of the grid and the domain,
    walls on periodic axes ...) are checked once, by the core's own constructors
    ([`Surface`][pes_ref.core.surface.Surface], [`Spring`][pes_ref.core.terms.Spring],
    [`Walls`][pes_ref.core.terms.Walls],
    [`Scene`][pes_ref.core.scene.Scene], the objectives), whose keyed errors name the case key.

    Parameters
    ----------
    raw : mapping of str -> array_like
        As read by [`load_case`][pes_ref.oracle.case.load_case] (or built in memory; a Python ``str`` is accepted
        wherever a 0-d unicode array is).
    allow_unstable : bool
        Accept a case past the stability rule (docs/spec.md section 10). Not part of the
        contract: a conforming program refuses such a case; this is for studying the
        unstable scheme on purpose.
    backend : {"numpy", "numba"}
        The loops that will run the case ([`run_case`][pes_ref.oracle.case.run_case]); the stability rule takes the
        grid's cross curvature on them too (the same number). Checked first.

    Returns
    -------
    ValidCase

    Raises
    ------
    CaseError
        The first rule the case breaks, naming its key (a [`CaseTypeError`][pes_ref.oracle.errors.CaseTypeError], also
        a ``TypeError``, when the key holds the wrong kind of data). Keys are checked
        in a fixed order: names (unknown, then missing), mode and objective, the key
        rules (objective parameters, mobility, groups), the initial state, the scene's
        keys, the force, the objective's parameters, the regularization; last the
        stability rule ([`pes_ref.core.stability.check_stable`][pes_ref.core.stability.check_stable]), naming ``dt`` or
        ``mobility``. Right after the scene's keys, before any array of the run's size
        is built, a run that cannot fit in the available memory is refused naming
        ``n_steps`` ([`pes_ref.core.budget.check_memory`][pes_ref.core.budget.check_memory]; not part of the contract).
    """
    backend = backends.check_backend(backend)
    if not isinstance(raw, Mapping):
        raise CaseTypeError(None, f"a case is a mapping of key -> array, got {type(raw).__name__}")
    _check_key_names(raw)
    mode = _string("mode", raw["mode"], MODES)
    objective_name = _string("objective", raw["objective"], tuple(OBJECTIVE_PARAMS))
    _check_key_rules(raw, mode, objective_name)

    x0, v0 = _state(raw)
    n = x0.shape[0]
    with _core_checks():
        scene = _scene(raw, mode, n)
        _check_lookup_range(x0, scene.surface)
        budget.check_memory(scene.n_steps, n, "case")
        shape = (scene.n_steps + 1, n, 2)
        force = _force(raw, shape)
        objective = _OBJECTIVES[objective_name](raw, shape)
        reg = checks.as_nonneg_float("regularization", _scalar("regularization", raw.get("regularization", 0.0)))
        if not allow_unstable:
            stability.check_stable(scene, backend)
    return ValidCase(scene, x0, v0, force, objective, reg, gradient_names(mode, scene.spring is not None))


# =========================================================================== running

def run_case(case, *, allow_unstable: bool = False, monitor=None, backend: str = "numpy") -> dict:
    """Run a case with the reference engine: the oracle.

    Parameters
    ----------
    case : mapping, str or os.PathLike
        A case dict, or the path of a case file.
    allow_unstable : bool
        Run a case past the stability rule anyway (see [`validate_case`][pes_ref.oracle.case.validate_case]).
    monitor : callable, optional
        Called once, after the case is validated and before it runs, with the run's
        [`pes_ref.core.budget.RunEstimate`][pes_ref.core.budget.RunEstimate] (steps, particles, memory, seconds); it
        returns a progress callback ``(phase, done, total)`` for the run's forward loop
        and adjoint ([`pes_ref.core.runtime.progress`][pes_ref.core.runtime.progress]), or None for no reports.
    backend : {"numpy", "numba"}
        The loops that run it (`pes_ref.core.backends.BACKENDS`): NumPy's by default,
        so that the oracle imports no compiler; the compiled ones give the same trajectory
        and gradients to 1e-13 of their largest entry.

    Returns
    -------
    dict of str -> ndarray (float64)
        ``x``, ``v`` (T+1, N, 2), ``energy`` (T+1, N), ``loss`` (0-d) and ``grad_<name>`` for every
        name of [`pes_ref.core.scene.gradient_names`][pes_ref.core.scene.gradient_names], each
        shaped like its input (``grad_force`` (T+1, N, 2)).

    Raises
    ------
    CaseError
        The case breaks docs/spec.md section 8, is past the stability rule (section 10), or its run
        leaves the finite numbers (blamed on ``dt`` in dynamic mode, ``mobility`` in quasistatic mode).
    """
    if isinstance(case, (str, os.PathLike)):
        case = load_case(case)
    vc = validate_case(case, allow_unstable=allow_unstable, backend=backend)
    scene = vc.scene
    progress = None if monitor is None else monitor(budget.estimate(scene.n_steps, vc.x0.shape[0], "case"))
    blame = "dt" if scene.mode == "dynamic" else "mobility"
    try:
        with np.errstate(over="raise", invalid="raise", divide="raise", under="ignore"):
            e = pages.empty((scene.n_steps + 1, vc.x0.shape[0]))
            loss, grads, traj = value_and_grad(scene, vc.x0, vc.v0, vc.objective,
                                               regularization_weight=vc.regularization,
                                               wrt=vc.grad_names, fext=vc.force, progress=progress, backend=backend,
                                               checked=True, energy_out=e)       # checked by validate_case, once
    except NonFiniteError as exc:             # its message names the step and a stable value
        raise CaseError(blame, str(exc)) from None
    except FloatingPointError as exc:
        raise CaseError(blame, f"the run left the finite numbers ({exc}); {stability.advice(scene)}") from None
    except MemoryError:
        raise CaseError("n_steps", f"a run of n_steps={scene.n_steps} does not fit in memory") from None
    values = dict(zip(TRAJECTORY_KEYS, (traj.x, traj.v, e, np.float64(loss))))
    values.update(("grad_" + name, grads[name]) for name in vc.grad_names)
    result = {k: _own_array(values[k]) for k in result_keys(vc.grad_names)}
    # x and v are finite (the run checked them); the rest is checked here, once, for an overflow
    # that raised nothing (a sum by einsum or BLAS sets no floating-point flag)
    bad = next((k for k in result if k not in ("x", "v") and not _all_finite(result[k])), None)
    if bad is not None:
        raise CaseError(blame, f"the result's {bad} is not finite: an overflow computing the loss, the energy or "
                               f"the gradients ({scene.mode} mode; docs/spec.md section 12.1)")
    return result


def _own_array(a) -> np.ndarray:
    """``a`` as a float64 array of the result's own: the run's fresh arrays as they are (a copy of a
    trajectory costs a pass over it and its page faults), anything else (a view, a read-only or
    strided array, a scalar) copied."""
    if isinstance(a, np.ndarray) and a.dtype == np.float64 and pages.owns(a) and a.flags.writeable \
            and a.flags.c_contiguous:
        return a
    return np.array(a, dtype=np.float64)


def write_result(result: Mapping, path, overwrite: bool = False, compress: bool = False) -> None:
    """Write a result dict to ``path`` (temporary file, then an atomic move).

    Members are stored uncompressed unless ``compress``: deflating float64 trajectories
    and gradients saves little space (their low bits look random) and costs more time
    than the paper-sized funnel's whole computation. ``np.load`` reads both.

    Raises
    ------
    ResultExistsError
        ``path`` exists and ``overwrite`` is False; nothing is written.
    """
    write_npz(path, result, overwrite=overwrite, compress=compress)


def run_case_file(case_path, result_path, overwrite: bool = False, compress: bool = False, *,
                  allow_unstable: bool = False, monitor=None, backend: str = "numpy") -> dict:
    """Run the case file ``case_path`` and write its result to ``result_path``
    (deflated if ``compress``; see [`write_result`][pes_ref.oracle.case.write_result]).

    Nothing is written when the case is refused, when its run fails, or when
    ``result_path`` exists and ``overwrite`` is False. ``allow_unstable``, ``monitor`` and
    ``backend`` as in [`run_case`][pes_ref.oracle.case.run_case].

    Returns
    -------
    dict
        The result that was written.
    """
    case_path, result_path = os.fspath(case_path), os.fspath(result_path)
    if os.path.lexists(result_path):
        if os.path.exists(case_path) and os.path.samefile(case_path, result_path):
            raise ValueError(f"the result path {result_path!r} is the case file itself")
        if not overwrite:
            raise ResultExistsError(result_path)
    result = run_case(load_case(case_path), allow_unstable=allow_unstable, monitor=monitor, backend=backend)
    write_result(result, result_path, overwrite=overwrite, compress=compress)
    return result
