"""The optional extras of realization: ``realize``, shapely >= 2.1 (the parts' geometry and
their triangulation), contourpy (the blocked region's contour), ezdxf (DXF) and trimesh (STL);
and ``mujoco``, the heightfield's check in MuJoCo ([`pes_ref.realize.mujoco_ball`][pes_ref.realize.mujoco_ball]).

[`require_realize`][pes_ref.realize.extra.require_realize] imports shapely and finds the others
without importing them (each is imported where it is used; importing ezdxf and trimesh takes longer
than refusing a bad option), or raises
[`pes_ref.devices.geometry.MissingExtraError`][pes_ref.core.runtime.extras.MissingExtraError] with
the pip line, which the command line prints as its one error line.
[`require_mujoco`][pes_ref.realize.extra.require_mujoco] imports mujoco or raises the same error
with the extra's pip line (`MUJOCO_PIP_LINE`).
"""
from __future__ import annotations

from pes_ref.core.runtime.extras import MissingExtraError, found, pip_line, require

__all__ = ["PIP_LINE", "MUJOCO_PIP_LINE", "require_realize", "require_mujoco"]

#: The pip line that installs what realization needs.
PIP_LINE = pip_line("realize")
#: The pip line that installs MuJoCo, the heightfield's second check.
MUJOCO_PIP_LINE = pip_line("mujoco")
#: The oldest MuJoCo whose Python bindings the check uses (the extra's pin).
MUJOCO_MIN = (3, 2)
#: The modules of the extra beyond shapely, and what each is for.
_MODULES = (("contourpy", "contours"), ("ezdxf", "DXF files"), ("trimesh", "STL files"))


def require_realize() -> dict:
    """``{"shapely": the module}`` once every module of the extra is found, or
    [`MissingExtraError`][pes_ref.core.runtime.extras.MissingExtraError] naming the missing one and the pip line."""
    out = {"shapely": require("shapely", "realize", "realization", least=(2,))}
    if not hasattr(out["shapely"], "constrained_delaunay_triangles"):
        raise MissingExtraError(f"realization needs shapely >= 2.1 (its triangulation), found "
                                f"{out['shapely'].__version__}: {PIP_LINE}")
    for name, what in _MODULES:
        found(name, "realize", f"realization's {what}")
    return out


def require_mujoco():
    """The ``mujoco`` module (>= `MUJOCO_MIN`), or
    [`MissingExtraError`][pes_ref.core.runtime.extras.MissingExtraError] with `MUJOCO_PIP_LINE`."""
    return require("mujoco", "mujoco", "the MuJoCo check", least=MUJOCO_MIN)
