"""The faults of `conformance`: each row refused in one line naming its argument, the folder left as it was
(the harness and the assets: ``tests/_faults.py``)."""
import pytest

from _faults import Fault, check_fault, run_rows

FAULTS = [
    # ------------------------------------------------------------------ conformance
    Fault("conformance-no-mode", "conformance", ("--write", "--check")),
    Fault("conformance-check-missing", "conformance --check nodir", ("nodir", "does not exist")),
    Fault("conformance-check-a-file", "conformance --check text.npz", ("text.npz", "not a folder")),
    Fault("conformance-check-no-manifest", "conformance --check sub", ("sub", "manifest.json")),
    Fault("conformance-write-no-parent", "conformance --write nodir/vectors", ("nodir", "does not exist")),
    Fault("conformance-write-under-a-file", "conformance --write text.npz/vectors", ("text.npz", "not a folder")),
    Fault("conformance-write-over-user-files", "conformance --write .", ("--write .", "manifest.json")),
    Fault("conformance-unknown-version", "conformance --check --vectors v999", ("--vectors", "'v999'")),
    Fault("conformance-unknown-option", "conformance --check --bogus", ("--bogus",)),
]


@pytest.fixture(scope="module")
def outcomes(fault_assets, tmp_path_factory):
    """Every row, run in parallel (each in a folder of its own)."""
    return run_rows(FAULTS, fault_assets, tmp_path_factory.mktemp("faults"))


@pytest.mark.parametrize("fault", FAULTS, ids=[f.id for f in FAULTS])
def test_fault(fault, outcomes):
    check_fault(fault, outcomes[fault.id])
