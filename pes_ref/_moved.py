"""Old import paths of modules that moved into subpackages, kept working with a
``DeprecationWarning`` (``import pes_ref.surface`` gives ``pes_ref.core.surface``).

:data:`MOVED` is the one table of old -> new module paths; :class:`_MovedFinder`, put on
``sys.meta_path`` by ``pes_ref/__init__.py``, serves an old path by importing the new
module and registering it under the old name too.
"""
from __future__ import annotations

import importlib
import importlib.util
import sys
import warnings

#: Old module path -> new module path (the flat layout before the layered one).
MOVED = {
    "pes_ref.checks": "pes_ref.core.checks",
    "pes_ref.surface": "pes_ref.core.surface",
    "pes_ref.bilinear": "pes_ref.core.bilinear",
    "pes_ref.bicubic": "pes_ref.core.bicubic",
    "pes_ref.terms": "pes_ref.core.terms",
    "pes_ref.effects": "pes_ref.core.effects",
    "pes_ref.forces": "pes_ref.core.forces",
    "pes_ref.integrator": "pes_ref.core.integrator",
    "pes_ref.gjf": "pes_ref.core.gjf",
    "pes_ref.objectives": "pes_ref.core.objectives",
    "pes_ref.stability": "pes_ref.core.stability",
    "pes_ref.scene": "pes_ref.core.scene",
    "pes_ref.conformance": "pes_ref.oracle.conformance",
    "pes_ref.conformance.generate": "pes_ref.oracle.conformance.generate",
    "pes_ref.geometry": "pes_ref.devices.geometry",
    "pes_ref.cspace": "pes_ref.devices.cspace",
    "pes_ref.ratchet": "pes_ref.devices.ratchet",
    "pes_ref.dartgun": "pes_ref.devices.dartgun",
    "pes_ref.optimizers": "pes_ref.synthesis.optimizers",
    "pes_ref.designs": "pes_ref.synthesis",
    "pes_ref.design_file": "pes_ref.synthesis.design_file",
    # designs.py split into problems, plans, resampling, training, analysis, escapement (issue 12)
    "pes_ref.synthesis.designs": "pes_ref.synthesis",
}


# The finder and the loader follow the import protocols (PEP 451) without deriving from
# importlib.abc's classes: importing importlib.abc pulls in importlib.resources and
# tempfile, ~5 ms of every start-up (``python -m pes_ref oracle`` included).

class _Alias:
    """Loader protocol: the module of an old path is the new module itself."""

    def __init__(self, new: str):
        self.new = new

    def create_module(self, spec):
        return importlib.import_module(self.new)

    def exec_module(self, module):
        pass


class _MovedFinder:
    """Finds the old paths of :data:`MOVED` only; every other import passes through."""

    def find_spec(self, fullname, path=None, target=None):
        new = MOVED.get(fullname)
        if new is None:
            return None
        warnings.warn(f"{fullname} moved to {new}; import it from there (or use the names re-exported "
                      f"by pes_ref)", DeprecationWarning, stacklevel=2)
        return importlib.util.spec_from_loader(fullname, _Alias(new))


def install() -> None:
    """Put the finder on ``sys.meta_path`` once."""
    if not any(isinstance(f, _MovedFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, _MovedFinder())
