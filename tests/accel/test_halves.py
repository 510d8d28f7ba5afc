"""A NumPy run of many particles as two halves on two threads (:mod:`pes_ref.accel.halves`):
each particle's numbers are the one-thread run's, bit for bit; the grid's and the mobility's
gradients, sums over the particles, agree to 1e-13 of their largest entry and are the same on
every run; an error in a half is the one-thread run's error and stops the other half."""
from __future__ import annotations

import threading
from dataclasses import replace
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import pes_ref as pr
from pes_ref.accel import halves
from pes_ref.core import backends, steppers
from pes_ref.core.integrator import NonFiniteError
from pes_ref.testing import strategies as pst

SUMMED_RTOL = 1e-13
N_STRATUM = max(1, settings.default.max_examples // 25)


def _relative_to_largest(a, b) -> float:
    diff = float(np.max(np.abs(np.subtract(a, b)), initial=0.0))
    return 0.0 if diff == 0.0 else diff / float(np.max(np.abs(b), initial=0.0))


def _runs(scene, x0, v0, objective, R=0.0):
    """``(one thread, two halves)``: each ``(trajectory, energy, loss, grads)`` on NumPy."""
    out = []
    for least in (10 ** 9, 2):
        with mock.patch.object(halves, "MIN_PARTICLES", least):
            e = np.empty((scene.n_steps + 1, x0.shape[0]))
            loss, grads, traj = pr.value_and_grad(scene, x0, v0, objective, regularization_weight=R,
                                                  backend="numpy", energy_out=e)
            assert pr.simulate(scene, x0, v0, backend="numpy").x.tobytes() == traj.x.tobytes()
        out.append((traj, e, loss, grads))
    return out


def _assert_halves_agree(one, two):
    (traj1, e1, loss1, g1), (traj2, e2, loss2, g2) = one, two
    for name, a, b in zip("xvf", traj2, traj1):
        assert a.tobytes() == b.tobytes(), f"{name} differs"
    assert e2.tobytes() == e1.tobytes(), "energy differs"
    assert g2.keys() == g1.keys()
    for name in g1:
        if name in halves.SUMMED:
            err = _relative_to_largest(g2[name], g1[name])
            assert err <= SUMMED_RTOL, f"{name}: {err:.3g} of its largest entry"
        else:
            assert g2[name].tobytes() == g1[name].tobytes(), f"{name}: differs (must be bit-identical)"
    # the loss is a sum over the particles of the same per-particle numbers, in the same order
    assert loss2 == loss1


STRATA = [(mode, topology) for mode in ("dynamic", "quasistatic") for topology in pst.TOPOLOGIES]


@pytest.mark.parametrize("mode, topology", STRATA)
@settings(max_examples=N_STRATUM)
@given(data=st.data())
def test_random_scenes_run_as_halves_as_in_one_thread(mode, topology, data):
    """Random scenes (every effect, per-particle springs and masses among them) and objectives."""
    scene, x0, v0 = data.draw(pst.scene_cases(mode=mode, topology=topology, min_particles=2, max_particles=7))
    objective, R = data.draw(pst.objectives(scene, x0.shape[0]))
    one, two = _runs(scene, x0, v0, objective, R)
    _assert_halves_agree(one, two)


def _scene(n: int, integrator: str = "verlet", interpolation: str = "bilinear", mode: str = "dynamic"):
    rng = np.random.default_rng(11)
    surf = pr.Surface(rng.uniform(-0.2, 0.2, (7, 6)), (0, 0), (1, 2), (False, True), interpolation)
    kw = dict(mobility=(0.02, 0.03)) if mode == "quasistatic" else dict(
        mass=rng.uniform(0.5, 2.0, (n, 2)), damping=rng.uniform(0.1, 1.0, (n, 2)), integrator=integrator)
    scene = pr.Scene(surf, dt=0.01, n_steps=30, mode=mode,
                     spring=pr.Spring(rng.uniform(0.5, 2.0, (n, 2)), rng.uniform(0, 1, (n, 2))),
                     walls=pr.Walls(20.0, 0.1, [[True, True], [False, False]]),
                     effects=(pr.Constant((0.1, -0.2)), pr.Noise((0.3, 0.3), 3)), **kw)
    return scene, rng.uniform(0.1, 0.9, (n, 2)) * (1, 2), rng.uniform(-0.2, 0.2, (n, 2))


@pytest.mark.parametrize("integrator, interpolation, mode", [
    ("verlet", "bilinear", "dynamic"), ("verlet", "bicubic", "dynamic"), ("gjf", "bilinear", "dynamic"),
    ("verlet", "bilinear", "quasistatic"), ("verlet", "bicubic", "quasistatic")])
@pytest.mark.parametrize("n", [2, 9])
def test_every_numpy_stepper_runs_as_halves_as_in_one_thread(integrator, interpolation, mode, n):
    scene, x0, v0 = _scene(n, integrator, interpolation, mode)
    if mode == "quasistatic":
        v0 = np.zeros_like(v0)
    one, two = _runs(scene, x0, v0, pr.Funnel(target=0.5, when="every_step"))
    _assert_halves_agree(one, two)


def test_the_same_run_as_halves_is_the_same_every_time():
    """The halves are fixed by N, not by the threads: the sums come out bit for bit alike."""
    scene, x0, v0 = _scene(9)
    runs = [_runs(scene, x0, v0, pr.Funnel(target=0.5, when="every_step"))[1] for _ in range(3)]
    for other in runs[1:]:
        for name in runs[0][3]:
            assert other[3][name].tobytes() == runs[0][3][name].tobytes(), name


def test_the_halves_cover_every_particle_once():
    for n in (2, 3, 8192, 65537):
        a, b = halves.split(n)
        assert (a.start, a.stop, b.start, b.stop) == (0, n // 2, n // 2, n)


def test_numpy_runs_from_min_particles_on_are_halves():
    numpy = steppers.stepper("dynamic", "verlet")
    at = backends.stepper("numpy", "dynamic", "verlet", "bilinear", halves.MIN_PARTICLES)
    assert at is not numpy and at.gradients == numpy.gradients
    below = backends.stepper("numpy", "dynamic", "verlet", "bilinear", halves.MIN_PARTICLES - 1)
    assert below is numpy
    assert backends.stepper("numpy", "dynamic", "verlet", "bilinear") is numpy       # a population's
    assert backends.stepper("numba", "dynamic", "verlet", "bilinear", halves.MIN_PARTICLES) \
        is backends._steppers("numba")[("dynamic", "verlet")]                        # the compiled loops' own threads


def test_a_run_of_min_particles_runs_on_two_threads(monkeypatch):
    """At the real threshold (a short run): the second half runs on a worker thread."""
    seen = []
    numpy = steppers.stepper("dynamic", "verlet")

    def simulate(*args):
        seen.append(threading.current_thread() is threading.main_thread())
        return numpy.simulate(*args)
    monkeypatch.setitem(steppers.STEPPERS, ("dynamic", "verlet"), numpy._replace(simulate=simulate))
    n = halves.MIN_PARTICLES
    scene, x0, v0 = _scene(n)
    pr.simulate(replace(scene, n_steps=2), x0, v0, backend="numpy")
    assert sorted(seen) == [False, True]


def test_progress_reports_are_the_first_halfs():
    scene, x0, v0 = _scene(9)
    scene = replace(scene, n_steps=600)
    reports = []
    for least in (10 ** 9, 2):
        got = []
        with mock.patch.object(halves, "MIN_PARTICLES", least):
            pr.value_and_grad(scene, x0, v0, pr.Funnel(target=0.5), backend="numpy",
                              progress=lambda *a: got.append(a))
        reports.append(got)
    assert reports[1] == reports[0] and len(reports[0]) > 4


def test_a_run_that_left_the_finite_numbers_names_the_first_bad_step_of_either_half():
    """Particles of the second half leave the finite numbers first: the error is the one-thread
    run's, naming that half's step, not the later one of the first half."""
    scene, x0, v0 = _scene(4)
    scene = replace(scene, dt=0.5, n_steps=200, spring=pr.Spring(np.array([[1e3, 1e3]] * 2 + [[1e5, 1e5]] * 2),
                                                                  scene.spring.center))
    errors = []
    for least in (10 ** 9, 2):
        with mock.patch.object(halves, "MIN_PARTICLES", least):
            with pytest.raises(NonFiniteError) as err:
                pr.simulate(scene, x0, v0, backend="numpy", allow_unstable=True)
        errors.append(str(err.value))
    assert errors[1] == errors[0]


def _fails_once_started(started):
    def half(report):
        started.wait(10)
        raise KeyboardInterrupt
    return half


def _reports_until_stopped(started, reports):
    def half(report):
        for i in range(10_000):
            report("forward", i, 10_000)
            reports.append(i)
            started.set()
            threading.Event().wait(1e-4)
        return "finished"
    return half


@pytest.mark.parametrize("failing", [0, 1])
def test_an_error_in_one_half_stops_the_other_at_its_next_report(failing):
    """Ctrl-C in the calling thread's half, or an error in the worker's: the other half stops at
    its next progress report, and the error is raised once both have ended."""
    started, reports = threading.Event(), []
    pair = [_reports_until_stopped(started, reports)] * 2
    pair[failing] = _fails_once_started(started)
    with pytest.raises(KeyboardInterrupt):
        halves._both(*pair, None)
    assert 0 < len(reports) < 10_000
    assert not any(t.name == "pes_ref-half" for t in threading.enumerate())


def test_the_worker_runs_under_the_callers_errstate():
    with np.errstate(over="raise", invalid="ignore"):
        got = halves._both(lambda report: np.geterr(), lambda report: np.geterr(), None)
    assert got[1] == got[0] and got[1]["over"] == "raise"


def test_a_floating_point_error_of_the_second_half_is_raised():
    def second(report):
        with np.errstate(over="raise"):
            np.multiply(np.array(1e300), 1e300)

    with pytest.raises(FloatingPointError):
        halves._both(lambda report: None, second, None)


def test_the_halves_per_particle_gradients_are_joined_in_memory_of_their_own():
    """``force``'s gradient (as large as the trajectory) is joined along the particles into a
    map of its own (pes_ref.core.runtime.pages); the other per-particle ones along axis 0."""
    from pes_ref.core.runtime import pages
    rng = np.random.default_rng(0)
    first, second = rng.normal(size=(300, 1000, 2)), rng.normal(size=(300, 1024, 2))
    joined = halves._joined(first, second, "force")
    np.testing.assert_array_equal(joined, np.concatenate((first, second), axis=1))
    assert isinstance(joined.base, pages.Pages) and pages.owns(joined)
    small = halves._joined(first[0], second[0], "x0")
    np.testing.assert_array_equal(small, np.concatenate((first[0], second[0])))
