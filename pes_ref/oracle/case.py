"""The oracle: the case/result ``.npz`` interchange format of SPEC section 6.

A *case* is one ``.npz`` file naming a scene, its initial state, an objective and a
regularization weight; the oracle runs it with the reference engine and writes a
*result* ``.npz`` holding the trajectory, the energy, the loss and one ``grad_<name>``
per differentiable input the case uses. Any implementation, in any language, can read
and write both, so a case is the unit of cross-implementation testing (the shipped
conformance vectors of :mod:`pes_ref.oracle.conformance` are cases plus their results).

The format decisions that the SPEC leaves open are written down in ``docs/oracle.md``.

Example
-------
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

import errno
import os
import re
import secrets
import zipfile
from collections.abc import Mapping
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from pes_ref.core import checks
from pes_ref.core.objectives import Funnel, Oscillator, Quadratic
from pes_ref.core.scene import Scene, energy, gradient_names, value_and_grad
from pes_ref.core.surface import Surface
from pes_ref.core.terms import Spring, Walls

__all__ = [
    "CaseError", "CaseTypeError", "ResultExistsError", "ValidCase",
    "REQUIRED_KEYS", "OPTIONAL_KEYS", "OBJECTIVE_PARAMS", "CASE_KEYS", "KEY_GROUPS",
    "load_case", "validate_case", "run_case", "write_result", "run_case_file", "save_case",
    "read_npz", "write_npz", "result_keys",
]

MODES = ("dynamic", "quasistatic")

#: Keys every case must hold (SPEC section 6: the keys without brackets). ``v0``, ``mass``
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

#: Every key a case may hold, in the SPEC's order.
CASE_KEYS = REQUIRED_KEYS + OPTIONAL_KEYS + tuple(p for ps in OBJECTIVE_PARAMS.values() for p in ps)

_STRING_KEYS = ("mode", "objective", "when")
_FIXED_DATE = (1980, 1, 1, 0, 0, 0)   # the zip epoch: written files do not depend on the clock
_ZIP64_ABOVE = 1 << 30                # zip64 headers only for members that may need them


# =========================================================================== errors

class CaseError(ValueError):
    """A case that breaks SPEC section 6.

    Parameters
    ----------
    key : str or None
        The case key at fault (None for a file that is not a readable ``.npz`` at all).
    reason : str
        What is wrong with it.

    The message is ``"case key '<key>': <reason>"``, one line.
    """

    def __init__(self, key: str | None, reason: str):
        self.key = key
        self.reason = " ".join(str(reason).split())
        super().__init__(self.reason if key is None else f"case key {key!r}: {self.reason}")


class CaseTypeError(CaseError, TypeError):
    """A case key holding the wrong kind of data (a string where a number belongs, a
    float ``n_steps``, an object array ...). Both a :class:`CaseError` and a ``TypeError``."""


class ResultExistsError(FileExistsError):
    """The result file exists already and ``overwrite`` was not asked for."""

    def __init__(self, path):
        self.path = os.fspath(path)
        super().__init__(f"result file {self.path!r} exists already; refusing to overwrite it "
                         "(pass overwrite=True, or --force on the command line)")

    def __str__(self):
        return self.args[0]


@contextmanager
def _about(key: str):
    """Turn a ValueError/TypeError of the checks layer into a CaseError naming ``key``."""
    try:
        yield
    except CaseError:
        raise
    except TypeError as exc:
        raise CaseTypeError(key, str(exc)) from None
    except ValueError as exc:
        raise CaseError(key, str(exc)) from None


# =========================================================================== npz files

def read_npz(path, *, what: str = "case") -> dict:
    """Read every array of an ``.npz`` file without pickle.

    Parameters
    ----------
    path : str or os.PathLike
    what : str
        "case" or "result", for the error messages.

    Returns
    -------
    dict of str -> ndarray

    Raises
    ------
    OSError
        The file cannot be opened (missing, a directory, no permission).
    CaseError
        The file is not an ``.npz`` archive, or a member cannot be read without pickle.
    """
    path = os.fspath(path)
    try:
        npz = np.load(path, allow_pickle=False)
    except OSError:
        raise
    except Exception as exc:  # not a zip, truncated zip, an .npy with object dtype ...
        raise CaseError(None, f"{what} file {path!r} is not a readable .npz archive ({exc})") from None
    if not isinstance(npz, np.lib.npyio.NpzFile):
        raise CaseError(None, f"{what} file {path!r} holds a single .npy array, not an .npz archive of named arrays")
    out = {}
    with npz:
        for key in npz.files:
            try:
                value = npz[key]
            except ValueError as exc:
                raise CaseTypeError(key, f"cannot be read without pickle ({exc}); {what}s hold "
                                         "numeric, bool or unicode arrays only") from None
            except Exception as exc:
                raise CaseError(key, f"cannot be read from {path!r} ({exc})") from None
            if not isinstance(value, np.ndarray):
                raise CaseTypeError(key, f"is not a .npy array inside {path!r}")
            out[key] = value
    return out


def _as_storable(key, value) -> np.ndarray:
    if not isinstance(key, str) or not key.isidentifier():
        raise ValueError(f"array names must be identifiers, got {key!r}")
    arr = np.asarray(value)   # a Python str becomes a 0-d unicode array
    if arr.dtype.hasobject:
        raise TypeError(f"{key}: object arrays cannot be stored (they would need pickle)")
    return arr


def write_npz(path, arrays: Mapping, *, overwrite: bool = False, compress: bool = True) -> None:
    """Write named arrays to an ``.npz`` file atomically and reproducibly.

    The archive is written to a temporary file in the same folder, then moved into
    place with :func:`os.replace` (or hard-linked, which fails if ``path`` exists when
    ``overwrite`` is False), so a reader never sees half a file. Every member carries
    the same fixed date, so the same arrays always give the same bytes.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write (no ``.npz`` suffix is added).
    arrays : mapping of str -> array_like
        Python strings become 0-d unicode arrays; object arrays are refused.
    overwrite : bool
        Replace an existing file; otherwise raise :class:`ResultExistsError`.
    compress : bool
        Deflate the members (``np.load`` reads both).
    """
    path = os.fspath(path)
    items = [(k, _as_storable(k, v)) for k, v in arrays.items()]
    if not overwrite and os.path.lexists(path):
        raise ResultExistsError(path)
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise FileNotFoundError(errno.ENOENT, "the folder to write into does not exist", folder)
    tmp = os.path.join(folder, f".{os.path.basename(path)}.{secrets.token_hex(6)}.tmp")
    method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    try:
        with open(tmp, "xb") as fh, zipfile.ZipFile(fh, "w", compression=method) as zf:
            for key, arr in items:
                info = zipfile.ZipInfo(key + ".npy", date_time=_FIXED_DATE)
                info.compress_type = method
                info.external_attr = 0o644 << 16
                with zf.open(info, "w", force_zip64=arr.nbytes > _ZIP64_ABOVE) as member:
                    np.lib.format.write_array(member, arr, allow_pickle=False)
        _move_into_place(tmp, path, overwrite)
    finally:
        if os.path.lexists(tmp):
            os.unlink(tmp)


def _move_into_place(tmp: str, path: str, overwrite: bool) -> None:
    if overwrite:
        os.replace(tmp, path)
        return
    try:
        os.link(tmp, path)            # atomic "create if absent"
    except FileExistsError:
        raise ResultExistsError(path) from None
    except OSError:                   # a file system without hard links
        if os.path.lexists(path):
            raise ResultExistsError(path) from None
        os.replace(tmp, path)


def load_case(path) -> dict:
    """Read a case file: ``np.load(path, allow_pickle=False)`` into a plain dict.

    The arrays are not validated here; see :func:`validate_case`.

    Raises
    ------
    OSError
        The file cannot be opened.
    CaseError
        Not an ``.npz`` archive, or a member needs pickle.
    """
    return read_npz(path, what="case")


def save_case(path, *, overwrite: bool = True, compress: bool = True, **keys) -> None:
    """Write a case file from keyword arrays (strings stored as 0-d unicode arrays).

    The keys are written as given and not validated, so that invalid cases can be
    written too (the conformance vectors need them); run :func:`validate_case` first to
    check a case.

    Example
    -------
    >>> save_case("c.npz", values=np.zeros((2, 2)), mode="dynamic", ...)  # doctest: +SKIP
    """
    write_npz(path, keys, overwrite=overwrite, compress=compress)


# =========================================================================== validation

@dataclass(frozen=True)
class ValidCase:
    """A validated case, ready to run.

    Attributes
    ----------
    scene : Scene
    x0, v0 : ndarray (N, 2)
    force : ndarray (T+1, N, 2)
        The external force schedule (zeros when the case has no ``force``).
    objective : Funnel, Oscillator or Quadratic
    regularization : float
    grad_names : tuple of str
        The differentiable inputs the case uses, in :data:`pes_ref.GRADIENT_NAMES` order.
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


def _array(key: str, value, **kw) -> np.ndarray:
    """A float64 array through :func:`pes_ref.core.checks.as_float_array`, errors naming ``key``."""
    arr = _numeric(key, value)
    with _about(key):
        return checks.as_float_array(key, arr, **kw)


def _scalar(key: str, value, check=checks.as_finite_float) -> float:
    arr = _numeric(key, value)
    if arr.ndim != 0:
        raise CaseError(key, f"{key} must be a scalar (a 0-d array), got shape {arr.shape}")
    with _about(key):
        return check(key, arr)


def _integer(key: str, value) -> int:
    if isinstance(value, (str, bytes)) or np.asarray(value).dtype.kind not in "iu":
        raise CaseTypeError(key, f"{key} must be an integer (a 0-d integer array), got {_describe(value)}")
    if np.asarray(value).ndim != 0:
        raise CaseError(key, f"{key} must be a scalar (a 0-d array), got shape {np.asarray(value).shape}")
    with _about(key):
        return checks.as_nonneg_int(key, np.asarray(value))


def _string(key: str, value, choices) -> str:
    """A string stored as a 0-d unicode array (a Python ``str`` in memory is the same)."""
    if isinstance(value, np.ndarray) and value.dtype.kind == "U" and value.ndim == 0:
        value = str(value)
    if not isinstance(value, str):
        raise CaseTypeError(key, f"{key} must be a string stored as a 0-d unicode array, got {_describe(value)}")
    if value not in choices:
        raise CaseError(key, f"{key} must be one of {list(choices)}, got {value!r}")
    return value


def _flags(key: str, value, shape: tuple) -> np.ndarray:
    arr = np.asarray(value) if not isinstance(value, (str, bytes)) else None
    if arr is None or arr.dtype.kind not in "biu":
        raise CaseTypeError(key, f"{key} must be a bool array, got {_describe(value)}")
    with _about(key):
        return checks.as_bool_array(key, arr, shape=shape)


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


def _surface(raw: Mapping) -> Surface:
    values = _array("values", raw["values"], ndim=2)
    if values.shape[0] < 2 or values.shape[1] < 2:
        raise CaseError("values", f"values must have at least 2 nodes per axis, got shape {values.shape}")
    lower = _array("lower", raw["lower"], shape=(2,))
    upper = _array("upper", raw["upper"], shape=(2,))
    if not np.all(upper > lower):
        raise CaseError("upper", f"upper must be > lower on both axes, got lower={lower.tolist()}, "
                                 f"upper={upper.tolist()}")
    periodic = _flags("periodic", raw["periodic"], (2,))
    with _about("values"):
        return Surface(values, lower, upper, tuple(bool(p) for p in periodic))


def _state(raw: Mapping):
    x0 = _array("x0", raw["x0"], shape=(None, 2))
    if x0.shape[0] < 1:
        raise CaseError("x0", "x0 must hold at least one particle, got shape (0, 2)")
    n = x0.shape[0]
    v0 = _array("v0", raw["v0"])
    if v0.shape != (n, 2):
        raise CaseError("v0", f"v0 must have shape (N, 2) = ({n}, 2) like x0, got shape {v0.shape}")
    return x0, v0


def _per_particle(key: str, value, n: int, **kw) -> np.ndarray:
    """mass, damping, spring_k, spring_center: a scalar, (2,), (N, 1), (N, 2) (or (1,), (1, 1), (1, 2))."""
    arr = _numeric(key, value)
    if arr.ndim > 2:
        raise CaseError(key, f"{key} must broadcast to (N, 2) = ({n}, 2), got shape {arr.shape}")
    return _array(key, arr, broadcast_to=(n, 2), **kw)


def _walls(raw: Mapping, surface: Surface):
    if "walls" not in raw:
        return None
    k = _scalar("wall_k", raw["wall_k"], checks.as_positive_float)
    margin = _scalar("wall_margin", raw["wall_margin"], checks.as_nonneg_float)
    edges = _flags("walls", raw["walls"], (2, 2))
    for d in range(2):
        if surface.periodic[d] and edges[d].any():
            raise CaseError("walls", f"axis {d} is periodic and cannot have a wall "
                                     f"(walls[{d}] = {edges[d].tolist()})")
        if edges[d].all() and 2 * margin >= surface.length[d]:
            raise CaseError("wall_margin", f"wall_margin={margin} leaves no room between the two walls "
                                           f"of axis {d} (length {surface.length[d]})")
    with _about("walls"):
        return Walls(k, margin, edges)


def _objective(raw: Mapping, name: str, shape: tuple):
    if name == "funnel":
        target = _scalar("target", raw["target"])
        when = _string("when", raw["when"], ("final", "every_step"))
        return Funnel(target, when)
    if name == "oscillator":
        return Oscillator(_scalar("amplitude", raw["amplitude"]), _scalar("omega", raw["omega"]))
    params = {p: _array(p, raw[p], broadcast_to=shape) for p in OBJECTIVE_PARAMS["quadratic"]}
    return Quadratic(**params)


_KEY_IN_MESSAGE = re.compile(r"^(\w+)")


def _scene(surface, raw, mode, n, dt, n_steps, t0) -> Scene:
    mass = _per_particle("mass", raw["mass"], n, positive=True)
    damping = _per_particle("damping", raw["damping"], n, nonneg=True)
    mobility = _array("mobility", raw["mobility"], shape=(2,), positive=True) if mode == "quasistatic" else None
    spring = None
    if "spring_k" in raw:
        k = _per_particle("spring_k", raw["spring_k"], n, nonneg=True)
        center = _per_particle("spring_center", raw["spring_center"], n)
        with _about("spring_k"):
            spring = Spring(k, center)
    walls = _walls(raw, surface)
    try:
        return Scene(surface, dt=dt, n_steps=n_steps, mode=mode, mass=mass, damping=damping,
                     mobility=mobility, spring=spring, walls=walls, t0=t0)
    except (TypeError, ValueError) as exc:   # not expected after the checks above; name a key anyway
        m = _KEY_IN_MESSAGE.match(str(exc))
        key = m.group(1) if m and m.group(1) in CASE_KEYS else "mode"
        with _about(key):
            raise


def grad_names_for(mode: str, has_spring: bool) -> tuple:
    """The ``grad_<name>`` a case of this mode has, in :data:`pes_ref.GRADIENT_NAMES` order.

    ``values``, ``x0`` and ``force`` always; ``v0``, ``mass``, ``damping`` in dynamic
    mode; ``mobility`` in quasistatic mode; ``spring_k``, ``spring_center`` with a spring.
    """
    return gradient_names(mode, has_spring)


def result_keys(grad_names) -> tuple:
    """The keys of a result: ``x, v, energy, loss`` and ``grad_<name>`` per name."""
    return ("x", "v", "energy", "loss") + tuple("grad_" + g for g in grad_names)


def validate_case(raw: Mapping) -> ValidCase:
    """Check a case against SPEC section 6 and build what the engine runs.

    Parameters
    ----------
    raw : mapping of str -> array_like
        As read by :func:`load_case` (or built in memory; a Python ``str`` is accepted
        wherever a 0-d unicode array is).

    Returns
    -------
    ValidCase

    Raises
    ------
    CaseError
        The first rule the case breaks, naming its key (a :class:`CaseTypeError`, also
        a ``TypeError``, when the key holds the wrong kind of data). Keys are checked
        in a fixed order: names (unknown, then missing), mode and objective, the key
        rules (objective parameters, mobility, groups), then each key's value.
    """
    if not isinstance(raw, Mapping):
        raise CaseTypeError(None, f"a case is a mapping of key -> array, got {type(raw).__name__}")
    _check_key_names(raw)
    mode = _string("mode", raw["mode"], MODES)
    objective_name = _string("objective", raw["objective"], tuple(OBJECTIVE_PARAMS))
    _check_key_rules(raw, mode, objective_name)

    surface = _surface(raw)
    dt = _scalar("dt", raw["dt"], checks.as_positive_float)
    n_steps = _integer("n_steps", raw["n_steps"])
    t0 = _scalar("t0", raw.get("t0", 0.0))
    x0, v0 = _state(raw)
    n = x0.shape[0]
    scene = _scene(surface, raw, mode, n, dt, n_steps, t0)
    shape = (n_steps + 1, n, 2)
    if "force" in raw:
        force = _array("force", raw["force"])
        if force.shape != shape:
            raise CaseError("force", f"force must have shape (T+1, N, 2) = {shape}, got shape {force.shape}")
    else:
        force = np.zeros(shape)
    objective = _objective(raw, objective_name, shape)
    reg = _scalar("regularization", raw.get("regularization", 0.0), checks.as_nonneg_float)
    return ValidCase(scene, x0, v0, force, objective, reg, grad_names_for(mode, scene.spring is not None))


# =========================================================================== running

def run_case(case) -> dict:
    """Run a case with the reference engine: the oracle.

    Parameters
    ----------
    case : mapping, str or os.PathLike
        A case dict, or the path of a case file.

    Returns
    -------
    dict of str -> ndarray (float64)
        ``x``, ``v`` (T+1, N, 2), ``energy`` (T+1, N), ``loss`` (0-d) and
        ``grad_<name>`` for every name of :func:`grad_names_for`, each shaped like its
        input (``grad_force`` (T+1, N, 2)).

    Raises
    ------
    CaseError
        The case breaks the SPEC, or its run leaves the finite numbers (blamed on
        ``dt`` in dynamic mode, ``mobility`` in quasistatic mode).
    """
    if isinstance(case, (str, os.PathLike)):
        case = load_case(case)
    vc = validate_case(case)
    scene = vc.scene
    blame = "dt" if scene.mode == "dynamic" else "mobility"
    try:
        with np.errstate(over="raise", invalid="raise", divide="raise", under="ignore"):
            loss, grads, traj = value_and_grad(scene, vc.x0, vc.v0, vc.objective,
                                               regularization_weight=vc.regularization,
                                               wrt=vc.grad_names, fext=vc.force)
            e = energy(scene, traj)
    except FloatingPointError as exc:
        raise CaseError(blame, f"the run left the finite numbers ({exc}); the step is probably past "
                               "the stability limit of the stiffest term") from None
    except MemoryError:
        raise CaseError("n_steps", f"a run of n_steps={scene.n_steps} does not fit in memory") from None
    result = {"x": traj.x, "v": traj.v, "energy": e, "loss": np.float64(loss)}
    for name in vc.grad_names:
        result["grad_" + name] = grads[name]
    return {k: np.array(v, dtype=np.float64) for k, v in result.items()}


def write_result(result: Mapping, path, overwrite: bool = False) -> None:
    """Write a result dict to ``path`` (temporary file, then an atomic move).

    Raises
    ------
    ResultExistsError
        ``path`` exists and ``overwrite`` is False; nothing is written.
    """
    write_npz(path, result, overwrite=overwrite)


def run_case_file(case_path, result_path, overwrite: bool = False) -> dict:
    """Run the case file ``case_path`` and write its result to ``result_path``.

    Nothing is written when the case is refused, when its run fails, or when
    ``result_path`` exists and ``overwrite`` is False.

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
    result = run_case(load_case(case_path))
    write_result(result, result_path, overwrite=overwrite)
    return result
