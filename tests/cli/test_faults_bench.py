"""The faults of `bench`: each row refused in one line naming its argument, the folder left as it was
(the harness and the assets: ``tests/_faults.py``)."""
import pytest

from _faults import Fault, check_fault, run_rows

FAULTS = [
    # ------------------------------------------------------------------ bench
    Fault("bench-out-no-folder", "bench --quick --out nodir/b.json", ("nodir", "does not exist")),
    Fault("bench-out-under-a-file", "bench --quick --out text.npz/b.json", ("text.npz", "not a folder")),
    Fault("bench-out-exists", "bench --quick --out notes.txt", ("notes.txt", "exists")),
    Fault("bench-plot-exists", "bench --quick --out b.json", ("b-scaling.png", "exists")),
    Fault("bench-out-is-a-folder", "bench --quick --out sub", ("cannot write sub", "is a folder")),
    Fault("bench-unknown-option", "bench --quick --bogus", ("--bogus",)),
]


@pytest.fixture(scope="module")
def outcomes(fault_assets, tmp_path_factory):
    """Every row, run in parallel (each in a folder of its own)."""
    return run_rows(FAULTS, fault_assets, tmp_path_factory.mktemp("faults"))


@pytest.mark.parametrize("fault", FAULTS, ids=[f.id for f in FAULTS])
def test_fault(fault, outcomes):
    check_fault(fault, outcomes[fault.id])
