"""The conformance vectors' families: every vector of the set, built from seeded generators.

Every vector is built here from a seeded `numpy.random.Generator` (the seed is
derived from the vector's id, so adding or reordering vectors changes no other one); a
vector is a case, its kind, flags and, if invalid, the key and error type the oracle must
refuse it with ([`pes_ref.oracle.conformance.writer`][pes_ref.oracle.conformance.writer] writes them and their results).

Topologies use a node spacing of 0.25 on every axis, so node and seam positions are
exact in binary and the edge-state vectors really sit on a node or a seam; the
``spacing-inexact-*`` vectors use spacings that are not (where a float32 ``1/h`` differs
from float64's). A kink vector may list its other one-sided gradients (docs/spec.md 7.3),
computed by the oracle on the case with the kink state nudged one ulp to the other side;
an invalid vector whose file breaks the container rules (docs/spec.md 8.1) is written
byte for byte (flag ``file``).
"""
from __future__ import annotations

import hashlib
import io
import zipfile
from dataclasses import dataclass, field

import numpy as np

from pes_ref.core.effects import Constant, Noise, PerParticle, Window, build_schedule

__all__ = ["VERSION", "TOPOLOGIES", "Vector", "valid_vectors", "invalid_vectors", "build_vectors"]

#: The vector set these families make. v5 (spec v5) keeps every vector of v4 and adds each
#: refusal rule from both sides: ``limit-*``, 1% inside (valid) and past (refused) the
#: stability rule of docs/spec.md section 10, or on it, so that each misreading of the rule
#: lands on the wrong side of one; ``edge-*``, valid values at the edges of ranges; and
#: ``optional-*``, every optional key NaN, infinite, misshapen or of a wrong type. v4 kept
#: every vector of v3 (the same cases and results, the same one-sided files) and added three
#: families of valid cases
#: the spec accepts that no v3 vector held: a single wall of an axis with a margin of at
#: least half the axis's length (``wide-margin-*``: docs/spec.md 8.6, the room rule binds
#: two walls of one axis only), ``periodic`` and ``walls`` as int8 and uint8 arrays of 0
#: and 1 (``integer-flags-*``: 8.4), and particles 1e-9 below and above interior cell
#: edges on every kind of axis (``near-edge-*``: 2.3, the cell ``floor`` picks from the
#: float64 ``u``, which a float32 ``u`` rounds onto the edge). (v3 bound the gradients of
#: kink vectors to their one-sided values and added the points the spec fixes that no
#: vector sat on, the container refusals and runs that overflow; v2 added the stability
#: rule of section 10 to v1.)
VERSION = "v5"
_SEED = 20210921

# name -> (shape, lower, upper, periodic); every spacing is 0.25
TOPOLOGIES = {
    "plane": ((5, 7), (0.0, 0.0), (1.0, 1.5), (False, False)),
    "cylinder-q0": ((8, 5), (0.0, -0.5), (2.0, 0.5), (True, False)),
    "cylinder-q1": ((5, 8), (-0.5, 0.0), (0.5, 2.0), (False, True)),
    "torus": ((4, 8), (0.0, 0.0), (1.0, 2.0), (True, True)),
}


@dataclass
class Vector:
    """One conformance vector.

    Attributes
    ----------
    id : str
        Unique, also the file stem.
    comment : str
        What it covers.
    case : dict
        The case keys (as [`pes_ref.oracle.case.save_case`][pes_ref.oracle.case.save_case] takes them).
    kind : {"valid", "invalid"}
    flags : list of str
        ``kink``: a state sits exactly on a kink (node, seam, clip edge, wall onset),
        where the contract (docs/spec.md 2.5, 7.3) owes a one-sided gradient: the
        result's, or one of ``other_sides``. ``file``: the case is the bytes ``file``.
        ``nonfinite``: an invalid case refused only when run (12.1). Other flags are
        informational.
    key, error : str
        Invalid vectors: the key at fault (None for a file that is not an ``.npz``) and the
        error type ("ValueError" or "TypeError").
    other_sides : dict of str -> callable
        Kink vectors: per name, a function ``case -> case`` that moves the kink state one
        ulp to the side whose one-sided gradient is also accepted; its gradients are
        shipped as ``<id>.<name>.result.npz``.
    file : bytes, optional
        The case file's bytes, for a case that is no ``.npz`` of case keys (flag ``file``).
    """

    id: str
    comment: str
    case: dict
    kind: str = "valid"
    flags: list = field(default_factory=list)
    key: str | None = None
    error: str | None = None
    other_sides: dict = field(default_factory=dict)
    file: bytes | None = None


# =========================================================================== case builders

def _rng(vid: str) -> np.random.Generator:
    digest = hashlib.sha256(vid.encode()).digest()
    return np.random.default_rng([_SEED, int.from_bytes(digest[:8], "little")])


def _case(rng, topology="plane", *, n=2, mode="dynamic", n_steps=20, dt=0.05, shape=None, domain=None,
          objective="funnel-final", speed=0.5, **extra) -> dict:
    """A valid case: random grid and state on a topology, and one objective (``shape``
    and ``domain = (lower, upper)`` replace the topology's grid)."""
    shp, lower, upper, periodic = TOPOLOGIES[topology]
    if shape is not None:
        shp = shape
    if domain is not None:
        lower, upper = domain
    lower, upper = np.array(lower), np.array(upper)
    case = {
        "values": rng.normal(0.0, 0.5, shp),
        "lower": lower,
        "upper": upper,
        "periodic": np.array(periodic),
        "dt": np.float64(dt),
        "n_steps": np.int64(n_steps),
        "mode": mode,
        "mass": np.float64(1.0),
        "damping": np.float64(0.0),
        "x0": lower + (upper - lower) * rng.uniform(0.15, 0.85, (n, 2)),
        "v0": rng.normal(0.0, speed, (n, 2)),
    }
    if mode == "quasistatic":
        case["mobility"] = np.array([0.02, 0.03])
    case.update(_objective(rng, objective, n_steps, n))
    case.update(extra)
    return case


def _objective(rng, kind: str, n_steps: int, n: int) -> dict:
    if kind == "funnel-final":
        return {"objective": "funnel", "target": np.float64(0.6), "when": "final"}
    if kind == "funnel-every":
        return {"objective": "funnel", "target": np.float64(0.4), "when": "every_step"}
    if kind == "oscillator":
        return {"objective": "oscillator", "amplitude": np.float64(0.3), "omega": np.float64(2.0)}
    if kind == "quadratic":
        return {"objective": "quadratic", "wx": np.float64(1.0), "wv": np.float64(0.5),
                "xref": rng.uniform(0.0, 1.0, (n, 2)), "vref": np.array([0.1, -0.2])}
    if kind == "quadratic-arrays":
        t1 = n_steps + 1
        return {"objective": "quadratic", "wx": rng.uniform(0.5, 2.0, (t1, 1, 2)),
                "wv": rng.uniform(0.0, 1.0, (t1, n, 2)), "xref": rng.uniform(0.0, 1.0, (t1, n, 2)),
                "vref": np.float64(0.0)}
    if kind == "quadratic-velocity":
        return {"objective": "quadratic", "wx": np.float64(0.0), "wv": np.float64(1.0),
                "xref": np.float64(0.0), "vref": np.array([0.3, 0.0])}
    raise ValueError(f"unknown objective kind {kind!r}")


def _force(case: dict, *effects) -> np.ndarray:
    """Realize effects into the case's ``force`` schedule (what the oracle records)."""
    n = case["x0"].shape[0]
    return build_schedule(effects, n, int(case["n_steps"]), float(case["dt"]), float(case.get("t0", 0.0)))


def _walls(*edges) -> dict:
    w = np.zeros((2, 2), dtype=bool)
    for d, e in edges:
        w[d, e] = True
    return {"wall_k": np.float64(40.0), "wall_margin": np.float64(0.1), "walls": w}


# =========================================================================== valid vectors

def _valid(vid: str, comment: str, build, flags=(), other_sides=None) -> Vector:
    return Vector(vid, comment, build(_rng(vid)), "valid", list(flags), other_sides=dict(other_sides or {}))


def _topology_vectors():
    yield _valid("plane-dynamic", "plane, dynamic, no effects, zero damping, funnel at the final step",
                 lambda r: _case(r, "plane", n=3, n_steps=24))
    yield _valid("cylinder-q0-dynamic", "cylinder periodic in q0, damped, particles cross the seam, "
                 "funnel at every step",
                 lambda r: _case(r, "cylinder-q0", n=2, n_steps=24, objective="funnel-every",
                                 damping=np.float64(0.2), v0=np.array([[3.0, 0.1], [-2.5, -0.2]])))
    yield _valid("cylinder-q1-dynamic", "cylinder periodic in q1, particles cross the seam, oscillator",
                 lambda r: _case(r, "cylinder-q1", n=2, n_steps=24, objective="oscillator",
                                 v0=np.array([[0.1, 3.0], [-0.2, -2.5]])))
    yield _valid("torus-dynamic", "torus, both seams crossed, quadratic, regularization",
                 lambda r: _case(r, "torus", n=3, n_steps=24, objective="quadratic",
                                 v0=np.array([[2.0, 3.0], [-1.5, 2.5], [0.5, -3.5]]),
                                 regularization=np.float64(0.01)))
    yield _valid("plane-quasistatic", "plane, quasistatic, funnel at the final step",
                 lambda r: _case(r, "plane", n=3, mode="quasistatic", n_steps=24))
    yield _valid("cylinder-q0-quasistatic", "cylinder periodic in q0, quasistatic, quadratic",
                 lambda r: _case(r, "cylinder-q0", mode="quasistatic", n_steps=24, objective="quadratic"))
    yield _valid("cylinder-q1-quasistatic", "cylinder periodic in q1, quasistatic, funnel at every step",
                 lambda r: _case(r, "cylinder-q1", mode="quasistatic", n_steps=24, objective="funnel-every"))
    yield _valid("torus-quasistatic", "torus, quasistatic, oscillator (V is zero), regularization",
                 lambda r: _case(r, "torus", n=3, mode="quasistatic", n_steps=24, objective="oscillator",
                                 regularization=np.float64(0.05)))


def _spring_wall_vectors():
    yield _valid("spring-per-axis", "plane, spring with per-axis k and center (2,), quadratic",
                 lambda r: _case(r, "plane", n=3, objective="quadratic",
                                 spring_k=np.array([2.0, 3.0]), spring_center=np.array([0.5, 0.75])))
    yield _valid("spring-per-particle-torus", "torus, per-particle spring (N, 2): minimum image on both axes",
                 lambda r: _case(r, "torus", n=3, objective="funnel-every", speed=1.5,
                                 spring_k=r.uniform(1.0, 4.0, (3, 2)), spring_center=r.uniform(0.0, 2.0, (3, 2))))
    yield _valid("spring-cylinder-q0-quasistatic", "cylinder q0, quasistatic, spring k (N, 1), center (2,) "
                 "on the far side of the seam",
                 lambda r: _case(r, "cylinder-q0", n=2, mode="quasistatic", objective="quadratic",
                                 spring_k=np.array([[1.5], [3.0]]), spring_center=np.array([1.9, 0.1]),
                                 x0=np.array([[0.2, -0.1], [0.7, 0.2]])))
    edges = {"q0-lower": (0, 0), "q0-upper": (0, 1), "q1-lower": (1, 0), "q1-upper": (1, 1)}
    for name, (d, e) in edges.items():
        def build(r, d=d, e=e):
            case = _case(r, "plane", n=2, n_steps=30, objective="quadratic", **_walls((d, e)))
            lo, hi = case["lower"][d], case["upper"][d]
            case["x0"][:, d] = [lo + 0.2, lo + 0.3] if e == 0 else [hi - 0.2, hi - 0.3]
            case["v0"][:, d] = [-1.5, -1.0] if e == 0 else [1.5, 1.0]
            return case
        yield _valid(f"wall-{name}", f"plane, only the {name.replace('-', ' ')} wall; particles run into it", build)
    yield _valid("walls-all-quasistatic", "plane, all four walls, quasistatic, constant force pushing "
                 "particles into the upper walls",
                 lambda r: _with_force(_case(r, "plane", n=3, mode="quasistatic", n_steps=20, objective="quadratic",
                                             **_walls((0, 0), (0, 1), (1, 0), (1, 1))),
                                       Constant([6.0, 8.0])))
    yield _valid("walls-cylinder-q0", "cylinder q0, both walls on the non-periodic axis q1, dynamic, damped",
                 lambda r: _case(r, "cylinder-q0", n=2, n_steps=30, damping=np.float64(0.1),
                                 v0=np.array([[1.0, 2.0], [-1.0, -2.0]]), **_walls((1, 0), (1, 1))))
    yield _valid("walls-cylinder-q1-quasistatic", "cylinder q1, both walls on q0, quasistatic, force into the wall",
                 lambda r: _with_force(_case(r, "cylinder-q1", n=2, mode="quasistatic", n_steps=20,
                                             objective="funnel-every", **_walls((0, 0), (0, 1))),
                                       Constant([-7.0, 1.0])))


def _with_force(case: dict, *effects) -> dict:
    case["force"] = _force(case, *effects)
    return case


def _force_vectors():
    yield _valid("force-constant", "plane, constant external force",
                 lambda r: _with_force(_case(r, "plane", n=2), Constant([0.5, -0.3])))
    yield _valid("force-per-particle", "plane, a constant force per particle",
                 lambda r: _with_force(_case(r, "plane", n=3, objective="quadratic"),
                                       PerParticle(r.normal(0.0, 0.5, (3, 2)))))
    yield _valid("force-window", "plane, a force on for t in [0.4, 0.8) only, t0 = 0.1",
                 lambda r: _with_force(_case(r, "plane", n=2, objective="oscillator", t0=np.float64(0.1)),
                                       Window(Constant([1.0, 0.5]), 0.4, 0.8)))
    yield _valid("force-noise", "plane, Gaussian force noise (std (0.3, 0.1), seed 7) realized into force",
                 lambda r: _with_force(_case(r, "plane", n=2, objective="funnel-every"),
                                       Noise([0.3, 0.1], 7)))
    yield _valid("force-combined-torus-quasistatic", "torus, quasistatic: constant + windowed per-particle "
                 "force + noise; grad_force[T] is 0",
                 lambda r: _with_force(_case(r, "torus", n=3, mode="quasistatic", objective="quadratic"),
                                       Constant([0.2, 0.1]), Window(PerParticle(r.normal(0, 1, (3, 2))), 0.2, 0.6),
                                       Noise([0.5, 0.5], 11)))
    yield _valid("force-window-quasistatic", "plane, quasistatic, a windowed force reaching the last state",
                 lambda r: _with_force(_case(r, "plane", n=2, mode="quasistatic"),
                                       Window(Constant([2.0, -1.0]), 0.5, 5.0)))


def _mass_damping_vectors():
    yield _valid("mass-per-particle", "plane, mass per particle (N, 1), oscillator",
                 lambda r: _case(r, "plane", n=3, objective="oscillator", mass=np.array([[0.5], [1.0], [2.0]])))
    yield _valid("mass-damping-per-particle-axis", "cylinder q1, mass and damping (N, 2)",
                 lambda r: _case(r, "cylinder-q1", n=3, objective="quadratic", mass=r.uniform(0.5, 2.0, (3, 2)),
                                 damping=r.uniform(0.0, 1.0, (3, 2))))
    yield _valid("mass-damping-per-axis", "plane, mass (2,) and damping (2,) per axis",
                 lambda r: _case(r, "plane", n=2, objective="funnel-every", mass=np.array([0.8, 1.5]),
                                 damping=np.array([0.2, 0.7])))
    yield _valid("damping-per-particle", "torus, damping per particle (N, 1), one of them zero",
                 lambda r: _case(r, "torus", n=3, objective="oscillator", damping=np.array([[0.0], [0.3], [1.0]])))
    yield _valid("damping-zero-per-axis", "plane, damping (2,) all zero: the undamped step, but "
                 "grad_damping is still owed",
                 lambda r: _case(r, "plane", n=2, objective="quadratic", damping=np.zeros(2)))
    yield _valid("damping-strong", "plane, heavy damping (gamma dt / 2m = 0.5)",
                 lambda r: _case(r, "plane", n=2, damping=np.float64(20.0), speed=2.0))


def _objective_vectors():
    yield _valid("oscillator-t0", "cylinder q0, oscillator with t0 = 0.35",
                 lambda r: _case(r, "cylinder-q0", n=2, objective="oscillator", t0=np.float64(0.35)))

    def zero_root(r):
        case = _case(r, "plane", n=1, objective="oscillator")
        case["x0"][0, 0] = 0.3    # = A cos(0)
        case["v0"][0, 0] = 0.0    # = -A w sin(0)
        return case
    yield _valid("oscillator-zero-root", "oscillator whose root argument is exactly 0 at n = 0 "
                 "(its derivative is taken as 0 there)", zero_root, flags=["zero-root"])
    yield _valid("quadratic-arrays", "quadratic with weights and references of shape (T+1, 1, 2) and (T+1, N, 2)",
                 lambda r: _case(r, "cylinder-q1", n=2, objective="quadratic-arrays"))
    yield _valid("quadratic-velocity", "quadratic on velocities only (wx = 0)",
                 lambda r: _case(r, "plane", n=2, objective="quadratic-velocity"))
    yield _valid("quadratic-quasistatic-arrays", "quasistatic, quadratic with (T+1, N, 2) arrays, regularization",
                 lambda r: _case(r, "torus", n=2, mode="quasistatic", objective="quadratic-arrays",
                                 regularization=np.float64(0.02)))
    yield _valid("regularization", "plane, dynamic, funnel plus regularization R = 0.1",
                 lambda r: _case(r, "plane", n=2, regularization=np.float64(0.1)))


def _grid_vectors():
    yield _valid("plane-2x2", "plane on the smallest grid, 2 x 2, dynamic",
                 lambda r: _case(r, "plane", n=2, shape=(2, 2), objective="quadratic"))
    yield _valid("torus-2x2-quasistatic", "torus on a 2 x 2 grid, quasistatic",
                 lambda r: _case(r, "torus", n=2, shape=(2, 2), mode="quasistatic", objective="funnel-every"))
    yield _valid("cylinder-q1-2x2", "cylinder q1 on a 2 x 2 grid, dynamic, fast particles",
                 lambda r: _case(r, "cylinder-q1", n=2, shape=(2, 2), objective="oscillator", speed=3.0))
    yield _valid("integer-dtypes", "plane with integer values, lower, upper and mass (read as float64)",
                 lambda r: _case(r, "plane", n=2, values=r.integers(-2, 3, (5, 7)), lower=np.array([0, 0]),
                                 upper=np.array([1, 2]), mass=np.int64(2)), flags=["dtype"])
    yield _valid("everything-cylinder-q1", "cylinder q1: spring, walls on q0, per-particle force and mass, "
                 "per-axis damping, quadratic, regularization",
                 lambda r: _with_force(_case(r, "cylinder-q1", n=3, n_steps=40, objective="quadratic",
                                             mass=np.array([[1.0], [2.0], [0.5]]), damping=np.array([0.1, 0.3]),
                                             spring_k=np.array([1.0, 2.0]), spring_center=np.array([0.0, 1.9]),
                                             regularization=np.float64(0.01), **_walls((0, 0), (0, 1))),
                                       PerParticle(r.normal(0.0, 1.0, (3, 2)))))
    yield _valid("torus-long", "torus, dynamic, 40 steps, four particles, oscillator",
                 lambda r: _case(r, "torus", n=4, n_steps=40, objective="oscillator", speed=1.0))


def _edge_vectors():
    def on_node(r):
        case = _case(r, "plane", n=3, objective="quadratic")
        case["x0"] = np.array([[0.25, 0.5], [0.5, 1.0], [0.75, 0.25]])
        case["v0"] = np.zeros((3, 2))
        return case
    yield _valid("on-node", "plane, particles start at rest exactly on interior nodes", on_node, flags=["kink"])

    def on_edge(r):
        case = _case(r, "plane", n=2, mode="quasistatic")
        case["x0"] = np.array([[1.0, 0.5], [0.0, 1.5]])   # on the upper / lower edge nodes
        return case
    yield _valid("on-domain-edge", "plane, quasistatic, particles exactly on the domain's edge nodes (clip edge)",
                 on_edge, flags=["kink"])

    def on_seam(r):
        case = _case(r, "cylinder-q0", n=3, objective="quadratic")
        case["x0"] = np.array([[0.0, 0.1], [2.0, -0.2], [-2.0, 0.3]])   # the seam, unwrapped three ways
        return case
    yield _valid("on-seam-cylinder-q0", "cylinder q0, particles exactly on the seam at q0 = 0, 2 and -2",
                 on_seam, flags=["kink"])

    def on_seam_torus(r):
        case = _case(r, "torus", n=2, mode="quasistatic", objective="quadratic")
        case["x0"] = np.array([[1.0, 2.0], [0.0, 0.0]])
        return case
    yield _valid("on-seam-torus-quasistatic", "torus, quasistatic, particles on the corner of both seams",
                 on_seam_torus, flags=["kink"])

    def far_outside(r):
        case = _case(r, "plane", n=3, objective="quadratic")
        case["x0"] = np.array([[0.4, 10.0], [-5.0, 0.7], [7.5, -9.0]])
        case["v0"] = np.array([[0.3, 1.0], [-1.0, 0.2], [1.0, -1.0]])
        return case
    yield _valid("far-outside", "plane, particles far outside one or both non-periodic axes (slope 0 there)",
                 far_outside)

    def far_outside_spring(r):
        # mobility within the stability rule (v1 had [0.05, 0.1], 1.74x the limit of the grid's curvature)
        case = _case(r, "cylinder-q0", n=2, mode="quasistatic", objective="funnel-every", n_steps=40,
                     spring_k=np.array([0.0, 2.0]), spring_center=np.array([0.0, 0.0]),
                     mobility=np.array([0.025, 0.04]))
        case["x0"] = np.array([[0.3, 4.0], [1.1, -3.0]])
        return case
    yield _valid("far-outside-spring-quasistatic", "cylinder q0, quasistatic, a spring pulls particles back "
                 "from far outside q1 into the grid", far_outside_spring)
    yield _valid("steps-0-dynamic", "T = 0: one state, no step", lambda r: _case(r, "plane", n=2, n_steps=0,
                                                                                 objective="quadratic"))
    yield _valid("steps-0-quasistatic", "T = 0, quasistatic", lambda r: _case(r, "torus", n=2, n_steps=0,
                                                                              mode="quasistatic"))
    yield _valid("steps-1-dynamic", "T = 1, with a force", lambda r: _with_force(
        _case(r, "cylinder-q0", n=2, n_steps=1, objective="oscillator"), Constant([0.3, 0.3])))
    yield _valid("steps-1-quasistatic", "T = 1, quasistatic, spring",
                 lambda r: _case(r, "plane", n=1, n_steps=1, mode="quasistatic", objective="quadratic",
                                 spring_k=np.float64(1.0), spring_center=np.array([0.5, 0.5])))


def _limit_vectors():
    """Valid cases near the stability rule of docs/spec.md section 10 (and one past it that
    takes no step)."""
    def near_spring(r):
        # dt sqrt(k / m) = 1.8: 0.9 of the limit of the spring, the stiffest term
        case = _case(r, "plane", n=2, n_steps=30, objective="quadratic", mass=np.array([1.0, 4.0]))
        case.update(spring_k=np.array([(1.8 / 0.05) ** 2, 1.0]), spring_center=np.array([0.5, 0.75]))
        return case
    yield _valid("near-limit-spring-dynamic", "dynamic, a spring at 0.9 of its stability limit "
                 "(dt sqrt(k/m) = 1.8); the grid's curvature is far below", near_spring)

    def near_grid(r):
        # mobility_1 c = 1.8: 0.9 of the limit of the grid's cross curvature c
        case = _case(r, "cylinder-q1", n=3, mode="quasistatic", n_steps=30, objective="funnel-every")
        case["mobility"] = np.array([0.01, 1.8 / _cross_curvature(case)])
        return case
    yield _valid("near-limit-grid-quasistatic", "quasistatic, the mobility on q1 at 0.9 of the stability "
                 "limit of the grid's curvature (mobility_1 c = 1.8)", near_grid)

    yield _valid("steps-0-past-limit", "T = 0 with dt far past the limit of its spring: a run of no step is "
                 "never refused", lambda r: _case(r, "plane", n=2, n_steps=0, dt=10.0, objective="quadratic",
                                                  spring_k=np.float64(100.0), spring_center=np.array([0.5, 0.5])))


def _nudged(*moves):
    """``case -> case`` moving ``x0[i, d]`` one ulp toward ``toward`` (-inf or inf) for each
    ``(i, d, toward)``: the kink state on the other side of its kink."""
    def move(case: dict) -> dict:
        x0 = np.array(case["x0"], dtype=np.float64)
        for i, d, toward in moves:
            x0[i, d] = np.nextafter(x0[i, d], toward)
        return dict(case, x0=x0)
    return move


def _kink_vectors():
    """States exactly on the kinks of docs/spec.md 7.3 that v2 had no vector on, each
    with the one-sided gradients the spec accepts there."""
    w = 0.125                                     # a wall margin that puts the onsets off the nodes

    def wall_onset(r):
        case = _case(r, "plane", n=4, n_steps=24, objective="quadratic", wall_k=np.float64(40.0),
                     wall_margin=np.float64(w), walls=np.ones((2, 2), dtype=bool))
        a, b = case["lower"] + w, case["upper"] - w            # the onsets a = lower + w, b = upper - w
        case["x0"] = np.array([[a[0], 0.6], [b[0], 0.85], [0.4, a[1]], [0.65, b[1]]])
        return case
    yield _valid("wall-onset-dynamic", "plane, all four walls, one particle exactly at each wall's onset "
                 "(q = a or q = b): the gradient of the inactive wall or of the active one is accepted",
                 wall_onset, flags=["kink"],
                 other_sides={"wall-active": _nudged((0, 0, -np.inf), (1, 0, np.inf), (2, 1, -np.inf),
                                                     (3, 1, np.inf))})

    def wall_onset_quasistatic(r):
        case = _case(r, "cylinder-q1", n=2, mode="quasistatic", objective="funnel-every", wall_k=np.float64(40.0),
                     wall_margin=np.float64(w), walls=np.array([[True, True], [False, False]]))
        case["x0"] = np.array([[case["lower"][0] + w, 0.7], [case["upper"][0] - w, 1.3]])
        return case
    yield _valid("wall-onset-cylinder-q1-quasistatic", "cylinder q1, quasistatic, both walls of q0, a particle "
                 "exactly at each onset", wall_onset_quasistatic, flags=["kink"],
                 other_sides={"wall-active": _nudged((0, 0, -np.inf), (1, 0, np.inf))})

    def grid_edge(r):
        case = _case(r, "plane", n=4, objective="quadratic")
        case["x0"] = np.array([[0.0, 0.6], [1.0, 0.85], [0.4, 0.0], [0.65, 1.5]])   # u = 0 or n - 1 on one axis
        case["v0"] = np.array([[0.8, 0.1], [-0.8, -0.2], [0.1, 0.8], [-0.2, -0.8]])
        return case
    yield _valid("grid-edge-plane", "plane, a particle exactly on the closed grid edge of each non-periodic "
                 "axis, lower and upper (s = 1 there), moving inward: only the inside derivative is one-sided",
                 grid_edge, flags=["kink"])

    def grid_edge_quasistatic(r):
        case = _case(r, "cylinder-q0", n=2, mode="quasistatic", objective="quadratic")
        case["x0"] = np.array([[0.6, -0.5], [1.3, 0.5]])
        return case
    yield _valid("grid-edge-cylinder-q0-quasistatic", "cylinder q0, quasistatic, particles exactly on both "
                 "closed edges of the non-periodic axis q1", grid_edge_quasistatic, flags=["kink"])

    def spring_seam(r):
        case = _case(r, "cylinder-q0", n=3, objective="quadratic", spring_k=np.array([3.0, 1.0]),
                     spring_center=np.array([0.875, 0.0]))
        case["x0"][:, 0] = [1.875, -0.125, 3.875]      # q - c + L/2 = 0 mod L: delta = -L/2, off the nodes
        return case
    yield _valid("spring-seam-cylinder-q0", "cylinder q0, particles exactly on the spring's minimum-image seam "
                 "(delta = -L/2), unwrapped three ways, off the grid's nodes", spring_seam, flags=["kink"])

    def spring_seam_torus(r):
        case = _case(r, "torus", n=3, mode="quasistatic", objective="funnel-every", spring_k=np.float64(2.0),
                     spring_center=np.array([0.375, 0.875]))
        case["x0"] = np.array([[0.875, 0.4], [0.3, 1.875], [-0.125, -0.125]])
        return case
    yield _valid("spring-seam-torus-quasistatic", "torus, quasistatic, particles on the spring's seam of q0, of "
                 "q1, and of both", spring_seam_torus, flags=["kink"])

    def zero_root_mid_run(r):
        dt, steps_to_zero = 0.0625, 5
        case = _case(r, "plane", n=1, mode="quasistatic", n_steps=12, dt=dt, objective="oscillator",
                     t0=np.float64(-(dt * steps_to_zero)))
        case["x0"] = np.array([[0.3, 0.6]])            # X = A cos(0) at t_5 = 0, in cell (1, 2) ...
        case["values"][1:3, 2:4] = np.mean(case["values"][1:3, 2:4])   # ... which is flat: X stays there
        return case
    yield _valid("oscillator-zero-root-mid-run", "quasistatic oscillator, a particle at rest in a flat cell "
                 "with t0 = -5 dt: the root's argument S_n is exactly 0 at n = 5 (its derivative is 0 there)",
                 zero_root_mid_run, flags=["zero-root"])


def _time_vectors():
    """Step times that do not start at 0, and windowed forces across them."""
    yield _valid("force-window-t0-negative", "plane, oscillator, t0 = -0.4, a force on for t in [-0.2, 0.3)",
                 lambda r: _with_force(_case(r, "plane", n=2, objective="oscillator", n_steps=24, t0=np.float64(-0.4)),
                                       Window(Constant([1.5, -0.5]), -0.2, 0.3)))
    yield _valid("oscillator-t0-quasistatic", "torus, quasistatic, oscillator with t0 = 1.25",
                 lambda r: _case(r, "torus", n=2, mode="quasistatic", objective="oscillator", n_steps=24,
                                 t0=np.float64(1.25)))
    yield _valid("force-windows-t0-cylinder-q1", "cylinder q1, damped, t0 = 2.5, a per-particle force on in "
                 "[2.6, 3.1) and a constant one from 2.9 to past the last step, funnel at every step",
                 lambda r: _with_force(_case(r, "cylinder-q1", n=2, n_steps=24, objective="funnel-every",
                                             damping=np.float64(0.3), t0=np.float64(2.5)),
                                       Window(PerParticle(r.normal(0.0, 1.0, (2, 2))), 2.6, 3.1),
                                       Window(Constant([0.0, 1.0]), 2.9, 10.0)))
    yield _valid("oscillator-t0-late-spring", "plane, spring and damping, oscillator with t0 = 7.3 (cos and sin "
                 "far from their values at 0)",
                 lambda r: _case(r, "plane", n=3, objective="oscillator", n_steps=30, t0=np.float64(7.3),
                                 damping=np.float64(0.3), spring_k=np.array([2.0, 1.0]),
                                 spring_center=np.array([0.5, 0.75])))


def _spacing_vectors():
    """Spacings that are not exact binary fractions, where ``-1/h`` in float32 differs from float64."""
    yield _valid("spacing-inexact-plane", "plane 6 x 7 on [-0.3, 1.0] x [0.1, 1.7]: h = (0.26, 0.2667)",
                 lambda r: _case(r, "plane", n=3, n_steps=30, shape=(6, 7), objective="oscillator",
                                 domain=((-0.3, 0.1), (1.0, 1.7))))
    yield _valid("spacing-inexact-torus-quasistatic", "torus 5 x 6 on [0, 1.1] x [0, 2.3]: h = (0.22, 0.3833), "
                 "quasistatic", lambda r: _case(r, "torus", n=3, mode="quasistatic", n_steps=24, shape=(5, 6),
                                                objective="quadratic", domain=((0.0, 0.0), (1.1, 2.3))))
    yield _valid("spacing-inexact-cylinder-q0", "cylinder q0 7 x 5 on [0, 2.1] x [-0.6, 0.6]: h = (0.3, 0.3), "
                 "damped, spring, particles cross the seam",
                 lambda r: _case(r, "cylinder-q0", n=2, n_steps=30, shape=(7, 5), objective="funnel-every",
                                 domain=((0.0, -0.6), (2.1, 0.6)), damping=np.float64(0.3),
                                 spring_k=np.array([0.5, 1.5]), spring_center=np.array([1.0, 0.0]),
                                 v0=np.array([[3.0, 0.2], [-2.5, -0.1]])))


def _cross_curvature(case: dict) -> float:
    """The grid curvature c of a case, ``max over cells |G11 - G10 - G01 + G00| / (h0 h1)``
    (docs/spec.md section 10; cells closed by wrap-around on a periodic axis)."""
    G = np.asarray(case["values"], dtype=np.float64)
    periodic = np.asarray(case["periodic"], dtype=bool)
    n = np.array(G.shape)
    h = (np.asarray(case["upper"]) - np.asarray(case["lower"])) / np.where(periodic, n, n - 1)
    for d in range(2):
        if periodic[d]:
            G = np.concatenate((G, np.take(G, [0], axis=d)), axis=d)
    return float(np.max(np.abs(G[1:, 1:] - G[1:, :-1] - G[:-1, 1:] + G[:-1, :-1])) / (h[0] * h[1]))


def _wide_margin_vectors():
    """A single wall of an axis whose margin is at least half the axis's length: valid,
    since the room rule of docs/spec.md 8.6 binds only two walls of one axis."""
    def wide_exactly_half(r):
        # q0 (L = 1) has its lower wall alone, at a = lower + L/2; q1 (L = 1.5) has both walls, 2 w < 1.5
        return _case(r, "plane", n=3, n_steps=24, objective="quadratic", wall_k=np.float64(40.0),
                     wall_margin=np.float64(0.5), walls=np.array([[True, False], [True, True]]))
    yield _valid("wide-margin-dynamic", "plane, the lower wall of q0 alone with wall_margin = L0/2 (the room rule "
                 "would refuse it for two walls), both walls of q1 with room between them (2 w < L1)",
                 wide_exactly_half, flags=["wide-margin"])

    def wide_past_the_far_edge(r):
        # the upper wall of q0 (L = 1) at b = upper - 1.25 L, below the lower edge: every particle is in it
        return _case(r, "cylinder-q1", n=3, mode="quasistatic", n_steps=24, objective="funnel-every",
                     wall_k=np.float64(40.0), wall_margin=np.float64(1.25),
                     walls=np.array([[False, True], [False, False]]))
    yield _valid("wide-margin-quasistatic", "cylinder q1, quasistatic, the upper wall of q0 alone with "
                 "wall_margin = 1.25 L0: its onset lies past the far edge, and it pushes every particle out of "
                 "the grid", wide_past_the_far_edge, flags=["wide-margin"])


def _integer_flag_vectors():
    """``periodic`` and ``walls`` as integer arrays of 0 and 1 (docs/spec.md 8.4), each dtype
    on a topology with a 0 and a 1 in both keys."""
    def int8_flags(r):
        return _case(r, "cylinder-q0", n=2, n_steps=24, objective="oscillator", periodic=np.array([1, 0], np.int8),
                     wall_k=np.float64(40.0), wall_margin=np.float64(0.1),
                     walls=np.array([[0, 0], [1, 1]], np.int8), v0=np.array([[2.5, 0.8], [-2.0, -0.9]]))
    yield _valid("integer-flags-int8", "cylinder q0, periodic and walls as int8 0/1 arrays: both walls of q1, "
                 "particles cross the seam of q0", int8_flags, flags=["dtype"])

    def uint8_flags(r):
        return _case(r, "cylinder-q1", n=2, mode="quasistatic", n_steps=24, objective="quadratic",
                     periodic=np.array([0, 1], np.uint8), wall_k=np.float64(40.0), wall_margin=np.float64(0.15),
                     walls=np.array([[1, 0], [0, 0]], np.uint8), x0=np.array([[-0.45, 0.3], [0.2, 1.7]]))
    yield _valid("integer-flags-uint8", "cylinder q1, quasistatic, periodic and walls as uint8 0/1 arrays: the "
                 "lower wall of q0, a particle starting inside it", uint8_flags, flags=["dtype"])


#: How far the near-edge states sit from their cell edge: in a spacing of 0.25, u is 4e-9
#: from an integer, which float64 resolves and float32 (half an ulp: 2**-25, about 3e-8,
#: or more at u >= 1) rounds onto the edge.
_NEAR = 1e-9


def _near_edge_vectors():
    """Particles 1e-9 below and above interior cell edges (docs/spec.md 2.3: the cell is
    the one ``floor`` picks from the float64 ``u``), on each topology, on periodic axes
    also on the seam and whole periods away."""
    e = _NEAR

    def near(topology, x0, **kw):
        def build(r):
            case = _case(r, topology, n=len(x0), n_steps=24, **kw)
            case["x0"] = np.array(x0)
            return case
        return build
    yield _valid("near-edge-plane-dynamic", "plane, particles 1e-9 below and above the interior edges q0 = 0.5 "
                 "and q1 = 1.0",
                 near("plane", [[0.5 - e, 0.6], [0.5 + e, 0.85], [0.4, 1.0 - e], [0.65, 1.0 + e]],
                      objective="quadratic"), flags=["near-edge"])
    yield _valid("near-edge-cylinder-q0-dynamic", "cylinder q0, particles 1e-9 below and above edges of the "
                 "periodic q0 (0.5, the seam at 2, and whole periods away) and of q1 (0)",
                 near("cylinder-q0", [[0.5 - e, 0.1], [2.5 + e, -0.2], [2.0 - e, -e], [-1.5 - e, e]],
                      objective="funnel-every", damping=np.float64(0.2)), flags=["near-edge"])
    yield _valid("near-edge-cylinder-q1-quasistatic", "cylinder q1, quasistatic, particles 1e-9 below and above "
                 "edges of q0 (0 and 0.25) and of the periodic q1 (1.5, and 3.75 one period away)",
                 near("cylinder-q1", [[-e, 0.7], [0.25 + e, 1.3], [0.1, 1.5 - e], [-0.3, 3.75 + e]],
                      mode="quasistatic", objective="funnel-every"), flags=["near-edge"])
    yield _valid("near-edge-torus-dynamic", "torus, particles 1e-9 below and above edges of both axes, the "
                 "seams of q0 at 1 and of q1 at 4 (two periods away) among them",
                 near("torus", [[0.75 - e, 1.25 + e], [0.25 + e, 0.5 - e], [1.0 - e, 0.3], [0.6, 4.0 - e]],
                      objective="oscillator"), flags=["near-edge"])


def valid_vectors() -> list:
    """All valid vectors, in manifest order."""
    out = []
    for group in (_topology_vectors, _spring_wall_vectors, _force_vectors, _mass_damping_vectors,
                  _objective_vectors, _grid_vectors, _edge_vectors, _limit_vectors,
                  _kink_vectors, _time_vectors, _spacing_vectors, _wide_margin_vectors, _integer_flag_vectors,
                  _near_edge_vectors):
        out.extend(group())
    return out


# =========================================================================== invalid vectors

def _base_dynamic() -> dict:
    return _case(_rng("invalid-base-dynamic"), "plane", n=2, n_steps=5, objective="funnel-final")


def _base_quasistatic() -> dict:
    return _case(_rng("invalid-base-quasistatic"), "cylinder-q0", n=2, n_steps=5, mode="quasistatic",
                 objective="quadratic")


def _invalid(vid, comment, key, error, *, drop=(), base=_base_dynamic, flags=(), **changes) -> Vector:
    case = base()
    for k in drop:
        del case[k]
    case.update(changes)
    return Vector(vid, comment, case, "invalid", list(flags), key, error)


def invalid_vectors() -> list:
    """All invalid vectors: each breaks exactly one rule, named by ``key``."""
    nan2 = np.array([[0.2, np.nan], [0.5, 0.5]])
    V, T = "ValueError", "TypeError"
    q = _base_quasistatic
    return [
        # missing and unknown keys
        _invalid("missing-values", "required key values absent", "values", V, drop=["values"]),
        _invalid("missing-mass", "required key mass absent", "mass", V, drop=["mass"]),
        _invalid("missing-v0-quasistatic", "v0 is required in quasistatic mode too", "v0", V, drop=["v0"], base=q),
        _invalid("missing-damping-quasistatic", "damping is required in quasistatic mode too", "damping", V,
                 drop=["damping"], base=q),
        _invalid("missing-objective", "required key objective absent", "objective", V,
                 drop=["objective", "target", "when"]),
        _invalid("missing-mobility", "quasistatic mode needs mobility", "mobility", V, drop=["mobility"], base=q),
        _invalid("missing-target", "funnel needs target", "target", V, drop=["target"]),
        _invalid("missing-vref", "quadratic needs all of wx, wv, xref, vref", "vref", V, drop=["vref"], base=q),
        _invalid("unknown-key", "a key the SPEC does not name", "gravity", V, gravity=np.float64(9.81)),
        _invalid("unknown-objective", "objective 'banana'", "objective", V, objective="banana"),
        _invalid("unknown-mode", "mode 'stochastic'", "mode", V, mode="stochastic"),
        _invalid("unknown-when", "funnel when 'sometimes'", "when", V, when="sometimes"),
        _invalid("foreign-objective-param", "omega belongs to the oscillator, not the funnel", "omega", V,
                 omega=np.float64(1.0)),
        _invalid("mobility-in-dynamic", "mobility is refused in dynamic mode", "mobility", V,
                 mobility=np.array([0.1, 0.1])),
        _invalid("spring-without-center", "spring_k and spring_center come together", "spring_center", V,
                 spring_k=np.float64(1.0)),
        _invalid("walls-without-k", "wall_k, wall_margin, walls come together", "wall_k", V,
                 wall_margin=np.float64(0.1), walls=np.ones((2, 2), dtype=bool)),
        # shapes
        _invalid("values-1d", "values must be 2-D", "values", V, values=np.zeros(7)),
        _invalid("values-one-node", "values needs 2 nodes per axis", "values", V, values=np.zeros((1, 7))),
        _invalid("lower-shape", "lower must have shape (2,)", "lower", V, lower=np.zeros(3)),
        _invalid("periodic-shape", "periodic must have shape (2,)", "periodic", V, periodic=np.array([False] * 3)),
        _invalid("x0-shape", "x0 must have shape (N, 2)", "x0", V, x0=np.zeros((2, 3))),
        _invalid("x0-empty", "x0 must hold a particle", "x0", V, x0=np.zeros((0, 2)), v0=np.zeros((0, 2))),
        _invalid("v0-particle-count", "v0 with another N than x0", "v0", V, v0=np.zeros((3, 2))),
        _invalid("mass-particle-count", "mass (N+1, 2) does not broadcast to (N, 2)", "mass", V, mass=np.ones((3, 2))),
        _invalid("damping-3d", "damping (1, N, 2) does not broadcast to (N, 2)", "damping", V,
                 damping=np.zeros((1, 2, 2))),
        _invalid("force-steps", "force with T entries instead of T+1", "force", V, force=np.zeros((5, 2, 2))),
        _invalid("force-particles", "force with another N", "force", V, force=np.zeros((6, 3, 2))),
        _invalid("walls-shape", "walls must have shape (2, 2)", "walls", V, wall_k=np.float64(10.0),
                 wall_margin=np.float64(0.1), walls=np.array([True, True])),
        _invalid("mobility-shape", "mobility must have shape (2,)", "mobility", V, mobility=np.ones(3) * 0.1,
                 base=q),
        _invalid("xref-shape", "xref does not broadcast to (T+1, N, 2)", "xref", V, xref=np.zeros((2, 3)), base=q),
        _invalid("dt-not-scalar", "dt must be a 0-d array", "dt", V, dt=np.array([0.05])),
        # non-finite
        _invalid("x0-nan", "NaN in x0", "x0", V, x0=nan2),
        _invalid("values-nan", "NaN in values", "values", V, values=np.full((5, 7), np.nan)),
        _invalid("force-nan", "NaN in force", "force", V, force=np.full((6, 2, 2), np.nan)),
        _invalid("spring-center-nan", "NaN in spring_center", "spring_center", V, spring_k=np.float64(1.0),
                 spring_center=np.array([np.nan, 0.0])),
        _invalid("dt-inf", "dt = inf", "dt", V, dt=np.float64(np.inf)),
        _invalid("v0-inf", "-inf in v0", "v0", V, v0=np.array([[0.0, -np.inf], [0.0, 0.0]])),
        _invalid("mass-inf", "mass = inf", "mass", V, mass=np.float64(np.inf)),
        _invalid("target-nan", "funnel target NaN", "target", V, target=np.float64(np.nan)),
        # signs and ranges
        _invalid("mass-zero", "m = 0", "mass", V, mass=np.float64(0.0)),
        _invalid("mass-negative", "one m < 0", "mass", V, mass=np.array([[1.0, 1.0], [1.0, -0.5]])),
        _invalid("dt-zero", "dt = 0", "dt", V, dt=np.float64(0.0)),
        _invalid("dt-negative", "dt < 0", "dt", V, dt=np.float64(-0.05)),
        _invalid("damping-negative", "gamma < 0", "damping", V, damping=np.array([0.1, -0.1])),
        _invalid("upper-not-above-lower", "upper <= lower on axis 1", "upper", V, upper=np.array([1.0, 0.0])),
        _invalid("spring-k-negative", "spring_k < 0", "spring_k", V, spring_k=np.float64(-1.0),
                 spring_center=np.zeros(2)),
        _invalid("wall-k-zero", "wall_k must be > 0", "wall_k", V, wall_k=np.float64(0.0),
                 wall_margin=np.float64(0.1), walls=np.ones((2, 2), dtype=bool)),
        _invalid("wall-margin-negative", "wall_margin < 0", "wall_margin", V, wall_k=np.float64(10.0),
                 wall_margin=np.float64(-0.1), walls=np.ones((2, 2), dtype=bool)),
        _invalid("wall-margin-no-room", "two walls on axis 0 whose margins meet", "wall_margin", V,
                 wall_k=np.float64(10.0), wall_margin=np.float64(0.5), walls=np.array([[True, True], [False, False]])),
        _invalid("wall-on-periodic-axis", "a wall on the periodic axis of a cylinder", "walls", V, base=q,
                 wall_k=np.float64(10.0), wall_margin=np.float64(0.1), walls=np.array([[True, False], [False, False]])),
        _invalid("mobility-zero", "mobility must be > 0", "mobility", V, mobility=np.array([0.1, 0.0]), base=q),
        _invalid("regularization-negative", "R < 0", "regularization", V, regularization=np.float64(-0.1)),
        _invalid("n-steps-negative", "n_steps < 0", "n_steps", V, n_steps=np.int64(-1)),
        _invalid("periodic-two", "periodic holds a 2", "periodic", V, periodic=np.array([0, 2])),
        # data types
        _invalid("n-steps-float", "n_steps must be an integer", "n_steps", T, n_steps=np.float64(5.0)),
        _invalid("mode-bytes", "strings are 0-d unicode arrays, not bytes", "mode", T, mode=np.array(b"dynamic")),
        _invalid("objective-1d", "strings are 0-d unicode arrays, not (1,) arrays", "objective", T,
                 objective=np.array(["funnel"])),
        _invalid("values-string", "values holds strings", "values", T, values=np.array([["a", "b"], ["c", "d"]])),
        _invalid("values-complex", "values holds complex numbers", "values", T, values=np.zeros((5, 7), complex)),
        _invalid("mass-bool", "mass holds a bool", "mass", T, mass=np.bool_(True)),
        _invalid("periodic-float", "periodic holds floats", "periodic", T, periodic=np.array([0.0, 1.0])),
        _invalid("dt-string", "dt holds a string", "dt", T, dt="0.05"),
        _invalid("n-steps-float-fraction", "n_steps = 10.5: an integer dtype is required, and a float that is "
                 "not whole must not be truncated either", "n_steps", T, n_steps=np.float64(10.5)),
        # the stability rule (docs/spec.md section 10): finite numbers, but past the limit of the stiffest term
        *_unstable_vectors(),
        # a run within the stability rule whose numbers leave the finite range (section 12.1): refused, no file
        _invalid("overflow-dynamic", "dynamic, stable by section 10, but a force of 1e308 overflows the run: "
                 "refused naming dt, and no result file, not even an empty one", "dt", V, flags=["nonfinite"],
                 force=np.full((6, 2, 2), 1e308)),
        _invalid("overflow-quasistatic", "quasistatic, stable by section 10, but a force of 1e200 against a spring "
                 "overflows the energy: refused naming mobility", "mobility", V, base=q, flags=["nonfinite"],
                 spring_k=np.float64(1.0), spring_center=np.zeros(2), force=np.full((6, 2, 2), 1e200)),
        # the container (section 8.1): files that are no .npz of case keys
        *_container_vectors(),
    ]


def _zip(members: dict) -> bytes:
    """A zip of stored members with the fixed date, byte for byte reproducible."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_STORED) as z:
        for name, data in members.items():
            z.writestr(zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0)), data)
    return buffer.getvalue()


def _npy(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.lib.format.write_array(buffer, array, allow_pickle=array.dtype.hasobject)
    return buffer.getvalue()


def _container_vectors() -> list:
    """Invalid vectors whose file breaks docs/spec.md 8.1 (flag ``file``): the bytes of
    the base dynamic case's members, one made unreadable, or no case archive at all."""
    base = _base_dynamic()
    members = {f"{k}.npy": _npy(np.asarray(v)) for k, v in base.items()}
    whole = _zip(members)

    def vector(vid, comment, key, error, data):
        return Vector(vid, comment, {}, "invalid", ["file"], key, error, file=data)
    grid = np.asarray(base["values"])
    return [
        vector("object-array", "values is an object array (a member that needs pickle to be read)", "values",
               "TypeError", _zip(dict(members, **{"values.npy": _npy(grid.astype(object))}))),
        vector("member-not-array", "the member values.npy holds text, not a .npy array", "values", "TypeError",
               _zip(dict(members, **{"values.npy": b"this is not an array\n"}))),
        vector("not-npz", "a text file, not an .npz archive (refused without a key)", None, "ValueError",
               b"values = [[0, 1], [1, 0]]\n"),
        vector("single-npy", "a single .npy array, not an .npz archive of named arrays", None, "ValueError",
               _npy(grid)),
        vector("truncated-zip", "the first half of a valid case's .npz: a damaged zip", None, "ValueError",
               whole[: len(whole) // 2]),
    ]


def _unstable_vectors() -> list:
    """Invalid vectors past the stability rule by 1.5x, one per term (dynamic, key ``dt``)
    and one quasistatic (key ``mobility``); the base cases stay far inside it otherwise."""
    dt = float(_base_dynamic()["dt"])
    k = (3.0 / dt) ** 2                                     # dt sqrt(k / m) = 3 with m = 1
    qs = _base_quasistatic()
    return [
        _invalid("unstable-spring", "dynamic, dt sqrt(k/m) = 3 for the spring: 1.5x its stability limit", "dt",
                 "ValueError", spring_k=np.array([1.0, k]), spring_center=np.zeros(2)),
        _invalid("unstable-wall", "dynamic, dt sqrt(k_w/m) = 3 for the walls of q0: 1.5x their stability limit",
                 "dt", "ValueError", wall_k=np.float64(k), wall_margin=np.float64(0.1),
                 walls=np.array([[True, True], [False, False]])),
        _invalid("unstable-grid", "dynamic, dt sqrt(c/m) = 3 for the grid's cross curvature c: 1.5x its "
                 "stability limit", "dt", "ValueError",
                 dt=np.float64(3.0 / np.sqrt(_cross_curvature(_base_dynamic())))),
        _invalid("unstable-quasistatic", "quasistatic, mobility_1 c = 3 for the grid's cross curvature c: 1.5x "
                 "its stability limit", "mobility", "ValueError", base=_base_quasistatic,
                 mobility=np.array([float(qs["mobility"][0]), 3.0 / _cross_curvature(qs)])),
    ]


def build_vectors() -> list:
    """Every vector of this version: valid ones first, then invalid ones."""
    v5 = _limit_pairs()
    vectors = (valid_vectors() + [v for v in v5 if v.kind == "valid"] + _edge_valid_vectors()
               + invalid_vectors() + [v for v in v5 if v.kind == "invalid"] + _optional_invalid_vectors())
    ids = [v.id for v in vectors]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise RuntimeError(f"duplicate vector ids {dup}")
    return vectors




# =========================================================================== v5: each rule from both sides

#: How far inside and past a limit the ``limit-*`` pairs sit: ``dt sqrt(K/m)`` or
#: ``mobility_d K`` at 1.98 and 2.02, 1% either side of 2.
_INSIDE, _PAST = 1.98, 2.02


def _quiet(r, topology="plane", **kw) -> dict:
    """A case whose grid is gentle (values 0.05 times the usual: cross curvature about 5),
    so that the term a ``limit-*`` vector puts at the limit is the stiffest by far."""
    case = _case(r, topology, **kw)
    case["values"] = case["values"] * 0.05
    return case


def _limit(vid, comment, build, *, reach=_INSIDE, key="dt"):
    """A ``limit-*`` vector: valid at ``reach`` 1.98 (it must run), invalid at 2.02 (refused
    naming ``key``). ``build(r, reach)`` makes the case."""
    if reach < 2.0:
        return _valid(vid, comment, lambda r: build(r, reach), flags=["limit"])
    return Vector(vid, comment, build(_rng(vid), reach), "invalid", ["limit"], key, "ValueError")


def _spring_particle(r, reach):
    """Particle 0 heavy (m = 4) with the stiff spring K on q0, particle 1 light (m = 1) with
    a soft one: the rule pairs the largest K with the smallest m, dt sqrt(K / 1) = reach."""
    dt = 0.05
    case = _quiet(r, n=2, n_steps=20, dt=dt, objective="quadratic", mass=np.array([[4.0, 4.0], [1.0, 1.0]]))
    case.update(spring_k=np.array([[(reach / dt) ** 2, 0.0], [1.0, 0.0]]), spring_center=np.array([0.5, 0.75]))
    return case


def _spring_axis(axis):
    """Mass per axis (1, 4); a spring on ``axis`` alone with dt sqrt(K / m_axis) = reach."""
    def build(r, reach):
        dt, m = 0.05, np.array([1.0, 4.0])
        k = np.zeros(2)
        k[axis] = (reach / dt) ** 2 * m[axis]
        case = _quiet(r, n=2, n_steps=20, dt=dt, objective="quadratic", mass=m)
        case.update(spring_k=k, spring_center=np.array([0.5, 0.75]))
        return case
    return build


def _wall_axis(axis, edge):
    """Mass per axis (1, 4); one wall, of ``axis`` at ``edge``, with dt sqrt(k_w / m_axis) = reach."""
    def build(r, reach):
        dt, m = 0.05, np.array([1.0, 4.0])
        walls = np.zeros((2, 2), dtype=bool)
        walls[axis, edge] = True
        case = _quiet(r, n=2, n_steps=20, dt=dt, objective="funnel-every", mass=m)
        case.update(wall_k=np.float64((reach / dt) ** 2 * m[axis]), wall_margin=np.float64(0.3), walls=walls)
        return case
    return build


def _terms_inside(r, reach):
    """A spring and a wall of q0 each at ``reach``: one at a time inside, summed past."""
    dt = 0.05
    K = (reach / dt) ** 2
    case = _quiet(r, n=2, n_steps=20, dt=dt, objective="quadratic")
    case.update(spring_k=np.array([K, 0.0]), spring_center=np.array([0.5, 0.75]), wall_k=np.float64(K),
                wall_margin=np.float64(0.2), walls=np.array([[True, True], [False, False]]))
    return case


def _seam_grid(r, topology, n_steps):
    """A grid ``s i j`` (plus a little noise) on ``topology``, periodic in q0: the cells of
    the interior have the cross term s, the cells across the seam of q0 (node 7 to node 0)
    7 s: the grid's curvature c is the seam's."""
    case = _case(r, topology, n=2, n_steps=n_steps, objective="funnel-every")
    n0, n1 = case["values"].shape
    case["values"] = 0.02 * np.outer(np.arange(n0), np.arange(n1)) + r.normal(0.0, 1e-3, (n0, n1))
    return case


def _seam_dynamic(r, reach):
    case = _seam_grid(r, "cylinder-q0", 12)
    case["dt"] = np.float64(reach / np.sqrt(_cross_curvature(case)))
    return case


def _seam_quasistatic(r, reach):
    case = _seam_grid(r, "torus", 12)
    case["mode"] = "quasistatic"
    case["mobility"] = np.array([reach / _cross_curvature(case), 0.001])
    return case


def _edges_not_a_term(r, reach):
    """A grid with steep second differences along q0 (``a i^2``) and a cross term: the rule
    takes the cross curvature alone (dt sqrt(c) = reach); the summed bound of 10.2, which adds
    the second differences, is 4 times past it."""
    case = _case(r, "plane", n=2, n_steps=4, objective="quadratic", speed=0.1)
    n0, n1 = case["values"].shape
    i, j = np.meshgrid(np.arange(n0), np.arange(n1), indexing="ij")
    case["values"] = 0.4 * i * i + 0.02 * i * j + r.normal(0.0, 1e-4, (n0, n1))
    case["dt"] = np.float64(reach / np.sqrt(_cross_curvature(case)))
    return case


def _mobility_axis(axis):
    """Quasistatic, mobility (0.02, 0.002); a spring on ``axis`` alone with mobility_axis K =
    reach: the other axis's mobility is 10x (axis 1) or 0.1x (axis 0) its own."""
    def build(r, reach):
        mu = np.array([0.02, 0.002])
        k = np.zeros(2)
        k[axis] = reach / mu[axis]
        case = _quiet(r, "plane", n=2, n_steps=20, mode="quasistatic", objective="funnel-every")
        case.update(mobility=mu, spring_k=k, spring_center=np.array([0.5, 0.75]))
        return case
    return build


def _exact(mode):
    """The rule's value exactly 2 with numbers every reading computes exactly: dt = 0.5 and
    k = 16 (m = 1), or mobility 0.125 and k = 16."""
    def build(r):
        kw = dict(mode="quasistatic") if mode == "quasistatic" else dict(dt=0.5)
        case = _quiet(r, "plane", n=2, n_steps=10, objective="quadratic", **kw)
        case["values"] = case["values"] * 0.2
        case.update(spring_k=np.array([16.0, 0.0]), spring_center=np.array([0.5, 0.75]))
        if mode == "quasistatic":
            case["mobility"] = np.array([0.125, 0.01])
        return case
    return build


def _limit_pairs() -> list:
    """docs/spec.md section 10 from both sides: pairs at 1.98 (valid, must run) and 2.02
    (refused), each built so that a misreading of the rule lands on the wrong side of one."""
    pairs = [
        ("spring-particle", _spring_particle, "the stiff spring on heavy particle 0 (m 4), the light particle 1 "
         "(m 1) with a soft one: K is paired with min_i m (dt sqrt(K/1)), not with its own particle's mass"),
        ("spring-axis-q1", _spring_axis(1), "mass per axis (1, 4), the spring on q1: dt sqrt(K/m_1); the mass of "
         "q0 (or the smallest of both) would put it 2x past"),
        ("spring-axis-q0", _spring_axis(0), "mass per axis (1, 4), the spring on q0: dt sqrt(K/m_0); the mass of "
         "q1 (or the largest) would put it 2x inside"),
        ("wall-one-lower-q0", _wall_axis(0, 0), "a single lower wall of q0, mass (1, 4): the wall is a term of "
         "an axis with at least one wall, with that axis's mass"),
        ("wall-one-upper-q1", _wall_axis(1, 1), "a single upper wall of q1, mass (1, 4): a term of q1 only "
         "(with m_1 = 4), not of every axis"),
        ("grid-seam-dynamic", _seam_dynamic, "a cylinder periodic in q0 whose cross curvature is 7x larger in "
         "the cells across the seam than inside: the curvature closes the grid by wrap-around"),
        ("grid-seam-quasistatic", _seam_quasistatic, "the same on a torus, quasistatic, mobility_0 c: the seam "
         "cells count"),
    ]
    out = []
    for name, build, what in pairs:
        key = "mobility" if "quasistatic" in name else "dt"
        out.append(_limit(f"limit-{name}-inside", f"{what}; the rule's value 1.98: valid", build))
        out.append(_limit(f"limit-{name}-past", f"{what}; the rule's value 2.02: refused naming {key}", build,
                          reach=_PAST, key=key))
    for axis, other in ((1, "0.1x"), (0, "10x")):
        build = _mobility_axis(axis)
        what = (f"quasistatic, the spring on q{axis} alone, the mobility of the other axis {other} its own: "
                f"mobility_{axis} K, not another axis's mobility")
        out.append(_limit(f"limit-mobility-axis-q{axis}-inside", f"{what}; 1.98: valid", build))
        out.append(_limit(f"limit-mobility-axis-q{axis}-past", f"{what}; 2.02: refused naming mobility", build,
                          reach=_PAST, key="mobility"))
    out += [
        _limit("limit-terms-one-at-a-time", "a spring and a wall of q0, each at 1.98: the terms are taken one at "
               "a time, so valid (summed, 2.8)", _terms_inside),
        _limit("limit-edges-not-a-term", "steep second differences along q0 and the cross curvature at 1.98: the "
               "second differences are no term of the rule, so valid", _edges_not_a_term),
        _valid("limit-exact-dynamic", "dt sqrt(k/m) exactly 2 (dt 0.5, k 16, m 1): a value at 2 is accepted "
               "(the rule is strict, > 2)", _exact("dynamic"), flags=["limit"]),
        _valid("limit-exact-quasistatic", "mobility_0 k exactly 2 (0.125 x 16): accepted", _exact("quasistatic"),
               flags=["limit"]),
    ]
    return out


def _edge_valid_vectors() -> list:
    """Valid values at the edge of each key's range, and optional keys at theirs."""
    tiny = 5e-324                                            # the smallest subnormal

    def spring_zero_axis(r):
        case = _case(r, "plane", n=2, n_steps=15, objective="quadratic")
        case.update(spring_k=np.array([0.0, 2.0]), spring_center=np.array([0.5, 0.75]))
        return case

    def spring_zero_particle(r):
        case = _case(r, "cylinder-q1", n=2, n_steps=15, mode="quasistatic", objective="quadratic")
        case.update(spring_k=np.array([[0.0], [3.0]]), spring_center=np.array([0.0, 1.0]))
        return case

    def spring_all_zero(r):
        case = _case(r, "cylinder-q0", n=2, n_steps=15, objective="funnel-every")
        case.update(spring_k=np.float64(0.0), spring_center=np.array([1.0, 0.0]))
        return case

    def room_just_inside(r):
        case = _case(r, "plane", n=2, n_steps=15, objective="funnel-every")
        case.update(wall_k=np.float64(20.0), wall_margin=np.float64(np.nextafter(0.5, 0.0)),
                    walls=np.array([[True, True], [False, False]]))
        return case

    return [
        _valid("edge-spring-k-zero-axis", "spring_k = (0, 2): a stiffness of 0 on q0 is valid; its force is 0 but "
               "grad_spring_k on q0 is not (-delta w summed)", spring_zero_axis, flags=["edge"]),
        _valid("edge-spring-k-zero-particle", "spring_k (N, 1) = (0, 3), quasistatic on a cylinder: particle 0's "
               "spring of stiffness 0 still has a gradient", spring_zero_particle, flags=["edge"]),
        _valid("edge-spring-k-all-zero", "spring_k = 0 (a scalar): a spring of no stiffness is still a spring; "
               "grad_spring_k and grad_spring_center are owed", spring_all_zero, flags=["edge"]),
        _valid("edge-wall-margin-zero", "four walls with wall_margin = 0: on the domain's edges",
               lambda r: _case(r, "plane", n=2, n_steps=15, objective="quadratic", **dict(_walls((0, 0), (0, 1),
                               (1, 0), (1, 1)), wall_margin=np.float64(0.0))), flags=["edge"]),
        _valid("edge-room-just-inside", "both walls of q0 with 2 wall_margin one ulp below L = 1: the room rule "
               "2 w < L holds", room_just_inside, flags=["edge"]),
        _valid("edge-dt-subnormal", "dt = 5e-324, the smallest subnormal: > 0, valid (no state moves)",
               lambda r: _case(r, "plane", n=2, n_steps=5, dt=tiny, objective="oscillator"), flags=["edge"]),
        _valid("edge-mobility-subnormal", "quasistatic, mobility (5e-324, 0.02): > 0, valid",
               lambda r: _case(r, "plane", n=2, n_steps=5, mode="quasistatic", objective="quadratic",
                               mobility=np.array([tiny, 0.02])), flags=["edge"]),
        _valid("edge-wall-k-subnormal", "wall_k = 5e-324: > 0, valid",
               lambda r: _case(r, "plane", n=2, n_steps=5, objective="funnel-final",
                               **dict(_walls((0, 0), (1, 1)), wall_k=np.float64(tiny))), flags=["edge"]),
        _valid("edge-one-particle-no-step", "one particle and n_steps = 0: the smallest run",
               lambda r: _case(r, "torus", n=1, n_steps=0, objective="oscillator"), flags=["edge"]),
        _valid("edge-regularization-zero", "regularization given as 0 (its default)",
               lambda r: _case(r, "plane", n=2, n_steps=5, objective="funnel-final",
                               regularization=np.float64(0.0)), flags=["edge"]),
        _valid("edge-t0-large", "t0 = 1e6: any finite t0 is valid", lambda r: _case(
            r, "plane", n=2, n_steps=8, objective="oscillator", t0=np.float64(1e6)), flags=["edge"]),
    ]


def _optional_invalid_vectors() -> list:
    """Every optional key tried NaN, infinite, of a wrong shape and of a wrong type, and
    values just past a range's edge (by the smallest subnormal), each naming its key."""
    V, T = "ValueError", "TypeError"
    q = _base_quasistatic
    nan, inf, tiny = np.nan, np.inf, 5e-324
    spring = {"spring_k": np.float64(1.0), "spring_center": np.zeros(2)}
    walls = {"wall_k": np.float64(10.0), "wall_margin": np.float64(0.1), "walls": np.ones((2, 2), dtype=bool)}
    rows = [
        ("t0-nan", "t0 NaN", "t0", V, {}, dict(t0=np.float64(nan))),
        ("t0-inf", "t0 = -inf", "t0", V, {}, dict(t0=np.float64(-inf))),
        ("t0-shape", "t0 of shape (1,), not 0-d", "t0", V, {}, dict(t0=np.array([0.5]))),
        ("t0-string", "t0 holds a string", "t0", T, {}, dict(t0=np.asarray("0.5"))),
        ("t0-bool", "t0 holds a bool", "t0", T, {}, dict(t0=np.bool_(False))),
        ("regularization-nan", "regularization NaN", "regularization", V, {}, dict(regularization=np.float64(nan))),
        ("regularization-inf", "regularization = inf", "regularization", V, {},
         dict(regularization=np.float64(inf))),
        ("regularization-shape", "regularization of shape (2,)", "regularization", V, {},
         dict(regularization=np.array([0.1, 0.1]))),
        ("regularization-string", "regularization holds a string", "regularization", T, {},
         dict(regularization=np.asarray("0.1"))),
        ("regularization-negative-tiny", "regularization = -5e-324, just below 0", "regularization", V, {},
         dict(regularization=np.float64(-tiny))),
        ("force-inf", "+inf in one force entry", "force", V, {},
         dict(force=np.where(np.arange(24).reshape(6, 2, 2) == 7, inf, 0.0))),
        ("force-string", "force holds strings", "force", T, {}, dict(force=np.full((6, 2, 2), "0"))),
        ("force-bool", "force holds bools", "force", T, {}, dict(force=np.zeros((6, 2, 2), dtype=bool))),
        ("spring-k-nan", "spring_k NaN", "spring_k", V, spring, dict(spring_k=np.array([1.0, nan]))),
        ("spring-k-inf", "spring_k = inf", "spring_k", V, spring, dict(spring_k=np.float64(inf))),
        ("spring-k-shape", "spring_k (3,) does not broadcast to (N, 2)", "spring_k", V, spring,
         dict(spring_k=np.ones(3))),
        ("spring-k-string", "spring_k holds a string", "spring_k", T, spring, dict(spring_k=np.asarray("1"))),
        ("spring-k-negative-tiny", "spring_k = -5e-324 on one axis", "spring_k", V, spring,
         dict(spring_k=np.array([1.0, -tiny]))),
        ("spring-center-inf", "spring_center -inf", "spring_center", V, spring,
         dict(spring_center=np.array([0.0, -inf]))),
        ("spring-center-shape", "spring_center (3,) does not broadcast", "spring_center", V, spring,
         dict(spring_center=np.zeros(3))),
        ("wall-k-nan", "wall_k NaN", "wall_k", V, walls, dict(wall_k=np.float64(nan))),
        ("wall-k-inf", "wall_k = inf", "wall_k", V, walls, dict(wall_k=np.float64(inf))),
        ("wall-k-shape", "wall_k of shape (2,)", "wall_k", V, walls, dict(wall_k=np.array([10.0, 10.0]))),
        ("wall-k-string", "wall_k holds a string", "wall_k", T, walls, dict(wall_k=np.asarray("10"))),
        ("wall-margin-nan", "wall_margin NaN", "wall_margin", V, walls, dict(wall_margin=np.float64(nan))),
        ("wall-margin-inf", "wall_margin = inf", "wall_margin", V, walls, dict(wall_margin=np.float64(inf))),
        ("wall-margin-negative-tiny", "wall_margin = -5e-324", "wall_margin", V, walls,
         dict(wall_margin=np.float64(-tiny))),
        ("walls-float", "walls of floats 0.0/1.0", "walls", T, walls, dict(walls=np.ones((2, 2)))),
        ("walls-two", "walls holds a 2", "walls", V, walls, dict(walls=np.array([[1, 2], [0, 0]], dtype=np.int8))),
        ("damping-negative-tiny", "damping = -5e-324 on one axis", "damping", V, {},
         dict(damping=np.array([0.0, -tiny]))),
        ("upper-equal-lower", "upper = lower on axis 0", "upper", V, {}, dict(upper=np.array([0.0, 1.5]))),
    ]
    qrows = [
        ("mobility-nan", "mobility NaN", "mobility", V, {}, dict(mobility=np.array([nan, 0.02]))),
        ("mobility-inf", "mobility inf", "mobility", V, {}, dict(mobility=np.array([0.02, inf]))),
        ("mobility-string", "mobility holds strings", "mobility", T, {}, dict(mobility=np.array(["0.02", "0.02"]))),
        ("x0-beyond-lookup", "x0 2**53 cells from lower on the periodic axis q0 of a cylinder, where float64 holds "
         "no fraction of a cell (docs/spec.md 8.6)", "x0", V, {}, dict(x0=np.array([[2.0 ** 53 * 0.25, 0.0],
                                                                                  [0.5, 0.0]]))),
    ]
    out = [_invalid(f"optional-{vid}", comment, key, error, **{**group, **changes})
           for vid, comment, key, error, group, changes in rows]
    out += [_invalid(f"optional-{vid}", comment, key, error, base=q, **{**group, **changes})
            for vid, comment, key, error, group, changes in qrows]
    return out
