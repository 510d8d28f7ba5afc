"""Synthesis: designing a surface's grid values by gradient descent through the adjoint,
followed, for the oscillator, by a gradient-free polish.

Its modules are in four rooms, each importing only from those below it (setup.cfg's
``synthesis`` contract; ``docs/architecture.md``):

- [`.engine`][pes_ref.synthesis.engine]   the engine that runs a plan: a run's state, its refusals, the gradient
  stage, the polish, the stages one after the other, design files, a run from what a user names
- [`.kinds`][pes_ref.synthesis.kinds]    the kinds of design: the paper's funnel and oscillator (one module each,
  with the oscillator's gait and the funnel's envelope), the escapement, the held-out analysis, and
  the registry (`KINDS`) that serves every kind through one interface
- [`.problem`][pes_ref.synthesis.problem]  the problem-file format: keys, objective terms, success tests and their
  surrogates, the contact, the problem a file states, reading and writing files
- [`.common`][pes_ref.synthesis.common]   what all of them share: the base problem and its batch, optimizers, plans,
  resampling, validation, exits, the level set

The names below are the public synthesis API (with [`Progress`][pes_ref.core.runtime.progress.Progress], what the loops'
callbacks receive, from [`pes_ref.core.runtime.progress`][pes_ref.core.runtime.progress]).
"""
from pes_ref.core.runtime.progress import Progress
from pes_ref.synthesis.common.optimizers import Adam, RMSprop, make_optimizer
from pes_ref.synthesis.common.exits import FunnelExit, exit_steps
from pes_ref.synthesis.common.problems import Batch
from pes_ref.synthesis.common.plans import (DEFAULT_OSCILLATOR_PLAN, FUNNEL_ENVELOPE_PLAN, FUNNEL_PLAN,
                                            OSCILLATOR_PLANS, OSCILLATOR_POLISH, Plan, PolishPlan, default_plan)
from pes_ref.synthesis.common.resampling import resample
from pes_ref.synthesis.problem.objective_terms import OBJECTIVE_TERMS, TermSum
from pes_ref.synthesis.problem.success import SUCCESS_TESTS
from pes_ref.synthesis.problem.design_problem import FORCES, DesignProblem
from pes_ref.synthesis.problem.problem_file import (SHIPPED_PROBLEMS, ProblemFileError, load_problem, parse_problem,
                                                    plan_for, problem_from_text, problem_text, shipped_problem,
                                                    with_sets)
from pes_ref.synthesis.kinds.gait import GaitShooting, GaitStarts, sample_gait_starts
from pes_ref.synthesis.kinds.funnel import exit_positions, FUNNEL_OBJECTIVES, FunnelProblem, IN_BAND_SHARE
from pes_ref.synthesis.kinds.oscillator import OSCILLATOR_COSTS, OscillatorProblem, PhaseThenCycle
from pes_ref.synthesis.kinds.escapement import escapement_values
from pes_ref.synthesis.kinds.analysis import (ANALYSIS_PERIODS, CYCLE_DRIFT, CYCLE_TOLERANCE, Paths, TorqueSweep,
                                              cycle_figures, funnel_paths, oscillator_grid_starts,
                                              oscillator_torque_sweep, phase_space, q1_advance)
from pes_ref.synthesis.kinds.registry import (KINDS, DesignKind, Realizable, evaluate, evaluate_seeds,
                                              held_out_panels, held_out_steps, kind_named, kind_of)
from pes_ref.synthesis.engine.refusals import check_design_memory, check_stable_design
from pes_ref.synthesis.engine.design_state import STOPPED, DesignState, new_design
from pes_ref.synthesis.engine.training import GradientStep, design_gradient, run_design
from pes_ref.synthesis.engine.polish import (PolishParticles, PolishResult, capture_fitness, legendre_fourier_basis,
                                             polish, polish_particles)
from pes_ref.synthesis.engine.stages import run_stages
from pes_ref.synthesis.engine.design_file import (DesignFileError, design_arrays, first_difference, load_design,
                                                  save_design)
from pes_ref.synthesis.engine.paths_start import needs_paths_start, paths_start
from pes_ref.synthesis.engine.runs import (DESIGN_OPTIONS, DesignInputs, check_resume, design_inputs, run_to_file,
                                           start_design)

__all__ = [
    "Adam", "RMSprop", "make_optimizer",
    "GaitShooting", "GaitStarts", "sample_gait_starts",
    "FunnelExit", "exit_steps",
    "FunnelProblem", "OscillatorProblem", "PhaseThenCycle", "Batch", "OSCILLATOR_COSTS",
    "IN_BAND_SHARE", "exit_positions", "FUNNEL_OBJECTIVES",
    "Plan", "PolishPlan", "default_plan", "FUNNEL_PLAN", "FUNNEL_ENVELOPE_PLAN", "OSCILLATOR_PLANS", "OSCILLATOR_POLISH",
    "DEFAULT_OSCILLATOR_PLAN",
    "resample",
    "DesignState", "Progress", "GradientStep", "new_design", "run_design", "design_gradient",
    "check_stable_design", "check_design_memory", "STOPPED",
    "Paths", "TorqueSweep", "funnel_paths", "oscillator_torque_sweep", "oscillator_grid_starts",
    "phase_space", "cycle_figures", "q1_advance", "evaluate", "evaluate_seeds", "CYCLE_TOLERANCE", "CYCLE_DRIFT",
    "ANALYSIS_PERIODS",
    "legendre_fourier_basis", "PolishParticles", "polish_particles", "capture_fitness", "PolishResult", "polish",
    "run_stages", "needs_paths_start", "paths_start",
    "escapement_values",
    "KINDS", "DesignKind", "Realizable", "kind_of", "kind_named", "held_out_steps", "held_out_panels",
    "DESIGN_OPTIONS", "DesignInputs", "design_inputs", "start_design", "check_resume", "run_to_file",
    "save_design", "load_design", "design_arrays", "first_difference",
    "DesignFileError",
    "DesignProblem", "OBJECTIVE_TERMS", "SUCCESS_TESTS", "FORCES", "TermSum", "load_problem", "parse_problem",
    "problem_from_text", "problem_text", "with_sets", "plan_for", "shipped_problem", "SHIPPED_PROBLEMS",
    "ProblemFileError",
]
