"""The faults of `bench`: each row refused in one line naming its argument, the folder left as it was
(the harness and the assets: ``tests/_faults.py``)."""
from _faults import Fault, fault_table

FAULTS = [
    # ------------------------------------------------------------------ bench
    Fault("bench-out-no-folder", "bench --quick --out nodir/b.json", ("nodir", "does not exist")),
    Fault("bench-out-under-a-file", "bench --quick --out text.npz/b.json", ("text.npz", "not a folder")),
    Fault("bench-out-exists", "bench --quick --out notes.txt", ("notes.txt", "exists")),
    Fault("bench-plot-exists", "bench --quick --out b.json", ("b-scaling.png", "exists")),
    Fault("bench-out-is-a-folder", "bench --quick --out sub", ("cannot write sub", "is a folder")),
    Fault("bench-unknown-option", "bench --quick --bogus", ("--bogus",)),
]


outcomes, test_fault = fault_table(FAULTS)
