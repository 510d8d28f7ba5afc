"""A hand-drawn escapement surface for the oscillator problem: a reference, not a design.

It shows what a torque-independent oscillator looks like on the oscillator's scene
(``docs/synthesis.md``, "The oscillator"); gradient descent on the grid values does not
find it.
"""
from __future__ import annotations

import numpy as np

from pes_ref.core import checks
from pes_ref.synthesis.kinds.oscillator import OscillatorProblem

__all__ = ["escapement_values"]


def escapement_values(problem: OscillatorProblem, shape: tuple | None = None, *, kappa: float = 0.032,
                      d: float = 0.4, h: float = 0.5, teeth: int = 4) -> np.ndarray:
    """A hand-drawn escapement for the oscillator problem, sampled at the grid's nodes (n0, n1).

    Not a design found by gradient descent: a reference that shows what a torque-independent
    oscillator looks like on this scene (``docs/synthesis.md``, "The oscillator"). q1 runs
    down under the torque; with ``u = (-q1) mod 2 pi``, half tooth ``j = floor(u / (pi /
    teeth))`` and ``s = u - j pi / teeth``,

    ``E = kappa q0 g + h gate bump``

    where ``bump = sin^2(pi (s - 0.1) / 0.25)`` on ``s in [0.1, 0.35]`` is a wall that holds
    q1 (``h`` must beat the largest torque), ``gate = sigmoid((q0 + d) / 0.1)`` on even j
    (held while ``q0 > -d``) and ``sigmoid(-(q0 - d) / 0.1)`` on odd j (held while
    ``q0 < d``), and ``g`` goes from +1 to -1 (even j) or -1 to +1 (odd j) by a smoothstep
    over ``s in [0.35, 0.75]``. Each half swing q0 passes the far gate, the wall drops, q1
    falls half a tooth and turns the push ``-kappa g`` on q0 round for the next swing.
    """
    from scipy.special import expit

    if not isinstance(problem, OscillatorProblem):
        raise TypeError(f"problem must be an OscillatorProblem, got {type(problem).__name__}")
    shape = problem.shape() if shape is None else tuple(shape)
    if len(shape) != 2:
        raise ValueError(f"shape must be (n0, n1), got {shape!r}")
    n0, n1 = (checks.as_positive_int("shape", n) for n in shape)
    kappa, d, h = (checks.as_nonneg_float(name, val) for name, val in (("kappa", kappa), ("d", d), ("h", h)))
    teeth = checks.as_positive_int("teeth", teeth)
    q0 = np.linspace(problem.lower[0], problem.upper[0], n0)[:, None]
    q1 = (np.arange(n1) * (problem.upper[1] - problem.lower[1]) / n1)[None, :]
    u = np.mod(-q1, 2 * np.pi)
    j = np.floor(u / (np.pi / teeth))
    s = u - j * np.pi / teeth
    bump = np.where((s >= 0.1) & (s <= 0.35), np.sin(np.pi * (s - 0.1) / 0.25) ** 2, 0.0)
    even = j % 2 == 0
    gate = np.where(even, expit((q0 + d) / 0.1), expit(-(q0 - d) / 0.1))
    sm = np.clip((s - 0.35) / 0.4, 0.0, 1.0)
    sm = sm * sm * (3 - 2 * sm)
    g = np.where(even, 1 - 2 * sm, -1 + 2 * sm)
    return kappa * q0 * g + h * gate * bump
