"""A realization's files: named per follower, written as one set, read back and checked.

`CONTACT_FILES` names a contact realization's files per follower and `HEIGHTFIELD_FILES` the
heightfield's, known before anything is computed (the command checks every path first).
[`write_contact`][pes_ref.realize.files.write_contact] makes the drawings and meshes whole in a
staging folder beside them and moves them into place
([`pes_ref.core.runtime.files.move_into`][pes_ref.core.runtime.files.move_into]), then writes the
set's index, ``device.toml``, last and atomically, so that a stop part-way leaves no half file;
[`check_contact`][pes_ref.realize.files.check_contact] reads every file back.
[`write_heightfield`][pes_ref.realize.files.write_heightfield] writes the plate's STL and reads it
back.
"""
from __future__ import annotations

import io
import os
import shutil
import tempfile

import numpy as np

__all__ = ["CONTACT_FILES", "HEIGHTFIELD_FILES", "MESHES", "write_contact", "check_contact", "write_heightfield"]

#: A contact realization's files, per follower (`pes_ref.realize.followers.FOLLOWERS`' names):
#: output key -> (file name, what it is, for refusals).
CONTACT_FILES = {
    "pin-in-plate": {"device": ("device.toml", "device"), "dxf": ("plate.dxf", "DXF"),
                     "plate_stl": ("plate.stl", "STL"), "base_stl": ("base.stl", "STL"), "pin_stl": ("pin.stl", "STL"),
                     "png": ("parts.png", "drawing")},
    "drum-cam": {"device": ("device.toml", "device"), "dxf": ("drum.dxf", "DXF"), "drum_stl": ("drum.stl", "STL"),
                 "pin_stl": ("pin.stl", "STL"), "png": ("parts.png", "drawing")},
}
#: The heightfield realization's one file.
HEIGHTFIELD_FILES = {"stl": ("heightfield.stl", "STL")}


def _plate_meshes(real) -> dict:
    """The plate's pieces and the base, both with the dowel holes through them, and the pin."""
    from pes_ref.realize import exports
    plate, t = real.parts.plate, real.thickness
    holes = exports.dowel_polygons(real.dowels, real.dowel_radius)
    return {"plate_stl": exports.plate_mesh(plate.difference(holes), t),
            "base_stl": exports.base_mesh(plate, t, holes), "pin_stl": exports.pin_mesh(real.parts.pin_made, t)}


def _drum_meshes(real) -> dict:
    from pes_ref.realize import exports
    parts, t = real.parts, real.thickness
    return {"drum_stl": exports.drum_mesh(parts.plate, parts.motion["radius"], t, _drum_cell(real)),
            "pin_stl": exports.pin_mesh(parts.pin_made, t)}


def _drum_cell(real) -> float:
    """The drum STL's node spacing: a quarter of the design grid's finer spacing on the drum's surface."""
    return float(min(real.region.spacing * [1.0, real.parts.motion["radius"]])) / 4.0


def _drum_volume(real, part) -> float:
    from pes_ref.realize import exports
    return exports.drum_volume(part, real.parts.motion["radius"], real.thickness)


#: Per follower: its meshes (realization -> {output key: mesh}) and the volume the first
#: mesh should have, from the part read back from the DXF (realization, part -> (name, volume)).
MESHES = {
    "pin-in-plate": (_plate_meshes, lambda real, part: ("plate_volume_expected", float(part.area * real.thickness))),
    "drum-cam": (_drum_meshes, lambda real, part: ("drum_volume_expected", _drum_volume(real, part))),
}


def write_contact(real, problem, values, outputs: dict, force: bool) -> None:
    """Write a contact realization ``real`` of design ``values`` of ``problem`` to ``outputs``
    (output key -> path, `CONTACT_FILES`' keys) as one set (module docstring); the
    drawing shows the pin along one of the design's paths (the ``visited`` rule's seed)."""
    from pes_ref.core.runtime.files import move_into
    from pes_ref.realize import exports
    from pes_ref.realize.drawing import parts_figure
    from pes_ref.realize.hooks import held_out_positions
    from pes_ref.realize.regions import VISITED_SEED
    folder = os.path.dirname(outputs["device"]) or "."
    os.makedirs(folder, exist_ok=True)
    staging = tempfile.mkdtemp(prefix=".realize-", dir=folder)
    try:
        staged = {key: os.path.join(staging, os.path.basename(path)) for key, path in outputs.items()}
        exports.write_dxf(staged["dxf"], real.parts.plate, False, real.units, real.dowels, real.dowel_radius)
        for key, mesh in MESHES[real.parts.follower][0](real).items():
            exports.write_stl(staged[key], mesh, False)
        path = held_out_positions(problem, values, VISITED_SEED, n_particles=1)[:, 0, :]
        buf = io.BytesIO()
        parts_figure(real, path).savefig(buf, format="png", dpi=110)
        exports.write_bytes(staged["png"], buf.getvalue(), False, "drawing")
        move_into([staged[key] for key in outputs if key != "device"], folder)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    header = f"{real.device['description']}\nwritten by pes_ref realize (docs/realize.md)"
    exports.write_text(outputs["device"], exports.device_text(real.device, header), force, "device")


def check_contact(real, outputs: dict) -> dict:
    """Every file read back: the blocked share of the device file's C-space, the part's area
    from the DXF against the device file's, each mesh's watertightness and volume, and the
    volume the first mesh should have."""
    from pes_ref.devices.device_file import load_device
    from pes_ref.realize import exports
    device = load_device(outputs["device"])
    part = exports.read_dxf_plate(outputs["dxf"])
    file_part = device.parts[1].geometry(device.grid.tolerance)
    name = real.parts.part_name
    dowels = exports.read_dxf_dowels(outputs["dxf"])
    out = {"device_blocked_share": float(device.cspace().blocked.mean()),
           f"{name}_area_dxf": float(part.area), f"{name}_area_device": float(file_part.area),
           "dxf_units": f"{exports.read_dxf_units(outputs['dxf'])} (one C-space length unit)",
           f"{name}_pieces": len(getattr(part, "geoms", [part])),
           "dowel_holes": f"{len(dowels)} (two in each of {len(dowels) // 2} pieces, radius {real.dowel_radius:g}, "
                          f"layer {exports.DOWEL_LAYER}; through the base at the same places)" if dowels else "0"}
    if dowels:
        part = part.difference(exports.dowel_polygons([d[:2] for d in dowels], dowels[0][2]))
    for key in outputs:
        if key.endswith("_stl"):
            mesh = exports.read_stl(outputs[key])
            out[f"{key[:-4]}_watertight"] = bool(mesh.is_watertight)
            out[f"{key[:-4]}_volume"] = float(mesh.volume)
    expected, volume = MESHES[real.parts.follower][1](real, part)
    out[expected] = volume
    return out


def write_heightfield(hf, base: float, path, force: bool) -> tuple:
    """Write the plate of heightfield ``hf`` (``base`` below its lowest point) as an STL at
    ``path``, read it back: ``(the heightfield read back, figures)`` (the heights' range and
    slopes, the mesh's watertightness and volume, and how far the heights read back are from
    the written ones: the STL stores float32)."""
    from pes_ref.realize import exports
    from pes_ref.realize.heightfield import HeightField, heightfield_mesh, heights_from_mesh
    os.makedirs(os.path.dirname(os.fspath(path)) or ".", exist_ok=True)
    exports.write_stl(path, heightfield_mesh(hf, base), force)
    mesh = exports.read_stl(path)
    heights = heights_from_mesh(mesh, hf)
    slope = hf.slope()
    figures = {"g": hf.g, "height_range": float(np.ptp(hf.heights)), "max_slope": float(slope.max()),
               "slope_share_over_0.1": float(np.mean(slope > 0.1)), "watertight": bool(mesh.is_watertight),
               "volume": float(mesh.volume), "height_error": float(np.max(np.abs(heights - hf.heights)))}
    return HeightField(heights, hf.lower, hf.upper, hf.mass, hf.g), figures
