"""Writing a realization's files and reading them back (``docs/realize.md``).

- ``device.toml``: the device-file format (``docs/devices.md``, written with tomli-w), so
  that every device tool (``analyze``, [`pes_ref.load_device`][pes_ref.devices.device_file.load_device]) applies to it;
- ``plate.dxf``: the plate's outline and cut-outs as closed LWPOLYLINEs on layer ``CUT``
  (ezdxf), one C-space length unit a unit of `DXF_UNITS` (``$INSUNITS``), for laser
  cutting; a plate of several pieces has dowel holes on layer ``DOWEL`` (`dowel_holes`),
  drilled through the base at the same places, that locate every piece;
- ``plate.stl``, ``base.stl``, ``pin.stl``: the plate's pieces extruded to its thickness, the
  slab they stand on (it holds the islands a cut-out leaves), and the pin as a cylinder of
  the same height (trimesh; the plate's faces triangulated by shapely's constrained
  Delaunay triangulation), for 3D printing;
- ``drum.dxf``, ``drum.stl``: a drum cam's walls on its surface unrolled (the same DXF: a
  template to cut and wrap round the drum), and the drum as one solid, its walls standing
  proud of a cylinder ([`drum_mesh`][pes_ref.realize.exports.drum_mesh]).

Every file is written atomically ([`pes_ref.core.runtime.files.atomic_file`][pes_ref.core.runtime.files.atomic_file]).
The readers
([`read_dxf_plate`][pes_ref.realize.exports.read_dxf_plate], [`read_stl`][pes_ref.realize.exports.read_stl]) rebuild
what a check needs from the files alone.
"""
from __future__ import annotations

import io

import numpy as np

from pes_ref.core.runtime.files import atomic_file

__all__ = ["device_text", "write_bytes", "write_text", "write_dxf", "read_dxf_plate", "read_dxf_units", "read_dxf_dowels",
           "plate_mesh", "base_mesh", "pin_mesh", "drum_mesh", "drum_volume", "write_stl", "read_stl", "dowel_holes", "dowel_polygons",
           "DXF_LAYER", "DOWEL_LAYER", "DXF_UNITS", "DOWEL_RIM_SHARE"]

#: The DXF layer of the cutting lines.
DXF_LAYER = "CUT"
#: The DXF layer of the dowel holes that locate a plate's pieces on its base.
DOWEL_LAYER = "DOWEL"
#: What one C-space length unit is in a DXF file (``realize --units``): name -> the header's
#: ``$INSUNITS`` code (the DXF reference's) and ``$MEASUREMENT`` (0 imperial, 1 metric).
DXF_UNITS = {"mm": (4, 1), "cm": (5, 1), "m": (6, 1), "in": (1, 0), "ft": (2, 0)}
#: A dowel hole's radius as a share of the plate's rim (every piece of a plate holds some rim).
DOWEL_RIM_SHARE = 0.2


def device_text(data: dict, header: str) -> str:
    """The device file's text of ``data`` (a parsed device file's tables), after ``header`` comment lines."""
    import tomli_w
    lines = "".join(f"# {line}\n" for line in header.splitlines())
    return lines + tomli_w.dumps(data)


def write_bytes(path, data: bytes, overwrite: bool, what: str) -> None:
    """``data`` into ``path`` atomically (an existing file kept unless ``overwrite``)."""
    with atomic_file(path, overwrite=overwrite, what=what) as fh:
        fh.write(data)


def write_text(path, text: str, overwrite: bool, what: str) -> None:
    """``text`` into ``path`` as UTF-8, atomically ([`write_bytes`][pes_ref.realize.exports.write_bytes])."""
    write_bytes(path, text.encode("utf-8"), overwrite, what)


def dowel_holes(plate, radius: float) -> list:
    """Where a plate of several pieces is located on its base: two dowel holes of ``radius`` in
    each piece, ``(x, y)`` centres, the two points farthest apart of the piece shrunk by twice
    the radius (a hole with a radius of material round it); none for a plate of one piece, and
    none in a piece too thin to hold a hole (it is then not located: see ``plate_pieces`` and
    ``dowel_holes`` in the report)."""
    import shapely
    pieces = list(getattr(plate, "geoms", [plate]))
    if len(pieces) < 2:
        return []
    out = []
    for piece in pieces:
        room = piece.buffer(-2.0 * radius)
        if room.is_empty:
            continue
        corners = shapely.get_coordinates(room.convex_hull)
        gap = np.linalg.norm(corners[:, None, :] - corners[None, :, :], axis=2)
        i, j = np.unravel_index(int(np.argmax(gap)), gap.shape)
        out += [tuple(map(float, corners[min(i, j)])), tuple(map(float, corners[max(i, j)]))]
    return out


def dowel_polygons(centres, radius: float):
    """The dowel holes as one shapely geometry (discs of 64 sides), what the meshes cut."""
    import shapely
    return shapely.union_all([shapely.Point(c).buffer(radius, quad_segs=16) for c in centres])


def write_dxf(path, plate, overwrite: bool, units: str = "mm", dowels=(), dowel_radius: float = 0.0) -> None:
    """The plate's rings (outlines and holes) as closed polylines on `DXF_LAYER`, in
    ``units`` (`DXF_UNITS`), and the ``dowels`` (centres) as circles of ``dowel_radius``
    on `DOWEL_LAYER`."""
    import ezdxf
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"], doc.header["$MEASUREMENT"] = DXF_UNITS[units]
    doc.layers.add(DXF_LAYER)
    msp = doc.modelspace()
    for poly in getattr(plate, "geoms", [plate]):
        for ring in [poly.exterior, *poly.interiors]:
            msp.add_lwpolyline(np.asarray(ring.coords)[:-1, :2].tolist(), close=True,
                               dxfattribs={"layer": DXF_LAYER})
    if dowels:
        doc.layers.add(DOWEL_LAYER)
    for centre in dowels:
        msp.add_circle(centre, dowel_radius, dxfattribs={"layer": DOWEL_LAYER})
    buf = io.StringIO()
    doc.write(buf)
    write_text(path, buf.getvalue(), overwrite, "DXF")


def read_dxf_units(path) -> str:
    """The name (`DXF_UNITS`) of a DXF file's ``$INSUNITS``, or ``"unitless"``."""
    import ezdxf
    code = ezdxf.readfile(path).header.get("$INSUNITS", 0)
    return next((name for name, (c, _) in DXF_UNITS.items() if c == code), "unitless")


def read_dxf_dowels(path) -> list:
    """The dowel holes of a DXF file: ``(x, y, radius)`` of its circles on `DOWEL_LAYER`."""
    import ezdxf
    return [(float(e.dxf.center.x), float(e.dxf.center.y), float(e.dxf.radius))
            for e in ezdxf.readfile(path).modelspace().query("CIRCLE") if e.dxf.layer == DOWEL_LAYER]


def read_dxf_plate(path):
    """The plate rebuilt from a DXF file: its closed polylines on `DXF_LAYER`, each ring
    inside an odd number of others a hole (even-odd), as one shapely geometry."""
    import ezdxf
    import shapely
    doc = ezdxf.readfile(path)
    rings = [shapely.Polygon(np.asarray(e.get_points("xy"))) for e in doc.modelspace().query("LWPOLYLINE")
             if e.dxf.layer == DXF_LAYER and e.closed]
    out = shapely.Polygon()
    for ring in rings:
        out = shapely.symmetric_difference(out, ring)
    return shapely.normalize(out)


def _triangulated(poly):
    import shapely
    tris = shapely.constrained_delaunay_triangles(poly)
    corners = np.array([np.asarray(t.exterior.coords)[:3] for t in tris.geoms])
    vertices, faces = np.unique(corners.reshape(-1, 2), axis=0, return_inverse=True)
    return vertices, faces.reshape(-1, 3)


def plate_mesh(plate, thickness: float):
    """The plate's pieces extruded from z = 0 to ``thickness``: separate watertight bodies, one mesh."""
    import trimesh
    return trimesh.util.concatenate([trimesh.creation.extrude_triangulation(*_triangulated(p), thickness)
                                     for p in getattr(plate, "geoms", [plate])])


def base_mesh(plate, thickness: float, holes=None):
    """The base that holds the plate's pieces (islands among them): a slab the plate's bounding
    box wide, from z = -thickness to 0, less ``holes`` (the dowel holes, a shapely geometry)."""
    import shapely
    import trimesh
    slab = shapely.box(*plate.bounds)
    slab = slab if holes is None or holes.is_empty else slab.difference(holes)
    base = trimesh.creation.extrude_triangulation(*_triangulated(slab), thickness)
    base.apply_translation([0.0, 0.0, -thickness])
    return base


def pin_mesh(radius: float, height: float):
    """The pin: a cylinder of ``radius`` and ``height`` standing on z = 0 at the origin."""
    import trimesh
    mesh = trimesh.creation.cylinder(radius=radius, height=height, sections=64)
    mesh.apply_translation([0.0, 0.0, height / 2])
    return mesh


def drum_mesh(walls, radius: float, thickness: float, cell: float):
    """A drum cam as one watertight solid: a cylinder of ``radius`` about the x axis, as long as
    the ``walls`` (the unrolled drawing: x along the axis, y = the arc length ``radius * angle``
    in ``[0, 2 pi radius]``), with the walls standing ``thickness`` proud of it. Its surface is
    sampled on nodes about ``cell`` apart along x and round the drum (a tube of quads, closed by
    a fan at each end): radius + thickness at a node inside the walls, radius elsewhere, so a
    wall's side rises across one cell (the DXF holds the exact outline)."""
    import shapely
    import trimesh
    from pes_ref.devices.geometry import Drum
    x0, _, x1, _ = walls.bounds
    nx = int(np.ceil((x1 - x0) / cell)) + 1
    nu = max(8, int(np.ceil(2.0 * np.pi * radius / cell)))
    x = np.linspace(x0, x1, nx)
    theta = 2.0 * np.pi * np.arange(nu) / nu
    X, T = np.meshgrid(x, theta, indexing="ij")
    inside = shapely.contains_xy(Drum(radius).tiled(walls), X, radius * T)
    rho = radius + thickness * inside
    tube = np.stack([X.ravel(), (rho * np.cos(T)).ravel(), (rho * np.sin(T)).ravel()], axis=1)
    idx = np.arange(nx * nu).reshape(nx, nu)
    nxt = np.roll(idx, -1, axis=1)
    a, b, c, d = idx[:-1].ravel(), idx[1:].ravel(), nxt[1:].ravel(), nxt[:-1].ravel()
    ends = np.array([[x0, 0.0, 0.0], [x1, 0.0, 0.0]])
    e0, e1 = nx * nu, nx * nu + 1
    faces = [np.stack([a, c, b], 1), np.stack([a, d, c], 1),                            # the tube, outward
             np.stack([np.full(nu, e0), nxt[0], idx[0]], 1), np.stack([np.full(nu, e1), idx[-1], nxt[-1]], 1)]  # ends
    return trimesh.Trimesh(np.concatenate([tube, ends]), np.concatenate(faces), process=True)


def drum_volume(walls, radius: float, thickness: float) -> float:
    """The volume of the exact drum [`drum_mesh`][pes_ref.realize.exports.drum_mesh] samples: the cylinder ``pi R^2 L``
    (L the
    walls' length along x) and the walls, each unit of their unrolled area a shell
    ``thickness (1 + thickness / (2 R))`` thick."""
    x0, _, x1, _ = walls.bounds
    return float(np.pi * radius ** 2 * (x1 - x0) + walls.area * thickness * (1.0 + thickness / (2.0 * radius)))


def write_stl(path, mesh, overwrite: bool) -> None:
    """A trimesh ``mesh`` into ``path`` as binary STL, atomically ([`write_bytes`][pes_ref.realize.exports.write_bytes])."""
    write_bytes(path, mesh.export(file_type="stl"), overwrite, "STL")


def read_stl(path):
    """The mesh of an STL file (trimesh, vertices merged)."""
    import trimesh
    return trimesh.load_mesh(path, file_type="stl")
