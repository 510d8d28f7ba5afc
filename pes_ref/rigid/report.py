"""A drive on one engine or two, as the ``analyze`` command reports it
([`DriveReport`][pes_ref.rigid.report.DriveReport]): its ``name: value unit`` lines, its figures
as JSON, its motion law(s) as CSV, what the rigid parts say of a surface drive's stall, and its
warnings (free play a dynamic drive on the surface cannot follow: `pes_ref.rigid.play`).

[`drive_on`][pes_ref.rigid.report.drive_on] runs the drive on each engine named, by the engines'
registry (`pes_ref.rigid.engines.ENGINES`); the command parses,
prints and writes, and nothing else.
"""
from __future__ import annotations

import numpy as np

from pes_ref.rigid.engines import (ENGINES, compare_laws, engine_facts, law_lines, side_by_side, stall_from_runs,
                                   stated_lines, tell_stall)
from pes_ref.rigid.play import free_play

__all__ = ["drive_on", "DriveReport"]


def drive_on(names, device, axis: int, load: float, mode: str, cycles, start, threshold: float, progress=None) -> dict:
    """[`pes_ref.devices.drive.drive`][pes_ref.devices.drive.drive] on each engine of ``names``, by
    name (the surface's as it always ran: its engine's hook is None)."""
    from pes_ref.devices.drive import drive
    return {name: drive(device, axis, load, mode, cycles, start, threshold, progress, engine=ENGINES[name].hook())
            for name in names}


def _stall(device, results: dict):
    """What the rigid engine says of the surface drive's stall (None when it did not stall):
    the rigid drive of both engines, else a rigid run from the stall point
    ([`pes_ref.rigid.engines.tell_stall`][pes_ref.rigid.engines.tell_stall]; unknown without pymunk)."""
    surface = results.get("surface")
    if surface is None or surface.stop_reason != "stalled":
        return None
    if "rigid" in results:
        return stall_from_runs(device, surface, results["rigid"])
    return tell_stall(device, surface)


class DriveReport:
    """The report of a drive on one or two engines.

    Parameters
    ----------
    device : pes_ref.devices.device.Device
    results : dict
        Engine name -> [`DriveResult`][pes_ref.devices.drive.DriveResult] ([`drive_on`][pes_ref.rigid.report.drive_on]).

    Attributes
    ----------
    stall : object or None
        What the rigid parts say of the surface drive's stall (None: it did not stall).
    """

    def __init__(self, device, results: dict):
        self.device, self.results = device, dict(results)
        self.stall = _stall(device, self.results)

    def lines(self) -> list:
        """The drive's lines: one engine's (the rigid engine's with its contact), or both side by
        side with the two motion laws' difference; then the stall's verdict."""
        lines = {name: r.as_lines() + stated_lines(self.device, name) for name, r in self.results.items()}
        if len(lines) == 1:
            out = next(iter(lines.values()))
        else:
            (a, ra), (b, rb) = self.results.items()
            out = side_by_side(lines) + law_lines(compare_laws(ra, rb), f"{b}-{a}")
        return out + ([self.stall.line()] if self.stall is not None else [])

    def warnings(self) -> list:
        """A line for each thing that makes the surface's figures say something else than rigid parts
        would: the free play a dynamic drive on the surface cannot follow
        ([`pes_ref.rigid.play.free_play`][pes_ref.rigid.play.free_play])."""
        surface = self.results.get("surface")
        play = None if surface is None else free_play(self.device, surface)
        return [] if play is None else [play.message()]

    def summary(self) -> dict:
        """The JSON: one engine's figures with its facts, or ``{"engine": "both", name: figures, ...,
        "difference": ...}``; the stall's verdict when the surface drive stalled."""
        figures = {name: {**r.summary(), **engine_facts(self.device, name)} for name, r in self.results.items()}
        if len(figures) == 1:
            out = next(iter(figures.values()))
        else:
            (a, ra), (b, rb) = self.results.items()
            diff = {k: getattr(rb, k) - getattr(ra, k) for k in ("advance_per_cycle", "moving_fraction", "max_ratio")}
            out = {"engine": "both", **figures, "difference": {"of": f"{b} - {a}", **diff,
                                                               "motion_law": compare_laws(ra, rb).summary()}}
        if self.stall is not None:
            out.update(self.stall.summary())
        return out

    def csv(self) -> bytes:
        """The motion law(s): ``q_in,q_out`` for one engine; for two, ``q_in,q_out_<engine>,...``
        on the input's samples (the same for every engine: every half input spacing from the
        start), ``nan`` past where an engine's input got."""
        if len(self.results) == 1:
            r = next(iter(self.results.values()))
            lines = ["q_in,q_out"] + [f"{a:.17g},{b:.17g}" for a, b in zip(r.q_in, r.q_out)]
            return ("\n".join(lines) + "\n").encode()
        longest = max(self.results.values(), key=lambda r: r.q_in.size)
        cols = [np.full(longest.q_in.size, np.nan) for _ in self.results]
        for col, r in zip(cols, self.results.values()):
            col[:r.q_in.size] = r.q_out
        lines = [",".join(["q_in"] + [f"q_out_{name}" for name in self.results])]
        lines += [",".join(f"{v:.17g}" for v in row) for row in zip(longest.q_in, *cols)]
        return ("\n".join(lines) + "\n").encode()
