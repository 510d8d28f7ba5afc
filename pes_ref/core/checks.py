"""Input validation at the public boundary.

Every public entry point converts its inputs here, once: to a float64 (or bool)
NumPy array of the right shape, finite, with the sign it must have. A bad input
raises one [`InputError`][pes_ref.core.checks.InputError] (a ``ValueError``) or
[`InputTypeError`][pes_ref.core.checks.InputTypeError] (also a
``TypeError``) whose message names the argument and quotes the offending value, and
whose ``key`` attribute is the argument's name, so a caller that maps arguments to its
own names (the oracle's case keys) never parses a message. The numerical core after
the boundary trusts its inputs and never checks again.

Inputs are never modified: a converted array is a copy whenever the caller's
array is not already a float64 array (and it is never written to by the core).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = [
    "InputError",
    "InputTypeError",
    "as_float_array",
    "as_bool_array",
    "as_positive_int",
    "as_nonneg_int",
    "as_int_at_least",
    "as_positive_float",
    "as_nonneg_float",
    "as_finite_float",
    "as_choice",
    "reduce_to_shape",
]


class InputError(ValueError):
    """A bad value of one argument.

    Parameters
    ----------
    key : str or None
        The argument's name (None when no single argument is at fault).
    message : str
        The whole message; it names the argument and quotes the bad value.
    names : tuple of str, optional
        Every argument name the message mentions (default: ``key`` alone), for a command
        line that rewords them as its flags.
    """

    def __init__(self, key: str | None, message: str, names: tuple = ()):
        super().__init__(message)
        self.key = key
        self.names = tuple(names) or ((key,) if key is not None else ())


class InputTypeError(InputError, TypeError):
    """An argument holding the wrong kind of data (a string where a number belongs, a
    float count, an object array ...): both an [`InputError`][pes_ref.core.checks.InputError] and a ``TypeError``."""


def _quote(value, limit: int = 80) -> str:
    """A short repr of a bad value for an error message."""
    try:
        text = np.array2string(np.asarray(value), threshold=8, edgeitems=2) if not isinstance(value, str) else repr(value)
    except Exception:  # pragma: no cover - repr of exotic objects
        text = repr(value)
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def as_float_array(
    name: str,
    value,
    *,
    shape: tuple | None = None,
    broadcast_to: tuple | None = None,
    ndim: int | None = None,
    finite: bool = True,
    positive: bool = False,
    nonneg: bool = False,
) -> np.ndarray:
    """Convert ``value`` to a float64 array and check it.

    Parameters
    ----------
    name : str
        The argument's name, quoted in every error.
    value : array_like
        Real numbers (bool, int, float of any width). Complex, object and string
        data are refused with a `TypeError`.
    shape : tuple, optional
        The exact shape required; ``None`` entries match any length.
    broadcast_to : tuple, optional
        The value must broadcast to this shape (its own shape is kept).
    ndim : int, optional
        The exact number of dimensions required.
    finite, positive, nonneg : bool
        Refuse NaN/inf; require ``> 0``; require ``>= 0``.

    Returns
    -------
    numpy.ndarray
        float64, never a view that the core could write back into the caller's data.
    """
    if isinstance(value, (str, bytes)):
        raise InputTypeError(name, f"{name} must be a real number array, got the string {_quote(value)}")
    try:
        arr = np.asarray(value)
    except Exception as exc:  # ragged lists and the like
        raise InputTypeError(name, f"{name} must be a real number array, got {_quote(value)} ({exc})") from None
    if arr.dtype.kind not in "biuf":          # (bool, integers, floats: real numbers, no test needed)
        if arr.dtype == object or not (np.issubdtype(arr.dtype, np.number) or arr.dtype == bool):
            raise InputTypeError(name, f"{name} must be a real number array, got dtype {arr.dtype} ({_quote(value)})")
        if np.iscomplexobj(arr):
            raise InputTypeError(name, f"{name} must be real, got complex values {_quote(value)}")
    arr = np.array(arr, dtype=np.float64, copy=True)
    if ndim is not None and arr.ndim != ndim:
        raise InputError(name, f"{name} must have {ndim} dimension(s), got shape {arr.shape}")
    if shape is not None:
        ok = len(shape) == arr.ndim and all(s is None or s == a for s, a in zip(shape, arr.shape))
        if not ok:
            want = "(" + ", ".join("any" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
            raise InputError(name, f"{name} must have shape {want}, got shape {arr.shape}")
    if broadcast_to is not None:
        try:
            np.broadcast_shapes(arr.shape, tuple(broadcast_to))
            if np.broadcast_shapes(arr.shape, tuple(broadcast_to)) != tuple(broadcast_to):
                raise ValueError
        except ValueError:
            raise InputError(
                name, f"{name} must broadcast to shape {tuple(broadcast_to)}, got shape {arr.shape}"
            ) from None
    if finite and not np.isfinite(arr).all():
        raise InputError(name, f"{name} must be finite, got {_quote(arr)}")
    if positive and not (arr > 0).all():
        raise InputError(name, f"{name} must be > 0, got {_quote(arr)}")
    if nonneg and not (arr >= 0).all():
        raise InputError(name, f"{name} must be >= 0, got {_quote(arr)}")
    arr.setflags(write=False)
    return arr


def as_bool_array(name: str, value, *, shape: tuple) -> np.ndarray:
    """Convert ``value`` to a bool array of exactly ``shape``.

    Only bool, or integers equal to 0/1, are accepted (``2`` or ``0.5`` is an error).
    """
    arr = np.asarray(value)
    if arr.dtype != bool:
        if not np.issubdtype(arr.dtype, np.number) or np.iscomplexobj(arr):
            raise InputTypeError(name, f"{name} must be booleans, got dtype {arr.dtype} ({_quote(value)})")
        if not np.all((arr == 0) | (arr == 1)):
            raise InputError(name, f"{name} must be booleans (0/1), got {_quote(value)}")
        arr = arr.astype(bool)
    if arr.shape != tuple(shape):
        raise InputError(name, f"{name} must have shape {tuple(shape)}, got shape {arr.shape}")
    arr = arr.copy()
    arr.setflags(write=False)
    return arr


def _as_scalar(name: str, value) -> float:
    if isinstance(value, (bool, np.bool_)):
        raise InputTypeError(name, f"{name} must be a number, got the bool {value!r}")
    arr = np.asarray(value)
    if arr.ndim != 0:
        raise InputError(name, f"{name} must be a scalar, got shape {arr.shape}")
    if arr.dtype.kind not in "iuf" and (not np.issubdtype(arr.dtype, np.number) or np.iscomplexobj(arr)):
        raise InputTypeError(name, f"{name} must be a real number, got {_quote(value)}")
    return float(arr)


def as_finite_float(name: str, value) -> float:
    """A finite real scalar."""
    x = _as_scalar(name, value)
    if not math.isfinite(x):
        raise InputError(name, f"{name} must be finite, got {x!r}")
    return x


def as_positive_float(name: str, value) -> float:
    """A finite real scalar > 0."""
    x = as_finite_float(name, value)
    if not x > 0:
        raise InputError(name, f"{name} must be > 0, got {x!r}")
    return x


def as_nonneg_float(name: str, value) -> float:
    """A finite real scalar >= 0."""
    x = as_finite_float(name, value)
    if not x >= 0:
        raise InputError(name, f"{name} must be >= 0, got {x!r}")
    return x


def as_int_at_least(name: str, value, least: int) -> int:
    """An integer >= ``least`` (an integral float such as ``3.0`` is refused: counts are
    ints); every value below ``least`` gets the same message."""
    if isinstance(value, (bool, np.bool_)):
        raise InputTypeError(name, f"{name} must be an integer, got the bool {value!r}")
    arr = np.asarray(value)
    if arr.ndim != 0 or not (arr.dtype.kind in "iu" or np.issubdtype(arr.dtype, np.integer)):
        raise InputTypeError(name, f"{name} must be an integer, got {_quote(value)}")
    x = int(arr)
    if x < least:
        raise InputError(name, f"{name} must be >= {least}, got {x}")
    return x


def as_nonneg_int(name: str, value) -> int:
    """An integer >= 0 (an integral float such as ``3.0`` is refused: counts are ints)."""
    return as_int_at_least(name, value, 0)


def as_positive_int(name: str, value) -> int:
    """An integer >= 1 (``-3`` and ``0`` get the same message)."""
    return as_int_at_least(name, value, 1)


def as_choice(name: str, value, choices) -> str:
    """One of a fixed set of strings (a 0-d unicode array is accepted)."""
    if isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind == "U":
        value = str(value)
    if not isinstance(value, str):
        raise InputTypeError(name, f"{name} must be one of {sorted(choices)}, got {_quote(value)}")
    if value not in choices:
        raise InputError(name, f"{name} must be one of {sorted(choices)}, got {value!r}")
    return value


def reduce_to_shape(grad: np.ndarray, shape: tuple) -> np.ndarray:
    """Sum a broadcast gradient back to the shape of the input it belongs to.

    The adjoint of ``np.broadcast_to(a, grad.shape)``: leading axes that broadcasting
    added are summed away, and axes where ``shape`` has length 1 are summed with
    ``keepdims``.
    """
    shape = tuple(shape)
    extra = grad.ndim - len(shape)
    if extra > 0:
        grad = grad.sum(axis=tuple(range(extra)))
    axes = tuple(i for i, s in enumerate(shape) if s == 1 and grad.shape[i] != 1)
    if axes:
        grad = grad.sum(axis=axes, keepdims=True)
    return grad.reshape(shape)

