"""Synthesis: designing a surface's grid values by gradient descent through the adjoint,
followed, for the oscillator, by a gradient-free polish.

Modules, one idea each, in import order:

- [`.optimizers`][pes_ref.synthesis.optimizers]  RMSprop and Adam on the grid values
- [`.gait`][pes_ref.synthesis.gait]        the oscillator's prescribed-gait shooting cost and its starts
- [`.exits`][pes_ref.synthesis.exits]       where a funnel particle leaves the domain, and eq. (5) charged there
- [`.problems`][pes_ref.synthesis.problems]    the funnel and oscillator design problems (scene, objective, sampler,
  metric)
- [`.plans`][pes_ref.synthesis.plans]       how a problem is optimized ([`Plan`][pes_ref.synthesis.plans.Plan],
  [`PolishPlan`][pes_ref.synthesis.plans.PolishPlan]) and the defaults
- [`.resampling`][pes_ref.synthesis.resampling]  bilinear resampling of a grid between coarse-to-fine stages
- [`.file_keys`][pes_ref.synthesis.file_keys]   the keys of a problem file: types, defaults, units, and their reader
- [`.objective_terms`][pes_ref.synthesis.objective_terms] the objective terms of a problem file (registry kind -> class)
- [`.success`][pes_ref.synthesis.success]     the per-particle success tests of a problem file (registry kind -> class),
  each with its surrogate
- [`.surrogates`][pes_ref.synthesis.surrogates]  the objective a problem without ``[[objective]]`` derives from its
  success tests
- [`.design_problem`][pes_ref.synthesis.design_problem] a design problem stated by a problem file
  ([`DesignProblem`][pes_ref.synthesis.design_problem.DesignProblem])
- [`.refusals`][pes_ref.synthesis.refusals]    what a design run refuses before it starts (unstable scene, memory)
- [`.kinds`][pes_ref.synthesis.kinds]       the kinds of design as one interface (`KINDS`) and
  [`evaluate`][pes_ref.synthesis.kinds.evaluate] for every kind
- [`.design_state`][pes_ref.synthesis.design_state] a design run's state
  ([`DesignState`][pes_ref.synthesis.design_state.DesignState]) and
  [`new_design`][pes_ref.synthesis.design_state.new_design]
- [`.training`][pes_ref.synthesis.training]    the loop of a run's gradient stage
  ([`run_design`][pes_ref.synthesis.training.run_design])
- [`.analysis`][pes_ref.synthesis.analysis]    held-out particles, cycle figures, each kind's figures and panels
- [`.polish`][pes_ref.synthesis.polish]      the polish stage: CMA-ES on a smooth correction, capture-test fitness
- [`.stages`][pes_ref.synthesis.stages]      a run's stages one after the other
  ([`run_stages`][pes_ref.synthesis.stages.run_stages])
- [`.escapement`][pes_ref.synthesis.escapement]  the hand-drawn escapement surface, a reference for the oscillator
- [`.problem_file`][pes_ref.synthesis.problem_file] problem files: reading, checking, changing keys, writing
- [`.design_file`][pes_ref.synthesis.design_file] design runs in ``.npz`` files
- [`.runs`][pes_ref.synthesis.runs]        a run from what a user names: options resolved
  ([`design_inputs`][pes_ref.synthesis.runs.design_inputs]), started or
                      resumed ([`start_design`][pes_ref.synthesis.runs.start_design])
- [`.plots`][pes_ref.synthesis.plots]       held-out paths drawn on a design's surface (``evaluate --plot``; imported
  when
                      it draws, with matplotlib, never here)


The names below are the public synthesis API (with [`Progress`][pes_ref.core.runtime.progress.Progress], what the loops'
callbacks receive, from [`pes_ref.core.runtime.progress`][pes_ref.core.runtime.progress]).
"""
from pes_ref.core.runtime.progress import Progress
from pes_ref.synthesis.optimizers import Adam, RMSprop, make_optimizer
from pes_ref.synthesis.gait import GaitShooting, GaitStarts, sample_gait_starts
from pes_ref.synthesis.exits import FunnelExit, exit_steps
from pes_ref.synthesis.funnel import exit_positions, FUNNEL_OBJECTIVES, FunnelProblem, IN_BAND_SHARE
from pes_ref.synthesis.oscillator import OSCILLATOR_COSTS, OscillatorProblem, PhaseThenCycle
from pes_ref.synthesis.problems import Batch
from pes_ref.synthesis.plans import (DEFAULT_OSCILLATOR_PLAN, FUNNEL_ENVELOPE_PLAN, FUNNEL_PLAN, OSCILLATOR_PLANS,
                                     OSCILLATOR_POLISH, Plan, PolishPlan, default_plan)
from pes_ref.synthesis.resampling import resample
from pes_ref.synthesis.objective_terms import OBJECTIVE_TERMS, TermSum
from pes_ref.synthesis.success import SUCCESS_TESTS
from pes_ref.synthesis.design_problem import FORCES, DesignProblem
from pes_ref.synthesis.refusals import check_design_memory, check_stable_design
from pes_ref.synthesis.kinds import (KINDS, DesignKind, Realizable, evaluate, evaluate_seeds, held_out_panels,
                                     held_out_steps, kind_named, kind_of)
from pes_ref.synthesis.design_state import STOPPED, DesignState, new_design
from pes_ref.synthesis.training import GradientStep, design_gradient, run_design
from pes_ref.synthesis.analysis import (ANALYSIS_PERIODS, CYCLE_DRIFT, CYCLE_TOLERANCE, Paths, TorqueSweep,
                                        cycle_figures, funnel_paths,
                                        oscillator_grid_starts,
                                        oscillator_torque_sweep, phase_space, q1_advance)
from pes_ref.synthesis.polish import (PolishParticles, PolishResult, capture_fitness, legendre_fourier_basis, polish,
                                      polish_particles)
from pes_ref.synthesis.stages import run_stages
from pes_ref.synthesis.escapement import escapement_values
from pes_ref.synthesis.problem_file import (SHIPPED_PROBLEMS, ProblemFileError, load_problem, parse_problem, plan_for,
                                            problem_from_text, problem_text, shipped_problem, with_sets)
from pes_ref.synthesis.design_file import DesignFileError, design_arrays, first_difference, load_design, save_design
from pes_ref.synthesis.runs import (DESIGN_OPTIONS, DesignInputs, check_resume, design_inputs, run_to_file,
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
    "run_stages",
    "escapement_values",
    "KINDS", "DesignKind", "Realizable", "kind_of", "kind_named", "held_out_steps", "held_out_panels",
    "DESIGN_OPTIONS", "DesignInputs", "design_inputs", "start_design", "check_resume", "run_to_file",
    "save_design", "load_design", "design_arrays", "first_difference",
    "DesignFileError",
    "DesignProblem", "OBJECTIVE_TERMS", "SUCCESS_TESTS", "FORCES", "TermSum", "load_problem", "parse_problem",
    "problem_from_text", "problem_text", "with_sets", "plan_for", "shipped_problem", "SHIPPED_PROBLEMS",
    "ProblemFileError",
]
