"""Figure 5: the design gradient dL/dE of one funnel iteration, with the particle paths behind it.

The paper's Fig. 5 is lost from our copy; its text says the gradient is zero wherever no
particle passes. :func:`pes_ref.synthesis.engine.training.design_gradient` returns one iteration's masked
gradient of the funnel objective (eq. (5)) with respect to every grid value, and the
paths of that iteration's particles. (a) the first iteration, on the flat starting surface
at the design's final resolution; (b) the iteration after the last one, on the designed
surface. Grey: nodes whose gradient is exactly zero. The caption counts the nonzero nodes
outside the cells the paths visit (:meth:`pes_ref.Surface.locate`), which must be none.
"""
from __future__ import annotations

import numpy as np
from matplotlib.colors import ListedColormap, SymLogNorm

from figures import _common as C
from pes_ref.synthesis import design_gradient
from pes_ref.core.surface import Surface

NAME = "fig05_funnel_gradient"
#: The colour scale is linear below this percentile of the nonzero |dL/dE| and logarithmic
#: above it, so gradients spanning many decades all show (a few huge values would otherwise
#: wash every other node out to white).
LINEAR_PERCENTILE = 10.0


def visited_nodes(surface: Surface, x) -> np.ndarray:
    """Nodes at the corners of every cell a path state lies in (those a bilinear lookup reads)."""
    cells = surface.locate(np.asarray(x).reshape(-1, 2))
    inside = (cells.s0 * cells.s1) > 0
    out = np.zeros(surface.shape, dtype=bool)
    for i in (cells.i0[inside], cells.i1[inside]):
        for j in (cells.j0[inside], cells.j1[inside]):
            out[i, j] = True
    return out


def panel(ax, problem, values, step, title):
    surface = Surface(values, problem.lower, problem.upper, problem.periodic)
    g = step.grad
    mag = np.abs(g[g != 0]) if np.any(g) else np.ones(1)
    big, small = float(mag.max()), float(np.percentile(mag, LINEAR_PERCENTILE))
    im = C.energy_image(ax, surface, "dL/dE (loss units per energy unit, symlog)", values=g, cmap="RdBu_r",
                        norm=SymLogNorm(linthresh=small, vmin=-big, vmax=big, base=10))
    lo, hi = int(np.ceil(np.log10(small))), int(np.floor(np.log10(big)))
    dec = 10.0 ** np.arange(lo, hi + 1, max(1, (hi - lo) // 3 + 1))      # at most 4 decades per side
    im.colorbar.set_ticks(np.concatenate([-dec[::-1], [0.0], dec]))
    zero = np.where(g == 0.0, 1.0, np.nan)
    C.energy_image(ax, surface, "", values=zero, cbar=False, cmap=ListedColormap(["#c8c8c8"]), vmin=0, vmax=1)
    C.draw_paths(ax, surface, step.traj.x, "#e6c619", lw=0.5, alpha=0.8, label="particle paths of this iteration")
    ax.plot(step.x0[:, 0], step.x0[:, 1], ".", color="#e6c619", ms=3)
    visited = visited_nodes(surface, step.traj.x)
    stray = int(np.count_nonzero((g != 0) & ~visited))
    ax.set_xlabel("x = q0 (length units)")
    ax.set_ylabel("y = q1 (length units)")
    ax.set_title(f"{title}\nloss {step.loss:.3g}; nonzero dL/dE at {100 * np.mean(g != 0):.1f}% of "
                 f"{g.size} nodes; nonzero outside visited cells: {stray}")
    ax.legend(loc="lower right", fontsize=7, framealpha=0.9)
    return im


def main(argv=None) -> int:
    args = C.parser(__doc__.splitlines()[0], design_kind="funnel").parse_args(argv)
    state = C.design_state(args, "funnel")
    problem, n = state.problem, state.plan.n_particles
    flat = problem.flat_values()
    first = design_gradient(problem, flat, seed=state.seed, iteration=0, n_particles=n)
    last = design_gradient(problem, state.values, seed=state.seed, iteration=state.iteration, n_particles=n)
    fig, axes = C.plt.subplots(1, 2, figsize=(13, 5.6), constrained_layout=True)
    panel(axes[0], problem, flat, first, f"(a) iteration 0, flat starting surface, {n} particles")
    panel(axes[1], problem, state.values, last, f"(b) iteration {state.iteration}, designed surface, {n} particles")
    fig.suptitle("Fig. 5  Design gradient dL/dE of one funnel iteration over the surface "
                 "(grey: exactly zero, where no particle passes)")
    C.save(fig, args.out, NAME, args.smoke)
    return 0


if __name__ == "__main__":
    C.run(main)
