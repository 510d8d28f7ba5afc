"""pes_ref: the reference NumPy implementation of potential energy surfaces for the
conceptual design and analysis of mechanical systems (Manion & Fuge, DETC2021).

The numerical contract is ``SPEC.md`` (shipped beside the paper); the adjoint is
derived in ``docs/adjoint.md``. Modules, one idea each:

- :mod:`pes_ref.core.grid`       the grid lookup (spacing, cell and fraction, wrap) with the hot loop's fast path
- :mod:`pes_ref.core.surface`    the validated ``Surface``: energy and slope by its interpolation
- :mod:`pes_ref.core.bilinear`   the bilinear rule: energy, slope, force, adjoints; the hot loop's tables and kernels
- :mod:`pes_ref.core.bicubic`    option: the C1 bicubic (Catmull-Rom) surface and its adjoints
- :mod:`pes_ref.core.interpolations` the registry of grid interpolations ("bilinear", "bicubic")
- :mod:`pes_ref.core.kernels`    the hot loop's kernel interfaces (typing protocols)
- :mod:`pes_ref.core.terms`      springs and walls
- :mod:`pes_ref.core.effects`    external force effects and their schedule
- :mod:`pes_ref.core.forces`     the total conservative force and its adjoint
- :mod:`pes_ref.core.integrator` damped velocity Verlet / quasistatic steps and their adjoints
- :mod:`pes_ref.core.gjf`        option: the second-order damped Gronbech-Jensen-Farago step and its adjoint
- :mod:`pes_ref.core.steppers`   the registry of steppers by (mode, integrator)
- :mod:`pes_ref.core.objectives` trajectory objectives and regularization
- :mod:`pes_ref.core.scene`      the frozen scene layer: ``simulate``, ``value_and_grad``, ``gradient_names``
- :mod:`pes_ref.core.stability`  the explicit step's stability limit, named in errors past it
- :mod:`pes_ref.oracle.case`     the case/result ``.npz`` interchange format
- :mod:`pes_ref.devices.geometry` / :mod:`pes_ref.devices.cspace` parts -> C-space -> eq. (1) surface; devices in :mod:`pes_ref.devices.ratchet`, :mod:`pes_ref.devices.dartgun`
- :mod:`pes_ref.synthesis.optimizers` / :mod:`pes_ref.synthesis.designs` / :mod:`pes_ref.synthesis.design_file` RMSprop, Adam; the funnel and oscillator designs and their files
- :mod:`pes_ref.bench.benchmark`      the benchmark (``python -m pes_ref bench``)
- :mod:`pes_ref.testing`    conformance helpers and hypothesis strategies for other implementations
"""
from pes_ref import _moved
from pes_ref.devices.cspace import CSpaceGrid, GridSpring, apf_energy
from pes_ref.core.effects import Constant, Noise, PerParticle, Schedule, Window, build_schedule
from pes_ref.core.integrator import NonFiniteError, Trajectory
from pes_ref.core.objectives import Custom, Funnel, Oscillator, Quadratic, regularization
from pes_ref.synthesis.optimizers import Adam, RMSprop
from pes_ref.core.scene import GRADIENT_NAMES, Scene, energy, simulate, value_and_grad
from pes_ref.core.surface import Surface
from pes_ref.devices.geometry import Part, Polygon, Rotation, Translation
from pes_ref.core.terms import Spring, Walls

__version__ = "0.1.0"

_moved.install()   # old flat import paths keep working, with a DeprecationWarning

__all__ = [
    "Surface", "Spring", "Walls", "Constant", "PerParticle", "Noise", "Window", "Schedule",
    "build_schedule", "Scene", "simulate", "value_and_grad", "energy", "Trajectory",
    "NonFiniteError", "Funnel", "Oscillator", "Quadratic", "Custom", "regularization",
    "GRADIENT_NAMES", "__version__",
    "Polygon", "Translation", "Rotation", "Part", "CSpaceGrid", "GridSpring", "apf_energy",
    "RMSprop", "Adam",
]
