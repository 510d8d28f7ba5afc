"""Populations (``pes_ref.simulate_batch``): each member's trajectory is its own run's, bit for bit.

A population stacks its scenes' grids and gives each particle its grid's offset in the
stacked tables; springs, walls, mass, damping, mobility and the external force become
per-particle arrays. Particles never interact, so each member must get exactly what
``pes_ref.simulate`` gives it alone, whatever the other members are: checked on random
scenes of every topology and mode, on both backends, with members that differ in every
way a population allows. The refusals name the argument and the member.
"""
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import pes_ref as pr
from pes_ref.core import backends
from pes_ref.core.checks import InputError
from pes_ref.core.stability import UnstableStepError, stability_limit
from pes_ref.testing import strategies as pst

BACKENDS = [name for name in pr.BACKENDS if backends.installed(name)]
N_STRATUM = max(1, settings.default.max_examples // 25)


def assert_same_run(a: pr.Trajectory, b: pr.Trajectory, what: str) -> None:
    """Equal entry by entry (``-0.0 == 0.0``: a member without a term another member has gets
    it with a zero coefficient, which changes no value but may change the sign of a zero)."""
    for name, x, y in zip(("x", "v", "f"), a, b):
        assert x.shape == y.shape and np.array_equal(x, y), f"{what}: {name} differs from the member's own run"


def _variant(scene: pr.Scene, rng: np.random.Generator, n: int) -> pr.Scene:
    """Another scene of the same shape: new grid values, and a random choice of spring,
    walls, mass, damping, mobility and effects (each possibly absent)."""
    s = scene.surface
    values = rng.uniform(-0.5, 0.5, s.shape) * float(np.ptp(s.values) + 0.1)
    kw = {"spring": None, "walls": None, "mass": rng.uniform(0.5, 2.0, (n, 1)), "damping": None}
    if rng.random() < 0.5:
        kw["spring"] = pr.Spring(rng.uniform(0.0, 2.0, (n, 2)) * (rng.random(2) < 0.7),
                                 s.lower + rng.random(2) * s.length)
    if rng.random() < 0.5 and not all(s.periodic):
        edges = np.array([[not s.periodic[d]] * 2 for d in range(2)])
        kw["walls"] = pr.Walls(rng.uniform(5.0, 50.0), 0.05 * float(s.length.min()), edges)
    if scene.mode == "dynamic":
        kw["damping"] = None if rng.random() < 0.5 else rng.uniform(0.0, 1.0, 2)
    else:
        kw["mobility"] = scene.mobility * rng.uniform(0.5, 1.0, 2)
    kw["effects"] = [(), (pr.Constant(rng.uniform(-1, 1, 2)),), (pr.Noise(rng.uniform(0, 1, 2), int(rng.integers(99))),),
                     (pr.PerParticle(rng.uniform(-1, 1, (n, 2))),)][int(rng.integers(4))]
    return replace(scene.with_values(values), **kw)


STRATA = [(mode, topology) for mode in ("dynamic", "quasistatic") for topology in pst.TOPOLOGIES]


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("mode, topology", STRATA)
@settings(max_examples=N_STRATUM)
@given(data=st.data())
def test_each_member_is_its_own_run_bit_for_bit(backend, mode, topology, data):
    scene, x0, v0 = data.draw(pst.scene_cases(mode=mode, topology=topology))
    rng = np.random.default_rng(data.draw(pst.seeds()))
    members = [(scene, x0, v0)]
    for _ in range(int(rng.integers(1, 4))):
        n = int(rng.integers(1, 4))
        other = _variant(scene, rng, n)
        if rng.random() < 0.2:                         # sometimes the same scene twice
            other, n = scene, x0.shape[0]
        lo, span = other.surface.lower, other.surface.length
        members.append((other, lo + span * rng.uniform(0.1, 0.9, (n, 2)), rng.uniform(-0.3, 0.3, (n, 2))))
    members = [m for m in members if stability_limit(m[0], "rule").ratio <= 1.0] or members[:1]
    batch = pr.simulate_batch([m[0] for m in members], [m[1] for m in members], [m[2] for m in members],
                              backend=backend)
    for i, ((s, x, v), got) in enumerate(zip(members, batch)):
        assert_same_run(got, pr.simulate(s, x, v, backend=backend), f"member {i}")


@pytest.mark.parametrize("backend", BACKENDS)
def test_the_polish_generation_is_each_candidates_own_run(backend):
    """The oscillator's polish scenes (cylinder, spring k = (1, 0), walls, damping, a torque per
    particle): the same bits in every byte, zeros' signs included."""
    from pes_ref.synthesis.engine.polish import polish_particles
    from pes_ref.synthesis.kinds.oscillator import OscillatorProblem
    problem = OscillatorProblem(grid0=8, grid1=8)
    parts = polish_particles(problem, np.random.default_rng(0), n=6)
    rng = np.random.default_rng(1)
    scenes = [problem.torque_scene(0.05 * rng.standard_normal((8, 8)), parts.torques, 3.0) for _ in range(3)]
    batch = pr.simulate_batch(scenes, [parts.x0] * 3, backend=backend)
    for scene, got in zip(scenes, batch):
        alone = pr.simulate(scene, parts.x0, backend=backend)
        assert all(a.tobytes() == np.ascontiguousarray(b).tobytes() for a, b in zip(alone, got))


def test_the_bicubic_grid_and_the_gjf_step_batch_too():
    rng = np.random.default_rng(2)
    surf = pr.Surface(rng.uniform(-0.1, 0.1, (6, 7)), (0, 0), (1, 1), (True, False), "bicubic")
    scenes = [pr.Scene(pr.Surface(rng.uniform(-0.1, 0.1, (6, 7)), (0, 0), (1, 1), (True, False), "bicubic"), dt=0.01, n_steps=20,
                       damping=0.3, integrator="gjf") for k in range(3)]
    x0s = [rng.uniform(0.2, 0.8, (k + 1, 2)) for k in range(3)]
    for scene, x0, got in zip(scenes, x0s, pr.simulate_batch(scenes, x0s)):
        assert_same_run(got, pr.simulate(scene, x0), "bicubic gjf member")


def _plain(n_steps=10, **kw):
    surf = pr.Surface(np.zeros((5, 5)), (0, 0), (1, 1), (False, False))
    return pr.Scene(surf, dt=0.01, n_steps=n_steps, **kw)


@pytest.mark.parametrize("other, match", [
    (_plain(n_steps=11), r"scenes\[1\] has n_steps = 11, scenes\[0\] 10"),
    (_plain(mode="quasistatic", mobility=(1.0, 1.0)), r"scenes\[1\] has mode = 'quasistatic'"),
    (pr.Scene(pr.Surface(np.zeros((5, 6)), (0, 0), (1, 1), (False, False)), dt=0.01, n_steps=10),
     r"scenes\[1\] has shape = \(5, 6\)"),
    (pr.Scene(pr.Surface(np.zeros((5, 5)), (0, 0), (1, 2), (False, False)), dt=0.01, n_steps=10),
     r"scenes\[1\] has upper"),
    ("scene", r"scenes\[1\] must be a pes_ref.Scene, got str"),
])
def test_scenes_of_another_shape_are_refused(other, match):
    with pytest.raises(InputError, match=match) as err:
        pr.simulate_batch([_plain(), other], [[[0.5, 0.5]], [[0.5, 0.5]]])
    assert err.value.key == "scenes"


@pytest.mark.parametrize("x0s, v0s, key, match", [
    ([[[0.5, 0.5]]], None, "x0s", r"x0s must hold one state per scene \(2\), got 1"),
    ([[[0.5, 0.5]], [[0.5, 0.5]]], [None], "v0s", r"v0s must hold one state per scene \(2\), got 1"),
    ([[[0.5, 0.5]], [0.5, 0.5]], None, "x0s", r"x0s\[1\]: x0 must have shape"),
    ([[[0.5, 0.5]], [[0.5, 0.5]]], [None, [[1.0, "a"]]], "v0s", r"v0s\[1\]"),
])
def test_bad_states_name_the_member(x0s, v0s, key, match):
    with pytest.raises(InputError, match=match) as err:
        pr.simulate_batch([_plain(), _plain()], x0s, v0s)
    assert err.value.key == key


def test_an_empty_population_and_a_bad_backend_are_refused():
    with pytest.raises(InputError, match="at least one") as err:
        pr.simulate_batch([], [])
    assert err.value.key == "scenes"
    with pytest.raises(InputError, match="backend must be one of") as err:
        pr.simulate_batch([_plain()], [[[0.5, 0.5]]], backend="gpu")
    assert err.value.key == "backend"


def _walled(k):
    surf = pr.Surface(np.random.default_rng(3).uniform(-1, 1, (5, 5)), (0, 0), (1, 1), (False, False))
    return pr.Scene(surf, dt=0.05, n_steps=400, walls=pr.Walls(k, 0.1, np.ones((2, 2), bool)))


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_member_that_leaves_the_finite_numbers_is_named_or_returned(backend):
    """Past the stability limit (allowed on purpose) member 1 blows up; member 0 does not
    notice: its run is its own. Without ``return_errors`` the error names scenes[1]."""
    scenes, x0s = [_walled(10.0), _walled(1e8)], [[[0.05, 0.4]], [[0.05, 0.4]]]
    with pytest.raises(pr.NonFiniteError, match=r"scenes\[1\]: the trajectory became non-finite at step"):
        pr.simulate_batch(scenes, x0s, allow_unstable=True, backend=backend)
    good, bad = pr.simulate_batch(scenes, x0s, allow_unstable=True, backend=backend, return_errors=True)
    assert isinstance(bad, pr.NonFiniteError) and "scenes[1]" in str(bad)
    assert_same_run(good, pr.simulate(scenes[0], x0s[0], backend=backend), "the finite member")
    with pytest.raises(UnstableStepError, match=r"scenes\[1\]: dt = 0.05 is 250x the stability limit"):
        pr.simulate_batch(scenes, x0s, backend=backend)
