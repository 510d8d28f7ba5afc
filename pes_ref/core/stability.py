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
  ``r < r_c``, reaches the integrator only through the grid it is sampled onto (its second
  differences above); [`pes_ref.devices.cspace.apf_curvature`][pes_ref.devices.cspace.apf_curvature]
  gives its analytic curvature ``v (3/r^4 - 2/(r_c r^3))``, which grows without bound as ``r -> 0``
  and is capped at ``r_min`` on the grid.

Per axis ``K_d = S_d + c + k_d + k_w`` (``S_d`` the largest second-difference
stiffness; Gershgorin's bound of the summed Hessians).

Dynamic (damped velocity Verlet, eqs. (2)-(3)): a harmonic mode of angular frequency
``omega = sqrt(K / m)`` is stable iff ``omega dt < 2``, with or without damping (the
amplification matrix of the damped step has spectral radius <= 1 exactly up to
``omega dt = 2`` for every ``gamma >= 0``; checked in ``tests/core/test_hard_cases.py``). So

    dt_max = 2 / omega_max,   omega_max = max_d sqrt(K_d / min_i m_{i,d}).

Quasistatic (``X_{n+1} = X_n + mu F_n``): stable iff ``mu_d K_d < 2`` on every axis,
``mu_max,d = 2 / K_d``.

Because ``K`` bounds the stiffness from above, the limit is conservative: a scene may
run stably somewhat past it (a particle that never reaches the stiffest cell). Past
the true limit errors grow geometrically until the run leaves the finite numbers;
[`pes_ref.simulate`][pes_ref.core.scene.simulate] then raises
[`pes_ref.NonFiniteError`][pes_ref.core.integrator.NonFiniteError] with
[`advice`][pes_ref.core.stability.advice], which names this limit and a stable step.

The refusal rule (docs/spec.md section 10) takes the terms one at a time instead, as
the contract states it: per axis d the terms are a spring ``k_d`` (the largest over
particles), a wall ``k_w`` (on an axis with a wall) and the grid's cross curvature ``c``
(the same on both axes; the bicubic surface is held to the same ``c``). The second
differences ``S_d`` are not a term: they are kinks of the bilinear force, whose force
stays bounded by the grid's largest slope. A scene is refused iff, over terms and axes,

- dynamic: ``max dt sqrt(K / min_i m_{i,d}) > 2``;
- quasistatic: ``max mobility_d K > 2``;

and it takes at least one step (``n_steps > 0``).

One stiffness table, one limit: [`term_stiffness`][pes_ref.core.stability.term_stiffness] is each
term's ``K`` per axis (the second differences too when asked), and
[`stability_limit`][pes_ref.core.stability.stability_limit] takes a scene's
[`StabilityLimit`][pes_ref.core.stability.StabilityLimit] under one of the `BOUNDS`: ``"sum"``
(every term summed per axis, the conservative bound above) or ``"rule"`` (each term of the refusal
rule alone). [`check_stable`][pes_ref.core.stability.check_stable] applies the rule, raising
[`UnstableStepError`][pes_ref.core.stability.UnstableStepError] that names ``dt`` or ``mobility``,
the factor past the limit, the term and a stable value: the `StabilityLimit.suggestion` of the
summed bound, which is within the per-term rule too (each term is at most the sum).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from pes_ref.core import checks

__all__ = ["StabilityLimit", "grid_cross_curvature", "grid_second_difference", "grid_stiffness",
           "term_stiffness", "stability_limit", "advice", "SAFETY", "BOUNDS",
           "RULE_TERMS", "RULE_DOC", "UnstableStepError", "check_stable"]

#: The stable step `advice` suggests, as a fraction of the limit: at
#: ``omega dt = 1`` velocity Verlet's energy error is ``(omega dt)^2 / 4`` of the
#: oscillation energy, 25%; half the limit keeps a margin for the bound's looseness.
SAFETY = 0.5


def _closed(G: np.ndarray, periodic) -> np.ndarray:
    """The grid with node 0 appended after the last node along each periodic axis."""
    for d in range(2):
        if periodic[d]:
            G = np.concatenate((G, np.take(G, [0], axis=d)), axis=d)
    return G


def grid_cross_curvature(surface, backend: str = "numpy") -> float:
    """``max over cells |G11 - G10 - G01 + G00| / (h0 h1)``: the bilinear surface's only
    second derivative inside a cell (its Hessian has eigenvalues +-this). ``backend="numba"``
    takes the maximum in one compiled pass over the grid
    ([`pes_ref.accel.compiled.cross_curvature_max`][pes_ref.accel.compiled.cross_curvature_max]), without the temporaries:
    the same
    number bit for bit."""
    from pes_ref.core.backends import kernel         # here: the backends' registry imports the steppers
    h = surface.spacing
    fast = kernel(backend, "cross_curvature_max")
    if fast is not None:
        return float(np.float64(fast(surface.values, surface.periodic)) / (h[0] * h[1]))
    G = _closed(surface.values, surface.periodic)
    hc = np.abs(G[1:, 1:] - G[1:, :-1] - G[:-1, 1:] + G[:-1, :-1])
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
    """``max_d S_d`` ([`grid_second_difference`][pes_ref.core.stability.grid_second_difference]): the stiffest cell edge
    of the grid
    along either axis, one number (e.g. to pick a stable quasistatic mobility)."""
    return float(np.max(grid_second_difference(surface)))


def term_stiffness(scene, edges: bool = True, backend: str = "numpy") -> dict:
    """Each term's stiffness ``K`` per axis, the one stiffness table of a scene: a dict of
    (2,) arrays ``grid_cross`` (the grid's cross curvature ``c``, the same on both axes),
    ``spring`` (the largest ``k_d`` over particles), ``walls`` (``k_w`` on an axis with a
    wall) and, with ``edges``, ``grid_edges``
    ([`grid_second_difference`][pes_ref.core.stability.grid_second_difference], the
    costliest; the refusal rule, which runs on every [`pes_ref.simulate`][pes_ref.core.scene.simulate], leaves it out).
    ``backend``: which loops take the cross curvature ([`grid_cross_curvature`][pes_ref.core.stability.grid_cross_curvature])."""
    table = {"grid_cross": np.full(2, grid_cross_curvature(scene.surface, backend)), "spring": np.zeros(2),
             "walls": np.zeros(2)}
    if scene.spring is not None:
        k = np.broadcast_to(scene.spring.k, np.broadcast_shapes(np.shape(scene.spring.k), (1, 2)))
        table["spring"] = np.max(k.reshape(-1, 2), axis=0)
    if scene.walls is not None:
        table["walls"] = np.where(scene.walls.edges.any(axis=1), scene.walls.k, 0.0)
    if edges:
        table = {"grid_edges": grid_second_difference(scene.surface), **table}
    return table


#: The terms of the refusal rule, by their name in `term_stiffness`'s table, with
#: the name a message gives them (the second differences ``grid_edges`` are none).
RULE_TERMS = {"grid_cross": "grid curvature", "spring": "spring", "walls": "wall"}

#: The stiffness bounds a `StabilityLimit` is taken under: ``"sum"``, every term of
#: `term_stiffness` summed per axis (``K_d = S_d + c + k_d + k_w``; conservative,
#: what `advice` and the suggested stable values use), and ``"rule"``, each term of
#: `RULE_TERMS` alone (the refusal rule of docs/spec.md section 10).
BOUNDS = ("sum", "rule")

#: The name of the summed bound's one term.
_SUM = "all terms"


class StabilityLimit(NamedTuple):
    """The stability limit of a scene under one of the `BOUNDS` (see the module docstring).

    Attributes
    ----------
    mode : str
        "dynamic" or "quasistatic".
    key : str
        What the limit is on: ``"dt"`` (dynamic) or ``"mobility"`` (quasistatic).
    bound : str
        One of `BOUNDS`.
    terms : dict str -> ndarray (2,)
        The stiffness of each term the bound takes ([`term_stiffness`][pes_ref.core.stability.term_stiffness]); under
        ``"sum"`` the limit is that of their sum per axis.
    term : str
        The stiffest term's name (`RULE_TERMS`' names; ``"all terms"`` under
        ``"sum"``); ``""`` when the scene has no stiffness.
    axis : int
        The axis where it is stiffest (relative to the mass there, in dynamic mode).
    stiffness : float
        Its ``K`` on that axis.
    limit : float
        Dynamic: the largest stable dt, ``2 / sqrt(K / min_i m_{i,axis})``; quasistatic:
        the largest stable mobility on ``axis``, ``2 / K``. Infinite without stiffness.
    ratio : float
        ``dt / limit`` or ``mobility[axis] / limit``: the largest ``dt sqrt(K/m) / 2`` or
        ``mobility_d K / 2`` over terms and axes. Stable below 1.
    suggestion : float or ndarray (2,)
        Dynamic: a stable dt, `SAFETY` times the limit; quasistatic: a stable
        mobility per axis, ``SAFETY * 2 / K_d`` where the given one reaches past
        `SAFETY` of its axis's limit, else the given one.
    """

    mode: str
    key: str
    bound: str
    terms: dict
    term: str
    axis: int
    stiffness: float
    limit: float
    ratio: float
    suggestion: object


def _min_mass(scene) -> np.ndarray:
    """``min_i m_{i,d}`` per axis, shape (2,)."""
    m = np.broadcast_to(scene.mass, np.broadcast_shapes(np.shape(scene.mass), (1, 2)))
    return np.min(m.reshape(-1, 2), axis=0)


def _omega(K, m) -> np.ndarray:
    """``sqrt(K / m)``, elementwise, also where ``K / m`` alone is beyond float64 (a huge
    stiffness over a small mass): inf only where the frequency itself is."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        omega = np.sqrt(K / m)
        return np.where(np.isfinite(omega), omega, np.sqrt(K) / np.sqrt(m))


def _dynamic_reach(scene, K: np.ndarray) -> np.ndarray:
    """``dt sqrt(K / min m_d)`` per term and axis."""
    return scene.dt * _omega(K, _min_mass(scene))


def _quasistatic_reach(scene, K: np.ndarray) -> np.ndarray:
    """``mobility_d K`` per term and axis."""
    return scene.mobility * K


#: How far each mode's step reaches into the limit 2 of a term: per term and axis.
_REACH = {"dynamic": _dynamic_reach, "quasistatic": _quasistatic_reach}

#: The key a limit is on, per mode.
_KEYS = {"dynamic": "dt", "quasistatic": "mobility"}
#: The key of the input each term's stiffness comes from: what a refusal names when that
#: stiffness is beyond float64 (then no step is stable, and the step is not what to change).
_TERM_KEYS = {"grid curvature": "values", "spring": "spring_k", "wall": "wall_k"}


def stability_limit(scene, bound: str = "sum", backend: str = "numpy") -> StabilityLimit:
    """The stability limit of ``scene`` under ``bound`` (see the module docstring).

    Parameters
    ----------
    scene : pes_ref.Scene
    bound : {"sum", "rule"}
        `BOUNDS`: every term summed per axis (conservative), or each term of the
        refusal rule alone (what [`check_stable`][pes_ref.core.stability.check_stable] applies).
    backend : {"numpy", "numba"}
        Which loops take the grid's cross curvature
        ([`grid_cross_curvature`][pes_ref.core.stability.grid_cross_curvature]; the
        same number); the caller has checked that it is installed.

    Returns
    -------
    StabilityLimit
    """
    checks.as_choice("bound", bound, set(BOUNDS))
    names = [_SUM] if bound == "sum" else list(RULE_TERMS)
    with np.errstate(over="ignore", invalid="ignore"):     # a stiffness beyond float64: inf, limit 0
        table = term_stiffness(scene, edges=bound == "sum", backend=backend)
        K = np.array([sum(table.values())]) if bound == "sum" else np.array([table[name] for name in names])
        reach = _REACH[scene.mode](scene, K)                           # (terms, 2)
    reach = np.where(np.isnan(reach), np.inf, reach)        # a stiffness beyond float64 (inf - inf)
    t, d = np.unravel_index(int(np.argmax(reach)), reach.shape)
    key = _KEYS[scene.mode]
    value = scene.dt if scene.mode == "dynamic" else float(scene.mobility[d])
    axis_ratio = np.max(reach, axis=0) / 2.0                           # per axis
    if scene.mode == "dynamic":
        suggestion = SAFETY * value / axis_ratio[d] if axis_ratio[d] > 0 else value
    else:
        suggestion = np.where(axis_ratio >= SAFETY, SAFETY * scene.mobility / np.maximum(axis_ratio, SAFETY),
                              scene.mobility)
    if not reach[t, d] > 0.0:
        return StabilityLimit(scene.mode, key, bound, table, "", 0, 0.0, np.inf, 0.0, suggestion)
    ratio = float(reach[t, d]) / 2.0
    term = _SUM if bound == "sum" else RULE_TERMS[names[t]]
    # value / ratio, unless the ratio underflowed (a subnormal dt or mobility): then the limit itself
    limit = value / ratio if ratio > 0.0 else _direct_limit(scene, float(K[t, d]), int(d))
    return StabilityLimit(scene.mode, key, bound, table, term, int(d), float(K[t, d]), limit, ratio, suggestion)


def _direct_limit(scene, K: float, d: int) -> float:
    """The limit of one term of stiffness ``K > 0`` on axis ``d`` from the stiffness alone:
    ``2 / sqrt(K / min_i m_{i,d})`` (dynamic) or ``2 / K`` (quasistatic)."""
    with np.errstate(divide="ignore"):
        scale = _omega(K, _min_mass(scene)[d]) if scene.mode == "dynamic" else np.float64(K)
        return float(np.float64(2.0) / scale)


def _fmt(values) -> str:
    """``[a, b]`` with 3 significant digits each (or one number for a scalar)."""
    values = np.asarray(values, dtype=np.float64)
    if values.ndim == 0:
        return f"{float(values):.3g}"
    return "[" + ", ".join(f"{float(v):.3g}" for v in values.ravel()) + "]"


def advice(scene) -> str:
    """One clause on the scene's (summed, conservative) stability limit and a stable step,
    for the message of a run that left the finite numbers, e.g. ``"the stability limit
    is dt < 0.2 (dt = 1 is 5x it); a stable dt is 0.1 (docs/spec.md section 10)"``.
    Quasistatic: the same per axis for the mobility.
    """
    lim = stability_limit(scene)
    value = scene.dt if lim.mode == "dynamic" else scene.mobility
    where = "" if lim.mode == "dynamic" else f" on axis {lim.axis}"
    return (f"the stability limit is {lim.key} < {_fmt(lim.limit)}{where} ({lim.key} = {_fmt(value)} is "
            f"{lim.ratio:.3g}x it); a stable {lim.key} is {_fmt(lim.suggestion)} ({RULE_DOC})")


# =========================================================================== the refusal rule

#: Where the rule is stated; every refusal names it.
RULE_DOC = "docs/spec.md section 10"


class UnstableStepError(checks.InputError):
    """A scene whose step is past the stability limit of its stiffest term (the rule of
    docs/spec.md section 10). ``key`` is ``"dt"`` (dynamic) or ``"mobility"`` (quasistatic);
    the message is one line naming the value, the factor past the limit, the term and a
    stable value. A [`InputError`][pes_ref.core.checks.InputError], so a ``ValueError``."""


def _beyond_float(scene, lim: StabilityLimit) -> UnstableStepError | None:
    """The refusal of a scene whose stiffest term is beyond float64, where no step is
    stable: its stiffness is not finite (naming the input it comes from, ``values``,
    ``spring_k`` or ``wall_k``), or, dynamic, the stiffness over the smallest mass is not
    (naming ``mass``); None for any other scene."""
    if not np.isfinite(lim.stiffness):
        key = _TERM_KEYS[lim.term]
        return UnstableStepError(key, f"{key} gives the {lim.term} a stiffness beyond float64 ({lim.stiffness:.3g} on "
                                      f"axis {lim.axis}), so no {lim.key} is stable ({RULE_DOC})")
    if lim.mode == "dynamic":
        m = float(_min_mass(scene)[lim.axis])
        if not np.isfinite(_omega(lim.stiffness, m)):
            return UnstableStepError("mass", f"mass {m:.3g} on axis {lim.axis} is too small for the {lim.term} "
                                             f"stiffness {lim.stiffness:.3g}: its frequency sqrt(K/m) is beyond float64, "
                                             f"so no dt is stable ({RULE_DOC})")
    return None


def _refusal(scene, lim: StabilityLimit) -> str:
    """The one-line message of a refused scene."""
    suggestion = _fmt(stability_limit(scene).suggestion)
    if lim.mode == "dynamic":
        where = "" if lim.term == RULE_TERMS["grid_cross"] else f" on axis {lim.axis}"
        return (f"dt = {scene.dt:.3g} is {lim.ratio:.3g}x the stability limit {lim.limit:.3g} of its stiffest "
                f"term ({lim.term} {lim.stiffness:.3g}{where}); a stable dt is {suggestion} ({RULE_DOC})")
    return (f"mobility = {_fmt(scene.mobility)} is {lim.ratio:.3g}x the stability limit {lim.limit:.3g} on axis "
            f"{lim.axis} of its stiffest term ({lim.term} {lim.stiffness:.3g}); a stable mobility is {suggestion} "
            f"({RULE_DOC})")


def check_stable(scene, backend: str = "numpy") -> StabilityLimit:
    """Apply the refusal rule (docs/spec.md section 10): refuse a scene that takes at
    least one step past the stability limit of its stiffest term.

    Parameters
    ----------
    scene : pes_ref.Scene
    backend : {"numpy", "numba"}
        As in [`stability_limit`][pes_ref.core.stability.stability_limit].

    Returns
    -------
    StabilityLimit
        The scene's limit under the rule (``bound = "rule"``: its stiffest term), when
        it is accepted.

    Raises
    ------
    UnstableStepError
        ``n_steps > 0`` and `StabilityLimit.ratio` ``> 1``; it names ``dt`` or
        ``mobility``, the factor, the term and a stable value, in one line. Where the
        stiffest term is beyond float64, so that no step is stable, it names the input
        instead: ``values``, ``spring_k`` or ``wall_k`` for a stiffness that is not
        finite, ``mass`` for a frequency ``sqrt(K/m)`` that is not.
    """
    with np.errstate(over="ignore", invalid="ignore"):      # a grid of huge values: infinite stiffness
        lim = stability_limit(scene, "rule", backend)
        if scene.n_steps > 0 and lim.ratio > 1.0:
            raise _beyond_float(scene, lim) or UnstableStepError(lim.key, _refusal(scene, lim))
    return lim
