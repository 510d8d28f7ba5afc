"""validation/experiments/oscillator_plans.toml: each variant trains the grid of the plan of the same name
in oscillator_plans.py, bit for bit (at a few iterations on a tiny grid, the learning-rate schedule kept)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pes_ref.sweep.options import run_inputs
from pes_ref.sweep.spec import load_sweep
from pes_ref.synthesis import new_design, run_design

from _helpers import ROOT, load_script

EXPERIMENTS = ROOT / "validation" / "experiments"
plans = load_script(EXPERIMENTS / "oscillator_plans.py")

SWEEP = load_sweep(EXPERIMENTS / "oscillator_plans.toml")
#: A few iterations on an 8 x 8 grid with short runs, a stage change included.
TINY_STAGES = ((0, 8, 40), (2, 8, 60))
STOP = 4


def test_the_sweep_file_holds_the_plans_the_script_leaves_to_it():
    assert {run.variant for run in SWEEP.runs} == set(plans.SWEPT) and set(plans.SWEPT) <= set(plans.PLANS)


@pytest.mark.parametrize("run", SWEEP.runs, ids=lambda r: r.variant)
def test_variant_trains_the_scripts_plan(run):
    options = {**run.options, "iterations": STOP, "stages": [list(s) for s in TINY_STAGES]}
    inputs = run_inputs("oscillator", options)
    state = run_design(new_design("oscillator", seed=run.seed, plan=inputs.plan(), **inputs.sets))
    # the script's plan, on the same tiny stages, stopped at STOP with its lr schedule (decay over 3000) kept
    setting = dataclasses.replace(plans.PLANS[run.variant], stages=TINY_STAGES)
    assert setting.iterations == inputs.plan().decay_iterations == 3000
    record = plans.run(setting, run.seed, progress=lambda line: None, eval_periods=1, n_eval=2, stop=STOP)
    np.testing.assert_array_equal(state.values, record["grids"][f"it{STOP}"])
    assert state.history["loss"] == record["loss"]
