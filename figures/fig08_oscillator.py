"""Figure 8: the synthesized oscillator surface (a) and particle paths on it (b).

(a) the designed grid values of the oscillator design file (computed by ``python -m
pes_ref design oscillator``) on the cylinder, q1 periodic; the scene adds the linear
spring on q0. (b) 50 particles with torques evenly from the minimum to the maximum of the
design range (:func:`pes_ref.synthesis.kinds.analysis.oscillator_torque_sweep`), started at rest at
q1 = 0 and q0 = the target amplitude, as the paper's text says.
"""
from __future__ import annotations

import dataclasses

from figures import _common as C
from pes_ref.synthesis import oscillator_torque_sweep
from pes_ref.core.surface import Surface

NAME = "fig08_oscillator"
#: Particles of the torque sweep (the paper's 50).
PARTICLES = 50
#: Target periods simulated: the paper's three of transient, then three more (Fig. 9 draws those).
PERIODS = 6


def torque_sweep(doc: str, argv):
    """Options, design and the sweep of Figs. 8-9: every particle started at rest at the target
    amplitude as the paper's text says (the training sampler's kick and start noise set to 0)."""
    args = C.parser(doc.splitlines()[0], design_kind="oscillator").parse_args(argv)
    state = C.design_state(args, "oscillator")
    p = dataclasses.replace(state.problem, kick=0.0, start_noise=0.0)
    n = 8 if args.smoke else PARTICLES
    return args, state, p, oscillator_torque_sweep(p, state.values, n_particles=n, periods=PERIODS)


def main(argv=None) -> int:
    args, state, p, sweep = torque_sweep(__doc__, argv)
    n = sweep.torques.size
    surface = Surface(state.values, p.lower, p.upper, p.periodic)

    fig, (ax0, ax1) = C.plt.subplots(1, 2, figsize=(13, 5.2), constrained_layout=True)
    C.energy_image(ax0, surface, "designed energy E (energy units)", cmap="viridis")
    ax0.set_title(f"(a) synthesized surface, {surface.shape[0]}x{surface.shape[1]} grid on a cylinder "
                  f"(q1 periodic), {C.design_work(state)}")
    C.energy_image(ax1, surface, "designed energy E (energy units)", cmap="Greys")
    colors = C.value_colors(ax1, sweep.torques, "torque tau on q1 (torque units)")
    C.draw_paths(ax1, surface, sweep.traj.x, colors, lw=0.6, alpha=0.7)
    ax1.plot(sweep.x0[:, 0], sweep.x0[:, 1], "o", color="#2ca02c", ms=5, zorder=5, label="start (all particles)")
    ax1.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), fontsize=7)
    ax1.set_title(f"(b) paths of {n} particles, torques {p.torque_min:g}..{p.torque_max:g}, "
                  f"{PERIODS} target periods")
    for ax in (ax0, ax1):
        ax.set_xlabel("q0 (length units; spring rest at 0)")
        ax.set_ylabel("q1 (rad, periodic)")
    fig.suptitle("Fig. 8  Synthesized oscillator potential energy surface (a) and particle paths on it (b)")
    C.save(fig, args.out, NAME, args.smoke)
    return 0


if __name__ == "__main__":
    C.run(main)
