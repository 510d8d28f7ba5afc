"""The explicit stability limit of a scene: how large a step its stiffest term allows.

Both steps of docs/spec.md section 5 are explicit, so each has a largest stable step set by the
stiffest force in the scene. Linearized about a state, every term acts like a spring of
stiffness ``K`` (a force change per unit displacement):

- a spring: ``k_d`` along axis d (the largest over particles);
- a wall: ``k_w`` on an axis that has one;
- the grid: inside a cell the bilinear surface's Hessian is ``[[0, c], [c, 0]]`` with
  the cross curvature ``c = |G11 - G10 - G01 + G00| / (h0 h1)``; and across a cell edge
  the slope along d jumps by the second difference ``(G[i+1] - 2 G[i] + G[i-1]) / h_d``
  within one cell width, an effective stiffness ``|second difference| / h_d^2``. A step
  that crosses several cells sees their mean, so this is the worst case;
- a C-space barrier of the paper's eq. (1), ``E = v/2 (1/r - 1/r_c)^2`` for
  ``r < r_c``, reaches the integrator only through the grid it is sampled onto (its
  second differences above); :func:`pes_ref.devices.cspace.apf_curvature` gives its analytic
  curvature ``v (3/r^4 - 2/(r_c r^3))``, which grows without bound as ``r -> 0`` and
  is capped at ``r_min`` on the grid.

Per axis ``K_d = S_d + c + k_d + k_w`` (``S_d`` the largest second-difference
stiffness; Gershgorin's bound of the summed Hessians).

Dynamic (damped velocity Verlet, eqs. (2)-(3)): a harmonic mode of angular frequency
``omega = sqrt(K / m)`` is stable iff ``omega dt < 2``, with or without damping (the
amplification matrix of the damped step has spectral radius <= 1 exactly up to
``omega dt = 2`` for every ``gamma >= 0``; checked in ``tests/test_hard_cases.py``). So

    dt_max = 2 / omega_max,   omega_max = max_d sqrt(K_d / min_i m_{i,d}).

Quasistatic (``X_{n+1} = X_n + mu F_n``): stable iff ``mu_d K_d < 2`` on every axis,
``mu_max,d = 2 / K_d``.

Because ``K`` bounds the stiffness from above, the limit is conservative: a scene may
run stably somewhat past it (a particle that never reaches the stiffest cell). Past
the true limit errors grow geometrically until the run leaves the finite numbers;
:func:`pes_ref.simulate` then raises :class:`pes_ref.NonFiniteError` with
:func:`advice`, which names this limit and a stable step.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["StabilityLimit", "grid_cross_curvature", "grid_second_difference", "grid_stiffness",
           "axis_stiffness", "stability_limit", "advice", "SAFETY"]

#: The stable step :func:`advice` suggests, as a fraction of the limit: at
#: ``omega dt = 1`` velocity Verlet's energy error is ``(omega dt)^2 / 4`` of the
#: oscillation energy, 25%; half the limit keeps a margin for the bound's looseness.
SAFETY = 0.5


class StabilityLimit(NamedTuple):
    """The stability limit of a scene (see the module docstring).

    Attributes
    ----------
    mode : str
        "dynamic" or "quasistatic".
    stiffness : ndarray (2,)
        ``K_d``, per axis.
    terms : dict str -> ndarray (2,)
        Its parts: ``grid_edges`` (second differences), ``grid_cross``, ``spring``, ``walls``.
    omega_max : float
        Dynamic: ``max_d sqrt(K_d / min m_d)``; quasistatic: nan.
    limit : float or ndarray (2,)
        Dynamic: ``dt_max = 2 / omega_max`` (inf without any stiffness); quasistatic:
        the largest stable mobility per axis, ``2 / K_d`` (inf where ``K_d = 0``).
    ratio : float
        Dynamic: ``dt / dt_max``; quasistatic: ``max_d mu_d K_d / 2``. Stable below 1.
    suggestion : float or ndarray
        Dynamic: a stable ``dt`` (:data:`SAFETY` ``* dt_max``); quasistatic: a stable
        mobility (2,), ``SAFETY * 2 / K_d`` where the given one is too large.
    """

    mode: str
    stiffness: np.ndarray
    terms: dict
    omega_max: float
    limit: float
    ratio: float
    suggestion: object


def _closed(G: np.ndarray, periodic) -> np.ndarray:
    """The grid with node 0 appended after the last node along each periodic axis."""
    for d in range(2):
        if periodic[d]:
            G = np.concatenate((G, np.take(G, [0], axis=d)), axis=d)
    return G


def grid_cross_curvature(surface) -> float:
    """``max over cells |G11 - G10 - G01 + G00| / (h0 h1)``: the bilinear surface's only
    second derivative inside a cell (its Hessian has eigenvalues +-this)."""
    G = _closed(surface.values, surface.periodic)
    hc = np.abs(G[1:, 1:] - G[1:, :-1] - G[:-1, 1:] + G[:-1, :-1])
    h = surface.spacing
    return float(hc.max() / (h[0] * h[1]))


def grid_second_difference(surface) -> np.ndarray:
    """``S_d = max |G[i+1] - 2 G[i] + G[i-1]| / h_d^2`` along each axis, shape (2,): the
    effective stiffness of the slope's jump at a cell edge (0 for a 2-node
    non-periodic axis, which has no interior edge; periodic axes wrap)."""
    G = surface.values
    out = np.zeros(2)
    for d in range(2):
        if surface.periodic[d]:
            dd = np.roll(G, -1, axis=d) - 2.0 * G + np.roll(G, 1, axis=d)
        elif G.shape[d] >= 3:
            dd = np.diff(G, n=2, axis=d)
        else:
            continue
        out[d] = float(np.max(np.abs(dd))) / surface.spacing[d] ** 2
    return out


def grid_stiffness(surface) -> float:
    """``max_d S_d`` (:func:`grid_second_difference`): the stiffest cell edge of the grid
    along either axis, one number (e.g. to pick a stable quasistatic mobility)."""
    return float(np.max(grid_second_difference(surface)))


def axis_stiffness(scene) -> tuple:
    """``(K, terms)``: the per-axis stiffness bound ``K_d`` (2,) and its parts."""
    s = scene.surface
    terms = {
        "grid_edges": grid_second_difference(s),
        "grid_cross": np.full(2, grid_cross_curvature(s)),
        "spring": np.zeros(2),
        "walls": np.zeros(2),
    }
    if scene.spring is not None:
        k = np.broadcast_to(scene.spring.k, np.broadcast_shapes(np.shape(scene.spring.k), (1, 2)))
        terms["spring"] = np.max(k.reshape(-1, 2), axis=0)
    if scene.walls is not None:
        terms["walls"] = np.where(scene.walls.edges.any(axis=1), scene.walls.k, 0.0)
    return sum(terms.values()), terms


def stability_limit(scene) -> StabilityLimit:
    """The explicit stability limit of ``scene`` (see the module docstring).

    Parameters
    ----------
    scene : pes_ref.Scene

    Returns
    -------
    StabilityLimit
    """
    K, terms = axis_stiffness(scene)
    if scene.mode == "dynamic":
        m = np.broadcast_to(scene.mass, np.broadcast_shapes(np.shape(scene.mass), (1, 2)))
        m_min = np.min(m.reshape(-1, 2), axis=0)
        omega = float(np.sqrt(np.max(K / m_min)))
        limit = 2.0 / omega if omega > 0 else np.inf
        ratio = scene.dt / limit
        return StabilityLimit("dynamic", K, terms, omega, limit, ratio, SAFETY * limit)
    mu = np.asarray(scene.mobility, dtype=np.float64)
    ratios = mu * K / 2.0
    ratio = float(np.max(ratios))
    with np.errstate(divide="ignore"):
        mu_max = np.where(K > 0, 2.0 / np.where(K > 0, K, 1.0), np.inf)
    suggestion = np.where(ratios >= SAFETY, SAFETY * mu_max, mu)
    return StabilityLimit("quasistatic", K, terms, np.nan, mu_max, ratio, suggestion)


def _fmt_terms(lim: StabilityLimit) -> str:
    parts = [f"{name} {np.array2string(val, precision=3)}" for name, val in lim.terms.items() if np.any(val)]
    return ", ".join(parts) if parts else "none"


def advice(scene) -> str:
    """One sentence on the scene's stability limit and a stable step, for error messages.

    Dynamic: ``"explicit stability limit dt < 2/omega_max = ...; dt = ... is 1.5x that;
    a stable dt is ..."``. Quasistatic: the same for ``mu_d K_d < 2`` and the mobility.
    """
    lim = stability_limit(scene)
    K = np.array2string(lim.stiffness, precision=4)
    if lim.mode == "dynamic":
        where = "past" if lim.ratio >= 1.0 else "within"
        return (f"explicit stability limit of velocity Verlet: dt < 2/omega_max = {lim.limit:.6g} "
                f"(omega_max = {lim.omega_max:.6g}, stiffness per axis K = {K} from {_fmt_terms(lim)}); "
                f"dt = {scene.dt:.6g} is {lim.ratio:.3g}x the limit ({where} it); "
                f"a stable dt is {lim.suggestion:.6g}")
    mu = np.array2string(np.asarray(scene.mobility), precision=6)
    where = "past" if lim.ratio >= 1.0 else "within"
    return (f"explicit stability limit of the quasistatic step: mobility_d * K_d < 2 "
            f"(stiffness per axis K = {K} from {_fmt_terms(lim)}); mobility = {mu} reaches "
            f"{lim.ratio:.3g}x the limit ({where} it); a stable mobility is "
            f"{np.array2string(lim.suggestion, precision=6)}")
