"""Small helpers shared by the unit tests (not a test module)."""
import numpy as np

from pes_ref.oracle.tolerances import FD_RTOL

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
    force (SPEC section 5): a cell edge or clip edge of the grid, a wall onset, or the
    minimum-image seam of a spring on a periodic axis."""
    x = np.asarray(x)
    n_particles = x.shape[-2]
    best = np.inf
    for d in range(2):
        q = x[..., d]
        h, n = field.h[d], field.values.shape[d]
        u = (q - field.lower[d]) / h
        if field.periodic[d]:
            dist = np.abs(u - np.round(u)) * h
        else:
            dist = np.abs(u - np.round(np.clip(u, 0.0, n - 1.0))) * h
        best = min(best, float(dist.min()))
        if field.walls is not None:
            _, lo, hi = field.walls
            for b in (lo[d], hi[d]):
                if np.isfinite(b):
                    best = min(best, float(np.abs(q - b).min()))
        if field.spring is not None and field.periodic[d]:
            c = np.broadcast_to(field.spring[1], (n_particles, 2))[:, d]
            L = field.length[d]
            m = np.mod(q - c + 0.5 * L, L)
            best = min(best, float(np.minimum(m, L - m).min()))
    return best
