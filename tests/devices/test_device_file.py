"""Device files: every key read, every bad key or value refused in one line naming it (pes_ref.devices.device_file)."""
import copy
import tomllib
from pathlib import Path

import numpy as np
import pytest

import pes_ref
from pes_ref.devices import device_file as F
from pes_ref.devices.geometry import Circle, Polygon, Rectangle

ROOT = Path(pes_ref.__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "examples" / "devices").glob("*.toml"))

#: A small valid file that uses every key (the base of the refusals below).
FULL = """
format = 1
name = "every key"
description = "a pin in a plate with a hole, on a plane"

[[part]]
name = "pin"
motion = "translation"
direction = [1.0, 0.0]
shapes = [{ circle = { center = [0.0, 0.0], radius = 0.1 } }]

[[part]]
name = "plate"
motion = "translation"
direction = [0.0, 2.0]
shapes = [
    { rectangle = { lower = [-1.0, -1.0], upper = [1.0, 1.0] }, minus = [
        { circle = { center = [0.0, 0.0], radius = 0.5 } },
        { polygon = [[0.4, -0.1], [1.2, -0.1], [1.2, 0.1], [0.4, 0.1]] },
    ] },
    { polygon = [[2.0, 0.0], [3.0, 0.0], [2.5, 1.0]] },
]

[cspace]
lower = [-0.5, -0.5]
upper = [0.5, 0.5]
shape = [21, 17]

[geometry]
tolerance = 1e-4

[energy]
v = 1e-4
r_c = 0.1
r_min = 0.02
springs = [{ axis = 0, k = 2.0, center = 0.1, side = "above" }, { axis = 1, k = 1.0, center = 0.0 }]

[dynamics]
mass = [1.0, 2.0]
damping = [0.5, 0.0]
dt = 1e-3
walls = { k = 100.0, margin = 0.01, edges = [[true, true], [false, true]] }

[start]
q = [0.1, -0.2]
"""


def test_every_key_is_read():
    d = F.parse_device(tomllib.loads(FULL), "full.toml")
    assert d.name == "every key" and d.shape == (21, 17) and d.periodic == (False, False)
    pin, plate = d.parts
    assert isinstance(pin.shapes[0], Circle) and pin.shapes[0].radius == 0.1
    assert isinstance(plate.shapes[0], Rectangle) and len(plate.shapes[0].minus) == 2
    assert isinstance(plate.shapes[1], Polygon)
    np.testing.assert_allclose(plate.motion.direction, [0.0, 1.0])          # normalized
    assert d.grid.tolerance == 1e-4 and d.r_min == 0.02 and d.dt == 1e-3
    assert [(s.axis, s.k, s.center, s.side) for s in d.springs] == [(0, 2.0, 0.1, "above"), (1, 1.0, 0.0, "both")]
    np.testing.assert_array_equal(d.mass, [1.0, 2.0])
    np.testing.assert_array_equal(d.walls.edges, [[True, True], [False, True]])
    np.testing.assert_array_equal(d.start, [0.1, -0.2])


def test_a_full_turn_is_periodic_and_made_exact():
    data = tomllib.loads(FULL)
    data["part"][0] = {"motion": "rotation", "pivot": [0.0, 0.0], "shapes": data["part"][0]["shapes"]}
    data["cspace"]["lower"], data["cspace"]["upper"] = [0.0, -0.5], [6.28318531, 0.5]   # 2 pi within 1e-6
    data["dynamics"]["walls"]["edges"] = [[False, False], [False, True]]
    d = F.parse_device(data, "turn.toml")
    assert d.periodic == (True, False) and d.upper[0] == 2 * np.pi


@pytest.mark.parametrize("name", F.SHIPPED)
def test_the_shipped_devices_load(name):
    d = F.shipped_device(name)
    assert d.name == name and d.analysis["kind"] == name


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_the_example_files_load(path):
    d = F.load_device(path)
    assert d.name == path.stem and min(d.shape) >= 2


def _edit(path: str, value):
    """FULL with the key at ``path`` (dots and [i]) set to ``value`` (``DELETE`` removes it)."""
    data = copy.deepcopy(tomllib.loads(FULL))
    keys = [int(k) if k.isdigit() else k for k in path.replace("[", ".").replace("]", "").split(".")]
    node = data
    for k in keys[:-1]:
        node = node[k]
    if value is DELETE:
        del node[keys[-1]]
    else:
        node[keys[-1]] = value
    return data


DELETE = object()

#: (the key changed, its new value, what the one-line error must name)
BAD = [
    ("format", 2, "format: this is pes_ref's device-file format 1; the file says format = 2"),
    ("format", DELETE, "format: missing"),
    ("colour", "red", "colour: unknown key"),
    ("part", [], "part: expected exactly two [[part]] tables"),
    ("part[0].motion", "screw", "part[0].motion: expected one of 'rotation', 'translation', 'drum', got 'screw'"),
    ("part[1].motion", "drum", "part[1].direction: a drum has a radius, not a direction"),
    ("part[1].radius", 0.5, "part[1].radius: a translating part has a direction, not a radius"),
    ("part[0].direction", DELETE, "part[0].direction: missing"),
    ("part[0].direction", [0.0, 0.0], "part[0].direction: expected a non-zero direction"),
    ("part[0].pivot", [0.0, 0.0], "part[0].pivot: a translating part has a direction, not a pivot"),
    ("part[0].speed", 3, "part[0].speed: unknown key"),
    ("part[0].shapes", [], "part[0].shapes: expected a non-empty list of shapes"),
    ("part[0].shapes[0]", {"ellipse": {}}, "part[0].shapes[0].ellipse: unknown key"),
    ("part[0].shapes[0]", {}, "part[0].shapes[0]: expected exactly one of polygon, circle, rectangle"),
    ("part[0].shapes[0].circle.radius", -1, "part[0].shapes[0].circle.radius: expected a number > 0, got -1"),
    ("part[0].shapes[0].circle.center", [0.0], "part[0].shapes[0].circle.center: expected a list of two numbers"),
    ("part[0].shapes[0].circle.centre", [0, 0], "part[0].shapes[0].circle.centre: unknown key"),
    ("part[1].shapes[0].rectangle.upper", [-2.0, 1.0], "part[1].shapes[0].rectangle.upper: expected upper > lower"),
    ("part[1].shapes[0].minus[1].polygon", [[0, 0], [3, 3], [3, 0], [0, 1]],
     "part[1].shapes[0].minus[1].polygon: vertices must form a simple polygon"),
    ("part[1].shapes[1].polygon", [[0, 0], [1, 0]], "part[1].shapes[1].polygon: expected a list of at least three"),
    ("part[1].shapes[1].polygon[2]", ["a", 1], "part[1].shapes[1].polygon[2][0]: expected a finite number, got 'a'"),
    ("part[1].shapes[0].minus", {"circle": 1}, "part[1].shapes[0].minus: expected a list of shapes"),
    ("cspace.shape", [1, 5], "cspace.shape[0]: expected an integer >= 2, got 1"),
    ("cspace.shape", [10.5, 5], "cspace.shape[0]: expected an integer >= 2, got 10.5"),
    ("cspace.upper", [-1.0, 1.0], "cspace.upper[0]: expected upper > lower"),
    ("cspace.lower", DELETE, "cspace.lower: missing"),
    ("cspace.periodic", [True, True], "cspace.periodic: unknown key"),
    ("geometry.tolerance", 0, "geometry.tolerance: expected a number > 0, got 0"),
    ("energy.v", -1e-3, "energy.v: expected a number >= 0"),
    ("energy.r_c", "wide", "energy.r_c: expected a finite number, got 'wide'"),
    ("energy.r_min", 0.5, "energy.r_min: expected r_min < r_c = 0.1, got 0.5"),
    ("energy.springs[0].axis", 2, "energy.springs[0].axis: expected an axis, 0 or 1, got 2"),
    ("energy.springs[1].side", "left", "energy.springs[1].side: expected one of"),
    ("energy.springs[1].k", float("nan"), "energy.springs[1].k: expected a finite number, got nan"),
    ("energy.springs[1].stiffness", 1.0, "energy.springs[1].stiffness: unknown key"),
    ("dynamics.mass", [1.0, 0.0], "dynamics.mass[1]: expected a number > 0, got 0.0"),
    ("dynamics.damping", [1.0], "dynamics.damping: expected a list of two numbers"),
    ("dynamics.dt", -1e-3, "dynamics.dt: expected a number > 0"),
    ("dynamics.walls.edges", [[True], [False, True]], "dynamics.walls.edges: expected [[lower0, upper0]"),
    ("dynamics.walls.edges", [True, True], "dynamics.walls.edges: expected [[lower0, upper0], [lower1, upper1]] of "
                                           "true/false, got [true, true]"),
    ("dynamics.walls.edges[0][1]", 1, "dynamics.walls.edges[0][1]: expected true or false, got 1"),
    ("dynamics.walls.k", 0.0, "dynamics.walls.k: expected a number > 0"),
    ("start.q", [1.0, True], "start.q[1]: expected a finite number, got true"),
    ("start.velocity", [0, 0], "start.velocity: unknown key"),
    ("analysis", {"kind": "catapult"}, "analysis.kind: expected one of 'ratchet', 'dartgun', got 'catapult'"),
    ("analysis", {"kind": "ratchet", "pitch": 0.5}, "analysis.settle: missing"),
    ("analysis", {"kind": "ratchet", "pitch": 0.5, "settle": 1.0, "teeth": 4}, "analysis.teeth: unknown key"),
    ("rigid", {"restitution": 1.5}, "rigid.restitution: expected a number in [0, 1], got 1.5"),
    ("rigid", {"restitution": -0.1}, "rigid.restitution: expected a number >= 0, got -0.1"),
    ("rigid", {"friction": "high"}, "rigid.friction: expected a finite number, got 'high'"),
    ("rigid", {"stiffness": 1e6}, "rigid.stiffness: unknown key"),
    ("rigid", 0.5, "rigid: expected a table, got 0.5"),
]


@pytest.mark.parametrize("key, value, message", BAD, ids=[(f"{k} deleted" if v is DELETE else f"{k}={v!r}")[:60] for k, v, _ in BAD])
def test_a_bad_key_or_value_is_refused_in_one_line_naming_it(key, value, message):
    with pytest.raises(F.DeviceFileError) as err:
        F.parse_device(_edit(key, value), "bad.toml")
    text = str(err.value)
    assert text.startswith("bad.toml: ") and "\n" not in text
    assert message in text, text


@pytest.mark.parametrize("table, expected", [(None, (0.0, 0.0)), ({}, (0.0, 0.0)),
                                             ({"restitution": 0.25, "friction": 0.5}, (0.25, 0.5))])
def test_the_rigid_table_sets_the_contact_and_defaults_to_inelastic_and_frictionless(table, expected):
    data = _edit("rigid", table) if table is not None else copy.deepcopy(tomllib.loads(FULL))
    device = F.parse_device(data, "rigid.toml")
    assert (device.restitution, device.friction) == expected


#: A drum's drawing within one turn of a drum of radius 0.5 (y in [0, pi]): a plate with a hole.
DRUM_SHAPES = [{"rectangle": {"lower": [-1.0, 0.0], "upper": [1.0, 3.0]},
                "minus": [{"circle": {"center": [0.0, 1.5], "radius": 0.5}}]}]


def _drum(**keys):
    """FULL with part 1 a drum of radius 0.5 (its other keys replaced by ``keys``)."""
    data = _edit("part[1]", {"motion": "drum", "radius": 0.5, "shapes": DRUM_SHAPES})
    data["part"][1].update(keys)
    data["dynamics"]["walls"]["edges"][1] = [False, False]
    return data


def test_a_drum_is_read_and_a_full_turn_of_it_is_periodic():
    data = _drum()
    data["cspace"]["lower"][1], data["cspace"]["upper"][1] = 0.0, 2 * np.pi * (1 + 1e-7)
    device = F.parse_device(data, "drum.toml")
    assert device.parts[1].motion.radius == 0.5 and device.periodic == (False, True)
    assert device.upper[1] == 2 * np.pi


@pytest.mark.parametrize("keys, message", [
    ({"radius": -1.0}, "part[1].radius: expected a number > 0, got -1"),
    ({"radius": "big"}, "part[1].radius: expected a finite number, got 'big'"),
    ({"radius": float("inf")}, "part[1].radius: expected a finite number, got inf"),
    ({"pivot": [0.0, 0.0]}, "part[1].pivot: a drum has a radius, not a pivot"),
    ({"shapes": tomllib.loads(FULL)["part"][1]["shapes"]},
     "part[1].shapes: the drum's shapes span y from -1 to 1, more than one turn of its surface: they must lie "
     "within y in [0, 2 pi R] = [0, 3.142]"),
    ({"radius": 0.4}, "part[1].shapes: the drum's shapes span y from 0 to 3, more than one turn"),
])
def test_a_bad_drum_is_refused_in_one_line_naming_its_key(keys, message):
    with pytest.raises(F.DeviceFileError) as err:
        F.parse_device(_drum(**keys), "bad.toml")
    assert message in str(err.value) and "\n" not in str(err.value), str(err.value)


def test_a_drum_without_its_radius_is_refused():
    data = _drum()
    del data["part"][1]["radius"]
    with pytest.raises(F.DeviceFileError, match=r"part\[1\].radius: missing"):
        F.parse_device(data, "bad.toml")


def test_a_periodic_axis_with_a_wall_is_refused():
    data = _edit("part[0]", {"motion": "rotation", "pivot": [0.0, 0.0],
                             "shapes": [{"circle": {"center": [0.2, 0.0], "radius": 0.1}}]})
    data["cspace"]["lower"], data["cspace"]["upper"] = [0.0, -0.5], [2 * np.pi, 0.5]
    with pytest.raises(F.DeviceFileError, match="dynamics.walls: axis 0 is periodic"):
        F.parse_device(data, "bad.toml")


@pytest.mark.parametrize("text, message", [
    ("format = 1\n[cspace\n", "not valid TOML"),
    ("\xff\xfe", "cannot read the device file"),
])
def test_unreadable_files_are_refused(tmp_path, text, message):
    path = tmp_path / "x.toml"
    path.write_bytes(text.encode("latin-1"))
    with pytest.raises(F.DeviceFileError, match=message):
        F.load_device(path)


def test_missing_files_and_folders_are_refused(tmp_path):
    with pytest.raises(F.DeviceFileError, match="device file .*nothing.toml does not exist"):
        F.load_device(tmp_path / "nothing.toml")
    with pytest.raises(F.DeviceFileError, match="is a folder"):
        F.load_device(tmp_path)
