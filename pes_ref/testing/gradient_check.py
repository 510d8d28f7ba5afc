"""Gradients against finite differences, for any ``value_and_grad``: the adjoint's
gradient of every differentiable input of docs/spec.md section 7 against central differences of the
loss ([`check_gradient_fd`][pes_ref.testing.gradient_check.check_gradient_fd]), with the
difference's own rounding noise estimated
([`loss_conditioning`][pes_ref.testing.gradient_check.loss_conditioning]) and every perturbed run's
smooth piece compared with the base run's ([`pes_ref.testing.kinks`][pes_ref.testing.kinks]), so
that a difference across a kink is reported, not counted.
"""
from __future__ import annotations

from dataclasses import dataclass, field as dc_field, replace

import numpy as np

from pes_ref.core.effects import step_times
from pes_ref.core.scene import Scene, gradient_names
from pes_ref.core.scene import simulate as _simulate
from pes_ref.core.terms import Spring
from pes_ref.oracle.tolerances import FD_EPS
from pes_ref.testing.kinks import kink_distance, kink_signature

__all__ = ["GradientCheck", "check_gradient_fd", "get_parameter", "with_parameter", "loss_conditioning"]


#: Each differentiable input: how to read it from ``(scene, x0, v0, fext)`` and how to
#: replace it (``damping`` of an undamped scene reads as the scalar 0).
_PARAMETERS = {
    "values": (lambda s, x0, v0, f: s.surface.values, lambda s, x0, v0, f, u: (s.with_values(u), x0, v0, f)),
    "x0": (lambda s, x0, v0, f: x0, lambda s, x0, v0, f, u: (s, u, v0, f)),
    "v0": (lambda s, x0, v0, f: v0, lambda s, x0, v0, f, u: (s, x0, u, f)),
    "force": (lambda s, x0, v0, f: f, lambda s, x0, v0, f, u: (s, x0, v0, u)),
    "mass": (lambda s, x0, v0, f: s.mass, lambda s, x0, v0, f, u: (replace(s, mass=u), x0, v0, f)),
    "damping": (lambda s, x0, v0, f: 0.0 if s.damping is None else s.damping,
                lambda s, x0, v0, f, u: (replace(s, damping=u), x0, v0, f)),
    "mobility": (lambda s, x0, v0, f: s.mobility, lambda s, x0, v0, f, u: (replace(s, mobility=u), x0, v0, f)),
    "spring_k": (lambda s, x0, v0, f: s.spring.k,
                 lambda s, x0, v0, f, u: (replace(s, spring=Spring(u, s.spring.center)), x0, v0, f)),
    "spring_center": (lambda s, x0, v0, f: s.spring.center,
                      lambda s, x0, v0, f, u: (replace(s, spring=Spring(s.spring.k, u)), x0, v0, f)),
}


def get_parameter(scene: Scene, x0, v0, fext, name: str) -> np.ndarray:
    """The current value of the differentiable input ``name`` (a float64 copy).

    ``fext`` is the realized external force (T+1, N, 2); ``damping`` of an undamped
    scene is the scalar 0.
    """
    getter = _PARAMETERS.get(name)
    if getter is None:
        raise ValueError(f"unknown gradient name {name!r}")
    out = getter[0](scene, x0, v0, fext)
    return np.array(out, dtype=np.float64, copy=True)


def with_parameter(scene: Scene, x0, v0, fext, name: str, value):
    """``(scene, x0, v0, fext)`` with the input ``name`` replaced by ``value``."""
    setter = _PARAMETERS.get(name)
    if setter is None:
        raise ValueError(f"unknown gradient name {name!r}")
    return setter[1](scene, x0, v0, fext, value)


@dataclass
class GradientCheck:
    """The outcome of [`check_gradient_fd`][pes_ref.testing.gradient_check.check_gradient_fd].

    Attributes
    ----------
    errors : dict str -> float
        Relative error per gradient name beyond the difference's own rounding noise.
        Directional: ``max(|fd - <g, u>| - noise, 0) / max(|g|, |fd|)`` with ``u`` a
        random unit direction (a dot-product test); full: the same entry by entry,
        over ``max |fd|``.
    raw_errors : dict str -> float
        The same without subtracting the noise: ``|fd - <g, u>| / max(|g|, |fd|)``.
    resolution : dict str -> float
        ``noise / max(|g|, |fd|)``: the smallest relative error this difference can
        see. Above the tolerance, the name was checked only to its rounding noise.
    noise : dict str -> float
        The estimated rounding error of the difference, ``eps_mach * kappa / h`` (four times that
        for the one-sided formula), with ``kappa`` the loss's conditioning
        ([`loss_conditioning`][pes_ref.testing.gradient_check.loss_conditioning]) and ``h`` the
        step. Where the gradient is far larger than this (the usual case) ``errors`` equals
        ``raw_errors``; where it is not, no difference can resolve it to 1e-6.
    fd, adjoint : dict str -> float or ndarray
        The finite difference and the adjoint's value (directional derivatives, or
        whole gradients when ``full``).
    crossed : dict str -> bool
        True where a perturbed run went through a different smooth piece than the base
        run ([`kink_signature`][pes_ref.testing.kinks.kink_signature]): that name's finite difference is not a
        derivative.
    kink_distance : float
        [`kink_distance`][pes_ref.testing.kinks.kink_distance] of the base run.
    near_kink : bool
        The base run came within ``kink_margin`` of a kink; no difference was taken.
    loss : float
        The loss that ``value_and_grad_fn`` returned.
    """

    errors: dict = dc_field(default_factory=dict)
    raw_errors: dict = dc_field(default_factory=dict)
    resolution: dict = dc_field(default_factory=dict)
    noise: dict = dc_field(default_factory=dict)
    fd: dict = dc_field(default_factory=dict)
    adjoint: dict = dc_field(default_factory=dict)
    crossed: dict = dc_field(default_factory=dict)
    kink_distance: float = np.inf
    near_kink: bool = False
    loss: float = np.nan

    @property
    def valid(self) -> bool:
        """No difference was taken across a kink (and the base run kept its margin)."""
        return not self.near_kink and not any(self.crossed.values())

    @property
    def max_error(self) -> float:
        """The largest of `errors` (0 if none was taken)."""
        return max(self.errors.values(), default=0.0)


_EPS_MACH = float(np.finfo(np.float64).eps)

#: Lower bounds of the parameters that have one: a central difference there would
#: step outside; one-sided differences are used instead (docs/spec.md section 8: m > 0, gamma >= 0, k >= 0, mu > 0).
_LOWER_BOUND = {"mass": 0.0, "damping": 0.0, "spring_k": 0.0, "mobility": 0.0}

#: Inputs with a natural positive scale: their difference step is ``eps * max |p|``.
_RELATIVE_STEP = ("mass", "damping", "spring_k", "mobility")


def _step(name: str, p: np.ndarray, eps: float) -> float:
    """The difference step: ``eps`` times the input's scale for the positive physical
    parameters (a mobility of 1e-3 needs a step of 1e-9, not 1e-6), else ``eps``."""
    if name in _RELATIVE_STEP:
        scale = float(np.max(np.abs(p), initial=0.0))
        if scale > 0.0:
            return eps * scale
    return eps


def loss_conditioning(objective, traj, times, loss: float) -> float:
    """The size of a loss's rounding error in units of the machine epsilon, ``kappa``.

    ``kappa = |L| + (T+1) sum_n (|dL/dX_n| |X_n| + |dL/dV_n| |V_n|)``: every state
    carries rounding relative to its own size, accumulated over up to T+1 steps, and
    reaches the loss through the objective's derivatives. A central difference with
    step ``h`` then carries a rounding error of about ``eps_mach kappa / h``.
    """
    _, gx, gv = objective.value_and_grad(traj.x, traj.v, times)
    kappa = 0.0
    if gx is not None:
        kappa += float(np.sum(np.abs(gx) * np.abs(traj.x)))
    if gv is not None:
        kappa += float(np.sum(np.abs(gv) * np.abs(traj.v)))
    return abs(float(loss)) + traj.x.shape[0] * kappa


def _difference(loss_at, name, p, u, h, bound):
    """``d/ds L(p + s u)`` at 0 with step ``h``: central, or the one-sided second-order
    formula where the central one would step below the input's lower bound.

    Returns ``(derivative, crossed_a_kink, one_sided)``.
    """
    if bound is not None and float(np.min(p - h * u)) <= bound:
        l0, c0 = loss_at(name, p)
        l1, c1 = loss_at(name, p + h * u)
        l2, c2 = loss_at(name, p + 2.0 * h * u)
        return (-3.0 * l0 + 4.0 * l1 - l2) / (2.0 * h), (c0 or c1 or c2), True
    lp, cp = loss_at(name, p + h * u)
    lm, cm = loss_at(name, p - h * u)
    return (lp - lm) / (2.0 * h), (cp or cm), False


def _beyond(diff, noise, scale):
    """``max(diff - noise, 0) / scale``, elementwise, with 0/0 = 0."""
    excess = np.maximum(np.asarray(diff) - noise, 0.0)
    return np.where(excess == 0.0, 0.0, excess / np.maximum(scale, 1e-300))


def check_gradient_fd(value_and_grad_fn, scene: Scene, x0, v0, objective, names=None, *,
                      regularization_weight: float = 0.0, kink_margin: float = 0.0, full: bool = False,
                      seed: int = 0, eps: float = FD_EPS, simulate_fn=None) -> GradientCheck:
    """Check gradients of docs/spec.md section 7 against central finite differences of the loss.

    Parameters
    ----------
    value_and_grad_fn : callable
        ``(scene, x0, v0, objective, *, regularization_weight, wrt, fext) -> (loss, grads, ...)``,
        the signature of [`pes_ref.value_and_grad`][pes_ref.core.scene.value_and_grad]; ``grads[name]`` shaped like the
        input (``fext`` is passed as the realized (T+1, N, 2) schedule).
    scene, x0, v0 : the case
    objective : an object with ``value_and_grad(x, v, t)`` ([`pes_ref.core.objectives`][pes_ref.core.objectives])
    names : sequence of str, optional
        Gradients to check (default: all the scene has,
        [`pes_ref.core.scene.gradient_names`][pes_ref.core.scene.gradient_names]).
    regularization_weight : float
        R of the paper's eq. (7); the differenced loss includes ``R sum G^2`` (for
        ``values``; for every other input it is a constant and left out, which only
        lowers the rounding noise).
    kink_margin : float
        If the base run passes closer than this to a kink ([`kink_distance`][pes_ref.testing.kinks.kink_distance]), take
        no difference (``near_kink``; a hypothesis test then ``assume``-s it away).
    full : bool
        Entry by entry (2 runs per entry) instead of one random unit direction per name
        (2 runs per name, a dot-product test ``<g, u>`` against ``dL/du``).
    seed : int
        Seeds the directions (``numpy.random.default_rng``).
    eps : float
        The difference step: ``eps`` for ``values``, ``x0``, ``v0``, ``force``,
        ``spring_center``; ``eps * max |p|`` for the positive physical parameters
        ``mass``, ``damping``, ``spring_k``, ``mobility``. Where a central difference
        would step below a lower bound (``damping`` of an undamped scene, say), the
        one-sided second-order ``(-3 L(0) + 4 L(h) - L(2h)) / (2h)`` along ``|u|`` is used.
    simulate_fn : callable, optional
        The forward run for the differences, with the signature of
        [`pes_ref.simulate`][pes_ref.core.scene.simulate] (default: ``pes_ref.simulate``). Pass your own so that
        your gradient is checked against differences of your own forward program.

    Returns
    -------
    GradientCheck
        Test ``check.valid`` (else the example straddles a kink: skip it) and
        ``check.max_error < FD_RTOL``.
    """
    simulate_fn = _simulate if simulate_fn is None else simulate_fn
    x0 = np.array(x0, dtype=np.float64)
    v0 = np.array(v0, dtype=np.float64)
    N = x0.shape[0]
    fext = scene.schedule(N)
    fext = np.zeros((scene.n_steps + 1, N, 2)) if fext is None else fext
    names = gradient_names(scene.mode, scene.spring is not None) if names is None else tuple(names)
    R = float(regularization_weight)
    times = step_times(scene.n_steps, scene.dt, scene.t0)

    out = GradientCheck()
    base = simulate_fn(scene, x0, v0, fext=fext)
    base_sig = kink_signature(scene, base.x)
    out.kink_distance = kink_distance(scene, base.x)
    if out.kink_distance < kink_margin:
        out.near_kink = True
        return out
    res = value_and_grad_fn(scene, x0, v0, objective, regularization_weight=R, wrt=names, fext=fext)
    out.loss, grads = float(res[0]), res[1]
    reg = R * float(np.sum(scene.surface.values ** 2)) if R else 0.0
    kappa_values = loss_conditioning(objective, base, times, out.loss)
    kappa_other = loss_conditioning(objective, base, times, out.loss - reg)

    def loss_at(name, value):
        sc, a, b, f = with_parameter(scene, x0, v0, fext, name, value)
        traj = simulate_fn(sc, a, b, fext=f)
        crossed = not np.array_equal(kink_signature(sc, traj.x), base_sig)
        val = objective.value_and_grad(traj.x, traj.v, times)[0]
        if R and name == "values":     # R sum G^2 is a constant for every other input
            val += R * float(np.sum(sc.surface.values ** 2))
        return float(val), crossed

    rng = np.random.default_rng(seed)
    for name in names:
        p = get_parameter(scene, x0, v0, fext, name)
        g = np.asarray(grads[name], dtype=np.float64)
        if g.shape != p.shape:
            raise ValueError(f"gradient {name!r} has shape {g.shape}, its input {p.shape}")
        h = _step(name, p, eps)
        bound = _LOWER_BOUND.get(name)
        noise1 = _EPS_MACH * (kappa_values if name == "values" else kappa_other) / h
        if full:
            fd = np.zeros_like(p)
            noise = np.zeros_like(p)
            crossed = False
            for i in np.ndindex(p.shape):
                u = np.zeros_like(p)
                u[i] = 1.0
                fd[i], c, one_sided = _difference(loss_at, name, p, u, h, bound)
                noise[i] = noise1 * (4.0 if one_sided else 1.0)
                crossed |= c
            scale = float(np.max(np.abs(fd), initial=0.0))
            diff = np.abs(g - fd)
            out.fd[name], out.adjoint[name], out.noise[name] = fd, g, noise
            out.raw_errors[name] = float(_beyond(diff.max(initial=0.0), 0.0, scale))
            out.errors[name] = float(np.max(_beyond(diff, noise, scale), initial=0.0))
            out.resolution[name] = float(_beyond(noise.max(initial=0.0), 0.0, scale))
        else:
            u = rng.standard_normal(p.shape)
            u /= max(float(np.linalg.norm(u)), 1e-300)
            if bound is not None and float(np.min(p - h * np.abs(u))) <= bound:
                u = np.abs(u)          # at the bound: step inward only
            fd, crossed, one_sided = _difference(loss_at, name, p, u, h, bound)
            ad = float(np.sum(g * u))
            scale = max(float(np.linalg.norm(g)), abs(fd))
            noise = noise1 * (4.0 if one_sided else 1.0)
            out.fd[name], out.adjoint[name], out.noise[name] = fd, ad, noise
            out.raw_errors[name] = float(_beyond(abs(fd - ad), 0.0, scale))
            out.errors[name] = float(_beyond(abs(fd - ad), noise, scale))
            out.resolution[name] = float(_beyond(noise, 0.0, scale))
        out.crossed[name] = bool(crossed)
    return out
