"""Device files: a TOML file (read with :mod:`tomllib`) that describes a device completely.

Every key, its unit and default is documented in ``docs/devices.md``; this module is the
one place that reads them. A file is checked whole before anything is computed: an
unknown key, a missing one, or a bad value raises one :class:`DeviceFileError` whose
message names the file and the key (``ratchet.toml: part[1].shapes[0].circle.radius:
expected a number > 0, got -1``).

The format is versioned by the top-level key ``format`` (:data:`FORMAT`); a file of
another version is refused.
"""
from __future__ import annotations

import os
from importlib import resources

import numpy as np

from pes_ref.core import checks
from pes_ref.core.runtime.keyfile import KeyFileError, KeyReader, parse_toml, read_text, show as _show
from pes_ref.core.terms import Walls
from pes_ref.devices import geometry as g
from pes_ref.devices.cspace import SIDES, GridSpring
from pes_ref.devices.device import Device

__all__ = ["FORMAT", "DeviceFileError", "load_device", "parse_device", "shipped_device", "SHIPPED", "ANALYSES", "read_shapes",
           "FILE_KEYS"]

#: The device-file format this module reads.
FORMAT = 1
#: The devices shipped in the package (``pes_ref/devices/data/NAME.toml``).
SHIPPED = ("ratchet", "dartgun")
#: A rotation axis whose span is within this relative distance of 2 pi is a full turn (made exact).
FULL_TURN_RTOL = 1e-6

TOP_KEYS = ("format", "name", "description", "part", "cspace", "geometry", "energy", "dynamics", "rigid",
            "start", "analysis")
PART_KEYS = ("name", "motion", "pivot", "direction", "radius", "shapes")
SHAPE_KINDS = ("polygon", "circle", "rectangle")
CSPACE_KEYS = ("lower", "upper", "shape")
GEOMETRY_KEYS = ("tolerance",)
ENERGY_KEYS = ("v", "r_c", "r_min", "springs")
SPRING_KEYS = ("axis", "k", "center", "side")
DYNAMICS_KEYS = ("mass", "damping", "dt", "walls")
WALL_KEYS = ("k", "margin", "edges")
START_KEYS = ("q",)
#: ``[rigid]``: the contact of the rigid engine (``analyze --engine rigid``), each with its default.
RIGID_KEYS = {"restitution": 0.0, "friction": 0.0}
#: The device-file key of each argument of :class:`~pes_ref.devices.device.Device` whose refusal
#: names a key of its own (an argument not here is named as it is).
FILE_KEYS = {"walls": "dynamics.walls", "upper": "cspace.upper", "lower": "cspace.lower", "shape": "cspace.shape",
             "periodic": "cspace.upper", "tolerance": "geometry.tolerance", "wall_margin": "dynamics.walls.margin",
             "r_c": "energy.r_c", "r_min": "energy.r_min", "restitution": "rigid.restitution",
             "friction": "rigid.friction"}
#: The device analyses a file may configure (``[analysis] kind``): their keys, each required.
ANALYSES = {
    "ratchet": ("pitch", "settle"),
    "dartgun": ("latch_q0", "stop_q0", "settle"),
}


class DeviceFileError(KeyFileError):
    """A device file that cannot be used; the message names the file and the key."""


class _Reader(KeyReader):
    """Checks values and raises :class:`DeviceFileError` naming ``path`` and the key."""

    error = DeviceFileError
    noun = "a device file"

    def table(self, value, key: str, allowed) -> dict:
        return self.check_keys(value, key, allowed)

    def require(self, table: dict, key: str, where: str):
        if key not in table:
            self.fail(where, "missing")
        return table[key]

    def number(self, value, key: str, *, positive=False, nonneg=False) -> float:
        return super().number(value, key, above=0 if positive else None, least=0 if nonneg else None)

    def pair(self, value, key: str, **kw) -> np.ndarray:
        if not isinstance(value, list) or len(value) != 2:
            self.fail(key, f"expected a list of two numbers, got {_show(value)}")
        return np.array([self.number(v, f"{key}[{i}]", **kw) for i, v in enumerate(value)])

    def string(self, value, key: str, choices=None) -> str:
        if not isinstance(value, str):
            self.fail(key, f"expected a string, got {_show(value)}")
        if choices is not None and value not in choices:
            self.fail(key, f"expected one of {', '.join(repr(c) for c in choices)}, got {_show(value)}")
        return value

    def build(self, key: str, make, *args):
        """``make(*args)``, with a library refusal reworded to name the file's key."""
        try:
            return make(*args)
        except (ValueError, TypeError) as exc:
            self.fail(key, " ".join(str(exc).split()))


# --------------------------------------------------------------------------- the sections

def _shape(r: _Reader, value, key: str):
    if not isinstance(value, dict):
        r.fail(key, f"expected a shape table ({{ polygon = ... }}, {{ circle = ... }} or {{ rectangle = ... }}), "
                    f"got {_show(value)}")
    r.table(value, key, SHAPE_KINDS + ("minus",))
    kinds = [k for k in SHAPE_KINDS if k in value]
    if len(kinds) != 1:
        r.fail(key, f"expected exactly one of polygon, circle, rectangle, got {kinds or 'none'}")
    kind = kinds[0]
    minus = value.get("minus", [])
    if not isinstance(minus, list):
        r.fail(f"{key}.minus", f"expected a list of shapes, got {_show(minus)}")
    cuts = tuple(_shape(r, m, f"{key}.minus[{i}]") for i, m in enumerate(minus))
    spec, where = value[kind], f"{key}.{kind}"
    if kind == "polygon":
        if not isinstance(spec, list) or len(spec) < 3:
            r.fail(where, f"expected a list of at least three [x, y] corners, got {_show(spec)}")
        vertices = np.array([r.pair(p, f"{where}[{i}]") for i, p in enumerate(spec)])
        return r.build(where, g.Polygon, vertices, cuts)
    if kind == "circle":
        r.table(spec, where, ("center", "radius"))
        center = r.pair(r.require(spec, "center", f"{where}.center"), f"{where}.center")
        radius = r.number(r.require(spec, "radius", f"{where}.radius"), f"{where}.radius", positive=True)
        return r.build(where, g.Circle, center, radius, cuts)
    r.table(spec, where, ("lower", "upper"))
    lower = r.pair(r.require(spec, "lower", f"{where}.lower"), f"{where}.lower")
    upper = r.pair(r.require(spec, "upper", f"{where}.upper"), f"{where}.upper")
    if not np.all(upper > lower):
        r.fail(f"{where}.upper", f"expected upper > lower on both axes, got lower {lower.tolist()}, "
                                 f"upper {upper.tolist()}")
    return r.build(where, g.Rectangle, lower, upper, cuts)


def _rotation(r: _Reader, value, key: str):
    return g.Rotation(r.pair(r.require(value, "pivot", f"{key}.pivot"), f"{key}.pivot"))


def _translation(r: _Reader, value, key: str):
    d = r.pair(r.require(value, "direction", f"{key}.direction"), f"{key}.direction")
    if not np.hypot(*d) > 0:
        r.fail(f"{key}.direction", f"expected a non-zero direction, got {d.tolist()}")
    return g.Translation(d)


def _drum(r: _Reader, value, key: str):
    return g.Drum(r.number(r.require(value, "radius", f"{key}.radius"), f"{key}.radius", positive=True))


#: The part motions (``motion = NAME``): their key, what a part of that motion is called
#: (for refusals), and the reader of the key.
MOTIONS = {
    "rotation": ("pivot", "a rotating part", _rotation),
    "translation": ("direction", "a translating part", _translation),
    "drum": ("radius", "a drum", _drum),
}


def _part(r: _Reader, value, key: str) -> g.Part:
    r.table(value, key, PART_KEYS)
    motion = r.string(r.require(value, "motion", f"{key}.motion"), f"{key}.motion", tuple(MOTIONS))
    own, noun, read = MOTIONS[motion]
    for other, *_ in MOTIONS.values():
        if other != own and other in value:
            r.fail(f"{key}.{other}", f"{noun} has a {own}, not a {other}")
    m = read(r, value, key)
    if "name" in value:
        r.string(value["name"], f"{key}.name")
    shapes = r.require(value, "shapes", f"{key}.shapes")
    if not isinstance(shapes, list) or not shapes:
        r.fail(f"{key}.shapes", f"expected a non-empty list of shapes, got {_show(shapes)}")
    built = tuple(_shape(r, s, f"{key}.shapes[{i}]") for i, s in enumerate(shapes))
    part = r.build(f"{key}.shapes", g.Part, built, m)
    r.build(f"{key}.shapes", part.geometry, 1e-3)        # a part the cuts leave empty is refused here
    r.build(f"{key}.shapes", g.check_drum_drawing, part)
    return part


def read_shapes(value, where: str, path: str, error: type) -> tuple:
    """A non-empty list of shape tables (a part's ``shapes``, ``docs/devices.md``) at key ``where``
    of another file that draws shapes (a problem file's ``surface.contact.blocked``): a refusal
    raises ``error`` naming ``path`` and the key."""
    r = _Reader(path)
    r.error = error
    if not isinstance(value, list) or not value:
        r.fail(where, f"expected a non-empty list of shapes, got {_show(value)}")
    return tuple(_shape(r, s, f"{where}[{i}]") for i, s in enumerate(value))


def _cspace(r: _Reader, value, parts):
    r.table(value, "cspace", CSPACE_KEYS)
    lower = r.pair(r.require(value, "lower", "cspace.lower"), "cspace.lower")
    upper = r.pair(r.require(value, "upper", "cspace.upper"), "cspace.upper")
    shape = r.require(value, "shape", "cspace.shape")
    if not isinstance(shape, list) or len(shape) != 2:
        r.fail("cspace.shape", f"expected two integers >= 2, got {_show(shape)}")
    shape = tuple(r.integer(n, f"cspace.shape[{i}]", 2) for i, n in enumerate(shape))
    r.ordered(lower, upper, "cspace", strict=True)
    for d in range(2):
        span = upper[d] - lower[d]
        if parts[d].periodic and abs(span - 2 * np.pi) <= FULL_TURN_RTOL * 2 * np.pi:
            upper[d] = lower[d] + 2 * np.pi         # a full turn: the axis is periodic
    return lower, upper, shape


def _energy(r: _Reader, value):
    r.table(value, "energy", ENERGY_KEYS)
    v = r.number(r.require(value, "v", "energy.v"), "energy.v", nonneg=True)
    r_c = r.number(r.require(value, "r_c", "energy.r_c"), "energy.r_c", positive=True)
    r_min = None
    if "r_min" in value:
        r_min = r.number(value["r_min"], "energy.r_min", positive=True)
        if not r_min < r_c:
            r.fail("energy.r_min", f"expected r_min < r_c = {r_c:g}, got {r_min:g}")
    springs = value.get("springs", [])
    if not isinstance(springs, list):
        r.fail("energy.springs", f"expected a list of spring tables, got {_show(springs)}")
    out = []
    for i, s in enumerate(springs):
        key = f"energy.springs[{i}]"
        r.table(s, key, SPRING_KEYS)
        axis = r.require(s, "axis", f"{key}.axis")
        if isinstance(axis, bool) or axis not in (0, 1):
            r.fail(f"{key}.axis", f"expected 0 or 1, got {_show(axis)}")
        k = r.number(r.require(s, "k", f"{key}.k"), f"{key}.k", nonneg=True)
        center = r.number(r.require(s, "center", f"{key}.center"), f"{key}.center")
        side = r.string(s.get("side", "both"), f"{key}.side", SIDES)
        out.append(GridSpring(int(axis), k, center, side))
    return v, r_c, r_min, tuple(out)


def _dynamics(r: _Reader, value):
    r.table(value, "dynamics", DYNAMICS_KEYS)
    mass = r.pair(r.require(value, "mass", "dynamics.mass"), "dynamics.mass", positive=True)
    damping = r.pair(r.require(value, "damping", "dynamics.damping"), "dynamics.damping", nonneg=True)
    dt = r.number(value["dt"], "dynamics.dt", positive=True) if "dt" in value else None
    walls = None
    if "walls" in value:
        w = r.table(value["walls"], "dynamics.walls", WALL_KEYS)
        k = r.number(r.require(w, "k", "dynamics.walls.k"), "dynamics.walls.k", positive=True)
        margin = r.number(w.get("margin", 0.0), "dynamics.walls.margin", nonneg=True)
        edges = r.require(w, "edges", "dynamics.walls.edges")
        if not (isinstance(edges, list) and len(edges) == 2 and all(isinstance(e, list) and len(e) == 2
                                                                    for e in edges)):
            r.fail("dynamics.walls.edges", f"expected [[lower0, upper0], [lower1, upper1]] of true/false, "
                                           f"got {_show(edges)}")
        flags = [[r.boolean(f, f"dynamics.walls.edges[{d}][{s}]") for s, f in enumerate(e)]
                 for d, e in enumerate(edges)]
        walls = Walls(k, margin, flags)
    return mass, damping, dt, walls


def _rigid(r: _Reader, value) -> tuple:
    r.table(value, "rigid", tuple(RIGID_KEYS))
    restitution = r.number(value.get("restitution", RIGID_KEYS["restitution"]), "rigid.restitution", nonneg=True)
    if restitution > 1.0:
        r.fail("rigid.restitution", f"expected a number in [0, 1], got {_show(value['restitution'])}")
    friction = r.number(value.get("friction", RIGID_KEYS["friction"]), "rigid.friction", nonneg=True)
    return restitution, friction


def _analysis(r: _Reader, value) -> dict:
    if not isinstance(value, dict):
        r.fail("analysis", f"expected a table, got {_show(value)}")
    kind = r.string(r.require(value, "kind", "analysis.kind"), "analysis.kind", tuple(ANALYSES))
    r.table(value, "analysis", ("kind",) + ANALYSES[kind])
    out = {"kind": kind}
    for key in ANALYSES[kind]:
        out[key] = r.number(r.require(value, key, f"analysis.{key}"), f"analysis.{key}", positive=True)
    return out


# --------------------------------------------------------------------------- the file

def parse_device(data: dict, path: str = "<device>") -> Device:
    """Check the parsed TOML ``data`` of a device file and build its :class:`Device`."""
    r = _Reader(path)
    r.table(data, "", TOP_KEYS)
    version = r.require(data, "format", "format")
    if isinstance(version, bool) or not isinstance(version, int):
        r.fail("format", f"expected the integer {FORMAT}, got {_show(version)}")
    if version != FORMAT:
        r.fail("format", f"this is pes_ref's device-file format {FORMAT}; the file says format = {version}")
    name = r.string(data.get("name", os.path.splitext(os.path.basename(path))[0]), "name")
    if "description" in data:
        r.string(data["description"], "description")
    parts = r.require(data, "part", "part")
    if not isinstance(parts, list) or len(parts) != 2:
        r.fail("part", f"expected exactly two [[part]] tables (part 0 moves with q0, part 1 with q1), got "
                       f"{len(parts) if isinstance(parts, list) else _show(parts)}")
    parts = tuple(_part(r, p, f"part[{i}]") for i, p in enumerate(parts))
    lower, upper, shape = _cspace(r, r.require(data, "cspace", "cspace"), parts)
    tolerance = None
    if "geometry" in data:
        geo = r.table(data["geometry"], "geometry", GEOMETRY_KEYS)
        if "tolerance" in geo:
            tolerance = r.number(geo["tolerance"], "geometry.tolerance", positive=True)
    v, r_c, r_min, springs = _energy(r, r.require(data, "energy", "energy"))
    mass, damping, dt, walls = _dynamics(r, r.require(data, "dynamics", "dynamics"))
    start = np.zeros(2)
    if "start" in data:
        st = r.table(data["start"], "start", START_KEYS)
        start = r.pair(r.require(st, "q", "start.q"), "start.q")
    analysis = _analysis(r, data["analysis"]) if "analysis" in data else {}
    restitution, friction = _rigid(r, data.get("rigid", {}))
    try:
        return Device(parts, lower, upper, shape, v, r_c, springs, mass, damping, dt, start, r_min, walls,
                      tolerance, name, analysis, restitution, friction)
    except checks.InputError as exc:
        key = FILE_KEYS.get(exc.key, exc.key or "device")
        r.fail(key, " ".join(str(exc).split()))


def load_device(path) -> Device:
    """Read and check the device file at ``path`` (``docs/devices.md``).

    Raises
    ------
    DeviceFileError
        A missing or unreadable file, bad TOML, an unknown or missing key, or a bad
        value: one line naming the file and the key.
    pes_ref.devices.geometry.MissingExtraError
        shapely 2 is not installed.
    """
    path = os.fspath(path)
    data = parse_toml(read_text(path, DeviceFileError, "device file"), path, DeviceFileError)
    g.require_shapely()
    return parse_device(data, path)


def shipped_device(name: str) -> Device:
    """A device shipped in the package (:data:`SHIPPED`), read from its file."""
    if name not in SHIPPED:
        raise checks.InputError("name", f"name must be one of {', '.join(SHIPPED)}, got {name!r}")
    with resources.as_file(resources.files("pes_ref.devices") / "data" / f"{name}.toml") as path:
        return load_device(path)
