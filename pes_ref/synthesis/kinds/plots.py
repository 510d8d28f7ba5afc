"""Drawing a design's held-out particles on its surface, for ``python -m pes_ref evaluate --plot``.

One panel per [`pes_ref.synthesis.kinds.analysis.Panel`][pes_ref.synthesis.kinds.analysis.Panel] (what passing means there: the
funnel's band, the oscillator's capture by the cycle, each success test of a problem file
and all of them): the design's energy as a heat map on its domain, each held-out path
drawn over it in green if it passed and red if it did not, with the counts in the legend.
It only turns what [`pes_ref.synthesis.kinds.registry.held_out_panels`][pes_ref.synthesis.kinds.registry.held_out_panels] computed into a
picture; matplotlib is imported when a figure is made, never by ``import pes_ref``.
"""
from __future__ import annotations

import math

import numpy as np

from pes_ref.devices.plots import display_grid, domain_limits, wrapped_path

__all__ = ["paths_figure", "PATH_COLORS"]

#: The colour of a path that passed, and of one that failed.
PATH_COLORS = {True: "#1a9850", False: "#d73027"}


def paths_figure(problem, values, panels, title: str):
    """A matplotlib Figure (no pyplot: its own Agg canvas when saved as PNG): one panel
    per entry of ``panels`` over the surface of design ``values``, three to a row."""
    from matplotlib.figure import Figure
    surface = problem.scene(values).surface
    energy, extent = display_grid(surface, surface.values)
    ncols = min(len(panels), 3)
    nrows = math.ceil(len(panels) / ncols)
    fig = Figure(figsize=(5.6 * ncols, 4.8 * nrows + 0.6))
    for k, panel in enumerate(panels):
        ax = fig.add_subplot(nrows, ncols, k + 1)
        image = ax.imshow(energy.T, origin="lower", extent=extent, aspect="auto", cmap="Greys_r",
                          interpolation="nearest")
        fig.colorbar(image, ax=ax, label="energy")
        handles = [_paths(ax, surface, panel, passed) for passed in (False, True)]
        start = ax.plot(panel.x[0, :, 0], panel.x[0, :, 1], ".", color="#4575b4", ms=3, label="start")[0]
        domain_limits(ax, surface)
        ax.legend(handles=handles + [start], loc="lower right", fontsize=8, framealpha=0.9)
        ax.set_xlabel("q0")
        ax.set_ylabel("q1")
        ax.set_title(f"{panel.title}\n{int(np.sum(panel.passed))} of {panel.passed.size} pass", fontsize=10)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    return fig


def _paths(ax, surface, panel, passed: bool):
    """The paths of ``panel`` that passed (or failed) as one line collection; returns its legend handle."""
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D
    chosen = np.nonzero(np.asarray(panel.passed, dtype=bool) == passed)[0]
    if chosen.size:             # each path wrapped onto the domain, broken where it wraps
        lines = [wrapped_path(surface, panel.x[:, i]) for i in chosen]
        ax.add_collection(LineCollection(lines, colors=PATH_COLORS[passed], linewidths=0.7, alpha=0.6))
    word = "pass" if passed else "fail"
    return Line2D([], [], color=PATH_COLORS[passed], lw=1.5, label=f"{word}: {chosen.size} of {panel.passed.size}")
