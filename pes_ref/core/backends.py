"""The registry of backends: which code runs a scene's steps and their adjoints.

- ``"numpy"``: the NumPy loops (`pes_ref.core.steppers.STEPPERS`); every scene. A run of
  many particles runs as two halves on two threads ([`pes_ref.accel.halves`][pes_ref.accel.halves], its ``threads``).
- ``"numba"``: compiled loops ([`pes_ref.accel.compiled`][pes_ref.accel.compiled], the optional extra ``fast``:
  ``pip install 'pes_ref[fast]'``), for the bilinear grid with the paper's dynamic step and
  the quasistatic step, springs, walls, damping and the external force. A scene it does not
  cover (the bicubic grid, the GJF step) runs on NumPy. Its forward trajectories are
  bit-identical to NumPy's; its gradients agree to 1e-13 of their largest entry (the grid
  gradient and the mobility's are sums in another order; the others are bit-identical).

The default (``backend=None`` everywhere) is the first of `DEFAULT_ORDER` that is
installed: the compiled loops when numba is, else NumPy. Whether a backend is installed is
read from the import system without importing it, so choosing the default imports nothing
(``python -m pes_ref oracle`` asks for ``"numpy"`` and never imports numba).
[`stepper`][pes_ref.core.backends.stepper] is the one dispatch point (``core/scene.py`` and ``core/population.py``).

The accelerators (``pes_ref/accel/``) are reached only here, by the module names of their
entries, imported on first use: the method (``pes_ref/core/``) imports none of them
(setup.cfg's import-linter contracts).
"""
from __future__ import annotations

import functools
import importlib
import importlib.util
from typing import NamedTuple

from pes_ref.core import checks
from pes_ref.core.steppers import Stepper, stepper as numpy_stepper

__all__ = ["Backend", "BACKENDS", "DEFAULT_ORDER", "installed", "default_backend", "check_backend", "stepper",
           "covers"]


class Backend(NamedTuple):
    """One way to run the steps.

    ``module`` holds its ``STEPPERS`` (``(mode, integrator) -> Stepper``), imported on first
    use; ``requires`` the package it needs (None: NumPy alone) and ``extra`` the pip extra
    that installs it; ``interpolations`` the grid rules its steppers compute; ``kernels`` the
    whole-array operations its module has of its own (the energy of a trajectory, the grid's
    largest cross curvature: [`kernel`][pes_ref.core.backends.kernel]); ``threads`` the
    module that runs a large run of its steppers on both cores (its ``MIN_PARTICLES`` and
    ``stepper(inner)``), or None where its loops use the cores themselves. What it does not
    cover runs on ``"numpy"``.
    """

    name: str
    module: str
    requires: str | None
    extra: str | None
    interpolations: tuple
    kernels: tuple = ()
    threads: str | None = None


#: Every backend by name.
BACKENDS = {
    "numpy": Backend("numpy", "pes_ref.core.steppers", None, None, ("bilinear", "bicubic"),
                     threads="pes_ref.accel.halves"),
    "numba": Backend("numba", "pes_ref.accel.compiled", "numba", "fast", ("bilinear",),
                     ("energy", "cross_curvature_max")),
}

#: What runs every scene a backend does not cover.
FALLBACK = "numpy"

#: The default backend is the first of these that is installed.
DEFAULT_ORDER = ("numba", "numpy")


@functools.lru_cache(maxsize=None)
def installed(name: str) -> bool:
    """Whether backend ``name``'s package can be imported (found, not imported)."""
    requires = BACKENDS[name].requires
    return requires is None or importlib.util.find_spec(requires) is not None


def kernel(backend: str, name: str, interpolation: str = "bilinear"):
    """Backend ``backend``'s own ``name`` (one of its ``kernels``: ``"energy"``,
    ``"cross_curvature_max"``) for a grid of rule ``interpolation``, or None where it has none
    or does not cover the rule: the caller then computes it with NumPy. The same numbers bit
    for bit either way (each kernel's tests)."""
    b = BACKENDS[backend]
    if name not in b.kernels or interpolation not in b.interpolations:
        return None
    return getattr(importlib.import_module(b.module), name)


def _pip_line(extra: str) -> str:
    from pes_ref.core.runtime.extras import pip_line       # here: only a refusal needs it (the oracle's start-up)
    return pip_line(extra)


def default_backend() -> str:
    """The first installed backend of `DEFAULT_ORDER`."""
    return next(name for name in DEFAULT_ORDER if installed(name))


def check_backend(backend) -> str:
    """``backend`` checked at a public boundary: None gives [`default_backend`][pes_ref.core.backends.default_backend];
    a name
    not in `BACKENDS`, or one whose package is not installed, raises an
    [`InputError`][pes_ref.core.checks.InputError] keyed ``"backend"``."""
    if backend is None:
        return default_backend()
    if not isinstance(backend, str) or backend not in BACKENDS:
        raise checks.InputError("backend", f"backend must be one of {sorted(BACKENDS)} or None (the default), "
                                           f"got {backend!r}")
    if not installed(backend):
        b = BACKENDS[backend]
        raise checks.InputError("backend", f"backend={backend!r} needs {b.requires}, which is not installed: "
                                           f"{_pip_line(b.extra)}")
    return backend


def _steppers(name: str) -> dict:
    return importlib.import_module(BACKENDS[name].module).STEPPERS


def covers(backend: str, mode: str, integrator: str, interpolation: str) -> bool:
    """Whether ``backend`` itself runs a scene of this mode, integrator and grid rule."""
    return interpolation in BACKENDS[backend].interpolations and (mode, integrator) in _steppers(backend)


def stepper(backend: str, mode: str, integrator: str, interpolation: str, n_particles: int | None = None) -> Stepper:
    """The stepper that runs ``(mode, integrator)`` on an ``interpolation`` grid for
    ``backend`` (checked): its own when it covers the scene, else NumPy's, which for a run of
    ``n_particles`` >= its ``threads``' ``MIN_PARTICLES`` runs the particles as two halves
    on two threads ([`pes_ref.accel.halves.stepper`][pes_ref.accel.halves.stepper]; None: one thread, as a population's
    stacked grids need)."""
    if backend != FALLBACK and covers(backend, mode, integrator, interpolation):
        return _steppers(backend)[(mode, integrator)]
    numpy = numpy_stepper(mode, integrator)
    threads = BACKENDS[FALLBACK].threads
    if n_particles is not None and threads is not None:
        both = importlib.import_module(threads)
        if n_particles >= both.MIN_PARTICLES:
            return both.stepper(numpy)
    return numpy
