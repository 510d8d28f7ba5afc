"""The dart gun runs that Figs. 2-4 draw, all through :mod:`pes_ref.devices.dartgun`."""
from __future__ import annotations

import dataclasses
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
    design: dartgun.DartGunDesign
    blocked: np.ndarray          # (n0, n1) bool, the C-space
    distance: np.ndarray         # (n0, n1) signed distance to its boundary
    surface: object              # pes_ref.Surface
    rest: np.ndarray             # (1, 2) the unloaded rest state


class Runs(NamedTuple):
    reload: dartgun.ReloadResult
    latched: np.ndarray          # (1, 2) the latched equilibrium the reload reaches
    fire: dartgun.FireResult


def build(smoke: bool) -> DartGun:
    """The default dart gun (on the coarse smoke grid under ``smoke``), its C-space and surface."""
    d = dartgun.DartGunDesign()
    if smoke:
        d = dataclasses.replace(d, shape=SMOKE_SHAPE)
    cs = dartgun.dartgun_cspace(d)
    blocked = cs.blocked()
    surface = dartgun.dartgun_surface(d, blocked=blocked)
    return DartGun(d, blocked, cs.distance(blocked), surface, dartgun.dartgun_start(d, surface))


def reload_and_fire(gun: DartGun, trigger_forces) -> Runs:
    """Reload from rest with ``RELOAD_FORCE``, settle at the latch, fire with each trigger force."""
    reload = dartgun.run_reload(gun.design, [RELOAD_FORCE], RELOAD_TIME, surface=gun.surface, start=gun.rest)
    latched = dartgun.settle(gun.design, reload.final, gun.surface)
    fire = dartgun.run_fire(gun.design, list(trigger_forces), FIRE_TIME, start=latched, surface=gun.surface)
    return Runs(reload, latched, fire)
