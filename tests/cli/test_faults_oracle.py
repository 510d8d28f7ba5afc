"""The faults of `oracle`: each row refused in one line naming its argument, the folder left as it was
(the harness and the assets: ``tests/_faults.py``)."""
import pytest

from _faults import Fault, check_fault, run_rows

FAULTS = [
    # ------------------------------------------------------------------ oracle
    Fault("oracle-missing-case", "oracle nothing.npz out.npz", ("case file nothing.npz does not exist",)),
    Fault("oracle-case-is-a-folder", "oracle sub out.npz", ("case file sub is a folder",)),
    Fault("oracle-text-named-npz", "oracle text.npz out.npz", ("text.npz", "is not an .npz archive")),
    Fault("oracle-design-file", "oracle design.npz out.npz", ("design.npz is a design file", "evaluate")),
    Fault("oracle-invalid-case", "oracle bad.case.npz out.npz", ("case key 'mass'",)),
    Fault("oracle-no-folder", "oracle case.npz nodir/out.npz", ("nodir", "does not exist")),
    Fault("oracle-under-a-file", "oracle case.npz text.npz/out.npz", ("text.npz is a file, not a folder",)),
    Fault("oracle-result-exists", "oracle case.npz result.npz", ("result.npz", "exists")),
    Fault("oracle-result-is-the-case", "oracle case.npz case.npz", ("case.npz", "exists")),
    Fault("oracle-result-is-a-folder", "oracle case.npz sub", ("cannot write sub", "is a folder")),
    Fault("oracle-odd-files", "oracle case.npz", ("pairs", "got 1 file name")),
    Fault("oracle-out-dir-missing", "oracle case.npz --out-dir nodir", ("nodir", "does not exist")),
    Fault("oracle-result-file", "oracle result.npz out.npz", ("result.npz is an oracle result file",)),
    Fault("oracle-unknown-option", "oracle case.npz out.npz --bogus 3", ("--bogus",)),
    Fault("oracle-backend-unknown", "oracle case.npz out.npz --backend cuda", ("--backend", "'cuda'")),
    Fault("oracle-refusals-no-folder", "oracle bad.case.npz out.npz --refusals nodir/r.jsonl",
          ("nodir/r.jsonl", "does not exist")),
    Fault("oracle-refusals-a-folder", "oracle bad.case.npz out.npz --refusals sub", ("sub", "is a folder")),
    Fault("oracle-read-only-folder", "oracle case.npz ro/out.npz", ("ro", "not writable"), needs_permissions=True),
    Fault("oracle-wall-k-beyond-float", "oracle huge-wall.case.npz out.npz",
          ("case key 'dt'", "stiffest term (wall 1e+308", "a stable dt is")),
    Fault("oracle-values-beyond-float", "oracle steep.case.npz out.npz",
          ("case key 'values'", "stiffness beyond float64", "no dt is stable")),
    Fault("oracle-fuzz-huge-force", "oracle huge-force.case.npz out.npz",
          ("case key 'dt'", "left the range of the grid lookup", "periodic axis 1")),
    Fault("oracle-fuzz-huge-weight", "oracle huge-weight.case.npz out.npz",
          ("case key 'mobility'", "grad_mobility is not finite")),
]


@pytest.fixture(scope="module")
def outcomes(fault_assets, tmp_path_factory):
    """Every row, run in parallel (each in a folder of its own)."""
    return run_rows(FAULTS, fault_assets, tmp_path_factory.mktemp("faults"))


@pytest.mark.parametrize("fault", FAULTS, ids=[f.id for f in FAULTS])
def test_fault(fault, outcomes):
    check_fault(fault, outcomes[fault.id])
