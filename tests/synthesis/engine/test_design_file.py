"""Design files: round trip, bit-exact resume, refusals."""
import os

import numpy as np
import pytest

import pes_ref as pr
from pes_ref import synthesis
from pes_ref.synthesis import Plan
from pes_ref.synthesis.engine import design_file
from pes_ref.synthesis.engine.design_file import DesignFileError, load_design, save_design

TINY = dict(grid=9, n_steps=50, dt=0.05)


def tiny(plan=None, kind="funnel", **kw):
    if kind == "oscillator":
        return synthesis.new_design("oscillator", seed=5, plan=plan or Plan(iterations=2, n_particles=3),
                             grid0=6, grid1=6, n_steps=30)
    return synthesis.new_design("funnel", seed=5, plan=plan or Plan(iterations=6, n_particles=6), **{**TINY, **kw})


def assert_same_state(a, b):
    assert type(a.problem) is type(b.problem) and a.problem == b.problem
    assert a.plan == b.plan and a.seed == b.seed and a.iteration == b.iteration
    np.testing.assert_array_equal(a.values, b.values)
    assert a.history == b.history
    sa, sb = a.optimizer.state_dict(), b.optimizer.state_dict()
    assert sa.keys() == sb.keys()
    for k in sa:
        np.testing.assert_array_equal(sa[k], sb[k])


@pytest.mark.parametrize("kind", ["funnel", "oscillator"])
def test_round_trip_is_exact(tmp_path, kind):
    st = synthesis.run_design(tiny(kind=kind))
    save_design(tmp_path / "d.npz", st)
    back = load_design(tmp_path / "d.npz")
    assert_same_state(st, back)
    assert back.status == "done"
    assert [p.name for p in tmp_path.iterdir()] == ["d.npz"]      # no temporary file left behind


@pytest.mark.parametrize("optimizer, stages", [
    ("rmsprop", ((0, 0),)),
    ("adam", ((0, 5), (3, 0))),          # the grid changes at the resume point: resample + reset
    ("rmsprop", ((0, 5), (2, 0))),       # ... or before it
])
def test_save_and_resume_continues_bit_exactly(tmp_path, optimizer, stages):
    plan = Plan(iterations=6, lr=0.01, lr_final=0.002, optimizer=optimizer, stages=stages, n_particles=6)
    straight = synthesis.run_design(tiny(plan))
    half = synthesis.run_design(tiny(plan), 3)
    save_design(tmp_path / "half.npz", half)
    resumed = synthesis.run_design(load_design(tmp_path / "half.npz"))
    assert_same_state(straight, resumed)


def test_existing_file_is_refused_unless_overwrite(tmp_path):
    path = tmp_path / "d.npz"
    path.write_bytes(b"precious")
    st = tiny()
    with pytest.raises(FileExistsError, match="d.npz' exists already"):
        save_design(path, st)
    assert path.read_bytes() == b"precious"
    save_design(path, st, overwrite=True)
    assert load_design(path).iteration == 0


def test_save_design_hands_the_existence_check_to_the_atomic_writer(tmp_path, monkeypatch):
    # save_design itself never asks whether the file exists (a check-then-write race): it hands
    # the arrays and overwrite to the one atomic writer, which refuses or replaces in one step
    calls = []
    monkeypatch.setattr(design_file, "write_npz", lambda *a, **kw: calls.append((a, kw)))

    def no_check(*_):
        raise AssertionError("save_design checked the file system itself")
    for name in ("exists", "lexists", "isfile"):
        monkeypatch.setattr(os.path, name, no_check)
    st = tiny()
    for overwrite in (False, True):
        save_design(tmp_path / "d.npz", st, overwrite=overwrite)
    assert [(a[0], kw) for a, kw in calls] == [(tmp_path / "d.npz", {"overwrite": False, "compress": False, "what": "design"}),
                                                (tmp_path / "d.npz", {"overwrite": True, "compress": False,
                                                                      "what": "design"})]
    assert calls[0][0][1].keys() == design_file.design_arrays(st).keys()


def test_a_file_appearing_during_the_save_is_not_replaced(tmp_path, monkeypatch):
    # another writer creates the file after save_design has started (while it builds the arrays)
    path = tmp_path / "d.npz"
    build = design_file.design_arrays

    def build_then_race(state):
        arrays = build(state)
        path.write_bytes(b"the other writer's")
        return arrays
    monkeypatch.setattr(design_file, "design_arrays", build_then_race)
    with pytest.raises(FileExistsError, match="d.npz' exists already"):
        save_design(path, tiny())
    assert path.read_bytes() == b"the other writer's"
    assert [p.name for p in tmp_path.iterdir()] == ["d.npz"]      # no temporary file left behind


@pytest.mark.parametrize("make, match", [
    (lambda p: p.write_text("hello"), "is not an .npz archive"),
    (lambda p: p.write_bytes(b""), "is not an .npz archive"),
    (lambda p: np.savez(p, x=np.zeros(3)), "not a design file"),
    (lambda p: np.savez(p, format=np.array("pes_ref.design"), version=np.array(1)), "missing keys"),
])
def test_files_that_are_not_designs_are_refused(tmp_path, make, match):
    path = tmp_path / "bad.npz"
    make(path)
    with pytest.raises(DesignFileError, match=match):
        load_design(path)


def test_a_plain_text_file_gets_no_pickle_advice(tmp_path):
    path = tmp_path / "bad.npz"
    path.write_text("hello")
    with pytest.raises(DesignFileError) as info:
        load_design(path)
    assert "pickle" not in str(info.value)


def test_a_case_or_result_file_is_refused_as_no_design_file(tmp_path):
    """Design files know no other format: what else a file is, the command line says
    (pes_ref.cli.files, tests/cli/test_cli_files.py)."""
    from pes_ref.oracle import conformance, load_case, run_case, write_result
    from pes_ref.testing.conformance import load_manifest
    vid = next(e for e in load_manifest(conformance.LATEST)["vectors"] if e["kind"] == "valid")
    case = conformance.vectors_dir(conformance.LATEST) / vid["case"]
    result = tmp_path / "r.npz"
    write_result(run_case(load_case(case)), result)
    for path in (case, result):
        with pytest.raises(DesignFileError, match=r"is not a design file \(no format tag 'pes_ref.design'"):
            load_design(path)


def test_a_newer_version_is_refused(tmp_path):
    path = tmp_path / "d.npz"
    save_design(path, tiny())
    data = dict(np.load(path))
    data["version"] = np.array(99)
    np.savez(path, **data)
    with pytest.raises(DesignFileError, match="version 99"):
        load_design(path)


def test_missing_file():
    with pytest.raises(FileNotFoundError, match="nowhere.npz"):
        load_design("nowhere.npz")


def test_a_stopped_run_saves_its_last_good_state(tmp_path):
    # lr = 1e4: iteration 1's grid is past the stability rule; the run rolls back to iteration 0
    plan = Plan(iterations=5, lr=1e4, lr_final=1e4, n_particles=4)
    st = synthesis.new_design("funnel", seed=0, plan=plan, grid=8, n_steps=200, dt=0.01, noise=0.0)
    st = synthesis.run_design(st)
    save_design(tmp_path / "nf.npz", st)
    back = load_design(tmp_path / "nf.npz")
    assert back.status.startswith("unstable: iteration 1") and back.iteration == 0
    assert np.isfinite(back.values).all()
    assert_same_state(st, back)


# --------------------------------------------------------------------------- version 2: the polish stage

def polished(tmp_path):
    from pes_ref.synthesis import PolishPlan
    from pes_ref.synthesis.engine.stages import run_stages
    plan = Plan(iterations=2, optimizer="adam", n_particles=3)
    st = synthesis.new_design("oscillator", seed=5, plan=plan, polish=PolishPlan(n_particles=3, evaluations=9,
                                                                                popsize=4), grid0=6, grid1=6,
                              eval_periods=4)
    return run_stages(st)


def test_round_trip_of_a_polished_design_is_exact(tmp_path):
    st = polished(tmp_path)
    assert st.stage == "polish" and st.base_values is not None and st.evaluations == 9
    save_design(tmp_path / "p.npz", st)
    back = load_design(tmp_path / "p.npz")
    assert_same_state(st, back)
    assert back.polish == st.polish and back.stage == "polish" and back.method == "gradient+polish"
    np.testing.assert_array_equal(back.base_values, st.base_values)
    assert back.evaluations == 9 and back.polish_history == st.polish_history and back.finished
    with np.load(tmp_path / "p.npz") as z:
        assert int(z["version"]) == design_file.VERSION == 5 and str(z["method"]) == "gradient+polish"


def test_a_version_1_file_is_read_as_a_gradient_only_run(tmp_path):
    import json
    st = synthesis.run_design(tiny())
    arrays = design_file.design_arrays(st)
    for key in ("method", "stage", "polish", "base_values", "evaluations", "polish_evals", "polish_fitness"):
        del arrays[key]
    plan = json.loads(str(arrays["plan"]))
    del plan["scale_lr_by_grid"]                       # a field the plan gained in version 2
    arrays.update(version=np.array(1), plan=np.array(json.dumps(plan)))
    np.savez(tmp_path / "v1.npz", **arrays)
    back = load_design(tmp_path / "v1.npz")
    assert_same_state(st, back)
    assert back.polish is None and back.stage == "gradient" and back.method == "gradient" and back.finished
    assert back.backend == "numpy"


# --------------------------------------------------------------------------- version 3: the backend

@pytest.mark.parametrize("backend", sorted(pr.BACKENDS))
def test_a_design_file_records_its_backend(tmp_path, backend):
    st = synthesis.run_design(synthesis.new_design("funnel", plan=Plan(iterations=2, n_particles=3), backend=backend,
                                                   grid=8, n_steps=20))
    save_design(tmp_path / "d.npz", st)
    back = load_design(tmp_path / "d.npz")
    assert st.backend == back.backend == backend
    with np.load(tmp_path / "d.npz") as z:
        assert str(z["backend"]) == backend


def test_a_version_2_file_is_read_as_a_numpy_run(tmp_path):
    st = synthesis.run_design(tiny())
    arrays = design_file.design_arrays(st)
    del arrays["backend"]
    arrays.update(version=np.array(2))
    np.savez(tmp_path / "v2.npz", **arrays)
    back = load_design(tmp_path / "v2.npz")
    assert_same_state(st, back)
    assert back.backend == "numpy"


@pytest.mark.parametrize("change", [lambda d: d.pop("backend"), lambda d: d.update(backend=np.array("cuda"))],
                         ids=["missing", "unknown"])
def test_a_damaged_backend_is_refused(tmp_path, change):
    save_design(tmp_path / "d.npz", synthesis.run_design(tiny()))
    data = dict(np.load(tmp_path / "d.npz"))
    change(data)
    np.savez(tmp_path / "d.npz", **data)
    with pytest.raises(DesignFileError, match="backend ''|backend 'cuda'"):
        load_design(tmp_path / "d.npz")


@pytest.mark.parametrize("change, match", [
    (lambda d: d.pop("stage"), "missing keys \\['stage'\\]"),
    (lambda d: d.update(stage=np.array("sanding")), "stage 'sanding'"),
    (lambda d: d.update(polish=np.array("null")), "stage 'polish', method 'gradient\\+polish' with polish none"),
    (lambda d: d.update(base_values=np.zeros((2, 2))), "base_values"),
    (lambda d: d.update(polish=np.array('{"method": "cma", "evaluations": 0}')), "polish plan: evaluations"),
])
def test_damaged_polish_fields_are_refused(tmp_path, change, match):
    save_design(tmp_path / "p.npz", polished(tmp_path))
    data = dict(np.load(tmp_path / "p.npz"))
    change(data)
    np.savez(tmp_path / "p.npz", **data)
    with pytest.raises(DesignFileError, match=match):
        load_design(tmp_path / "p.npz")
