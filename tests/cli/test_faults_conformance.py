"""The faults of `conformance`: each row refused in one line naming its argument, the folder left as it was
(the harness and the assets: ``tests/_faults.py``)."""
from _faults import Fault, fault_table

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


outcomes, test_fault = fault_table(FAULTS)
