"""The faults of the top level (no command, an unknown one): each row refused in one line naming its argument, the folder left as it was
(the harness and the assets: ``tests/_faults.py``)."""
import pytest

from _faults import Fault, check_fault, run_rows

FAULTS = [
    # ------------------------------------------------------------------ the top level
    Fault("no-command", "", ("COMMAND",)),
    Fault("unknown-command", "frobnicate", ("'frobnicate'",)),
]


@pytest.fixture(scope="module")
def outcomes(fault_assets, tmp_path_factory):
    """Every row, run in parallel (each in a folder of its own)."""
    return run_rows(FAULTS, fault_assets, tmp_path_factory.mktemp("faults"))


@pytest.mark.parametrize("fault", FAULTS, ids=[f.id for f in FAULTS])
def test_fault(fault, outcomes):
    check_fault(fault, outcomes[fault.id])
