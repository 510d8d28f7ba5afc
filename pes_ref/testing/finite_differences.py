"""Central finite differences and dot-product (VJP) checks.

In the spirit of autograd's ``check_vjp``: for a function ``f: R^n -> R^m`` and its claimed
vector-Jacobian product ``vjp(w) = J^T w``, a random direction ``u`` and cotangent ``w`` must
satisfy ``<w, J u> = <J^T w, u>``, with ``J u`` from a central difference. For a scalar loss,
[`central_gradient`][pes_ref.testing.finite_differences.central_gradient] gives the full gradient
entry by entry; [`pes_ref.oracle.compare.relative_error`][pes_ref.oracle.compare.relative_error]
compares it with a gradient.
"""
from __future__ import annotations

import numpy as np

from pes_ref.oracle.tolerances import FD_EPS

__all__ = ["central_gradient", "directional_derivative", "check_vjp"]


def directional_derivative(f, x: np.ndarray, u: np.ndarray, eps: float = FD_EPS) -> np.ndarray:
    """Central difference ``(f(x + eps u) - f(x - eps u)) / (2 eps)``."""
    x = np.asarray(x, dtype=np.float64)
    return (np.asarray(f(x + eps * u)) - np.asarray(f(x - eps * u))) / (2.0 * eps)


def central_gradient(loss, x: np.ndarray, eps: float = FD_EPS) -> np.ndarray:
    """Gradient of a scalar ``loss(x)`` by central differences, entry by entry (shape of x)."""
    x = np.array(x, dtype=np.float64, copy=True)
    g = np.zeros_like(x)
    flat, gflat = x.reshape(-1), g.reshape(-1)
    for i in range(flat.size):
        old = flat[i]
        flat[i] = old + eps
        up = float(loss(x))
        flat[i] = old - eps
        down = float(loss(x))
        flat[i] = old
        gflat[i] = (up - down) / (2.0 * eps)
    return g


def check_vjp(f, vjp, x: np.ndarray, rng: np.random.Generator, eps: float = FD_EPS):
    """Dot-product test of a VJP against a central difference.

    Parameters
    ----------
    f : callable, x -> array
    vjp : callable, (x, w) -> array shaped like x
        The claimed ``J(x)^T w``.
    x : ndarray
    rng : numpy.random.Generator
        Draws the direction ``u`` and the cotangent ``w``.

    Returns
    -------
    (lhs, rhs) : floats
        ``<w, J u>`` by central differences and ``<J^T w, u>`` by the VJP; they agree
        to ``FD_RTOL`` away from kinks.
    """
    x = np.asarray(x, dtype=np.float64)
    fx = np.asarray(f(x))
    u = rng.standard_normal(x.shape)
    w = rng.standard_normal(fx.shape)
    lhs = float(np.sum(w * directional_derivative(f, x, u, eps)))
    rhs = float(np.sum(np.asarray(vjp(x, w)) * u))
    return lhs, rhs
