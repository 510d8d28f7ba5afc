"""Drawing a device with matplotlib: its parts as patches, its C-space and a drive's path.

The figure scripts and ``python -m pes_ref analyze DEVICE.toml --plot`` draw through these
helpers; they only turn what the library computed into pictures (call them with a
matplotlib axes; [`drive_figure`][pes_ref.devices.plots.drive_figure] makes a whole figure on the Agg backend).
"""
from __future__ import annotations

import numpy as np

__all__ = ["geometry_path", "draw_geometry", "draw_device", "cspace_image", "drive_figure", "display_grid",
           "wrapped_path", "domain_limits", "CSPACE_COLORS", "motion_law_title", "engines_figure",
           "ENGINE_COLORS"]

#: Colours of the C-space: free, blocked, boundary.
CSPACE_COLORS = {"free": "#f7f7f7", "blocked": "#4d4d4d", "boundary": "#d62728"}
#: Colours of part 0 and part 1.
PART_COLORS = ("#9ecae1", "#fdae6b")


def geometry_path(geom):
    """A matplotlib Path of a shapely (Multi)Polygon, holes included."""
    from matplotlib.path import Path

    polys = getattr(geom, "geoms", [geom])
    verts, codes = [], []
    for poly in polys:
        for ring in (poly.exterior, *poly.interiors):
            xy = np.asarray(ring.coords)
            verts.append(xy)
            codes.append([Path.MOVETO] + [Path.LINETO] * (len(xy) - 2) + [Path.CLOSEPOLY])
    return Path(np.concatenate(verts), np.concatenate(codes))


def draw_geometry(ax, geom, **kw):
    """Add a shapely (Multi)Polygon to ``ax`` as one patch (``kw``: PathPatch options)."""
    from matplotlib.patches import PathPatch

    kw.setdefault("edgecolor", "k")
    kw.setdefault("lw", 0.8)
    patch = PathPatch(geometry_path(geom), **kw)
    ax.add_patch(patch)
    return patch


def draw_device(ax, device, q, labels=("part 0", "part 1"), colors=PART_COLORS):
    """Both parts of ``device`` posed at C-space point ``q`` (2,), with an equal aspect."""
    from pes_ref.devices.geometry import posed_geometries

    for geom, label, color in zip(posed_geometries(*device.parts, q[0], q[1], device.grid.tolerance), labels, colors):
        draw_geometry(ax, geom, facecolor=color, label=label)
    ax.set_aspect("equal")
    ax.autoscale_view()


def display_grid(surface, values):
    """Values and imshow extent putting each value at its node; on a periodic axis the
    first node is repeated after the last so the image fills [lower, upper]."""
    values = np.asarray(values)
    h = surface.spacing
    lo = surface.lower - h / 2
    hi = lo + h * np.array(values.shape)
    for d in range(2):
        if surface.periodic[d]:
            values = np.concatenate([values, np.take(values, [0], axis=d)], axis=d)
            hi[d] += h[d]
    return values, [lo[0], hi[0], lo[1], hi[1]]


def cspace_image(ax, surface, blocked, segments=None):
    """Blocked / free as two flat colours and the boundary polyline (``segments`` (M, 2, 2),
    wrapped onto the domain) as a line; returns legend handles."""
    from matplotlib.collections import LineCollection
    from matplotlib.colors import ListedColormap
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    cmap = ListedColormap([CSPACE_COLORS["free"], CSPACE_COLORS["blocked"]])
    values, extent = display_grid(surface, np.asarray(blocked, dtype=float))
    ax.imshow(values.T, origin="lower", extent=extent, aspect="auto", cmap=cmap, vmin=0, vmax=1,
              interpolation="nearest")
    handles = [Patch(facecolor=CSPACE_COLORS["free"], edgecolor="k", label="free"),
               Patch(facecolor=CSPACE_COLORS["blocked"], edgecolor="k", label="blocked")]
    if segments is not None and len(segments):
        seg = np.array(segments, dtype=float)
        for d in range(2):
            if surface.periodic[d]:
                shift = np.floor((seg[:, :, d].min(axis=1) - surface.lower[d]) / surface.length[d])
                seg[:, :, d] -= shift[:, None] * surface.length[d]
        ax.add_collection(LineCollection(seg, colors=CSPACE_COLORS["boundary"], linewidths=1.0))
        handles.append(Line2D([], [], color=CSPACE_COLORS["boundary"], label="boundary (contact)"))
    domain_limits(ax, surface)
    return handles


def domain_limits(ax, surface):
    """Axis limits: the period on a periodic axis, the node span plus half a cell otherwise."""
    h = surface.spacing
    lims = [(surface.lower[d], surface.upper[d]) if surface.periodic[d]
            else (surface.lower[d] - h[d] / 2, surface.upper[d] + h[d] / 2) for d in range(2)]
    ax.set_xlim(*lims[0])
    ax.set_ylim(*lims[1])


def wrapped_path(surface, x):
    """Positions (T, 2) wrapped onto the domain, NaN where a periodic axis wraps (breaks the line)."""
    xw = surface.wrap(np.asarray(x, dtype=float))
    jump = np.zeros(xw.shape[0], dtype=bool)
    for d in range(2):
        if surface.periodic[d]:
            jump[1:] |= np.abs(np.diff(xw[:, d])) > surface.length[d] / 2
    xw[jump] = np.nan
    return xw


def motion_law_title(result) -> str:
    """The motion law's title, two lines that fit over its axes: the steady advance (the last full
    cycle's; a run short of a turn gives its advance over the travel achieved, never extrapolated)
    and the moving share, with where the run jammed."""
    if result.periodic_input and result.advance_per_cycle_each:
        head = f"advance {result.advance_per_cycle:.4g} per cycle (last of {len(result.advance_per_cycle_each)})"
    elif result.periodic_input:
        head = f"advance {result.advance:.4g} over {result.input_travel:.3g} rad (no full cycle)"
    else:
        head = f"advance {result.advance_per_cycle:.4g} per unit of input"
    tail = f"moving {100 * result.moving_fraction:.1f}% of the travel"
    if result.jammed:
        tail += f"; JAMMED ({result.stop_reason}) at ({result.stopped_at[0]:.3g}, {result.stopped_at[1]:.3g})"
    return f"motion law: {head}\n{tail}"


def drive_figure(device, result, title: str = ""):
    """The C-space with the drive's path (left) and its motion law (right): a matplotlib Figure."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cs = device.cspace()
    surface = device.surface()
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 4.8), constrained_layout=True)
    handles = cspace_image(ax0, surface, cs.blocked, cs.segments)
    p = wrapped_path(surface, result.path)
    (line,) = ax0.plot(p[:, 0], p[:, 1], color="#1f77b4", lw=1.4, label="path")
    (s,) = ax0.plot(*surface.wrap(result.path[0]), "o", color="#2ca02c", ms=5, label="start")
    (e,) = ax0.plot(*surface.wrap(result.path[-1]), "x" if result.jammed else "s", color="#ff7f0e", ms=7, mew=2,
                    label="jammed here" if result.jammed else "end")
    ax0.legend(handles=handles + [line, s, e], loc="lower right", fontsize=7, framealpha=0.9)
    ax0.set_xlabel("q0")
    ax0.set_ylabel("q1")
    ax0.set_title(f"C-space ({cs.blocked.shape[0]}x{cs.blocked.shape[1]}, {100 * cs.blocked.mean():.0f}% blocked)")
    ax1.plot(result.q_in - result.q_in[0], result.q_out - result.q_out[0], color="#1f77b4", lw=1.4)
    ax1.set_xlabel(f"input q{result.drive} travel")
    ax1.set_ylabel(f"output q{1 - result.drive} change")
    ax1.set_title(motion_law_title(result), fontsize=10)
    ax1.grid(alpha=0.3)
    fig.suptitle(title or f"{device.name}: drive q{result.drive} with load {result.load:g} ({result.mode})")
    return fig


#: The colour of each engine's path and motion law (`engines_figure`).
ENGINE_COLORS = {"surface": "#1f77b4", "rigid": "#9467bd"}   # the boundary is red


def engines_figure(device, results: dict, title: str = ""):
    """One drive on several engines (``{engine: DriveResult}``): the C-space with each path (left)
    and each motion law (right), both against the start, one colour per engine."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cs = device.cspace()
    surface = device.surface()
    first = next(iter(results.values()))
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 4.8), constrained_layout=True)
    handles = cspace_image(ax0, surface, cs.blocked, cs.segments)
    (s,) = ax0.plot(*surface.wrap(first.path[0]), "o", color="#2ca02c", ms=5, label="start")
    handles.append(s)
    for name, r in results.items():
        color = ENGINE_COLORS.get(name, "k")
        p = wrapped_path(surface, r.path)
        (line,) = ax0.plot(p[:, 0], p[:, 1], color=color, lw=1.2, label=f"path ({name})")
        ax0.plot(*surface.wrap(r.path[-1]), "x" if r.jammed else "s", color=color, ms=7, mew=2)
        handles.append(line)
        ax1.plot(r.q_in - first.q_in[0], r.q_out - first.q_out[0], color=color, lw=1.3,
                 label=f"{name}: advance {r.advance_per_cycle:.4g}, moving {100 * r.moving_fraction:.1f}%"
                       f"{', JAMMED' if r.jammed else ''}")
    ax0.legend(handles=handles, loc="lower right", fontsize=7, framealpha=0.9)
    ax0.set_xlabel("q0")
    ax0.set_ylabel("q1")
    ax0.set_title(f"C-space ({cs.blocked.shape[0]}x{cs.blocked.shape[1]}, {100 * cs.blocked.mean():.0f}% blocked)")
    ax1.set_xlabel(f"input q{first.drive} travel")
    ax1.set_ylabel(f"output q{1 - first.drive} change")
    ax1.set_title(f"motion laws ({' vs '.join(results)})")
    ax1.legend(fontsize=8, loc="best")
    ax1.grid(alpha=0.3)
    fig.suptitle(title or f"{device.name}: drive q{first.drive} with load {first.load:g} ({first.mode})")
    return fig
