"""pes_ref: the reference NumPy implementation of potential energy surfaces for the
conceptual design and analysis of mechanical systems (Manion & Fuge, DETC2021).

The numerical contract is ``docs/spec.md``; the adjoint is
derived in ``docs/adjoint.md``. The subpackages are layers that import only downward:
``docs/architecture.md`` draws them and says what each module holds.

The names below are re-exported here and imported on first use, so that a command
that needs only the core (``python -m pes_ref oracle``) does not pay for the rest.
"""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

__version__ = "0.1.0"

#: Each public name and the module it lives in (imported on first access, PEP 562).
_EXPORTS = {
    **dict.fromkeys(("Surface",), "pes_ref.core.surface"),
    **dict.fromkeys(("Spring", "Walls"), "pes_ref.core.terms"),
    **dict.fromkeys(("Constant", "PerParticle", "Noise", "Window", "Schedule", "build_schedule"),
                    "pes_ref.core.effects"),
    **dict.fromkeys(("Scene", "simulate", "value_and_grad", "energy", "GRADIENT_NAMES"), "pes_ref.core.scene"),
    **dict.fromkeys(("simulate_batch",), "pes_ref.core.population"),
    **dict.fromkeys(("BACKENDS", "default_backend"), "pes_ref.core.backends"),
    **dict.fromkeys(("Trajectory", "NonFiniteError"), "pes_ref.core.integrator"),
    **dict.fromkeys(("Funnel", "Oscillator", "Quadratic", "Custom", "regularization"), "pes_ref.core.objectives"),
    **dict.fromkeys(("Polygon", "Circle", "Rectangle", "Translation", "Rotation", "Part"), "pes_ref.devices.geometry"),
    **dict.fromkeys(("CSpaceGrid", "GridSpring", "apf_energy"), "pes_ref.devices.cspace"),
    **dict.fromkeys(("Device",), "pes_ref.devices.device"),
    **dict.fromkeys(("load_device", "DeviceFileError"), "pes_ref.devices.device_file"),
    **dict.fromkeys(("drive", "DriveResult"), "pes_ref.devices.drive"),
    **dict.fromkeys(("RMSprop", "Adam"), "pes_ref.synthesis.common.optimizers"),
    **dict.fromkeys(("DesignProblem",), "pes_ref.synthesis.problem.design_problem"),
    **dict.fromkeys(("load_problem", "parse_problem"), "pes_ref.synthesis.problem.problem_file"),
    **dict.fromkeys(("LevelSet",), "pes_ref.synthesis.common.level_set"),
}

__all__ = [*_EXPORTS, "__version__"]


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'pes_ref' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))


if TYPE_CHECKING:   # for type checkers and IDEs: the same names, imported eagerly
    from pes_ref.core.effects import Constant, Noise, PerParticle, Schedule, Window, build_schedule  # noqa: F401
    from pes_ref.core.integrator import NonFiniteError, Trajectory  # noqa: F401
    from pes_ref.core.objectives import Custom, Funnel, Oscillator, Quadratic, regularization  # noqa: F401
    from pes_ref.core.backends import BACKENDS, default_backend  # noqa: F401
    from pes_ref.core.population import simulate_batch  # noqa: F401
    from pes_ref.core.scene import GRADIENT_NAMES, Scene, energy, simulate, value_and_grad  # noqa: F401
    from pes_ref.core.surface import Surface  # noqa: F401
    from pes_ref.core.terms import Spring, Walls  # noqa: F401
    from pes_ref.devices.cspace import CSpaceGrid, GridSpring, apf_energy  # noqa: F401
    from pes_ref.devices.device import Device  # noqa: F401
    from pes_ref.devices.device_file import DeviceFileError, load_device  # noqa: F401
    from pes_ref.devices.drive import DriveResult, drive  # noqa: F401
    from pes_ref.devices.geometry import Circle, Part, Polygon, Rectangle, Rotation, Translation  # noqa: F401
    from pes_ref.synthesis.problem.design_problem import DesignProblem  # noqa: F401
    from pes_ref.synthesis.common.optimizers import Adam, RMSprop  # noqa: F401
    from pes_ref.synthesis.problem.problem_file import load_problem, parse_problem  # noqa: F401
    from pes_ref.synthesis.common.level_set import LevelSet  # noqa: F401

