"""The faults of the top level (no command, an unknown one): each row refused in one line naming its argument, the folder left as it was
(the harness and the assets: ``tests/_faults.py``)."""
from _faults import Fault, fault_table

FAULTS = [
    # ------------------------------------------------------------------ the top level
    Fault("no-command", "", ("COMMAND",)),
    Fault("unknown-command", "frobnicate", ("'frobnicate'",)),
]


outcomes, test_fault = fault_table(FAULTS)
