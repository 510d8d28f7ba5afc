"""Figure 11: the phase-space cycles the grid-started particles reach after 15 periods.

The 25 particles of Fig. 10 (:func:`pes_ref.synthesis.kinds.analysis.oscillator_grid_starts`, at rest on a
5 x 5 grid, maximum torque), run for 15 + 3 target periods; the last three periods in phase
space (:func:`pes_ref.synthesis.kinds.analysis.phase_space`). The title counts the particles that reach the
cycle by the library's test (:func:`pes_ref.synthesis.kinds.analysis.cycle_figures`).
"""
from __future__ import annotations

import numpy as np

from figures import _common as C
from pes_ref.synthesis import cycle_figures, oscillator_grid_starts, phase_space

NAME = "fig11_grid_cycles"
#: Target periods before the drawn window (the paper's 15), then periods drawn.
AFTER_PERIODS, SHOWN_PERIODS = 15, 3


def main(argv=None) -> int:
    args = C.parser(__doc__.splitlines()[0], design_kind="oscillator").parse_args(argv)
    state = C.design_state(args, "oscillator")
    p = state.problem
    after = 2 if args.smoke else AFTER_PERIODS
    grid = oscillator_grid_starts(p, state.values, periods=after + SHOWN_PERIODS)
    q0, dq0 = phase_space(p, grid.traj, after_periods=after)
    captured = cycle_figures(p, grid.traj)[3]
    fig, ax = C.plt.subplots(figsize=(7.5, 6), constrained_layout=True)
    colors = C.value_colors(ax, grid.x0[:, 0], "start q0 of the particle (length units)", cmap="viridis")
    C.draw_phase(ax, p, q0, dq0, colors)
    ax.set_title(f"Fig. 11  Phase space of the {q0.shape[1]} grid-started particles (max torque {p.torque_max:g}),\n"
                 f"periods {after} to {after + SHOWN_PERIODS}: {int(np.sum(captured))}/{captured.size} reach the "
                 f"cycle (design: {C.design_work(state)})")
    C.save(fig, args.out, NAME, args.smoke)
    return 0


if __name__ == "__main__":
    C.run(main)
