"""The synthesis names the sweep layer uses, imported from their homes in one place.

``pes_ref.synthesis`` is being split into modules and will re-export these names; when it
does, the two imports below become the one line
``from pes_ref.synthesis import (DEFAULT_PLANS, PROBLEMS, DesignState, Plan, evaluate,
load_design, new_design, run_design, save_design)``
(``OSCILLATOR_OBJECTIVES`` stays with the designs).
"""
from pes_ref.synthesis.designs import (DEFAULT_PLANS, OSCILLATOR_OBJECTIVES, PROBLEMS, DesignState, Plan,  # noqa: F401
                                       evaluate, new_design, run_design)
from pes_ref.synthesis.design_file import load_design, save_design  # noqa: F401
