"""Scenes: the frozen, validated configuration layer over the numerical core.

A [`Scene`][pes_ref.core.scene.Scene] names a surface and exactly the effects it has (springs, walls,
damping, external force effects, per-particle mass); [`simulate`][pes_ref.core.scene.simulate] and
[`value_and_grad`][pes_ref.core.scene.value_and_grad] validate the initial state once, then run the pure core through
the stepper registry ([`pes_ref.core.steppers`][pes_ref.core.steppers]), which evaluates nothing that the
scene does not name.

Examples
--------
>>> import numpy as np, pes_ref as pr
>>> surf = pr.Surface(np.zeros((8, 8)), lower=(0, 0), upper=(1, 1), periodic=(True, False))
>>> scene = pr.Scene(surf, dt=0.01, n_steps=10, damping=0.1)
>>> traj = pr.simulate(scene, x0=[[0.2, 0.5]], v0=[[1.0, 0.0]])
>>> traj.x.shape
(11, 1, 2)
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field as dc_field

import numpy as np

from pes_ref.core import backends, budget, checks
from pes_ref.core import stability
from pes_ref.core.effects import all_zero, build_schedule, step_times
from pes_ref.core.bilinear import BilinearForce
from pes_ref.core.forces import Field, potential_energy
from pes_ref.core.grid import Locator
from pes_ref.core.integrator import NonFiniteError, Trajectory
from pes_ref.core.objectives import regularization
from pes_ref.core.runtime import pages
from pes_ref.core.steppers import INTEGRATORS, MODES, STEPPERS, StepParams, for_particles, mode_gradients, modes_of
from pes_ref.core.surface import Surface
from pes_ref.core.terms import Spring, Walls, spring_energy, wall_bounds

__all__ = ["Scene", "simulate", "value_and_grad", "energy", "GRADIENT_NAMES", "gradient_names"]

#: Every differentiable input of docs/spec.md section 7, in a fixed order.
GRADIENT_NAMES = ("values", "x0", "v0", "force", "mass", "damping", "spring_k", "spring_center", "mobility")

#: The gradients every scene has, and those a spring adds (a mode's own: its steppers'
#: `gradients`).
_ALWAYS_GRADIENTS = ("values", "x0", "force")
_SPRING_GRADIENTS = ("spring_k", "spring_center")


def gradient_names(mode: str, has_spring: bool) -> tuple:
    """The gradients of docs/spec.md section 7 that a scene of ``mode`` has, in
    `GRADIENT_NAMES` order: ``values``, ``x0`` and ``force`` always; ``v0``,
    ``mass``, ``damping`` in dynamic mode; ``mobility`` in quasistatic mode; ``spring_k``,
    ``spring_center`` with a spring.

    >>> gradient_names("quasistatic", has_spring=True)
    ('values', 'x0', 'force', 'spring_k', 'spring_center', 'mobility')
    """
    used = set(_ALWAYS_GRADIENTS) | set(mode_gradients(mode)) | (set(_SPRING_GRADIENTS) if has_spring else set())
    return tuple(name for name in GRADIENT_NAMES if name in used)


@dataclass(frozen=True)
class Scene:
    """A surface plus the effects that act on its particles (docs/spec.md sections 3-5).

    Parameters
    ----------
    surface : Surface
    dt : float > 0
        Time step (dynamic) or the time between states (quasistatic; ``t_n = t0 + n dt``).
    n_steps : int >= 0
        T; a run holds T+1 states.
    mode : {"dynamic", "quasistatic"}
    mass : array_like broadcastable to (N, 2), > 0
        Per axis (shape (2,)), per particle ((N, 1) or (N, 2)) or one scalar.
    damping : array_like broadcastable to (N, 2), >= 0, or None
        None (the default) is an undamped scene: no damping arithmetic at all.
    mobility : array_like (2,), > 0
        Quasistatic mode only (required there).
    spring : Spring or None
    walls : Walls or None
        Only on non-periodic axes.
    effects : effect or sequence of effects
        External forces ([`pes_ref.core.effects`][pes_ref.core.effects]); empty means none; a single
        effect is taken for a sequence of one.
    t0 : float
        Time of state 0.
    integrator : {"verlet", "gjf"}
        Dynamic mode's step: "verlet" (default) is the paper's eqs. (2)-(3); "gjf" is the
        second-order damped Gronbech-Jensen-Farago step (``docs/variants.md``). The pairs
        ``(mode, integrator)`` are those of `pes_ref.core.steppers.STEPPERS`.
    """

    surface: Surface
    dt: float
    n_steps: int
    mode: str = "dynamic"
    mass: np.ndarray = 1.0
    damping: np.ndarray | None = None
    mobility: np.ndarray | None = None
    spring: Spring | None = None
    walls: Walls | None = None
    effects: tuple = dc_field(default_factory=tuple)
    t0: float = 0.0
    integrator: str = "verlet"

    def __post_init__(self):
        if not isinstance(self.surface, Surface):
            raise checks.InputTypeError("surface",
                                        f"surface must be a pes_ref.Surface, got {type(self.surface).__name__}")
        set_ = lambda k, val: object.__setattr__(self, k, val)  # noqa: E731
        set_("dt", checks.as_positive_float("dt", self.dt))
        set_("n_steps", checks.as_nonneg_int("n_steps", self.n_steps))
        set_("t0", checks.as_finite_float("t0", self.t0))
        set_("mode", checks.as_choice("mode", self.mode, set(MODES)))
        set_("integrator", checks.as_choice("integrator", self.integrator, set(INTEGRATORS)))
        if (self.mode, self.integrator) not in STEPPERS:
            only = " or ".join(f"mode={m!r}" for m in modes_of(self.integrator))
            raise checks.InputError("integrator", f"integrator={self.integrator!r} is for {only} only; "
                                                  f"this scene is {self.mode}")
        set_("mass", _per_particle("mass", self.mass, positive=True))
        if self.damping is not None:
            set_("damping", _per_particle("damping", self.damping, nonneg=True))
        if self.mode == "quasistatic":
            if self.mobility is None:
                raise checks.InputError("mobility", "mobility is required in quasistatic mode (shape (2,), > 0)")
            set_("mobility", checks.as_float_array("mobility", self.mobility, shape=(2,), positive=True))
        elif self.mobility is not None:
            raise checks.InputError("mobility", "mobility is only for mode='quasistatic'; this scene is dynamic")
        if self.spring is not None and not isinstance(self.spring, Spring):
            raise checks.InputTypeError("spring",
                                        f"spring must be a pes_ref.Spring or None, got {type(self.spring).__name__}")
        if self.walls is not None:
            if not isinstance(self.walls, Walls):
                raise checks.InputTypeError("walls",
                                            f"walls must be a pes_ref.Walls or None, got {type(self.walls).__name__}")
            for d in range(2):
                if self.surface.periodic[d] and self.walls.edges[d].any():
                    raise checks.InputError("walls", f"walls: axis {d} is periodic and cannot have a wall "
                                                     f"(walls[{d}] = {self.walls.edges[d].tolist()})")
                if self.walls.edges[d].all() and 2 * self.walls.margin >= self.surface.length[d]:
                    raise checks.InputError("wall_margin",
                                            f"wall_margin={self.walls.margin} leaves no room between the two walls "
                                            f"of axis {d} (length {self.surface.length[d]})")
        effects = self.effects
        if hasattr(effects, "add_to"):          # one effect: a tuple of one
            effects = (effects,)
        try:
            effects = tuple(effects)
        except TypeError:
            raise checks.InputTypeError("effects", f"effects must be a pes_ref effect or a sequence of them, "
                                                   f"got {effects!r}") from None
        for e in effects:
            if not hasattr(e, "add_to"):
                raise checks.InputTypeError("effects",
                                            f"effects must be pes_ref effects (Constant, PerParticle, Noise, Window, "
                                            f"Schedule), got {e!r}")
        set_("effects", effects)

    # ------------------------------------------------------------------ derived plain arrays
    @property
    def damped(self) -> bool:
        """True when the scene has damping that is not zero everywhere."""
        return self.damping is not None and bool(np.any(self.damping != 0))

    def field(self) -> Field:
        """The plain-array energy terms for the core ([`pes_ref.core.forces.Field`][pes_ref.core.forces.Field])."""
        s = self.surface
        spring = None if self.spring is None else (self.spring.k, self.spring.center)
        walls = None
        if self.walls is not None and self.walls.edges.any():
            lo, hi = wall_bounds(s.lower, s.upper, self.walls.margin, self.walls.edges)
            walls = (self.walls.k, lo, hi)
        return Field(s.values, s.lower, s.spacing, s.length, s.periodic, spring, walls, s.interpolation)

    def times(self) -> np.ndarray:
        """t_n = t0 + n dt, shape (T+1,)."""
        return step_times(self.n_steps, self.dt, self.t0)

    def schedule(self, n_particles: int):
        """The realized external force (T+1, N, 2), or None without effects."""
        return build_schedule(self.effects, n_particles, self.n_steps, self.dt, self.t0)

    def with_values(self, values) -> "Scene":
        """The same scene on a new grid of values (same domain and topology)."""
        s = self.surface
        return _replace(self, surface=Surface(values, s.lower, s.upper, s.periodic, s.interpolation))


def _replace(scene: Scene, **kw) -> Scene:
    from dataclasses import replace
    return replace(scene, **kw)


def _per_particle(name, value, **kw):
    arr = checks.as_float_array(name, value, **kw)
    if arr.ndim > 2 or (arr.ndim >= 1 and arr.shape[-1] not in (1, 2)):
        raise checks.InputError(name, f"{name} must broadcast to (N, 2): a scalar, (2,), (N, 1) or (N, 2); "
                                      f"got shape {arr.shape}")
    return arr


def _check_state(scene: Scene, x0, v0):
    x0 = checks.as_float_array("x0", x0, shape=(None, 2))
    n = x0.shape[0]
    if n < 1:
        raise ValueError("x0 must hold at least one particle, got shape (0, 2)")
    if v0 is None:
        v0 = np.zeros((n, 2))
    else:
        v0 = checks.as_float_array("v0", v0, shape=(n, 2))
    for name, arr in (("mass", scene.mass), ("damping", scene.damping),
                      ("spring_k", None if scene.spring is None else scene.spring.k),
                      ("spring_center", None if scene.spring is None else scene.spring.center)):
        if arr is not None:
            try:
                np.broadcast_to(arr, (n, 2))
            except ValueError:
                raise ValueError(f"{name} of shape {arr.shape} does not broadcast to (N, 2) = ({n}, 2)") from None
    return x0, v0


def simulate(scene: Scene, x0, v0=None, *, fext="scene", allow_unstable: bool = False,
             progress=None, backend: str | None = None) -> Trajectory:
    """Run a scene forward (docs/spec.md section 5).

    Parameters
    ----------
    scene : Scene
    x0 : array_like, shape (N, 2)
        Initial positions (unwrapped coordinates).
    v0 : array_like, shape (N, 2), optional
        Initial velocities (zeros if omitted; ignored in quasistatic mode).
    fext : "scene", None or ndarray (T+1, N, 2)
        The external force; by default the schedule the scene's effects realize.
    allow_unstable : bool
        Run a scene past the stability limit of its stiffest term anyway (for studying
        the unstable scheme on purpose); by default it is refused before the run.
    progress : callable, optional
        ``progress(phase, done, total)``, called before the first step, every few
        hundred steps and after the last (``phase`` is ``"forward"``;
        [`pes_ref.core.runtime.progress`][pes_ref.core.runtime.progress]).
    backend : {"numba", "numpy"} or None
        Which loops run the steps (`pes_ref.core.backends.BACKENDS`): None is the
        compiled ones when the extra ``fast`` (numba) is installed, else NumPy's; a scene
        the compiled loops do not cover runs on NumPy. The trajectory is bit-identical
        whichever runs it.

    Returns
    -------
    Trajectory
        ``x``, ``v``, ``f`` of shape (T+1, N, 2).

    Raises
    ------
    pes_ref.core.stability.UnstableStepError
        The step is past the stability limit of the scene's stiffest term
        ([`pes_ref.core.stability.check_stable`][pes_ref.core.stability.check_stable], docs/spec.md section 10), unless
        ``allow_unstable``; a ``ValueError`` naming ``dt`` or ``mobility``.
    pes_ref.core.budget.RunTooLargeError
        The run's arrays cannot fit in the available memory
        ([`pes_ref.core.budget.check_memory`][pes_ref.core.budget.check_memory]); a ``ValueError`` naming ``n_steps``.
    NonFiniteError
        The run left the finite numbers.
    """
    x0, v0 = _check_state(scene, x0, v0)
    backend = backends.check_backend(backend)
    _check_run(scene, x0.shape[0], "simulate", allow_unstable, progress, backend)
    fext = _resolve_fext(scene, fext, x0.shape[0])
    return _forward(scene, x0, v0, fext, progress, backend)


def _check_run(scene: Scene, n_particles: int, kind: str, allow_unstable, progress, backend: str = "numpy") -> None:
    """What the public boundary checks of a run before anything of its size is allocated:
    the stability rule ([`pes_ref.core.stability.check_stable`][pes_ref.core.stability.check_stable]), unless
    ``allow_unstable`` (its grid's cross curvature on ``backend``, checked), and its memory
    ([`pes_ref.core.budget.check_memory`][pes_ref.core.budget.check_memory])."""
    if not isinstance(allow_unstable, (bool, np.bool_)):
        raise checks.InputTypeError("allow_unstable", f"allow_unstable must be True or False, got {allow_unstable!r}")
    if progress is not None and not callable(progress):
        raise checks.InputTypeError("progress", f"progress must be a callable (phase, done, total) or None, "
                                                f"got {progress!r}")
    if not allow_unstable:
        stability.check_stable(scene, backend)
    budget.check_memory(scene.n_steps, n_particles, kind)


def _resolve_fext(scene, fext, n):
    """The external force the core gets, (T+1, N, 2), or None: for none, for effects that
    all push with 0 ([`pes_ref.core.effects.all_zero`][pes_ref.core.effects.all_zero]: nothing is realized), and for a
    given schedule that is 0 everywhere (adding it would change no value)."""
    if isinstance(fext, str) and fext == "scene":
        return None if all_zero(scene.effects) else scene.schedule(n)
    if fext is None:
        return None
    fext = checks.as_float_array("fext", fext, shape=(scene.n_steps + 1, n, 2))
    return fext if fext.any() else None


def _explains_nonfinite(forward):
    """Re-raise the core's [`NonFiniteError`][pes_ref.core.integrator.NonFiniteError] with the scene's stability limit
    and a
    stable step ([`pes_ref.core.stability.advice`][pes_ref.core.stability.advice]), in one line."""
    @functools.wraps(forward)
    def wrapper(scene, *args, **kwargs):
        try:
            return forward(scene, *args, **kwargs)
        except NonFiniteError as err:
            raise NonFiniteError(f"{err}; {stability.advice(scene)}") from err
    return wrapper


def _step_params(scene: Scene, progress=None, energy=None) -> StepParams:
    """The scene's step parameters for its stepper; ``damping`` is None unless some gamma
    is nonzero (then the core does no damping arithmetic at all)."""
    return StepParams(scene.dt, scene.n_steps, scene.mass, scene.damping if scene.damped else None, scene.mobility,
                      progress, energy=energy)


def _stepper(scene: Scene, backend: str, n_particles: int):
    """The stepper of a run of ``scene`` on ``backend`` ([`pes_ref.core.backends.stepper`][pes_ref.core.backends.stepper])."""
    return backends.stepper(backend, scene.mode, scene.integrator, scene.surface.interpolation, n_particles)


@_explains_nonfinite
def _forward(scene: Scene, x0, v0, fext, progress=None, backend: str = "numpy", energy=None,
             field: Field | None = None) -> Trajectory:
    """The run; ``energy`` an `_EnergyOut` that its loop may fill (`StepParams.energy`),
    or None; ``field`` the scene's [`Scene.field`][pes_ref.core.scene.Scene.field] when the caller has it already."""
    field = scene.field() if field is None else field
    return _stepper(scene, backend, x0.shape[0]).simulate(field, x0, v0, fext, _step_params(scene, progress, energy))


#: Particle-states per chunk of `energy` on NumPy: its ~20 temporaries then stay in cache
#: (the whole trajectory at once costs a pass over memory for each of them).
ENERGY_CHUNK = 1 << 14


def energy(scene: Scene, traj: Trajectory, backend: str = "numpy", out: np.ndarray | None = None) -> np.ndarray:
    """Total energy per state and particle, shape (T+1, N) (docs/spec.md section 3.4), into
    ``out`` (a C-contiguous float64 (T+1, N) array; fresh when None).

    Kinetic ``sum_d m_d v_d^2 / 2`` plus ``U = U_grid + U_spring + U_wall``. On NumPy a
    chunk of `ENERGY_CHUNK` particle-states at a time; with ``backend="numba"`` (the
    bilinear grid) the compiled loop [`pes_ref.accel.compiled.energy`][pes_ref.accel.compiled.energy]: the same numbers
    bit for bit.
    """
    x, v = traj.x, traj.v
    T1, N = x.shape[0], x.shape[1]
    fld = scene.field()
    fast = backends.kernel(backend, "energy", fld.interpolation)
    if fast is not None:
        return fast(fld, x, v, scene.mass, out)
    if out is None:
        out = pages.empty((T1, N))
    if fld.interpolation == "bilinear" and fld.offsets is None:
        return _bilinear_energy(fld, x, v, scene.mass, out)
    m = np.broadcast_to(scene.mass, (N, 2))
    step = max(1, ENERGY_CHUNK // max(N, 1))
    spring = fld.spring
    for t0 in range(0, T1, step):
        t1 = min(T1, t0 + step)
        part = fld
        if spring is not None:
            # per-particle spring arrays (N, 2) or (N, 1) repeat over the chunk's flattened states
            k, c = (np.broadcast_to(a, (t1 - t0, N, 2)).reshape(-1, 2) for a in spring)
            part = fld._replace(spring=(k, c))
        u = potential_energy(part, x[t0:t1].reshape(-1, 2)).reshape(t1 - t0, N)
        vv = v[t0:t1]
        np.add(u, 0.5 * np.sum(m * vv * vv, axis=2), out=out[t0:t1])
    return out


def _bilinear_energy(fld: Field, x: np.ndarray, v: np.ndarray, mass, out: np.ndarray) -> np.ndarray:
    """[`energy`][pes_ref.core.scene.energy] on the bilinear grid, a chunk of states at a time with the hot loop's
    lookup ([`pes_ref.core.grid.Locator`][pes_ref.core.grid.Locator]: the cells and fractions of
    [`pes_ref.core.grid.locate`][pes_ref.core.grid.locate]), then `_BilinearEnergy.into`."""
    T1, N = x.shape[0], x.shape[1]
    n0, n1 = fld.values.shape
    loc = Locator(fld.lower, fld.h, (n0, n1), fld.periodic)
    step = max(1, ENERGY_CHUNK // max(N, 1))
    terms = _BilinearEnergy(fld, mass, N, min(step, T1))
    buf = loc.buffers((step * N,))
    locate_into = loc.bind(buf)
    cell, f = buf["cell"], buf["f"]
    for t0 in range(0, T1, step):
        t1 = min(T1, t0 + step)
        M = (t1 - t0) * N
        q = x[t0:t1].reshape(M, 2)
        if M != buf["u"].shape[0]:
            buf = Locator.head(loc.buffers((step * N,)), M)
            locate_into = loc.bind(buf)
            cell, f = buf["cell"], buf["f"]
        locate_into(q)
        terms.into(q, cell, f, x[t0:t1], v[t0:t1], out[t0:t1])
    return out


class _BilinearEnergy:
    """The total energy at located states (bilinear grid, one grid): a per-cell table of the
    four corner values, column by column, then the operations of
    [`pes_ref.core.bilinear.grid_energy`][pes_ref.core.bilinear.grid_energy],
    [`pes_ref.core.terms.spring_energy`][pes_ref.core.terms.spring_energy],
    [`pes_ref.core.terms.wall_energy`][pes_ref.core.terms.wall_energy] and the kinetic energy in
    their order, so the same numbers bit for bit as [`energy`][pes_ref.core.scene.energy]'s formula.
    (A sum over the axis of length 2 is ``0 + a0 + a1``, which is ``a0 + a1`` here: every term is >=
    +0; a wall that is absent adds +0 and is skipped.) For `_bilinear_energy`'s chunks of states and
    for the NumPy forward loop, one state at a time at its own lookup (`_EnergyOut`); ``states`` is
    the most states of N particles a call takes."""

    def __init__(self, fld: Field, mass, n: int, states: int):
        values = fld.values
        n0, n1 = values.shape
        corners = np.empty((n0, n1, 4))
        nxt0 = np.concatenate((values[1:], values[:1]), axis=0)      # row i + 1 (wrapped: unused at a plane's edge)
        corners[..., 0] = values
        corners[..., 1] = nxt0
        corners[..., 2] = np.concatenate((values[:, 1:], values[:, :1]), axis=1)
        corners[..., 3] = np.concatenate((nxt0[:, 1:], nxt0[:, :1]), axis=1)
        self.corners = corners.reshape(-1, 4)
        m = np.broadcast_to(np.asarray(mass, dtype=np.float64), (n, 2))
        self.m0, self.m1 = np.ascontiguousarray(m[:, 0]), np.ascontiguousarray(m[:, 1])
        self.fld, self.n = fld, n
        self.walls, self.hk, self.no_wall = [], None, None
        if fld.walls is not None:
            k, lo, hi = fld.walls
            self.hk = 0.5 * np.asarray(k, dtype=np.float64)
            lo, hi = np.broadcast_to(lo, (n, 2)), np.broadcast_to(hi, (n, 2))
            # which sides have a wall: fixed for the run, so looked at once
            self.walls = [(d, lo[:, d] if np.any(np.isfinite(lo[:, d])) else None,
                           hi[:, d] if np.any(np.isfinite(hi[:, d])) else None) for d in range(2)]
            self.no_wall = np.zeros((states, n))
            self.no_wall.setflags(write=False)          # an axis without a wall adds it: never written
            self.wall_bufs = [(np.empty((states, n)), np.empty((states, n))) for _ in range(2)]
            self.total = np.empty((states, n))
        self.spring = None
        if fld.spring is not None:
            self.spring = tuple(np.broadcast_to(s_, (states, n, 2)) for s_ in fld.spring)
        m = states * n
        self.g = np.empty((m, 4))
        self.a, self.b, self.u, self.t = (np.empty(m) for _ in range(4))
        self.kin, self.k1 = np.empty((states, n)), np.empty((states, n))

    def into(self, q: np.ndarray, cell: np.ndarray, f: np.ndarray, xs: np.ndarray, vs: np.ndarray,
             out: np.ndarray) -> None:
        """``out`` (S, N): the energy of the S states ``xs``, ``vs`` (S, N, 2), whose points
        ``q`` (S N, 2) are located at ``cell`` (S N,) with fractions ``f`` (S N, 2). A cell
        off the table (a non-finite point, whose run is refused) is clipped to it. Every
        temporary is a buffer of the object's (a fresh half-megabyte array per operation
        costs its page faults whenever the allocator hands the memory back)."""
        S, N = xs.shape[0], xs.shape[1]
        M = S * N
        mul, add, sub, maximum = np.multiply, np.add, np.subtract, np.maximum
        g = self.corners.take(cell, axis=0, mode="clip", out=self.g[:M])
        f0, f1 = f[:, 0], f[:, 1]
        a, b, u, t = sub(1.0, f0, self.a[:M]), sub(1.0, f1, self.b[:M]), self.u[:M], self.t[:M]
        mul(a, b, u)
        mul(u, g[:, 0], u)
        add(u, mul(mul(f0, b, b), g[:, 1], b), u)          # b = 1 - f1 is not needed after this
        add(u, mul(mul(a, f1, a), g[:, 2], a), u)
        add(u, mul(mul(f0, f1, t), g[:, 3], t), u)
        u = u.reshape(S, N)
        fld = self.fld
        if self.spring is not None:
            k, c = (s_[:S].reshape(-1, 2) for s_ in self.spring)
            u = u + spring_energy(q, k, c, fld.length, fld.periodic).reshape(S, N)
        if self.walls:
            total, no_wall = None, self.no_wall[:S]
            for (d, lo_d, hi_d), (low, high) in zip(self.walls, self.wall_bufs):
                if lo_d is not None:
                    below = maximum(sub(lo_d, xs[..., d], low[:S]), 0.0, out=low[:S])
                    low = mul(below, below, below)
                if hi_d is not None:
                    above = maximum(sub(xs[..., d], hi_d, high[:S]), 0.0, out=high[:S])
                    high = mul(above, above, above)
                axis = low if hi_d is None else (high if lo_d is None else add(low, high, low))
                if lo_d is None and hi_d is None:
                    axis = no_wall
                total = axis if total is None else add(total, axis, self.total[:S] if total is no_wall else total)
            if total is no_wall:
                np.copyto(self.total[:S], no_wall)
                total = self.total[:S]
            hk = self.hk
            if np.ndim(hk) == 0:
                add(u, mul(hk, total, total), u)
            else:
                u = u + hk * total
        v0_, v1_ = vs[..., 0], vs[..., 1]
        kin, k1 = mul(self.m0, v0_, self.kin[:S]), mul(self.m1, v1_, self.k1[:S])
        mul(kin, v0_, kin)
        mul(k1, v1_, k1)
        add(kin, k1, kin)
        mul(0.5, kin, kin)
        add(u, kin, out)


class _EnergyOut:
    """[`value_and_grad`][pes_ref.core.scene.value_and_grad]'s ``energy_out`` as a forward loop takes it
    (`StepParams.energy`):
    ``out`` (T+1, N), which the compiled loop fills (setting ``filled``), and `bind`, the
    NumPy loop's per-state energy at its force's own lookup."""

    def __init__(self, scene: Scene, out: np.ndarray, mass=None):
        self.scene, self.out, self.filled = scene, out, False
        self.mass = scene.mass if mass is None else mass
        self.errors_ignored = False      # computed under the NumPy loop's np.errstate (overflow ignored)

    def part(self, sl: slice) -> "_EnergyOut":
        """The sink of the particles ``sl`` of the run (a half, [`pes_ref.accel.halves`][pes_ref.accel.halves]): its
        columns of ``out``, with their masses."""
        return _EnergyOut(self.scene, self.out[:, sl], for_particles(self.mass, sl, self.out.shape[1]))

    def bind(self, force, field: Field):
        """``step(x, v, row)``: the energy of one state (N, 2) into ``row`` (N,), right after
        ``force`` (the loop's [`ForceKernel`][pes_ref.core.forces.ForceKernel]) was called at ``x``,
        whose lookup it reads; None where the force has no such lookup (not the bilinear grid,
        one particle, or a population) or a state has fewer than `ENERGY_CHUNK`
        particles (the pass after the run then takes several states per NumPy call, where a
        call per state would cost more in calls than the lookup it saves), and the energy is
        then left to [`energy`][pes_ref.core.scene.energy]."""
        grid = force.grid
        if not (isinstance(grid, BilinearForce) and field.offsets is None and self.out.shape[1] >= ENERGY_CHUNK):
            return None
        terms = _BilinearEnergy(field, self.mass, self.out.shape[1], 1)
        cell, f, into = grid.buf["cell"], grid.buf["f"], terms.into
        self.filled = self.errors_ignored = True

        def step(x, v, row):
            into(x, cell, f, x[None], v[None], row[None])
        return step


def value_and_grad(scene: Scene, x0, v0, objective, *, regularization_weight: float = 0.0,
                   wrt=None, fext="scene", allow_unstable: bool = False, progress=None, checked: bool = False,
                   backend: str | None = None, energy_out: np.ndarray | None = None):
    """The loss of a run and its exact gradients by the hand-derived adjoint (docs/spec.md sections 6-7).

    Parameters
    ----------
    scene : Scene
    x0, v0 : array_like (N, 2)
    objective : object with ``value_and_grad(x, v, t)``
        One of [`pes_ref.core.objectives`][pes_ref.core.objectives] or a user's own.
    regularization_weight : float >= 0
        R of the paper's eq. (7).
    wrt : iterable of str, optional
        Which gradients to compute (default: all that the scene uses; see
        `GRADIENT_NAMES`). Only those are accumulated.
    fext : "scene", None or ndarray (T+1, N, 2)
        As in [`simulate`][pes_ref.core.scene.simulate].
    allow_unstable : bool
        As in [`simulate`][pes_ref.core.scene.simulate]: by default a step past the stability limit of the
        scene's stiffest term is refused before the run.
    progress : callable, optional
        As in [`simulate`][pes_ref.core.scene.simulate], for the forward run (phase ``"forward"``) and then the
        adjoint (``"adjoint"``). A run that cannot fit in memory is refused as there.
    backend : {"numba", "numpy"} or None
        As in [`simulate`][pes_ref.core.scene.simulate]. The compiled loops' gradients agree with NumPy's to 1e-13
        of their largest entry (the grid's and the mobility's are sums in another order;
        the others are bit-identical).
    checked : bool
        The caller has checked everything already, as the oracle's
        [`pes_ref.oracle.case.validate_case`][pes_ref.oracle.case.validate_case] does: ``x0`` and ``v0`` are float64
        (N, 2) arrays, ``fext`` a float64 (T+1, N, 2) array or None, the weight a float
        >= 0, the objective has ``value_and_grad``, ``energy_out`` is as asked or None, and
        the run's stability and memory are checked. Nothing of it is done again
        (``allow_unstable`` is then moot).
    energy_out : ndarray (T+1, N), optional
        A writable C-contiguous float64 array to fill with the run's
        [`energy`][pes_ref.core.scene.energy] (the same numbers as ``energy(scene, traj)``): the
        compiled dynamic loop computes it as it makes each state, at the state's own grid lookup;
        the others after the run.

    Returns
    -------
    loss : float
    grads : dict of str -> ndarray
        Each gradient shaped like its input (``values`` (n0, n1); ``mass``,
        ``damping``, ``spring_k``, ``spring_center`` reduced to their input's shape;
        ``force`` (T+1, N, 2); ``mobility`` (2,)).
    traj : Trajectory
    """
    if checked:
        R, n = regularization_weight, x0.shape[0]
    else:
        x0, v0 = _check_state(scene, x0, v0)
        if not hasattr(objective, "value_and_grad"):
            raise TypeError(f"objective must have a value_and_grad(x, v, t) method, got {objective!r}")
        R = checks.as_nonneg_float("regularization_weight", regularization_weight)
        n = x0.shape[0]
        backend = backends.check_backend(backend)
        _check_run(scene, n, "value_and_grad", allow_unstable, progress, backend)
        fext = _resolve_fext(scene, fext, n)
        if energy_out is not None:
            _check_energy_out(energy_out, (scene.n_steps + 1, n))
    want = _wanted(scene, wrt)
    backend = backends.check_backend(backend)
    stepper = _stepper(scene, backend, n)
    sink = None if energy_out is None else _EnergyOut(scene, energy_out)
    fld = scene.field()                                         # one for the run and its adjoint
    traj = _forward(scene, x0, v0, fext, progress, backend, sink, fld)
    loss, gx, gv = objective.value_and_grad(traj.x, traj.v, scene.times())
    reg, greg = regularization(scene.surface.values, R)
    raw = stepper.adjoint(fld, traj, _step_params(scene, progress), gx, gv, want)
    # a pass after the run where the loop did not fill it; on NumPy, where a state's energy left
    # the finite numbers, again after the run, under the caller's np.errstate (as it always was)
    if sink is not None and (not sink.filled or (sink.errors_ignored and not np.isfinite(energy_out).all())):
        energy(scene, traj, backend=backend, out=energy_out)
    grads = {name: _INPUT_SHAPE.get(name, _as_given)(scene, raw[name], n) for name in GRADIENT_NAMES if name in want}
    if "values" in grads and greg is not None:
        grads["values"] = grads["values"] + greg
    return loss + reg, grads, traj


def _check_energy_out(out, shape: tuple) -> None:
    """``energy_out`` of [`value_and_grad`][pes_ref.core.scene.value_and_grad]: a writable C-contiguous float64 array of ``shape``."""
    if not (isinstance(out, np.ndarray) and out.dtype == np.float64 and out.shape == shape
            and out.flags.c_contiguous and out.flags.writeable):
        raise checks.InputError("energy_out", f"energy_out must be a writable C-contiguous float64 array of shape "
                                              f"(T+1, N) = {shape}, got {_describe_array(out)}")


def _describe_array(a) -> str:
    if not isinstance(a, np.ndarray):
        return f"a {type(a).__name__}"
    return f"dtype {a.dtype}, shape {a.shape}" + ("" if a.flags.c_contiguous else ", not C-contiguous") + (
        "" if a.flags.writeable else ", read-only")


# ---------------------------------------------------------------- a gradient in its input's shape
# The adjoint returns per-particle (N, 2) gradients for mass and damping and flat ones for the grid;
# each is returned in the shape its input was given in (a broadcast input's gradient is summed).

def _as_given(scene: Scene, g, n: int):
    return g


def _grid_shape(scene: Scene, g, n: int):
    shape = scene.surface.shape
    return g if g.shape == shape else g.reshape(shape)      # the compiled adjoint's is shaped (and its own) already


def _scene_field_shape(field: str):
    def shape(scene: Scene, g, n: int):
        src = getattr(scene, field)
        return checks.reduce_to_shape(np.broadcast_to(g, (n, 2)), np.shape(src) if src is not None else ())
    return shape


def _spring_field_shape(field: str):
    def shape(scene: Scene, g, n: int):
        return checks.reduce_to_shape(g, np.shape(getattr(scene.spring, field)))
    return shape


#: How each gradient takes its input's shape (a name not here is returned as the adjoint gives it).
_INPUT_SHAPE = {"values": _grid_shape, "mass": _scene_field_shape("mass"), "damping": _scene_field_shape("damping"),
                "spring_k": _spring_field_shape("k"), "spring_center": _spring_field_shape("center")}


def _wanted(scene: Scene, wrt) -> frozenset:
    usable = set(gradient_names(scene.mode, scene.spring is not None))
    if wrt is None:
        return frozenset(usable)
    if isinstance(wrt, str):
        wrt = (wrt,)
    wrt = frozenset(wrt)
    unknown = wrt - set(GRADIENT_NAMES)
    if unknown:
        raise ValueError(f"wrt names unknown gradients {sorted(unknown)}; choose from {list(GRADIENT_NAMES)}")
    missing = wrt - usable
    if missing:
        raise ValueError(f"wrt asks for {sorted(missing)}, which this scene does not have")
    return wrt
