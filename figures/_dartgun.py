"""The dart gun runs that Figs. 2-4 draw, all through :mod:`pes_ref.devices.dartgun`."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from pes_ref.devices import dartgun

#: The reload push and the fire time (force units, seconds): the defaults of
#: ``python -m pes_ref analyze dartgun``; the trigger forces drawn are two of its four.
RELOAD_FORCE, RELOAD_TIME, FIRE_TIME = 30.0, 1.0, 0.3
#: The dart gun's grid under --smoke: about the coarsest on which the default reload still
#: latches (on 61 x 41 it does not), so the smoke run takes the same code paths.
SMOKE_SHAPE = (91, 61)


class DartGun(NamedTuple):
    device: object               # pes_ref.devices.device.Device
    blocked: np.ndarray          # (n0, n1) bool, the C-space
    distance: np.ndarray         # (n0, n1) signed distance to its boundary
    surface: object              # pes_ref.Surface
    rest: np.ndarray             # (1, 2) the unloaded rest state


class Dims(NamedTuple):
    """What the drawings need of the dart gun, read off its parts' geometry (at q = 0) and grid."""

    dart_length: float
    dart_height: float
    tooth_x: float
    tooth_width: float
    tooth_length: float
    lower: np.ndarray
    upper: np.ndarray


def dims(device) -> Dims:
    """The drawing dimensions of the dart gun ``device``."""
    tol = device.grid.tolerance
    dx0, _, dx1, dy1 = device.parts[0].geometry(tol).bounds
    tx0, ty0, tx1, _ = device.parts[1].geometry(tol).bounds
    return Dims(dx1 - dx0, dy1, tx0, tx1 - tx0, -ty0, device.lower, device.upper)


class Runs(NamedTuple):
    reload: dartgun.ReloadResult
    latched: np.ndarray          # (1, 2) the latched equilibrium the reload reaches
    fire: dartgun.FireResult


def build(smoke: bool) -> DartGun:
    """The shipped dart gun (on the coarse smoke grid under ``smoke``), its C-space and surface."""
    d = dartgun.dartgun_device()
    if smoke:
        d = d.replace(shape=SMOKE_SHAPE)
    cs = d.cspace()
    return DartGun(d, cs.blocked, cs.distance, d.surface(), dartgun.dartgun_start(d))


def reload_and_fire(gun: DartGun, trigger_forces) -> Runs:
    """Reload from rest with ``RELOAD_FORCE``, settle at the latch, fire with each trigger force."""
    reload = dartgun.run_reload(gun.device, [RELOAD_FORCE], RELOAD_TIME, start=gun.rest)
    latched = dartgun.settle(gun.device, reload.final)
    fire = dartgun.run_fire(gun.device, list(trigger_forces), FIRE_TIME, start=latched)
    return Runs(reload, latched, fire)
