"""The Gronbech-Jensen-Farago step (an accuracy option beside the paper's) and its adjoint.

N. Gronbech-Jensen and O. Farago, "A simple and effective Verlet-type algorithm for
simulating Langevin dynamics", Mol. Phys. 111 (2013) 983-991, deterministic part
(no noise). With ``b = 1/(1 + gamma dt/(2m))`` and ``a_gjf = (1 - gamma dt/(2m)) b``::

    X_{n+1} = X_n + b dt V_n + b dt^2/(2m) F_n
    V_{n+1} = a_gjf V_n + dt/(2m) (a_gjf F_n + F_{n+1})

Unlike the paper's eq. (2), the position update feels the damping force (through b),
so the scheme stays second order in dt with gamma > 0 (``docs/variants.md`` has the
measured orders). With gamma = 0, b = a_gjf = 1 and it is velocity Verlet, bit for bit.

In the notation of ``docs/adjoint.md`` (``a = dt/(2m)``, ``c = dt gamma/(2m)``,
``d = 1/(1+c)`` = b, ``e = (1-c) d`` = a_gjf), the step is four named sub-steps, and its
adjoint, directly below, the same list reversed (section 10 of ``docs/adjoint.md``)::

    (G1) half_kick  P       = V_n + a F_n
    (G2) drift      X_{n+1} = X_n + dt d P
    (G3) force      F_{n+1} = F(X_{n+1}) + F_ext[n+1]
    (G4) kick       V_{n+1} = e P + a F_{n+1}

Adjoint, per step: (GB4) kick^T, (GB3) force^T, (GB2) drift^T, (GB1) half_kick^T.
Undamped (``damping=None``) the multiplications by d and e are skipped, exactly as the
paper's step skips its damping operations, so the two integrators then share every
floating-point operation. Quasistatic mode has no GJF variant.
"""
from __future__ import annotations

import numpy as np

from pes_ref.core.forces import Field, ForceAdjoint
from pes_ref.core.integrator import (Trajectory, check_finite, finish_dynamic_adjoint, reports_nonfinite, start_dynamic,
                                     step_coefficients)
from pes_ref.core.runtime import pages
from pes_ref.core.runtime.progress import reporting

__all__ = ["simulate_gjf", "adjoint_gjf"]


def _coefficients(dt: float, mass: np.ndarray, damping, n: int):
    """``a`` and ``c`` ([`pes_ref.core.integrator.step_coefficients`][pes_ref.core.integrator.step_coefficients]), and
    with damping
    ``d = 1/(1+c)``, ``e = (1-c) d``, all (N, 2); without damping c, d, e are None."""
    a, c = step_coefficients(dt, mass, damping, n)
    if c is None:
        return a, None, None, None
    d = 1.0 / (1.0 + c)
    return a, c, d, (1.0 - c) * d


@reports_nonfinite
def simulate_gjf(field: Field, x0: np.ndarray, v0: np.ndarray, fext, dt: float, n_steps: int,
                 mass: np.ndarray, damping, progress=None, refuse_nonfinite: bool = True,
                 out: Trajectory | None = None) -> Trajectory:
    """The Gronbech-Jensen-Farago step, deterministic part (``docs/adjoint.md`` (G1)-(G4)).

    Parameters and return value as
    [`pes_ref.core.integrator.simulate_dynamic`][pes_ref.core.integrator.simulate_dynamic]: ``x0, v0``
    (N, 2); ``fext`` (T+1, N, 2) or None; ``mass`` and ``damping`` broadcastable to
    (N, 2), ``damping=None`` for an undamped scene (then this is velocity Verlet);
    ``progress``, ``refuse_nonfinite``, ``out``.

    Returns
    -------
    Trajectory
        ``x, v, f`` of shape (T+1, N, 2).
    """
    N = x0.shape[0]
    x, v, f, force = start_dynamic(field, x0, v0, fext, n_steps, out)
    a, _, d, e = _coefficients(dt, mass, damping, N)
    damped = d is not None
    dt_d = dt * d if damped else None
    p = np.empty((N, 2))
    fcall = force.call
    steps = enumerate(zip(x[:-1], x[1:], v[:-1], v[1:], f[:-1], f[1:]))
    for n, (xn, xn1, vn, vn1, fn, fn1) in reporting(steps, progress, "forward", n_steps):
        # (G1) half_kick: P = V_n + a F_n
        np.multiply(a, fn, out=p)
        np.add(p, vn, out=p)
        # (G2) drift: X_{n+1} = X_n + dt d P   (d = 1 undamped)
        np.multiply(p, dt_d if damped else dt, out=xn1)
        np.add(xn1, xn, out=xn1)
        # (G3) force: F_{n+1} = F(X_{n+1}) + F_ext[n+1]
        fcall(xn1, fn1)
        if fext is not None:
            np.add(fn1, fext[n + 1], out=fn1)
        # (G4) kick: V_{n+1} = e P + a F_{n+1}   (e = 1 undamped)
        np.multiply(a, fn1, out=vn1)
        if damped:
            np.multiply(p, e, out=p)
        np.add(vn1, p, out=vn1)
    traj = Trajectory(x, v, f)
    if refuse_nonfinite:
        check_finite(traj, f"integrator='gjf', dt={dt!r}", field)
    return traj


def adjoint_gjf(field: Field, traj: Trajectory, dt: float, mass: np.ndarray, damping,
                gx, gv, want: frozenset, progress=None) -> dict:
    """Backward pass of [`simulate_gjf`][pes_ref.core.gjf.simulate_gjf]: (G1)-(G4) reversed (``docs/adjoint.md``
    (GB1)-(GB4), (GP1)).

    Parameters and return value as [`pes_ref.core.integrator.adjoint_dynamic`][pes_ref.core.integrator.adjoint_dynamic]:
    ``gx, gv``
    (T+1, N, 2) or None are dL/dX_n, dL/dV_n; ``want`` names the gradients among
    ``values, x0, v0, force, mass, damping, spring_k, spring_center``. ``mass`` and
    ``damping`` come back as (N, 2), before reduction to the input's shape. With
    ``damping=None`` a wanted ``damping`` gradient is dL/dgamma at gamma = 0.
    """
    x, v, f = traj
    T, N = x.shape[0] - 1, x.shape[1]
    adj = ForceAdjoint(field, x, want)
    a, c, d, e = _coefficients(dt, mass, damping, N)
    damped = d is not None
    want_mass, want_damping = "mass" in want, "damping" in want
    abar = np.zeros((N, 2)) if want_mass else None                    # dL/da
    # dL/dc through d and e: d'(c) = -d^2, e'(c) = -2 d^2; sbar collects dL/dd + 2 dL/de
    sbar = np.zeros((N, 2)) if (want_damping or (want_mass and damped)) else None
    gforce = pages.empty((T + 1, N, 2)) if "force" in want else None    # every state written

    xbar = np.zeros((N, 2)) if gx is None else gx[T].copy()
    vbar = np.zeros((N, 2)) if gv is None else gv[T].copy()
    fbar = np.zeros((N, 2))
    pbar = np.empty((N, 2))
    p = np.empty((N, 2))
    vjp = adj.vjp
    for n in reporting(range(T - 1, -1, -1), progress, "adjoint", T):
        if sbar is not None:          # P = V_n + a F_n, recomputed (G1)
            np.multiply(a, f[n], out=p)
            p += v[n]
        # (GB4) kick^T: P^ = e V^_{n+1}; F^_{n+1} += a V^_{n+1}; a^ += F_{n+1} V^_{n+1}; e^ += P V^_{n+1}
        if damped:
            np.multiply(e, vbar, out=pbar)
        else:
            pbar[...] = vbar
        fbar += a * vbar
        if abar is not None:
            abar += f[n + 1] * vbar
        if sbar is not None:
            sbar += 2.0 * p * vbar
        # (GB3) force^T at X_{n+1}: F_ext^[n+1] = F^_{n+1}; X^_{n+1} += -H_U F^_{n+1}; G^, k^, c^
        if gforce is not None:
            gforce[n + 1] = fbar
        vjp(n + 1, fbar, xbar)
        # (GB2) drift^T: P^ += dt d X^_{n+1}; d^ += dt P X^_{n+1}; X^_n = X^_{n+1} (kept in xbar)
        pbar += (dt * d if damped else dt) * xbar
        if sbar is not None:
            sbar += dt * p * xbar
        # (GB1) half_kick^T: V^_n = P^; F^_n = a P^; a^ += F_n P^
        vbar[...] = pbar
        np.multiply(a, pbar, out=fbar)
        if abar is not None:
            abar += f[n] * pbar
        # the objective's direct terms at step n
        if gx is not None:
            xbar += gx[n]
        if gv is not None:
            vbar += gv[n]
    # (GP1) c^ = -d^2 (d^ + 2 e^); then (B0) and (P1): dL/dm = -(a^ a + c^ c)/m, dL/dgamma = c^ a
    cbar = None if sbar is None else -sbar * (d * d if damped else 1.0)
    return finish_dynamic_adjoint(adj, xbar, vbar, fbar, gforce, abar, cbar, a, c, mass, want_damping)
