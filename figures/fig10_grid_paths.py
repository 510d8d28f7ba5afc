"""Figure 10: particle paths from a 5 x 5 grid of starting positions at rest, maximum torque.

:func:`pes_ref.synthesis.kinds.analysis.oscillator_grid_starts` starts 25 particles at rest on a 5 x 5
grid of (q0, q1) and pushes each with the design's maximum torque; their paths over the
evaluation run (the problem's ``eval_periods`` target periods) are drawn on the surface.
"""
from __future__ import annotations

from figures import _common as C
from pes_ref.synthesis import oscillator_grid_starts
from pes_ref.core.surface import Surface

NAME = "fig10_grid_paths"


def main(argv=None) -> int:
    args = C.parser(__doc__.splitlines()[0], design_kind="oscillator").parse_args(argv)
    state = C.design_state(args, "oscillator")
    p = state.problem
    grid = oscillator_grid_starts(p, state.values, periods=p.eval_periods)
    surface = Surface(state.values, p.lower, p.upper, p.periodic)
    fig, ax = C.plt.subplots(figsize=(8.5, 6), constrained_layout=True)
    C.energy_image(ax, surface, "designed energy E (energy units)", cmap="Greys")
    colors = C.value_colors(ax, grid.x0[:, 0], "start q0 of the particle (length units)", cmap="viridis")
    C.draw_paths(ax, surface, grid.traj.x, colors, lw=0.6, alpha=0.8)
    ax.scatter(grid.x0[:, 0], grid.x0[:, 1], c=colors, edgecolors="k", s=30, zorder=5, label="starts (at rest)")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), fontsize=7)
    ax.set_xlabel("q0 (length units; spring rest at 0)")
    ax.set_ylabel("q1 (rad, periodic)")
    ax.set_title(f"Fig. 10  Paths of {grid.x0.shape[0]} particles from a grid of starts at rest,\n"
                 f"maximum torque {p.torque_max:g}, {p.eval_periods:g} target periods "
                 f"(design: {C.design_work(state)})")
    C.save(fig, args.out, NAME, args.smoke)
    return 0


if __name__ == "__main__":
    C.run(main)
