"""Narrow free channels of a device's C-space: where its surface cannot be trusted.

The surface of a device is eq. (1) of the C-space's distance to blocked space, sampled on
the grid. Two things make it say something else than the parts do, and both show in the
distance field of the computed C-space (`pes_ref.devices.cspace.CSpace.distance`):

- **The barrier is wider than the clearance.** Where a free channel (a locked Geneva
  wheel's play, a pin in its slot) is narrower than ``2 r_c``, eq. (1) acts everywhere
  across it: no pose in it is free of the barrier, and the barriers of its two walls push
  the state along wherever the channel's width changes (a "locked" wheel is dragged). It
  matters once a wall's push at the channel's centre is more than `BARRIER_SHARE` of
  the barrier's force where it holds a load, which is below about 0.7 r_c.
- **The grid cannot resolve the channel.** The surface is interpolated between nodes; a
  channel whose half-width spans fewer than `RESOLVE_CELLS` cells across it is a few
  nodes wide or none: the interpolated surface misplaces its walls, and a quasistatic drive
  may stall in it.

The channels are found on the *ridge* of the distance field: the nodes where the distance
peaks along a grid axis that crosses the channel steeply (`CROSSING`). Across a
channel the distance is a tent whose peak is the channel's half-width ``w``, located between
the nodes from the node and its two neighbours ([`ridge`][pes_ref.devices.clearance.ridge]); the tent's slope gives the
direction across the channel, and so the grid's cell extent across it,
``h_n = |n0| h0 + |n1| h1``. A ridge node is narrow when ``w < BARRIER_REACH r_c`` (the
barrier) or ``w < RESOLVE_CELLS h_n`` (the grid). A corner of free space also has a ridge
that narrows to nothing; a channel is long. So the narrow ridge nodes count only as
stretches (8-connected, across a periodic seam) at least `MIN_LENGTH` times their
median half-width long, and no shorter than `MIN_CELLS` cells.

[`check_clearance`][pes_ref.devices.clearance.check_clearance] returns one
[`Finding`][pes_ref.devices.clearance.Finding] per kind, with the narrowest stretch, the
numbers and what to change; ``analyze DEVICE.toml`` prints each as one ``warning:`` line.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Finding", "check_clearance", "ridge", "RESOLVE_CELLS", "MIN_LENGTH", "MIN_CELLS", "KINDS",
           "BARRIER_SHARE", "BARRIER_REACH", "CROSSING"]

#: A channel's half-width must span at least this many grid cells across it.
RESOLVE_CELLS = 2.0
#: A narrow stretch of ridge counts when it is at least this many times its median half-width long ...
MIN_LENGTH = 16.0
#: ... and at least this many grid cells long.
MIN_CELLS = 8
#: A node is on the ridge along an axis where the distance peaks along it and falls at least this
#: steeply (|n_k|, the share of the axis across the channel): an axis at more than 45 degrees to
#: the channel's direction crosses it; a peak along an axis nearly parallel to a wall is no ridge.
CROSSING = 0.7
#: Eq. (1)'s push from one wall at a channel's centre, as a share of its force at the standoff
#: r_c / 3 (where ``v = F r_c^3 / 18`` holds a load F, docs/devices.md), above which the barrier
#: drags the parts: ``(1/x - 1) / (18 x^2)`` with ``x = half-width / r_c``, which exceeds it for
#: ``x < BARRIER_REACH`` (0.70).
BARRIER_SHARE = 0.05
BARRIER_REACH = float(min(r.real for r in np.roots([18.0 * BARRIER_SHARE, 0.0, 1.0, -1.0])
                          if abs(r.imag) < 1e-12))
#: The kinds of finding: eq. (1)'s cut-off against the clearance, the grid against the channel.
KINDS = ("barrier", "resolution")


@dataclass(frozen=True)
class Finding:
    """One reason the device's surface cannot be trusted.

    Attributes
    ----------
    kind : {"barrier", "resolution"}
    keys : tuple of str
        The device-file keys that decide it (``energy.r_c``, ``cspace.shape``).
    message : str
        One line: what is wrong, where, and what to change, with the device's numbers.
    half_width : float
        The narrowest stretch's median half-width (C-space units: the clearance on each side).
    at : tuple of float
        A C-space point (q0, q1) in the middle of that stretch, at about that half-width.
    limit : float
        What the half-width is compared with: ``BARRIER_REACH r_c``, or the clearance that
        spans ``RESOLVE_CELLS`` cells across the channel.
    suggestion : float or tuple
        The fix in numbers: the r_c to stay below (``half_width / BARRIER_REACH``), or the grid
        shape that resolves the channel.
    """

    kind: str
    keys: tuple
    message: str
    half_width: float
    at: tuple
    limit: float
    suggestion: object


def ridge(distance, spacing, periodic):
    """The ridge of a signed distance field and the channels' half-widths along it.

    Parameters
    ----------
    distance : ndarray (n0, n1)
        Signed distance to blocked space (> 0 free).
    spacing : array_like (2,)
    periodic : sequence of 2 bool

    Returns
    -------
    width : ndarray (n0, n1)
        The half-width of the channel through each ridge node (the tent's peak between the
        node and its neighbours, along the axis that crosses the ridge most steeply); NaN
        off the ridge.
    across : ndarray (n0, n1)
        The grid's cell extent across the channel there, ``|n0| h0 + |n1| h1``; NaN off the ridge.
    """
    d = np.asarray(distance, dtype=float)
    h = np.asarray(spacing, dtype=float)
    width = np.full(d.shape, np.nan)
    across = np.full(d.shape, np.nan)
    steep = np.full(d.shape, -np.inf)
    for k in range(2):
        prev, nxt = np.roll(d, 1, axis=k), np.roll(d, -1, axis=k)
        top = (d > 0) & (d >= prev) & (d >= nxt) & ((d > prev) | (d > nxt))
        if not periodic[k]:
            edge = [slice(None)] * 2
            for end in (0, -1):
                edge[k] = end
                top[tuple(edge)] = False
        hi, lo = np.maximum(prev, nxt), np.minimum(prev, nxt)
        s = d - lo                                  # the tent's fall per cell on the far side
        peak = np.minimum((d + hi + s) / 2.0, d + s / 2.0)
        slope = np.clip(s / h[k], 0.0, 1.0)         # |d distance / d q_k| = |n_k|
        better = top & (slope >= CROSSING) & (slope > steep)
        n_k = slope
        n_o = np.sqrt(np.maximum(1.0 - n_k * n_k, 0.0))
        ext = n_k * h[k] + n_o * h[1 - k]
        width[better], across[better], steep[better] = peak[better], ext[better], slope[better]
    return width, across


def _stretches(mask, periodic):
    """8-connected components of ``mask``, joined across periodic seams: a label array (0: none)."""
    from scipy import ndimage

    labels, n = ndimage.label(mask, structure=np.ones((3, 3), dtype=int))
    if n == 0:
        return labels
    parent = np.arange(n + 1)

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for k in range(2):
        if not periodic[k]:
            continue
        first, last = np.take(labels, 0, axis=k), np.take(labels, -1, axis=k)
        for shift in (-1, 0, 1):
            other = np.roll(last, shift)
            for a, b in zip(first[(first > 0) & (other > 0)], other[(first > 0) & (other > 0)]):
                ra, rb = find(a), find(b)
                if ra != rb:
                    parent[ra] = rb
    roots = np.array([find(a) for a in range(n + 1)])
    return roots[labels]


def _narrow(width, narrow, spacing, periodic) -> list:
    """The narrow stretches that count: (node indices i, j, their median half-width) of each
    one at least `MIN_LENGTH` times its median half-width and `MIN_CELLS` cells long."""
    labels = _stretches(narrow, periodic)
    out = []
    for lab in np.unique(labels[labels > 0]):
        i, j = np.nonzero(labels == lab)
        w = float(np.median(width[i, j]))
        cells = max(np.unique(i).size, np.unique(j).size)
        length = max(np.unique(i).size * spacing[0], np.unique(j).size * spacing[1])
        if cells >= MIN_CELLS and length >= MIN_LENGTH * w:
            out.append((i, j, w))
    return out


def _typical(i, j, widths, w) -> int:
    """The node of a stretch to name: of those within 2% of its median half-width ``w`` (or the
    nearest), the middle one along the stretch's longer axis."""
    near = np.nonzero(np.abs(widths - w) <= 0.02 * w)[0]
    if near.size == 0:
        return int(np.argmin(np.abs(widths - w)))
    along = i if np.unique(i).size >= np.unique(j).size else j
    order = near[np.argsort(along[near], kind="stable")]
    return int(order[order.size // 2])


def _sig(x: float, digits: int = 2, up: bool = False) -> float:
    """``x`` rounded down (``up``: up) to ``digits`` significant digits: a bound that stays on its side of ``x``."""
    if not x > 0:
        return 0.0
    e = 10.0 ** (np.floor(np.log10(x)) - digits + 1)
    return float(round((np.ceil(x / e) if up else np.floor(x / e)) * e, 12))


def check_clearance(device, cspace=None) -> list:
    """Where the device's surface cannot be trusted: a list of [`Finding`][pes_ref.devices.clearance.Finding] (empty:
    none found).

    Parameters
    ----------
    device : pes_ref.devices.device.Device
    cspace : pes_ref.devices.cspace.CSpace, optional
        The device's computed C-space (default ``device.cspace()``).

    Returns
    -------
    list of Finding
        At most one per kind (`KINDS`): the narrowest stretch of the kind.
    """
    cs = device.cspace() if cspace is None else cspace
    h = np.asarray(device.spacing, dtype=float)
    periodic = device.periodic
    width, across = ridge(cs.distance, h, periodic)
    on = np.isfinite(width)
    nodes = [device.grid.nodes(d) for d in range(2)]
    findings = []
    rules = (("barrier", on & (width < BARRIER_REACH * device.r_c)),
             ("resolution", on & (width < RESOLVE_CELLS * across)))
    for kind, narrow in rules:
        stretches = _narrow(width, narrow, h, periodic)
        if not stretches:
            continue
        i, j, w = min(stretches, key=lambda s: s[2])          # the narrowest stretch
        k = _typical(i, j, width[i, j], w)
        at = (float(nodes[0][i[k]]), float(nodes[1][j[k]]))
        where = f"q0 = {at[0]:.4g}, q1 = {at[1]:.4g}"
        if kind == "barrier":
            top, r_c = _sig(w / BARRIER_REACH), _sig(w)
            msg = (f"[energy] r_c = {device.r_c:g} is wider than the clearance of a free channel of the C-space "
                   f"(half-width {w:.3g} at {where}, below {BARRIER_REACH:.2f} r_c): eq. (1)'s barrier acts "
                   f"across all of it and drags the parts (a locked output moves); set [energy] r_c below "
                   f"{top:g} (at most {r_c:g} leaves the channel's centre free of it; scale [energy] v by "
                   f"(new r_c / {device.r_c:g})^3 for the same standoff), or widen the clearance to "
                   f"{_sig(BARRIER_REACH * device.r_c, up=True):g} or more")
            findings.append(Finding(kind, ("energy.r_c",), msg, w, at, BARRIER_REACH * float(device.r_c), top))
        else:
            cells = float(np.median(width[i, j] / across[i, j]))
            need = max(float(np.quantile(RESOLVE_CELLS * across[ii, jj] / width[ii, jj], 0.75))
                       for ii, jj, _ in stretches)
            shape = tuple(int(np.ceil(n * need)) for n in device.shape)
            lim = _sig(float(RESOLVE_CELLS * np.median(across[i, j])), up=True)
            msg = (f"[cspace] shape = {list(device.shape)} cannot resolve a free channel of the C-space "
                   f"(half-width {w:.3g} at {where}: {cells:.2g} cells across it, fewer than {RESOLVE_CELLS:g}): "
                   f"the interpolated surface misplaces its walls and a quasistatic drive may stall in it; "
                   f"raise [cspace] shape to at least "
                   f"{shape[0]},{shape[1]}, or widen the clearance to {lim:g} or more")
            findings.append(Finding(kind, ("cspace.shape",), msg, w, at, lim, shape))
    return findings
