"""Hypothesis strategies that draw valid pes_ref scenes, states and objectives.

Another implementation (JAX, PyTorch, C++ through bindings, ...) imports these to run
its own property tests on the same distribution of inputs that ``pes_ref`` is tested
on, and compares with ``pes_ref`` or checks the plain properties of
:mod:`pes_ref.testing`. Importing this module needs ``hypothesis`` (the
``test`` extra).

Every strategy draws small, cheap and numerically tame examples: grids of 2..12 nodes
per axis, a handful of particles, short runs, bounded grid values, and a time step (or
mobility) safely inside the explicit stability limit of the stiffest term (see
:func:`pes_ref.testing.energy.max_frequency`). Random arrays are filled from
``numpy.random.default_rng(seed)`` with the seed drawn by hypothesis (``st.integers``),
never from NumPy's global random state, so examples replay and shrink deterministically.

Example
-------
>>> from hypothesis import given
>>> from pes_ref.testing import strategies as pst
>>> @given(pst.scene_cases(mode="dynamic"))
... def test_runs(case):
...     scene, x0, v0 = case
...     my_simulate(scene, x0, v0)   # doctest: +SKIP
"""
from __future__ import annotations

import numpy as np
from hypothesis import strategies as st

from pes_ref.core.effects import Constant, Noise, PerParticle, Window
from pes_ref.core.objectives import Funnel, Oscillator, Quadratic
from pes_ref.core.scene import MODES, Scene
from pes_ref.core.surface import Surface
from pes_ref.core.terms import Spring, Walls
from pes_ref.testing.energy import max_frequency

__all__ = ["TOPOLOGIES", "topologies", "seeds", "surfaces", "states", "scenes", "scene_cases",
           "objectives", "exit_paths", "term_cases", "TERM_MARGIN"]

#: The four topologies as ``periodic`` pairs: plane, the two cylinders, torus.
TOPOLOGIES = ((False, False), (True, False), (False, True), (True, True))

_SEED_MAX = 2**32 - 1


def seeds():
    """Seeds for ``numpy.random.default_rng`` (and for :class:`pes_ref.Noise`).

    Returns
    -------
    SearchStrategy[int]
        Integers in ``[0, 2**32 - 1]``.
    """
    return st.integers(0, _SEED_MAX)


def topologies():
    """The ``periodic`` pair of a surface.

    Returns
    -------
    SearchStrategy[tuple[bool, bool]]
        One of :data:`TOPOLOGIES`: ``(False, False)`` plane, ``(True, False)`` and
        ``(False, True)`` the two cylinders, ``(True, True)`` torus. Shrinks toward the plane.
    """
    return st.sampled_from(TOPOLOGIES)


def _floats(lo, hi):
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False, width=64)


@st.composite
def surfaces(draw, topology=None, *, min_nodes: int = 2, max_nodes: int = 12, constant: bool = False,
             min_amplitude: float = 0.0, max_amplitude: float = 2.0):
    """A valid :class:`pes_ref.Surface` on a small grid.

    Parameters
    ----------
    topology : tuple of 2 bool, optional
        The ``periodic`` pair; drawn from :func:`topologies` when None.
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
    SearchStrategy[Surface]
        ``lower`` in [-2, 2] per axis, ``upper - lower`` in [0.5, 4].
    """
    if min_nodes < 2 or max_nodes < min_nodes:
        raise ValueError(f"need 2 <= min_nodes <= max_nodes, got {min_nodes}, {max_nodes}")
    periodic = draw(topologies()) if topology is None else tuple(bool(p) for p in topology)
    shape = (draw(st.integers(min_nodes, max_nodes)), draw(st.integers(min_nodes, max_nodes)))
    lower = np.array([draw(_floats(-2.0, 2.0)), draw(_floats(-2.0, 2.0))])
    length = np.array([draw(_floats(0.5, 4.0)), draw(_floats(0.5, 4.0))])
    offset = draw(_floats(-1.0, 1.0))
    if constant:
        values = np.full(shape, offset)
    else:
        amplitude = draw(_floats(min_amplitude, max_amplitude))
        rng = np.random.default_rng(draw(seeds()))
        values = offset + amplitude * rng.uniform(-1.0, 1.0, size=shape)
    return Surface(values, lower, lower + length, periodic)


@st.composite
def states(draw, surface, n_particles: int, *, margin: float = 0.1, max_speed: float = 1.0,
           max_periods: int = 2):
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

    Returns
    -------
    SearchStrategy[tuple[ndarray, ndarray]]
    """
    rng = np.random.default_rng(draw(seeds()))
    L = surface.length
    x0 = rng.uniform(surface.lower - margin * L, surface.upper + margin * L, size=(n_particles, 2))
    if max_periods:
        for d in range(2):
            if surface.periodic[d]:
                x0[:, d] += L[d] * rng.integers(-max_periods, max_periods + 1, size=n_particles)
    v0 = rng.uniform(-max_speed, max_speed, size=(n_particles, 2))
    return x0, v0


def _per_particle_shape(draw, n_particles: int, *, allow_scalar=True):
    """One of the shapes that broadcast to (N, 2): (), (2,), (N, 1), (N, 2)."""
    shapes = ([()] if allow_scalar else []) + [(2,), (n_particles, 1), (n_particles, 2)]
    return draw(st.sampled_from(shapes))


def _resolve(draw, value, strategy):
    """``value`` if given (True/False/number), else draw from ``strategy``."""
    return draw(strategy) if value is None else value


@st.composite
def scenes(draw, n_particles: int = 1, *, topology=None, mode=None, damped=None, smooth_only: bool = False,
           spring=None, walls=None, effects=None, noise=None, per_particle_mass=None,
           n_steps=None, min_steps: int = 0, max_steps: int = 12, min_nodes: int = 2, max_nodes: int = 12,
           min_amplitude: float = 0.0, max_amplitude: float = 2.0,
           dt_range=(0.01, 0.2), max_omega_dt: float = 0.5, omega_dt=None, surface=None):
    """A full valid :class:`pes_ref.Scene` for N particles.

    Any subset of the effects may be drawn: a spring (stiffness and centre shaped
    (), (2,), (N, 1) or (N, 2)), walls on the allowed (non-periodic) edges, damping,
    per-particle mass, and external force effects (:class:`~pes_ref.Constant`,
    :class:`~pes_ref.PerParticle`, :class:`~pes_ref.Noise`, each possibly inside a
    :class:`~pes_ref.Window`).

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
        minimum-image seam; :func:`scene_cases` keeps particles below that seam's energy.)
    spring, walls, effects, noise, per_particle_mass : bool, optional
        Force the effect on (True) or off (False); None draws. ``effects`` governs all
        external force effects, ``noise`` only the Noise effect among them. Walls on a
        torus are always off (no non-periodic edge).
    n_steps : int, optional
        Fix T; else drawn in ``[min_steps, max_steps]``.
    min_nodes, max_nodes, min_amplitude, max_amplitude
        Grid size per axis and value amplitude (see :func:`surfaces`).
    dt_range : (float, float)
        The time step is drawn in this range ...
    max_omega_dt : float
        ... and then cut to ``max_omega_dt / omega_max``, where ``omega_max``
        (:func:`~pes_ref.testing.energy.max_frequency`) bounds the frequency of the
        stiffest term (velocity Verlet is stable for ``omega_max dt < 2``). Quasistatic
        mobility is ``mu_d = r / K`` with ``r <= max_omega_dt`` and ``K = omega_max^2
        min m`` the stiffness ``omega_max`` bounds by (stable for ``mu K < 2``).
    omega_dt : (float, float), optional
        Instead, set ``dt = r / omega_max`` with ``r`` drawn in this range (dynamic
        mode; capped at ``dt_range[1]``): the energy-error tests use it to control
        ``omega_max dt``.
    surface : Surface, optional
        Use this surface instead of drawing one.

    Returns
    -------
    SearchStrategy[Scene]
    """
    N = int(n_particles)
    mode = _resolve(draw, mode, st.sampled_from(MODES))
    if surface is None:
        surface = draw(surfaces(topology, min_nodes=min_nodes, max_nodes=max_nodes, constant=smooth_only,
                                min_amplitude=min_amplitude, max_amplitude=max_amplitude))
    periodic = surface.periodic
    lower, L = surface.lower, surface.length
    rng = np.random.default_rng(draw(seeds()))

    # -- mass (per axis, per particle or one scalar), in [0.5, 2]
    if _resolve(draw, per_particle_mass, st.booleans()):
        mshape = (N, draw(st.sampled_from((1, 2))))
    else:
        mshape = draw(st.sampled_from(((), (2,))))
    mass = rng.uniform(0.5, 2.0, size=mshape)

    # -- damping
    damping = None
    if mode == "dynamic":
        if _resolve(draw, damped, st.booleans()):
            damping = rng.uniform(0.05, 1.0, size=_per_particle_shape(draw, N))
        elif draw(st.booleans()):
            damping = np.zeros(_per_particle_shape(draw, N))      # an explicit zero: still undamped
    elif damped:
        raise ValueError("damped=True needs mode='dynamic' (quasistatic scenes have no damping)")

    # -- spring
    spring_obj = None
    if _resolve(draw, spring, st.booleans()):
        k = rng.uniform(0.1, 4.0, size=_per_particle_shape(draw, N))
        cshape = draw(st.sampled_from(((2,), (N, 2))))
        center = rng.uniform(lower, lower + L, size=cshape)
        spring_obj = Spring(k, center)

    # -- walls: only on non-periodic edges
    walls_obj = None
    free = [d for d in range(2) if not periodic[d]]
    if free and _resolve(draw, walls, st.booleans()):
        edges = np.zeros((2, 2), dtype=bool)
        candidates = [(d, side) for d in free for side in (0, 1)]
        for d, side in draw(st.lists(st.sampled_from(candidates), min_size=1, unique=True)):
            edges[d, side] = True
        k_w = draw(_floats(1.0, 20.0))
        margin = draw(_floats(0.0, 0.25)) * float(min(L[d] for d in free))
        walls_obj = Walls(k_w, margin, edges)

    # -- time grid
    T = draw(st.integers(min_steps, max_steps)) if n_steps is None else int(n_steps)
    t0 = draw(_floats(-1.0, 1.0))

    # -- external force effects
    eff = []
    if _resolve(draw, effects, st.booleans()):
        kinds = draw(st.lists(st.sampled_from(("constant", "per_particle", "noise")), min_size=1, max_size=3))
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
                e = Noise(rng.uniform(0.0, 1.0, size=2), draw(seeds()))
            if draw(st.booleans()):
                # a window [t_start, t_end) somewhere over the run's times (in units of steps)
                a = draw(_floats(-1.0, T + 1.0))
                b = a + draw(_floats(0.5, T + 2.0))
                e = Window(e, t_start=a, t_end=b)       # rescaled to times below
            eff.append(e)
    elif noise:
        eff.append(Noise(rng.uniform(0.0, 1.0, size=2), draw(seeds())))

    # -- the time step (or mobility) from the stiffest term: omega_max dt = r
    probe = Scene(surface, dt=1.0, n_steps=0, mass=mass, spring=spring_obj, walls=walls_obj)
    omega = max_frequency(probe)
    mobility = None
    if mode == "dynamic":
        if omega_dt is None:
            dt = min(draw(_floats(*dt_range)), max_omega_dt / omega if omega > 0 else np.inf)
        else:                      # (capped: a nearly flat scene would get a huge step)
            dt = min(draw(_floats(*omega_dt)) / omega if omega > 0 else np.inf, dt_range[1])
    else:
        dt = draw(_floats(*dt_range))
        r = draw(_floats(0.05, max_omega_dt))
        K = omega ** 2 * float(np.min(probe.mass))        # the stiffness max_frequency bounds by
        mobility = np.array([draw(_floats(0.1, 1.0)), draw(_floats(0.1, 1.0))]) * r / max(K, 1.0)

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
    for d in range(2):
        if not scene.surface.periodic[d]:
            continue
        L = scene.surface.length[d]
        for i in range(N):
            if k[i, d] == 0:
                continue
            e_seam = 0.5 * k[i, d] * (0.5 * L) ** 2
            delta = rng.uniform(-0.35, 0.35) * L              # potential <= 0.49 e_seam ...
            room = max(0.25 * e_seam - 0.5 * k[i, d] * delta * delta, 0.0)
            if room == 0.0:
                delta *= 0.5                                   # ... but keep a quarter at most
                room = 0.25 * e_seam - 0.5 * k[i, d] * delta * delta
            x0[i, d] = c[i, d] + delta + L * rng.integers(-2, 3)
            v0[i, d] = rng.uniform(-1.0, 1.0) * np.sqrt(2.0 * room / m[i, d])
    return x0, v0


@st.composite
def scene_cases(draw, *, min_particles: int = 1, max_particles: int = 3, max_speed: float = 1.0,
                max_periods: int = 2, **scene_kw):
    """A scene with an initial state: ``(scene, x0, v0)``.

    Parameters
    ----------
    min_particles, max_particles : int
        N is drawn in this range.
    max_speed : float
        Initial speeds per axis are at most this (see :func:`states`).
    max_periods : int
        Periodic coordinates start up to this many whole periods away from the domain
        (see :func:`states`; 0 keeps them near it, which also keeps rounding small).
    **scene_kw
        Passed to :func:`scenes` (``topology``, ``mode``, ``damped``, ``smooth_only``,
        ``spring``, ``walls``, ``effects``, ``noise``, ``n_steps``, ``max_steps``, ...).
        With ``smooth_only=True`` the state is also kept below the minimum-image seam
        of every periodic spring (the seam is a kink of the spring force).

    Returns
    -------
    SearchStrategy[tuple[Scene, ndarray, ndarray]]
        ``x0``, ``v0`` of shape (N, 2); in quasistatic mode ``v0`` is zeros.
    """
    N = draw(st.integers(min_particles, max_particles))
    scene = draw(scenes(N, **scene_kw))
    x0, v0 = draw(states(scene.surface, N, max_speed=max_speed, max_periods=max_periods))
    if scene_kw.get("smooth_only"):
        x0, v0 = _below_seam(scene, x0, v0, np.random.default_rng(draw(seeds())))
    if scene.mode == "quasistatic":
        v0 = np.zeros_like(v0)
    return scene, x0, v0


@st.composite
def objectives(draw, scene: Scene, n_particles: int, *, kinds=("funnel_final", "funnel_every_step",
                                                                "oscillator", "quadratic"),
               regularization=None):
    """An objective of docs/spec.md section 6 and a regularization weight: ``(objective, R)``.

    Parameters
    ----------
    scene : Scene
        The objective's parameters are drawn on the scale of its domain and run.
    n_particles : int
    kinds : sequence of str
        Among ``"funnel_final"``, ``"funnel_every_step"``, ``"oscillator"``, ``"quadratic"``.
    regularization : bool, optional
        True: ``R`` in [1e-3, 1]; False: ``R = 0``; None: either.

    Returns
    -------
    SearchStrategy[tuple[object, float]]
        The quadratic objective's ``wx, wv, xref, vref`` have random broadcastable
        shapes among (), (2,), (N, 2) and (T+1, N, 2).
    """
    kind = draw(st.sampled_from(tuple(kinds)))
    s = scene.surface
    rng = np.random.default_rng(draw(seeds()))
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
    R = 0.0
    if _resolve(draw, regularization, st.booleans()):
        R = draw(_floats(1e-3, 1.0))
    return obj, R


@st.composite
def exit_paths(draw, *, max_states: int = 8, max_particles: int = 4, margin: float = 1e-3):
    """Positions ``x`` (T+1, N, 2) whose q1 falls through a level, and the level: ``(x, level)``.

    Each particle's q1 decreases from state to state; some particles cross ``level``, some
    may not; no q1 lies within ``margin`` of it (away from the kink where a particle's exit
    step changes, for finite differences of the funnel's exit cost). q0 is uniform in [-1, 1].
    """
    n_states = draw(st.integers(2, max_states))
    n = draw(st.integers(1, max_particles))
    rng = np.random.default_rng(draw(seeds()))
    level = float(rng.uniform(-1.0, 1.0))
    x = np.empty((n_states, n, 2))
    x[:, :, 0] = rng.uniform(-1.0, 1.0, (n_states, n))
    d = np.sort(rng.uniform(-1.0, 1.0, (n_states, n)), axis=0)[::-1]     # q1 - level, falling
    x[:, :, 1] = level + np.where(np.abs(d) < margin, np.copysign(2.0 * margin, d), d)
    return x, level


#: The margin kept from a term's kinks (a box face, an exit level, the minimum-image seam), far
#: beyond the finite-difference step.
TERM_MARGIN = 1e-3


def _away(offset: np.ndarray, half, margin: float = TERM_MARGIN) -> np.ndarray:
    """``offset`` with every ``|offset|`` within ``margin`` of ``half`` moved ``2 margin`` away from it."""
    near = np.abs(np.abs(offset) - half) < margin
    return np.where(near, offset + np.sign(offset) * 2 * margin, offset)


@st.composite
def term_cases(draw, *, max_states: int = 7, max_particles: int = 3):
    """A state term of a problem file (:data:`pes_ref.synthesis.objective_terms.OBJECTIVE_TERMS`,
    every kind but the grid's) on a random domain of any topology, with a trajectory away from
    its kinks: ``(term, x, v, t)``.

    Positions lie within 0.45 of a period of the term's target, box centre or edge centre (plus
    whole periods on a periodic axis, to exercise the minimum image), and no coordinate lies
    within :data:`TERM_MARGIN` of a box face or an exit level; a time is one of the states' (or
    after the run's end, where a term charges nothing).
    """
    from pes_ref.core.objectives import Quadratic
    from pes_ref.synthesis.objective_terms import EDGES, OBJECTIVE_TERMS, Domain

    periodic = draw(topologies())
    kinds = [k for k, cls in OBJECTIVE_TERMS.items() if not hasattr(cls, "grid_value_and_grad")
             and (k != "exit" or not all(periodic))]
    kind = draw(st.sampled_from(sorted(kinds)))
    rng = np.random.default_rng(draw(seeds()))
    lower = rng.uniform(-2.0, 0.0, 2)
    length = rng.uniform(1.0, 3.0, 2)
    domain = Domain(tuple(lower), tuple(lower + length), tuple(periodic))
    n_states, n = draw(st.integers(2, max_states)), draw(st.integers(1, max_particles))
    t = 0.1 * np.arange(n_states)
    shape = (n_states, n, 2)
    v = rng.normal(0.0, 1.0, shape)
    laps = np.where(periodic, rng.integers(-1, 2, shape), 0) * length      # whole periods on periodic axes
    weight = float(rng.uniform(0.1, 3.0))
    time = float(t[rng.integers(n_states)] if rng.uniform() < 0.85 else t[-1] + 0.3)
    point = lambda: tuple(lower + rng.uniform(0, 1, 2) * length)  # noqa: E731

    def near(center, half=0.0):
        return np.asarray(center) + _away(rng.uniform(-0.45, 0.45, shape) * length, half) + laps

    if kind in ("final_position", "position_at"):
        keys = {"target": point(), "weight": weight, "time": time}
        x = near(keys["target"])
    elif kind == "stay_in":
        a, b = point(), point()
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        start, end = sorted(rng.uniform(0.0, t[-1] + 0.2, 2))
        keys = {"lower": tuple(lo), "upper": tuple(hi), "from": float(start), "to": float(end), "weight": weight}
        x = near(0.5 * (lo + hi), 0.5 * (hi - lo))
    elif kind == "speed_at":
        keys = {"time": time, "axis": int(rng.integers(2)), "target": float(rng.normal()), "weight": weight}
        x = near(point())
    elif kind == "cycle":
        keys = {"amplitude": float(rng.uniform(0.2, 2.0)), "omega": float(rng.uniform(0.5, 3.0)),
                "axis": int(rng.integers(2)), "weight": weight}
        x = near(point())
    elif kind == "exit":
        edge = draw(st.sampled_from([e for e, (axis, _) in EDGES.items() if not periodic[axis]]))
        axis, side, level = domain.edge(edge)
        keys = {"edge": edge, "center": float(point()[1 - axis]), "halfwidth": float(rng.uniform(0.0, 0.3)),
                "weight": weight}
        x = near(np.where(np.arange(2) == axis, level, keys["center"]), keys["halfwidth"])
        d = np.sort(rng.uniform(-1.0, 1.0, (n_states, n)), axis=0)                 # distance past the level
        d = d[::-1] if side == "lower" else d
        x[:, :, axis] = level + _away(d, 0.0)
    else:                                                                           # custom
        keys = {"object": Quadratic(wx=float(rng.uniform(0.5, 2)), xref=float(rng.normal()),
                                    wv=float(rng.uniform(0.5, 2)), vref=float(rng.normal())), "weight": weight}
        x = near(point())
    cls = OBJECTIVE_TERMS[kind]
    term = cls.from_keys({k: keys[k] for k in cls.KEYS}, domain, float(t[-1]))
    return term, x, v, t
