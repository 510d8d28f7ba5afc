"""The fast path of the time stepping (docs/spec.md section 5) and of its hand-derived
adjoint: one fused loop per mode and direction.

[`simulate_dynamic`][pes_ref.core.integrator.simulate_dynamic] and
[`adjoint_dynamic`][pes_ref.core.integrator.adjoint_dynamic],
[`simulate_quasistatic`][pes_ref.core.integrator.simulate_quasistatic] and
[`adjoint_quasistatic`][pes_ref.core.integrator.adjoint_quasistatic] are each one loop over the
steps that does a whole step's sub-steps inline, on preallocated buffers (nothing is allocated per
step), with the force from a kernel built once per run
([`ForceKernel`][pes_ref.core.forces.ForceKernel],
[`ForceAdjoint`][pes_ref.core.forces.ForceAdjoint]); the GJF option's pair is
[`pes_ref.core.gjf`][pes_ref.core.gjf]. The loop bodies mark the sub-steps with the equation numbers
of ``docs/adjoint.md``. They are an optimization of
[`pes_ref.core.reference`][pes_ref.core.reference], which writes each sub-step as a function beside
its transpose; ``tests/core/test_reference.py`` checks that the two agree entry by entry on random
scenes of every topology, mode and effect (bit for bit on the bilinear grid, but for the grid
gradient, summed in another order).

Dynamic mode, the paper's eqs. (2)-(3), with ``a = dt/(2m)``, ``c = dt gamma/(2m)``
([`step_coefficients`][pes_ref.core.integrator.step_coefficients])::

    (S1) half_kick  P       = V_n + a F_n
    (S2) drift      X_{n+1} = X_n + dt P                 = X_n + dt V_n + dt^2/(2m) F_n
    (S3) force      F_{n+1} = F(X_{n+1}) + F_ext[n+1]
    (S4) kick       V_{n+1} = P + a F_{n+1}                              (no damping)
         kick_damp  V_{n+1} = (P - c V_n + a F_{n+1}) / (1 + c)        (damping)

Its adjoint, per step, reversed: (B4) kick(_damp)^T, (B3) force^T, (B2) drift^T,
(B1) half_kick^T.

Quasistatic mode::

    (Q1) force      F_n     = F(X_n) + F_ext[n]
    (Q2) drift      X_{n+1} = X_n + mu F_n

Adjoint: (QB2) drift^T, (QB1) force^T.

The functions here are the numerical core: they trust their (validated) inputs, and
they evaluate only the effects they are given. ``damping=None`` means no damping
arithmetic at all, ``fext=None`` no external force, and a
[`Field`][pes_ref.core.forces.Field] without spring or walls evaluates neither.
"""
from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from pes_ref.core.forces import Field, ForceAdjoint, ForceKernel
from pes_ref.core.runtime import pages
from pes_ref.core.runtime.progress import reporting

__all__ = ["Trajectory", "simulate_dynamic", "adjoint_dynamic", "simulate_quasistatic",
           "adjoint_quasistatic", "NonFiniteError", "check_finite", "reports_nonfinite", "step_coefficients",
           "trajectory_arrays", "quasistatic_velocities", "start_dynamic", "finish_dynamic_adjoint",
           "finish_quasistatic_adjoint"]


class NonFiniteError(FloatingPointError):
    """A trajectory left the finite numbers (usually: dt past the stability limit); ``step``
    is its first non-finite state, where [`check_finite`][pes_ref.core.integrator.check_finite] found it (else None)."""

    def __init__(self, message: str, step: int | None = None):
        super().__init__(message)
        self.step = step


class Trajectory(NamedTuple):
    """The T+1 states of a run.

    x, v, f : ndarray, shape (T+1, N, 2)
        Positions (unwrapped), velocities (zeros in quasistatic mode) and the total
        force ``F_n = F(X_n) + F_ext[n]`` acting at each state.
    """

    x: np.ndarray
    v: np.ndarray
    f: np.ndarray


#: How far (in cells, ``|u|``) a position on a periodic axis may lie from ``lower``: from
#: 2**52 on, float64 holds no fraction of a cell (every ``u`` is a whole number), and the hot
#: loop's ``k mod n`` (`pes_ref.core.grid.Locator`) is no longer exact.
LOOKUP_RANGE = 2.0 ** 52


def check_finite(traj: Trajectory, step_name: str, field=None) -> None:
    """Refuse to return a trajectory that left the finite numbers, or (given its ``field``)
    the range of the grid lookup on a periodic axis (`LOOKUP_RANGE` cells).

    Checked once after the loop, not per step (docs/performance.md): a non-finite value
    never becomes finite again in these updates, so the last state tells, and the first
    bad state is then searched for. Until then the grid lookup of a NaN position gathers
    a clipped (meaningless, but in-bounds) cell and yields NaN. A position past the
    lookup's range is as meaningless (its cell is garbage, gathered in bounds); a scene
    with a periodic axis pays the largest and smallest position for it (two contiguous
    reductions; each axis is searched only when they reach that far). A non-periodic
    axis clips, so any finite position there is looked up exactly."""
    if not (np.isfinite(traj.x[-1]).all() and np.isfinite(traj.v[-1]).all() and np.isfinite(traj.f[-1]).all()):
        finite = [np.isfinite(a).all(axis=(1, 2)) for a in traj]
        bad = int(np.argmax(~(finite[0] & finite[1] & finite[2])))
        raise NonFiniteError(f"the trajectory became non-finite at step {bad} ({step_name})", step=bad)
    axes = [d for d in range(2) if field is not None and field.periodic[d]]
    if not axes:
        return
    lower = [float(field.lower[d]) for d in axes]
    reach = [LOOKUP_RANGE * float(field.h[d]) for d in axes]
    with np.errstate(over="ignore"):            # q - lower beyond float64 is past the range too
        # both axes at once first (contiguous: ~10 ms at T = 100, N = 65,536; per axis, strided, 5x that)
        if traj.x.max() - min(lower) < min(reach) and max(lower) - traj.x.min() < min(reach):
            return
    for d, low, r in zip(axes, lower, reach):
        q = traj.x[..., d]
        with np.errstate(over="ignore"):
            far = np.abs(q - low) >= r
        if not far.any():
            continue
        bad = int(np.argmax(far.any(axis=1)))
        raise NonFiniteError(f"the trajectory left the range of the grid lookup at step {bad} ({step_name}): "
                             f"q{d} = {float(q[bad][far[bad]][0]):.3g} lies 2**52 cells or more from lower on "
                             f"periodic axis {d}, where float64 holds no fraction of a cell", step=bad)


def reports_nonfinite(simulate_fn):
    """Run a forward loop with overflow and invalid-operation warnings silenced, so that a
    run past the stability limit always ends in [`NonFiniteError`][pes_ref.core.integrator.NonFiniteError] (raised by
    [`check_finite`][pes_ref.core.integrator.check_finite]) and never in a bare NumPy ``FloatingPointError`` or warning,
    whatever the caller's ``np.errstate`` (docs/decisions.md, 'Non-finite runs')."""
    @functools.wraps(simulate_fn)
    def wrapper(*args, **kwargs):
        with np.errstate(over="ignore", invalid="ignore"):
            return simulate_fn(*args, **kwargs)
    return wrapper


# =========================================================================== dynamic

def step_coefficients(dt: float, mass, damping, n: int):
    """The dynamic step's coefficients ``a = dt/(2m)`` and ``c = dt gamma/(2m)``
    (``docs/adjoint.md`` section 4), each a fresh (N, 2) array for ``n`` particles; ``c``
    is None for an undamped scene (``damping=None``). The one place they are computed:
    both integrators and [`pes_ref.core.reference`][pes_ref.core.reference] call it."""
    a = np.broadcast_to(dt / (2.0 * mass), (n, 2)).copy()
    c = None if damping is None else np.broadcast_to(dt * damping / (2.0 * mass), (n, 2)).copy()
    return a, c


def trajectory_arrays(n_steps: int, n_particles: int, out=None) -> tuple:
    """A run's (T+1, N, 2) arrays ``x, v, f``: new ones
    ([`pes_ref.core.runtime.pages.empty`][pes_ref.core.runtime.pages.empty]: a large run's memory is
    that of the last run of its size, if its arrays are gone), or ``out``'s (a
    [`Trajectory`][pes_ref.core.integrator.Trajectory] of such arrays that a caller running many
    runs of one size keeps)."""
    if out is None:
        shape = (n_steps + 1, n_particles, 2)
        return pages.empty(shape), pages.empty(shape), pages.empty(shape)
    return out.x, out.v, out.f


def start_dynamic(field: Field, x0: np.ndarray, v0: np.ndarray, fext, n_steps: int, out=None):
    """A dynamic run's (T+1, N, 2) arrays x, v, f ([`trajectory_arrays`][pes_ref.core.integrator.trajectory_arrays]),
    with state 0
    and its force ``F_0 = F(X_0) + F_ext[0]`` stored; return ``(x, v, f, force)`` with the
    run's force kernel (shared by [`simulate_dynamic`][pes_ref.core.integrator.simulate_dynamic] and [`pes_ref.core.gjf.simulate_gjf`][pes_ref.core.gjf.simulate_gjf])."""
    N = x0.shape[0]
    x, v, f = trajectory_arrays(n_steps, N, out)
    force = ForceKernel(field, N)
    x[0] = x0
    v[0] = v0
    force.call(x[0], f[0])
    if fext is not None:
        f[0] += fext[0]
    return x, v, f, force


@reports_nonfinite
def simulate_dynamic(field: Field, x0: np.ndarray, v0: np.ndarray, fext, dt: float, n_steps: int,
                     mass: np.ndarray, damping, progress=None, refuse_nonfinite: bool = True,
                     out: Trajectory | None = None, energy=None) -> Trajectory:
    """Damped velocity Verlet of the paper's eqs. (2)-(3) (docs/spec.md section 5.1).

    Parameters
    ----------
    field : Field
        The energy terms.
    x0, v0 : ndarray, shape (N, 2)
    fext : ndarray, shape (T+1, N, 2), or None
        External force schedule; None when the scene has no external force.
    dt : float
    n_steps : int
        T; the trajectory holds T+1 states.
    mass : ndarray, broadcastable to (N, 2)
    damping : ndarray broadcastable to (N, 2), or None for an undamped scene.
    progress : callable or None
        ``progress("forward", done, n_steps)`` every few hundred steps
        ([`pes_ref.core.runtime.progress.reporting`][pes_ref.core.runtime.progress.reporting]).
    refuse_nonfinite : bool
        Raise [`NonFiniteError`][pes_ref.core.integrator.NonFiniteError] for a trajectory that left the finite numbers
        ([`check_finite`][pes_ref.core.integrator.check_finite]); False returns it (a population checks each member's
        part).
    out : Trajectory or None
        Arrays (T+1, N, 2) to run into instead of fresh ones
        ([`trajectory_arrays`][pes_ref.core.integrator.trajectory_arrays]).
    energy : object or None
        Where each state's total energy goes as the state is made (`pes_ref.core.steppers.StepParams.energy`):
        ``energy.bind(force, field)`` gives ``step(x_n, v_n, row_n)``, called right after the
        force at ``x_n``, whose lookup it reads, with the row ``n`` of ``energy.out``; or None
        (nothing is computed then).

    Returns
    -------
    Trajectory
    """
    N = x0.shape[0]
    x, v, f, force = start_dynamic(field, x0, v0, fext, n_steps, out)
    estep = None if energy is None else energy.bind(force, field)
    if estep is not None:
        estep(x[0], v[0], energy.out[0])
    a, c = step_coefficients(dt, mass, damping, N)
    damped = c is not None
    if damped:
        inv_1pc = 1.0 / (1.0 + c)
        cv = np.empty((N, 2))
    p = np.empty((N, 2))
    dt_ = np.array(dt)              # a 0-d array: no scalar conversion per call
    # ufuncs and the force's closure bound to locals, outputs passed positionally: at
    # small N each step's cost is the calls' fixed cost (docs/performance.md)
    mul, add, sub = np.multiply, np.add, np.subtract
    fcall = force.call
    ext = fext[1:] if fext is not None else [None] * n_steps
    has_fext = fext is not None
    # a F_n is computed once: by the kick of step n-1 (S4), reused by the half-kick (S1)
    af = np.multiply(a, f[0])
    # the loop runs over views (x_n, x_{n+1}, ...); nothing is allocated per step
    rows = energy.out[1:] if estep is not None else ext           # (ext: a placeholder, unused)
    steps = zip(x[:-1], x[1:], v[:-1], v[1:], f[1:], ext, rows)
    for xn, xn1, vn, vn1, fn1, fe, en1 in reporting(steps, progress, "forward", n_steps):
        # (S1) half_kick: P = V_n + a F_n
        add(af, vn, p)
        # (S2) drift: X_{n+1} = X_n + dt P
        mul(p, dt_, xn1)
        add(xn1, xn, xn1)
        # (S3) force: F_{n+1} = F(X_{n+1}) + F_ext[n+1]
        fcall(xn1, fn1)
        if has_fext:
            add(fn1, fe, fn1)
        # (S4) kick: V_{n+1} = P + a F_{n+1}, damped: (P - c V_n + a F_{n+1}) / (1 + c)
        mul(a, fn1, af)
        add(af, p, vn1)
        if damped:
            mul(c, vn, cv)
            sub(vn1, cv, vn1)
            mul(vn1, inv_1pc, vn1)
        if estep is not None:
            estep(xn1, vn1, en1)
    traj = Trajectory(x, v, f)
    if refuse_nonfinite:
        check_finite(traj, f"dt={dt!r}", field)
    return traj


def adjoint_dynamic(field: Field, traj: Trajectory, dt: float, mass: np.ndarray, damping,
                    gx, gv, want: frozenset, progress=None) -> dict:
    """Backward pass of [`simulate_dynamic`][pes_ref.core.integrator.simulate_dynamic]: the same sub-steps reversed
    (eqs. (B1)-(B4)).

    Parameters
    ----------
    field, dt, mass, damping
        As given to [`simulate_dynamic`][pes_ref.core.integrator.simulate_dynamic].
    traj : Trajectory
        Its output.
    gx, gv : ndarray (T+1, N, 2) or None
        Direct derivatives dL/dX_n and dL/dV_n of the objective (None means zero).
    want : frozenset of str
        Which gradients to compute, among ``values, x0, v0, force, mass, damping,
        spring_k, spring_center``. Nothing else is accumulated.
    progress : callable or None
        ``progress("adjoint", done, T)`` every few hundred steps.

    Returns
    -------
    dict
        Gradients: ``values`` (flat, n0*n1), ``x0``, ``v0`` (N, 2), ``force``
        (T+1, N, 2), ``mass``, ``damping`` (N, 2, before reduction to the input's
        shape), ``spring_k``, ``spring_center`` (N, 2).
    """
    x, v, f = traj
    T, N = x.shape[0] - 1, x.shape[1]
    adj = ForceAdjoint(field, x, want)
    a, c = step_coefficients(dt, mass, damping, N)
    damped = c is not None
    if damped:
        inv_1pc = 1.0 / (1.0 + c)
        minus_c = -c
    want_mass, want_damping = "mass" in want, "damping" in want
    abar = np.zeros((N, 2)) if want_mass else None                   # dL/da
    cbar = np.zeros((N, 2)) if (want_damping or (want_mass and damped)) else None  # dL/dc
    gforce = pages.empty((T + 1, N, 2)) if "force" in want else None    # every state written

    xbar = np.zeros((N, 2)) if gx is None else gx[T].copy()
    vbar = np.zeros((N, 2)) if gv is None else gv[T].copy()
    fbar = np.zeros((N, 2))
    tmp = np.empty((N, 2))
    tmp2 = np.empty((N, 2)) if cbar is not None else None         # V_n + V_{n+1}
    dt_ = np.array(dt)
    # undamped, P^ = V^_{n+1} and V^_n = P^: one buffer serves both
    pbar = np.empty((N, 2)) if damped else vbar
    vbar_prev = np.empty((N, 2)) if damped else None
    mul, add, sub, vjp = np.multiply, np.add, np.subtract, adj.vjp      # bound once (see simulate_dynamic)
    for n in reporting(range(T - 1, -1, -1), progress, "adjoint", T):
        # (B4) kick^T: P^ = d V^_{n+1} with d = 1/(1+c) (d = 1 undamped);
        #      F^_{n+1} += a P^; a^ += F_{n+1} P^; c^ -= (V_n + V_{n+1}) P^; V^_n = -c P^
        if damped:
            mul(vbar, inv_1pc, pbar)
            mul(minus_c, pbar, vbar_prev)          # -(c P^), exactly
        mul(a, pbar, tmp)
        add(fbar, tmp, fbar)
        if abar is not None:
            mul(f[n + 1], pbar, tmp)
            add(abar, tmp, abar)
        if cbar is not None:
            add(v[n], v[n + 1], tmp2)
            mul(tmp2, pbar, tmp2)
            sub(cbar, tmp2, cbar)
        # (B3) force^T at X_{n+1}: F_ext^[n+1] = F^_{n+1}; X^_{n+1} += -H_U F^_{n+1}; G^, k^, c^
        if gforce is not None:
            gforce[n + 1] = fbar
        vjp(n + 1, fbar, xbar)
        # (B2) drift^T: P^ += dt X^_{n+1}; X^_n = X^_{n+1} (kept in xbar)
        mul(xbar, dt_, tmp)
        add(pbar, tmp, pbar)
        # (B1) half_kick^T: V^_n += P^ (V^_n = -c P^ + P^ damped, P^ itself undamped);
        #      F^_n = a P^; a^ += F_n P^
        if damped:
            add(vbar_prev, pbar, vbar)
        mul(a, pbar, fbar)
        if abar is not None:
            mul(f[n], pbar, tmp)
            add(abar, tmp, abar)
        # the objective's direct terms at step n
        if gx is not None:
            add(xbar, gx[n], xbar)
        if gv is not None:
            add(vbar, gv[n], vbar)
    return finish_dynamic_adjoint(adj, xbar, vbar, fbar, gforce, abar, cbar, a, c, mass, want_damping)


def finish_dynamic_adjoint(adj, xbar, vbar, fbar, gforce, abar, cbar, a, c, mass, want_damping: bool,
                           initial_force: bool = True) -> dict:
    """The last piece of a dynamic adjoint (shared by [`adjoint_dynamic`][pes_ref.core.integrator.adjoint_dynamic],
    [`pes_ref.core.gjf.adjoint_gjf`][pes_ref.core.gjf.adjoint_gjf] and the compiled loops): (B0) the adjoint of the
    initial force ``F_0 = F(X_0) + F_ext[0]`` (unless ``initial_force`` is False: a loop that
    did it), then (P1) the chain rule from ``a = dt/2m`` and ``c = dt gamma/2m`` to the
    physical parameters, ``dL/dm = -(a^ a + c^ c)/m`` and ``dL/dgamma = c^ a``. ``abar`` is
    None unless the mass gradient is wanted; ``c`` is None for an undamped scene. Returns
    the gradient dict."""
    # (B0) adjoint of the initial force F_0 = F(X_0) + F_ext[0]
    if initial_force:
        if gforce is not None:
            gforce[0] = fbar
        adj.vjp(0, fbar, xbar)
    out = {"x0": xbar, "v0": vbar}
    out.update(adj.result())
    if gforce is not None:
        out["force"] = gforce
    # (P1) chain rule to the physical parameters
    if abar is not None:
        gm = -abar * a
        if c is not None:
            gm -= cbar * c
        out["mass"] = gm / np.broadcast_to(mass, (xbar.shape[0], 2))
    if want_damping:
        out["damping"] = cbar * a
    return out


# =========================================================================== quasistatic

@reports_nonfinite
def simulate_quasistatic(field: Field, x0: np.ndarray, fext, mobility: np.ndarray, n_steps: int,
                         progress=None, refuse_nonfinite: bool = True, out: Trajectory | None = None) -> Trajectory:
    """Quasistatic (overdamped) stepping ``X_{n+1} = X_n + mu F_n`` (docs/spec.md section 5.3).

    ``mobility`` has shape (2,) (or (N, 2): a population's). V is all zeros. ``f[T]`` is
    the force at the final state (it moves nothing; it is kept so the trajectory has T+1
    forces in both modes). ``progress``, ``refuse_nonfinite`` and ``out`` as in
    [`simulate_dynamic`][pes_ref.core.integrator.simulate_dynamic].
    """
    T, N = n_steps, x0.shape[0]
    x, v, f = trajectory_arrays(T, N, out)
    force = ForceKernel(field, N)
    mu = np.ascontiguousarray(np.broadcast_to(mobility, (N, 2)))   # (2,) would broadcast with an inner loop of 2
    x[0] = x0
    mul, add, fcall = np.multiply, np.add, force.call      # bound once (see simulate_dynamic)
    ext = fext[:-1] if fext is not None else [None] * n_steps
    has_fext = fext is not None
    for xn, xn1, fn, fe in reporting(zip(x[:-1], x[1:], f[:-1], ext), progress, "forward", n_steps):
        # (Q1) force: F_n = F(X_n) + F_ext[n]
        fcall(xn, fn)
        if has_fext:
            add(fn, fe, fn)
        # (Q2) drift: X_{n+1} = X_n + mu F_n
        mul(mu, fn, xn1)
        add(xn1, xn, xn1)
    fcall(x[T], f[T])
    if fext is not None:
        f[T] += fext[T]
    traj = Trajectory(x, quasistatic_velocities(v, out), f)
    if refuse_nonfinite:
        check_finite(traj, f"mobility={mobility.tolist()!r}", field)
    return traj


def quasistatic_velocities(v: np.ndarray, out) -> np.ndarray:
    """V of a quasistatic run, all zeros: ``out``'s array set to 0, or new zeros
    ([`pes_ref.core.runtime.pages.zeros`][pes_ref.core.runtime.pages.zeros]: a new map's zero pages
    are not written) for a run without ``out`` (``v`` from
    [`trajectory_arrays`][pes_ref.core.integrator.trajectory_arrays] is then dropped)."""
    if out is None:
        return pages.zeros(v.shape)
    v.fill(0.0)
    return v


def adjoint_quasistatic(field: Field, traj: Trajectory, mobility: np.ndarray, gx, want: frozenset,
                        progress=None) -> dict:
    """Backward pass of [`simulate_quasistatic`][pes_ref.core.integrator.simulate_quasistatic] (eqs. (QB1)-(QB2)).

    Returns ``x0`` (N, 2), and as wanted ``values`` (flat), ``force`` (T+1, N, 2; the
    last entry is 0 since F_ext[T] moves nothing), ``mobility`` (2,), ``spring_k``,
    ``spring_center`` (N, 2). ``progress`` as in [`adjoint_dynamic`][pes_ref.core.integrator.adjoint_dynamic].
    """
    x, _, f = traj
    T, N = x.shape[0] - 1, x.shape[1]
    adj = ForceAdjoint(field, x, want)
    gforce = pages.empty((T + 1, N, 2)) if "force" in want else None
    if gforce is not None:
        gforce[T] = 0.0                      # F_ext[T] moves nothing; the loop writes the others
    mubar = np.zeros(2) if "mobility" in want else None
    xbar = np.zeros((N, 2)) if gx is None else gx[T].copy()
    fbar = np.empty((N, 2))
    mu = np.ascontiguousarray(np.broadcast_to(mobility, (N, 2)))
    mul, add, vjp = np.multiply, np.add, adj.vjp             # bound once (see simulate_dynamic)
    for n in reporting(range(T - 1, -1, -1), progress, "adjoint", T):
        # (QB2) drift^T: F^_n = mu X^_{n+1}; mu^ += sum_i F_n X^_{n+1}; X^_n = X^_{n+1} (kept)
        mul(mu, xbar, fbar)
        if mubar is not None:
            mubar += np.einsum("id,id->d", f[n], xbar)
        # (QB1) force^T at X_n: F_ext^[n] = F^_n; X^_n += -H_U F^_n; G^, k^, c^
        if gforce is not None:
            gforce[n] = fbar
        vjp(n, fbar, xbar)
        if gx is not None:
            add(xbar, gx[n], xbar)
    return finish_quasistatic_adjoint(adj, xbar, gforce, mubar)


def finish_quasistatic_adjoint(adj, xbar, gforce, mubar) -> dict:
    """The gradients a quasistatic adjoint returns (shared by
    [`adjoint_quasistatic`][pes_ref.core.integrator.adjoint_quasistatic] and the
    compiled loops): ``x0``, the terms' (``adj.result()``), and ``force`` and ``mobility`` when
    asked for (not None)."""
    out = {"x0": xbar}
    out.update(adj.result())
    if gforce is not None:
        out["force"] = gforce
    if mubar is not None:
        out["mobility"] = mubar
    return out
