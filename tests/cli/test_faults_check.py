"""The faults of `check`: each row refused in one line naming its argument, the folder left as it was
(the harness and the assets: ``tests/_faults.py``)."""
from _faults import Fault, fault_table

FAULTS = [
    # ------------------------------------------------------------------ check
    Fault("check-missing-cmd", "check", ("--cmd", "required")),
    Fault("check-cmd-without-paths", "check --cmd true", ("--cmd", "'true'", "{case}")),
    Fault("check-missing-program", "check --cmd './nothing.sh {case} {result}'", ("./nothing.sh", "does not exist")),
    Fault("check-unknown-program", "check --cmd 'no-such-program-here {pairs}'", ("no-such-program-here", "not found")),
    Fault("check-random-negative", "check --cmd '{python} -m pes_ref oracle {pairs}' --random -1", ("--random", "-1")),
    Fault("check-random-not-a-number", "check --cmd 'x {pairs}' --random many", ("--random", "'many'")),
    Fault("check-timeout-zero", "check --cmd '{python} -m pes_ref oracle {pairs}' --timeout 0", ("--timeout", "0")),
    Fault("check-timeout-nan", "check --cmd '{python} -m pes_ref oracle {pairs}' --timeout nan", ("--timeout", "nan")),
    Fault("check-only-unknown", "check --cmd '{python} -m pes_ref oracle {pairs}' --only nope", ("--only", "'nope'")),
    Fault("check-only-misspelled", "check --cmd '{python} -m pes_ref oracle {pairs}' --only mass-zro",
          ("--only", "'mass-zro'", "did you mean mass-zero", "--list")),
    Fault("check-seed-negative", "check --cmd '{python} -m pes_ref oracle {pairs}' --random 2 --seed -1",
          ("--seed", "-1")),
    Fault("check-strict-without-refusals", "check --cmd '{python} -m pes_ref oracle {pairs}' --strict",
          ("--strict", "{refusals}")),
    Fault("check-nothing-to-check", "check --cmd '{python} -m pes_ref oracle {pairs}' --no-vectors",
          ("--no-vectors", "--random 0")),
    Fault("check-report-no-folder", "check --cmd '{python} -m pes_ref oracle {pairs}' --report nodir/r.json",
          ("nodir", "does not exist")),
    Fault("check-report-exists", "check --cmd '{python} -m pes_ref oracle {pairs}' --report notes.txt",
          ("notes.txt", "exists")),
    Fault("check-keep-is-a-file", "check --cmd '{python} -m pes_ref oracle {pairs}' --keep text.npz",
          ("text.npz", "not a folder")),
    Fault("check-unknown-option", "check --cmd 'x {pairs}' --bogus", ("--bogus",)),
]


outcomes, test_fault = fault_table(FAULTS)
