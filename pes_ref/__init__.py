"""pes_ref: the reference NumPy implementation of potential energy surfaces for the
conceptual design and analysis of mechanical systems (Manion & Fuge, DETC2021).

The numerical contract is ``SPEC.md`` (shipped beside the paper); the adjoint is
derived in ``docs/adjoint.md``. Modules, one idea each:

- :mod:`pes_ref.surface`    grid lookup, bilinear energy and slope, their adjoints
- :mod:`pes_ref.terms`      springs and walls
- :mod:`pes_ref.effects`    external force effects and their schedule
- :mod:`pes_ref.forces`     the total conservative force and its adjoint
- :mod:`pes_ref.integrator` damped velocity Verlet / quasistatic steps and their adjoints
- :mod:`pes_ref.objectives` trajectory objectives and regularization
- :mod:`pes_ref.scene`      the frozen scene layer: ``simulate``, ``value_and_grad``
- :mod:`pes_ref.oracle`     the case/result ``.npz`` interchange format
- :mod:`pes_ref.testing`    conformance helpers and hypothesis strategies for other implementations
"""
from .effects import Constant, Noise, PerParticle, Schedule, Window, build_schedule
from .integrator import NonFiniteError, Trajectory
from .objectives import Custom, Funnel, Oscillator, Quadratic, regularization
from .scene import GRADIENT_NAMES, Scene, energy, simulate, value_and_grad
from .surface import Surface
from .terms import Spring, Walls

__version__ = "0.1.0"

__all__ = [
    "Surface", "Spring", "Walls", "Constant", "PerParticle", "Noise", "Window", "Schedule",
    "build_schedule", "Scene", "simulate", "value_and_grad", "energy", "Trajectory",
    "NonFiniteError", "Funnel", "Oscillator", "Quadratic", "Custom", "regularization",
    "GRADIENT_NAMES", "__version__",
]
