"""Chaos: a scene whose motion is chaotic, and how fast the gradient grows with the
horizon there (the largest Lyapunov exponent the gradient sees), for any ``value_and_grad``.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from pes_ref.core.scene import Scene
from pes_ref.core.surface import Surface

__all__ = ["chaotic_case", "gradient_growth_rate"]


def chaotic_case(dt: float = 0.02):
    """``(scene, x0, v0)``: one particle whose motion is chaotic.

    The smooth torus potential ``cos q0 + cos q1 + cos(q0 + 2 q1) / 2`` sampled on
    16 x 16 nodes (2 pi periods), one particle with more kinetic energy than any
    barrier: the gradient of its final state with respect to its start grows like
    ``exp(lambda t)`` ([`gradient_growth_rate`][pes_ref.testing.chaos.gradient_growth_rate]).
    """
    n = 16
    q = np.arange(n) * 2 * np.pi / n
    G = np.cos(q[:, None]) + np.cos(q[None, :]) + 0.5 * np.cos(q[:, None] + 2 * q[None, :])
    scene = Scene(Surface(G, (0, 0), (2 * np.pi, 2 * np.pi), (True, True)), dt=dt, n_steps=1)
    return scene, np.array([[1.0, 2.0]]), np.array([[1.3, 0.7]])


def gradient_growth_rate(value_and_grad_fn, scene: Scene, x0, v0, objective, n_steps_list) -> tuple:
    """How fast ``|dL/dx0|`` grows with the horizon: ``(rate, norms)``.

    ``norms[k] = |dL/dx0|`` at ``T = n_steps_list[k]``; ``rate`` the least-squares slope
    of ``log norms`` against ``t = T dt`` (per unit time): the largest Lyapunov exponent
    seen by the gradient on a chaotic scene, about 0 on an integrable one (polynomial
    growth). A long-horizon gradient is then only as useful as ``exp(-rate t)``
    says; the rate is to be reported, not hidden.
    """
    norms = []
    for T in n_steps_list:
        res = value_and_grad_fn(replace(scene, n_steps=int(T)), x0, v0, objective, wrt=["x0"])
        norms.append(float(np.linalg.norm(res[1]["x0"])))
    t = np.asarray(n_steps_list, dtype=np.float64) * scene.dt
    return float(np.polyfit(t, np.log(norms), 1)[0]), np.asarray(norms)
