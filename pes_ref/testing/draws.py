"""The distribution of random valid scenes, states and objectives, over any source of draws.

The property tests draw from it through hypothesis ([`pes_ref.testing.strategies`][pes_ref.testing.strategies],
which replays and shrinks a failing example); ``pes_ref check --random`` draws from it
with a seeded `numpy.random.Generator` ([`GeneratorDraws`][pes_ref.testing.draws.GeneratorDraws]), so that the
checker runs on a plain install, without the ``test`` extra. Both go through the same
functions below, so the two see one distribution: every topology, both modes, springs,
walls, damping, external forces (constant, per particle, noise, windows), broadcast
shapes, every objective and regularization.

A *source of draws* ([`Draws`][pes_ref.testing.draws.Draws]) gives an ``integer(lo, hi)`` (inclusive), a
``real(lo, hi)``, a ``flag()``, a ``choice(options)``, a ``sample(options, min_size,
max_size)`` (with repetition), a ``subset(options, min_size)`` (distinct options), a
``seed()`` for `numpy.random.default_rng`, and ``nested(fn, ...)``, which draws
``fn(source, ...)`` as one unit (hypothesis shrinks it as a nested strategy). Bulk arrays
are filled from ``numpy.random.default_rng(source.seed())``, never from NumPy's global
random state.

Every draw is small, cheap and numerically tame: grids of 2..12 nodes per axis, a
handful of particles, short runs, bounded grid values, and a time step (or mobility)
safely inside the explicit stability limit of the stiffest term (see
[`pes_ref.testing.energy.max_frequency`][pes_ref.testing.energy.max_frequency]).

Three valid inputs that a uniform draw almost never reaches are drawn with odds of their
own, which ``pes_ref check --random`` sets (`CHECK_ODDS`) and the hypothesis
strategies leave at 0 unless asked: a wall margin of 0.5 to 1.25 times the length of an
axis that has one wall (``scene(wide_margin=)``), positions snapped 1e-8 to 2.5e-8 cells
below or above cell edges (``state(near_edge=)``), and flags stored as 0/1 integers
([`flag_dtype`][pes_ref.testing.draws.flag_dtype]).
"""
from __future__ import annotations

from typing import Protocol, Sequence

import numpy as np

from pes_ref.core import stability
from pes_ref.core.effects import Constant, Noise, PerParticle, Window
from pes_ref.core.objectives import Funnel, Oscillator, Quadratic
from pes_ref.core.scene import MODES, Scene
from pes_ref.core.surface import Surface
from pes_ref.core.terms import Spring, Walls
from pes_ref.testing.energy import max_frequency

__all__ = ["Draws", "GeneratorDraws", "TOPOLOGIES", "SEED_MAX", "OBJECTIVE_KINDS", "CHECK_ODDS", "NEAR_EDGE",
           "surface", "state", "scene", "scene_case", "objective", "flag_dtype"]

#: The four topologies as ``periodic`` pairs: plane, the two cylinders, torus.
TOPOLOGIES = ((False, False), (True, False), (False, True), (True, True))
#: The largest seed drawn for `numpy.random.default_rng` (and for `pes_ref.Noise`).
SEED_MAX = 2**32 - 1
#: The objectives `objective` draws among.
OBJECTIVE_KINDS = ("funnel_final", "funnel_every_step", "oscillator", "quadratic")
#: The odds ``pes_ref check --random`` draws the rarely reached inputs with (docs/spec.md
#: 13.1): ``wide_margin``, of a scene whose walls leave an axis with one wall, a margin of
#: 0.5 to 1.25 times that axis's length (`scene`); ``near_edge``, of a case, positions
#: snapped near cell edges (`state`); ``integer_flags``, of a case, ``periodic`` and
#: ``walls`` stored as int8 or uint8 (`flag_dtype`); ``near_limit``, of a case, its dt
#: (dynamic) or mobility (quasistatic) scaled to `NEAR_LIMIT` of the stability rule's
#: limit, inside or past it with even odds (`near_limit`).
CHECK_ODDS = {"wide_margin": 0.5, "near_edge": 0.25, "integer_flags": 0.5, "near_limit": 0.2}
#: How close to the stability rule's limit (docs/spec.md section 10) `near_limit` puts a
#: case, as the rule's value over 2: inside, and past (the case is then refused).
NEAR_LIMIT = {"inside": (0.95, 0.995), "past": (1.005, 1.05)}
#: How far, in cells, `state` snaps a coordinate from a cell edge: at least 100 times
#: the perturbation by which ``check`` measures a case's conditioning (so that it does not
#: cross the edge), and below half a float32 ulp of every ``u >= 1`` (2**-25), so that a
#: ``u`` rounded to float32 lands on the edge.
NEAR_EDGE = (1e-8, 2.5e-8)


class Draws(Protocol):
    """A source of draws (hypothesis's ``draw``, or a seeded Generator)."""

    def integer(self, lo: int, hi: int) -> int:
        """An integer in ``[lo, hi]`` (both included)."""
    def real(self, lo: float, hi: float) -> float:
        """A real number in ``[lo, hi]``."""
    def flag(self) -> bool:
        """True or False."""
    def choice(self, options: Sequence):
        """One of ``options``."""
    def sample(self, options: Sequence, min_size: int, max_size: int) -> list:
        """``min_size`` to ``max_size`` entries of ``options``, with repetition."""
    def subset(self, options: Sequence, min_size: int = 1) -> list:
        """At least ``min_size`` distinct entries of ``options``."""
    def seed(self) -> int:
        """A seed for `numpy.random.default_rng`, in ``[0, SEED_MAX]``."""
    def nested(self, fn, *args, **kwargs):
        """``fn(source, *args, **kwargs)`` drawn as one unit (under hypothesis, a nested strategy)."""


class GeneratorDraws:
    """Draws from a `numpy.random.Generator`: uniform integers, reals and choices.

    The same generator state gives the same draws, bit for bit.
    """

    def __init__(self, rng: np.random.Generator):
        self.rng = rng

    def integer(self, lo: int, hi: int) -> int:
        """[`Draws`][pes_ref.testing.draws.Draws]' ``integer``: uniform in ``[lo, hi]``."""
        return int(self.rng.integers(lo, hi + 1))

    def real(self, lo: float, hi: float) -> float:
        """[`Draws`][pes_ref.testing.draws.Draws]' ``real``: uniform in ``[lo, hi)``."""
        return float(self.rng.uniform(lo, hi))

    def flag(self) -> bool:
        """[`Draws`][pes_ref.testing.draws.Draws]' ``flag``: True or False with even odds."""
        return bool(self.rng.integers(2))

    def choice(self, options: Sequence):
        """[`Draws`][pes_ref.testing.draws.Draws]' ``choice``: each option with even odds."""
        options = tuple(options)
        return options[int(self.rng.integers(len(options)))]

    def sample(self, options: Sequence, min_size: int, max_size: int) -> list:
        """[`Draws`][pes_ref.testing.draws.Draws]' ``sample``: a uniform size, then each entry by `choice`."""
        return [self.choice(options) for _ in range(self.integer(min_size, max_size))]

    def subset(self, options: Sequence, min_size: int = 1) -> list:
        """[`Draws`][pes_ref.testing.draws.Draws]' ``subset``: a uniform size, then that many options of a random permutation."""
        options = tuple(options)
        k = self.integer(min_size, len(options))
        return [options[i] for i in self.rng.permutation(len(options))[:k]]

    def seed(self) -> int:
        """[`Draws`][pes_ref.testing.draws.Draws]' ``seed``: uniform in ``[0, SEED_MAX]``."""
        return int(self.rng.integers(0, SEED_MAX, endpoint=True))

    def nested(self, fn, *args, **kwargs):
        """[`Draws`][pes_ref.testing.draws.Draws]' ``nested``: ``fn(self, *args, **kwargs)``."""
        return fn(self, *args, **kwargs)


def _given(value, drawn):
    """``value`` if given (True/False/number), else the result of ``drawn()``."""
    return drawn() if value is None else value


def _chance(d: Draws, odds: float) -> bool:
    """True with probability ``odds``; odds of 0 or 1 draw nothing (so a distribution
    without the option draws what it drew before). Under hypothesis it shrinks to False."""
    if odds <= 0.0 or odds >= 1.0:
        return odds >= 1.0
    return d.real(0.0, 1.0) >= 1.0 - odds


def flag_dtype(d: Draws, integer_flags: float = 0.0) -> np.dtype:
    """The dtype a case stores its flags (``periodic``, ``walls``) in: with probability
    ``integer_flags`` int8 or uint8 (half each; docs/spec.md 8.4 accepts 0/1 integers),
    else bool."""
    if _chance(d, integer_flags):
        return np.dtype(d.choice((np.int8, np.uint8)))
    return np.dtype(bool)


def surface(d: Draws, topology=None, *, min_nodes: int = 2, max_nodes: int = 12, constant: bool = False,
            min_amplitude: float = 0.0, max_amplitude: float = 2.0) -> Surface:
    """A valid [`pes_ref.Surface`][pes_ref.core.surface.Surface] on a small grid.

    Parameters
    ----------
    topology : tuple of 2 bool, optional
        The ``periodic`` pair; drawn from `TOPOLOGIES` when None.
    min_nodes, max_nodes : int
        Nodes per axis, each drawn in ``[min_nodes, max_nodes]`` (``min_nodes >= 2``).
    constant : bool
        A constant grid (zero slope everywhere): the surface adds no force, so only
        springs and walls act, and the dynamics is smooth.
    min_amplitude, max_amplitude : float
        Grid values are ``offset + amplitude * U(-1, 1)`` with ``offset`` in [-1, 1] and
        ``amplitude`` in ``[min_amplitude, max_amplitude]``.

    Returns
    -------
    Surface
        ``lower`` in [-2, 2] per axis, ``upper - lower`` in [0.5, 4].
    """
    if min_nodes < 2 or max_nodes < min_nodes:
        raise ValueError(f"need 2 <= min_nodes <= max_nodes, got {min_nodes}, {max_nodes}")
    periodic = d.choice(TOPOLOGIES) if topology is None else tuple(bool(p) for p in topology)
    shape = (d.integer(min_nodes, max_nodes), d.integer(min_nodes, max_nodes))
    lower = np.array([d.real(-2.0, 2.0), d.real(-2.0, 2.0)])
    length = np.array([d.real(0.5, 4.0), d.real(0.5, 4.0)])
    offset = d.real(-1.0, 1.0)
    if constant:
        values = np.full(shape, offset)
    else:
        amplitude = d.real(min_amplitude, max_amplitude)
        rng = np.random.default_rng(d.seed())
        values = offset + amplitude * rng.uniform(-1.0, 1.0, size=shape)
    return Surface(values, lower, lower + length, periodic)


_surface = surface   # (scene's parameter of that name shadows it)


def state(d: Draws, surface: Surface, n_particles: int, *, margin: float = 0.1, max_speed: float = 1.0,
          max_periods: int = 2, near_edge: float = 0.0):
    """Initial positions and velocities ``(x0, v0)``, each of shape (N, 2).

    Parameters
    ----------
    surface : Surface
    n_particles : int
        N >= 1.
    margin : float
        Positions are uniform in ``[lower - margin L, upper + margin L]`` per axis, so
        some start just outside a non-periodic axis's span (where the surface is
        extended as a constant).
    max_speed : float
        Velocities uniform in ``[-max_speed, max_speed]``.
    max_periods : int
        On a periodic axis each particle is moved by a whole number of periods in
        ``[-max_periods, max_periods]``: states hold unwrapped coordinates (docs/spec.md 2.1).
    near_edge : float
        The probability that positions are snapped near cell edges: then each coordinate
        on an axis with an interior cell edge (every edge of a periodic axis, the seam
        too; the edges between the first and last node of another) is, with probability
        1/2, moved to `NEAR_EDGE` cells below or above one (half each), where the
        cell ``floor`` picks from the float64 ``u`` is the one a float32 ``u`` misses
        (docs/spec.md 2.3).
    """
    rng = np.random.default_rng(d.seed())
    L = surface.length
    x0 = rng.uniform(surface.lower - margin * L, surface.upper + margin * L, size=(n_particles, 2))
    if _chance(d, near_edge):
        x0 = _near_edges(x0, surface, rng)
    if max_periods:
        for axis in range(2):
            if surface.periodic[axis]:
                x0[:, axis] += L[axis] * rng.integers(-max_periods, max_periods + 1, size=n_particles)
    v0 = rng.uniform(-max_speed, max_speed, size=(n_particles, 2))
    return x0, v0


def _near_edges(x0: np.ndarray, surface: Surface, rng: np.random.Generator) -> np.ndarray:
    """``x0`` with each coordinate, with probability 1/2, snapped `NEAR_EDGE` cells
    below or above an interior cell edge of its axis (axes of 2 nodes that are not
    periodic have none)."""
    x0 = x0.copy()
    h = surface.spacing
    for axis in range(2):
        n = surface.values.shape[axis]
        edges = np.arange(n) if surface.periodic[axis] else np.arange(1, n - 1)
        if edges.size == 0:
            continue
        for i in range(x0.shape[0]):
            if rng.integers(2):
                k = float(rng.choice(edges))
                offset = rng.uniform(*NEAR_EDGE) * (1.0 if rng.integers(2) else -1.0)
                x0[i, axis] = surface.lower[axis] + (k + offset) * h[axis]
    return x0


def _per_particle_shape(d: Draws, n_particles: int, *, allow_scalar=True):
    """One of the shapes that broadcast to (N, 2): (), (2,), (N, 1), (N, 2)."""
    shapes = ([()] if allow_scalar else []) + [(2,), (n_particles, 1), (n_particles, 2)]
    return d.choice(shapes)


def scene(d: Draws, n_particles: int = 1, *, topology=None, mode=None, damped=None, smooth_only: bool = False,
          spring=None, walls=None, effects=None, noise=None, per_particle_mass=None,
          n_steps=None, min_steps: int = 0, max_steps: int = 12, min_nodes: int = 2, max_nodes: int = 12,
          min_amplitude: float = 0.0, max_amplitude: float = 2.0,
          dt_range=(0.01, 0.2), max_omega_dt: float = 0.5, omega_dt=None, surface=None,
          wide_margin: float = 0.0) -> Scene:
    """A full valid [`pes_ref.Scene`][pes_ref.core.scene.Scene] for N particles.

    Any subset of the effects may be drawn: a spring (stiffness and centre shaped
    (), (2,), (N, 1) or (N, 2)), walls on the allowed (non-periodic) edges, damping,
    per-particle mass, and external force effects ([`Constant`][pes_ref.core.effects.Constant],
    [`PerParticle`][pes_ref.core.effects.PerParticle], [`Noise`][pes_ref.core.effects.Noise], each possibly inside a
    [`Window`][pes_ref.core.effects.Window]).

    Parameters
    ----------
    n_particles : int
        N; per-particle arrays are shaped for it.
    topology : tuple of 2 bool, optional
        Fix the ``periodic`` pair (else drawn).
    mode : {"dynamic", "quasistatic"}, optional
        Fix the mode (else drawn).
    damped : bool, optional
        True: damping > 0 (dynamic only); False: no damping (None, or an explicit
        zero); None: either.
    smooth_only : bool
        A constant grid (no grid slope), so only springs and walls act; with
        ``damped=False, effects=False`` the dynamics conserves energy up to the
        O(dt^2) error of velocity Verlet. (A spring on a periodic axis still has its
        minimum-image seam; [`scene_case`][pes_ref.testing.draws.scene_case] keeps particles below that seam's energy.)
    spring, walls, effects, noise, per_particle_mass : bool, optional
        Force the effect on (True) or off (False); None draws. ``effects`` governs all
        external force effects, ``noise`` only the Noise effect among them. Walls on a
        torus are always off (no non-periodic edge).
    n_steps : int, optional
        Fix T; else drawn in ``[min_steps, max_steps]``.
    min_nodes, max_nodes, min_amplitude, max_amplitude
        Grid size per axis and value amplitude (see [`surface`][pes_ref.testing.draws.surface]).
    dt_range : (float, float)
        The time step is drawn in this range ...
    max_omega_dt : float
        ... and then cut to ``max_omega_dt / omega_max``, where ``omega_max``
        ([`max_frequency`][pes_ref.testing.energy.max_frequency]) bounds the frequency of the
        stiffest term (velocity Verlet is stable for ``omega_max dt < 2``). Quasistatic
        mobility is ``mu_d = r / K`` with ``r <= max_omega_dt`` and ``K`` the largest
        stiffness (stable for ``mu K < 2``).
    omega_dt : (float, float), optional
        Instead, set ``dt = r / omega_max`` with ``r`` drawn in this range (dynamic
        mode; capped at ``dt_range[1]``): the energy-error tests use it to control
        ``omega_max dt``.
    surface : Surface, optional
        Use this surface instead of drawing one.
    wide_margin : float
        The probability that a scene whose walls leave an axis with one wall gets a wall
        margin of 0.5 to 1.25 times that axis's length (valid: the room rule binds two
        walls of one axis only, docs/spec.md 8.6); an axis with both walls whose room
        that margin takes keeps its lower wall alone. Otherwise the margin is 0 to 0.25
        times the shortest non-periodic side.
    """
    N = int(n_particles)
    mode = _given(mode, lambda: d.choice(MODES))
    if surface is None:
        surface = d.nested(_surface, topology, min_nodes=min_nodes, max_nodes=max_nodes, constant=smooth_only,
                           min_amplitude=min_amplitude, max_amplitude=max_amplitude)
    periodic = surface.periodic
    lower, L = surface.lower, surface.length
    rng = np.random.default_rng(d.seed())

    # -- mass (per axis, per particle or one scalar), in [0.5, 2]
    if _given(per_particle_mass, d.flag):
        mshape = (N, d.choice((1, 2)))
    else:
        mshape = d.choice(((), (2,)))
    mass = rng.uniform(0.5, 2.0, size=mshape)

    # -- damping
    damping = None
    if mode == "dynamic":
        if _given(damped, d.flag):
            damping = rng.uniform(0.05, 1.0, size=_per_particle_shape(d, N))
        elif d.flag():
            damping = np.zeros(_per_particle_shape(d, N))      # an explicit zero: still undamped
    elif damped:
        raise ValueError("damped=True needs mode='dynamic' (quasistatic scenes have no damping)")

    # -- spring
    spring_obj = None
    if _given(spring, d.flag):
        k = rng.uniform(0.1, 4.0, size=_per_particle_shape(d, N))
        cshape = d.choice(((2,), (N, 2)))
        center = rng.uniform(lower, lower + L, size=cshape)
        spring_obj = Spring(k, center)

    # -- walls: only on non-periodic edges
    walls_obj = None
    free = [axis for axis in range(2) if not periodic[axis]]
    if free and _given(walls, d.flag):
        edges = np.zeros((2, 2), dtype=bool)
        for axis, side in d.subset([(axis, side) for axis in free for side in (0, 1)], 1):
            edges[axis, side] = True
        k_w = d.real(1.0, 20.0)
        margin = d.real(0.0, 0.25) * float(min(L[axis] for axis in free))
        single = [axis for axis in free if edges[axis].sum() == 1]
        if single and _chance(d, wide_margin):
            margin = d.real(0.5, 1.25) * float(L[d.choice(single)])
            for axis in free:
                if edges[axis].all() and 2.0 * margin >= L[axis]:
                    edges[axis, 1] = False
        walls_obj = Walls(k_w, margin, edges)

    # -- time grid
    T = d.integer(min_steps, max_steps) if n_steps is None else int(n_steps)
    t0 = d.real(-1.0, 1.0)

    # -- external force effects
    eff = []
    if _given(effects, d.flag):
        kinds = d.sample(("constant", "per_particle", "noise"), 1, 3)
        if noise is True and "noise" not in kinds:
            kinds.append("noise")
        if noise is False:
            kinds = [k for k in kinds if k != "noise"] or ["constant"]
        for kind in kinds:
            if kind == "constant":
                e = Constant(rng.uniform(-1.0, 1.0, size=2))
            elif kind == "per_particle":
                e = PerParticle(rng.uniform(-1.0, 1.0, size=(N, 2)))
            else:
                e = Noise(rng.uniform(0.0, 1.0, size=2), d.seed())
            if d.flag():
                # a window [t_start, t_end) somewhere over the run's times (in units of steps)
                a = d.real(-1.0, T + 1.0)
                b = a + d.real(0.5, T + 2.0)
                e = Window(e, t_start=a, t_end=b)       # rescaled to times below
            eff.append(e)
    elif noise:
        eff.append(Noise(rng.uniform(0.0, 1.0, size=2), d.seed()))

    # -- the time step (or mobility) from the stiffest term: omega_max dt = r
    probe = Scene(surface, dt=1.0, n_steps=0, mass=mass, spring=spring_obj, walls=walls_obj)
    omega = max_frequency(probe)
    mobility = None
    if mode == "dynamic":
        if omega_dt is None:
            dt = min(d.real(*dt_range), max_omega_dt / omega if omega > 0 else np.inf)
        else:                      # (capped: a nearly flat scene would get a huge step)
            dt = min(d.real(*omega_dt) / omega if omega > 0 else np.inf, dt_range[1])
    else:
        dt = d.real(*dt_range)
        r = d.real(0.05, max_omega_dt)
        K = omega ** 2 * float(np.min(probe.mass))        # the stiffness max_frequency bounds by
        mobility = np.array([d.real(0.1, 1.0), d.real(0.1, 1.0)]) * r / max(K, 1.0)

    # windows were drawn in units of steps; turn them into times t0 + s dt
    eff = tuple(Window(e.effect, t0 + e.t_start * dt, t0 + e.t_end * dt) if isinstance(e, Window) else e
                for e in eff)
    return Scene(surface, dt=dt, n_steps=T, mode=mode, mass=mass, damping=damping, mobility=mobility,
                 spring=spring_obj, walls=walls_obj, effects=eff, t0=t0)


def _below_seam(scene: Scene, x0: np.ndarray, v0: np.ndarray, rng: np.random.Generator):
    """Move particles so that, on each periodic axis with a spring, their energy along
    that axis is at most a quarter of the energy at the minimum-image seam.

    With a constant grid the axes are uncoupled, so each axis's energy is conserved
    (up to the O(dt^2) error): the particle never reaches the seam, where the spring
    force jumps, and the dynamics stays smooth.
    """
    if scene.spring is None:
        return x0, v0
    N = x0.shape[0]
    k = np.broadcast_to(scene.spring.k, (N, 2))
    c = np.broadcast_to(scene.spring.center, (N, 2))
    m = np.broadcast_to(scene.mass, (N, 2))
    x0, v0 = x0.copy(), v0.copy()
    for axis in range(2):
        if not scene.surface.periodic[axis]:
            continue
        L = scene.surface.length[axis]
        for i in range(N):
            if k[i, axis] == 0:
                continue
            e_seam = 0.5 * k[i, axis] * (0.5 * L) ** 2
            delta = rng.uniform(-0.35, 0.35) * L              # potential <= 0.49 e_seam ...
            room = max(0.25 * e_seam - 0.5 * k[i, axis] * delta * delta, 0.0)
            if room == 0.0:
                delta *= 0.5                                   # ... but keep a quarter at most
                room = 0.25 * e_seam - 0.5 * k[i, axis] * delta * delta
            x0[i, axis] = c[i, axis] + delta + L * rng.integers(-2, 3)
            v0[i, axis] = rng.uniform(-1.0, 1.0) * np.sqrt(2.0 * room / m[i, axis])
    return x0, v0


def scene_case(d: Draws, *, min_particles: int = 1, max_particles: int = 3, max_speed: float = 1.0,
               max_periods: int = 2, near_edge: float = 0.0, **scene_kw):
    """A scene with an initial state: ``(scene, x0, v0)``.

    Parameters
    ----------
    min_particles, max_particles : int
        N is drawn in this range.
    max_speed : float
        Initial speeds per axis are at most this (see [`state`][pes_ref.testing.draws.state]).
    max_periods : int
        Periodic coordinates start up to this many whole periods away from the domain
        (see [`state`][pes_ref.testing.draws.state]; 0 keeps them near it, which also keeps rounding small).
    near_edge : float
        The probability that positions are snapped near cell edges (see [`state`][pes_ref.testing.draws.state]).
    **scene_kw
        Passed to [`scene`][pes_ref.testing.draws.scene] (``topology``, ``mode``, ``damped``, ``smooth_only``,
        ``spring``, ``walls``, ``effects``, ``noise``, ``n_steps``, ``max_steps``, ...).
        With ``smooth_only=True`` the state is also kept below the minimum-image seam
        of every periodic spring (the seam is a kink of the spring force).

    Returns
    -------
    tuple of (Scene, ndarray, ndarray)
        ``x0``, ``v0`` of shape (N, 2); in quasistatic mode ``v0`` is zeros.
    """
    N = d.integer(min_particles, max_particles)
    sc = d.nested(scene, N, **scene_kw)
    x0, v0 = d.nested(state, sc.surface, N, max_speed=max_speed, max_periods=max_periods, near_edge=near_edge)
    if scene_kw.get("smooth_only"):
        x0, v0 = _below_seam(sc, x0, v0, np.random.default_rng(d.seed()))
    if sc.mode == "quasistatic":
        v0 = np.zeros_like(v0)
    return sc, x0, v0


def objective(d: Draws, scene: Scene, n_particles: int, *, kinds=OBJECTIVE_KINDS, regularization=None):
    """An objective of docs/spec.md section 6 and a regularization weight: ``(objective, R)``.

    Parameters
    ----------
    scene : Scene
        The objective's parameters are drawn on the scale of its domain and run.
    n_particles : int
    kinds : sequence of str
        Among `OBJECTIVE_KINDS`.
    regularization : bool, optional
        True: ``R`` in [1e-3, 1]; False: ``R = 0``; None: either.

    Returns
    -------
    tuple of (object, float)
        The quadratic objective's ``wx, wv, xref, vref`` have random broadcastable
        shapes among (), (2,), (N, 2) and (T+1, N, 2).
    """
    kind = d.choice(tuple(kinds))
    s = scene.surface
    rng = np.random.default_rng(d.seed())
    if kind.startswith("funnel"):
        target = float(rng.uniform(s.lower[0], s.upper[0]))
        obj = Funnel(target, "final" if kind == "funnel_final" else "every_step")
    elif kind == "oscillator":
        obj = Oscillator(float(rng.uniform(0.1, 1.0) * s.length[0]), float(rng.uniform(0.5, 3.0)))
    elif kind == "quadratic":
        shapes = ((), (2,), (n_particles, 2), (scene.n_steps + 1, n_particles, 2))
        pick = lambda: shapes[int(rng.integers(len(shapes)))]  # noqa: E731
        obj = Quadratic(wx=rng.uniform(0.0, 2.0, size=pick()), wv=rng.uniform(0.0, 2.0, size=pick()),
                        xref=rng.uniform(-1.0, 1.0, size=pick()) + 0.5 * float(np.mean(s.lower + s.upper)),
                        vref=rng.uniform(-1.0, 1.0, size=pick()))
    else:
        raise ValueError(f"unknown objective kind {kind!r}")
    R = d.real(1e-3, 1.0) if _given(regularization, d.flag) else 0.0
    return obj, R


def near_limit(d: Draws, scene: Scene, odds: float = 0.0):
    """With probability ``odds``, the step of ``scene`` scaled near the stability rule's limit
    (docs/spec.md section 10): ``(side, scale)``, ``side`` "inside" or "past" (even odds) and
    ``scale`` the factor for its dt (dynamic) or mobility (quasistatic, both axes) that puts
    the rule's value at a ratio of `NEAR_LIMIT` ``[side]`` of 2; None when not drawn, or
    for a scene of no stiffness or no step (nothing to be near)."""
    if not _chance(d, odds):
        return None
    side = "past" if d.flag() else "inside"
    ratio = d.real(*NEAR_LIMIT[side])
    lim = stability.stability_limit(scene, "rule")
    if scene.n_steps == 0 or not 0.0 < lim.ratio < np.inf:
        return None
    return side, ratio / lim.ratio
