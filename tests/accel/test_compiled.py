"""The compiled loops (backend ``"numba"``, ``pes_ref/accel/compiled.py``) against the NumPy loops.

The compiled loops do the NumPy loops' floating-point operations in the same order, so:

- the forward trajectory ``x, v, f`` is bit-identical (every byte, zeros' signs included),
  on every shipped conformance vector of every version and on random scenes of every
  topology and mode (hypothesis);
- every gradient is bit-identical but the grid's and the mobility's, which are the same
  sums in another order: within 1e-13 of their largest entry.

(``tests/core/test_reference.py`` holds the default backend, the compiled one here, to the
readable reference entry by entry; ``tests/core/test_population.py`` runs populations on
both.) A scene the compiled loops do not cover runs on NumPy's; progress reports come at
the same steps; each kernel compiles once for every scene (its arguments' types never
change), and the oracle never imports numba unless asked (``tests/cli/test_oracle_startup.py``).
"""
import threading
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import pes_ref as pr
from pes_ref.core import backends, steppers
from pes_ref.core.checks import InputError
from pes_ref.oracle import case as oracle
from pes_ref.oracle.conformance import vectors_dir
from pes_ref.oracle.from_scene import case_from_scene
from pes_ref.testing import conformance as conf
from pes_ref.testing import strategies as pst

numba = pytest.importorskip("numba", reason="the compiled loops need the extra 'fast' (make test installs it)")
from pes_ref.accel import compiled  # noqa: E402

#: Gradients the compiled loops sum in another order, and their tolerance relative to the
#: largest entry.
SUMMED, SUMMED_RTOL = ("values", "mobility"), 1e-13
N_STRATUM = max(1, settings.default.max_examples // 25)

VERSIONS = sorted(p.name for p in vectors_dir("v1").parent.glob("v[0-9]*") if (p / "manifest.json").exists())
VALID = [(version, entry["id"]) for version in VERSIONS for entry in conf.load_manifest(version)["vectors"]
         if entry["kind"] == "valid"]


def relative_to_largest(a, b) -> float:
    diff = float(np.max(np.abs(np.subtract(a, b)), initial=0.0))
    return 0.0 if diff == 0.0 else diff / float(np.max(np.abs(b), initial=0.0))


def assert_gradients_agree(got: dict, want: dict) -> None:
    assert got.keys() == want.keys()
    for name in want:
        summed = any(name in (s, f"grad_{s}") for s in SUMMED)
        if summed:
            err = relative_to_largest(got[name], want[name])
            assert err <= SUMMED_RTOL, f"{name}: {err:.3g} of its largest entry"
        else:
            assert np.array_equal(got[name], want[name]), f"{name}: differs (must be bit-identical)"


@pytest.mark.parametrize("version, vid", VALID, ids=[f"{v}-{i}" for v, i in VALID])
def test_every_conformance_vector_runs_bit_identically(version, vid):
    """(Past the stability rule too: v1 has vectors that the rule added later refuses.)"""
    case = oracle.load_case(vectors_dir(version) / f"{vid}.case.npz")
    fast, ref = (oracle.run_case(case, allow_unstable=True, backend=b) for b in ("numba", "numpy"))
    for key in ("x", "v", "energy", "loss"):
        assert fast[key].tobytes() == ref[key].tobytes(), f"{key} differs"
    assert_gradients_agree({k: v for k, v in fast.items() if k.startswith("grad_")},
                           {k: v for k, v in ref.items() if k.startswith("grad_")})


STRATA = [(mode, topology) for mode in ("dynamic", "quasistatic") for topology in pst.TOPOLOGIES]


@pytest.mark.parametrize("mode, topology", STRATA)
@settings(max_examples=N_STRATUM)
@given(data=st.data())
def test_random_scenes_run_bit_identically(mode, topology, data):
    """Random scenes (every effect, springs with a zero axis among them) and objectives."""
    scene, x0, v0 = data.draw(pst.scene_cases(mode=mode, topology=topology))
    objective, R = data.draw(pst.objectives(scene, x0.shape[0]))
    runs = {}
    for b in ("numba", "numpy"):
        traj = pr.simulate(scene, x0, v0, backend=b)
        loss, grads, _ = pr.value_and_grad(scene, x0, v0, objective, regularization_weight=R, backend=b)
        runs[b] = (traj, loss, grads)
    (fast, loss_f, grads_f), (ref, loss_r, grads_r) = runs["numba"], runs["numpy"]
    for name, a, b in zip("xvf", fast, ref):
        assert a.tobytes() == b.tobytes(), f"{name} differs"
    assert pr.energy(scene, fast, backend="numba").tobytes() == pr.energy(scene, ref).tobytes(), "energy differs"
    assert loss_f == loss_r
    assert_gradients_agree(grads_f, grads_r)


@pytest.mark.parametrize("topology", pst.TOPOLOGIES)
@settings(max_examples=N_STRATUM)
@given(data=st.data())
def test_the_energy_the_forward_loop_computes_is_the_energy_pass(topology, data):
    """value_and_grad's ``energy_out``: the dynamic loops fill it as they step, each state's at
    its own lookup (springs on periodic axes among the scenes: the compiled loop with the
    minimum image), the same bytes as the energy pass over the trajectory on either backend."""
    scene, x0, v0 = data.draw(pst.scene_cases(mode="dynamic", topology=topology))
    objective, R = data.draw(pst.objectives(scene, x0.shape[0]))
    from unittest import mock
    from pes_ref.core import scene as scene_module
    for b, chunk in (("numba", None), ("numpy", None), ("numpy", 1)):      # chunk 1: NumPy's loop at any N
        e = np.full((scene.n_steps + 1, x0.shape[0]), np.nan)
        with mock.patch.object(scene_module, "ENERGY_CHUNK", chunk or scene_module.ENERGY_CHUNK):
            _, _, traj = pr.value_and_grad(scene, x0, v0, objective, regularization_weight=R, backend=b,
                                           energy_out=e)
        assert e.tobytes() == pr.energy(scene, traj).tobytes(), (b, chunk)


def _scene(**kw):
    rng = np.random.default_rng(4)
    surf = pr.Surface(rng.uniform(-0.2, 0.2, (7, 6)), (0, 0), (1, 2), kw.pop("periodic", (False, True)),
                      kw.pop("interpolation", "bilinear"))
    return pr.Scene(surf, dt=kw.pop("dt", 0.01), n_steps=kw.pop("n_steps", 40), **kw)


X0 = np.array([[0.3, 0.4], [0.6, 1.5], [0.5, 0.1]])


@pytest.mark.parametrize("kw, mode, integrator", [
    (dict(interpolation="bicubic", damping=0.2), "dynamic", "verlet"),
    (dict(integrator="gjf", damping=0.2), "dynamic", "gjf"),
    (dict(interpolation="bicubic", mode="quasistatic", mobility=(0.01, 0.01)), "quasistatic", "verlet"),
])
def test_a_scene_the_compiled_loops_do_not_cover_runs_on_numpy(kw, mode, integrator):
    scene = _scene(**kw)
    assert backends.stepper("numba", mode, integrator, scene.surface.interpolation) is steppers.stepper(mode,
                                                                                                       integrator)
    assert not backends.covers("numba", mode, integrator, scene.surface.interpolation)
    loss = pr.Quadratic(wx=1.0)
    a = pr.value_and_grad(scene, X0, None, loss, backend="numba")
    b = pr.value_and_grad(scene, X0, None, loss, backend="numpy")
    assert a[0] == b[0] and all(np.array_equal(a[1][k], b[1][k]) for k in b[1])


@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
def test_progress_comes_at_the_same_steps(mode):
    kw = dict(mode="quasistatic", mobility=(0.01, 0.01)) if mode == "quasistatic" else dict(damping=0.3)
    scene = _scene(n_steps=600, spring=pr.Spring((1.0, 0.0), (0.5, 1.0)), **kw)
    calls = {}
    for b in ("numba", "numpy"):
        seen = calls[b] = []
        pr.value_and_grad(scene, X0, None, pr.Funnel(0.5), progress=lambda *a, _s=seen: _s.append(a), backend=b)
    assert calls["numba"] == calls["numpy"]
    assert calls["numba"][:4] == [("forward", 0, 600), ("forward", 256, 600), ("forward", 512, 600),
                                  ("forward", 600, 600)]


def test_a_run_past_the_stability_limit_fails_alike():
    scene = _scene(dt=2.0, n_steps=200, walls=pr.Walls(1e4, 0.05, [[True, True], [False, False]]))
    errors = []
    for b in ("numba", "numpy"):
        with pytest.raises(pr.NonFiniteError) as err:
            pr.simulate(scene, X0, allow_unstable=True, backend=b)
        errors.append(str(err.value))
    assert errors[0] == errors[1] and "became non-finite at step" in errors[0]


def test_each_kernel_compiles_once_for_every_scene():
    """Scenes with and without every term, both modes, a population: the kernels' argument
    types never change, so each compiled function has one signature (a second would be
    a compilation, seconds, inside someone's run)."""
    spring, walls = pr.Spring([[1.0, 0.0]], (0.5, 1.0)), pr.Walls(20.0, 0.05, [[True, True], [False, False]])
    scenes = [_scene(), _scene(periodic=(True, True), damping=0.1), _scene(spring=spring, walls=walls),
              _scene(effects=(pr.Constant((0.1, 0.0)),), mass=[[1.0], [2.0], [1.5]], damping=[0.1, 0.0]),
              _scene(mode="quasistatic", mobility=(0.01, 0.02), spring=spring, walls=walls,
                     effects=(pr.Noise((0.1, 0.1), 1),))]
    for scene in scenes:
        pr.value_and_grad(scene, X0, None, pr.Quadratic(wx=1.0, wv=0.5), backend="numba")
    pr.simulate_batch([scenes[0], scenes[2], scenes[3]], [X0] * 3, backend="numba")
    kernels = [f for ns in compiled.KERNELS.values() for f in vars(ns).values()]
    ran = [f for f in kernels if f.signatures]
    assert {f.py_func.__name__ for f in ran} >= {"_dynamic_steps", "_dynamic_adjoint_steps", "_quasistatic_steps",
                                                  "_quasistatic_adjoint_steps"}
    assert all(len(f.signatures) == 1 for f in ran), {f.py_func.__name__: len(f.signatures) for f in ran}


def test_the_kernels_cache_their_machine_code_on_disk():
    kernels = [k for ns in compiled.KERNELS.values() for k in vars(ns).values()]
    for f in kernels + [compiled._energy]:
        assert f._cache.__class__.__name__ == "FunctionCache"


@pytest.fixture
def threaded(monkeypatch):
    """The threaded loops from 1 particle on, in blocks of 2 (4 lanes of them in the adjoint)."""
    monkeypatch.setattr(compiled, "PARALLEL_MIN", 1)
    monkeypatch.setattr(compiled, "BLOCK", 2)


def _oracle_scene(periodic, n: int):
    rng = np.random.default_rng(7)
    walls = [[not periodic[0]] * 2, [not periodic[1], False]]
    surf = pr.Surface(rng.uniform(-0.2, 0.2, (7, 6)), (0, 0), (1, 2), periodic)
    return pr.Scene(surf, dt=0.01, n_steps=30, mass=rng.uniform(0.5, 2.0, (n, 2)), damping=rng.uniform(0, 1, (n, 2)),
                    spring=pr.Spring(rng.uniform(0.0, 2.0, (n, 2)), rng.uniform(0, 1, (n, 2))),
                    walls=pr.Walls(20.0, 0.1, walls) if any(map(any, walls)) else None,
                    effects=(pr.Constant((0.1, -0.2)), pr.Noise((0.3, 0.3), 3))), rng.uniform(0, 1, (n, 2)) * (1, 2)


@pytest.mark.parametrize("periodic", [(False, False), (False, True), (True, True)])
def test_a_threaded_run_gives_each_particle_its_own_run(threaded, periodic):
    """Each particle's trajectory, energy and gradients (all but the grid's, a sum over the
    particles) are those of its run alone, bit for bit; the grid's agrees with NumPy's."""
    n = 9
    scene, x0 = _oracle_scene(periodic, n)
    v0 = np.full((n, 2), 0.1)
    case = case_from_scene(scene, x0, v0, pr.Funnel(target=0.5, when="every_step"))
    whole = oracle.run_case(case, backend="numba")
    assert_gradients_agree({"grad_values": whole["grad_values"]},
                           {"grad_values": oracle.run_case(case, backend="numpy")["grad_values"]})
    per_particle = [k for k in whole if k not in ("loss", "grad_values")]
    for i in (0, 4, 8):
        own = dict(case)
        for key in ("x0", "v0", "mass", "damping", "spring_k", "spring_center"):
            own[key] = np.asarray(case[key])[i:i + 1]
        own["force"] = np.asarray(case["force"])[:, i:i + 1]
        alone = oracle.run_case(own, backend="numba")
        for key in per_particle:
            part = whole[key][:, i:i + 1] if whole[key].ndim == 3 or key == "energy" else whole[key][i:i + 1]
            assert part.tobytes() == alone[key].tobytes(), (i, key)


def test_a_threaded_run_does_not_depend_on_the_thread_count(threaded):
    scene, x0 = _oracle_scene((False, True), 9)
    case = case_from_scene(scene, x0, np.zeros((9, 2)), pr.Funnel(target=0.5, when="every_step"))
    runs = []
    for threads in (1, numba.config.NUMBA_NUM_THREADS):
        previous = numba.get_num_threads()
        numba.set_num_threads(threads)
        try:
            runs.append(oracle.run_case(case, backend="numba"))
        finally:
            numba.set_num_threads(previous)
    assert all(runs[0][k].tobytes() == runs[1][k].tobytes() for k in runs[0])


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs numba's thread count 2")
def test_a_threaded_run_calls_the_one_compiled_loop_from_two_threads_on_shares_of_its_blocks(threaded,
                                                                                             monkeypatch):
    """With 2 threads, the forward loop, its adjoint and the energy are each called from two
    threads at once, each on a run of consecutive blocks (lanes), together every block once."""
    # The timeout only ends a run whose shares never meet (all on one thread: the fault this
    # test catches); it is far beyond the time a loaded machine takes to start the second share.
    calls, both = [], threading.Barrier(2, timeout=120)

    def watched(name, kernel, units):
        def call(*args):
            calls.append((name, threading.get_ident(), args[units].copy()))
            both.wait()                   # the other share is running meanwhile: two threads at once
            return kernel(*args)
        return call

    for ns in compiled.KERNELS.values():
        monkeypatch.setattr(ns, "dynamic_steps", watched("forward", ns.dynamic_steps, 7))
        monkeypatch.setattr(ns, "dynamic_adjoint_steps", watched("adjoint", ns.dynamic_adjoint_steps, 23))
    monkeypatch.setattr(compiled, "_energy", watched("energy", compiled._energy, 3))
    n = 9
    scene, x0 = _oracle_scene((False, True), n)
    previous = numba.get_num_threads()
    numba.set_num_threads(2)
    try:
        pr.value_and_grad(scene, x0, np.zeros((n, 2)), pr.Funnel(target=0.5), backend="numba")
        pr.energy(scene, pr.simulate(scene, x0, backend="numba"), backend="numba")
    finally:
        numba.set_num_threads(previous)
    blocks = compiled.particle_blocks(n)
    lanes, _ = compiled.lanes_of(n)
    for name, whole in (("forward", blocks), ("adjoint", lanes), ("energy", blocks)):
        mine = [(thread, units) for kind, thread, units in calls if kind == name]
        assert mine and len(mine) % 2 == 0, (name, len(mine))           # two shares a call
        for first, second in zip(mine[::2], mine[1::2]):
            assert first[0] != second[0], name
            a, b = sorted((first[1], second[1]), key=lambda units: units[0])
            assert a[-1] == b[0] and np.array_equal(np.concatenate((a, b[1:])), whole), (name, a, b)


def test_the_default_is_the_first_installed_backend(monkeypatch):
    assert backends.default_backend() == "numba"
    monkeypatch.setattr(backends, "installed", lambda name: name == "numpy")
    assert backends.default_backend() == "numpy"
    assert pr.simulate(_scene(), X0).x.shape == (41, 3, 2)


def test_a_backend_that_is_unknown_or_not_installed_is_refused(monkeypatch):
    with pytest.raises(InputError, match=r"backend must be one of \['numba', 'numpy'\] or None .*got 'cuda'") as err:
        pr.simulate(_scene(), X0, backend="cuda")
    assert err.value.key == "backend"
    monkeypatch.setattr(backends, "installed", lambda name: name == "numpy")
    with pytest.raises(InputError, match=r"backend='numba' needs numba, which is not installed: "
                                         r"pip install 'pes_ref\[fast\]'") as err:
        pr.value_and_grad(_scene(), X0, None, pr.Funnel(0.5), backend="numba")
    assert err.value.key == "backend"


def test_a_population_needs_no_numpy_step_and_runs_on_the_compiled_loops(monkeypatch):
    """With the compiled backend a population of covered scenes never reaches NumPy's loops."""
    def boom(*args, **kwargs):
        raise AssertionError("the NumPy loop ran")
    monkeypatch.setattr(steppers, "simulate_dynamic", boom)
    scenes = [_scene(damping=0.1), replace(_scene(), surface=_scene().surface.__class__(
        np.zeros((7, 6)), (0, 0), (1, 2), (False, True)))]
    out = pr.simulate_batch(scenes, [X0, X0[:1]], backend="numba")
    assert [t.x.shape for t in out] == [(41, 3, 2), (41, 1, 2)]
    with pytest.raises(AssertionError, match="the NumPy loop ran"):
        pr.simulate_batch(scenes, [X0, X0[:1]], backend="numpy")


@pytest.mark.parametrize("shape", [(2, 2), (3, 5), (8, 7), (13, 30)])
def test_the_compiled_tables_are_numpys_bit_for_bit(shape):
    """The per-cell coefficient and cross tables and the table gradient's map to the grid, each
    the compiled twin of pes_ref.core.bilinear's, for one grid and for a stack of them."""
    from pes_ref.core import bilinear
    rng = np.random.default_rng(5)
    values, h = rng.standard_normal((3,) + shape), np.array([0.3, 0.7])
    assert np.array_equal(compiled.coefficient_table(values, h),
                          np.concatenate([bilinear.coefficient_table(v, h) for v in values]))
    assert np.array_equal(compiled.cross_table(values[0], h), bilinear.cross_table(values[0], h))
    gtab = rng.standard_normal((values[0].size, 4))
    assert np.array_equal(compiled.table_grad_to_values(gtab, h, shape),
                          bilinear.table_grad_to_values(gtab.copy(), h, shape))


@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
def test_a_run_of_no_steps_has_its_state_0_with_and_without_progress(mode):
    kw = dict(mode="quasistatic", mobility=(0.01, 0.01)) if mode == "quasistatic" else {}
    scene = _scene(n_steps=0, effects=(pr.Constant((0.3, 0.1)),), **kw)
    runs = {}
    for b in ("numba", "numpy"):
        seen = []
        runs[b] = (pr.value_and_grad(scene, X0, None, pr.Funnel(0.5), backend=b),
                   pr.value_and_grad(scene, X0, None, pr.Funnel(0.5), backend=b, progress=lambda *a: seen.append(a)),
                   seen)
    for (a, a_p, seen_a), (b, b_p, seen_b) in [(runs["numba"], runs["numpy"])]:
        for got in (a, a_p):
            assert got[2].f.tobytes() == b[2].f.tobytes() and got[0] == b[0]
            assert_gradients_agree(got[1], b[1])
        assert seen_a == seen_b


@pytest.mark.parametrize("periodic", pst.TOPOLOGIES)
@pytest.mark.parametrize("shape", [(2, 2), (3, 5), (8, 7), (13, 30)])
def test_the_compiled_cross_curvature_is_numpys_bit_for_bit(periodic, shape):
    """The stability rule's grid cross curvature on the compiled loops: the same number as
    NumPy's, on every topology, and inf alike where a corner difference leaves float64."""
    from pes_ref.core import stability
    rng = np.random.default_rng(6)
    grids = [rng.standard_normal(shape), rng.uniform(-1e3, 1e3, shape), np.zeros(shape), np.full(shape, 1.5)]
    huge = rng.standard_normal(shape)
    huge[0, 0], huge[-1, -1] = 1.7e308, -1.7e308          # a corner difference beyond float64
    for values in grids + [huge]:
        surf = pr.Surface(values, (0, -1), (1, 2.5), periodic)
        with np.errstate(over="ignore", invalid="ignore"):
            want = stability.grid_cross_curvature(surf)
            got = stability.grid_cross_curvature(surf, backend="numba")
        assert np.float64(got).tobytes() == np.float64(want).tobytes(), (got, want)


def test_the_stability_rule_on_the_compiled_loops_decides_alike():
    """check_stable's limit on either backend is the same (the oracle runs it on the case's)."""
    from pes_ref.core import stability
    for dt in (0.01, 0.5, 5.0):
        scene = _scene(dt=dt, walls=pr.Walls(30.0, 0.05, [[True, True], [False, False]]))
        results = []
        for b in ("numpy", "numba"):
            try:
                results.append(stability.check_stable(scene, b))
            except stability.UnstableStepError as err:
                results.append(str(err))
        assert repr(results[0]) == repr(results[1])


@pytest.mark.parametrize("backend", ["numba", "numpy"])
def test_the_energy_computed_in_blocks_of_steps_is_the_same(backend, monkeypatch):
    """With progress reports the loops run in blocks of steps; the energy the loop computes
    as it steps (NumPy's forced at any N) is the same bytes as without them."""
    from pes_ref.core import scene as scene_module
    monkeypatch.setattr(scene_module, "ENERGY_CHUNK", 1)
    scene, x0 = _oracle_scene((False, True), 5)
    scene = replace(scene, n_steps=600)
    case = case_from_scene(scene, x0, np.full((5, 2), 0.1), pr.Funnel(target=0.5, when="every_step"))
    seen = []
    quiet = oracle.run_case(case, backend=backend)
    reported = oracle.run_case(case, backend=backend, monitor=lambda estimate: lambda *a: seen.append(a))
    assert ("forward", 256, 600) in seen
    assert reported["energy"].tobytes() == quiet["energy"].tobytes()
    assert quiet["energy"].tobytes() == oracle.run_case(case, backend="numpy")["energy"].tobytes()


def test_the_lanes_table_gradients_map_to_the_grid_summed_in_lane_order_and_are_zeroed():
    """The adjoint's lanes are summed inside the map to the grid, ``(g0 + g1) + g2``, bit for
    bit the map of that sum; with ``clear`` the same pass leaves every lane all zeros."""
    rng = np.random.default_rng(8)
    shape, h = (9, 7), np.array([0.3, 0.7])
    for lanes in (1, 3):
        gtabs = rng.standard_normal((lanes, shape[0] * shape[1], 4))
        total = gtabs[0]
        for lane in gtabs[1:]:
            total = total + lane
        want = compiled.table_grad_to_values(total, h, shape, flat=False)
        got = np.empty(shape)
        compiled._table_grad_to_values(gtabs, -1.0 / h[0], -1.0 / h[1], shape[0], shape[1], got,
                                       np.empty((2, 3, shape[1])), True)
        assert got.tobytes() == want.tobytes()
        assert not gtabs.any()


def test_a_surfaces_table_serves_its_run_and_adjoint_and_goes_with_it():
    """The coefficient table is built once per read-only grid (a Surface's) and its adjoint
    reads it; a writable grid's is built each time; the kept one goes with its grid."""
    import gc
    import weakref
    scene = _scene()
    field = scene.field()
    table = compiled.grid_table(field)
    assert compiled.grid_table(scene.field()) is table
    assert np.array_equal(table, compiled.coefficient_table(field.values, field.h))
    writable = field._replace(values=np.array(field.values))
    assert compiled.grid_table(writable) is not compiled.grid_table(writable)
    kept = weakref.ref(table)
    del scene, field, table
    gc.collect()
    assert kept() is None


def test_the_spare_table_gradient_is_all_zeros_after_a_run():
    """An adjoint takes the spare table gradient zeroed and leaves it zeroed: two runs in a
    row give the same gradients bit for bit as each alone."""
    scene = _scene(damping=0.1)
    first = pr.value_and_grad(scene, X0, None, pr.Funnel(0.5, when="every_step"), backend="numba")[1]
    assert compiled._SPARE and all(not buf.any() for buf in compiled._SPARE)
    second = pr.value_and_grad(scene, X0, None, pr.Funnel(0.5, when="every_step"), backend="numba")[1]
    assert all(first[k].tobytes() == second[k].tobytes() for k in first)
    assert all(not buf.any() for buf in compiled._SPARE)


@pytest.mark.parametrize("periodic", [(False, False), (True, True)])
def test_the_adjoint_reads_the_forwards_lookups_only_where_the_positions_are_its_own(periodic):
    """A small dynamic run keeps each state's grid lookup for its adjoint; a state whose
    position was written since (here: some moved to other cells, then a state's axis-0
    positions set to -0.0) is looked up again, so the compiled adjoint of any trajectory is
    the NumPy adjoint's, bit for bit (the grid's within 1e-13)."""
    from pes_ref.core import integrator
    scene, x0 = _oracle_scene(periodic, 5)
    field, dt, mass, damping = scene.field(), scene.dt, scene.mass, scene.damping
    v0 = np.full((5, 2), 0.1)
    traj = compiled.simulate_dynamic(field, x0, v0, None, dt, scene.n_steps, mass, damping)
    assert compiled._LOOKUPS[0] is not None and compiled._LOOKUPS[0][0]() is traj.x
    want = frozenset(("values", "x0", "v0", "force", "mass", "damping", "spring_k", "spring_center"))
    gx = np.random.default_rng(9).standard_normal(traj.x.shape)
    for edit in (None, "moved", "zero"):
        if edit == "moved":
            traj.x[5:12, 1:3] += 0.37
        elif edit == "zero":
            traj.x[3, :, 0] = -0.0
        fast = compiled.adjoint_dynamic(field, traj, dt, mass, damping, gx, None, want)
        ref = integrator.adjoint_dynamic(field, traj, dt, mass, damping, gx, None, want)
        assert_gradients_agree({k: np.reshape(fast[k], np.shape(ref[k])) for k in ref}, ref)


def test_a_large_run_keeps_no_lookups(monkeypatch):
    monkeypatch.setattr(compiled, "LOOKUP_STATES", 10)
    scene, x0 = _oracle_scene((False, True), 5)
    field = scene.field()
    traj = compiled.simulate_dynamic(field, x0, np.zeros((5, 2)), None, scene.dt, scene.n_steps, scene.mass,
                                     scene.damping)
    assert compiled._LOOKUPS[0] is None or compiled._LOOKUPS[0][0]() is not traj.x
    assert compiled._kept_lookups(field, traj.x, compiled._grid(field, 5, compiled.grid_table(field)))[0] is False


@pytest.mark.parametrize("periodic", [(False, False), (False, True), (True, True)])
def test_the_dynamic_loops_coefficients_from_the_values_are_the_tables(periodic, monkeypatch):
    """On one grid the dynamic loops take a cell's coefficients from its values, no table:
    the same trajectory, energy and gradients, bit for bit, as the loops that read the table."""
    scene, x0 = _oracle_scene(periodic, 6)
    case = case_from_scene(scene, x0, np.full((6, 2), 0.1), pr.Funnel(target=0.5, when="every_step"))
    direct = oracle.run_case(case, backend="numba")
    monkeypatch.setattr(compiled, "_direct", lambda field: compiled._NO_DIRECT)
    table = oracle.run_case(case, backend="numba")
    assert direct.keys() == table.keys()
    assert all(direct[k].tobytes() == table[k].tobytes() for k in direct)


def test_a_backend_s_own_kernels_are_found_by_name_in_its_registry_entry():
    """The compiled energy and cross curvature come from the registry (no code asks for a backend
    by its name): NumPy has none of its own, and a grid rule the backend does not cover has none."""
    from pes_ref.accel import compiled
    from pes_ref.core import backends
    assert backends.kernel("numba", "energy") is compiled.energy
    assert backends.kernel("numba", "cross_curvature_max") is compiled.cross_curvature_max
    assert backends.kernel("numba", "energy", "bicubic") is None
    assert backends.kernel("numpy", "energy") is None and backends.kernel("numpy", "cross_curvature_max") is None
