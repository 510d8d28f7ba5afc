"""Figure 13 (beyond the paper): a latch designed from flat, load, hold and fire.

The shipped problem file ``latch.toml`` (``docs/problems.md``, "The latch"): a push along +q0
loads each particle into the latched region against a spring, it must stay there with no
push, and a push along +q1 (the trigger) must release it out of the exit edge q0 = -1 at
speed. (a) the designed surface with held-out paths (:meth:`pes_ref.synthesis.DesignProblem.run`,
seed 12345) coloured by phase (:meth:`~pes_ref.synthesis.DesignProblem.phases`: the force
schedule's windows); (b) the same particles when nobody pulls the trigger (the ``no_fire``
scenario, twice as long): they stay latched; (c) each phase's held-out success, all three
together, and the two no-premature-release checks, on held-out seeds 12345 and 9191
(:func:`pes_ref.synthesis.evaluate`), beside the flat surface's.
"""
from __future__ import annotations

import numpy as np

from figures import _common as C
from pes_ref.core.surface import Surface
from pes_ref.synthesis import evaluate

NAME = "fig13_latch"
#: Held-out seeds and the paths drawn.
SEEDS, DRAWN = (12345, 9191), 40
#: Phase colours, in order of the schedule's phases.
COLORS = ("#1f77b4", "#2ca02c", "#d62728", "#9467bd", "#8c564b")


def draw_phases(ax, problem, surface, run, phases):
    """The paths of ``run`` cut at the phases' times, one colour per phase."""
    steps = [int(round(t / problem.dt)) for t, _, _ in phases] + [run.traj.x.shape[0] - 1]
    for i, (start, stop, label) in enumerate(phases):
        x = run.traj.x[steps[i]:steps[i + 1] + 1]
        C.draw_paths(ax, surface, x, COLORS[i % len(COLORS)], lw=0.6, alpha=0.8,
                     label=f"{start:g}-{stop:g}: {label or 'no push'}")


def boxes(ax, problem):
    """The held-out tests' boxes (the latched region), dashed."""
    from matplotlib.patches import Rectangle
    for name, test in problem.tests:
        box = getattr(test, "box", None)
        if box is not None:
            (a, b), (c, d) = box.lower, box.upper
            ax.add_patch(Rectangle((a, b), c - a, d - b, fill=False, ls="--", color="k", lw=1.0))
    return ax


def main(argv=None) -> int:
    args = C.parser(__doc__.splitlines()[0], design_kind="latch").parse_args(argv)
    state = C.design_state(args, "latch")
    p = state.problem
    n = 8 if args.smoke else DRAWN
    surface = Surface(state.values, p.lower, p.upper, p.periodic)
    held = p.run(state.values, SEEDS[0], n)
    no_fire = next(s for s in p.scenarios if s.name == "no_fire")
    quiet = p.run(state.values, SEEDS[0], n, no_fire)
    figures = {seed: evaluate(p, state.values, seed=seed, n_particles=20 if args.smoke else None) for seed in SEEDS}

    fig, (ax, axq, axb) = C.plt.subplots(1, 3, figsize=(17, 5.2), width_ratios=[1.15, 1.15, 1.0],
                                         constrained_layout=True)
    for a, run, phases, title in ((ax, held, p.phases(), "(a) held-out paths, phase by phase"),
                                  (axq, quiet, p.phases(no_fire.forces, no_fire.n_steps),
                                   "(b) the same particles, trigger never pulled")):
        C.energy_image(a, surface, "designed energy E (energy units)", cmap="Greys")
        draw_phases(a, p, surface, run, phases)
        boxes(a, p)
        a.set_xlim(p.lower[0] - 0.6, p.upper[0])
        a.set_xlabel("q0, the dart (length units)")
        a.set_ylabel("q1, the trigger (length units)")
        a.legend(loc="upper right", fontsize=7, title="time: push", title_fontsize=7)
        a.set_title(title)

    names = ["success_" + name for name, _ in p.tests] + ["success_fraction"] + [
        f"scenario_{s.name}_success_fraction" for s in p.scenarios]
    labels = [name for name, _ in p.tests] + ["all three"] + [s.name for s in p.scenarios]
    pos = np.arange(len(names))
    for k, seed in enumerate(SEEDS):
        got = [figures[seed][name] for name in names]
        bars = axb.bar(pos + (k - 0.5) * 0.38, got, 0.36, label=f"held-out seed {seed}")
        axb.bar_label(bars, fmt="%.2f", fontsize=6)
    axb.axhline(figures[SEEDS[0]]["flat_success_fraction"], color="0.5", ls=":",
                label="flat surface, all three")
    axb.set_xticks(pos, labels, rotation=20)
    axb.set_ylim(0, 1.1)
    axb.set_ylabel("share of held-out particles passing")
    axb.legend(loc="lower left", fontsize=7)
    axb.set_title(f"(c) success, {int(figures[SEEDS[0]]['particles'])} particles per seed")
    fig.suptitle(f"Fig. 13  A latch designed from flat: load, hold, fire ({C.design_work(state)}, "
                 f"{state.values.shape[0]}x{state.values.shape[1]} grid)")
    C.save(fig, args.out, NAME, args.smoke)
    return 0


if __name__ == "__main__":
    C.run(main)
