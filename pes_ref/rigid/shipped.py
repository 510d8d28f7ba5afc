"""The shipped devices driven on both engines, against each other and the analytic answers:
the table of ``docs/rigid.md`` (``make rigid-devices``).

Each entry of `DRIVES` is one drive of a shipped device (the Geneva, cam-follower and drum-cam
examples, the ratchet and the dart gun) with what is known of its answer in closed form.
[`measure`][pes_ref.rigid.shipped.measure] runs it on the surface and the rigid engine in one mode
and states the steady advance per cycle (the mean over the turns after the first,
[`pes_ref.rigid.engines.steady_advance`][pes_ref.rigid.engines.steady_advance]), the difference of
the two motion laws after the first turn
([`pes_ref.rigid.engines.compare_laws`][pes_ref.rigid.engines.compare_laws]; its mean is the surface
barrier's standoff, stated apart), each engine's law against the analytic one where there is one,
and both run times.
"""
from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass

import numpy as np

from pes_ref.devices.device_file import load_device, shipped_device
from pes_ref.devices.drive import drive
from pes_ref.rigid.engines import ENGINES, compare_laws, cycle_advances, stall_from_runs, steady_advance

__all__ = ["Case", "DRIVES", "MODES", "measure", "measure_all", "markdown_table", "rewrite", "BEGIN", "END",
           "ADVANCE_BAR", "RMS_BAR"]

#: The bar: advances per cycle within 1 degree (or 1% of the output's travel per cycle, the larger) ...
ADVANCE_BAR = math.radians(1.0)
#: ... and motion laws within this share of the output's travel (RMS, the standoff removed).
RMS_BAR = 0.01
#: The drive's modes, each measured.
MODES = ("quasistatic", "dynamic")


@dataclass(frozen=True)
class Case:
    """One drive of a shipped device: ``source`` a file under the repository's root or a shipped
    device's name; ``advance`` the analytic advance per cycle (None: none known); ``law`` the
    analytic output as a function of the input (None: none known)."""

    name: str
    source: str
    axis: int
    load: float
    cycles: int | None
    start: tuple | None
    advance: float | None
    law: object = None
    note: str = ""

    def device(self, root: str):
        """The device this drive runs: the file ``source`` under ``root``, or the shipped device of that name."""
        if self.source.endswith(".toml"):
            return load_device(os.path.join(root, self.source))
        return shipped_device(self.source)


def _cam_lift(q0):
    return 0.5 + 0.2 * np.sin(q0)


def _geneva_wheel(q0):
    """The 4-slot Geneva's wheel angle for crank angle ``q0`` (no play; the wheel at 0 at q0 = 0):
    the pin (radius a = sin 45 degrees, at angle q0 + pi) drives the slot it is in from
    q0 = 3 pi / 4 to 5 pi / 4 of each turn, turning the wheel by -pi / 2; locked elsewhere."""
    q0 = np.asarray(q0, dtype=float)
    a = math.sin(math.pi / 4)
    k = np.floor(q0 / (2.0 * math.pi))
    r = q0 - 2.0 * math.pi * k
    alpha = r - math.pi                                  # the pin's angle from the line of centres
    beta = np.arctan2(a * np.sin(alpha), a * np.cos(alpha) - 1.0) % (2.0 * math.pi)   # the slot's direction
    phi = np.where(r < 0.75 * math.pi, 0.0, np.where(r > 1.25 * math.pi, -0.5 * math.pi, beta - 1.25 * math.pi))
    return -0.5 * math.pi * k + phi


#: The drives of the table.
DRIVES = (
    Case("geneva4", "examples/devices/geneva4.toml", 0, 1.0, 2, None, -math.pi / 2, _geneva_wheel,
         note="a quarter turn of the wheel per crank turn, the pin's kinematics in between"),
    Case("cam_follower", "examples/devices/cam_follower.toml", 0, 0.5, 2, None, 0.0, _cam_lift,
         note="lift q1 = R + e sin q0 = 0.5 + 0.2 sin q0, no net advance"),
    Case("drum_cam", "examples/devices/drum_cam.toml", 1, 1.0, 2, (-1.0, 0.0), 1.0,
         note="one lead (1) per drum turn; started at the groove's middle at q1 = 0 so two turns fit the grid"),
    Case("ratchet", "ratchet", 0, 1.0, 2, None, 0.0,
         note="the pawl rides each tooth and falls back: no net advance per wheel turn"),
    Case("dartgun", "dartgun", 0, 30.0, None, None, None,
         note="the dart pushed back until the tooth in its notch stops it at q0 = 2 (a jam of the geometry)"),
)


def _law_vs(result, law) -> tuple:
    """(RMS, mean) of ``result``'s law minus the analytic ``law`` after the first turn."""
    s = np.abs(result.q_in - result.q_in[0])
    keep = s >= 2.0 * math.pi - 1e-9 if s[-1] >= 4.0 * math.pi - 1e-9 else np.ones(s.size, bool)
    d = result.q_out[keep] - law(result.q_in[keep])
    return float(np.sqrt(np.mean(d * d))), float(np.mean(d))


def measure(case: Case, mode: str, root: str = ".", shape=None) -> dict:
    """``case`` driven in ``mode`` on both engines: a row of the table (plain values)."""
    device = case.device(root)
    if shape is not None:
        device = device.replace(shape=tuple(shape))
    t = time.perf_counter()
    device.cspace()
    device.surface()
    t_build = time.perf_counter() - t
    runs, times = {}, {}
    for name in ENGINES:
        t = time.perf_counter()
        runs[name] = drive(device, case.axis, case.load, mode, case.cycles, case.start,
                           engine=ENGINES[name].hook())
        times[name] = time.perf_counter() - t
    s, r = runs["surface"], runs["rigid"]
    diff = compare_laws(s, r)
    row = {"device": case.name, "mode": mode, "grid": "x".join(map(str, device.shape)),
           "advance_surface": _advance(s), "advance_rigid": _advance(r), "advance_analytic": case.advance,
           "output_travel": diff.output_travel, "rms": diff.rms, "offset": diff.offset,
           "rms_centred": diff.rms_centred, "rms_centred_share": diff.share(diff.rms_centred),
           "stop_surface": s.stop_reason, "stop_rigid": r.stop_reason,
           "stopped_surface": s.stopped_at, "stopped_rigid": r.stopped_at,
           "time_cspace": t_build, "time_surface": times["surface"], "time_rigid": times["rigid"],
           "steps_surface": s.steps, "steps_rigid": r.steps,
           "stall": stall_from_runs(device, s, r).kind if s.stop_reason == "stalled" else ""}
    if case.law is not None:
        row["law_rms_surface"], row["law_offset_surface"] = _law_vs(s, case.law)
        row["law_rms_rigid"], row["law_offset_rigid"] = _law_vs(r, case.law)
    row["bar"] = _bar(row)
    return row


def _advance(result):
    """The steady advance per cycle; None for a periodic input that stopped short of a turn."""
    if result.periodic_input and cycle_advances(result).size == 0:
        return None
    return steady_advance(result)


def _bar(row: dict) -> str:
    """Which parts of the bar a row meets: the advances within `ADVANCE_BAR` (or 1% of the
    output's travel per cycle, the larger) of each other and of the analytic one, the laws
    within `RMS_BAR` of the travel (RMS, the standoff removed)."""
    tol = max(ADVANCE_BAR, 0.01 * row["output_travel"])
    adv = [row["advance_surface"], row["advance_rigid"]]
    if row["advance_analytic"] is not None:
        adv.append(row["advance_analytic"])
    ok_adv = None not in adv and max(adv) - min(adv) <= tol
    ok_law = bool(row["rms_centred_share"] <= RMS_BAR)
    return f"advance {'yes' if ok_adv else 'no'}, law {'yes' if ok_law else 'no'}"


def measure_all(root: str = ".", cases=DRIVES, modes=MODES, report=None) -> list:
    """Every case in every mode (``report(row)`` after each)."""
    rows = []
    for case in cases:
        for mode in modes:
            rows.append(measure(case, mode, root))
            if report is not None:
                report(rows[-1])
    return rows


def _f(v, digits=4) -> str:
    return "-" if v is None else f"{v:.{digits}g}"


def markdown_table(rows: list) -> str:
    """The rows as the Markdown table of ``docs/rigid.md``."""
    head = ("| device | mode | advance per cycle: surface / rigid / analytic | law RMS rigid-surface, standoff "
            "removed (share of travel) | standoff: mean rigid-surface | law RMS against the analytic: surface / "
            "rigid | stop: surface / rigid | bar | time s: surface / rigid |")
    out = [head, "|" + "---|" * 9]
    for r in rows:
        stop = f"{r['stop_surface']} / {r['stop_rigid']}"
        if r["stall"]:
            stop += f" (stall: {r['stall']})"
        law = f"{_f(r['law_rms_surface'], 3)} / {_f(r['law_rms_rigid'], 3)}" if "law_rms_rigid" in r else "-"
        adv = " / ".join("stalled" if v is None and k != "advance_analytic" else _f(v)
                         for k, v in ((k, r[k]) for k in ("advance_surface", "advance_rigid", "advance_analytic")))
        out.append(f"| {r['device']} | {r['mode']} | {adv} | {_f(r['rms_centred'], 3)} "
                   f"({_f(r['rms_centred_share'], 2)}) | {_f(r['offset'], 3)} | {law} | {stop} | {r['bar']} | "
                   f"{r['time_surface']:.3g} / {r['time_rigid']:.3g} |")
    return "\n".join(out)


#: The lines of docs/rigid.md between which `markdown_table`'s table goes.
BEGIN = "<!-- rigid-devices:begin (make rigid-devices writes what follows) -->"
END = "<!-- rigid-devices:end -->"


def rewrite(text: str, block: str) -> str:
    """``text`` with the lines between `BEGIN` and `END` replaced by ``block``
    (a ValueError when either line is missing, twice, or they are out of order)."""
    lines = text.split("\n")
    at = {m: [i for i, line in enumerate(lines) if line.strip() == m] for m in (BEGIN, END)}
    for marker, found in at.items():
        if len(found) != 1:
            raise ValueError(f"expected the line {marker!r} once, found it {len(found)} times")
    begin, end = at[BEGIN][0], at[END][0]
    if end < begin:
        raise ValueError(f"the line {END!r} comes before {BEGIN!r}")
    return "\n".join(lines[:begin + 1] + block.split("\n") + lines[end:])
