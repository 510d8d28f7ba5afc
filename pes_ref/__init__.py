"""pes_ref: the reference NumPy implementation of potential energy surfaces for the
conceptual design and analysis of mechanical systems (Manion & Fuge, DETC2021).

The numerical contract is ``SPEC.md`` (shipped beside the paper); the adjoint is
derived in ``docs/adjoint.md``. Modules, one idea each:

- :mod:`pes_ref.surface`    grid lookup, bilinear energy and slope, their adjoints
- :mod:`pes_ref.bilinear`   the hot loop's per-cell coefficient tables for the bilinear grid force and its adjoint
- :mod:`pes_ref.terms`      springs and walls
- :mod:`pes_ref.effects`    external force effects and their schedule
- :mod:`pes_ref.forces`     the total conservative force and its adjoint
- :mod:`pes_ref.integrator` damped velocity Verlet / quasistatic steps and their adjoints
- :mod:`pes_ref.gjf`        option: the second-order damped Gronbech-Jensen-Farago step and its adjoint
- :mod:`pes_ref.bicubic`    option: the C1 bicubic (Catmull-Rom) surface and its adjoints
- :mod:`pes_ref.objectives` trajectory objectives and regularization
- :mod:`pes_ref.scene`      the frozen scene layer: ``simulate``, ``value_and_grad``
- :mod:`pes_ref.stability`  the explicit step's stability limit, named in errors past it
- :mod:`pes_ref.oracle`     the case/result ``.npz`` interchange format
- :mod:`pes_ref.geometry` / :mod:`pes_ref.cspace` parts -> C-space -> eq. (1) surface; devices in :mod:`pes_ref.ratchet`, :mod:`pes_ref.dartgun`
- :mod:`pes_ref.optimizers` / :mod:`pes_ref.designs` / :mod:`pes_ref.design_file` RMSprop, Adam; the funnel and oscillator designs and their files
- :mod:`pes_ref.bench`      the benchmark (``python -m pes_ref bench``)
- :mod:`pes_ref.testing`    conformance helpers and hypothesis strategies for other implementations
"""
from .cspace import CSpaceGrid, GridSpring, apf_energy
from .effects import Constant, Noise, PerParticle, Schedule, Window, build_schedule
from .integrator import NonFiniteError, Trajectory
from .objectives import Custom, Funnel, Oscillator, Quadratic, regularization
from .optimizers import Adam, RMSprop
from .scene import GRADIENT_NAMES, Scene, energy, simulate, value_and_grad
from .surface import Surface
from .geometry import Part, Polygon, Rotation, Translation
from .terms import Spring, Walls

__version__ = "0.1.0"

__all__ = [
    "Surface", "Spring", "Walls", "Constant", "PerParticle", "Noise", "Window", "Schedule",
    "build_schedule", "Scene", "simulate", "value_and_grad", "energy", "Trajectory",
    "NonFiniteError", "Funnel", "Oscillator", "Quadratic", "Custom", "regularization",
    "GRADIENT_NAMES", "__version__",
    "Polygon", "Translation", "Rotation", "Part", "CSpaceGrid", "GridSpring", "apf_energy",
    "RMSprop", "Adam",
]
