"""Figure 9: phase-space trajectories, same start, varying torque, after three periods.

The particles of Fig. 8 (all started at rest at q1 = 0, q0 = the target amplitude, each
with its own torque from the minimum to the maximum of the design range), run by
:func:`pes_ref.synthesis.kinds.analysis.oscillator_torque_sweep`; :func:`pes_ref.synthesis.kinds.analysis.phase_space`
keeps the states after the first three target periods. A closed loop near the target
orbit of eq. (6) is a stable oscillation.
"""
from __future__ import annotations

from figures import _common as C
from figures.fig08_oscillator import PERIODS, torque_sweep
from pes_ref.synthesis import phase_space

NAME = "fig09_phase_torques"
#: Target periods discarded as the transient (the paper's three); the rest of Fig. 8's run is drawn.
AFTER_PERIODS = 3


def main(argv=None) -> int:
    args, state, p, sweep = torque_sweep(__doc__, argv)
    n = sweep.torques.size
    q0, dq0 = phase_space(p, sweep.traj, after_periods=AFTER_PERIODS)
    fig, ax = C.plt.subplots(figsize=(7.5, 6), constrained_layout=True)
    colors = C.value_colors(ax, sweep.torques, "torque tau on q1 (torque units)")
    C.draw_phase(ax, p, q0, dq0, colors)
    ax.set_title(f"Fig. 9  Phase space of {n} particles, same start (q0 = {p.amplitude:g}, at rest), varying torque,\n"
                 f"periods {AFTER_PERIODS} to {PERIODS} of the target period "
                 f"{p.period:.3g} (design: {C.design_work(state)})")
    C.save(fig, args.out, NAME, args.smoke)
    return 0


if __name__ == "__main__":
    C.run(main)
