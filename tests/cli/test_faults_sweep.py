"""The faults of `sweep`: each row refused in one line naming its argument, the folder left as it was
(the harness and the assets: ``tests/_faults.py``)."""
from _faults import Fault, fault_table

FAULTS = [
    # ------------------------------------------------------------------ sweep
    Fault("sweep-missing-file", "sweep nothing.toml", ("sweep file nothing.toml does not exist",)),
    Fault("sweep-not-toml", "sweep notes.txt", ("notes.txt", "not valid TOML")),
    Fault("sweep-workers-zero", "sweep notes.txt --workers 0", ("--workers must be >= 1", "0")),
    Fault("sweep-progress-negative", "sweep notes.txt --progress -1", ("--progress must be > 0", "-1")),
    Fault("sweep-unknown-option", "sweep notes.txt --bogus", ("--bogus",)),
]


outcomes, test_fault = fault_table(FAULTS)
