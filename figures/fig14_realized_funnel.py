"""Figure 14 (beyond the paper): the funnel realized by contact, checked by re-simulation.

The funnel designed realizable (``design funnel --set realizable=true ...``: the grid values
are a level set, the surface eq. (1) of its shape, ``docs/realize.md``) is realized as a pin
in a plate (:func:`pes_ref.realize.contact.realize_contact`); the device file is written to
``OUT/fig14_device.toml`` and the device rebuilt from it (:func:`pes_ref.load_device`).
(a) the design's surface, its blocked region and held-out paths on it; (b) the plate and the
same held-out particles simulated on the realized device (:func:`pes_ref.realize.evaluation.realized_problem`:
the design's forces at the step the stability rule allows), with both in-band fractions.
"""
from __future__ import annotations

import os

import numpy as np

from figures import _common as C
from pes_ref.core.surface import Surface
from pes_ref.devices.plots import draw_geometry
from pes_ref.synthesis import IN_BAND_SHARE, exit_positions, funnel_paths

NAME = "fig14_realized_funnel"
#: Held-out seed and count: the defaults of ``python -m pes_ref evaluate``.
HELD_OUT_SEED, HELD_OUT = 12345, 200
#: The smoke design: the realizable funnel of ``make figures`` on the design command's tiny preset.
SMOKE_SETS = ["--set", "realizable=true", "--set", "linger=20", "--set", "init_shape=vee"]


def main(argv=None) -> int:
    from pes_ref.devices.device_file import load_device
    from pes_ref.realize import exports
    from pes_ref.realize.contact import realize_contact
    from pes_ref.realize.evaluation import realized_problem

    args = C.parser(__doc__.splitlines()[0], design_kind="funnel").parse_args(argv)
    state = C.design_state(args, "funnel", smoke_sets=SMOKE_SETS)
    p = state.problem
    n_held = 20 if args.smoke else HELD_OUT
    real = realize_contact(p, state.values, name="fig14")
    os.makedirs(args.out, exist_ok=True)
    path = os.path.join(args.out, "fig14_device.toml")
    exports.write_text(path, exports.device_text(real.device, "Fig. 14's realized funnel"), True, "device")
    run = realized_problem(p, load_device(path))
    held = funnel_paths(p, state.values, n_particles=n_held, seed=HELD_OUT_SEED)
    held_r = funnel_paths(run.problem, run.values, n_particles=n_held, seed=HELD_OUT_SEED)
    share = float(np.mean(p.in_band(exit_positions(p, held.traj))))
    share_r = float(np.mean(run.problem.in_band(exit_positions(run.problem, held_r.traj))))

    fig, (ax, axr) = C.plt.subplots(1, 2, figsize=(12.5, 5.4), constrained_layout=True)
    surface = Surface(p.surface_values(state.values), p.lower, p.upper, p.periodic)
    C.energy_image(ax, surface, "designed energy E (energy units)", cmap="Greys")
    region = real.region
    q0 = np.linspace(p.lower[0], p.upper[0], region.phi.shape[0])
    q1 = np.linspace(p.lower[1], p.upper[1], region.phi.shape[1])
    ax.contour(q0, q1, region.phi.T, levels=[0.0], colors="#ff7f0e", linewidths=1.0)
    C.draw_paths(ax, surface, held.traj.x, "#d62728", lw=0.5, alpha=0.5)
    band = IN_BAND_SHARE * p.width
    for a in (ax, axr):
        a.axvspan(p.target - band, p.target + band, ymax=0.04, color="#ff7f0e", alpha=0.8)
        a.set_xlabel("x = q0 (length units)")
        a.set_ylabel("y = q1 (length units)")
    ax.set_title(f"(a) the design, its blocked region ({region.rule}): {100 * share:.1f}% in band")
    draw_geometry(axr, real.parts.plate, facecolor="#fdae6b", alpha=0.9)
    realized_surface = Surface(run.values, p.lower, p.upper, p.periodic)
    C.draw_paths(axr, realized_surface, held_r.traj.x, "#1f77b4", lw=0.5, alpha=0.5)
    lo, hi = real.parts.plate.bounds[:2], real.parts.plate.bounds[2:]
    axr.set_xlim(lo[0], hi[0])
    axr.set_ylim(lo[1], hi[1])
    axr.set_aspect("equal")
    axr.set_title(f"(b) the plate (pin r = {real.parts.pin_radius:g}), dt = {run.dt:.3g}: "
                  f"{100 * share_r:.1f}% in band")
    fig.suptitle(f"Fig. 14  The funnel realized by contact: {n_held} held-out particles (seed {HELD_OUT_SEED}), "
                 f"in band {share:.3f} on the design, {share_r:.3f} on the parts")
    C.save(fig, args.out, NAME, args.smoke)
    return 0


if __name__ == "__main__":
    C.run(main)
