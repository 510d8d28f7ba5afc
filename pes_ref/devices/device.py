"""A device: two parts, the grid of their C-space, eq. (1), springs, dynamics and a start.

A [`Device`][pes_ref.devices.device.Device] is everything a device file says
([`pes_ref.devices.device_file`][pes_ref.devices.device_file],
``docs/devices.md``), checked: it builds its C-space, its surface and the scenes that run
on it. The C-space and the surface are computed once per device object, on first use.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from pes_ref.core import checks
from pes_ref.core.scene import Scene
from pes_ref.core.stability import SAFETY, stability_limit
from pes_ref.core.surface import Surface
from pes_ref.core.terms import Walls
from pes_ref.devices.boundary import BAND
from pes_ref.devices.cspace import CSpace, CSpaceGrid, GridSpring, default_r_min
from pes_ref.devices.geometry import Part

__all__ = ["Device"]


@dataclass(frozen=True, eq=False)
class Device:
    """Two parts with springs on the grid of their C-space (``docs/devices.md``).

    Parameters
    ----------
    parts : (Part, Part)
        Part 0 moves with q0, part 1 with q1.
    lower, upper : array_like, shape (2,)
        The C-space grid's domain (an axis whose part rotates through 2 pi is periodic).
    shape : (n0, n1)
    v, r_c : float
        Eq. (1)'s strength (>= 0) and cut-off (> 0).
    springs : sequence of GridSpring
    mass : array_like, shape (2,), > 0
    damping : array_like, shape (2,), >= 0
    dt : float, optional
        The time step; default: the stable step of docs/spec.md section 10 (half the
        conservative limit of the surface's stiffness, the walls and the masses).
    start : array_like, shape (2,)
        Where an analysis starts.
    r_min : float, optional
        Eq. (1)'s cap (default half the finer spacing).
    walls : pes_ref.Walls, optional
    tolerance : float, optional
        The circles' tolerance (default
        [`pes_ref.devices.geometry.default_tolerance`][pes_ref.devices.geometry.default_tolerance]).
    name : str
    analysis : dict
        Settings of the device's own analysis (``analyze ratchet``, ``analyze dartgun``).
    restitution, friction : float
        The rigid engine's contact ([`pes_ref.rigid`][pes_ref.rigid]): the coefficient of restitution in
        [0, 1] (0: inelastic) and of friction (>= 0; 0: frictionless). The surface model has
        neither.
    design : str or None
        The hash of the design a realization made the device from (``[realized] design``,
        `pes_ref.realize.contact.design_hash`); None: not a realization's.
    """

    parts: tuple
    lower: np.ndarray
    upper: np.ndarray
    shape: tuple
    v: float
    r_c: float
    springs: tuple = ()
    mass: np.ndarray = (1.0, 1.0)
    damping: np.ndarray = (0.0, 0.0)
    dt: float | None = None
    start: np.ndarray = (0.0, 0.0)
    r_min: float | None = None
    walls: Walls | None = None
    tolerance: float | None = None
    name: str = ""
    analysis: dict = dataclasses.field(default_factory=dict)
    restitution: float = 0.0
    friction: float = 0.0
    design: str | None = None

    def __post_init__(self):
        set_ = lambda k, val: object.__setattr__(self, k, val)  # noqa: E731
        parts = tuple(self.parts)
        if len(parts) != 2 or not all(isinstance(p, Part) for p in parts):
            raise checks.InputTypeError("parts", f"parts must be two pes_ref.devices.geometry.Part objects, "
                                                 f"got {self.parts!r}")
        set_("parts", parts)
        grid = CSpaceGrid(parts[0], parts[1], self.lower, self.upper, self.shape, tolerance=self.tolerance)
        set_("lower", grid.lower)
        set_("upper", grid.upper)
        set_("shape", grid.shape)
        set_("v", checks.as_nonneg_float("v", self.v))
        set_("r_c", checks.as_positive_float("r_c", self.r_c))
        if self.r_min is not None:
            set_("r_min", checks.as_positive_float("r_min", self.r_min))
            if not self.r_min < self.r_c:
                raise checks.InputError("r_min", f"r_min must be < r_c, got r_min={self.r_min:g}, r_c={self.r_c:g}")
        elif not default_r_min(grid.spacing) < self.r_c:
            raise checks.InputError("r_c", f"r_c = {self.r_c:g} must exceed r_min, which defaults to half the finer "
                                           f"grid spacing ({default_r_min(grid.spacing):g} on the grid of "
                                           f"cspace.shape {list(grid.shape)}): raise r_c, refine cspace.shape or "
                                           f"set r_min below r_c", names=("r_c", "r_min"))
        springs = tuple(self.springs)
        for s in springs:
            if not isinstance(s, GridSpring):
                raise checks.InputTypeError("springs", f"springs must be GridSpring objects, got {s!r}")
        set_("springs", springs)
        set_("mass", checks.as_float_array("mass", self.mass, shape=(2,), positive=True))
        set_("damping", checks.as_float_array("damping", self.damping, shape=(2,), nonneg=True))
        if self.dt is not None:
            set_("dt", checks.as_positive_float("dt", self.dt))
        set_("start", checks.as_float_array("start", self.start, shape=(2,)))
        if self.walls is not None and not isinstance(self.walls, Walls):
            raise checks.InputTypeError("walls", f"walls must be a pes_ref.Walls or None, got {self.walls!r}")
        if self.walls is not None:
            for d in range(2):
                if grid.periodic[d] and self.walls.edges[d].any():
                    raise checks.InputError("walls", f"axis {d} is periodic and cannot have a wall")
                length = float(grid.upper[d] - grid.lower[d])
                if self.walls.edges[d].all() and not 2.0 * self.walls.margin < length:
                    raise checks.InputError("wall_margin", f"the walls' margin {self.walls.margin:g} leaves no room "
                                                           f"between the two walls of q{d}: twice it must be below "
                                                           f"the grid's length {length:g} along q{d}")
        set_("analysis", dict(self.analysis))
        set_("restitution", checks.as_nonneg_float("restitution", self.restitution))
        if self.restitution > 1.0:
            raise checks.InputError("restitution", f"restitution must be in [0, 1], got {self.restitution:g}")
        set_("friction", checks.as_nonneg_float("friction", self.friction))
        set_("_grid", grid)
        set_("_cache", {})

    def replace(self, **changes) -> "Device":
        """A copy with some fields changed (e.g. ``shape`` and ``dt`` for a quick look); nothing computed is shared."""
        return dataclasses.replace(self, **changes)

    @property
    def grid(self) -> CSpaceGrid:
        """The C-space grid (parts, domain, shape, topology, circles' tolerance)."""
        return self._grid

    @property
    def periodic(self) -> tuple:
        """Whether each C-space axis is periodic, 2 bool (the grid's)."""
        return self._grid.periodic

    @property
    def spacing(self) -> np.ndarray:
        """The grid's node spacing h, shape (2,) (C-space length or radians per axis)."""
        return self._grid.spacing

    def angle_warnings(self) -> list:
        """A line per angle axis whose span is more than a turn (2 pi rad): angles are in radians,
        and a span such as 0..360 is almost always meant in degrees. Taken as radians it is 57
        turns, not periodic; a drive along it jams or runs off the grid, far from what was meant."""
        out = []
        for d, part in enumerate(self.parts):
            span = float(self.upper[d] - self.lower[d])
            if part.periodic and span > 2.0 * np.pi * (1.0 + 1e-6):
                out.append(f"cspace: q{d} is an angle (part[{d}] rotates) spanning {self.lower[d]:g} .. "
                           f"{self.upper[d]:g} = {span:g} rad, {span / (2.0 * np.pi):.3g} turns: angles are in "
                           f"radians; if it was meant in degrees, write lower = {np.radians(self.lower[d]):.6g}, "
                           f"upper = {np.radians(self.upper[d]):.6g} (a whole turn is periodic)")
        return out

    def blocked(self, progress=None) -> np.ndarray:
        """The blocked nodes of the C-space grid (bool, the grid's shape), once per device: the
        first part of [`cspace`][pes_ref.devices.device.Device.cspace], enough to refuse a C-space with no free node."""
        if "blocked" not in self._cache:
            self._cache["blocked"] = self._grid.posed_blocked(progress)
        return self._cache["blocked"][1]

    def cspace(self, progress=None) -> CSpace:
        """The computed C-space
        ([`pes_ref.devices.cspace.CSpaceGrid.compute`][pes_ref.devices.cspace.CSpaceGrid.compute]), once per device;
        its distance is exact out to eq. (1)'s cut-off r_c and two spacings more."""
        if "cspace" not in self._cache:
            h = float(np.max(self.spacing))
            reach = max(BAND * h, self.r_c + 2.0 * h)
            self.blocked(progress)
            self._cache["cspace"] = self._grid.compute(progress, reach, self._cache["blocked"])
        return self._cache["cspace"]

    def surface(self, progress=None) -> Surface:
        """Eq. (1) of the C-space's distance plus the springs, once per device."""
        if "surface" not in self._cache:
            self._cache["surface"] = self.cspace(progress).surface(self.v, self.r_c, self.springs, self.r_min)
        return self._cache["surface"]

    def stable_dt(self) -> float:
        """``dt`` if the device names one, else half the stability limit of docs/spec.md section 10.2."""
        if self.dt is not None:
            return self.dt
        probe = Scene(self.surface(), dt=1.0, n_steps=0, mass=self.mass, walls=self.walls)
        limit = stability_limit(probe)
        if not np.isfinite(limit.suggestion):
            raise checks.InputError("dt", f"device {self.name!r} has no stiffness (no barrier, spring or wall) to "
                                          f"choose a step from: give [dynamics] dt")
        return float(limit.suggestion)

    def stable_mobility(self) -> np.ndarray:
        """A stable quasistatic mobility, the same on both axes (the paper: a step proportional
        to the net force): half the limit ``2 / K`` of docs/spec.md section 10.2 on the stiffer axis."""
        probe = Scene(self.surface(), dt=1.0, n_steps=0, mode="quasistatic", mobility=(1.0, 1.0), walls=self.walls)
        k_max = float(np.max(stability_limit(probe).stiffness))
        return np.full(2, SAFETY * 2.0 / k_max if k_max > 0 else 1.0)

    def scene(self, n_steps: int, effects=(), mode: str = "dynamic", dt: float | None = None,
              mobility=None) -> Scene:
        """A scene on the device's surface: its masses, damping and walls, ``effects``.

        Parameters
        ----------
        n_steps : int
        effects : effect or sequence of effects
        mode : {"dynamic", "quasistatic"}
        dt : float, optional
            Default [`stable_dt`][pes_ref.devices.device.Device.stable_dt].
        mobility : array_like (2,), optional
            Quasistatic only; default [`stable_mobility`][pes_ref.devices.device.Device.stable_mobility].
        """
        dt = self.stable_dt() if dt is None else dt
        if mode == "quasistatic":
            mobility = self.stable_mobility() if mobility is None else mobility
            return Scene(self.surface(), dt=dt, n_steps=n_steps, mode="quasistatic", mobility=mobility,
                         walls=self.walls, effects=effects)
        return Scene(self.surface(), dt=dt, n_steps=n_steps, mass=self.mass, damping=self.damping,
                     walls=self.walls, effects=effects)
