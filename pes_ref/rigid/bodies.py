"""A device's two parts as rigid bodies in pymunk (Chipmunk2D): the rigid engine's model.

Each part of a device file ([`pes_ref.devices.geometry.Part`][pes_ref.devices.geometry.Part]) becomes one pymunk body
holding the part's own geometry (the same shapely geometry, circles within the same
tolerance, that the surface model's C-space is computed from), cut into convex pieces
(shapely's constrained Delaunay triangles merged while convex, [`convex_pieces`][pes_ref.rigid.bodies.convex_pieces];
pymunk collides convex pieces), and held to
its one degree of freedom:

- a **translation** slides on a groove joint along its direction; its mass is the axis's
  mass and it cannot turn (infinite moment);
- a **rotation** turns on a pivot joint; its moment of inertia is the axis's inertia;
- a **drum** is unrolled: its drawing, tiled a turn apart
  ([`pes_ref.devices.geometry.Drum.tiled`][pes_ref.devices.geometry.Drum.tiled]),
  slides along -y by the arc length ``R q`` on a groove joint, with the mass ``I / R^2``
  that gives the drum's kinetic energy ``I q'^2 / 2``; the body is moved back by a whole
  turn whenever it leaves the turn ``(-2 pi R, 0]`` (the drawing repeats, so nothing moves)
  and the turns are counted, so the coordinate stays unwrapped.

Each motion is one entry of `MOTION_BODIES` (motion type -> how its body is made, read
and pushed), so the engine never asks which motion it has. A part's circle without cuts is a
pymunk circle of its radius as drawn (round, as the part is made), on a translation or a
rotation; every other shape (a drum's drawing too) is its polygon. Contact is frictionless and
inelastic by default; a device's ``[rigid]`` table states its restitution and friction
(pymunk multiplies the two shapes' values, so each shape gets the square root). A bounce
never adds energy (`bounce_without_gain`).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from pes_ref.core import checks
from pes_ref.core.runtime.extras import pip_line, require
from pes_ref.devices.geometry import Circle, Drum, Rotation, Translation, require_shapely

__all__ = ["PIP_LINE", "require_pymunk", "MOTION_BODIES", "RigidParts", "rigid_parts", "convex_pieces", "SLOP_SHARE",
           "COLLISION_BIAS", "ITERATIONS", "round_circles", "bounce_without_gain"]

#: The pip line that installs the rigid engine.
PIP_LINE = pip_line("rigid")
#: pymunk's allowed overlap (its collision slop), as a share of the C-space cell in length
#: (`RigidParts.cell`): the contact rests this far inside the wall.
SLOP_SHARE = 1e-3
#: The share of an overlap the contact leaves after one second (pymunk's collision bias; its
#: default 0.9^60 takes a tenth of a second to push out an overlap). 0: each step pushes the
#: whole overlap beyond the slop out, with pymunk's separate pseudo-velocities, which move the
#: parts without changing their velocities (no energy is added). A part that moved into the
#: other within a substep (up to half a C-space cell) is back at the contact the next substep.
COLLISION_BIAS = 0.0
#: The constraint solver's iterations per step (pymunk's default is 10; the pivot and groove
#: joints and the contacts are solved together).
ITERATIONS = 20


def require_pymunk():
    """The ``pymunk`` module (version 7), or [`pes_ref.devices.geometry.MissingExtraError`][pes_ref.core.runtime.extras.MissingExtraError] with the pip line."""
    return require("pymunk", "rigid", "the rigid engine", major=7, version="version")


def _triangles(geom) -> list:
    """The constrained Delaunay triangles of a (Multi)Polygon, each three corners counter-clockwise."""
    shapely = require_shapely()
    tris = shapely.get_parts(shapely.constrained_delaunay_triangles(geom))
    out = []
    for t in tris:
        if t.area > 0:
            c = np.asarray(shapely.orient_polygons(t).exterior.coords)[:3] if hasattr(shapely, "orient_polygons") \
                else np.asarray(shapely.geometry.polygon.orient(t).exterior.coords)[:3]
            out.append(c)
    return out


def _cross(o, a, b) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def _convex(poly: list, eps: float) -> bool:
    n = len(poly)
    return all(_cross(poly[i - 1], poly[i], poly[(i + 1) % n]) >= -eps for i in range(n))


def convex_pieces(geom) -> list:
    """The convex pieces of a (Multi)Polygon, each its corners counter-clockwise: its constrained
    Delaunay triangles, merged across their shared edges while the union stays convex (the
    Hertel-Mehlhorn rule: at most four times the fewest pieces). A circle's polygon is one
    piece, not a fan of thin triangles: fewer shapes make pymunk's step cheaper, and no contact
    meets an edge inside a part. The edges are tried in a fixed order (bit-identical runs)."""
    pieces = {i: [tuple(map(float, p)) for p in t] for i, t in enumerate(_triangles(geom))}
    if not pieces:
        return []
    scale = max(max(abs(c) for p in pieces.values() for v in p for c in v), 1.0)
    eps = 1e-12 * scale * scale
    owner = {}                         # directed edge (a, b) -> the piece that has it
    for i, poly in pieces.items():
        for k in range(len(poly)):
            owner[(poly[k], poly[(k + 1) % len(poly)])] = i
    for edge in sorted(owner):
        u, v = edge
        i, j = owner.get((u, v)), owner.get((v, u))
        if i is None or j is None or i == j:
            continue
        a, b = pieces[i], pieces[j]
        ka, kb = a.index(v), b.index(u)
        ra = a[ka:] + a[:ka]           # v ... u (the edge u -> v closes it)
        rb = b[kb:] + b[:kb]           # u ... v
        merged = ra + rb[1:-1]
        if not _convex(merged, eps):
            continue
        for k in range(len(a)):
            owner.pop((a[k], a[(k + 1) % len(a)]), None)
        for k in range(len(b)):
            owner.pop((b[k], b[(k + 1) % len(b)]), None)
        del pieces[j]
        pieces[i] = merged
        for k in range(len(merged)):
            owner[(merged[k], merged[(k + 1) % len(merged)])] = i
    return [np.array(p) for _, p in sorted(pieces.items())]


@functools.lru_cache(maxsize=64)
def _pieces(wkb: bytes) -> tuple:
    """[`convex_pieces`][pes_ref.rigid.bodies.convex_pieces] of a geometry given as WKB, once per geometry (every space
    of a run,
    and every chunk of a drive, builds the same parts)."""
    return tuple(convex_pieces(require_shapely().from_wkb(wkb)))


# --------------------------------------------------------------------------- one entry per motion
class _TranslationBody:
    """A part sliding by q along its unit direction u: the body sits at ``q u``."""

    @staticmethod
    def lever(motion, geom) -> float:
        return 1.0

    @staticmethod
    def make(pymunk, space, motion, inertia: float, geom):
        u = np.asarray(motion.direction, dtype=float)
        body = pymunk.Body(float(inertia), math.inf)
        space.add(body)
        far = 1e9
        space.add(pymunk.GrooveJoint(space.static_body, body, tuple(-far * u), tuple(far * u), (0.0, 0.0)))
        return body, geom, (u,)

    @staticmethod
    def frame(motion, geom):
        """The part's geometry in its body's frame (as `make` returns it)."""
        return geom

    @staticmethod
    def place(body, data, q: float) -> int:
        (u,) = data
        body.position = (q * u[0], q * u[1])
        return 0

    @staticmethod
    def set_velocity(body, data, qdot: float) -> None:
        (u,) = data
        body.velocity = (qdot * u[0], qdot * u[1])

    @staticmethod
    def read(body, data, turns: int):
        (u,) = data
        p, v = body.position, body.velocity
        return p.x * u[0] + p.y * u[1], v.x * u[0] + v.y * u[1]

    @staticmethod
    def push(body, data, force: float) -> None:
        (u,) = data
        body.force = (force * u[0], force * u[1])

    @staticmethod
    def rewrap(space, body, data) -> int:
        return 0

    @staticmethod
    def circle_offset(motion, center):
        return tuple(map(float, center))


class _RotationBody:
    """A part turning by q about its pivot: the body sits at the pivot, turned by q."""

    @staticmethod
    def lever(motion, geom) -> float:
        return _reach(geom, motion.pivot)

    @staticmethod
    def make(pymunk, space, motion, inertia: float, geom):
        pivot = np.asarray(motion.pivot, dtype=float)
        reach = _reach(geom, pivot)
        body = pymunk.Body(float(inertia) / reach ** 2, float(inertia))
        body.position = tuple(pivot)
        space.add(body)
        space.add(pymunk.PivotJoint(space.static_body, body, tuple(pivot)))
        return body, _RotationBody.frame(motion, geom), (pivot,)

    @staticmethod
    def frame(motion, geom):
        pivot = np.asarray(motion.pivot, dtype=float)
        return require_shapely().transform(geom, lambda xy: xy - pivot)

    @staticmethod
    def place(body, data, q: float) -> int:
        body.angle = q
        return 0

    @staticmethod
    def set_velocity(body, data, qdot: float) -> None:
        body.angular_velocity = qdot

    @staticmethod
    def read(body, data, turns: int):
        return body.angle, body.angular_velocity

    @staticmethod
    def push(body, data, torque: float) -> None:
        body.torque = torque

    @staticmethod
    def rewrap(space, body, data) -> int:
        return 0

    @staticmethod
    def circle_offset(motion, center):
        return tuple(map(float, np.asarray(center, dtype=float) - np.asarray(motion.pivot, dtype=float)))


class _DrumBody:
    """A drum unrolled: its tiled drawing slides along -y by ``R q``; the body is kept within
    the turn ``(-2 pi R, 0]`` and the whole turns it is moved back by are counted."""

    @staticmethod
    def lever(motion, geom) -> float:
        return float(motion.radius)

    @staticmethod
    def make(pymunk, space, motion, inertia: float, geom):
        r = float(motion.radius)
        body = pymunk.Body(float(inertia) / r ** 2, math.inf)
        space.add(body)
        far = 1e9
        space.add(pymunk.GrooveJoint(space.static_body, body, (0.0, -far), (0.0, far), (0.0, 0.0)))
        return body, motion.tiled(geom), (r, 2.0 * math.pi * r)

    @staticmethod
    def frame(motion, geom):
        return motion.tiled(geom)

    @staticmethod
    def place(body, data, q: float) -> int:
        r, period = data
        turns = math.floor(q / (2.0 * math.pi))
        body.position = (0.0, -r * (q - 2.0 * math.pi * turns))
        return turns

    @staticmethod
    def set_velocity(body, data, qdot: float) -> None:
        r, _ = data
        body.velocity = (0.0, -r * qdot)

    @staticmethod
    def read(body, data, turns: int):
        r, period = data
        return turns * 2.0 * math.pi - body.position.y / r, -body.velocity.y / r

    @staticmethod
    def push(body, data, torque: float) -> None:
        r, _ = data
        body.force = (0.0, -torque / r)

    @staticmethod
    def rewrap(space, body, data) -> int:
        """Move the body back into ``(-2 pi R, 0]`` by whole turns; returns the turns it moved
        (the coordinate is ``2 pi turns - y / R``)."""
        _, period = data
        y = body.position.y
        k = math.floor(-y / period)
        if k == 0:
            return 0
        body.position = (body.position.x, y + k * period)
        space.reindex_shapes_for_body(body)
        return k

    #: A drum's drawing is tiled a turn apart (`pes_ref.devices.geometry.Drum.tiled`): its circles stay polygons.
    circle_offset = None


#: How each motion's body is made, placed, read and pushed.
MOTION_BODIES = {Translation: _TranslationBody, Rotation: _RotationBody, Drum: _DrumBody}


def _reach(geom, pivot) -> float:
    """The largest distance of the geometry from ``pivot`` (> 0): a rotating body's radius of gyration's scale."""
    shapely = require_shapely()
    xy = shapely.get_coordinates(geom) - np.asarray(pivot, dtype=float)
    return max(float(np.max(np.hypot(xy[:, 0], xy[:, 1]))), 1e-12)


@dataclass(frozen=True, eq=False)
class RigidParts:
    """A device's parts as pymunk bodies, one pymunk space per particle
    ([`space`][pes_ref.rigid.bodies.RigidParts.space]).

    Attributes
    ----------
    device : pes_ref.devices.device.Device
    restitution, friction : float
        The contact's (the device's ``[rigid]`` table).
    cell : float
        The length a part may move in one substep, at most: the C-space cell in length,
        ``min_d h_d l_d`` with ``l_d`` the lever of axis d's motion (1 for a translation, the
        part's reach for a rotation, R for a drum), or the radius of the largest disc inside
        the parts' smallest piece where that is less (a pin thinner than a cell of a coarse
        grid), so that no part passes through another and a start's allowance never eats one.
    levers : ndarray (2,)
        Length per unit of each coordinate at the parts' far edge.
    """

    device: object
    mass: np.ndarray
    quasistatic: bool
    restitution: float
    friction: float
    cell: float
    levers: np.ndarray

    def space(self):
        """A new space holding both parts, and what `place`, `read`, `push`
        and `rewrap` need of it."""
        pymunk = require_pymunk()
        space = pymunk.Space()
        space.iterations = ITERATIONS
        space.collision_slop = SLOP_SHARE * self.cell
        space.collision_bias = COLLISION_BIAS
        handles = []
        e, mu = math.sqrt(self.restitution), math.sqrt(self.friction)
        for d, part in enumerate(self.device.parts):
            entry = MOTION_BODIES[type(part.motion)]
            rounds, rest = round_circles(part)
            body, geom, data = entry.make(pymunk, space, part.motion, float(self.mass[d]), self._geometry(d))
            if rounds and rest:                  # the polygons of the shapes that are not round
                geom = entry.frame(part.motion, self._geometry(d, rest))
            shapes = [pymunk.Circle(body, float(c.radius), entry.circle_offset(part.motion, c.center)) for c in rounds]
            if rest:
                shapes += [pymunk.Poly(body, [tuple(p) for p in piece])
                           for piece in _pieces(require_shapely().to_wkb(geom))]
            for shape in shapes:
                shape.elasticity, shape.friction = e, mu
                space.add(shape)
            handles.append((entry, body, data))
        if self.restitution > 0.0:
            space.on_collision(pre_solve=bounce_without_gain, data=self.restitution)
        return space, handles

    def _geometry(self, d: int, shapes=None):
        """Part ``d``'s geometry (of ``shapes`` only, when given: some of its shapes)."""
        part = self.device.parts[d]
        if shapes is not None and len(shapes) != len(part.shapes):
            part = type(part)(tuple(shapes), part.motion)
        return part.geometry(self.device.grid.tolerance)


def round_circles(part) -> tuple:
    """``(circles, others)``: the part's shapes that the engine makes pymunk circles (a
    [`Circle`][pes_ref.devices.geometry.Circle] without cuts, on a motion whose body takes
    circles: its entry's ``circle_offset``) and the rest, which are polygons."""
    if MOTION_BODIES[type(part.motion)].circle_offset is None:
        return (), tuple(part.shapes)
    rounds = tuple(s for s in part.shapes if isinstance(s, Circle) and not s.minus)
    return rounds, tuple(s for s in part.shapes if not (isinstance(s, Circle) and not s.minus))


def _acceleration(body, point):
    """The acceleration of ``body``'s point ``point`` (a world point) under the force and torque
    set on it for this step (no contact): ``f / m + alpha x r``."""
    a = np.zeros(2)
    if math.isfinite(body.mass) and body.mass > 0:
        a += np.array([body.force.x, body.force.y]) / body.mass
    if math.isfinite(body.moment) and body.moment > 0:
        alpha = body.torque / body.moment
        r = np.array([point.x - body.position.x, point.y - body.position.y])
        a += alpha * np.array([-r[1], r[0]])
    return a


def bounce_without_gain(arbiter, space, restitution) -> None:
    """pymunk's ``pre_solve``: the contact's restitution for this step, so that a bounce never
    adds energy.

    pymunk finds a contact once the parts overlap and bounces them with ``e`` times the normal
    speed they then have; the overlap is pushed out without work (pseudo-velocities). A part
    pushed into the other gained speed over that overlap, so an elastic bounce would give back
    the push's work over it (a pin pushed steadily onto a wall would never settle). The speed
    the parts met with is the speed they have less what the forces of the step (the scene's
    and the springs', set on the bodies; not the contact's) gave them over the overlap ``d``:
    ``s_touch^2 = s^2 - 2 g d`` (``s`` the approach speed, ``g`` the approach acceleration
    along the normal). The restitution is ``e s_touch / s``, never above ``e``: a bounce
    returns at most ``e`` times the speed of the touch."""
    points = arbiter.contact_point_set.points
    if not points:
        return
    n = arbiter.contact_point_set.normal
    a, b = arbiter.bodies
    worst = min(points, key=lambda p: p.distance)
    depth = max(0.0, -float(worst.distance))
    at = worst.point_a
    vrn = (b.velocity_at_world_point(at) - a.velocity_at_world_point(at)).dot(n)
    arn = float(np.dot(_acceleration(b, at) - _acceleration(a, at), (n.x, n.y)))
    if vrn < 0.0 and arn < 0.0:                         # approaching, and pushed together
        touch = max(0.0, vrn * vrn + 2.0 * arn * depth)
        arbiter.restitution = restitution * min(1.0, math.sqrt(touch) / -vrn)
    else:
        arbiter.restitution = restitution


def _thinnest(geoms) -> float:
    """The radius of the largest disc inside the smallest piece of the parts' geometries."""
    shapely = require_shapely()
    pieces = [p for g in geoms for p in shapely.get_parts(g)]
    return float(min(shapely.length(shapely.maximum_inscribed_circle(p)) for p in pieces))


def rigid_parts(device, mass, quasistatic: bool = False) -> RigidParts:
    """The device's parts as rigid bodies with the masses (or inertias) ``mass`` (2,) per axis;
    ``quasistatic``: the masses are the inverse mobilities (the bodies take the velocity the
    mobility gives the force, and the contact's impulses take away what the parts forbid)."""
    require_pymunk()
    mass = checks.as_float_array("mass", mass, shape=(2,), positive=True)
    geoms = [p.geometry(device.grid.tolerance) for p in device.parts]
    levers = np.array([MOTION_BODIES[type(p.motion)].lever(p.motion, g) for p, g in zip(device.parts, geoms)])
    cell = min(float(np.min(np.asarray(device.spacing) * levers)), _thinnest(geoms))
    return RigidParts(device, mass, bool(quasistatic), float(device.restitution), float(device.friction), cell, levers)
