"""Synthesis: designing a surface's grid values by gradient descent through the adjoint.

Modules, one idea each, in import order:

- :mod:`.optimizers`  RMSprop and Adam on the grid values
- :mod:`.problems`    the funnel and oscillator design problems (scene, objective, sampler, metric)
- :mod:`.plans`       how a problem is optimized (:class:`Plan`) and the default plans
- :mod:`.resampling`  bilinear resampling of a grid between coarse-to-fine stages
- :mod:`.training`    a design run (:class:`DesignState`) and the loop that advances it
- :mod:`.analysis`    held-out particles, cycle figures and :func:`evaluate`
- :mod:`.escapement`  the hand-drawn escapement surface, a reference for the oscillator
- :mod:`.design_file` design runs in ``.npz`` files

The names below are the public synthesis API.
"""
from pes_ref.synthesis.optimizers import Adam, RMSprop, make_optimizer
from pes_ref.synthesis.problems import (IN_BAND_SHARE, OSCILLATOR_COSTS, PROBLEMS, Batch, FunnelProblem,
                                        OscillatorProblem, PhaseThenCycle, exit_positions)
from pes_ref.synthesis.plans import DEFAULT_OSCILLATOR_OBJECTIVE, DEFAULT_PLANS, OSCILLATOR_OBJECTIVES, Plan
from pes_ref.synthesis.resampling import resample
from pes_ref.synthesis.training import (STOPPED, DesignState, GradientStep, Progress, check_stable_design,
                                        design_gradient, new_design, run_design)
from pes_ref.synthesis.analysis import (ANALYSIS_PERIODS, CYCLE_DRIFT, CYCLE_TOLERANCE, Paths, TorqueSweep,
                                        cycle_figures, evaluate, funnel_paths, oscillator_grid_starts,
                                        oscillator_torque_sweep, phase_space)
from pes_ref.synthesis.escapement import escapement_values
from pes_ref.synthesis.design_file import (DesignFileError, check_same_scene, design_arrays, load_design,
                                           save_design)

__all__ = [
    "Adam", "RMSprop", "make_optimizer",
    "FunnelProblem", "OscillatorProblem", "PhaseThenCycle", "Batch", "PROBLEMS", "OSCILLATOR_COSTS",
    "IN_BAND_SHARE", "exit_positions",
    "Plan", "DEFAULT_PLANS", "OSCILLATOR_OBJECTIVES", "DEFAULT_OSCILLATOR_OBJECTIVE",
    "resample",
    "DesignState", "Progress", "GradientStep", "new_design", "run_design", "design_gradient",
    "check_stable_design", "STOPPED",
    "Paths", "TorqueSweep", "funnel_paths", "oscillator_torque_sweep", "oscillator_grid_starts",
    "phase_space", "cycle_figures", "evaluate", "CYCLE_TOLERANCE", "CYCLE_DRIFT", "ANALYSIS_PERIODS",
    "escapement_values",
    "save_design", "load_design", "design_arrays", "check_same_scene", "DesignFileError",
]
