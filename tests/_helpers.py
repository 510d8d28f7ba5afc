"""Small helpers shared by the unit tests (not a test module)."""
import numpy as np

from pes_ref.oracle.tolerances import FD_RTOL
from pes_ref.testing.properties import distance_to_kinks

#: A dot-product test whose VJP side is below this carries no information.
NONTRIVIAL = 1e-8

TOPOLOGIES = {
    "plane": (False, False),
    "cylinder0": (True, False),
    "cylinder1": (False, True),
    "torus": (True, True),
}


def assert_dot(lhs: float, rhs: float) -> None:
    """The two sides of a dot-product (VJP) test agree to FD_RTOL, and are not trivially 0."""
    assert abs(rhs) > NONTRIVIAL, f"degenerate dot-product test: <J^T w, u> = {rhs!r}"
    assert abs(lhs - rhs) <= FD_RTOL * max(abs(lhs), abs(rhs)), f"<w, J u> = {lhs!r} but <J^T w, u> = {rhs!r}"


def kink_distance(field, x) -> float:
    """The smallest distance from any position in ``x`` (..., N, 2) to a kink of the
    force of ``field`` (the core's plain-array description of a scene, SPEC section 5):
    :func:`pes_ref.testing.properties.distance_to_kinks` of its grid, walls and spring."""
    walls = None if field.walls is None else field.walls[1:]
    return distance_to_kinks(x, field.lower, field.h, field.values.shape, field.periodic, field.length,
                             walls=walls, spring=field.spring)
