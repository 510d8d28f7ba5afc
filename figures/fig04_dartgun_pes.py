"""Figure 4: the reload and the fire trajectories on the dart gun's potential energy surface.

The surface is the shipped dart gun's (:func:`pes_ref.devices.dartgun.dartgun_device`: eq. (1)
of the C-space plus the dart and trigger springs). Reload: a push +q0 from the unloaded rest state, after which
the particle settles at the latch. Fire: pushes -q1 on the trigger from the latched
state, one too weak (the particle falls back to the latch) and one that releases the dart,
which leaves the surface at q0 = lower edge with the exit speed the library measures.
"""
from __future__ import annotations

import numpy as np
from matplotlib.colors import LogNorm

from figures import _common as C
from figures import _dartgun as G

NAME = "fig04_dartgun_pes"
#: The trigger pulls drawn (force units): one too weak to fire, one that fires.
TRIGGER_FORCES = (10.0, 20.0)


def main(argv=None) -> int:
    args = C.parser(__doc__.splitlines()[0]).parse_args(argv)
    gun = G.build(args.smoke)
    surface, rest = gun.surface, gun.rest
    reload, latched, fire = G.reload_and_fire(gun, TRIGGER_FORCES)

    fig, ax = C.plt.subplots(figsize=(9, 5.6), constrained_layout=True)
    vals = surface.values
    # a log colour scale: the springs' energy (tens) and eq. (1)'s walls (thousands) on one bar
    C.energy_image(ax, surface, "potential energy E (energy units, log scale)",
                   norm=LogNorm(vmin=max(vals.min(), vals.max() * 1e-4), vmax=vals.max()), cmap="magma")
    ax.contour(surface.nodes(0), surface.nodes(1), gun.distance.T, levels=[0.0], colors="w", linewidths=0.8,
               linestyles="--")
    xr = reload.trajectory.x[:, 0]
    ax.plot(xr[:, 0], xr[:, 1], color="#00bfff", lw=1.6, label=f"reload: push +q0 = {G.RELOAD_FORCE:g} "
            f"for {G.RELOAD_TIME:g} s ({'latched' if reload.latched[0] else 'not latched'})")
    styles = ("#7CFC00", "#ff4500")
    for i, f in enumerate(TRIGGER_FORCES):
        x = fire.trajectory.x[:, i]
        if fire.fired[i]:                    # draw up to the first state past the surface's edge
            x = x[:int(np.argmax(x[:, 0] < surface.lower[0])) + 1]
            what = f"fired, exit speed {fire.exit_speed[i]:.2f} length/s"
        else:
            what = "not fired: back to the latch"
        ax.plot(x[:, 0], x[:, 1], color=styles[i % 2], lw=1.6 if fire.fired[i] else 3.0,
                zorder=3 if fire.fired[i] else 4, label=f"fire: pull -q1 = {f:g} for {G.FIRE_TIME:g} s, {what}")
    ax.plot(*rest[0], "o", color="w", mec="k", ms=7, zorder=5, label="unloaded rest state")
    ax.plot(*latched[0], "s", color="w", mec="k", ms=7, zorder=5, label="latched equilibrium")
    ax.legend(loc="lower right", fontsize=7, framealpha=0.9)
    ax.set_xlabel("dart displacement q0 (length units)")
    ax.set_ylabel("trigger displacement q1 (length units)")
    ax.set_title("Fig. 4  Reload and fire trajectories on the dart gun's potential energy surface\n"
                 "(white dashes: the C-space boundary)")
    C.save(fig, args.out, NAME, args.smoke)
    return 0


if __name__ == "__main__":
    C.run(main)
