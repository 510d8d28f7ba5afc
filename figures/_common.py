"""Plumbing shared by the figure scripts: options, saving, and drawing helpers.

Everything numerical comes from :mod:`pes_ref`; this module only turns arrays the
library returns into pictures (Agg backend, no screen needed).
"""
from __future__ import annotations

import argparse
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import ListedColormap  # noqa: E402

from pes_ref.devices.plots import CSPACE_COLORS, display_grid, domain_limits  # noqa: E402

__all__ = ["DEFAULT_OUT", "parser", "save", "design_state", "design_work", "energy_image", "draw_paths",
           "cspace_image", "cspace_legend", "draw_parts", "value_colors", "draw_phase", "CSPACE_COLORS", "plt"]

#: Where ``make figures`` writes (gitignored).
DEFAULT_OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "out")
#: PNG resolution: readable labels at the paper's column width.
DPI = 150
#: Under --smoke only a coarse PNG is written (no PDF): rendering is most of a smoke run's time.
SMOKE_DPI = 50

plt.rcParams.update({"font.size": 9, "axes.titlesize": 10, "figure.dpi": DPI})


def parser(description: str, design_kind: str | None = None) -> argparse.ArgumentParser:
    """The options every figure script takes: ``--out``, ``--smoke`` (and ``--design``)."""
    p = argparse.ArgumentParser(description=description)
    p.add_argument("--out", default=DEFAULT_OUT, metavar="DIR", help="output folder (default figures/out)")
    p.add_argument("--smoke", action="store_true", help="tiny sizes, for the tests (seconds)")
    if design_kind is not None:
        p.add_argument("--design", default=None, metavar="FILE.npz",
                       help=f"the {design_kind} design (default OUT/cache/{design_kind}.npz, which make figures "
                            f"computes; with --smoke and no file, a tiny design made by the design command)")
    return p


def save(fig, out: str, name: str, smoke: bool = False) -> list:
    """Write ``out/name.png`` and ``out/name.pdf`` (under ``smoke`` only a coarse PNG); return the paths."""
    os.makedirs(out, exist_ok=True)
    paths = [os.path.join(out, f"{name}.{ext}") for ext in (("png",) if smoke else ("png", "pdf"))]
    for path in paths:
        fig.savefig(path, dpi=SMOKE_DPI if smoke else DPI, bbox_inches="tight")
    plt.close(fig)
    print("wrote " + ", ".join(paths))
    return paths


def design_state(args, kind: str, smoke_sets=()):
    """The design of ``kind`` named by ``--design`` (or its default), loaded by the library.

    With ``--smoke`` and no file, a tiny design is made by the project's own command
    (``python -m pes_ref design KIND --smoke``) into ``OUT/cache/KIND-smoke.npz``. ``kind`` is
    ``"funnel"``, ``"oscillator"`` or the name of a shipped problem file (``"latch"``);
    ``smoke_sets`` are further options of that smoke design (``--set NAME=VALUE`` pairs).

    """
    from pes_ref.cli import main as cli_main
    from pes_ref.synthesis.engine.design_file import DesignFileError, load_design

    path = args.design
    if path is None and args.smoke:
        path = os.path.join(args.out, "cache", f"{kind}-smoke.npz")
        os.makedirs(os.path.dirname(path), exist_ok=True)
        code = cli_main(["design", kind, *smoke_sets, "--smoke", "--quiet", "--force", "--out", path])
        if code != 0:
            raise SystemExit(f"the smoke {kind} design failed (exit {code})")
    elif path is None:
        path = os.path.join(args.out, "cache", f"{kind}.npz")
        if not os.path.exists(path):
            raise SystemExit(f"no {kind} design at {path}: run `make figures` (or "
                             f"`python -m pes_ref design {kind} --out {path}`), or pass --design FILE.npz")
    try:
        state = load_design(path)
    except (OSError, DesignFileError) as exc:
        raise SystemExit(f"--design {path}: {exc}") from None
    name = getattr(state.problem, "name", state.kind)          # a problem file's design: its problem's name
    if name != kind:
        raise SystemExit(f"--design {path} holds a {name} design; this figure needs a {kind} design")
    return state


def design_work(state) -> str:
    """What a design cost: ``"3000 iterations"``, plus ``" + 3009 polish evaluations"`` if it was polished."""
    polish = f" + {state.evaluations} polish evaluations" if state.stage == "polish" else ""
    return f"{state.iteration} iterations{polish}"


def energy_image(ax, surface, label: str, values=None, cbar: bool = True, **kw):
    """Draw grid values (default ``surface.values``) over q0 (x) and q1 (y) with a colour bar."""
    values, extent = display_grid(surface, surface.values if values is None else values)
    kw.setdefault("cmap", "viridis")
    im = ax.imshow(values.T, origin="lower", extent=extent, aspect="auto", interpolation="nearest", **kw)
    domain_limits(ax, surface)
    if cbar:
        ax.figure.colorbar(im, ax=ax, label=label, shrink=0.9)
    return im


def cspace_image(ax, surface, blocked, distance, periodic_note: str = ""):
    """Blocked / free as two flat colours and the boundary (zero level of the library's signed
    distance) as a line; a legend instead of a colour bar (the colours are categories)."""
    from matplotlib.patches import Patch
    from matplotlib.lines import Line2D

    cmap = ListedColormap([CSPACE_COLORS["free"], CSPACE_COLORS["blocked"]])
    values, extent = display_grid(surface, np.asarray(blocked, dtype=float))
    ax.imshow(values.T, origin="lower", extent=extent, aspect="auto", cmap=cmap, vmin=0, vmax=1,
              interpolation="nearest")
    domain_limits(ax, surface)
    ax.contour(surface.nodes(0), surface.nodes(1), distance.T, levels=[0.0], colors=CSPACE_COLORS["boundary"],
               linewidths=1.0)
    handles = [Patch(facecolor=CSPACE_COLORS["free"], edgecolor="k", label="free"),
               Patch(facecolor=CSPACE_COLORS["blocked"], edgecolor="k", label="blocked"),
               Line2D([], [], color=CSPACE_COLORS["boundary"], label="boundary (contact)")]
    return handles


def cspace_legend(ax, handles, blocked) -> str:
    """The legend: the C-space categories of :func:`cspace_image` then the axes' own labelled
    artists; returns the note "n0xn1 grid, p% blocked" for the title."""
    ax.legend(handles=handles + ax.get_legend_handles_labels()[0], loc="lower right", fontsize=7, framealpha=0.9)
    return f"{blocked.shape[0]}x{blocked.shape[1]} grid, {100 * np.mean(blocked):.0f}% blocked"


def draw_paths(ax, surface, x, colors, lw: float = 0.8, alpha: float = 0.9, label=None, zorder: int = 3):
    """Draw particle paths ``x`` (T+1, N, 2) on ``surface``'s domain: periodic axes wrapped
    (:meth:`pes_ref.Surface.wrap`) with the line broken where a path wraps around."""
    xw = surface.wrap(np.asarray(x, dtype=float).reshape(-1, 2)).reshape(np.shape(x))
    jump = np.zeros(xw.shape[:2], dtype=bool)
    for d in range(2):
        if surface.periodic[d]:
            jump[1:] |= np.abs(np.diff(xw[..., d], axis=0)) > surface.length[d] / 2
    colors = [colors] * xw.shape[1] if isinstance(colors, str) else list(colors)
    for i in range(xw.shape[1]):
        p = xw[:, i].copy()
        p[jump[:, i]] = np.nan      # a NaN point ends the line before the wrap
        ax.plot(p[:, 0], p[:, 1], color=colors[i], lw=lw, alpha=alpha, zorder=zorder,
                label=label if i == 0 else None)


def draw_parts(ax, device, q, labels, colors=("#9ecae1", "#fdae6b")):
    """Both parts of ``device`` posed at C-space point ``q`` (2,) (:func:`pes_ref.devices.plots.draw_device`)."""
    from pes_ref.devices.plots import draw_device

    draw_device(ax, device, q, labels, colors)


def value_colors(ax, values, label: str, cmap: str = "plasma"):
    """One colour per value (N,) from ``cmap`` and a colour bar saying what the colour means."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    values = np.asarray(values, dtype=float)
    lo, hi = float(values.min()), float(values.max())
    sm = ScalarMappable(Normalize(lo, hi if hi > lo else lo + 1.0), cmap)
    ax.figure.colorbar(sm, ax=ax, label=label, shrink=0.9)
    return [sm.to_rgba(v) for v in values]


def draw_phase(ax, problem, q0, dq0, colors, lw: float = 0.7):
    """Phase-space curves (q0, dq0/dt), each (T', N), and the target orbit of eq. (6):
    ``q0 = A cos(w t)``, ``dq0/dt = -A w sin(w t)``."""
    for i in range(q0.shape[1]):
        ax.plot(q0[:, i], dq0[:, i], color=colors[i], lw=lw, alpha=0.8)
    t = np.linspace(0.0, 2 * np.pi, 200)
    a, w = problem.amplitude, problem.omega
    ax.plot(a * np.cos(t), -a * w * np.sin(t), "k--", lw=1.2, label=f"target orbit (A = {a:g}, omega = {w:g})")
    ax.set_xlabel("q0 (length units)")
    ax.set_ylabel("dq0/dt (length units per time unit)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(loc="upper right", fontsize=7)


def run(main) -> None:
    """``sys.exit(main())`` for the ``if __name__ == "__main__"`` line."""
    sys.exit(main())
