"""Free play: where a dynamic drive on the surface cannot follow rigid parts.

An output held by nothing but its contacts, free between two of them along its own axis (the
Geneva's wheel in the play its slots and locking arcs leave), moves differently on eq. (1)'s
surface and as rigid parts in a dynamic drive. When the driving contact lets it go while it
moves, the rigid output coasts on across its play, stops inelastically at the far side and
rattles there; eq. (1)'s smooth, conservative barrier slows it, bounces it back and centres it.
No setting of the surface closes that difference (lowering ``r_c`` below the play does not):
docs/rigid.md, "Play", measures it on the Geneva.

[`free_play`][pes_ref.rigid.play.free_play] finds it in the drive's own data. Along a dynamic
surface drive's steady travel (after its first turn, as ``max_ratio``'s), a sample is *in free
play* where

- the output dwells: ``|dq_out/dq_in|`` is below the drive's threshold (nothing drives it);
- its pocket is closed: along the output's axis, at the input's nearest grid node, blocked
  space bounds the free span that holds the output on both sides (a span that reaches the edge
  of a non-periodic grid, or a whole free turn, is open); the span is read between the zero
  crossings of the C-space's signed distance;
- no spring acts on the output there (one would hold it against one side of its play, where
  both models put it).

The play is the median span over those samples. It counts (a [`Play`][pes_ref.rigid.play.Play]
is returned) when the samples are at least `MIN_SHARE` of the steady travel and half the play
(how far the rigid output can sit from the pocket's middle, where the surface keeps it) is more
than `pes_ref.rigid.shipped.RMS_BAR` of the output's travel: the motion laws' agreement bar of
docs/rigid.md's table. ``analyze DEVICE.toml --mode dynamic`` prints it as one ``warning:`` line.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pes_ref.devices.drive import ratio
from pes_ref.rigid.shipped import RMS_BAR

__all__ = ["Play", "free_play", "pocket_spans", "MIN_SHARE"]

#: The share of the steady travel in free play below which it does not count (a passing dwell).
MIN_SHARE = 0.05


@dataclass(frozen=True)
class Play:
    """Free play the surface's dynamic drive cannot follow.

    Attributes
    ----------
    span : float
        The median free span of the output between its contacts where it dwells (its play).
    share : float
        The share of the steady travel the output dwells in free play.
    travel : float
        The output's travel over the steady travel (peak to peak).
    at : tuple of float
        A state (q0, q1) in free play, with a span near the median.
    output : int
        The output's axis.
    unit : str
        The output's unit (``rad`` for a rotation).
    """

    span: float
    share: float
    travel: float
    at: tuple
    output: int
    unit: str

    def message(self) -> str:
        """One line: what differs, why, and what to run instead."""
        u = f" {self.unit}" if self.unit else ""
        half = 0.5 * self.span
        return (f"the output q{self.output} dwells in {self.span:.3g}{u} of free play between its contacts "
                f"({self.share:.0%} of the steady travel, e.g. at q0 = {self.at[0]:.4g}, q1 = {self.at[1]:.4g}), "
                f"held by no spring: rigid parts coast across such play and stop inelastically at its far side, "
                f"where eq. (1)'s smooth, conservative barrier slows, bounces and centres the output, so this "
                f"dynamic drive's figures on the surface may differ from rigid parts' (the output's place by up "
                f"to half the play, {half:.3g}{u}, {half / self.travel:.2g} of its travel {self.travel:.4g}; no "
                f"r_c closes it); --engine rigid (or both) gives the parts' figures (docs/rigid.md, \"Play\")"
                if self.travel > 0 else
                f"the output q{self.output} dwells in {self.span:.3g}{u} of free play between its contacts, held "
                f"by no spring: rigid parts coast across such play where eq. (1)'s barrier centres the output; "
                f"--engine rigid (or both) gives the parts' figures (docs/rigid.md, \"Play\")")


def pocket_spans(device, cspace, axis: int, q_in, q_out) -> np.ndarray:
    """The free span of the output (axis ``1 - axis``) that holds it at each sample of a motion law:
    along the output's axis at the input's nearest grid node, between the zero crossings of the
    C-space's signed distance on either side of the output's nearest node; ``inf`` where the span is
    open (it reaches a non-periodic grid's edge, or the whole column is free), NaN where that node
    is blocked."""
    out = 1 - axis
    d = np.asarray(cspace.distance, dtype=float)
    nodes = [device.grid.nodes(k) for k in range(2)]
    h = float(device.spacing[out])
    n = d.shape[out]
    periodic = bool(device.periodic[out])

    def nearest(k, q):
        x = (np.asarray(q, dtype=float) - nodes[k][0]) / float(device.spacing[k])
        i = np.rint(x).astype(int)
        return np.mod(i, d.shape[k]) if device.periodic[k] else np.clip(i, 0, d.shape[k] - 1)

    cols, rows = nearest(axis, q_in), nearest(out, q_out)
    spans = np.full(cols.size, np.nan)
    for c in np.unique(cols):
        column = np.take(d, c, axis=axis)
        blocked = np.nonzero(column <= 0.0)[0]
        pick = np.nonzero(cols == c)[0]
        for s in pick:
            j = rows[s]
            if column[j] <= 0.0:
                continue
            if blocked.size == 0:
                spans[s] = np.inf
                continue
            k = np.searchsorted(blocked, j)
            if periodic:
                up, down = (blocked[k] if k < blocked.size else blocked[0] + n), \
                           (blocked[k - 1] if k > 0 else blocked[-1] - n)
            elif k == 0 or k == blocked.size:
                spans[s] = np.inf
                continue
            else:
                up, down = blocked[k], blocked[k - 1]
            # the crossing between the last free node and the first blocked one, on each side
            f_up = column[(up - 1) % n] / (column[(up - 1) % n] - column[up % n])
            f_down = column[(down + 1) % n] / (column[(down + 1) % n] - column[down % n])
            spans[s] = (up - 1 - (down + 1) + f_up + f_down) * h
    return spans


def free_play(device, result, cspace=None):
    """The free play a dynamic surface drive cannot follow ([`Play`][pes_ref.rigid.play.Play]), or
    None: a quasistatic drive, an output held by a spring, or play too small or too brief to count
    (module docstring).

    Parameters
    ----------
    device : pes_ref.devices.device.Device
    result : pes_ref.devices.drive.DriveResult
        The drive on the surface.
    cspace : pes_ref.devices.cspace.CSpace, optional
        The device's computed C-space (default ``device.cspace()``).
    """
    if result.mode != "dynamic" or result.q_in.size < 2:
        return None
    cs = device.cspace() if cspace is None else cspace
    axis, out = result.drive, 1 - result.drive
    steady = np.abs(result.q_in - result.q_in[0]) >= result.steady_from * (1 - 1e-9)
    q_in, q_out = result.q_in[steady], result.q_out[steady]
    if q_in.size < 2:
        return None
    dwell = np.abs(ratio(result.q_in, result.q_out))[steady] < result.threshold
    held = np.zeros(q_out.size, dtype=bool)
    length = float(device.upper[out] - device.lower[out])
    for spring in device.springs:
        if spring.axis == out:
            held |= spring.force(q_out, length, bool(device.periodic[out])) != 0.0
    spans = pocket_spans(device, cs, axis, q_in, q_out)
    free = dwell & ~held & np.isfinite(spans)
    share = float(np.mean(free))
    if share < MIN_SHARE:
        return None
    span = float(np.median(spans[free]))
    travel = float(np.ptp(q_out))
    if 0.5 * span <= RMS_BAR * travel:
        return None
    k = np.nonzero(free)[0][int(np.argmin(np.abs(spans[free] - span)))]
    at = [0.0, 0.0]
    at[axis], at[out] = float(q_in[k]), float(q_out[k])
    unit = "rad" if device.parts[out].periodic else ""
    return Play(span, share, travel, (at[0], at[1]), out, unit)
