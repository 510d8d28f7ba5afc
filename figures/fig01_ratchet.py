"""Figure 1: a ratchet and pawl beside its toroidal configuration space (blocked / free / boundary).

(a) the wheel and pawl of :mod:`pes_ref.devices.ratchet` drawn at the engaged rest state;
(b) their C-space, the torus unrolled onto [0, 2 pi) x [-pi, pi), with the paths of the
wheel under a forward and a backward torque; (c) the same C-space on a torus.
"""
from __future__ import annotations

import numpy as np
from matplotlib.colors import to_rgb

from figures import _common as C
from pes_ref.devices import ratchet

NAME = "fig01_ratchet_cspace"
#: Torque on the wheel for the two example paths and how long they run (the CLI's defaults).
TORQUE, DURATION = 1.0, 10.0
#: Torus radii for panel (c), display only.
TORUS_R, TORUS_r = 2.0, 0.9


def _draw_parts(ax, device, state):
    C.draw_parts(ax, device, state, ("wheel (angle q0)", "pawl (angle q1)"))
    piv = device.parts[1].motion.pivot
    tip = device.parts[0].geometry(device.grid.tolerance).bounds[3]      # the wheel's radius
    ax.plot([0, piv[0]], [0, piv[1]], "k+", ms=8)
    ax.annotate("pivot + torsion\nspring", piv, xytext=(piv[0] - 0.3, piv[1] + 0.35), fontsize=7,
                arrowprops=dict(arrowstyle="->", lw=0.6))
    ax.annotate("", xy=(-0.55, 0.55), xytext=(-0.35, 0.72),
                arrowprops=dict(arrowstyle="->", lw=1.0, connectionstyle="arc3,rad=0.3"))
    ax.text(-0.9, 0.7, "+q0", fontsize=8)
    r = tip + 0.5
    ax.set_xlim(-r, r)
    ax.set_ylim(-tip - 0.1, piv[1] + 0.7)
    ax.set_aspect("equal")
    ax.set_xlabel("x (length units)")
    ax.set_ylabel("y (length units)")
    ax.set_title("(a) ratchet wheel and pawl, engaged rest state")
    ax.legend(loc="lower left", fontsize=7)


def _draw_torus(ax, surface, blocked, stride):
    q0 = np.append(surface.nodes(0)[::stride], surface.upper[0])
    q1 = np.append(surface.nodes(1)[::stride], surface.upper[1])
    a, b = np.meshgrid(q0, q1, indexing="ij")
    x = (TORUS_R + TORUS_r * np.cos(b)) * np.cos(a)
    y = (TORUS_R + TORUS_r * np.cos(b)) * np.sin(a)
    z = TORUS_r * np.sin(b)
    cell = blocked[::stride, ::stride]           # one colour per quad: the node at its lower corner
    colors = np.where(cell[..., None], np.array(to_rgb(C.CSPACE_COLORS["blocked"])),
                      np.array(to_rgb("#9ecae1")))
    ax.plot_surface(x, y, z, facecolors=colors, rstride=1, cstride=1, linewidth=0, antialiased=False, shade=False)
    ax.set_box_aspect((1, 1, 0.4), zoom=1.5)
    ax.view_init(elev=40, azim=-60)
    ax.set_axis_off()          # a picture of the topology: the coordinates are the two angles named below
    ax.set_title("(c) the same C-space on the torus: q0 the long way round,\n"
                 "q1 round the tube (q1 = 0 outer equator); dark = blocked", pad=0)


def main(argv=None) -> int:
    args = C.parser(__doc__.splitlines()[0]).parse_args(argv)
    device = ratchet.ratchet_device()
    duration, stride = DURATION, 2
    if args.smoke:
        device, duration, stride = device.replace(shape=(48, 48)), 1.0, 1
    cs = device.cspace()
    blocked, distance = cs.blocked, cs.distance
    surface = device.surface()
    start = ratchet.ratchet_start(device)
    traj = ratchet.run_ratchet(device, [TORQUE, -TORQUE], duration, start)

    fig = C.plt.figure(figsize=(14, 4.6))
    gs = fig.add_gridspec(1, 3, width_ratios=[1.0, 1.25, 1.25], wspace=0.22)
    _draw_parts(fig.add_subplot(gs[0]), device, start[0])

    ax = fig.add_subplot(gs[1])
    handles = C.cspace_image(ax, surface, blocked, distance)
    C.draw_paths(ax, surface, traj.x[:, :1], "#1f77b4", lw=1.2, label=f"+{TORQUE:g} torque: advances")
    C.draw_paths(ax, surface, traj.x[:, 1:], "#2ca02c", lw=2.5, label=f"-{TORQUE:g} torque: blocked", zorder=4)
    ax.plot(*start[0], "o", color="#ff7f0e", ms=4, zorder=5, label="engaged rest state")
    ax.plot(*surface.wrap(traj.x[-1, 1]), "x", color="#2ca02c", ms=7, mew=2, zorder=6, label="end, -torque")
    note = C.cspace_legend(ax, handles, blocked)
    ax.set_xlabel("wheel angle q0 (rad)")
    ax.set_ylabel("pawl angle q1 (rad)")
    ax.set_title(f"(b) C-space, torus unrolled ({note})")

    _draw_torus(fig.add_subplot(gs[2], projection="3d"), surface, blocked, stride)
    fig.suptitle("Fig. 1  Ratchet and pawl and its configuration space on a torus", y=1.02)
    C.save(fig, args.out, NAME, args.smoke)
    return 0


if __name__ == "__main__":
    C.run(main)
