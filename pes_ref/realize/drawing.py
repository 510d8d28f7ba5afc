"""Drawing a realization: the design's surface with its blocked region, and the parts at three
positions (a plate, or a drum's walls unrolled, in the part's own frame)."""
from __future__ import annotations

import numpy as np

from pes_ref.devices.plots import draw_geometry

__all__ = ["parts_figure", "POSITIONS"]

#: Where along a held-out path the pin is drawn: its share of the path's states.
POSITIONS = (0.0, 0.35, 1.0)


def parts_figure(realization, path):
    """A two-panel Agg figure: the design's surface with the contact level's contour, and the
    plate (or drum) with the pin at `POSITIONS` along ``path`` ((T+1, 2) states of one
    held-out particle; the pin is drawn where the particle is, up to where it leaves the grid's
    domain along a non-periodic axis)."""
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
    bounded = ~np.asarray(region.periodic)
    out = np.nonzero(np.any(((path <= lo) | (path >= hi)) & bounded, axis=1))[0]
    end = int(out[0]) if out.size else path.shape[0] - 1
    drawn = parts.in_frame(path[:end + 1])
    if parts.y_period is not None:             # no line across the drum's seam
        drawn[1:][np.abs(np.diff(drawn[:, 1])) > parts.y_period / 2] = np.nan
    ax1.plot(drawn[:, 0], drawn[:, 1], color="0.4", lw=0.8)
    for share in POSITIONS:
        k = int(round(share * end))
        q, at = path[k], parts.in_frame(path[k])
        ax1.add_patch(_circle(at, parts.pin_made))
        ax1.annotate(f"({q[0]:.2f}, {q[1]:.2f})", at, xytext=(4, 4), textcoords="offset points", fontsize=7)
    b0, b1 = parts.plate.bounds[:2], parts.plate.bounds[2:]
    ax1.set_xlim(b0[0], b1[0])
    ax1.set_ylim(b0[1], b1[1])
    ax1.set_aspect("equal")
    ax1.set_title(f"{parts.part_name} and pin (r = {parts.pin_made:g}) at three positions (q0, q1)")
    ax1.set_xlabel(f"x ({parts.part_name} frame)")
    ax1.set_ylabel("y" if parts.y_period is None else "y: arc length round the drum")
    fig.tight_layout()
    return fig


def _circle(q, radius):
    from matplotlib.patches import Circle
    return Circle(tuple(q), radius, facecolor="#3182bd", edgecolor="k", lw=0.6)
