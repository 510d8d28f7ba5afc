"""The ``design`` command of ``python -m pes_ref``.

- ``design funnel|oscillator [--iterations N] [--seed S] [--out FILE.npz] [--resume FILE.npz]
  [--force] [--set NAME=VALUE ...] [--lr LR] [--optimizer rmsprop|adam] [--clip C]
  [--particles N] [--objective gait|overshoot|eq6] [--evaluations N] [--polish-particles N]
  [--workers N] [--stages SPEC | --no-stages] [--smoke] [--quiet]``:
  run (or continue) a design, its gradient stage and then its polish if it has one
  (:func:`pes_ref.synthesis.stages.run_stages`), and write its file
  (:mod:`pes_ref.synthesis.design_file`). A progress line goes to stderr every ``--progress``
  seconds; Ctrl-C finishes the iteration or generation, saves and exits 130; a run that
  goes non-finite saves its last finite state and exits 1.

``--smoke`` is a tiny preset for tests and a quick look (see ``docs/synthesis.md``).
"""
from __future__ import annotations

import dataclasses
import os
import signal
import sys
import time

from pes_ref.cli.common import EXIT_FAIL, EXIT_INTERRUPTED, EXIT_OK, add_command, error

#: The ``--smoke`` preset: problem overrides per kind, the plan's (iterations, particles, stages)
#: and the polish plan's overrides (used when the run has a polish stage).
SMOKE = {
    "funnel": ({"grid": 12, "n_steps": 60, "dt": 0.05}, (6, 8, ((0, 0),)), {}),
    "oscillator": ({"grid0": 8, "grid1": 8, "n_steps": 60, "eval_periods": 4}, (6, 4, ((0, 0),)),
                   {"evaluations": 20, "n_particles": 6, "popsize": 8}),
}
METRIC_NAMES = {"funnel": "in_band", "oscillator": "amp_err"}
#: ``--objective`` choices: the keys of :data:`pes_ref.synthesis.plans.OSCILLATOR_OBJECTIVES` (tested equal).
OSCILLATOR_OBJECTIVE_NAMES = ("gait", "overshoot", "eq6")


def add_parser(sub) -> None:
    p = add_command(sub, "design", help="design a funnel or an oscillator by gradient descent (paper Figs. 6-11)",
        description="Optimize the grid values of a potential energy surface for the paper's funnel or "
                    "oscillator objective and write the design (grid, scene parameters, seed, loss history, "
                    "optimizer state) to FILE.npz. The default oscillator runs prescribed-gait shooting by "
                    "gradient descent, then a gradient-free polish (CMA-ES). --iterations is the total count "
                    "to reach, also on --resume. Ctrl-C stops after the current iteration or polish "
                    "generation and saves. An existing --out is refused unless --force; with --resume and no "
                    "--out the resumed file itself is updated.",
        examples=['design funnel --out funnel.npz', 'design oscillator --seed 1 --out osc.npz && python -m pes_ref evaluate osc.npz'])
    p.add_argument("kind", choices=["funnel", "oscillator"], help="the device to design")
    p.add_argument("--iterations", type=int, default=None, help="total iterations (default: the plan's)")
    p.add_argument("--seed", type=int, default=None, help="run seed (default 0; a resumed run keeps its own)")
    p.add_argument("--out", default=None, metavar="FILE.npz", help="design file to write (default KIND.npz)")
    p.add_argument("--resume", default=None, metavar="FILE.npz", help="continue the run saved in this file")
    p.add_argument("--force", action="store_true", help="overwrite an existing --out")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="override one scene parameter (e.g. --set n_steps=200); repeatable; the names: "
                        + "; ".join(f"{kind}: {', '.join(names)}" for kind, names in _set_names().items()))
    p.add_argument("--lr", type=float, default=None, help="initial learning rate (default: the plan's)")
    p.add_argument("--lr-final", type=float, default=None, help="learning rate reached at the last iteration (default: the plan's)")
    p.add_argument("--objective", choices=OSCILLATOR_OBJECTIVE_NAMES, default=None,
                   help="oscillator only: named training setting, 'gait' (default: prescribed-gait shooting, then "
                        "the polish), 'overshoot' (eq. (6) + eq. (7) aimed at 1.4 times the target amplitude) or "
                        "'eq6' (the paper's setting, aimed at the target amplitude); evaluation is the same for all")
    p.add_argument("--evaluations", type=int, default=None,
                   help="polish stage only: fitness evaluations (default: the polish plan's)")
    p.add_argument("--polish-particles", type=int, default=None,
                   help="polish stage only: training particles of the fitness (default: the polish plan's)")
    p.add_argument("--workers", type=int, default=1,
                   help="processes evaluating the polish's candidates (the result does not depend on it)")
    p.add_argument("--optimizer", choices=["rmsprop", "adam"], default=None,
                   help="the optimizer (default: the plan's; a resumed run keeps its own)")
    p.add_argument("--clip", type=float, default=None, help="clip the gradient to this norm (default: the plan's)")
    p.add_argument("--particles", type=int, default=None, help="particles per iteration (default: the plan's)")
    grp = p.add_mutually_exclusive_group()
    grp.add_argument("--stages", default=None, metavar="IT:GRID,...",
                     help="coarse-to-fine grid stages, e.g. 0:25,100:50,200:0 (0 = the scene's grid)")
    grp.add_argument("--no-stages", action="store_true", help="plain run on the scene's grid from the start")
    p.add_argument("--smoke", action="store_true", help="tiny preset (a few iterations on a tiny grid)")
    p.add_argument("--progress", type=float, default=2.0, metavar="SECONDS", help="progress line period")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=_run_design)


def _set_names() -> dict:
    """The names ``--set`` takes, per kind: the fields of each design problem."""
    from pes_ref.synthesis.problems import PROBLEMS
    return {kind: [f.name for f in dataclasses.fields(cls)] for kind, cls in PROBLEMS.items()}


def _parse_sets(items, problem_cls) -> dict:
    fields = {f.name: f for f in dataclasses.fields(problem_cls)}
    out = {}
    for item in items:
        name, sep, text = item.partition("=")
        if not sep or name not in fields:
            raise ValueError(f"--set {item!r}: expected NAME=VALUE with NAME one of {sorted(fields)}")
        default = fields[name].default
        try:
            out[name] = type(default)(text) if not isinstance(default, bool) else text.lower() in ("1", "true")
        except ValueError:
            raise ValueError(f"--set {item!r}: {text!r} is not a {type(default).__name__}") from None
    return out


def _parse_stages(text: str) -> tuple:
    try:
        return tuple(tuple(int(x) for x in part.split(":")) for part in text.split(","))
    except ValueError:
        raise ValueError(f"--stages {text!r}: expected IT:GRID pairs separated by commas, e.g. 0:25,100:0") from None


def _plan_overrides(args) -> dict:
    out = {}
    for name, key in (("iterations", "iterations"), ("lr", "lr"), ("lr_final", "lr_final"),
                      ("optimizer", "optimizer"), ("clip", "clip"), ("particles", "n_particles")):
        if getattr(args, name) is not None:
            out[key] = getattr(args, name)
    if args.stages is not None:
        out["stages"] = _parse_stages(args.stages)
    if args.no_stages:
        out["stages"] = ((0, 0),)
    return out


def _polish_overrides(args) -> dict:
    out = {}
    for name, key in (("evaluations", "evaluations"), ("polish_particles", "n_particles")):
        if getattr(args, name) is not None:
            out[key] = getattr(args, name)
    return out


def _pool(workers: int):
    """A process pool for the polish's candidates (None for 1 worker); its workers ignore Ctrl-C,
    which the main process turns into a clean stop."""
    if workers < 1:
        raise ValueError(f"--workers must be >= 1, got {workers}")
    if workers == 1:
        return None
    from concurrent.futures import ProcessPoolExecutor
    return ProcessPoolExecutor(workers, initializer=signal.signal, initargs=(signal.SIGINT, signal.SIG_IGN))


def _format_time(seconds: float) -> str:
    if not seconds < float("inf"):
        return "?"
    seconds = int(round(seconds))
    return f"{seconds // 60}:{seconds % 60:02d}"


def _run_design(args) -> int:
    from pes_ref import synthesis
    from pes_ref.synthesis import check_same_scene, load_design, save_design
    from pes_ref.synthesis.stages import set_polish
    try:
        sets = _parse_sets(args.set, synthesis.PROBLEMS[args.kind])
        plan_over, polish_over = _plan_overrides(args), _polish_overrides(args)
        base_plan, base_polish = synthesis.DEFAULT_PLANS[args.kind], synthesis.DEFAULT_POLISH[args.kind]
        if args.objective is not None:
            if args.kind != "oscillator":
                raise ValueError(f"--objective {args.objective}: only the oscillator has a choice of objective")
            obj_sets, base_plan = synthesis.OSCILLATOR_OBJECTIVES[args.objective]
            base_polish = synthesis.OSCILLATOR_POLISH[args.objective]
            sets = {**obj_sets, **sets}
        if args.smoke:
            smoke_sets, (its, parts, stages), smoke_polish = SMOKE[args.kind]
            sets = {**smoke_sets, **sets}
            plan_over = {"iterations": its, "n_particles": parts, "stages": stages, **plan_over}
            polish_over = {**smoke_polish, **polish_over}
        if args.resume is not None:
            state = load_design(args.resume)
            check_same_scene(state, args.kind, sets)
            if args.seed is not None and args.seed != state.seed:
                raise ValueError(f"--seed {args.seed} differs from the resumed run's seed {state.seed}")
            if "optimizer" in plan_over and plan_over["optimizer"] != state.plan.optimizer:
                raise ValueError(f"--optimizer {plan_over['optimizer']} differs from the resumed run's "
                                 f"{state.plan.optimizer}")
            state.plan = dataclasses.replace(state.plan, **plan_over)
            _refuse_polish_options(args, state.polish, _polish_overrides(args))
            if state.polish is not None:
                set_polish(state, dataclasses.replace(state.polish, **polish_over))
            out = args.out if args.out is not None else args.resume
            may_overwrite = args.force or os.path.abspath(out) == os.path.abspath(args.resume)
        else:
            _refuse_polish_options(args, base_polish, _polish_overrides(args))
            plan = dataclasses.replace(base_plan, **plan_over)
            polish = None if base_polish is None else dataclasses.replace(base_polish, **polish_over)
            state = synthesis.new_design(args.kind, seed=0 if args.seed is None else args.seed, plan=plan,
                                         polish=polish, **sets)
            out = args.out if args.out is not None else f"{args.kind}.npz"
            may_overwrite = args.force
        if os.path.exists(out) and not may_overwrite:
            raise FileExistsError(f"{out} exists; refusing to overwrite it (use --force or another --out)")
        executor = _pool(args.workers)
    except (OSError, ValueError, TypeError) as exc:
        return error(exc)

    metric_name = METRIC_NAMES[args.kind]

    def progress(p):
        if not args.quiet:
            print(_PROGRESS_LINES[type(p).__name__](args.kind, metric_name, p), file=sys.stderr, flush=True)

    def checkpoint(s):
        save_design(out, s, overwrite=True)

    start_it, t0 = state.iteration, time.perf_counter()
    try:
        save_design(out, state, overwrite=may_overwrite)       # claims the file before the long run
        state = synthesis.run_stages(state, state.plan.iterations, executor=executor, callback=progress,
                                     progress_every=args.progress, checkpoint=checkpoint)
        save_design(out, state, overwrite=True)
    except (OSError, ValueError) as exc:
        return error(exc)
    finally:
        if executor is not None:
            executor.shutdown()
    print(_summary(args.kind, metric_name, out, state, state.iteration - start_it, time.perf_counter() - t0))
    if state.status.startswith("non-finite"):
        print(f"error: the run went non-finite and stopped; the last finite state (iteration {state.iteration}) "
              f"is saved: {state.status}", file=sys.stderr)
        return EXIT_FAIL
    if state.status == "interrupted":
        again = " (the polish starts again from its beginning)" if state.stage == "polish" else ""
        print(f"interrupted; saved; continue with: python -m pes_ref design {args.kind} --resume {out}{again}",
              file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_OK


def _refuse_polish_options(args, polish, polish_over: dict) -> None:
    """Polish options on a run without a polish stage are a mistake: say so."""
    if polish is None and (polish_over or args.workers != 1):
        names = ", ".join(f"--{n.replace('_', '-')}" for n in ("evaluations", "polish_particles", "workers")
                          if getattr(args, n) not in (None, 1))
        raise ValueError(f"{names}: this {args.kind} run has no polish stage")


def _gradient_line(kind: str, metric_name: str, p) -> str:
    return (f"design {kind}: it {p.iteration}/{p.total} | loss {p.loss:.4g} | {metric_name} {p.metric:.3f} | "
            f"{p.it_per_s:.1f} it/s | left {_format_time(p.seconds_left)}")


def _polish_line(kind: str, metric_name: str, p) -> str:
    return (f"design {kind}: polish {p.evaluations}/{p.total} evaluations | fitness {p.fitness:.4g} "
            f"(start {p.fitness_start:.4g}) | {p.evals_per_s:.1f} ev/s | left {_format_time(p.seconds_left)}")


#: Progress lines by the progress record's type (gradient iterations, polish generations).
_PROGRESS_LINES = {"Progress": _gradient_line, "PolishProgress": _polish_line}


def _summary(kind: str, metric_name: str, out: str, state, iterations: int, seconds: float) -> str:
    loss = state.history["loss"][-1] if state.history["loss"] else float("nan")
    metric = state.history["metric"][-1] if state.history["metric"] else float("nan")
    line = (f"wrote {out}: {kind}, iteration {state.iteration}/{state.plan.iterations} "
            f"({state.status.split(':')[0]}), loss {loss:.6g}, {metric_name} {metric:.3f}")
    if state.stage == "polish":
        fit = state.polish_history["fitness"]
        line += (f", polish {state.evaluations} evaluations"
                 + (f", fitness {fit[0]:.4g} -> {fit[-1]:.4g}" if fit else ""))
    return line + f"; {iterations} iterations this run, {seconds:.1f} s"
