"""Device files: a TOML file (read with `tomllib`) that describes a device completely.

Every key, its unit and default is documented in ``docs/devices.md``; this module is the one place
that reads them. A file is checked whole before anything is computed: an unknown key, a missing one,
or a bad value raises one [`DeviceFileError`][pes_ref.devices.device_file.DeviceFileError] whose
message names the file and the key (``ratchet.toml: part[1].shapes[0].circle.radius: expected a
number > 0, got -1``).

The format is versioned by the top-level key ``format`` (`FORMAT`); a file of
another version is refused.
"""
from __future__ import annotations

import os
from importlib import resources

import numpy as np

from pes_ref.core import checks
from pes_ref.core.runtime.keyfile import TYPES, Key, KeyFileError, KeyReader, parse_toml, read_text, show
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


class DeviceFileError(KeyFileError):
    """A device file that cannot be used; the message names the file and the key."""


def _format(r, v, w, k):
    if isinstance(v, bool) or not isinstance(v, int):
        r.fail(w, f"expected the integer {FORMAT}, got {show(v)}")
    if v != FORMAT:
        r.fail(w, f"this is pes_ref's device-file format {FORMAT}; the file says format = {v}")
    return v


def _two_parts(r, v, w, k):
    if not isinstance(v, list) or len(v) != 2:
        r.fail(w, f"expected exactly two [[part]] tables (part 0 moves with q0, part 1 with q1), got "
                  f"{len(v) if isinstance(v, list) else show(v)}")
    return v


def _shapes(r, v, w, k):
    if not isinstance(v, list) or not v:
        r.fail(w, f"expected a non-empty list of shapes, got {show(v)}")
    return tuple(_shape(r, s, r.at(w, i)) for i, s in enumerate(v))


def _shape_list(r, v, w, k):
    if not isinstance(v, list):
        r.fail(w, f"expected a list of shapes, got {show(v)}")
    return tuple(_shape(r, s, r.at(w, i)) for i, s in enumerate(v))


def _corners(r, v, w, k):
    if not isinstance(v, list) or len(v) < 3:
        r.fail(w, f"expected a list of at least three [x, y] corners, got {show(v)}")
    return np.array([r.value(p, r.at(w, i), Key("point")) for i, p in enumerate(v)])


class _Reader(KeyReader):
    """Checks values and raises [`DeviceFileError`][pes_ref.devices.device_file.DeviceFileError] naming ``path`` and the key."""

    error = DeviceFileError
    noun = "a device file"
    types = {**TYPES, "format": _format, "parts": _two_parts, "shapes": _shapes, "shape_list": _shape_list,
             "corners": _corners}

    def build(self, key: str, make, *args):
        """``make(*args)``, with a library refusal reworded to name the file's key."""
        try:
            return make(*args)
        except (ValueError, TypeError) as exc:
            self.fail(key, " ".join(str(exc).split()))


def _direction(r: _Reader, d, key: str):
    if not np.hypot(*d) > 0:
        r.fail(key, f"expected a non-zero direction, got {list(d)}")
    return g.Translation(np.array(d))


#: The part motions (``motion = NAME``): their key, what a part of that motion is called
#: (for refusals), and the motion made from the key's value.
MOTIONS = {
    "rotation": ("pivot", "a rotating part", lambda r, pivot, key: g.Rotation(np.array(pivot))),
    "translation": ("direction", "a translating part", _direction),
    "drum": ("radius", "a drum", lambda r, radius, key: g.Drum(radius)),
}


# --------------------------------------------------------------------------- the keys
# Each section's keys: type (`pes_ref.core.runtime.keyfile.TYPES` and the reader's own),
# default and unit; docs/devices.md documents every one (a test keeps the two equal).

TOP_KEYS = {"format": Key("format"), "name": Key("text", None), "description": Key("text", ""),
            "part": Key("parts"), "cspace": Key("table"), "geometry": Key("table", {}), "energy": Key("table"),
            "dynamics": Key("table"), "rigid": Key("table", {}), "start": Key("table", {}),
            "analysis": Key("table", None), "realized": Key("table", {})}
PART_KEYS = {"name": Key("text", None), "motion": Key("choice", choices=tuple(MOTIONS)),
             "pivot": Key("point", None, "length"), "direction": Key("point", None),
             "radius": Key("positive", None, "length"), "shapes": Key("shapes")}
#: A shape is one of these tables (its kind -> its keys), and may cut others out (``minus``).
SHAPES = {"polygon": Key("corners", unit="length"),
          "circle": {"center": Key("point", unit="length"), "radius": Key("positive", unit="length")},
          "rectangle": {"lower": Key("point", unit="length"), "upper": Key("point", unit="length")}}
SHAPE_KEYS = {"minus": Key("shape_list", ())}
CSPACE_KEYS = {"lower": Key("point", unit="q"), "upper": Key("point", unit="q"), "shape": Key("grid_pair", unit="nodes")}
GEOMETRY_KEYS = {"tolerance": Key("positive", None, "length")}
ENERGY_KEYS = {"v": Key("nonneg", unit="energy x C-space length^2"), "r_c": Key("positive", unit="C-space length"),
               "r_min": Key("positive", None, "C-space length"), "springs": Key("table_list", ())}
SPRING_KEYS = {"axis": Key("axis"), "k": Key("nonneg", unit="force / q"), "center": Key("number", unit="q"),
               "side": Key("choice", "both", choices=SIDES)}
DYNAMICS_KEYS = {"mass": Key("positive_pair", unit="mass or inertia"), "damping": Key("nonneg_pair", unit="force s / q"),
                 "dt": Key("positive", None, "s"), "walls": Key("table", None)}
WALL_KEYS = {"k": Key("positive", unit="force / q"), "margin": Key("nonneg", 0.0, "q"), "edges": Key("edges")}
#: ``[rigid]``: the contact of the rigid engine (``analyze --engine rigid``), each with its default.
RIGID_KEYS = {"restitution": Key("unit", 0.0), "friction": Key("nonneg", 0.0)}
START_KEYS = {"q": Key("point", (0.0, 0.0), "q")}
#: ``[realized]``: what a realization's device was made from (``realize``; ``evaluate --realized`` checks it).
REALIZED_KEYS = {"design": Key("text", None)}
#: The device analyses a file may configure (``[analysis] kind``): their keys, each required.
ANALYSES = {
    "ratchet": {"pitch": Key("positive", unit="rad"), "settle": Key("positive", unit="s")},
    "dartgun": {"latch_q0": Key("positive", unit="length"), "stop_q0": Key("positive", unit="length"),
                "settle": Key("positive", unit="s")},
}
#: The device-file key of each argument of `Device` whose refusal
#: names a key of its own (an argument not here is named as it is).
FILE_KEYS = {"walls": "dynamics.walls", "upper": "cspace.upper", "lower": "cspace.lower", "shape": "cspace.shape",
             "periodic": "cspace.upper", "tolerance": "geometry.tolerance", "wall_margin": "dynamics.walls.margin",
             "r_c": "energy.r_c", "r_min": "energy.r_min", "restitution": "rigid.restitution",
             "friction": "rigid.friction"}


# --------------------------------------------------------------------------- the sections

def _shape(r: _Reader, value, key: str):
    if not isinstance(value, dict):
        r.fail(key, f"expected a shape table ({{ polygon = ... }}, {{ circle = ... }} or {{ rectangle = ... }}), "
                    f"got {show(value)}")
    kinds = [k for k in SHAPES if k in value]
    cuts = r.table(value, key, SHAPE_KEYS, also=SHAPES)["minus"]
    if len(kinds) != 1:
        r.fail(key, f"expected exactly one of polygon, circle, rectangle, got {kinds or 'none'}")
    kind = kinds[0]
    where = r.at(key, kind)
    if kind == "polygon":
        return r.build(where, g.Polygon, r.value(value[kind], where, SHAPES[kind]), cuts)
    spec = r.table(value[kind], where, SHAPES[kind])
    if kind == "circle":
        return r.build(where, g.Circle, np.array(spec["center"]), spec["radius"], cuts)
    lower, upper = np.array(spec["lower"]), np.array(spec["upper"])
    if not np.all(upper > lower):
        r.fail(f"{where}.upper", f"expected upper > lower on both axes, got lower {lower.tolist()}, "
                                 f"upper {upper.tolist()}")
    return r.build(where, g.Rectangle, lower, upper, cuts)


def _part(r: _Reader, value, key: str) -> g.Part:
    t = r.table(value, key, PART_KEYS)
    own, noun, make = MOTIONS[t["motion"]]
    for other, *_ in MOTIONS.values():
        if other != own and other in value:
            r.fail(f"{key}.{other}", f"{noun} has a {own}, not a {other}")
    if t[own] is None:
        r.fail(f"{key}.{own}", "missing")
    motion = make(r, t[own], f"{key}.{own}")
    part = r.build(f"{key}.shapes", g.Part, t["shapes"], motion)
    r.build(f"{key}.shapes", part.geometry, 1e-3)        # a part the cuts leave empty is refused here
    r.build(f"{key}.shapes", g.check_drum_drawing, part)
    return part


def read_shapes(value, where: str, path: str, error: type) -> tuple:
    """A non-empty list of shape tables (a part's ``shapes``, ``docs/devices.md``) at key ``where``
    of another file that draws shapes (a problem file's ``surface.contact.blocked``): a refusal
    raises ``error`` naming ``path`` and the key."""
    r = _Reader(path)
    r.error = error
    return _shapes(r, value, where, None)


def _cspace(r: _Reader, value, parts):
    t = r.table(value, "cspace", CSPACE_KEYS)
    lower, upper = np.array(t["lower"]), np.array(t["upper"])
    r.ordered(lower, upper, "cspace", strict=True)
    for d in range(2):
        span = upper[d] - lower[d]
        if parts[d].periodic and abs(span - 2 * np.pi) <= FULL_TURN_RTOL * 2 * np.pi:
            upper[d] = lower[d] + 2 * np.pi         # a full turn: the axis is periodic
    return lower, upper, t["shape"]


def _energy(r: _Reader, value):
    t = r.table(value, "energy", ENERGY_KEYS)
    if t["r_min"] is not None and not t["r_min"] < t["r_c"]:
        r.fail("energy.r_min", f"expected r_min < r_c = {t['r_c']:g}, got {t['r_min']:g}")
    springs = []
    for i, spring in enumerate(t["springs"]):
        s = r.table(spring, f"energy.springs[{i}]", SPRING_KEYS)
        springs.append(GridSpring(int(s["axis"]), s["k"], s["center"], s["side"]))
    return t["v"], t["r_c"], t["r_min"], tuple(springs)


def _dynamics(r: _Reader, value):
    t = r.table(value, "dynamics", DYNAMICS_KEYS)
    walls = None
    if t["walls"] is not None:
        w = r.table(t["walls"], "dynamics.walls", WALL_KEYS)
        walls = Walls(w["k"], w["margin"], [list(edge) for edge in w["edges"]])
    return np.array(t["mass"]), np.array(t["damping"]), t["dt"], walls


def _analysis(r: _Reader, value) -> dict:
    kind = {"kind": Key("choice", choices=tuple(ANALYSES))}
    others = {name for keys in ANALYSES.values() for name in keys}
    chosen = r.table(value, "analysis", kind, also=sorted(others))["kind"]
    return r.table(value, "analysis", {**kind, **ANALYSES[chosen]})


# --------------------------------------------------------------------------- the file

def parse_device(data: dict, path: str = "<device>") -> Device:
    """Check the parsed TOML ``data`` of a device file and build its [`Device`][pes_ref.devices.device.Device]."""
    r = _Reader(path)
    top = r.table(data, "", TOP_KEYS)
    name = os.path.splitext(os.path.basename(path))[0] if top["name"] is None else top["name"]
    parts = tuple(_part(r, p, f"part[{i}]") for i, p in enumerate(top["part"]))
    lower, upper, shape = _cspace(r, top["cspace"], parts)
    tolerance = r.table(top["geometry"], "geometry", GEOMETRY_KEYS)["tolerance"]
    v, r_c, r_min, springs = _energy(r, top["energy"])
    mass, damping, dt, walls = _dynamics(r, top["dynamics"])
    start = np.array(r.table(top["start"], "start", START_KEYS)["q"])
    analysis = {} if top["analysis"] is None else _analysis(r, top["analysis"])
    rigid = r.table(top["rigid"], "rigid", RIGID_KEYS)
    realized = r.table(top["realized"], "realized", REALIZED_KEYS)
    try:
        return Device(parts, lower, upper, shape, v, r_c, springs, mass, damping, dt, start, r_min, walls,
                      tolerance, name, analysis, rigid["restitution"], rigid["friction"], realized["design"])
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
    """A device shipped in the package (`SHIPPED`), read from its file."""
    if name not in SHIPPED:
        raise checks.InputError("name", f"name must be one of {', '.join(SHIPPED)}, got {name!r}")
    with resources.as_file(resources.files("pes_ref.devices") / "data" / f"{name}.toml") as path:
        return load_device(path)
