"""The synthesis names the sweep layer uses, in one place."""
from pes_ref.synthesis import (DEFAULT_PLANS, DEFAULT_POLISH, OSCILLATOR_OBJECTIVES, OSCILLATOR_POLISH,  # noqa: F401
                               PROBLEMS, DesignState, Plan, evaluate, load_design, new_design, run_stages,
                               save_design)
