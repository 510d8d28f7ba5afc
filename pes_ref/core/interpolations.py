"""The registry of grid interpolations: the one place that maps a surface's
``interpolation`` name to the code that evaluates it.

``"bilinear"`` is docs/spec.md section 2, the paper's rule ([`pes_ref.core.bilinear`][pes_ref.core.bilinear]);
``"bicubic"`` the C1 Catmull-Rom option ([`pes_ref.core.bicubic`][pes_ref.core.bicubic],
``docs/variants.md``). [`Surface`][pes_ref.core.surface.Surface] validates its
``interpolation`` against `INTERPOLATIONS`, and
[`Surface`][pes_ref.core.surface.Surface] and [`pes_ref.core.forces`][pes_ref.core.forces] dispatch through
[`interpolation`][pes_ref.core.interpolations.interpolation]; adding a rule is adding an entry here.
"""
from __future__ import annotations

from typing import Callable, NamedTuple

from pes_ref.core import bicubic, bilinear

__all__ = ["Interpolation", "INTERPOLATIONS", "interpolation"]


class Interpolation(NamedTuple):
    """What a grid interpolation provides.

    The point functions are for one-off calls; each builds what it needs. With
    ``values`` (n0, n1), ``lower``, ``h`` (2,), ``periodic`` (2 bool) and points ``x`` (N, 2):

    point_energy : ``(values, lower, h, periodic, x) -> (N,)``
        The energy.
    point_slope : ``(values, lower, h, periodic, x) -> (N, 2)``
        The slope dE/dx.
    point_force : ``(values, lower, h, periodic, x, out) -> out``
        The force ``-dE/dx`` into ``out`` (N, 2), with the hot loop's arithmetic.
    point_force_vjp : ``(values, lower, h, periodic, x, w, xbar, gvalues) -> None``
        Its adjoint for the cotangent ``w``: ``xbar += (dF/dx)^T w`` and, if ``gvalues``
        (flat n0*n1) is not None, ``gvalues += (dF/dG)^T w``.
    forward : ``(field, n_particles) ->`` [`GridForce`][pes_ref.core.kernels.GridForce]
        The hot loop's force kernel (``field`` a [`Field`][pes_ref.core.forces.Field]).
    adjoint : ``(field, xs, want_values) ->`` [`GridAdjoint`][pes_ref.core.kernels.GridAdjoint]
        The backward loop's kernel over the stored states ``xs`` (T+1, N, 2).
    """

    point_energy: Callable
    point_slope: Callable
    point_force: Callable
    point_force_vjp: Callable
    forward: Callable
    adjoint: Callable


#: Every grid interpolation by name.
INTERPOLATIONS = {
    "bilinear": Interpolation(bilinear.point_energy, bilinear.point_slope, bilinear.point_force,
                              bilinear.point_force_vjp, bilinear.forward_kernel, bilinear.BilinearAdjoint),
    "bicubic": Interpolation(bicubic.point_energy, bicubic.point_slope, bicubic.point_force,
                             bicubic.point_force_vjp, bicubic.BicubicForce, bicubic.BicubicAdjoint),
}


def interpolation(name: str) -> Interpolation:
    """The registered interpolation ``name``; a ValueError that names it if there is none."""
    try:
        return INTERPOLATIONS[name]
    except (KeyError, TypeError):
        raise ValueError(f"interpolation must be one of {sorted(INTERPOLATIONS)}, got {name!r}") from None
