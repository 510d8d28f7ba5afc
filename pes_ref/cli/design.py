"""The ``design`` command of ``python -m pes_ref``.

- ``design PROBLEM.toml [same options]``, or a shipped problem by its name (``design latch``): the
  problem a problem file states (``docs/problems.md``); ``--set`` takes its keys by dotted name;
  ``design --resume FILE.npz`` continues a design from the problem its file holds.

- ``design funnel|oscillator [--iterations N] [--seed S] [--out FILE.npz] [--resume FILE.npz]
  [--force] [--set NAME=VALUE ...] [--lr LR] [--optimizer rmsprop|adam] [--clip C] [--particles N]
  [--plan gait|overshoot|eq6] [--evaluations N] [--polish-particles N] [--workers N] [--backend
  numba|numpy] [--stages SPEC | --no-stages] [--smoke] [--quiet]``: run (or continue) a design, its
  gradient stage and then its polish if it has one
  ([`pes_ref.synthesis.engine.stages.run_stages`][pes_ref.synthesis.engine.stages.run_stages]), and
  write its file ([`pes_ref.synthesis.engine.design_file`][pes_ref.synthesis.engine.design_file]). A
  progress line goes to stderr every ``--progress`` seconds; Ctrl-C or SIGTERM finishes the
  iteration or generation, saves and exits 130; a run that goes non-finite, or whose grid steepens
  past the stability rule, saves its last good state and exits 1 (a fresh run that stops before
  finishing an iteration writes no file). A scene past the stability rule from the start (``--set
  dt=...``) is refused before anything is written (docs/spec.md section 10).

``--smoke`` is a tiny preset for tests and a quick look (see ``docs/synthesis.md``).
"""
from __future__ import annotations

import os
import sys
import time

from pes_ref.cli.common import (EXIT_FAIL, EXIT_INTERRUPTED, EXIT_OK, LazyChoices, LazyHelp, add_command, error,
                                input_file, output_file)
from pes_ref.cli.files import expect

#: The library's names of what the options set, and the options (errors name the option):
#: the plan's parameters here, each problem parameter ``NAME`` as ``--set NAME`` (`_flags`).
PLAN_FLAGS = {"iterations": "--iterations", "lr": "--lr", "lr_final": "--lr-final", "clip": "--clip",
              "n_particles": "--particles", "optimizer": "--optimizer", "stages": "--stages", "seed": "--seed",
              "plan": "--plan", "evaluations": "--evaluations", "polish_particles": "--polish-particles",
              "backend": "--backend", "smoke": "--smoke", "set": "--set", "workers": "--workers"}
#: What a problem file's design names in its errors where a built-in kind names its ``--set`` fields.
_FILE_FLAGS = {"problem": {"n_steps": "dynamics.duration / dt", "grid": "surface.shape"}}
#: ``--plan`` choices: the oscillator's named plans, read from their home when an argument is
#: checked or the help shown (``python -m pes_ref --help`` builds every command's parser, and
#: building a parser imports nothing from the layers below the command line:
#: tests/cli/test_oracle_startup.py).
PLAN_CHOICES = LazyChoices("pes_ref.synthesis.common.plans", "OSCILLATOR_PLANS")


def set_names() -> dict:
    """The names ``--set`` takes, per built-in kind: the fields of its problem
    (`pes_ref.synthesis.kinds.registry.KINDS`, each kind's ``default_problem``)."""
    import dataclasses
    from pes_ref.synthesis.kinds.registry import KINDS
    return {name: tuple(f.name for f in dataclasses.fields(kind.default_problem))
            for name, kind in KINDS.items() if kind.default_problem is not None}


def shipped_names() -> tuple:
    """The problem files shipped with the package, by name
    (`pes_ref.synthesis.problem.problem_file.SHIPPED_PROBLEMS`)."""
    from pes_ref.synthesis.problem.problem_file import SHIPPED_PROBLEMS
    return SHIPPED_PROBLEMS


def _kind_help() -> str:
    return ("the device to design: the paper's funnel or oscillator, or a problem file (docs/problems.md; a "
            "shipped one by its name: " + ", ".join(f"{name}.toml" for name in shipped_names()) + "); with "
            "--resume it may be left out")


def _set_help() -> str:
    return ("override one scene parameter (e.g. --set n_steps=200); repeatable; the names: "
            + "; ".join(f"{kind}: {', '.join(names)}" for kind, names in set_names().items())
            + "; a problem file: any of its keys by its dotted name, VALUE in TOML "
              "(e.g. --set dynamics.dt=0.005 --set objective.1.weight=2)")


def add_parser(sub) -> None:
    p = add_command(sub, "design", help="design a funnel, an oscillator or a problem file's device by gradient "
                                        "descent (paper Figs. 6-11; docs/problems.md)",
        description="Optimize the grid values of a potential energy surface for the paper's funnel or "
                    "oscillator objective, or for the problem a problem file states (docs/problems.md), and "
                    "write the design (grid, scene parameters or the problem file's text, seed, loss history, "
                    "optimizer state) to FILE.npz. The default oscillator runs prescribed-gait shooting by "
                    "gradient descent, then a gradient-free polish (CMA-ES). --iterations is the total count "
                    "to reach, also on --resume. Ctrl-C (or SIGTERM) stops after the current iteration or "
                    "polish generation, saves and exits 130. An existing --out is refused unless --force; with "
                    "--resume and no --out the resumed file itself is updated.",
        examples=['design funnel --out funnel.npz',
                  'design oscillator --smoke --out osc.npz && python -m pes_ref evaluate osc.npz',
                  'design latch --out latch.npz && python -m pes_ref design --resume latch.npz --iterations 1500'])


    p.add_argument("kind", nargs="?", default=None, metavar="funnel|oscillator|PROBLEM.toml",
                   help=LazyHelp(_kind_help))
    p.add_argument("--iterations", type=int, default=None, metavar="N", help="total iterations (default: the plan's)")
    p.add_argument("--seed", type=int, default=None, metavar="S",
                   help="run seed (default 0; a resumed run keeps its own)")
    p.add_argument("--out", default=None, metavar="FILE.npz", help="design file to write (default KIND.npz)")
    p.add_argument("--resume", default=None, metavar="FILE.npz", help="continue the run saved in this file")
    p.add_argument("--force", action="store_true", help="overwrite an existing --out")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help=LazyHelp(_set_help))
    p.add_argument("--lr", type=float, default=None, metavar="LR", help="initial learning rate (default: the plan's)")
    p.add_argument("--lr-final", type=float, default=None, metavar="LR", help="learning rate reached at the last iteration (default: the plan's)")
    p.add_argument("--plan", choices=PLAN_CHOICES, default=None, metavar="NAME",
                   help="oscillator only: the named training plan, i.e. the objective trained on, its aim and "
                        "the optimizer schedule: 'gait' (default: prescribed-gait shooting, then the polish), "
                        "'overshoot' (eq. (6) + eq. (7) aimed at 1.4 times the target amplitude) or 'eq6' (the "
                        "paper's setting, aimed at the target amplitude); evaluation is the same for all")
    p.add_argument("--evaluations", type=int, default=None,
                   help="polish stage only: fitness evaluations (default: the polish plan's)")
    p.add_argument("--polish-particles", type=int, default=None,
                   help="polish stage only: training particles of the fitness (default: the polish plan's)")
    p.add_argument("--workers", type=int, default=None,
                   help="processes evaluating the polish's candidates (default: 2 on a machine with 2 cores or "
                        "more, 1 under --smoke; the result does not depend on it)")
    p.add_argument("--backend", choices=["numba", "numpy"], default=None,
                   help="the loops that run the design: 'numba' (compiled; the default when the extra 'fast' is "
                        "installed) or 'numpy'; the design file records it and a resumed run keeps its own (the "
                        "gradients differ in their last bits, so a long design may end elsewhere)")
    p.add_argument("--optimizer", choices=["rmsprop", "adam"], default=None,
                   help="the optimizer (default: the plan's; a resumed run keeps its own)")
    p.add_argument("--clip", type=float, default=None, metavar="NORM", help="clip the gradient to this norm (default: the plan's)")
    p.add_argument("--particles", type=int, default=None, metavar="N", help="particles per iteration (default: the plan's)")
    grp = p.add_mutually_exclusive_group()
    grp.add_argument("--stages", default=None, metavar="IT:GRID[:STEPS],...",
                     help="coarse-to-fine stages: from iteration IT on, GRID nodes per axis and STEPS steps per "
                          "training run, e.g. 0:25,100:50,200:0 (0 = the scene's own grid or steps)")
    grp.add_argument("--no-stages", action="store_true", help="plain run on the scene's grid from the start")
    p.add_argument("--smoke", action="store_true", help="tiny preset (a few iterations on a tiny grid)")
    p.add_argument("--progress", type=float, default=2.0, metavar="SECONDS",
                   help="seconds between progress lines (0: after every iteration)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.set_defaults(func=_run_design)


def _flags(kind: str | None) -> dict:
    """Every name an error of a ``kind`` design may carry, and the option that sets it (a
    problem file's errors name its own keys; its steps come from its dynamics)."""
    return {**{name: f"--set {name}" for name in set_names().get(kind, ())}, **_FILE_FLAGS.get(kind, {}), **PLAN_FLAGS}


def _base_problem(arg: str | None, state):
    """The problem the positional argument names: a built-in kind's default problem, or the
    problem file read (a path; or a shipped problem by its name, with or without ``.toml``,
    when no such path exists); without one, the resumed design's own problem."""
    from pes_ref.synthesis import kind_named, load_problem, shipped_problem
    if arg is None:
        return state.problem
    if arg in set_names():
        return kind_named(arg).default_problem()
    stem = arg[:-5] if arg.endswith(".toml") else arg
    if not os.path.exists(arg) and os.sep not in arg and stem in shipped_names():
        return load_problem(shipped_problem(stem))
    if not arg.endswith(".toml") and not os.path.exists(arg):
        raise ValueError(f"design {arg!r}: expected funnel, oscillator, a problem file PATH.toml, or a shipped "
                         f"problem ({', '.join(shipped_names())})")
    return load_problem(input_file(arg, "problem file"))


def error_stopped(state) -> int:
    """The one line of a fresh run that stopped before finishing an iteration (no file is
    left: it would hold no iteration, and a scene that fails at once); EXIT_FAIL."""
    print(f"error: the run stopped at its first iteration, so no design file was written: {state.status}",
          file=sys.stderr)
    return EXIT_FAIL


def _run_design(args) -> int:
    from pes_ref import synthesis
    from pes_ref.synthesis import design_inputs, kind_of, load_design, run_to_file, start_design
    from pes_ref.synthesis.engine.polish import polish_pool, polish_workers
    flags = _flags(args.kind)
    try:
        if not args.progress >= 0:
            raise ValueError(f"--progress must be a number of seconds >= 0, got {args.progress}")
        if args.kind is None and args.resume is None:
            raise ValueError("give what to design (funnel, oscillator or PROBLEM.toml), or --resume FILE.npz")
        state = None if args.resume is None else load_design(expect(args.resume, "design"))
        base = _base_problem(args.kind, state)
        kind = kind_of(base)
        flags = _flags(kind.name)
        inputs = design_inputs(base, vars(args), kind.parse_sets(args.set))
        workers = polish_workers(args.workers, inputs, args.smoke)
        executor = polish_pool(workers, inputs, kind.name)
        if args.resume is not None:
            out = args.out if args.out is not None else args.resume
            may_overwrite = args.force or os.path.abspath(out) == os.path.abspath(args.resume)
        else:
            out = args.out if args.out is not None else f"{getattr(inputs.problem, 'name', kind.name)}.npz"
            may_overwrite = args.force
        output_file(out, "design", force=may_overwrite)      # before a start that takes a run of its own
    except (OSError, ValueError, TypeError, ImportError) as exc:   # ImportError: a missing extra, with its pip line
        return error(exc, flags)
    for line in getattr(inputs.problem, "warnings", ()):       # a problem file's, before the run
        print(f"warning: {inputs.problem.path}: {line}", file=sys.stderr)

    from pes_ref.core.runtime.progress import ProgressWriter, figure_text

    shown = []                          # the stages shown so far
    lines = ProgressWriter()            # in place at a terminal, plain lines elsewhere

    def start_progress(p):
        if not args.quiet:
            p.label = f"start (smooth design): {p.label}"
            lines.show(p)

    try:
        if args.resume is None and synthesis.needs_paths_start(inputs.problem) and not args.quiet:
            lines.note(f"{inputs.problem.name}: its start is made from the passing paths of a smooth design of "
                       f"the same problem (docs/realize.md, \"Realizable design for any problem\")")
        state = start_design(inputs, seed=args.seed, backend=args.backend, resume=state, where=args.resume,
                             start_callback=start_progress)
        lines.end()
    except (OSError, ValueError, TypeError, ImportError) as exc:
        lines.end()
        return error(exc, flags)

    def progress(p):
        if args.quiet:
            return
        if shown and p.stage != shown[-1] and p.figure("steps") is not None:   # a new gradient stage
            lines.note(f"{p.label}: now {p.stage}: grid {figure_text(p.figure('grid'))}, {p.figure('steps')} "
                       f"steps per run (its loss is not comparable with {shown[-1]}'s)")
        shown.append(p.stage)
        lines.show(p)

    start, t0 = state.iteration, time.perf_counter()
    fresh = args.resume is None
    try:
        state = run_to_file(state, out, fresh=fresh, overwrite=may_overwrite, executor=executor, tasks=workers,
                            callback=progress, progress_every=args.progress)
        lines.end()                     # the last progress line stays, whole, before anything else is printed
        if fresh and state.iteration == 0 and state.status.startswith(synthesis.STOPPED):
            return error_stopped(state)
    except Exception as exc:
        lines.end()
        if not isinstance(exc, (OSError, ValueError)):
            raise
        return error(exc, flags)
    finally:
        lines.end()                     # (a second Ctrl-C's abort too)
        if executor is not None:
            executor.shutdown()
    name = getattr(state.problem, "name", kind.name)
    print(_summary(name, state.problem.metric_name, out, state, state.iteration - start, time.perf_counter() - t0))
    if state.status.startswith(synthesis.STOPPED):
        print(f"error: the run stopped; its last good state (iteration {state.iteration}) is saved: {state.status}",
              file=sys.stderr)
        return EXIT_FAIL
    if state.status == "interrupted":
        again = " (the polish starts again from its beginning)" if state.stage == "polish" else ""
        what = "" if kind.default_problem is None else f" {kind.name}"     # a file's design names its file
        print(f"interrupted; saved; continue with: python -m pes_ref design{what} --resume {out}{again}",
              file=sys.stderr)

        return EXIT_INTERRUPTED
    return EXIT_OK


def _summary(kind: str, metric_name: str, out: str, state, iterations: int, seconds: float) -> str:
    loss = state.history["loss"][-1] if state.history["loss"] else float("nan")
    metric = state.history["metric"][-1] if state.history["metric"] else float("nan")
    line = (f"wrote {out}: {kind}, iteration {state.iteration}/{state.plan.iterations} "
            f"({state.status.split(':')[0]}), loss {loss:.6g}, {metric_name} {metric:.3f}")
    if state.best is not None:          # a validating plan delivers its best validated grid, not the last
        line += f"; delivered: the grid of iteration {state.best.iteration}, validation {state.best.success:.3f}"
    if state.screened["starts"]:        # a population's screening: every start's iterations, the chosen one's too
        line += f"; screened: {state.screened['starts']} starts, {state.screened['iterations']} iterations"
    if state.stage == "polish":
        fit = state.polish_history["fitness"]
        line += (f", polish {state.evaluations} evaluations"
                 + (f", fitness {fit[0]:.4g} -> {fit[-1]:.4g}" if fit else ""))
    return line + f"; {iterations} iterations this run, {seconds:.1f} s"
