"""Figure 3: the dart gun mechanism's C-space, a plane (translation q0 of the dart, q1 of the trigger).

(a) the simplified mechanism at q = (0, 0) with its two motions; (b) the blocked, free
and boundary regions that :meth:`pes_ref.devices.cspace.CSpaceGrid.compute` (``.blocked``, ``.distance``)
compute on the analysis grid, with the unloaded rest state and the latched state marked.
"""
from __future__ import annotations

import numpy as np

from figures import _common as C
from figures import _dartgun as G
from pes_ref.devices import dartgun

NAME = "fig03_dartgun_cspace"


def main(argv=None) -> int:
    args = C.parser(__doc__.splitlines()[0]).parse_args(argv)
    gun = G.build(args.smoke)
    d, surface, blocked, rest = G.dims(gun.device), gun.surface, gun.blocked, gun.rest[0]
    latched = dartgun.latched_state(gun.device, start=gun.rest)[0]

    fig, (ax0, ax1) = C.plt.subplots(1, 2, figsize=(12, 4.4), width_ratios=[1.15, 1.0], constrained_layout=True)
    C.draw_parts(ax0, gun.device, (0.0, 0.0), ("dart", "trigger"))
    for xy, dxy, text in (((d.dart_length + 0.2, 0.5), (0.9, 0.0), "+q0"),
                          ((d.tooth_x + d.tooth_width + 0.3, -1.0), (0.0, 0.7), "+q1")):
        ax0.annotate(text, xy=np.add(xy, dxy), xytext=xy, fontsize=9, va="center", ha="center",
                     arrowprops=dict(arrowstyle="-|>", lw=1.5))
    ax0.set_xlim(-0.5, d.dart_length + 1.5)
    ax0.set_ylim(-d.tooth_length - 0.3, d.dart_height + 0.4)
    ax0.set_aspect("equal")
    ax0.set_xlabel("x (length units)")
    ax0.set_ylabel("y (length units)")
    ax0.set_title("(a) simplified mechanism at q = (0, 0): dart slides in x, trigger in y")
    ax0.legend(loc="lower left", fontsize=8)

    handles = C.cspace_image(ax1, surface, blocked, gun.distance)
    ax1.plot(*rest, "o", color="#1f77b4", ms=6, label="unloaded rest state")
    ax1.plot(*latched, "s", color="#ff7f0e", ms=6, label="latched state")
    note = C.cspace_legend(ax1, handles, blocked)
    ax1.set_xlabel("dart displacement q0 (length units)")
    ax1.set_ylabel("trigger displacement q1 (length units)")
    ax1.set_title(f"(b) C-space on the plane ({note})")
    fig.suptitle("Fig. 3  Dart gun mechanism and its translation-translation C-space")
    C.save(fig, args.out, NAME, args.smoke)
    return 0


if __name__ == "__main__":
    C.run(main)
