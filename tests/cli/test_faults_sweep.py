"""The faults of `sweep`: each row refused in one line naming its argument, the folder left as it was
(the harness and the assets: ``tests/_faults.py``)."""
import pytest

from _faults import Fault, check_fault, run_rows

FAULTS = [
    # ------------------------------------------------------------------ sweep
    Fault("sweep-missing-file", "sweep nothing.toml", ("sweep file nothing.toml does not exist",)),
    Fault("sweep-not-toml", "sweep notes.txt", ("notes.txt", "not valid TOML")),
    Fault("sweep-workers-zero", "sweep notes.txt --workers 0", ("--workers must be >= 1", "0")),
    Fault("sweep-progress-negative", "sweep notes.txt --progress -1", ("--progress must be > 0", "-1")),
    Fault("sweep-unknown-option", "sweep notes.txt --bogus", ("--bogus",)),
]


@pytest.fixture(scope="module")
def outcomes(fault_assets, tmp_path_factory):
    """Every row, run in parallel (each in a folder of its own)."""
    return run_rows(FAULTS, fault_assets, tmp_path_factory.mktemp("faults"))


@pytest.mark.parametrize("fault", FAULTS, ids=[f.id for f in FAULTS])
def test_fault(fault, outcomes):
    check_fault(fault, outcomes[fault.id])
