"""``python -m pes_ref sweep`` on a 2-worker LocalCluster: the smoke sweep (4 tiny runs, one injected
failure), its table, resume, a worker that dies and Ctrl-C."""
from __future__ import annotations

import csv
import math
import os
import re
import signal
import sys

import numpy as np
import pytest

distributed = pytest.importorskip("distributed")

from pes_ref.cli import EXIT_ERROR, EXIT_FAIL, EXIT_OK, main  # noqa: E402
from pes_ref.sweep import cluster, results, task as task_module  # noqa: E402
from pes_ref.sweep.runner import run_sweep  # noqa: E402
from pes_ref.sweep.spec import load_sweep  # noqa: E402
from pes_ref.synthesis.engine.design_file import load_design  # noqa: E402
from pes_ref.synthesis import new_design, run_design  # noqa: E402

#: The smoke sweep: three tiny funnel runs (the design command's --smoke preset) and one that goes
#: is past the stability rule (stiff walls, a large dt), the injected failure.
SMOKE_SWEEP = '''description = "smoke sweep"
kind = "funnel"
eval_seeds = [12345, 777]
eval_particles = 16

[base]
smoke = true

[[variants]]
name = "a"
lr = 0.002
[[variants]]
name = "b"
lr = 0.004
[[variants]]
name = "c"
lr = 0.008
[[variants]]
name = "blowup"
lr = 10.0
lr_final = 10.0
noise = 0.0
wall_k = 1e6
dt = 0.01
n_steps = 200
grid = 8
'''


@pytest.fixture(scope="module")
def client():
    with cluster.local_cluster(2) as local, distributed.Client(local) as c:
        cluster._local_worker_setup(c)
        yield c


def read_csv(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def mtimes(folder):
    return {p: (os.stat(os.path.join(folder, p)).st_mtime_ns, open(os.path.join(folder, p), "rb").read())
            for p in sorted(os.listdir(folder))}


def test_workers_are_single_threaded_with_one_openmp_thread_and_ignore_ctrl_c(client):
    assert list(client.nthreads().values()) == [1, 1]
    env = client.run(lambda: os.environ.get("OMP_NUM_THREADS"))
    assert set(env.values()) == {"1"}
    handlers = client.run(lambda: signal.getsignal(signal.SIGINT) == signal.SIG_IGN)
    assert all(handlers.values())


def test_smoke_sweep_table_resume_and_injected_failure(client, tmp_path, capsys):
    spec = tmp_path / "smoke.toml"
    spec.write_text(SMOKE_SWEEP)
    out = tmp_path / "out"
    address = client.scheduler.address
    code = main(["sweep", str(spec), "--out", str(out), "--scheduler", address, "--quiet"])
    stdout, stderr = capsys.readouterr()
    assert code == EXIT_FAIL, stderr                       # one run failed (twice)
    rows = read_csv(out / "results.csv")
    assert [r["variant"] for r in rows] == ["a", "b", "c", "blowup"]
    assert [r["status"] for r in rows] == ["ok", "ok", "ok", "failed"]
    header = list(rows[0])
    assert header[:4] == ["run", "variant", "dt", "grid"] and "seed" in header and "wall_s" in header
    for row in rows[:3]:
        assert row["attempts"] == "1" and row["error"] == "" and row["iterations_done"] == "6"
        assert row["worker"].startswith("tcp://") and float(row["wall_s"]) > 0
        for name in ("in_band_fraction", "exit_spread", "exited_fraction", "flat_in_band_fraction"):
            per_seed = [float(row[f"{name}@{s}"]) for s in (12345, 777)]
            assert math.isclose(float(row[name]), sum(per_seed) / 2)
        assert os.path.exists(row["design_file"]) and load_design(row["design_file"]).status == "done"
    failed = rows[3]
    assert failed["attempts"] == "2" and failed["error"].count("stability limit") == 2   # refused, both attempts
    assert "attempt 1 on tcp://" in failed["error"] and "attempt 2 on tcp://" in failed["error"]
    assert failed["in_band_fraction"] == ""
    assert (out / "summary.png").stat().st_size > 1000
    assert "4 runs: 3 ok, 1 failed" in stdout and "0 finished earlier" in stdout
    assert stdout.splitlines()[0].split()[:4] == ["variant", "dt", "grid", "lr"]

    # resume: the three finished runs are neither submitted nor touched; the failed one runs again
    before = mtimes(out / "runs")
    report = run_sweep(load_sweep(spec), out, client, plot=False)
    ok_ids = [r["run"] for r in rows[:3]]
    assert report.skipped == ok_ids and report.submitted == [failed["run"]]
    after = mtimes(out / "runs")
    assert {p: after[p] for p in before if p.startswith(tuple(ok_ids))} == \
        {p: before[p] for p in before if p.startswith(tuple(ok_ids))}
    again = read_csv(out / "results.csv")
    assert again[:3] == rows[:3]                           # the finished rows, kept verbatim
    assert again[3]["status"] == "failed"


def test_a_new_held_out_seed_evaluates_again_without_redesigning(client, tmp_path):
    spec = tmp_path / "s.toml"
    spec.write_text('kind = "funnel"\neval_seeds = [1]\neval_particles = 8\n[base]\nsmoke = true\n')
    run_sweep(load_sweep(spec), tmp_path / "o", client, plot=False)
    design_file = read_csv(tmp_path / "o" / "results.csv")[0]["design_file"]
    stamp = os.stat(design_file).st_mtime_ns
    spec.write_text('kind = "funnel"\neval_seeds = [1, 2]\neval_particles = 8\n[base]\nsmoke = true\n')
    report = run_sweep(load_sweep(spec), tmp_path / "o", client, plot=False)
    row = read_csv(tmp_path / "o" / "results.csv")[0]
    assert report.submitted and row["status"] == "ok" and row["from_iteration"] == "6" and row["in_band_fraction@2"]
    assert os.stat(design_file).st_mtime_ns == stamp       # evaluated only: the design file is not rewritten


def _dies_on_first_attempt(payload):
    """The sweep's task, except that the process dies (like a killed worker) the first time it sees a run."""
    marker = payload["design_file"] + ".died"
    if not os.path.exists(marker):
        open(marker, "w").close()
        os._exit(1)
    return task_module.run_task(payload)


def test_a_run_whose_worker_dies_is_retried_on_another_worker(client, tmp_path):
    import cloudpickle
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    spec = tmp_path / "s.toml"
    spec.write_text('kind = "funnel"\neval_seeds = [1]\neval_particles = 8\n[base]\nsmoke = true\n')
    report = run_sweep(load_sweep(spec), tmp_path / "o", client, task=_dies_on_first_attempt, plot=False)
    row = report.rows[0]
    assert row["status"] == "ok" and row["attempts"] == 2 and report.retried == [row["run"]]
    assert "attempt 1 on tcp://" in row["error"] and "the worker died while running it" in row["error"]
    died_on = re.search(r"attempt 1 on (tcp://[0-9.]+:[0-9]+)", row["error"]).group(1)
    assert died_on != row["worker"]
    client.wait_for_workers(2, timeout=30)                # the nanny brings the dead worker back


def test_ctrl_c_saves_the_running_designs_and_the_next_run_resumes_them(client, tmp_path):
    """Interrupted mid-design, resumed: the same grid as a run that never stopped."""
    spec = tmp_path / "s.toml"
    spec.write_text('kind = "funnel"\nseeds = [0, 1]\neval_seeds = [1]\neval_particles = 8\n'
                    '[base]\nsmoke = true\niterations = 1500\nparticles = 4\n')
    sweep = load_sweep(spec)
    calls = []

    def ctrl_c_once(progress):
        if not calls and progress.figure("running") == 2:
            calls.append(progress)
            raise KeyboardInterrupt
    report = run_sweep(sweep, tmp_path / "o", client, progress=ctrl_c_once, progress_every=0.2, plot=False)
    assert calls and report.interrupted
    assert [r["status"] for r in report.rows] == ["interrupted", "interrupted"]
    stopped = [load_design(r["design_file"]) for r in report.rows]
    assert all(s.status == "interrupted" and 0 < s.iteration < 1500 for s in stopped)

    report = run_sweep(sweep, tmp_path / "o", client, plot=False)
    assert [r["status"] for r in report.rows] == ["ok", "ok"]
    for row, before in zip(report.rows, stopped):
        assert row["from_iteration"] == before.iteration
        final = load_design(row["design_file"])
        plan = final.plan
        fresh = run_design(new_design("funnel", seed=final.seed, plan=plan, grid=12, n_steps=60, dt=0.05))
        np.testing.assert_array_equal(final.values, fresh.values)


def test_a_stopped_sweeps_task_does_not_start(tmp_path):
    task_module.request_stop("t-stop")
    out = task_module.run_task({"id": "x", "kind": "funnel", "options": {"smoke": True}, "seed": 0,
                                "eval_seeds": [1], "eval_particles": 4, "design_file": str(tmp_path / "x.npz"),
                                "token": "t-stop"})
    assert out["status"] == "interrupted" and not (tmp_path / "x.npz").exists()


def test_a_task_never_raises_and_reports_the_error(tmp_path):
    (tmp_path / "x.npz").write_text("not a design")
    out = task_module.run_task({"id": "x", "kind": "funnel", "options": {"smoke": True}, "seed": 0,
                                "eval_seeds": [1], "eval_particles": 4, "design_file": str(tmp_path / "x.npz")})
    assert out["status"] == "failed" and "is not an .npz archive" in out["error"] and out["worker"] == "local"


def test_results_and_summary_are_published_whole_with_the_users_mode(tmp_path):
    """Through the one atomic writer: no temporary file left, and the mode any file of the
    user gets (0o666 less the umask), not a temporary file's 0o600."""
    spec = tmp_path / "s.toml"
    spec.write_text('kind = "funnel"\nseeds = [0, 1]\neval_seeds = [1]\n[base]\nsmoke = true\n')
    sweep = load_sweep(spec)
    rows = [results.new_row(run, sweep, str(tmp_path / f"{run.id}.npz")) for run in sweep.runs]
    out = tmp_path / "o"
    out.mkdir()
    old = os.umask(0o022)
    try:
        results.write_results(out / results.CSV_NAME, sweep, rows)
        results.plot_summary(out / results.PLOT_NAME, sweep, rows)
    finally:
        os.umask(old)
    assert {p.name: p.stat().st_mode & 0o777 for p in out.iterdir()} == {"results.csv": 0o644, "summary.png": 0o644}
    assert [r["run"] for r in read_csv(out / "results.csv")] == [run.id for run in sweep.runs]


def test_without_dask_the_command_says_how_to_install_it(tmp_path, capsys, monkeypatch):
    spec = tmp_path / "s.toml"
    spec.write_text('kind = "funnel"\neval_seeds = [1]\n')
    monkeypatch.setitem(sys.modules, "distributed", None)      # import distributed -> ImportError
    assert main(["sweep", str(spec)]) == EXIT_ERROR
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pip install 'pes_ref[sweep]'" in err


@pytest.mark.parametrize("argv, message", [
    (["{spec}", "--workers", "0"], "--workers must be >= 1"),
    (["{spec}", "--progress", "0"], "--progress must be > 0"),
    (["{spec}", "--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "has its own workers"),
    (["{tmp}/nothing.toml"], "nothing.toml does not exist"),
])
def test_bad_arguments_get_one_error_line(tmp_path, capsys, argv, message):
    spec = tmp_path / "s.toml"
    spec.write_text('kind = "funnel"\neval_seeds = [1]\n')
    code = main(["sweep"] + [a.format(spec=spec, tmp=tmp_path) for a in argv])
    err = capsys.readouterr().err
    assert code == EXIT_ERROR and err.count("\n") == 1 and err.startswith("error: ") and message in err


def test_default_output_folder_is_named_after_the_file(tmp_path, capsys, monkeypatch, client):
    spec = tmp_path / "tiny.toml"
    spec.write_text('kind = "funnel"\neval_seeds = [1]\neval_particles = 4\n[base]\nsmoke = true\n')
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", str(spec), "--scheduler", client.scheduler.address, "--quiet"]) == EXIT_OK
    assert (tmp_path / "sweeps" / "tiny" / "results.csv").exists()
