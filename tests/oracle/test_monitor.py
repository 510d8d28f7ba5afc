"""The progress of a long oracle run (pes_ref.oracle.monitor), from a fake clock."""
from pes_ref.core import budget
from pes_ref.core.runtime import progress
from pes_ref.oracle.monitor import ProgressLines


def test_progress_lines_from_a_fake_clock(capsys):
    """The oracle command's lines: an estimate first, then at most one line per period."""
    now = [0.0]
    est = budget.RunEstimate(1000, 8, 1.0, 10.0)
    lines = ProgressLines("c.npz", est, period=2.0, clock=lambda: now[0])
    for phase in ("forward", "adjoint"):
        for done in range(0, 1001, 100):
            now[0] += 0.5
            lines(phase, done, 1000)
    err = capsys.readouterr().err.strip().splitlines()
    assert err[0] == "c.npz: estimate | steps 0/1000 | N 8 | GiB 1 | ? steps/s | elapsed 0:00 | left 0:10"
    assert any(e.startswith("c.npz: forward | steps ") and " steps/s | " in e and "| left " in e for e in err[1:])
    assert any(e.startswith("c.npz: adjoint | steps ") for e in err[1:])
    assert 4 <= len(err) <= 7, err


def test_a_run_estimated_short_that_runs_long_starts_reporting(capsys):
    now = [0.0]
    lines = ProgressLines("c.npz", budget.RunEstimate(1000, 8, 1.0, 1.0), period=2.0, clock=lambda: now[0])
    lines("forward", 0, 1000)
    now[0] = 2.0
    lines("forward", 256, 1000)
    assert capsys.readouterr().err == ""            # estimated 1 s, 2 s so far: quiet
    now[0] = 4.0
    lines("forward", 512, 1000)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and err[0].startswith("c.npz: estimate | steps 0/1000 | N 8 | ") and \
        err[1].startswith("c.npz: forward | steps 512/1000 | "), err
    assert all(progress.is_progress_line(line) for line in err)
