"""Figure 2: the spring-loaded dart gun and its trigger, drawn from the geometry the analysis uses.

The dart and the trigger tooth are the parts of the shipped device file (:func:`pes_ref.devices.dartgun.dartgun_device`),
posed at three states the library computes: the unloaded rest state, the latched state
after a reload, and a moment of the fire run after the trigger is pulled. The springs
are drawn as zigzags between the parts and the gun's frame (drawing only).
"""
from __future__ import annotations

import numpy as np

from figures import _common as C
from figures import _dartgun as G
from pes_ref.devices import dartgun

NAME = "fig02_dartgun"
#: The trigger pull drawn (force units), one that fires (Fig. 4).
TRIGGER_FORCE = 20.0
#: Clearance between the parts' travel and the frame, display only (length units).
FRAME_GAP = 0.4


def zigzag(p0, p1, n: int = 8, width: float = 0.18):
    """Points of a zigzag spring from p0 to p1 (display only)."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    t = np.linspace(0, 1, 2 * n + 3)
    axis = p1 - p0
    normal = np.array([-axis[1], axis[0]]) / max(np.hypot(*axis), 1e-12)
    wig = np.zeros_like(t)
    wig[2:-2:2], wig[3:-2:2] = width / 2, -width / 2
    return p0 + t[:, None] * axis + wig[:, None] * normal


def draw_state(ax, device, q, title, arrow=None):
    """The dart and trigger at ``q`` with their springs and the frame; ``arrow`` = (xy, dxy, text)."""
    d = G.dims(device)
    C.draw_parts(ax, device, q, ("dart (slides along x by q0)", "trigger (slides along y by q1)"))
    rear = d.dart_length + d.upper[0] + FRAME_GAP           # the frame's rear wall, behind the dart's travel
    base = -d.tooth_length + d.lower[1] - FRAME_GAP          # the frame under the trigger's travel
    spring_end = d.dart_length + max(q[0], 0.0)              # the spring acts only while compressed (q0 > 0)
    ax.plot(*zigzag((spring_end, d.dart_height / 2), (rear, d.dart_height / 2)).T, color="#555", lw=1.0,
            label="springs")
    tooth_bottom = -d.tooth_length + q[1]
    xt = d.tooth_x + d.tooth_width / 2
    ax.plot(*zigzag((xt, base), (xt, tooth_bottom), n=5).T, color="#555", lw=1.0)
    ax.plot([rear, rear], [-0.3, d.dart_height + 0.3], color="k", lw=3)
    ax.plot([xt - 0.6, xt + 0.6], [base, base], color="k", lw=3, label="frame")
    if arrow is not None:
        xy, dxy, text = arrow
        ax.annotate(text, xy=np.add(xy, dxy), xytext=xy, fontsize=8, color="#d62728",
                    arrowprops=dict(arrowstyle="-|>", color="#d62728", lw=1.5))
    ax.set_xlim(d.lower[0] - 2.5, rear + 0.5)
    ax.set_ylim(base - 0.2, d.dart_height + 0.5)
    ax.set_aspect("equal")
    ax.set_xlabel("x (length units)")
    ax.set_ylabel("y (length units)")
    q = np.round(q, 2) + 0.0                                   # no "-0.00"
    ax.set_title(title + f"   (q0 = {q[0]:.2f}, q1 = {q[1]:.2f})")


def main(argv=None) -> int:
    args = C.parser(__doc__.splitlines()[0]).parse_args(argv)
    gun = G.build(args.smoke)
    runs = G.reload_and_fire(gun, [TRIGGER_FORCE])
    x = runs.fire.trajectory.x[:, 0]
    k = int(np.argmin(x[:, 1]))          # the fire state drawn: the trigger at its lowest
    device, d, rest, latched = gun.device, G.dims(gun.device), gun.rest, runs.latched
    fig, axes = C.plt.subplots(3, 1, figsize=(8, 9.5), constrained_layout=True)
    draw_state(axes[0], device, rest[0], "(a) unloaded, at rest",
               ((d.lower[0] - 2.3, d.dart_height + 0.2), (2.2, -0.5), "reload: push +q0"))
    draw_state(axes[1], device, latched[0], f"(b) latched after a reload push of {G.RELOAD_FORCE:g} for {G.RELOAD_TIME:g} s",
               ((d.tooth_x - 2.2, -0.5), (2.1, -0.7), "fire: pull -q1"))
    draw_state(axes[2], device, x[k], f"(c) firing: trigger pulled with {TRIGGER_FORCE:g} for {G.FIRE_TIME:g} s "
               f"(lowest point), exit speed {runs.fire.exit_speed[0]:.2f} length/s",
               ((x[k, 0] - 0.3, d.dart_height + 0.2), (-2.0, 0.0), "dart out: -q0"))
    axes[0].legend(loc="lower left", fontsize=7, ncol=2)
    fig.suptitle("Fig. 2  Spring-loaded dart gun and trigger (the polygons of the analysis)")
    C.save(fig, args.out, NAME, args.smoke)
    return 0


if __name__ == "__main__":
    C.run(main)
