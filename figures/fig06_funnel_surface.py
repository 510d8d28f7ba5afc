"""Figure 6: the synthesized funnel potential energy surface.

(a) the designed grid values of the funnel design file (computed by ``python -m pes_ref
design funnel``), with the start strip (and the exit strip, if the design has one) that the
design holds at zero energy; (b) the run's loss (eq. (5), charged where each particle exits by
default) and in-band share per iteration, from the file's history.
"""
from __future__ import annotations

import numpy as np

from figures import _common as C
from pes_ref.synthesis import IN_BAND_SHARE
from pes_ref.core.surface import Surface

NAME = "fig06_funnel_surface"


def main(argv=None) -> int:
    args = C.parser(__doc__.splitlines()[0], design_kind="funnel").parse_args(argv)
    state = C.design_state(args, "funnel")
    p = state.problem
    surface = Surface(state.values, p.lower, p.upper, p.periodic)
    fig, (ax, axh) = C.plt.subplots(1, 2, figsize=(12, 5), width_ratios=[1.2, 1.0], constrained_layout=True)
    C.energy_image(ax, surface, "designed energy E (energy units)", cmap="viridis")
    strips = ((p.start_zone, p.height - p.start_zone, "start strip above (held at E = 0)"),
              (p.exit_zone, p.exit_zone, "exit strip below (held at E = 0)"))
    for y, text in ((y, text) for depth, y, text in strips if depth > 0):
        ax.axhline(y, color="w", ls="--", lw=0.8)
        ax.text(p.lower[0] + 0.03, y + 0.02, text, color="w", fontsize=7)
    ax.axvline(p.target, color="#ff7f0e", ls=":", lw=1.2, label=f"target exit x0 = {p.target:g}")
    ax.legend(loc="lower right", fontsize=7)
    ax.set_xlabel("x = q0 (length units)")
    ax.set_ylabel("y = q1 (length units)")
    ax.set_title(f"(a) funnel surface, {surface.shape[0]}x{surface.shape[1]} grid after {state.iteration} "
                 f"iterations (seed {state.seed})")

    it = np.arange(1, state.iteration + 1)
    axh.plot(it, state.history["loss"], color="#1f77b4", lw=0.8)
    axh.set_yscale("log")
    axh.set_xlabel("iteration")
    axh.set_ylabel(f"batch loss, eq. (5) at {p.when.replace('_', ' ')} (length units^2)", color="#1f77b4")
    ax2 = axh.twinx()
    ax2.plot(it, state.history["metric"], color="#ff7f0e", lw=0.8)
    ax2.set_ylim(0, 1)
    ax2.set_ylabel(f"batch share exiting within {100 * IN_BAND_SHARE:g}% of the width of x0",
                   color="#ff7f0e")
    for stage in state.plan.stages[1:]:          # coarse-to-fine stages: (start iteration, grid, ...)
        n0, n1 = state.plan.grid_at(stage[0], p)
        axh.axvline(stage[0], color="0.5", ls=":", lw=0.8)
        axh.text(stage[0], axh.get_ylim()[1], f" grid {n0}x{n1} from here", fontsize=7, va="top", color="0.3")
    axh.set_title(f"(b) training history ({state.plan.optimizer}, {state.plan.n_particles} particles/iteration)")
    fig.suptitle("Fig. 6  Synthesized funnel potential energy surface")
    C.save(fig, args.out, NAME, args.smoke)
    return 0


if __name__ == "__main__":
    C.run(main)
