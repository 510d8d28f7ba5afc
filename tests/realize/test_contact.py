"""A design realized by contact: the region, the pin-in-plate parts, the files read back."""
from __future__ import annotations

import tomllib

import numpy as np
import pytest

from pes_ref.devices.device_file import parse_device
from pes_ref.realize import exports
from pes_ref.realize.contact import realize_contact
from pes_ref.realize.regions import contact_region
from pes_ref.synthesis.kinds.funnel import FunnelProblem

GRID = 41
LEVEL = 0.1


def _v_walls(problem) -> np.ndarray:
    """A funnel's energy with two V walls: 0.2 beyond ``|q0| = 0.25 + 0.4 q1``, a ramp 0.1 wide below."""
    q0 = np.linspace(problem.lower[0], problem.upper[0], GRID)[:, None]
    q1 = np.linspace(problem.lower[1], problem.upper[1], GRID)[None, :]
    ramp = np.clip((np.abs(q0) - (0.25 + 0.4 * q1)) / 0.1, 0.0, 1.0)
    return 0.2 * ramp * problem.mask((GRID, GRID))


@pytest.fixture(scope="module")
def problem():
    return FunnelProblem(grid=GRID, n_steps=300)


@pytest.fixture(scope="module")
def realized(problem):
    return realize_contact(problem, _v_walls(problem), "value", LEVEL, name="v")


def test_the_value_rule_blocks_above_the_level_and_reports_its_neighbours(problem, realized):
    values = _v_walls(problem)
    region = realized.region
    assert region.rule == "value" and region.level == LEVEL
    np.testing.assert_array_equal(region.phi < 0, values > LEVEL)
    assert [label for label, *_ in realized.sensitivity] == ["level -0.05 x range", "level +0.05 x range"]
    low, high = (share for _, _, share, _ in realized.sensitivity)
    assert low > region.blocked_share > high


def test_the_level_set_rule_needs_a_realizable_design(problem):
    with pytest.raises(ValueError, match="needs a design made realizable"):
        contact_region(problem, _v_walls(problem), "level-set")


def test_the_device_file_blocks_what_the_design_blocks(realized):
    device = parse_device(tomllib.loads(exports.device_text(realized.device, "test")), "v.toml")
    blocked = device.cspace().blocked
    design = realized.region.phi < 0
    assert blocked.shape == design.shape
    # the two differ only next to the boundary: the pin's closing and the contour's chords
    differ = blocked != design
    from scipy import ndimage
    near = ndimage.binary_dilation(design) & ndimage.binary_dilation(~design)    # a node from the boundary
    assert differ.mean() < 0.02 and not (differ & ~near).any()


def test_the_exit_edge_is_open_and_the_walled_sides_are_not(realized):
    plate = realized.parts.plate
    lo, hi = realized.parts.box
    import shapely
    r, rim = realized.parts.pin_radius, 0.1
    below = shapely.box(-0.05, lo[1] - r - rim + 0.01, 0.05, lo[1] - r - 0.01)   # in the bottom rim, under the exit
    assert plate.bounds[1] < below.bounds[1] and not plate.intersects(below)
    side = shapely.box(hi[0] + r + 0.01, 0.5, hi[0] + r + rim - 0.01, 0.6)        # in the side rim
    assert plate.contains(side)


def test_the_dxf_rebuilds_the_plate(realized, tmp_path):
    path = tmp_path / "plate.dxf"
    exports.write_dxf(path, realized.parts.plate, overwrite=False)
    back = exports.read_dxf_plate(path)
    assert back.symmetric_difference(realized.parts.plate).area < 1e-9 * realized.parts.plate.area


@pytest.mark.parametrize("make", ["plate", "base", "pin"])
def test_the_stl_meshes_are_watertight_with_the_volume_of_their_part(realized, tmp_path, make):
    t = realized.thickness
    plate = realized.parts.plate
    mesh, volume = {"plate": (exports.plate_mesh(plate, t), plate.area * t),
                    "base": (exports.base_mesh(plate, t), plate.envelope.area * t),
                    "pin": (exports.pin_mesh(realized.parts.pin_radius, t), None)}[make]
    exports.write_stl(tmp_path / "part.stl", mesh, overwrite=False)
    back = exports.read_stl(tmp_path / "part.stl")
    assert back.is_watertight
    if volume is None:          # a 64-gon's prism
        r = realized.parts.pin_radius
        volume = 0.5 * 64 * r * r * np.sin(2 * np.pi / 64) * t
    assert back.volume == pytest.approx(volume, rel=1e-6)         # STL stores float32 coordinates


def test_an_existing_file_is_kept(realized, tmp_path):
    path = tmp_path / "plate.dxf"
    path.write_text("a user's drawing")
    with pytest.raises(FileExistsError):
        exports.write_dxf(path, realized.parts.plate, overwrite=False)
    assert path.read_text() == "a user's drawing"


def test_what_is_lost_is_said(realized):
    assert any("energies below the contact level" in line for line in realized.lost)
    assert any("changes side" in line for line in realized.lost)


def test_a_clearance_makes_the_pin_larger_than_its_cut_out_and_grows_what_the_parts_block(problem, realized):
    loose = realize_contact(problem, _v_walls(problem), "value", LEVEL, name="v", clearance=0.05, restitution=0.9)
    assert loose.parts.plate.equals(realized.parts.plate)           # the same plate ...
    pin = loose.device["part"][0]["shapes"][0]["circle"]["radius"]
    assert pin == pytest.approx(realized.parts.pin_radius + 0.05)   # ... and a larger pin
    device = parse_device(tomllib.loads(exports.device_text(loose.device, "test")), "v.toml")
    tight = parse_device(tomllib.loads(exports.device_text(realized.device, "test")), "v.toml")
    grown = device.cspace().blocked
    assert (grown >= tight.cspace().blocked).all() and grown.mean() > tight.cspace().blocked.mean()
    assert device.restitution == 0.9 and tight.restitution == 0.0 and "rigid" not in realized.device
    assert any("0.05 larger" in line for line in loose.lost)


@pytest.mark.parametrize("kw, words", [({"clearance": -0.1}, "clearance must be >= 0"),
                                       ({"restitution": 1.5}, r"restitution must be in \[0, 1\]")])
def test_a_bad_clearance_or_restitution_is_refused_naming_it(problem, kw, words):
    with pytest.raises(ValueError, match=words):
        realize_contact(problem, _v_walls(problem), "value", LEVEL, **kw)


@pytest.mark.parametrize("units", sorted(exports.DXF_UNITS))
def test_the_dxf_states_its_units(realized, tmp_path, units):
    """``$INSUNITS`` names what one C-space length unit is (a DXF without it is unitless to a machinist)."""
    path = tmp_path / "plate.dxf"
    exports.write_dxf(path, realized.parts.plate, False, units)
    assert exports.read_dxf_units(path) == units
    import ezdxf
    header = ezdxf.readfile(path).header
    assert (header["$INSUNITS"], header["$MEASUREMENT"]) == exports.DXF_UNITS[units] and header["$INSUNITS"] != 0


def test_a_plate_of_several_pieces_is_located_by_dowel_holes_in_the_dxf_and_the_base(realized, tmp_path):
    import shapely
    plate, r, t = realized.parts.plate, realized.dowel_radius, realized.thickness
    pieces = list(getattr(plate, "geoms", [plate]))
    assert len(pieces) >= 2                                     # the V's exit and entry cut the frame in two
    assert realized.units == "mm" and r == pytest.approx(exports.DOWEL_RIM_SHARE * 0.1)
    holes = [shapely.Point(c).buffer(r) for c in realized.dowels]
    for piece in pieces:                                        # two in each piece, a radius of material round each
        inside = [h for h in holes if piece.contains(h.buffer(r * 0.999))]
        assert len(inside) == 2
    path = tmp_path / "plate.dxf"
    exports.write_dxf(path, plate, False, realized.units, realized.dowels, r)
    back = exports.read_dxf_dowels(path)
    assert np.allclose([(x, y) for x, y, _ in back], realized.dowels, rtol=0, atol=1e-12) and {d[2] for d in back} == {r}
    assert exports.read_dxf_plate(path).symmetric_difference(plate).area < 1e-9 * plate.area   # CUT unchanged
    cut = exports.dowel_polygons(realized.dowels, r)
    base = exports.base_mesh(plate, t, cut)
    assert base.is_watertight and base.volume == pytest.approx((plate.envelope.area - cut.area) * t, rel=1e-9)
    one = shapely.box(-1.0, -1.0, 1.0, 1.0).difference(shapely.box(-0.5, -0.5, 0.5, 0.5))
    assert exports.dowel_holes(one, r) == []                    # one piece: nothing to locate
