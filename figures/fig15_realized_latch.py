"""Figure 15 (beyond the paper): the latch realized by contact, a tooth and a cam in a plate.

The shipped problem file ``latch_contact.toml`` (``docs/realize.md``, "The latch"): the latch of
``latch.toml`` designed as a level set from a hand-drawn tooth and cam, realized as a pin in a
plate (:func:`pes_ref.realize.contact.realize_contact`); the device file is written to
``OUT/fig15_device.toml`` and the device rebuilt from it (:func:`pes_ref.load_device`).
(a) the design's surface, its blocked region and held-out paths phase by phase; (b) the plate,
the same held-out particles simulated on the realized device
(:func:`pes_ref.realize.evaluation.realized_problem`: its springs linear, the design's forces)
and the pin at three moments of one path (loading up the ramp, latched, fired into the cam);
(c) each phase's success and the no-release checks on the design and on the parts, on held-out
seeds 12345 and 9191 (:func:`pes_ref.realize.evaluation.evaluate_realized`).
"""
from __future__ import annotations

import os

import numpy as np

from figures import _common as C
from figures.fig13_latch import boxes, draw_phases
from pes_ref.core.surface import Surface
from pes_ref.devices.plots import draw_geometry

NAME = "fig15_realized_latch"
#: Held-out seeds and the paths drawn.
SEEDS, DRAWN = (12345, 9191), 40
#: The moments the pin is drawn at (time units): riding the ramp, latched, fired into the cam.
MOMENTS = (0.9, 3.0, 4.5)


def main(argv=None) -> int:
    from pes_ref.devices.device_file import load_device
    from pes_ref.realize import exports
    from pes_ref.realize.contact import realize_contact
    from pes_ref.realize.evaluation import evaluate_realized, realized_problem

    args = C.parser(__doc__.splitlines()[0], design_kind="latch_contact").parse_args(argv)
    state = C.design_state(args, "latch_contact")
    p = state.problem
    n = 8 if args.smoke else DRAWN
    real = realize_contact(p, state.values, name="fig15")
    os.makedirs(args.out, exist_ok=True)
    path = os.path.join(args.out, "fig15_device.toml")
    exports.write_text(path, exports.device_text(real.device, "Fig. 15's realized latch"), True, "device")
    device = load_device(path)
    run = realized_problem(p, device)
    held = p.run(state.values, SEEDS[0], n)
    held_r = run.problem.run(run.values, SEEDS[0], n)
    figures = {seed: evaluate_realized(p, state.values, device, seed=seed, n_particles=20 if args.smoke else None)
               for seed in SEEDS}

    fig, (ax, axr, axb) = C.plt.subplots(1, 3, figsize=(17.5, 5.4), width_ratios=[1.1, 1.1, 1.0],
                                         constrained_layout=True)
    surface = Surface(p.surface_values(state.values), p.lower, p.upper, p.periodic)
    C.energy_image(ax, surface, "designed energy E (energy units)", cmap="Greys")
    region = real.region
    q0, q1 = (p.nodes(region.phi.shape, d) for d in (0, 1))
    ax.contour(q0, q1, region.phi.T, levels=[0.0], colors="#ff7f0e", linewidths=1.0)
    draw_phases(ax, p, surface, held, p.phases())
    ax.set_title(f"(a) the design ({C.design_work(state)}), its blocked region ({region.rule})")

    draw_geometry(axr, real.parts.plate, facecolor="#fdae6b", alpha=0.9)
    realized_surface = Surface(run.values, p.lower, p.upper, p.periodic)
    draw_phases(axr, run.problem, realized_surface, held_r, run.problem.phases())
    from matplotlib.patches import Circle
    for t in MOMENTS:
        c = held_r.traj.x[int(round(t / run.dt)), 0]
        axr.add_patch(Circle(c, real.parts.pin_radius, color="k", zorder=5))
        axr.annotate(f"t = {t:g}", c, xytext=(6, 6), textcoords="offset points", fontsize=7)
    axr.set_title(f"(b) the plate and pin (r = {real.parts.pin_radius:g}), dt = {run.dt:.3g}")
    for a in (ax, axr):
        boxes(a, p)
        a.set_xlim(p.lower[0] - 0.3, p.upper[0] + 0.1)
        a.set_ylim(p.lower[1] - 0.1, p.upper[1] + 0.1)
        a.set_aspect("equal")
        a.set_xlabel("q0, the dart (length units)")
        a.set_ylabel("q1, the trigger (length units)")
        a.legend(loc="upper left", fontsize=6, title="time: push", title_fontsize=6)

    names = ["success_" + name for name, _ in p.tests] + ["success_fraction"] + [
        f"scenario_{s.name}_success_fraction" for s in p.scenarios]
    labels = [name for name, _ in p.tests] + ["all three"] + [s.name for s in p.scenarios]
    pos = np.arange(len(names))
    width = 0.2
    for k, seed in enumerate(SEEDS):
        for j, (which, hatch) in enumerate((("design", ""), ("parts", "//"))):
            got = [figures[seed][name][j] for name in names]
            bars = axb.bar(pos + (2 * k + j - 1.5) * width, got, width * 0.95, hatch=hatch,
                           color=f"C{k}", label=f"{which}, seed {seed}")
            axb.bar_label(bars, fmt="%.2f", fontsize=5, rotation=90)
    axb.set_xticks(pos, labels, rotation=20)
    axb.set_ylim(0, 1.15)
    axb.set_ylabel("share of held-out particles passing")
    axb.legend(loc="lower left", fontsize=7)
    axb.set_title(f"(c) success on the design and on the parts, {int(figures[SEEDS[0]]['particles'][0])} "
                  f"particles per seed")
    every = figures[SEEDS[0]]["success_fraction"]
    fig.suptitle(f"Fig. 15  The latch realized by contact: load, hold and fire {every[0]:.3f} on the design, "
                 f"{every[1]:.3f} on the parts (seed {SEEDS[0]})")
    C.save(fig, args.out, NAME, args.smoke)
    return 0


if __name__ == "__main__":
    C.run(main)
