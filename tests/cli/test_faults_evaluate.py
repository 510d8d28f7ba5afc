"""The faults of `evaluate`: each row refused in one line naming its argument, the folder left as it was
(the harness and the assets: ``tests/_faults.py``)."""
from _faults import Fault, Works, fault_table, works_table

FAULTS = [
    # ------------------------------------------------------------------ evaluate
    Fault("evaluate-missing", "evaluate nothing.npz", ("design file nothing.npz does not exist",)),
    Fault("evaluate-folder", "evaluate sub", ("design file sub is a folder",)),
    Fault("evaluate-text-named-npz", "evaluate text.npz", ("text.npz", "is not an .npz archive")),
    Fault("evaluate-case-file", "evaluate case.npz", ("case.npz is an oracle case file", "oracle")),
    Fault("evaluate-result-file", "evaluate result.npz", ("result.npz is an oracle result file",)),
    Fault("evaluate-particles-zero", "evaluate design.npz --particles 0", ("--particles must be >= 1", "0")),
    Fault("evaluate-particles-negative", "evaluate design.npz --particles -3", ("--particles must be >= 1", "-3")),
    Fault("evaluate-seed-negative", "evaluate design.npz --seed -1", ("--seed must be >= 0", "-1")),
    Fault("evaluate-engine-unknown", "evaluate design.npz --engine soft", ("--engine 'soft'", "surface, rigid, both")),
    Fault("evaluate-engine-without-realized", "evaluate design.npz --engine rigid", ("--engine rigid", "--realized")),
    Fault("evaluate-particles-float", "evaluate design.npz --particles 2.5", ("--particles", "'2.5'")),
    Fault("evaluate-unknown-option", "evaluate design.npz --bogus", ("--bogus",)),
    Fault("evaluate-particles-too-many-for-memory", "evaluate design.npz --particles 1000000000",
          ("--particles = 1000000000", "GiB", "reduce --particles"), absent=("n_steps",)),
    Fault("evaluate-realized-missing", "evaluate design.npz --realized nothing.toml",
          ("device file nothing.toml does not exist",)),
    Fault("evaluate-realized-folder", "evaluate design.npz --realized sub", ("device file sub is a folder",)),
    Fault("evaluate-realized-not-toml", "evaluate design.npz --realized broken.toml", ("broken.toml", "not valid TOML")),
    Fault("evaluate-realized-bad-key", "evaluate design.npz --realized dev-radius.toml",
          ("dev-radius.toml", "part[0].shapes[0].circle.radius")),
    Fault("evaluate-realized-other-grid", "evaluate design.npz --realized dev.toml",
          ("--realized dev.toml: the device's grid (21 x 21", "is not the design's (12 x 12")),
    Fault("evaluate-realized-problem-design", "evaluate problem.npz --realized dev.toml",
          ("--realized dev.toml: the device's grid (21 x 21", "is not the design's (8 x 8")),
    Fault("evaluate-json-no-folder", "evaluate design.npz --json nodir/e.json", ("--json nodir/e.json", "does not exist")),
    Fault("evaluate-json-read-only", "evaluate design.npz --json ro/e.json", ("--json ro/e.json", "not writable"),
          needs_permissions=True),
    Fault("evaluate-json-exists", "evaluate design.npz --json notes.txt", ("--json notes.txt", "exists already")),
    Fault("evaluate-json-a-folder", "evaluate design.npz --json sub", ("--json sub", "is a folder")),
    Fault("evaluate-plot-a-file", "evaluate design.npz --plot notes.txt", ("--plot notes.txt", "not a folder")),
    Fault("evaluate-plot-no-parent", "evaluate design.npz --plot nodir/plots", ("--plot nodir/plots", "does not exist")),
    Fault("evaluate-plot-read-only", "evaluate design.npz --plot ro", ("--plot ro", "not writable"),
          needs_permissions=True),
    Fault("evaluate-realized-another-design", "evaluate groups1.npz --realized gparts/device.toml",
          ("--realized gparts/device.toml", "the parts were made from another design", "[realized] design = sha256:",
           "--force")),
]


outcomes, test_fault = fault_table(FAULTS)

#: A realized design of every feature of a problem file evaluates (``groups.toml``, ``tests/_faults.py``).
WORKS = [
    Works("evaluate-realized-another-design-forced", "evaluate groups1.npz --realized gparts/device.toml --force",
          ("realized_success_fraction: ",)),
    Works("evaluate-realized-start-groups", "evaluate groups.npz --realized gparts/device.toml --engine both",
          ("rigid_success_out: ", "rigid_share_exits: ", "rigid_scenario_still_success_fraction: ",
           "rigid_starts_blocked: ")),
]

worked, test_works = works_table(WORKS)
