"""The engines a device's analysis runs on, by name, and one analysis on two engines side by side.

An *engine* runs a scene of a device: ``run(device, scene, x0, v0=None) -> Trajectory``
([`pes_ref.core.integrator.Trajectory`][pes_ref.core.integrator.Trajectory]). `ENGINES` holds them by name:

- ``surface``: the potential energy surface, eq. (1) of the C-space plus the springs
  ([`pes_ref.core.scene.simulate`][pes_ref.core.scene.simulate] of the scene; the device is not read);
- ``rigid``: the parts in rigid contact ([`pes_ref.rigid.engine.simulate`][pes_ref.rigid.engine.simulate], pymunk).

``both`` (`BOTH`) runs an analysis on each engine and states the two side by side
([`side_by_side`][pes_ref.rigid.engines.side_by_side]) with their difference; for a drive also the difference of the two
motion laws ([`compare_laws`][pes_ref.rigid.engines.compare_laws]).

A quasistatic surface drive that stalls is looked at with the rigid engine
([`tell_stall`][pes_ref.rigid.engines.tell_stall]): from the stall point, the rigid parts under the same load either
pass (the stall came from the grid's resolution: the barrier of a channel the grid
cannot resolve holds the input) or stop too (a jam of the geometry).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pes_ref.core import checks
from pes_ref.core.scene import simulate as surface_simulate
from pes_ref.devices.drive import JAM_CELLS, JAM_FRACTION, drive_scene
from pes_ref.rigid.bodies import require_pymunk
from pes_ref.rigid.engine import StartBlockedError, simulate as rigid_simulate

__all__ = ["Engine", "ENGINES", "BOTH", "engine_names", "require_engines", "engine_facts", "cycle_advances",
           "steady_advance", "stated_lines", "fact_lines", "law_lines", "LawDifference", "compare_laws", "side_by_side", "Stall", "tell_stall",
           "stall_from_runs", "PASS_CELLS", "PROBE_WINDOWS"]


def _surface_run(device, scene, x0, v0=None):
    return surface_simulate(scene, x0, v0)


def _rigid_run(device, scene, x0, v0=None):
    return rigid_simulate(device, scene, x0, v0)


def _nothing() -> None:
    return None


@dataclass(frozen=True)
class Engine:
    """An engine: ``run(device, scene, x0, v0=None) -> Trajectory``; ``require()`` raises
    [`pes_ref.devices.geometry.MissingExtraError`][pes_ref.core.runtime.extras.MissingExtraError]
    (with its pip line) when the engine's extra is not installed; ``contact``: its figures state the
    engine and the contact's restitution and friction; ``native``: the analyses' own runs (an
    analysis on it is called as it always was, without a ``run``); ``prefix``: what starts the names
    of a realized device's figures on it (``evaluate --realized``: ``realized_in_band_fraction`` on
    eq. (1) of the parts, ``rigid_in_band_fraction`` in rigid contact,
    [`pes_ref.realize.evaluation.evaluate_realized`][pes_ref.realize.evaluation.evaluate_realized])."""

    name: str
    run: object
    require: object
    contact: bool
    native: bool = False
    prefix: str = ""

    def hook(self):
        """What an analysis' ``run=`` (or a drive's ``engine=``) takes: None for the native engine."""
        return None if self.native else self.run


#: The engines by name (``analyze --engine NAME``).
ENGINES = {"surface": Engine("surface", _surface_run, _nothing, False, native=True, prefix="realized_"),
           "rigid": Engine("rigid", _rigid_run, require_pymunk, True, prefix="rigid_")}
#: The choice that runs every engine of `ENGINES` and states them side by side.
BOTH = "both"


def engine_names(choice: str) -> tuple:
    """The engines ``choice`` runs: every one for `BOTH`, else the one named (a keyed
    [`InputError`][pes_ref.core.checks.InputError] naming ``engine`` for another word)."""
    if choice == BOTH:
        return tuple(ENGINES)
    if choice not in ENGINES:
        raise checks.InputError("engine", f"engine must be one of {', '.join((*ENGINES, BOTH))}, got {choice!r}")
    return (choice,)


def require_engines(names) -> None:
    """Every named engine's extra is installed (else the first missing one's pip line)."""
    for name in names:
        ENGINES[name].require()


def engine_facts(device, name: str) -> dict:
    """What a run on engine ``name`` states beside its figures: the engine's name and, for the
    rigid engine, the contact's ``restitution`` and ``friction`` (the device's ``[rigid]``)."""
    facts = {"engine": name}
    if ENGINES[name].contact:
        facts.update(restitution=float(device.restitution), friction=float(device.friction))
    return facts


def stated_lines(device, name: str) -> list:
    """The lines an engine adds to an analysis' own: [`engine_facts`][pes_ref.rigid.engines.engine_facts] for an engine
    that
    states its contact (the rigid one), none for the surface (its lines as they always were)."""
    return fact_lines(engine_facts(device, name)) if ENGINES[name].contact else []


def fact_lines(facts: dict) -> list:
    """``name: value unit`` lines of [`engine_facts`][pes_ref.rigid.engines.engine_facts] (the engine's name has no unit)."""
    units = {"engine": "", "restitution": " 1", "friction": " 1"}
    return [f"{k}: {v:.6g}{units[k]}" if isinstance(v, float) else f"{k}: {v}{units[k]}" for k, v in facts.items()]


# =========================================================================== motion laws

def cycle_advances(result) -> np.ndarray:
    """The output's change over each whole turn of a periodic input: the drive's own
    ``advance_per_cycle_each`` ([`pes_ref.devices.drive.DriveResult`][pes_ref.devices.drive.DriveResult]; empty for a
    translation input or a run shorter than a turn)."""
    return np.asarray(result.advance_per_cycle_each, dtype=float)


def steady_advance(result) -> float:
    """The advance per cycle without the start's transient: the mean over the whole turns
    after the first (the first turn's when there is one turn; the drive's own figure, per
    unit of input travel, for a translation input)."""
    adv = cycle_advances(result)
    if adv.size == 0:
        return float(result.advance_per_cycle)
    return float(np.mean(adv[1:] if adv.size > 1 else adv))


@dataclass(frozen=True)
class LawDifference:
    """Two motion laws on the samples they share (the same input positions: both drives sample
    the input every half spacing from the same start), ``b - a``.

    Attributes
    ----------
    samples : int
    output_travel : float
        The larger of the two laws' ranges of the output (output unit): what the RMS is a share of.
    rms : float
        The RMS of the difference (output unit).
    offset : float
        Its mean (output unit): a constant standoff, such as the surface barrier's distance
        from a wall the rigid parts touch.
    rms_centred : float
        The RMS after removing ``offset`` (output unit).
    """

    samples: int
    output_travel: float
    rms: float
    offset: float
    rms_centred: float

    def share(self, value: float) -> float:
        """``value`` as a share of `output_travel` (nan for no travel)."""
        return value / self.output_travel if self.output_travel > 0 else float("nan")

    def summary(self) -> dict:
        """The difference's figures as plain JSON-able values (the ``difference`` of ``analyze
        --engine both --json``)."""
        return {"samples": self.samples, "output_travel": self.output_travel, "rms": self.rms,
                "rms_share": self.share(self.rms), "offset": self.offset, "rms_centred": self.rms_centred,
                "rms_centred_share": self.share(self.rms_centred)}


def compare_laws(a, b) -> LawDifference:
    """The difference ``b - a`` of two drives' motion laws ([`LawDifference`][pes_ref.rigid.engines.LawDifference]) on
    the
    samples both reached; after the first turn when both made two turns or more of a periodic
    input (the start's transient left out: parts that start apart, or a part set down at the
    barrier's standoff that the rigid parts do not keep, settle within it)."""
    n = min(a.q_in.size, b.q_in.size)
    if n == 0:
        return LawDifference(0, 0.0, float("nan"), float("nan"), float("nan"))
    first = 0
    if a.periodic_input and min(cycle_advances(a).size, cycle_advances(b).size) >= 2:
        first = int(np.searchsorted(np.abs(a.q_in[:n] - a.q_in[0]), 2.0 * math.pi - 1e-9))
    qa, qb = a.q_out[first:n], b.q_out[first:n]
    d = qb - qa
    offset = float(np.mean(d))
    travel = max(float(np.ptp(qa)), float(np.ptp(qb)))
    return LawDifference(n - first, travel, float(np.sqrt(np.mean(d * d))), offset,
                         float(np.sqrt(np.mean((d - offset) ** 2))))


def law_lines(diff: LawDifference, label: str) -> list:
    """``name[label]: value unit`` lines of a [`LawDifference`][pes_ref.rigid.engines.LawDifference]."""
    t = diff.output_travel
    return [f"motion_law_rms[{label}]: {diff.rms:.6g} output-unit ({diff.share(diff.rms):.3g} of the output's "
            f"travel {t:.6g})",
            f"motion_law_offset[{label}]: {diff.offset:.6g} output-unit (the mean difference: the barrier's "
            f"standoff)",
            f"motion_law_rms_centred[{label}]: {diff.rms_centred:.6g} output-unit "
            f"({diff.share(diff.rms_centred):.3g} of the output's travel, the offset removed)",
            f"motion_law_samples[{label}]: {diff.samples} samples"]


def _split(line: str) -> tuple:
    name, _, rest = line.partition(": ")
    value, _, unit = rest.partition(" ")
    return name, rest, value, unit


def _number(text: str):
    try:
        value = float(text)
    except ValueError:
        return None
    return value if text not in ("True", "False") else None


def side_by_side(lines: dict) -> list:
    """The ``name: value unit`` lines of one analysis on two engines (``{engine: lines}``, two
    entries ``a``, ``b``) as one list: a line both print the same once; any other as
    ``name[a]``, ``name[b]`` and, when both values are numbers in the same unit,
    ``name[b-a]`` (their difference)."""
    (a, la), (b, lb) = lines.items()
    rest_b = {_split(line)[0]: line for line in lb}
    out, seen = [], set()
    for line in la:
        name, rest, value, unit = _split(line)
        seen.add(name)
        other = rest_b.get(name)
        if other == line:
            out.append(line)
            continue
        out.append(f"{name}[{a}]: {rest}")
        if other is None:
            continue
        _, rest2, value2, unit2 = _split(other)
        out.append(f"{name}[{b}]: {rest2}")
        x, y = _number(value), _number(value2)
        if x is not None and y is not None and unit == unit2:
            out.append(f"{name}[{b}-{a}]: {y - x:.6g} {unit}")
    out += [f"{_split(line)[0]}[{b}]: {_split(line)[1]}" for line in lb if _split(line)[0] not in seen]
    return out


# =========================================================================== a stall told apart

#: The rigid parts pass a stall point when their input gets this many input spacings past it,
#: plus eq. (1)'s cut-off r_c (the surface's input stops up to about r_c short of a wall the
#: rigid parts touch: that much is no passing) ...
PASS_CELLS = 2.0
#: ... or is still moving at the end of this many of the drive's stall windows (the steps in
#: which the unresisted input would move `pes_ref.devices.drive.JAM_CELLS` spacings):
#: still moving by the drive's own test of a stall.
PROBE_WINDOWS = 4


@dataclass(frozen=True)
class Stall:
    """What the rigid engine says of a surface drive's stall.

    ``kind``: ``"resolution"`` (the rigid parts pass: the stall is the grid's, not the
    geometry's), ``"jam"`` (the rigid parts stop too) or ``"unknown"`` (the rigid engine could
    not start there, or is not installed); ``rigid_travel``: how far the rigid input got past
    the stall point (input unit); ``reason``: why the kind is unknown."""

    kind: str
    rigid_travel: float = float("nan")
    reason: str = ""

    def line(self) -> str:
        """``stall: resolution (the rigid parts pass)`` and the like."""
        if self.kind == "resolution":
            return "stall: resolution (the rigid parts pass)"
        if self.kind == "jam":
            return "stall: jam (the rigid parts stop too)"
        return f"stall: unknown ({self.reason})"

    def summary(self) -> dict:
        """The verdict as plain JSON-able values: ``stall`` (its kind) and ``stall_rigid_travel``."""
        return {"stall": self.kind, "stall_rigid_travel": self.rigid_travel}


def _passing(device, axis: int) -> float:
    """How far past a stall point the rigid input must get to pass it (`PASS_CELLS`)."""
    return PASS_CELLS * float(device.spacing[axis]) + float(device.r_c)


def stall_from_runs(device, surface, rigid) -> Stall:
    """The stall of the surface drive ``surface`` told apart by a whole rigid drive ``rigid`` from
    the same start: resolution when the rigid drive went the whole way or its input got
    `PASS_CELLS` spacings and r_c past where the surface input stalled."""
    past = float(rigid.input_travel - surface.input_travel)
    passed = rigid.stop_reason == "done" or past >= _passing(device, surface.drive)
    return Stall("resolution" if passed else "jam", past)


def tell_stall(device, result) -> Stall:
    """The stall of the surface drive ``result`` told apart by the rigid engine: the rigid parts
    run from the stall point under the same load and mode for `PROBE_WINDOWS` stall
    windows; they pass when their input gets `PASS_CELLS` input spacings and r_c on, or
    is still moving in the last window (it has not stalled by the drive's test)."""
    try:
        require_pymunk()
    except ImportError as exc:
        return Stall("unknown", reason=f"the rigid engine tells a stall of resolution from a jam: {exc}")
    axis, sign = result.drive, (1.0 if result.load > 0 else -1.0)
    _, per_spacing = drive_scene(device, axis, result.load, result.mode, 1)
    window = max(1, int(math.ceil(JAM_CELLS * per_spacing)))
    steps = PROBE_WINDOWS * window
    scene, _ = drive_scene(device, axis, result.load, result.mode, steps)
    x0 = np.asarray(result.stopped_at, dtype=float)[None, :]
    try:
        x = ENGINES["rigid"].run(device, scene, x0).x[:, 0, axis]
    except StartBlockedError:
        return Stall("unknown", reason="the parts overlap at the stall point: the rigid engine cannot start there")
    except checks.InputError as exc:        # a step the rigid parts cannot take (too fast a part)
        return Stall("unknown", reason=f"the rigid engine cannot run from the stall point: {exc}")
    p = sign * (x - x0[0, axis])
    past = float(np.max(p))
    moving = p[-1] - p[-1 - window] >= JAM_FRACTION * float(device.spacing[axis])
    return Stall("resolution" if moving or past >= _passing(device, axis) else "jam", past)
