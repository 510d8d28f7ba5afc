"""The grid potential energy surface: the validated, frozen wrapper the public API hands around.

docs/spec.md section 2; paper section "Simulating potential energy surfaces". A surface is a
grid of energy values ``G`` of shape (n0, n1) on a plane, a cylinder (one axis
periodic) or a torus (both periodic). Axis 0 of ``G`` is coordinate q0, axis 1 is q1.
The lookup (spacing, cells and fractions, wrapping) is [`pes_ref.core.grid`][pes_ref.core.grid]; the
energy and slope between the nodes are the surface's interpolation, dispatched through
[`pes_ref.core.interpolations`][pes_ref.core.interpolations] (the bilinear rule of docs/spec.md section 2 by default).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pes_ref.core import checks
from pes_ref.core.grid import Cells, locate, spacing, wrap
from pes_ref.core import interpolations

__all__ = ["Surface"]


@dataclass(frozen=True)
class Surface:
    """A validated grid potential energy surface (docs/spec.md section 2).

    Parameters
    ----------
    values : array_like, shape (n0, n1), n0, n1 >= 2
        Energy at the grid nodes; axis 0 is q0, axis 1 is q1.
    lower, upper : array_like, shape (2,)
        The domain's corners, ``upper > lower`` on both axes.
    periodic : sequence of 2 bool
        (False, False) plane, one True a cylinder, (True, True) a torus.
    interpolation : {"bilinear", "bicubic"}
        A name in `pes_ref.core.interpolations.INTERPOLATIONS`: "bilinear"
        (default) is docs/spec.md section 2, the paper's rule; "bicubic" the C1 Catmull-Rom
        option of [`pes_ref.core.bicubic`][pes_ref.core.bicubic] (``docs/variants.md``).
    """

    values: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    periodic: tuple
    interpolation: str = "bilinear"

    def __post_init__(self):
        values = checks.as_float_array("values", self.values, ndim=2)
        if values.shape[0] < 2 or values.shape[1] < 2:
            raise checks.InputError("values", f"values must have at least 2 nodes per axis, got shape {values.shape}")
        lower = checks.as_float_array("lower", self.lower, shape=(2,))
        upper = checks.as_float_array("upper", self.upper, shape=(2,))
        if not np.all(upper > lower):
            raise checks.InputError("upper", f"upper must be > lower on both axes, got lower={lower.tolist()}, "
                                             f"upper={upper.tolist()}")
        periodic = tuple(bool(p) for p in checks.as_bool_array("periodic", self.periodic, shape=(2,)))
        with np.errstate(over="ignore", divide="ignore"):
            h = spacing(lower, upper, values.shape, np.array(periodic))
            representable = np.all(np.isfinite(h)) and np.all(np.isfinite(1.0 / (h * h)))
        if not representable:
            raise checks.InputError("upper", f"the domain lower={lower.tolist()}, upper={upper.tolist()} with "
                                             f"{values.shape} nodes has a node spacing {h.tolist()} that float64 "
                                             f"cannot resolve (1/h^2 must be finite); use a domain of ordinary size",
                                    names=("upper", "lower"))
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "lower", lower)
        object.__setattr__(self, "upper", upper)
        object.__setattr__(self, "periodic", periodic)
        object.__setattr__(self, "interpolation",
                           checks.as_choice("interpolation", self.interpolation, set(interpolations.INTERPOLATIONS)))

    @property
    def shape(self) -> tuple:
        """The grid's shape (n0, n1)."""
        return self.values.shape

    @property
    def spacing(self) -> np.ndarray:
        """Node spacing h, shape (2,)."""
        return spacing(self.lower, self.upper, self.values.shape, np.array(self.periodic))

    @property
    def length(self) -> np.ndarray:
        """Domain length L = upper - lower, shape (2,)."""
        return self.upper - self.lower

    @property
    def topology(self) -> str:
        """``"plane"``, ``"cylinder"`` or ``"torus"``: how many axes are periodic."""
        return {0: "plane", 1: "cylinder", 2: "torus"}[sum(self.periodic)]

    def nodes(self, axis: int) -> np.ndarray:
        """Coordinates of the nodes along ``axis``."""
        return self.lower[axis] + self.spacing[axis] * np.arange(self.values.shape[axis])

    def locate(self, q) -> Cells:
        """Cells, fractions and switches of points ``q`` (N, 2) ([`pes_ref.core.grid.locate`][pes_ref.core.grid.locate])."""
        q = checks.as_float_array("q", q, shape=(None, 2))
        return locate(q, self.lower, self.spacing, self.values.shape, self.periodic)

    def energy(self, q) -> np.ndarray:
        """Energy at points ``q`` of shape (N, 2) by the surface's interpolation; returns (N,)."""
        q = checks.as_float_array("q", q, shape=(None, 2))
        rule = interpolations.interpolation(self.interpolation)
        return rule.point_energy(self.values, self.lower, self.spacing, self.periodic, q)

    def slope(self, q) -> np.ndarray:
        """dE/dq at points ``q`` of shape (N, 2) by the surface's interpolation; returns (N, 2)."""
        q = checks.as_float_array("q", q, shape=(None, 2))
        rule = interpolations.interpolation(self.interpolation)
        return rule.point_slope(self.values, self.lower, self.spacing, self.periodic, q)

    def wrap(self, q) -> np.ndarray:
        """Positions wrapped into the domain on periodic axes (display only)."""
        return wrap(q, self.lower, self.upper, self.periodic)
