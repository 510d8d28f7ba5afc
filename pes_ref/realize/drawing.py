"""Drawing a realization: the design's surface with its blocked region, and the parts at three positions."""
from __future__ import annotations

import numpy as np

from pes_ref.devices.plots import draw_geometry

__all__ = ["parts_figure", "POSITIONS"]

#: Where along a held-out path the pin is drawn: its share of the path's states.
POSITIONS = (0.0, 0.35, 1.0)


def parts_figure(realization, path):
    """A two-panel Agg figure: the design's surface with the contact level's contour, and the
    plate with the pin at :data:`POSITIONS` along ``path`` ((T+1, 2) states of one held-out
    particle; the pin is drawn where the particle is, at most at its exit)."""
    from matplotlib.figure import Figure
    region, parts = realization.region, realization.parts
    fig = Figure(figsize=(10, 4.6))
    ax0, ax1 = fig.subplots(1, 2)
    lo, hi = region.lower, region.upper
    im = ax0.imshow(region.energy.T, origin="lower", extent=(lo[0], hi[0], lo[1], hi[1]), cmap="viridis")
    fig.colorbar(im, ax=ax0, label="design energy")
    q0 = np.linspace(lo[0], hi[0], region.phi.shape[0])
    q1 = np.linspace(lo[1], hi[1], region.phi.shape[1])
    ax0.contour(q0, q1, region.phi.T, levels=[0.0], colors="w", linewidths=1.0)
    ax0.set_title(f"design: blocked above {region.level:.3g} ({region.rule})")
    ax0.set_xlabel("q0")
    ax0.set_ylabel("q1")
    draw_geometry(ax1, parts.plate, facecolor="#fdae6b", alpha=0.9)
    path = np.asarray(path, dtype=np.float64)
    below = np.nonzero(path[:, 1] <= lo[1])[0]
    end = int(below[0]) if below.size else path.shape[0] - 1
    ax1.plot(path[:end + 1, 0], path[:end + 1, 1], color="0.4", lw=0.8)
    for share in POSITIONS:
        q = path[int(round(share * end))]
        ax1.add_patch(_circle(q, parts.pin_radius))
        ax1.annotate(f"({q[0]:.2f}, {q[1]:.2f})", q, xytext=(4, 4), textcoords="offset points", fontsize=7)
    b0, b1 = parts.plate.bounds[:2], parts.plate.bounds[2:]
    ax1.set_xlim(b0[0], b1[0])
    ax1.set_ylim(b0[1], b1[1])
    ax1.set_aspect("equal")
    ax1.set_title(f"plate and pin (r = {parts.pin_radius:g}) at three positions")
    ax1.set_xlabel("x (plate frame)")
    ax1.set_ylabel("y")
    fig.tight_layout()
    return fig


def _circle(q, radius):
    from matplotlib.patches import Circle
    return Circle(tuple(q), radius, facecolor="#3182bd", edgecolor="k", lw=0.6)
