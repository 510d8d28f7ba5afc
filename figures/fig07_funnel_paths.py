"""Figure 7: particle paths on the synthesized funnel surface, held-out particles included.

(a) paths on the designed surface: one training batch (the particles of the run's next
iteration, :func:`pes_ref.synthesis.engine.training.design_gradient`) and held-out particles drawn with a
seed training never uses (:func:`pes_ref.synthesis.kinds.analysis.funnel_paths`); (b) where the held-out
particles leave the bottom edge (:func:`pes_ref.synthesis.kinds.funnel.exit_positions`), on the design
and on the flat starting surface.
"""
from __future__ import annotations

import numpy as np

from figures import _common as C
from pes_ref.synthesis import IN_BAND_SHARE, design_gradient, exit_positions, funnel_paths
from pes_ref.core.surface import Surface

NAME = "fig07_funnel_paths"
#: Held-out seed and count: the defaults of ``python -m pes_ref evaluate``.
HELD_OUT_SEED, HELD_OUT = 12345, 200


def main(argv=None) -> int:
    args = C.parser(__doc__.splitlines()[0], design_kind="funnel").parse_args(argv)
    state = C.design_state(args, "funnel")
    p = state.problem
    n_held = 20 if args.smoke else HELD_OUT
    surface = Surface(state.values, p.lower, p.upper, p.periodic)
    train = design_gradient(p, state.values, seed=state.seed, iteration=state.iteration,
                            n_particles=state.plan.n_particles)
    held = funnel_paths(p, state.values, n_particles=n_held, seed=HELD_OUT_SEED)
    flat = funnel_paths(p, p.flat_values(state.values.shape), n_particles=n_held, seed=HELD_OUT_SEED)
    exits = exit_positions(p, held.traj)
    exits_flat = exit_positions(p, flat.traj)

    fig, (ax, axh) = C.plt.subplots(1, 2, figsize=(12.5, 5.2), width_ratios=[1.25, 1.0], constrained_layout=True)
    C.energy_image(ax, surface, "designed energy E (energy units)", cmap="Greys")
    C.draw_paths(ax, surface, held.traj.x, "#d62728", lw=0.5, alpha=0.5,
                 label=f"held-out particles ({n_held}, seed {HELD_OUT_SEED})")
    C.draw_paths(ax, surface, train.traj.x, "#1f77b4", lw=0.6, alpha=0.7,
                 label=f"a training batch ({train.x0.shape[0]}, iteration {state.iteration})")
    band = IN_BAND_SHARE * p.width
    ax.axvspan(p.target - band, p.target + band, ymax=0.04, color="#ff7f0e", alpha=0.8, label="target exit band")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=3, fontsize=7)
    ax.set_xlabel("x = q0 (length units)")
    ax.set_ylabel("y = q1 (length units)")
    ax.set_title("(a) particle paths on the synthesized funnel (start at the top, pushed down, with noise)")

    bins = np.linspace(p.lower[0], p.upper[0], 41)
    for e, color, label in ((exits_flat, "0.6", "flat starting surface"), (exits, "#d62728", "synthesized funnel")):
        done = e[np.isfinite(e)]
        share = np.mean(p.in_band(e))
        axh.hist(done, bins=bins, color=color, alpha=0.7,
                 label=f"{label}: {done.size}/{e.size} exit, {100 * share:.1f}% in band")
    axh.axvspan(p.target - band, p.target + band, color="#ff7f0e", alpha=0.15, label="target exit band")
    axh.set_xlabel("exit position x at the bottom edge (length units)")
    axh.set_ylabel("held-out particles per bin (count)")
    axh.legend(loc="upper left", fontsize=7)
    axh.set_title("(b) where the held-out particles exit")
    fig.suptitle("Fig. 7  Particle paths on the optimal (synthesized) funnel surface")
    C.save(fig, args.out, NAME, args.smoke)
    return 0


if __name__ == "__main__":
    C.run(main)
