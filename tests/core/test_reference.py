"""The fast path against the readable reference, entry by entry.

:mod:`pes_ref.core.reference` writes the method once in plain NumPy; the public API
(``pes_ref.simulate``, ``pes_ref.value_and_grad``, ``pes_ref.energy``) runs the fast
path: the default backend, the compiled loops when the extra ``fast`` is installed (as in
``make test``), else the NumPy loops (``tests/accel/test_compiled.py`` checks the two against
each other, so both are held to the reference). Both run the same random scenes
(:mod:`pes_ref.testing.strategies`) and every number is compared: the trajectory ``x, v,
f``, the energy, the loss and every gradient the scene has. How exactly they must agree,
and why:

- Bilinear grid, Verlet or GJF, both modes: ``x, v, f``, energy, loss and the gradients
  ``x0, v0, force, mass, damping, spring_k, spring_center, mobility`` are bit-identical
  (``np.array_equal``): the reference performs the fast path's floating-point
  operations in the same order (the reference's module docstring says where it chose
  that order), so any change to the fast path's arithmetic shows here.
- Bilinear grid, the gradient ``values``: within 1e-13 of the array's largest entry.
  It is the same sum in another order: the reference adds (A3) per step straight into
  the grid, the fast path per cell into its coefficient table, mapped to the grid once.
  Measured worst 6e-16 (rounding is relative to the largest terms of the sum, hence a
  floor at the array's largest entry rather than at each entry). On the compiled loops
  the quasistatic ``mobility`` gradient too: they sum its products particle by particle,
  the reference (and NumPy's loops) by ``einsum``.
- Bicubic grid (an option): every number agrees to the contract's tolerances for two
  implementations (SPEC preamble, :mod:`pes_ref.oracle.tolerances`): ``x, v``, energy
  and loss to ``TRAJ_RTOL`` with the floor ``TRAJ_ATOL``, ``f`` and the gradients to
  ``GRAD_RTOL`` of the array's largest entry. Here the difference is not the order of
  one sum: the reference computes the cell coefficients (C1) by matrix products, the fast
  path by stencils and einsum, and the slope and Hessian of those coefficients divide
  their rounding by h and h^2 (measured over 3000 random examples: 99.5% below 1e-13,
  worst 5e-13 for ``f``, 4e-11 for a mobility gradient that is 1e-5 of its terms).
  Those scenes keep to a quarter of the stability limit (the strategies size the step
  for the bilinear grid; past the limit both runs amplify their rounding geometrically)
  and away from cell edges (the bicubic Hessian jumps there, and positions equal to
  rounding may sit on either side).

The reference itself is checked against central finite differences entry by entry
(:func:`pes_ref.testing.gradient_check.check_gradient_fd`) on a small fixed case per mode and
per option, and :func:`test_entrywise_check_fails_on_a_perturbed_sub_step` shows that the
comparison catches a wrong sub-step. Example counts scale with the hypothesis profile
(``make test-thorough`` runs 10x more).
"""
from dataclasses import dataclass, replace

import numpy as np
import pytest
from hypothesis import assume, event, given, settings, strategies as st
from hypothesis.strategies import SearchStrategy

import pes_ref as pr
from pes_ref.core import backends, reference
from pes_ref.core.stability import stability_limit
from pes_ref.oracle.tolerances import FD_RTOL, GRAD_RTOL, TRAJ_ATOL, TRAJ_RTOL
from pes_ref.testing import strategies as pst
from pes_ref.core.scene import gradient_names
from pes_ref.testing import check_gradient_fd, kink_distance

#: Examples per (topology, mode) stratum, per forced effect (36 of them) and per bicubic
#: mode: 100, 180 and 50 in all with the default profile (200), 10x that when thorough.
N_STRATUM = max(1, settings.default.max_examples // 16)
N_FORCED = max(1, settings.default.max_examples // 40)
N_BICUBIC = max(1, settings.default.max_examples // 8)

#: The tolerance of the gradients summed in another order, relative to their largest entry
#: (see the module docstring).
VALUES_RTOL = 1e-13
TRAJECTORY = ("x", "v", "energy", "loss")
#: The gradients the default backend sums in another order than the reference.
SUMMED = ("values", "mobility") if backends.default_backend() == "numba" else ("values",)
#: Compared bit for bit on a bilinear grid: all but those.
EXACT = ("x", "v", "f", "energy", "loss") + tuple(f"grad_{n}" for n in pr.GRADIENT_NAMES if n not in SUMMED)
TOPOLOGY_NAMES = {(False, False): "plane", (True, False): "cylinder0", (False, True): "cylinder1",
                  (True, True): "torus"}


# --------------------------------------------------------------------------- running both

def both(scene, x0, v0, objective, R) -> dict:
    """Every number of one case from the fast path and from the reference:
    ``name -> (fast, reference)`` for ``x, v, f, energy, loss`` and ``grad_<name>``."""
    traj = pr.simulate(scene, x0, v0)
    loss, grads, _ = pr.value_and_grad(scene, x0, v0, objective, regularization_weight=R)
    rloss, rgrads, run = reference.value_and_grad(scene, x0, v0, objective, regularization_weight=R)
    assert set(grads) == set(rgrads) == set(gradient_names(scene.mode, scene.spring is not None)), (sorted(grads), sorted(rgrads))
    out = {"x": (traj.x, run.x), "v": (traj.v, run.v), "f": (traj.f, run.f),
           "energy": (pr.energy(scene, traj), reference.energy(scene, run)), "loss": (loss, rloss)}
    out.update({f"grad_{name}": (grads[name], rgrads[name]) for name in grads})
    for name, (fast, ref) in out.items():
        assert np.shape(fast) == np.shape(ref), f"{name}: shape {np.shape(fast)} vs the reference's {np.shape(ref)}"
    return out


def relative_to_largest(fast, ref) -> float:
    """``max |fast - ref| / max |ref|`` (0 where both are equal; inf if ref is all 0 and they differ)."""
    diff = float(np.max(np.abs(np.subtract(fast, ref)), initial=0.0))
    return 0.0 if diff == 0.0 else diff / float(np.max(np.abs(ref), initial=0.0))


def assert_bilinear_agreement(pairs: dict) -> None:
    """Bit-identical but for the grid gradient, which is within VALUES_RTOL of its largest entry."""
    for name in EXACT:
        if name in pairs:
            fast, ref = pairs[name]
            assert np.array_equal(fast, ref), (
                f"{name}: the fast path and the reference differ by up to {np.max(np.abs(np.subtract(fast, ref)))} "
                f"(relative to the largest entry {relative_to_largest(fast, ref):.3g}); they must be bit-identical")
    for name in SUMMED:
        if f"grad_{name}" in pairs:
            err = relative_to_largest(*pairs[f"grad_{name}"])
            assert err <= VALUES_RTOL, f"grad_{name}: {err:.3g} of its largest entry, above {VALUES_RTOL}"


def assert_within_contract(pairs: dict) -> None:
    """The contract's tolerances: ``|fast - ref| <= TRAJ_ATOL + TRAJ_RTOL |ref|`` for x, v,
    energy and loss; ``<= GRAD_RTOL (|ref| + max |ref|)`` for f and the gradients."""
    for name, (fast, ref) in pairs.items():
        diff, ref = np.abs(np.subtract(fast, ref)), np.abs(ref)
        if name in TRAJECTORY:
            bound = TRAJ_ATOL + TRAJ_RTOL * ref
        else:
            bound = GRAD_RTOL * (ref + np.max(ref, initial=0.0))
        assert np.all(diff <= bound), f"{name}: differs by up to {np.max(diff)} (largest entry {np.max(ref)})"


def draw_case(data, **scene_kw):
    """``(scene, x0, v0, objective, R)`` from the strategies; a ``scene_kw`` value that is
    a strategy is drawn first, and ``objective`` (a tuple of kinds) picks the objective."""
    kinds = scene_kw.pop("objective", ("funnel_final", "funnel_every_step", "oscillator", "quadratic"))
    kw = {k: data.draw(v) if isinstance(v, SearchStrategy) else v for k, v in scene_kw.items()}
    scene, x0, v0 = data.draw(pst.scene_cases(**kw))
    objective, R = data.draw(pst.objectives(scene, x0.shape[0], kinds=kinds))
    return scene, x0, v0, objective, R


# --------------------------------------------------------------------------- every topology and mode

STRATA = [(mode, topology) for mode in ("dynamic", "quasistatic") for topology in pst.TOPOLOGIES]


@pytest.mark.parametrize("mode, topology", STRATA, ids=[f"{m}-{TOPOLOGY_NAMES[t]}" for m, t in STRATA])
@settings(max_examples=N_STRATUM)
@given(data=st.data())
def test_bilinear_bit_identical_except_grid_gradient(mode, topology, data):
    """Random scenes with random effects and objectives: x, v, f, energy, loss and every
    gradient but ``values`` bit-identical; ``values`` within 1e-13 of its largest entry."""
    scene, x0, v0, objective, R = draw_case(data, mode=mode, topology=topology)
    event(f"objective {type(objective).__name__}")
    assert_bilinear_agreement(both(scene, x0, v0, objective, R))


# --------------------------------------------------------------------------- each effect, forced on

def _with(**fields):
    return lambda scene, n, rng: replace(scene, **fields)


def _window(effect):
    """``effect`` on for a window of the run's times (in steps: from [0, T] for 0.5 .. T + 1 steps)."""
    def modify(scene, n, rng):
        a = rng.uniform(0.0, scene.n_steps)
        b = a + rng.uniform(0.5, scene.n_steps + 1.0)
        t = lambda s: scene.t0 + s * scene.dt  # noqa: E731
        return replace(scene, effects=(pr.Window(effect(n, rng), t(a), t(b)),))
    return modify


def _constant(n, rng):
    return pr.Constant(rng.uniform(-1.0, 1.0, 2))


def _noise(n, rng):
    return pr.Noise(rng.uniform(0.0, 1.0, 2), int(rng.integers(2**31)))


def _effects(*makers):
    return lambda scene, n, rng: replace(scene, effects=tuple(make(n, rng) for make in makers))


def _shape(n, rng):
    return [(), (2,), (n, 1), (n, 2)][int(rng.integers(4))]


@dataclass(frozen=True)
class Forced:
    """An effect forced on: keywords for :func:`pes_ref.testing.strategies.scenes`, then an
    optional ``modify(scene, n_particles, rng) -> scene``, in the listed modes."""

    scene_kw: dict
    modify: object = None
    modes: tuple = ("dynamic", "quasistatic")


DYNAMIC = ("dynamic",)
NON_TORUS = st.sampled_from(pst.TOPOLOGIES[:3])
FORCED = {
    "spring": Forced(dict(spring=True)),
    "walls": Forced(dict(walls=True, topology=NON_TORUS)),
    "spring_and_walls": Forced(dict(spring=True, walls=True, topology=NON_TORUS)),
    "damping_none": Forced(dict(damped=False), _with(damping=None), DYNAMIC),
    "damping_zero": Forced(dict(damped=False),
                           lambda scene, n, rng: replace(scene, damping=np.zeros(_shape(n, rng))), DYNAMIC),
    "damping_positive": Forced(dict(damped=True), None, DYNAMIC),
    "damping_per_particle": Forced(dict(damped=True), lambda scene, n, rng: replace(
        scene, damping=rng.uniform(0.05, 1.0, (n, int(rng.integers(1, 3))))), DYNAMIC),
    "mass_per_particle": Forced(dict(per_particle_mass=True), None, DYNAMIC),
    "mass_per_axis": Forced(dict(per_particle_mass=False), lambda scene, n, rng: replace(
        scene, mass=np.broadcast_to(scene.mass, (2,)) * rng.uniform(1.0, 2.0, 2)), DYNAMIC),
    "no_external_force": Forced(dict(effects=False)),
    "constant_force": Forced({}, _effects(_constant)),
    "per_particle_force": Forced({}, _effects(lambda n, rng: pr.PerParticle(rng.uniform(-1.0, 1.0, (n, 2))))),
    "noise": Forced({}, _effects(_noise)),
    "noise_in_window": Forced({}, _window(_noise)),
    "constant_in_window": Forced({}, _window(_constant)),
    "every_effect": Forced(dict(spring=True, walls=True, damped=True, per_particle_mass=True, effects=True,
                                noise=True, topology=NON_TORUS), None, DYNAMIC),
    "every_effect_quasistatic": Forced(dict(spring=True, walls=True, effects=True, noise=True,
                                            topology=NON_TORUS), None, ("quasistatic",)),
    "gjf_undamped": Forced(dict(damped=False), _with(integrator="gjf"), DYNAMIC),
    "gjf_damped": Forced(dict(damped=True, spring=True), _with(integrator="gjf"), DYNAMIC),
    **{f"objective_{kind}": Forced(dict(objective=(kind,)))
       for kind in ("funnel_final", "funnel_every_step", "oscillator", "quadratic")},
}
FORCED_CASES = [(name, mode) for name, forced in FORCED.items() for mode in forced.modes]


@pytest.mark.parametrize("name, mode", FORCED_CASES, ids=[f"{n}-{m}" for n, m in FORCED_CASES])
@settings(max_examples=N_FORCED)
@given(data=st.data())
def test_each_effect_bit_identical_except_grid_gradient(name, mode, data):
    """One effect forced on (every topology drawn): bit-identical but for the grid
    gradient, within 1e-13 of its largest entry."""
    forced = FORCED[name]
    scene, x0, v0, objective, R = draw_case(data, mode=mode, **forced.scene_kw)
    if forced.modify is not None:
        scene = forced.modify(scene, x0.shape[0], np.random.default_rng(data.draw(pst.seeds())))
    event(f"topology {scene.surface.topology}")
    assert_bilinear_agreement(both(scene, x0, v0, objective, R))


# --------------------------------------------------------------------------- option: the bicubic grid

def bicubic(scene, fraction: float = 0.25):
    """The scene on the bicubic interpolation of its grid, its step (or mobility) cut to
    ``fraction`` of the stability limit (:func:`pes_ref.core.stability.stability_limit`;
    a quarter, since the C1 surface's Hessian diagonal (C4) can exceed the nodes' second
    differences that the limit counts)."""
    s = scene.surface
    scene = replace(scene, surface=pr.Surface(s.values, s.lower, s.upper, s.periodic, "bicubic"))
    ratio = stability_limit(scene).ratio
    if ratio > fraction:
        cut = fraction / ratio
        scene = replace(scene, **({"dt": scene.dt * cut} if scene.mode == "dynamic"
                                  else {"mobility": scene.mobility * cut}))
    return scene


@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
@settings(max_examples=N_BICUBIC)
@given(data=st.data())
def test_bicubic_within_contract_tolerances(mode, data):
    """The bicubic option (random effects, objectives, topologies; Verlet or GJF): every
    number to the contract's tolerances (the module docstring says why not bit for bit)."""
    scene, x0, v0, objective, R = draw_case(data, mode=mode, min_amplitude=0.1)
    scene = bicubic(scene)
    if mode == "dynamic" and data.draw(st.booleans()):
        scene = replace(scene, integrator="gjf")
    assume(kink_distance(scene, pr.simulate(scene, x0, v0).x) > 1e-9)
    assert_within_contract(both(scene, x0, v0, objective, R))


# --------------------------------------------------------------------------- the reference against differences

def fd_case(mode: str, integrator: str, interpolation: str):
    """A small fixed case with every effect the mode has, away from kinks:
    ``(scene, x0, v0, objective, R)``."""
    rng = np.random.default_rng(7)
    surf = pr.Surface(rng.uniform(-0.5, 0.5, (5, 4)), (0.0, 0.0), (2.0, 1.5), (True, False), interpolation)
    x0 = np.array([[0.63, 0.52], [1.27, 1.35]])          # particle 1 starts inside the upper wall
    common = dict(spring=pr.Spring(np.array([[0.8, 1.5], [1.2, 0.6]]), np.array([1.0, 0.75])),
                  walls=pr.Walls(4.0, 0.3, [[False, False], [True, True]]),
                  effects=(pr.Constant([0.2, -0.1]), pr.Window(pr.Noise([0.3, 0.2], 5), 0.1, 0.3)))
    if mode == "dynamic":
        scene = pr.Scene(surf, dt=0.05, n_steps=6, mass=[1.3, 0.8], damping=[[0.4], [0.2]],
                         integrator=integrator, **common)
        return scene, x0, np.array([[0.4, -0.3], [-0.2, 0.5]]), pr.Quadratic(wx=1.0, wv=0.5, xref=0.8), 0.05
    scene = pr.Scene(surf, dt=0.05, n_steps=6, mode="quasistatic", mobility=[0.05, 0.04], **common)
    return scene, x0, np.zeros((2, 2)), pr.Funnel(1.1, "every_step"), 0.05


FD_CASES = [("dynamic", "verlet", "bilinear"), ("quasistatic", "verlet", "bilinear"),
            ("dynamic", "gjf", "bicubic"), ("quasistatic", "verlet", "bicubic")]


@pytest.mark.parametrize("mode, integrator, interpolation", FD_CASES, ids=["-".join(c) for c in FD_CASES])
def test_reference_matches_finite_differences(mode, integrator, interpolation):
    """Every gradient of the reference, entry by entry, against central differences of its
    own forward run, to FD_RTOL beyond the differences' rounding noise."""
    scene, x0, v0, objective, R = fd_case(mode, integrator, interpolation)
    check = check_gradient_fd(reference.value_and_grad, scene, x0, v0, objective, regularization_weight=R,
                              kink_margin=1e-3, full=True, simulate_fn=reference.simulate)
    assert check.valid, f"the fixed case passes within {check.kink_distance:.3g} of a kink"
    assert set(check.errors) == set(gradient_names(scene.mode, scene.spring is not None))
    assert check.max_error < FD_RTOL, {k: v for k, v in check.errors.items() if v >= FD_RTOL}


# --------------------------------------------------------------------------- the comparison has teeth

def test_entrywise_check_fails_on_a_perturbed_sub_step(monkeypatch):
    """The kick (S4) without its damping factor d: the comparison must reject it."""
    scene, x0, v0, objective, R = fd_case("dynamic", "verlet", "bilinear")
    assert_bilinear_agreement(both(scene, x0, v0, objective, R))
    monkeypatch.setattr(reference, "kick", lambda p, v, f_next, a, c, d: p + a * f_next - c * v)
    with pytest.raises(AssertionError, match="bit-identical"):
        assert_bilinear_agreement(both(scene, x0, v0, objective, R))
