"""The optional extras (setup.cfg's ``extras_require``): the one check that an extra's module is
there, and the one line that says how to install it.

Each layer that needs an extra asks here ([`require`][pes_ref.core.runtime.extras.require],
[`found`][pes_ref.core.runtime.extras.found]) in its own words of what needs it: part geometry
(shapely, ``devices``), the rigid engine (pymunk, ``rigid``), realization (``realize``), the
MuJoCo check (``mujoco``), sweeps (Dask, ``sweep``), the compiled loops (numba, ``fast``). A
missing or too old module is one [`MissingExtraError`][pes_ref.core.runtime.extras.MissingExtraError]
(an ``ImportError``), which every command prints as one ``error:`` line:
``the rigid engine needs pymunk 7 (the optional extra 'rigid'): pip install 'pes_ref[rigid]'``.
"""
from __future__ import annotations

import importlib
import importlib.util

__all__ = ["MissingExtraError", "pip_line", "require", "found"]


class MissingExtraError(ImportError):
    """An optional extra's module is missing or too old; the message says how to install it."""


def pip_line(extra: str) -> str:
    """The command that installs the optional extra ``extra``: ``pip install 'pes_ref[extra]'``."""
    return f"pip install 'pes_ref[{extra}]'"


def _version(text: str) -> tuple:
    return tuple(int(part) for part in str(text).split(".")[:3] if part.isdigit())


def require(module: str, extra: str, needs: str, least: tuple = (), major: int | None = None,
            version: str = "__version__"):
    """The module ``module``, imported, or a [`MissingExtraError`][pes_ref.core.runtime.extras.MissingExtraError].

    Parameters
    ----------
    module : str
        What to import (``"shapely"``).
    extra : str
        The optional extra that installs it (``"devices"``).
    needs : str
        What needs it, the message's subject (``"part geometry"``).
    least : tuple of int, optional
        The oldest version that serves (``(2,)``: 2 or later).
    major : int, optional
        The one major version that serves (pymunk's 7).
    version : str
        The module's attribute that holds its version.
    """
    wanted = (f" {major}" if major is not None else
              f" >= {'.'.join(map(str, least))}" if least else "")
    try:
        mod = importlib.import_module(module)
    except ImportError:
        raise MissingExtraError(f"{needs} needs {module}{wanted} (the optional extra '{extra}'): "
                                f"{pip_line(extra)}") from None
    have = _version(getattr(mod, version, ""))
    if (least and have[:len(least)] < tuple(least)) or (major is not None and have[:1] != (major,)):
        raise MissingExtraError(f"{needs} needs {module}{wanted}, found {getattr(mod, version, '?')}: "
                                f"{pip_line(extra)}")
    return mod


def found(module: str, extra: str, needs: str) -> None:
    """Raise a [`MissingExtraError`][pes_ref.core.runtime.extras.MissingExtraError] unless ``module``
    can be imported (found, not imported: ``needs`` names what needs it)."""
    if importlib.util.find_spec(module) is None:
        raise MissingExtraError(f"{needs} needs {module} (the optional extra '{extra}'): {pip_line(extra)}")
