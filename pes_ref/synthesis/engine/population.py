"""A population of starts, chosen on validation: structure one start's gradient does not find, another's may.

A plan with ``starts > 1`` ([`Plan`][pes_ref.synthesis.common.plans.Plan]) runs, before the rest of its gradient
stage, ``starts`` designs of the problem for its first ``screen`` iterations: the run's own
start (its initial grid and batches) and ``starts - 1`` others, start ``j`` the run of design
seed [`start_seed`][pes_ref.synthesis.engine.population.start_seed]``(seed, j)`` (its own initial grid and batches).
Each follows the plan (its stages, its validations, its early stop at the target). The starts run
one after the other and the first that reaches the plan's target is the design, so a problem the
run's own start solves early costs nothing more; so does one whose own start passes at least
`OWN_SHARE` of its validation particles by iteration ``screen``: the run goes on as itself. Otherwise the starts
run until `COMPARED` of them pass some (or all have run), and each start's grid after ``screen``
iterations is judged on the run's own validation particles
([`pes_ref.synthesis.common.validation`][pes_ref.synthesis.common.validation]): among those that pass
some (all, if none does) the best by the share passing its tests, then (ties, such as every start at 0
before the structure that passes exists) by the objective on those particles, the loss the run
descends. The run goes on from the best start's grid, optimizer and history, with its own batches
from iteration ``screen`` on; its validation record restarts with that judgment (the starts' own
validations were on their own particles). ``state.screened`` counts the starts screened and the
iterations they ran.

Measured on the examples of docs/problems.md ("Phases, classes and timing windows"): on the
light overload release whether the bowl behind the gate appears by the middle of the run decides
the design, and it appears in some starts and not in others; the first start in which it appears
is not always the one that finishes it in the final stage's iterations.

The screening is not checkpointed: a run stopped during it is back at its start (iteration 0)
and screens again from the beginning, deterministically, as a polish does.
"""
from __future__ import annotations

import copy
import dataclasses
from typing import Callable

import numpy as np

from pes_ref.core.stability import UnstableStepError
from pes_ref.synthesis.engine.design_state import DesignState, new_design
from pes_ref.synthesis.engine.training import design_step, run_design
from pes_ref.synthesis.common.validation import VALIDATION_STREAM, Best, validation_success

__all__ = ["START_STREAM", "start_seed", "screen_starts"]

#: The second entry of ``SeedSequence([seed, START_STREAM, j])``, which gives start ``j``'s design seed.
START_STREAM = 2 ** 32 + 4
#: How many starts that pass some validation particles by the screen are screened and compared
#: before the run goes on from the best of them (the run's own start among them unless it is
#: taken at once, `OWN_SHARE`).
COMPARED = 2
#: The run's own start is the run itself when its best validation by the screen passes at least
#: this share of the particles; one that passes fewer is compared with the others. Measured on
#: speed_sorter_barriers: an own start that sorts one class of three by the screen (0.335) ends
#: there, while others of its population at 0.995 by the screen finish.
OWN_SHARE = 0.5


def start_seed(seed: int, j: int) -> int:
    """The design seed of start ``j`` of a run of design seed ``seed``: ``seed`` itself for
    ``j = 0``, else a 32-bit draw of ``SeedSequence([seed, START_STREAM, j])``."""
    if j == 0:
        return seed
    return int(np.random.SeedSequence([seed, START_STREAM, j]).generate_state(1)[0])


def _judged(state: DesignState, member: DesignState) -> tuple:
    """``(success, loss, final)``: ``member``'s grid on ``state``'s validation particles: the share
    passing, the objective there (inf where its run leaves the finite numbers) and the grid
    on the problem's own."""
    plan, problem = state.plan, state.problem
    success, final = validation_success(problem, member.values, state.seed, plan.validation_particles,
                                        state.backend)
    try:
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            loss = float(design_step(problem, member.values, state.seed, VALIDATION_STREAM, plan.validation_particles,
                                     None, state.backend)[0])
    except (FloatingPointError, UnstableStepError):
        loss = float("inf")
    return success, loss if np.isfinite(loss) else float("inf"), final


def _adopt(state: DesignState, member: DesignState, judged: tuple) -> None:
    """``state`` goes on from ``member``'s grid, optimizer and history, judged on its own particles."""
    success, _, final = judged
    state.values, state.optimizer = member.values, member.optimizer
    state.iteration, state.history = member.iteration, member.history
    state.validation = {"iteration": [member.iteration], "success": [success]}
    state.best = Best(member.iteration, success, final)
    state.status = "running"


def _take(state: DesignState, member: DesignState) -> None:
    """``state`` becomes the run of its own start, ``member`` (its time kept)."""
    elapsed = state.elapsed
    for field in dataclasses.fields(state):
        setattr(state, field.name, getattr(member, field.name))
    state.elapsed = elapsed


def _labelled(callback: Callable | None, start: str) -> Callable | None:
    """``callback`` with each progress's stage named after its start too (``"start 2/8 stage 1/3"``)."""
    if callback is None:
        return None

    def labelled(progress):
        progress.stage = f"{start} {progress.stage}"
        callback(progress)
    return labelled


def screen_starts(state: DesignState, iterations: int | None = None, *, callback: Callable | None = None,
                  progress_every: float = 2.0) -> bool:
    """Run the plan's population of starts on a fresh ``state`` (module docstring) and leave it on
    the chosen one: done if a start reached the target, else running at iteration ``screen`` (at
    most ``iterations``, the run's; default the plan's). Returns whether it screened: a plan with
    one start, or a run already under way (a resumed one among them), is left as it is (False). Ctrl-C stops it with
    ``state`` at its start, ``status = "interrupted"``; ``callback`` receives each start's progress,
    its stage named after the start (``"start 2/8 stage 1/3"``); a start that stops on a failed iteration
    (`pes_ref.synthesis.engine.design_state.STOPPED`) is not chosen, and if every one does, ``state`` is
    the run's own start so stopped."""
    plan = state.plan
    if plan.starts <= 1 or state.iteration > 0 or state.history["loss"]:
        return False
    screen = min(plan.screen, plan.iterations if iterations is None else iterations)
    judged, passing, first = [], 0, None          # judged: (judgment, j, member, whether it passes some)
    for j in range(plan.starts):
        if j == 0:
            member = dataclasses.replace(state, values=state.values.copy(), optimizer=copy.deepcopy(state.optimizer),
                                         history={k: list(h) for k, h in state.history.items()},
                                         validation={k: list(h) for k, h in state.validation.items()})
        else:
            member = new_design(state.problem, seed=start_seed(state.seed, j), plan=plan, polish=None,
                                backend=state.backend)
        before = member.elapsed
        run_design(member, screen, callback=_labelled(callback, f"start {j + 1}/{plan.starts}"),
                   progress_every=progress_every, finish=False)
        state.elapsed += member.elapsed - before
        state.screened = {"starts": j + 1, "iterations": state.screened["iterations"] + member.iteration}
        if member.status == "interrupted":
            state.status = "interrupted"
            state.screened = {"starts": 0, "iterations": 0}
            return True
        if member.status == "done":                 # it reached the target: the design
            _go_on(state, member, j)
            return True
        if member.status != "running":              # stopped on a failed iteration
            if j == 0:
                first = member
            continue
        passes = member.best is not None and member.best.success > 0.0
        if j == 0 and passes and member.best.success >= OWN_SHARE:     # the run itself
            _go_on(state, member, j)
            return True
        judged.append((_judged(state, member), j, member, passes))
        passing += passes
        if passing >= COMPARED:
            break
    if not judged:
        screened = state.screened
        _take(state, first)
        state.screened = screened
        return True
    candidates = [m for m in judged if m[3]] or judged         # those that pass some, if any
    best = min(candidates, key=lambda m: (-m[0][0], m[0][1], m[1]))
    _adopt(state, best[2], best[0])
    return True


def _go_on(state: DesignState, member: DesignState, j: int) -> None:
    """``state`` goes on from start ``j``, ``member``: the run itself for its own start, else
    ``member``'s grid judged again on the run's own particles."""
    if j == 0:
        screened = state.screened
        _take(state, member)
        state.screened = screened
    else:
        _adopt(state, member, _judged(state, member))
