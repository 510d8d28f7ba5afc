"""The C-space boundary between the grid's nodes, and the signed distance to it.

Eq. (1) needs r, the distance from a node to blocked space. The nodes alone say only which side they
are on, so a distance taken from them (a Euclidean distance transform of the node mask,
[`mask_distance`][pes_ref.devices.boundary.mask_distance]) is quantized to the grid: neighbouring
nodes share a distance and a quasistatic drive stalls in a free channel. Here the boundary is
located between the nodes instead:

1. **Crossings.** On every grid edge whose two nodes differ (one blocked, one free),
   the point where the parts start to overlap is found by bisection on the exact overlap test of the
   posed geometry ([`locate_crossings`][pes_ref.devices.boundary.locate_crossings], ``steps``
   halvings: within ``h / 2**(steps + 1)``).
2. **Polyline.** Marching squares joins the crossings of each cell into segments
   ([`boundary_segments`][pes_ref.devices.boundary.boundary_segments]); in a cell with four
   crossings (two blocked corners on a diagonal) each blocked corner is cut off by its own segment.
   Where the polyline's neighbouring segments run straight into a cell from both sides and their
   lines meet inside it, that point is a corner of the obstacle and the cell's segment is bent
   there.
3. **Distance.** Every node's distance to the nearest segment
([`grid_distance`][pes_ref.devices.boundary.grid_distance]),
   exact within a band around the boundary (`BAND` spacings, or eq. (1)'s cut-off
   r_c and two spacings more for a device) and propagated beyond, where it stays within
   about h/2 (measured: 0.6 h deep inside a large obstacle), negative at blocked nodes.
   Periodic axes use the minimum image.

The error is that of the polyline: ``O(h^2 / R)`` where the boundary has radius of
curvature R, and at a corner of the obstacle up to the corner's cut through one cell
(``validation/cspace_minkowski.py`` measures it against exact Minkowski differences).
"""
from __future__ import annotations

import numpy as np

from pes_ref.core import checks

__all__ = ["locate_crossings", "boundary_segments", "grid_distance", "mask_distance", "BISECTION_STEPS"]

#: Halvings of a grid edge when a crossing is located: the crossing is known within
#: ``h / 2**(BISECTION_STEPS + 1)`` (h/512), far below the h/10 the distance must meet.
BISECTION_STEPS = 8
#: Three crossings of the polyline are on one line when the middle one is within this many spacings
#: of the line through the others (the crossings are exact to h/512: a straight edge stays within it).
STRAIGHT = 0.01
#: Half-width, in spacings of the coarser axis, of the band around the boundary where the
#: distance is exact by default (a device widens it to cover eq. (1)'s r_c).
BAND = 8
#: Rounds in which a node beyond the band looks at its neighbours' boundary points.
REFINE = 4


def _edges(mask: np.ndarray, axis: int, periodic: bool):
    """Grid edges along ``axis`` whose two nodes differ: (start node indices (i, j), start is blocked)."""
    nxt = np.roll(mask, -1, axis=axis)
    diff = mask != nxt
    if not periodic:
        last = [slice(None)] * 2
        last[axis] = -1
        diff[tuple(last)] = False
    i, j = np.nonzero(diff)
    return i, j, mask[i, j]


def locate_crossings(mask, periodic, overlaps, steps: int = BISECTION_STEPS):
    """Where the boundary crosses each grid edge whose nodes differ.

    Parameters
    ----------
    mask : ndarray of bool, shape (n0, n1)
        True where blocked.
    periodic : sequence of 2 bool
    overlaps : callable
        ``overlaps(axis, i, j, u, k) -> bool array``: whether the parts overlap at the point
        ``u / k`` of a spacing past node (i, j) along ``axis`` (arrays of equal length,
        integer ``u`` in ``(0, k)``).
    steps : int
        Halvings per edge.

    Returns
    -------
    list of two ndarrays, shape (n0, n1)
        ``t[axis][i, j]``: the crossing's fraction of a spacing past node (i, j) along
        ``axis``, NaN where that edge has no crossing.
    """
    out = []
    k = 2 ** steps
    for axis in range(2):
        t = np.full(mask.shape, np.nan)
        i, j, start_blocked = _edges(mask, axis, bool(periodic[axis]))
        free = np.where(start_blocked, k, 0)           # the bracket, in units of 1/k of a spacing
        hit = np.where(start_blocked, 0, k)
        for _ in range(steps):
            mid = (free + hit) // 2
            over = overlaps(axis, i, j, mid, k)
            hit = np.where(over, mid, hit)
            free = np.where(over, free, mid)
        t[i, j] = 0.5 * (free + hit) / k
        out.append(t)
    return out


def boundary_segments(mask, crossings, lower, spacing, periodic, corners: bool = True, return_ids: bool = False):
    """The boundary polyline by marching squares: segments (M, 2, 2) of (q0, q1) end points.

    Each cell (i, j) spans nodes i..i+1 and j..j+1 (across the seam on a periodic axis, so
    its points may lie past ``upper`` there: unwrapped). A cell with two crossings gives
    one segment; one with four (two blocked corners on a diagonal) gives two, each cutting
    off one blocked corner. With ``corners``, a corner of the obstacle inside a cell is put
    back (`_corners`) instead of being cut off by the chord between the crossings.

    With ``return_ids`` (and ``corners`` False) it also returns the crossing each end point is
    (M, 2) int: ``axis * n0 * n1 + i * n1 + j`` for the crossing on the edge from node (i, j)
    along ``axis`` (a level set's distance differentiates through them).
    """
    if return_ids and corners:
        raise ValueError("return_ids needs corners=False: a corner put back is no crossing")
    n0, n1 = mask.shape
    t0, t1 = crossings
    h = np.asarray(spacing, dtype=float)
    i, j = np.meshgrid(np.arange(n0 if periodic[0] else n0 - 1), np.arange(n1 if periodic[1] else n1 - 1),
                       indexing="ij")
    i, j = i.ravel(), j.ravel()
    ip, jp = (i + 1) % n0, (j + 1) % n1
    base = np.asarray(lower, dtype=float) + h * np.stack((i, j), axis=1)
    # the four edges of each cell: bottom (along q0 at j), top (at j+1), left (along q1 at i), right (at i+1)
    tb, tt, tl, tr = t0[i, j], t0[i, jp], t1[i, j], t1[ip, j]
    pts = {"b": base + h * np.stack((tb, np.zeros_like(tb)), axis=1),
           "t": base + h * np.stack((tt, np.ones_like(tt)), axis=1),
           "l": base + h * np.stack((np.zeros_like(tl), tl), axis=1),
           "r": base + h * np.stack((np.ones_like(tr), tr), axis=1)}
    size = n0 * n1                              # an edge's id: axis * size + node index of its start
    ids = {"b": i * n1 + j, "t": i * n1 + jp, "l": size + i * n1 + j, "r": size + ip * n1 + j}
    has = {"b": ~np.isnan(tb), "t": ~np.isnan(tt), "l": ~np.isnan(tl), "r": ~np.isnan(tr)}
    count = sum(has.values())
    pairs = []
    two = count == 2
    order = ("b", "t", "l", "r")
    for a_i, a in enumerate(order):            # the cells with two crossings: join them
        for b in order[a_i + 1:]:
            pairs.append((two & has[a] & has[b], a, b))
    four = count == 4
    bl_tr = four & mask[i, j]                  # the blocked diagonal is (i, j)-(i+1, j+1)
    br_tl = four & ~mask[i, j]
    pairs += [(bl_tr, "b", "l"), (bl_tr, "t", "r"), (br_tl, "b", "r"), (br_tl, "t", "l")]
    if not any(sel.any() for sel, _, _ in pairs):
        return (np.empty((0, 2, 2)), np.empty((0, 2), dtype=np.int64)) if return_ids else np.empty((0, 2, 2))
    seg = np.concatenate([np.stack((pts[a][sel], pts[b][sel]), axis=1) for sel, a, b in pairs])
    end_ids = np.concatenate([np.stack((ids[a][sel], ids[b][sel]), axis=1) for sel, a, b in pairs])
    if return_ids:
        return seg, end_ids
    cell = np.concatenate([base[sel] for sel, _, _ in pairs])
    return _corners(seg, end_ids, cell, h) if corners else seg


def _corners(seg, end_ids, cell, h) -> np.ndarray:
    """Put back the corners of the obstacle that chords cut off.

    Each segment's two end points are crossings shared with the neighbouring segments of the
    polyline. Where the polyline runs straight into this cell on both sides (the three
    crossings before each end on one line, within `STRAIGHT` spacings: a polygonal
    obstacle's edge over two cells or more), the two lines meet at the corner: if they meet
    ahead of both crossings, in the cell or one next to it (a corner may poke between two
    free nodes into the next cell), and no grid node lies between the chord and that point,
    the segment becomes the two segments through it. Elsewhere (a smooth boundary, corners
    closer than two cells) the chord stays.
    """
    m = seg.shape[0]
    flat = end_ids.ravel()                      # position 2k + e: end e of segment k
    order = np.argsort(flat, kind="stable")
    sorted_ids = flat[order]
    same_next = np.r_[sorted_ids[1:] == sorted_ids[:-1], False]
    same_prev = np.r_[False, sorted_ids[1:] == sorted_ids[:-1]]
    partner = np.full(flat.size, -1)
    partner[order[same_next]] = order[np.flatnonzero(same_next) + 1]
    partner[order[same_prev]] = order[np.flatnonzero(same_prev) - 1]
    k = np.arange(m)
    dirs = []
    for e in (0, 1):
        q = partner[2 * k + e]                  # the neighbour at end e: its segment and its end there
        nk, ne = q // 2, q % 2
        q2 = np.where(q >= 0, partner[2 * nk + 1 - ne], -1)     # the neighbour's own other neighbour
        mk, me = q2 // 2, q2 % 2
        shared = seg[nk, ne]                    # this segment's end, in the neighbour's coordinates
        p0 = seg[nk, 1 - ne]                    # the neighbour's far end
        p1 = seg[mk, 1 - me] + (p0 - seg[mk, me])               # the one before, moved into the same coordinates
        d = shared - p1                         # the line through the two crossings before, into this cell
        off = p0 - p1
        norm = np.hypot(d[:, 0], d[:, 1])
        dev = np.abs(d[:, 0] * off[:, 1] - d[:, 1] * off[:, 0]) / np.where(norm > 0, norm, 1.0)
        straight = (q >= 0) & (q2 >= 0) & (norm > 0) & (dev <= STRAIGHT * float(np.min(h)))
        dirs.append(np.where(straight[:, None], d, np.nan))
    a, b = seg[:, 0], seg[:, 1]
    da, db = dirs                               # line A: a + s da (s >= 0); line B: b + u db (u >= 0)
    det = da[:, 0] * db[:, 1] - da[:, 1] * db[:, 0]
    rhs = b - a
    with np.errstate(invalid="ignore", divide="ignore"):
        s = (rhs[:, 0] * db[:, 1] - rhs[:, 1] * db[:, 0]) / det
        u = (rhs[:, 0] * da[:, 1] - rhs[:, 1] * da[:, 0]) / det
    with np.errstate(invalid="ignore"):
        x = a + s[:, None] * da
    near = np.all((x >= cell - h) & (x <= cell + 2 * h), axis=1)     # in this cell or one next to it
    scale = np.hypot(*np.moveaxis(da, -1, 0)) * np.hypot(*np.moveaxis(db, -1, 0))
    turn = np.abs(det) > 1e-6 * scale           # not (nearly) parallel: a real corner
    use = np.isfinite(s) & np.isfinite(u) & (s > 0) & (u > 0) & near & turn
    use[use] = ~_node_inside(a[use], x[use], b[use], cell[use], h)
    if not use.any():
        return seg
    keep = seg[~use]
    corner = x[use]
    out = [keep, np.stack((a[use], corner), axis=1), np.stack((corner, b[use]), axis=1)]
    return np.concatenate(out)


def _node_inside(a, x, b, cell, h) -> np.ndarray:
    """Whether a grid node (of the 4 x 4 around each cell) lies strictly inside triangle (a, x, b)."""
    out = np.zeros(a.shape[0], dtype=bool)
    for di in (-1, 0, 1, 2):
        for dj in (-1, 0, 1, 2):
            p = cell + h * np.array([di, dj])
            s1 = _side(a, x, p)
            s2 = _side(x, b, p)
            s3 = _side(b, a, p)
            out |= ((s1 > 0) & (s2 > 0) & (s3 > 0)) | ((s1 < 0) & (s2 < 0) & (s3 < 0))
    return out


def _side(p, q, r) -> np.ndarray:
    """The orientation of r about the line p -> q (rows), zero within rounding of the coordinates."""
    o = (q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1]) - (q[:, 1] - p[:, 1]) * (r[:, 0] - p[:, 0])
    tol = 1e-12 * (1.0 + np.abs(p).max(axis=1) + np.abs(q).max(axis=1)) ** 2
    return np.where(np.abs(o) <= tol, 0.0, o)


def _min_image(d: np.ndarray, length: np.ndarray, periodic) -> np.ndarray:
    for ax in range(2):
        if periodic[ax]:
            d[..., ax] -= length[ax] * np.round(d[..., ax] / length[ax])
    return d


def grid_distance(segments, lower, spacing, shape, periodic, reach: float | None = None,
                  return_nearest: bool = False, propagate: bool = True):
    """The unsigned distance from every grid node to the polyline ``segments``, shape (n0, n1).

    Exact within ``reach`` of the polyline: each segment measures its distance to
    the nodes of a window around it, and each node keeps the least (with the segment it
    came from). Farther out, each node takes the nearest in-band node (a Euclidean
    distance transform with indices) and measures its distance to that node's nearest
    boundary point (closest-point propagation: exact where the nearest boundary point
    is seen the same way from both nodes, and off by a small fraction of a spacing near
    the medial axis, far from the boundary).

    Parameters
    ----------
    segments : ndarray, shape (M, 2, 2), M >= 1
        Unwrapped (q0, q1) end points.
    lower : array_like, shape (2,)
    spacing : array_like, shape (2,)
    shape : (n0, n1)
    periodic : sequence of 2 bool
    reach : float, optional
        Half-width of the exact band, in C-space units; default `BAND` spacings of the
        coarser axis.
    return_nearest : bool
        Also return, shape (n0, n1), the index of the segment each node's exact distance is
        to (-1 beyond the band).
    propagate : bool
        Whether the distance beyond the band is propagated (else those nodes get ``inf``: all
        a caller needs to know when nothing acts beyond ``reach``).
    """
    from scipy import ndimage     # imported here: ``import pes_ref`` stays light
    lower, h = np.asarray(lower, float), np.asarray(spacing, float)
    shape = tuple(int(n) for n in shape)
    n = np.array(shape)
    length = h * n                                   # the period on a periodic axis
    a = segments[:, 0]
    e = segments[:, 1] - a
    ee = np.einsum("ij,ij->i", e, e)
    safe = np.where(ee > 0, ee, 1.0)
    reach = BAND * float(np.max(h)) if reach is None else float(reach)
    w = np.ceil(reach / h).astype(int)               # window half-width in nodes, per axis
    lo = np.floor((np.minimum(a, a + e) - lower) / h).astype(int) - w
    offsets = [np.arange(2 * w[ax] + 5) for ax in range(2)]      # a segment spans up to 3 cells
    oi, oj = np.meshgrid(*offsets, indexing="ij")
    oi, oj = oi.ravel(), oj.ravel()
    best = np.full(n[0] * n[1], np.inf)
    nearest = np.full(n[0] * n[1], -1)
    chunk = max(1, 4_000_000 // oi.size)
    for s in range(0, segments.shape[0], chunk):
        sl = slice(s, s + chunk)
        ii = lo[sl, 0, None] + oi                    # (m, W) node indices, unwrapped
        jj = lo[sl, 1, None] + oj
        pts = lower + h * np.stack((ii, jj), axis=-1)
        rel = pts - a[sl, None, :]
        t = np.clip(np.einsum("mwi,mi->mw", rel, e[sl]) / safe[sl, None], 0.0, 1.0)
        d = np.hypot(*np.moveaxis(rel - t[..., None] * e[sl, None, :], -1, 0))
        ok = d <= reach
        for ax, idx in ((0, ii), (1, jj)):
            if periodic[ax]:
                np.mod(idx, n[ax], out=idx)
            else:
                ok &= (idx >= 0) & (idx < n[ax])
        flat = (ii * n[1] + jj)[ok]
        d = d[ok]
        seg = np.broadcast_to(np.arange(s, min(s + chunk, segments.shape[0]))[:, None], ok.shape)[ok]
        np.minimum.at(best, flat, d)
        win = d == best[flat]
        nearest[flat[win]] = seg[win]
    inside = nearest >= 0
    band = nearest.reshape(shape).copy() if return_nearest else None
    if inside.all() or not propagate:
        return (best.reshape(shape), band) if return_nearest else best.reshape(shape)
    # closest-point propagation from the band to the rest
    node = np.stack(np.unravel_index(np.arange(best.size), shape), axis=1)
    foot = np.full((best.size, 2), np.nan)
    k = nearest[inside]
    rel = lower + h * node[inside] - a[k]
    t = np.clip(np.einsum("ij,ij->i", rel, e[k]) / safe[k], 0.0, 1.0)
    foot[inside] = a[k] + t[:, None] * e[k]
    pad = [(n[ax], n[ax]) if periodic[ax] else (0, 0) for ax in range(2)]
    outside = np.pad(~inside.reshape(shape), pad, mode="wrap")
    _, idx = ndimage.distance_transform_edt(outside, sampling=h, return_indices=True)
    crop = tuple(slice(p[0], p[0] + m) for p, m in zip(pad, shape))
    src0 = np.mod(idx[0][crop] - pad[0][0], n[0]).ravel()
    src1 = np.mod(idx[1][crop] - pad[1][0], n[1]).ravel()
    src = (src0 * n[1] + src1).reshape(shape)
    far = np.nonzero(~inside)[0]
    x = lower + h * node[far]

    def dist(candidate):
        diff = _min_image(x - foot[candidate], length, periodic)
        return np.hypot(diff[:, 0], diff[:, 1])

    d = dist(src.ravel()[far])
    for _ in range(REFINE):          # a neighbour's source may see a nearer boundary point
        changed = False
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                if di == dj == 0:
                    continue
                cand = np.roll(src, (-di, -dj), axis=(0, 1)).ravel()[far]
                dc = dist(cand)
                better = dc < d
                if better.any():
                    changed = True
                    d[better] = dc[better]
                    src.ravel()[far[better]] = cand[better]
        if not changed:
            break
    best[far] = d
    return (best.reshape(shape), band) if return_nearest else best.reshape(shape)


def mask_distance(mask, spacing, periodic) -> np.ndarray:
    """The coarse signed distance from the node mask alone, shape (n0, n1).

    ``scipy.ndimage.distance_transform_edt`` from every free node to the nearest blocked
    node, minus ``min(h)/2`` (the boundary taken halfway between the two), and minus the
    same construction from the free side at blocked nodes; periodic axes wrapped one
    period on each side. Quantized to the grid (see the module docstring): kept as the
    reference the boundary distance is measured against. Without any blocked (free) node
    every node gets + (-) the domain's diagonal ``|h * n|``.
    """
    from scipy import ndimage
    shape = np.shape(mask)
    if len(shape) != 2 or min(shape) < 1:
        raise checks.InputError("mask", f"mask must be a 2-d boolean grid, got shape {shape}")
    mask = checks.as_bool_array("mask", mask, shape=shape)
    h = checks.as_float_array("spacing", spacing, shape=(2,), positive=True)
    periodic = tuple(bool(p) for p in checks.as_bool_array("periodic", periodic, shape=(2,)))
    half = 0.5 * float(np.min(h))
    far = float(np.hypot(*(h * np.array(mask.shape))))
    if not mask.any() or mask.all():
        return np.full(mask.shape, -far if mask.all() else far)

    def edt(inside):
        pad = [(n, n) if p else (0, 0) for n, p in zip(inside.shape, periodic)]
        d = ndimage.distance_transform_edt(np.pad(inside, pad, mode="wrap"), sampling=h)
        return d[tuple(slice(p[0], p[0] + n) for p, n in zip(pad, inside.shape))]

    out = np.empty(mask.shape)
    out[~mask] = edt(~mask)[~mask] - half
    out[mask] = half - edt(mask)[mask]
    return out
