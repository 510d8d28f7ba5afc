"""The engine that runs a plan: a run's state, its stages (the gradient stage, then the polish),
its design file, and a run from what a user names.

- [`.refusals`][pes_ref.synthesis.engine.refusals]    what a design run refuses before it starts (unstable scene,
  memory)
- [`.design_state`][pes_ref.synthesis.engine.design_state] a run's state
  ([`DesignState`][pes_ref.synthesis.engine.design_state.DesignState]) and
  [`new_design`][pes_ref.synthesis.engine.design_state.new_design]
- [`.training`][pes_ref.synthesis.engine.training]    the loop of the gradient stage
  ([`run_design`][pes_ref.synthesis.engine.training.run_design])
- [`.polish`][pes_ref.synthesis.engine.polish]      the polish stage: CMA-ES on a smooth correction, capture-test
  fitness
- [`.stages`][pes_ref.synthesis.engine.stages]      a run's stages one after the other
  ([`run_stages`][pes_ref.synthesis.engine.stages.run_stages])
- [`.design_file`][pes_ref.synthesis.engine.design_file] design runs in ``.npz`` files
- [`.runs`][pes_ref.synthesis.engine.runs]        a run from what a user names: options resolved
  ([`design_inputs`][pes_ref.synthesis.engine.runs.design_inputs]), started or resumed
  ([`start_design`][pes_ref.synthesis.engine.runs.start_design])
"""
