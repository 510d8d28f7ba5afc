"""The heightfield check in a real engine: balls rolling on the plate in MuJoCo.

[`mujoco_paths`][pes_ref.realize.mujoco_ball.mujoco_paths] runs the design's held-out funnel
particles as solid balls on a MuJoCo heightfield geom (``hfield``) whose nodes carry the plate's
heights ``h = (E - min E) / (m g)``
([`pes_ref.realize.heightfield.HeightField`][pes_ref.realize.heightfield.HeightField], read back
from the exported STL's top). Everything else is the design's, taken from its own held-out batch
(``problem.plain().batch``, the sampler of
[`pes_ref.synthesis.kinds.registry.evaluate`][pes_ref.synthesis.kinds.registry.evaluate] with
``default_rng(seed)``):

- **the starts**: each ball's centre over the particle's start, resting on the plate, its
  velocity the particle's (rolling, without slipping);
- **the pushes and the noise**: the design's force schedule (``scene.schedule``: the constant
  push and the seeded noise, the same draws for the same seed) is applied to each ball's
  centre (MuJoCo's ``xfrc_applied``) as the same impulse per design step: step ``k``'s
  velocity Verlet gives ``dt (F_k + F_{k+1}) / 2``, so the force ``(F_k + F_{k+1}) / 2`` is
  held over the substeps of that step. A force at the centre of a rolling ball is what a
  tilt of the plate gives (gravity acts at the centre), as the rolling-ball model has it;
- **the walls**: the design's side walls (a stiff spring, ``Walls``) act as the same force
  ([`pes_ref.core.terms.wall_add_force`][pes_ref.core.terms.wall_add_force]), evaluated at every substep;
- **the damping**: the design's ``-gamma v`` on the horizontal velocity (MuJoCo's
  ``dof_damping`` on the free joint's x and y, integrated implicitly);
- **gravity** ``g`` of the heightfield, the mass ``m`` of the design's particle (a solid
  sphere: inertia ``2/5 m r^2``), the design's horizon (``n_steps`` of its ``dt``, or
  ``n_steps`` given).

The balls share one model and never touch each other: each ball's geom has ``contype`` 1 and
``conaffinity`` 0, the plate's ``contype`` 0 and ``conaffinity`` 1 (MuJoCo collides two geoms
when one's ``contype`` shares a bit with the other's ``conaffinity``).

What MuJoCo adds over the rolling-ball model
([`pes_ref.realize.heightfield.rolling_paths`][pes_ref.realize.heightfield.rolling_paths]):
the contact is a sphere of radius `BALL_RADIUS_SHARE` of a grid cell on the plate's
triangles (two per cell, as the STL's), so its centre follows the surface offset by the
radius and it touches at a point not under its centre; the full slope and curvature terms;
sliding friction `SLIDING_FRICTION` (rolling is not imposed: the ball rolls because
friction holds its contact point) with `CONDIM` 3 (no rolling resistance, as the
rolling-ball model has none). MuJoCo's contact is soft: a time constant
`CONTACT_TIMECONST` (``solref``; [`contact_timeconst`][pes_ref.realize.mujoco_ball.contact_timeconst]), far below the
design's step.

The plate is padded by `PAD` of its size on every side with its edge heights (the
design's surface extends as a constant beyond its grid), so a ball that leaves the grid
(through the exit edge) rolls on before it falls. The paths are sampled at the design's
steps (a [`pes_ref.core.integrator.Trajectory`][pes_ref.core.integrator.Trajectory] of the balls' horizontal centres and
velocities, its ``f`` the schedule's and the walls' force at each state), so
[`pes_ref.synthesis.exit_positions`][pes_ref.synthesis.kinds.funnel.exit_positions] reads their exits as the design's.
"""
from __future__ import annotations

import math

import numpy as np

from pes_ref.core import checks
from pes_ref.core.integrator import Trajectory
from pes_ref.core.terms import wall_add_force

__all__ = ["BALL_RADIUS_SHARE", "SLIDING_FRICTION", "CONDIM", "CONTACT_TIMECONST", "CONTACT_G", "CONTACT_IMPEDANCE",
           "TIMESTEP_SHARE", "SUBSTEPS", "PAD", "contact_timeconst", "substeps", "mujoco_paths", "plate_model"]

#: The ball's radius as a share of the grid's finer spacing. A sphere on a heightfield touches
#: it at the point where the surface's normal passes through its centre, not under the centre
#: (on a slope s, ``r s / sqrt(1 + s^2)`` away: 0.002 for a quarter cell of the 200-node funnel
#: at its steepest, 1.35), and it cannot follow a dip narrower than itself: a quarter of a cell
#: keeps it inside the grid's smallest feature, one cell (docs/realize.md measures a half and an
#: eighth).
BALL_RADIUS_SHARE = 0.25
#: Sliding friction (Coulomb, MuJoCo's ``friction[0]``). A solid ball rolls without slipping
#: while the friction it needs, 2/7 of the tangential force, stays within mu times the normal
#: force: on a slope s under gravity alone that is mu >= (2/7) s; 1.0 holds slopes up to 3.5
#: (the realizable funnel's steepest is 1.35) and pushes up to 3.5 m g.
SLIDING_FRICTION = 1.0
#: Contact dimension 3: sliding friction only, no torsional or rolling friction. The design's
#: particle and the rolling-ball model lose energy only to the design's damping, so the ball
#: has no rolling resistance either (a hard ball on a hard plate has little: condim 6 would add it).
CONDIM = 3
#: The contact's time constant (s, MuJoCo's ``solref[0]``; damping ratio 1) under gravity
#: `CONTACT_G`. A ball sinks into the plate by about ``g tc^2`` times a factor of the
#: impedance, and the plate's drag grows with the sink (`CONTACT_IMPEDANCE`): at g = 98.1
#: and 0.002 s the balls of a flat plate exit 15 design steps late, at 0.0006 s one. So under a
#: stronger gravity the time constant shrinks as ``1 / sqrt(g)`` (`contact_timeconst`),
#: keeping the sink; under a weaker one it stays. MuJoCo needs a timestep at most half of it.
CONTACT_TIMECONST = 0.002
#: The gravity (length / time^2) at which `CONTACT_TIMECONST` holds.
CONTACT_G = 9.81
#: The contact's impedance (MuJoCo's ``solimp``: d0, d_width, width). MuJoCo's heightfield is
#: a row of triangular prisms; a ball sunk a depth p into the plate meets the next prism's side
#: face over its first ``sqrt(2 r p)`` of travel and is pushed back there, a drag at every cell
#: boundary. At MuJoCo's default impedance (0.9, 0.95) a ball of a quarter cell sinks 5e-6 and
#: on a flat plate rolls 2.5% slower than it should after 3 s; at (0.999, 0.9999) it sinks 4e-8
#: and the deficit is 0.05% (docs/realize.md).
CONTACT_IMPEDANCE = (0.999, 0.9999, 0.001)
#: MuJoCo's timestep as a share of the contact's time constant: a quarter, 5e-4 s at g = 9.81.
#: On the realizable funnel halving it moves the balls' median exit by at most half a design
#: step and the in-band fraction by at most 3 balls of 200 (docs/realize.md).
TIMESTEP_SHARE = 0.25
#: The fewest MuJoCo steps per design step (20: 5e-4 s under the funnel's dt = 0.01).
SUBSTEPS = 20
#: The plate's padding beyond the grid on every side, as a share of the grid's size.
PAD = 0.1


def contact_timeconst(g: float) -> float:
    """The contact's time constant under gravity ``g``: `CONTACT_TIMECONST`, shorter by
    ``sqrt(CONTACT_G / g)`` when ``g`` is stronger than `CONTACT_G`."""
    return CONTACT_TIMECONST * math.sqrt(min(1.0, CONTACT_G / g))


def substeps(dt: float, g: float) -> int:
    """MuJoCo's steps per design step of ``dt`` under gravity ``g``: enough for a timestep at
    most `TIMESTEP_SHARE` of the contact's time constant, and at least `SUBSTEPS`."""
    return max(SUBSTEPS, math.ceil(dt / (TIMESTEP_SHARE * contact_timeconst(g)) - 1e-9))


def _solimp() -> str:
    return " ".join(repr(float(x)) for x in CONTACT_IMPEDANCE)


def _mujoco():
    from pes_ref.realize.extra import require_mujoco
    return require_mujoco()


def plate_model(hf, n_balls: int, mass: float, radius: float, timestep: float, damping):
    """The MuJoCo model: the plate's heightfield (``hf``'s heights padded by `PAD`) and
    ``n_balls`` balls of ``mass`` and ``radius``, each on a free joint whose horizontal dofs
    carry ``damping`` (2,)."""
    mujoco = _mujoco()
    heights = np.asarray(hf.heights, dtype=np.float64)
    n0, n1 = heights.shape
    pad = [max(1, int(np.ceil(PAD * (n - 1)))) for n in (n0, n1)]
    padded = np.pad(heights, ((pad[0], pad[0]), (pad[1], pad[1])), mode="edge")
    h = hf.spacing
    half = 0.5 * (np.array([n0, n1]) - 1 + 2 * np.array(pad)) * h
    centre = 0.5 * (hf.lower + hf.upper)
    top = float(padded.max())
    elevation = top if top > 0 else 1.0
    base = max(float(hf.spacing.min()), elevation)          # the hfield's thickness below its lowest point
    contact = (f'condim="{CONDIM}" friction="{float(SLIDING_FRICTION)!r} 0 0" '
               f'solref="{contact_timeconst(hf.g)!r} 1" solimp="{_solimp()}"')
    balls = "\n".join(f'<body name="b{i}"><freejoint/><geom type="sphere" size="{float(radius)!r}" '
                      f'mass="{float(mass)!r}" contype="1" conaffinity="0" {contact}/></body>' for i in range(n_balls))
    xml = f"""<mujoco model="plate">
  <option timestep="{float(timestep)!r}" gravity="0 0 {float(-hf.g)!r}" integrator="Euler" cone="elliptic"/>
  <asset><hfield name="plate" nrow="{padded.shape[1]}" ncol="{padded.shape[0]}"
    size="{float(half[0])!r} {float(half[1])!r} {float(elevation)!r} {float(base)!r}"/></asset>
  <worldbody>
    <geom name="plate" type="hfield" hfield="plate" pos="{float(centre[0])!r} {float(centre[1])!r} 0"
      contype="0" conaffinity="1" {contact}/>
    {balls}
  </worldbody>
</mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    # MuJoCo's heightfield is row-major with rows along y (q1) and columns along x (q0),
    # elevations in [0, 1] scaled by size[2]
    model.hfield_data[:] = (padded.T / elevation).ravel()
    dofs = model.jnt_dofadr[:n_balls]
    model.dof_damping[dofs] = damping[0]
    model.dof_damping[dofs + 1] = damping[1]
    return model


def _surface_height(hf, x: np.ndarray):
    """The plate's height (bilinear in the nodes) and slope |grad h| (of the cell) at points x (N, 2)."""
    h = hf.spacing
    n = np.array(hf.heights.shape)
    u = np.clip((x - hf.lower) / h, 0.0, n - 1 - 1e-9)
    i = np.floor(u).astype(int)
    t = u - i
    H = hf.heights
    a, b = H[i[:, 0], i[:, 1]], H[i[:, 0] + 1, i[:, 1]]
    c, d = H[i[:, 0], i[:, 1] + 1], H[i[:, 0] + 1, i[:, 1] + 1]
    s0, s1 = t[:, 0], t[:, 1]
    z = a * (1 - s0) * (1 - s1) + b * s0 * (1 - s1) + c * (1 - s0) * s1 + d * s0 * s1
    g0 = ((b - a) * (1 - s1) + (d - c) * s1) / h[0]
    g1 = ((c - a) * (1 - s0) + (d - b) * s0) / h[1]
    return z, np.hypot(g0, g1)


def mujoco_paths(problem, hf, seed: int, n_particles: int, n_steps: int | None = None, *,
                 radius_share: float = BALL_RADIUS_SHARE, steps_per_step: int | None = None) -> Trajectory:
    """Held-out funnel particles as balls on heightfield ``hf`` in MuJoCo (module docstring):
    the design's batch from ``default_rng(seed)`` of ``n_particles``, run for ``n_steps`` of the
    design's ``dt`` (default its own ``n_steps``) with ``steps_per_step`` MuJoCo steps each
    (default [`substeps`][pes_ref.realize.mujoco_ball.substeps]); the
    balls' radius is ``radius_share`` of the grid's finer spacing. Returns the balls'
    horizontal centres, velocities and the schedule's and walls' force at the design's steps."""
    mujoco = _mujoco()
    seed = checks.as_nonneg_int("seed", seed)
    n = checks.as_positive_int("n_particles", n_particles)
    radius = checks.as_positive_float("radius_share", radius_share) * float(hf.spacing.min())
    if n_steps is not None:
        n_steps = checks.as_positive_int("n_steps", n_steps)
    batch = problem.plain().batch(hf.energy(), np.random.default_rng(seed), n, n_steps=n_steps)
    scene = batch.scene
    mass = float(hf.mass)
    damping = np.broadcast_to(np.zeros(2) if scene.damping is None else scene.damping, (2,))
    per_step = substeps(scene.dt, hf.g) if steps_per_step is None else \
        checks.as_positive_int("steps_per_step", steps_per_step)
    model = plate_model(hf, n, mass, radius, scene.dt / per_step, damping)
    data = mujoco.MjData(model)
    fext = scene.schedule(n)
    walls = scene.field().walls
    T = scene.n_steps

    qpos = data.qpos.reshape(n, 7)
    qvel = data.qvel.reshape(n, 6)
    x0, v0 = batch.x0, batch.v0
    z, slope = _surface_height(hf, x0)
    qpos[:, :2] = x0
    qpos[:, 2] = z + radius * np.sqrt(1.0 + slope ** 2)       # resting on a plane of that slope
    qpos[:, 3] = 1.0
    qvel[:, :2] = v0
    qvel[:, 3] = -v0[:, 1] / radius                           # rolling: the contact point at rest
    qvel[:, 4] = v0[:, 0] / radius
    mujoco.mj_forward(model, data)

    x, v, f = (np.empty((T + 1, n, 2)) for _ in range(3))
    applied = data.xfrc_applied[1:, :2]                      # body 0 is the world

    def wall_force(q):
        out = np.zeros((n, 2))
        if walls is not None:
            wall_add_force(q, *walls, out)
        return out

    x[0], v[0] = qpos[:, :2], qvel[:, :2]
    f[0] = wall_force(x[0]) + (0.0 if fext is None else fext[0])
    for k in range(T):
        held = 0.0 if fext is None else 0.5 * (fext[k] + fext[k + 1])
        for _ in range(per_step):
            applied[:] = wall_force(qpos[:, :2]) + held
            mujoco.mj_step(model, data)
        x[k + 1], v[k + 1] = qpos[:, :2], qvel[:, :2]
        f[k + 1] = wall_force(x[k + 1]) + (0.0 if fext is None else fext[k + 1])
    _check_warnings(mujoco, data)
    return Trajectory(x, v, f)


#: MuJoCo's warnings that make a run's figures untrustworthy, and what each means here.
_WARNINGS = {"mjWARN_CONTACTFULL": "it ran out of room for contacts", "mjWARN_CNSTRFULL": "it ran out of room for "
             "constraints", "mjWARN_BADQACC": "its accelerations became invalid (unstable)",
             "mjWARN_BADQPOS": "its positions became invalid", "mjWARN_BADQVEL": "its velocities became invalid"}


def _check_warnings(mujoco, data) -> None:
    """Refuse a run that MuJoCo warned about (it drops contacts or resets a state and carries on)."""
    for name, what in _WARNINGS.items():
        if data.warning[int(getattr(mujoco.mjtWarning, name))].number:
            raise checks.InputError("n_particles", f"the MuJoCo check's run is not to be trusted: {what} "
                                                   f"({name}); fewer n_particles or a gentler plate may help")
