"""A design run from what a user names: its options resolved, then started or resumed.

One design run is named by *design options*, the flags of ``python -m pes_ref design``
(`DESIGN_OPTIONS`: ``iterations``, ``lr``, ``plan``, ``smoke``, ...), and by the *problem's
parameters* it changes (``--set NAME=VALUE``: a built-in kind's fields, a problem file's dotted
keys). [`design_inputs`][pes_ref.synthesis.engine.runs.design_inputs] resolves them against the
problem and its kind (`pes_ref.synthesis.kinds.registry.KINDS`) into the problem, the plan and the
polish plan; [`start_design`][pes_ref.synthesis.engine.runs.start_design] starts the run, or resumes
a saved one after checking that it is the run asked for. The ``design`` command, every run of a
sweep and the studies go through both, so a sweep file's options mean exactly what the same flags
mean on the command line. [`run_to_file`][pes_ref.synthesis.engine.runs.run_to_file] runs a design
to its end in its design file (claimed first, checkpointed, never left holding nothing).
"""
from __future__ import annotations

import dataclasses
import os
from typing import Callable, Mapping, NamedTuple

from pes_ref.core import backends
from pes_ref.core.checks import InputError
from pes_ref.core.runtime.keyfile import show
from pes_ref.synthesis.engine.design_file import DesignFileError, first_difference, save_design
from pes_ref.synthesis.engine.design_state import STOPPED, DesignState, new_design
from pes_ref.synthesis.kinds.registry import kind_of
from pes_ref.synthesis.common.plans import Plan
from pes_ref.synthesis.engine.refusals import check_design_memory, check_run_memory, check_stable_design
from pes_ref.synthesis.engine.paths_start import needs_paths_start, paths_start
from pes_ref.synthesis.engine.stages import run_stages, set_polish

__all__ = ["DESIGN_OPTIONS", "POLISH_OPTIONS", "DesignInputs", "design_inputs", "plan_overrides", "parse_stages",
           "start_design", "check_resume", "run_to_file"]

#: The design options and the value types they take (a float option takes an int too);
#: ``stages`` is ``"IT:GRID[:STEPS],..."`` text or a list of ``[it, grid(, n_steps)]``.
DESIGN_OPTIONS = {
    "iterations": int, "lr": float, "lr_final": float, "optimizer": str, "clip": float, "particles": int,
    "stages": (str, list), "no_stages": bool, "plan": str, "smoke": bool, "backend": str,
}
#: The plan field each plain plan option sets.
_PLAN_FIELDS = {"iterations": "iterations", "lr": "lr", "lr_final": "lr_final", "optimizer": "optimizer",
                "clip": "clip", "particles": "n_particles"}
#: The polish options and the polish plan's fields they set.
POLISH_OPTIONS = {"evaluations": "evaluations", "polish_particles": "n_particles"}
#: The plan fields of the ``--smoke`` preset and the problem-file key that sets each: a key set
#: explicitly (``--set train.iterations=20``) wins over the preset.
_SMOKE_TRAIN_KEYS = {"iterations": "train.iterations", "n_particles": "train.particles", "stages": "train.stages"}


class DesignInputs(NamedTuple):
    """What a run's options resolve to ([`design_inputs`][pes_ref.synthesis.engine.runs.design_inputs]).

    ``problem`` is the run's problem: ``base`` (the kind's default problem, a problem file's,
    or a resumed design's own) with the parameters ``sets`` (the named plan's and the smoke
    preset's, then those ``given`` explicitly); ``base_plan`` with ``plan_overrides`` is the
    plan, ``base_polish`` with ``polish_overrides`` the polish plan; ``smoke`` whether the
    ``--smoke`` preset applies."""

    problem: object
    base: object
    sets: dict
    given: dict
    plan_overrides: dict
    base_plan: Plan
    base_polish: object = None
    polish_overrides: dict = {}
    smoke: bool = False

    def plan(self) -> Plan:
        """The run's plan: `base_plan` with [`plan_overrides`][pes_ref.synthesis.engine.runs.plan_overrides]."""
        return dataclasses.replace(self.base_plan, **self.plan_overrides)

    def polish(self):
        """The run's polish plan (None: the run has no polish stage)."""
        if self.base_polish is None:
            return None
        return dataclasses.replace(self.base_polish, **self.polish_overrides)


def parse_stages(text: str) -> tuple:
    """``--stages`` text ``IT:GRID[:STEPS],...`` to the plan's stage tuples."""
    try:
        return tuple(tuple(int(x) for x in part.split(":")) for part in text.split(","))
    except ValueError:
        raise ValueError(f"--stages {text!r}: expected IT:GRID pairs separated by commas, e.g. 0:25,100:0") from None


def plan_overrides(options: Mapping) -> dict:
    """The plan fields the design options in ``options`` set (``None`` means not given)."""
    out = {field: options[name] for name, field in _PLAN_FIELDS.items() if options.get(name) is not None}
    stages = options.get("stages")
    if stages is not None:
        out["stages"] = parse_stages(stages) if isinstance(stages, str) else tuple(tuple(st) for st in stages)
    if options.get("no_stages"):
        out["stages"] = ((0, 0),)
    return out


def design_inputs(base, options: Mapping, sets: Mapping | None = None) -> DesignInputs:
    """Resolve design ``options`` and parameters ``sets`` (a built-in kind's fields, a problem
    file's dotted keys) for a run of problem ``base`` (its kind's default problem, a problem
    file's, or a resumed design's).

    The order is the design command's: the kind's default plan (a problem file's own
    ``[train]``, with the ``train.*`` keys of ``sets``), or the named ``plan`` (its problem
    overrides, plan and polish); then the ``smoke`` preset; then the explicit options and
    ``sets``, which win over both. A problem file without ``train.stages`` has the default stages
    of the run's iteration count ([`pes_ref.synthesis.plan_for`][pes_ref.synthesis.problem.problem_file.plan_for]).

    Raises
    ------
    ValueError
        For a ``plan`` the kind does not have, a parameter it lacks, a bad value.
    """
    kind = kind_of(base)
    given = dict(sets or {})
    sets = dict(given)
    plan_over = plan_overrides(options)
    base_plan, base_polish = None, kind.default_polish
    polish_over = {field: options[name] for name, field in POLISH_OPTIONS.items() if options.get(name) is not None}
    name = options.get("plan")
    if name is not None:
        if not kind.named_plans:
            raise InputError("plan", f"plan {name}: only the oscillator has named plans")
        if name not in kind.named_plans:
            raise ValueError(f"plan {name!r}: expected one of {sorted(kind.named_plans)}")
        plan_sets, base_plan, base_polish = kind.named_plans[name]
        sets = {**plan_sets, **sets}
    smoke = bool(options.get("smoke"))
    if smoke:
        preset = kind.smoke
        sets = {**preset.scene(base), **sets}
        preset_plan = {"iterations": preset.iterations, "n_particles": preset.particles, "stages": preset.stages}
        plan_over = {**{k: v for k, v in preset_plan.items() if _SMOKE_TRAIN_KEYS[k] not in sets}, **plan_over}
        if base_polish is not None:
            polish_over = {**preset.polish, **polish_over}
    if base_polish is None and polish_over:
        named = [name for name in POLISH_OPTIONS if options.get(name) is not None]
        raise InputError(named[0], f"{', '.join(named)}: this {kind.name} run has no polish stage")
    problem = kind.with_sets(base, sets)
    if base_plan is None:
        base_plan = kind.default_plan(problem, plan_over.get("iterations"))
    return DesignInputs(problem, base, sets, given, plan_over, base_plan, base_polish, polish_over, smoke)


def _a(word: str) -> str:
    return ("an " if word[:1] in "aeiou" else "a ") + word


def check_resume(state: DesignState, inputs: DesignInputs, where: str = "the resumed design") -> None:
    """Refuse to resume ``state`` as the run ``inputs`` names when it is another problem's.

    A problem file's design must have the file's problem in every key (``--set`` on a resumed
    design's own problem changes nothing it keeps); a built-in kind's must have each parameter
    the run sets. With ``--smoke``, a design of another size than the preset's is refused
    (``where`` names the design in messages).

    Raises
    ------
    DesignFileError
        Naming the first difference.
    """
    kind = kind_of(inputs.problem)
    if state.kind != kind.name:
        raise DesignFileError(f"the resume file is {_a(state.kind)} design, not {_a(kind.name)} design (another "
                              f"scene)")
    have, want = kind.data(state.problem), kind.data(inputs.problem)
    if inputs.smoke:
        # a resumed design keeps its scene: one of another size than the preset's is refused, naming --smoke
        for name, value in kind.smoke.scene(state.problem).items():
            if name in inputs.given:
                continue
            there = _dotted(have, name)
            if there != value:
                raise InputError("smoke", f"smoke resumes only a design of its size: the design has {name} = "
                                          f"{show(there)}, smoke's is {show(value)}; leave smoke out to resume it")
    if not kind.whole:
        for name in inputs.sets:
            if have[name] != want[name]:
                raise DesignFileError(f"the resume file is from another scene: {name} = {have[name]!r} there, "
                                      f"{want[name]!r} asked for")
        return
    difference = first_difference(have, want)
    if difference is None:
        return
    if inputs.base is state.problem:            # the design's own problem, changed by sets
        raise InputError("set", f"set: a resumed design keeps its problem; {difference}".replace(" there,", ","))
    raise DesignFileError(f"the problem file {inputs.problem.path} differs from the one the design was made with: "
                          f"{difference}; resume without the file (design --resume FILE.npz) or start a new design")


def _dotted(data: dict, name: str):
    for part in name.split("."):
        data = data[part]
    return data


def start_design(inputs: DesignInputs, *, seed: int | None = None, backend: str | None = None,
                 resume: DesignState | None = None, where: str = "the resumed design",
                 exact: bool = False, start_callback: Callable | None = None) -> DesignState:
    """The run ``inputs`` names: a fresh one (seed ``seed``, default 0), or ``resume`` continued.

    A fresh run of a realizable problem file that draws no starting shape starts from its smooth
    design's paths ([`pes_ref.synthesis.engine.paths_start`][pes_ref.synthesis.engine.paths_start]),
    that smooth design's progress going to ``start_callback``.

    A resumed run keeps its problem, seed, optimizer and backend (each given one must be its
    own: [`check_resume`][pes_ref.synthesis.engine.runs.check_resume]) and its plan and polish, with the options given applied
    (``--iterations``, ``--lr`` ...); it is checked again for stability and memory. With
    ``exact`` (a sweep's run, which names every option) the resumed design must be this very
    run: the same problem, plan, seed and backend.

    Raises
    ------
    ValueError
        A resumed design of another run, or an option that contradicts it (one line naming it).
    """
    if resume is None:
        seed = 0 if seed is None else seed
        plan, start = inputs.plan(), None
        if needs_paths_start(inputs.problem):
            check_run_memory(inputs.problem, plan, inputs.polish())      # before the start's own run
            start, _ = paths_start(inputs.problem, seed, plan.iterations, backend, callback=start_callback)
        return new_design(inputs.problem, seed=seed, plan=plan, polish=inputs.polish(), backend=backend,
                          start_values=start)
    state = resume
    if exact:
        if state.problem != inputs.problem or state.plan != inputs.plan() or state.seed != seed or \
                backend not in (None, state.backend):
            raise ValueError(f"{where} holds another run's design (scene, plan, seed or backend differ); move it "
                             f"away")
        return state
    check_resume(state, inputs, where)
    if seed is not None and seed != state.seed:
        raise InputError("seed", f"seed {seed} differs from the resumed run's ({state.seed})")
    optimizer = inputs.plan_overrides.get("optimizer")
    if optimizer is not None and optimizer != state.plan.optimizer:
        raise InputError("optimizer", f"optimizer {optimizer} differs from the resumed run's "
                                      f"{state.plan.optimizer}", names=("optimizer",))
    if backend is not None and backend != state.backend:
        raise InputError("backend", f"backend {backend} differs from the resumed run's {state.backend}")
    backends.check_backend(state.backend)
    state.plan = dataclasses.replace(state.plan, **inputs.plan_overrides)
    check_stable_design(state)
    check_design_memory(state)
    if state.polish is not None:
        set_polish(state, dataclasses.replace(state.polish, **inputs.polish_overrides))
    return state


def run_to_file(state: DesignState, out, *, fresh: bool, overwrite: bool, **run_options) -> DesignState:
    """Run ``state``'s stages to its plan's end
    ([`pes_ref.synthesis.engine.stages.run_stages`][pes_ref.synthesis.engine.stages.run_stages] with
    ``run_options``), its design file ``out`` claimed before the long run, checkpointed and
    written at the end (the package's atomic writer).

    ``fresh`` is a run that starts here (not a resumed file): an existing ``out`` it may
    ``overwrite`` is kept until there is a result, and if the run stops or fails before
    finishing an iteration, the file it claimed is removed (a file holding no iteration means
    nothing). A resumed run's file is updated in place.

    Raises
    ------
    FileExistsError
        If ``out`` exists and ``overwrite`` is False (the file is left as it was).
    """
    start = state.iteration
    created = not os.path.exists(out)
    try:
        if created or not fresh:
            save_design(out, state, overwrite=overwrite)          # claims the file before the long run
        elif not os.access(out, os.W_OK):                         # kept until there is a result
            raise PermissionError(f"cannot write {out}: the file is not writable")
        state = run_stages(state, state.plan.iterations, checkpoint=lambda s: save_design(out, s, overwrite=True),
                           **run_options)
    except Exception:
        if fresh and created and state.iteration == start and os.path.lexists(out):
            os.unlink(out)              # our own claim, and nothing done
        raise
    if fresh and state.iteration == 0 and state.status.startswith(STOPPED):
        if created:
            os.remove(out)
        return state
    save_design(out, state, overwrite=True)
    return state
