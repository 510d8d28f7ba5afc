"""The faults of `realize`: each row refused in one line naming its argument, the folder left as it was
(the harness and the assets: ``tests/_faults.py``)."""
import pytest

from _faults import Fault, check_fault, run_rows

FAULTS = [
    # ------------------------------------------------------------------ realize
    Fault("realize-missing", "realize nothing.npz --as contact --out parts", ("design file nothing.npz does not exist",)),
    Fault("realize-folder", "realize sub --as contact --out parts", ("design file sub is a folder",)),
    Fault("realize-case-file", "realize case.npz --as contact --out parts", ("case.npz is an oracle case file",)),
    Fault("realize-no-as", "realize design.npz --out newparts", ("--as",)),
    Fault("realize-bad-as", "realize design.npz --as glue --out newparts", ("--as", "'glue'")),
    Fault("realize-no-out", "realize design.npz --as contact", ("--out",)),
    Fault("realize-out-is-a-file", "realize design.npz --as contact --out notes.txt", ("notes.txt", "is a file")),
    Fault("realize-out-not-writable", "realize design.npz --as contact --out ro", ("ro", "not writable"),
          needs_permissions=True),
    Fault("realize-out-no-parent", "realize design.npz --as contact --out nodir/parts", ("nodir", "does not exist")),
    Fault("realize-existing-file", "realize design.npz --as contact --out parts",
          ("device file", "parts/device.toml", "exists already")),
    Fault("realize-pin-radius-negative", "realize design.npz --as contact --out newparts --pin-radius -1",
          ("--pin-radius must be > 0", "-1")),
    Fault("realize-rim-zero", "realize design.npz --as contact --out newparts --rim 0", ("--rim must be > 0", "0")),
    Fault("realize-thickness-nan", "realize design.npz --as contact --out newparts --thickness nan",
          ("--thickness must be", "nan")),
    Fault("realize-pin-radius-beyond-domain", "realize design.npz --as contact --out newparts --pin-radius 1e308",
          ("--pin-radius must be below half the design's shortest side", "1e+308")),
    Fault("realize-rim-beyond-domain", "realize design.npz --as contact --out newparts --rim 1e308",
          ("--rim must be at most the design's longest side", "1e+308")),
    Fault("realize-thickness-beyond-float32", "realize design.npz --as contact --out newparts --thickness 1e308",
          ("--thickness must be below", "float32", "1e+308")),
    Fault("realize-level-text", "realize design.npz --as contact --out newparts --rule value --level high",
          ("--level", "'high'")),
    Fault("realize-level-without-value", "realize design.npz --as contact --out newparts --level 0.1",
          ("--level E goes with --rule value", "--level 0.1", "--rule None")),
    Fault("realize-value-without-level", "realize design.npz --as contact --out newparts --rule value",
          ("--level E goes with --rule value", "--level None", "--rule value")),
    Fault("realize-level-set-of-a-plain-design", "realize design.npz --as contact --out newparts --rule level-set",
          ("'level-set' needs a design made realizable", "realizable=true")),
    Fault("realize-bad-rule", "realize design.npz --as contact --out newparts --rule guess", ("--rule", "'guess'")),
    Fault("realize-problem-design-without-contact", "realize problem.npz --as contact --out newparts",
          ("states no [surface.contact]", "v, r_c and r_min")),
    Fault("realize-heightfield-g-negative", "realize design.npz --as heightfield --out newparts --g -1",
          ("--g must be > 0", "-1")),
    Fault("realize-heightfield-base-zero", "realize design.npz --as heightfield --out newparts --base 0",
          ("--base must be > 0", "0")),
    Fault("realize-heightfield-g-tiny", "realize design.npz --as heightfield --out newparts --g 1e-300",
          ("--g = 1e-300 makes the plate's heights span", "float32")),
    Fault("realize-heightfield-g-huge", "realize design.npz --as heightfield --out newparts --g 1e308",
          ("--g = 1e+308 makes the plate's heights span", "float32")),
    Fault("realize-heightfield-base-beyond-float32", "realize design.npz --as heightfield --out newparts --base 1e308",
          ("--base must leave the plate within", "1e+308")),
    Fault("realize-heightfield-particles-zero", "realize design.npz --as heightfield --out newparts --particles 0",
          ("--particles must be >= 1", "0")),
    Fault("realize-heightfield-seed-negative", "realize design.npz --as heightfield --out newparts --seed -2",
          ("--seed must be >= 0", "-2")),
    Fault("realize-heightfield-steps-zero", "realize design.npz --as heightfield --out newparts --steps 0",
          ("--steps must be >= 1, got 0",)),
    Fault("realize-heightfield-steps-not-an-integer", "realize design.npz --as heightfield --out newparts --steps 2.5",
          ("--steps", "'2.5'")),
    Fault("realize-steps-contact", "realize design.npz --as contact --out newparts --steps 700",
          ("--steps goes with --as heightfield, not --as contact",)),
    Fault("realize-heightfield-pin-radius", "realize design.npz --as heightfield --out newparts --pin-radius 0.1",
          ("--pin-radius goes with --as contact, not --as heightfield",)),
    Fault("realize-contact-g", "realize design.npz --as contact --out newparts --g 9.81",
          ("--g goes with --as heightfield, not --as contact",)),
    Fault("realize-clearance-negative", "realize design.npz --as contact --out newparts --clearance -0.01",
          ("--clearance must be >= 0", "-0.01")),
    Fault("realize-clearance-too-large", "realize design.npz --as contact --out newparts --clearance 5",
          ("--pin-radius + --clearance must be below half the design's shortest side",)),
    Fault("realize-restitution-above-one", "realize design.npz --as contact --out newparts --restitution 1.5",
          ("--restitution must be in [0, 1]", "1.5")),
    Fault("realize-restitution-heightfield", "realize design.npz --as heightfield --out newparts --restitution 0.5",
          ("--restitution goes with --as contact, not --as heightfield",)),
    Fault("realize-heightfield-existing", "realize design.npz --as heightfield --out sub2",
          ("STL file", "sub2/heightfield.stl", "exists already")),
    Fault("realize-heightfield-problem-design", "realize problem.npz --as heightfield --out newparts",
          ("--as heightfield checks funnel designs", "'problem' design")),
    Fault("realize-unknown-option", "realize design.npz --as contact --out newparts --bogus", ("--bogus",)),
    Fault("realize-drum-radius-on-a-plane", "realize design.npz --as contact --out newparts --drum-radius 1",
          ("--drum-radius goes with a cylinder design", "a plane")),
    Fault("realize-drum-radius-negative", "realize osc.npz --as contact --out newparts --drum-radius -1",
          ("--drum-radius must be > 0", "-1")),
    Fault("realize-drum-radius-beyond-float32", "realize osc.npz --as contact --out newparts --drum-radius 1e308",
          ("--drum-radius must be below", "1e+308")),
    Fault("realize-drum-radius-heightfield", "realize osc.npz --as heightfield --out newparts --drum-radius 2",
          ("--drum-radius goes with --as contact, not --as heightfield",)),
    Fault("realize-heightfield-of-a-cylinder", "realize osc.npz --as heightfield --out newparts",
          ("--as heightfield checks funnel designs", "'oscillator' design")),
]


@pytest.fixture(scope="module")
def outcomes(fault_assets, tmp_path_factory):
    """Every row, run in parallel (each in a folder of its own)."""
    return run_rows(FAULTS, fault_assets, tmp_path_factory.mktemp("faults"))


@pytest.mark.parametrize("fault", FAULTS, ids=[f.id for f in FAULTS])
def test_fault(fault, outcomes):
    check_fault(fault, outcomes[fault.id])
