"""The harness of the command line's fault tables (``tests/cli/test_faults_*.py``).

Each row runs the command line for real, in a process of its own (``tests/_forked.py``: forked
from one that has imported it, so a row costs its own work and not Python's start), in a folder
of its own holding a case, an invalid case, a result, a design, a plain-text file named ``.npz``, a
user's notes and a subfolder: :func:`make_assets`) and :func:`check_fault` checks that the
command

- exits with the expected status (2: refused) and prints no traceback,
- prints exactly one line ``error: ...`` on stderr naming the argument or flag and the
  bad value (every token of the row is in it), and nothing on stdout; progress lines that a
  slow or loaded machine may print before it are not compared
  (:func:`_helpers.without_progress`, docs/testing.md),
- leaves the folder as it was: every file there before is there after with the same
  bytes, and no file (not even a hidden temporary one) is added.

A :class:`Works` row is the other kind: a run whose fault was a crash (or a refusal of valid
input), which must now succeed: exit 0, its figures on stdout, no error line, only the files
it makes added (:func:`works_table`).

A table's rows run in parallel on a small thread pool (:func:`run_rows`; each is a process
of its own); every refusal comes before any computing, so a table takes seconds. Rows that
need a read-only folder run as ``python -m pes_ref ARGV`` without the capability that lets root
write anywhere (``setpriv``), so that they run, and mean something, as root too; the closed-pipe
rows run as ``python -m pes_ref ARGV`` too (:func:`run_piped`). The assets are made once
per test process (``tests/cli/conftest.py``).
"""
from __future__ import annotations

import contextlib
import io
import json
import os
import shlex
import shutil
import stat
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Callable, NamedTuple

import numpy as np

import _forked
import _helpers

import pes_ref
from pes_ref import cli
from pes_ref.oracle import conformance, load_case, run_case, save_case, write_result
from pes_ref.testing.conformance import load_manifest

ROOT = Path(pes_ref.__file__).resolve().parent.parent
ENV = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""), OMP_NUM_THREADS="1")
VECTORS = conformance.vectors_dir(conformance.LATEST)
MANIFEST = load_manifest(conformance.LATEST)["vectors"]
CASE = VECTORS / next(e for e in MANIFEST if e["id"] == "plane-dynamic")["case"]
BAD_CASE = next(e for e in MANIFEST if e["kind"] == "invalid" and e.get("key") == "mass")
WALL_CASE = VECTORS / next(e for e in MANIFEST if e["id"] == "wall-q0-lower")["case"]
#: Fuzzed case files that once broke the oracle (their README says how).
FUZZ_CASES = Path(__file__).resolve().parent / "oracle" / "fuzz-cases"
IS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0
#: Runs a command as root without CAP_DAC_OVERRIDE, the capability that lets root write into
#: a read-only folder: the refusal of a read-only folder is then what it is for any user.
UNPRIVILEGED = ["setpriv", "--inh-caps=-dac_override", "--bounding-set=-dac_override", "--"] if IS_ROOT else []


class Fault(NamedTuple):
    """One row: an id, the command line (``{python}`` is this interpreter), the tokens the
    error line must hold, and the exit status."""

    id: str
    argv: str
    tokens: tuple
    status: int = cli.EXIT_ERROR
    needs_permissions: bool = False     # run without root's power to ignore file permissions
    absent: tuple = ()                  # words the error line must not hold

#: A problem file with every feature a realization must carry (``docs/problems.md``): start
#: groups (a box and points, unequal shares), an ``any_of`` test and a group's test, a share,
#: a scenario, and ``[surface.contact]`` made realizable from a drawn shape; its designs are
#: realized by the rows of ``tests/cli/test_faults_realize.py``.
GROUPS_PROBLEM = """format = 1
name = "gate"
[surface]
lower = [-1.0, -1.0]
upper = [1.0, 1.0]
shape = [12, 12]
[surface.contact]
v = 1e-3
r_c = 0.2
realizable = true
blocked = [{ rectangle = { lower = [0.1, 0.3], upper = [0.4, 0.6] } }]
[dynamics]
dt = 0.05
duration = 2.0
damping = 1.0
walls = { k = 100.0, margin = 0.05, edges = [[true, false], [true, true]] }
[starts]
[[starts.group]]
name = "low"
share = 3
box = { lower = [-0.9, -0.9], upper = [-0.7, 0.2] }
[[starts.group]]
name = "high"
points = [[-0.8, 0.7], [0.25, 0.45]]
[[forces]]
kind = "constant"
force = [1.0, 0.0]
[[forces]]
kind = "noise"
std = 0.1
[evaluate]
particles = 8
[[evaluate.success]]
name = "out"
group = "low"
kind = "any_of"
tests = [{ kind = "exit", edge = "q0_upper", center = 0.0, halfwidth = 0.5 },
         { kind = "final_position", target = [0.8, 0.0], radius = 0.3 }]
[[evaluate.success]]
name = "bin"
group = "high"
kind = "stay_in"
lower = [-1.0, 0.5]
upper = [1.0, 1.0]
[[evaluate.share]]
name = "exits"
min = 0.3
test = { kind = "exit", edge = "q0_upper", center = 0.0, halfwidth = 1.0 }
[[evaluate.scenario]]
name = "still"
duration = 1.0
[[evaluate.scenario.forces]]
kind = "noise"
std = 0.05
[[evaluate.scenario.success]]
kind = "stay_in"
lower = [-1.0, -1.0]
upper = [0.0, 1.0]
[train]
iterations = 2
particles = 4
"""

#: A problem file (particles gather at a point) and its malformed versions, for the rows above.
GOOD_PROBLEM = _helpers.gather_problem(name=None, iterations=2, train_particles=4)
PROBLEM_FILES = {
    "good.toml": GOOD_PROBLEM,
    "good2.toml": GOOD_PROBLEM.replace("damping = 1.0", "damping = 2.0"),
    "notes.toml": "a user's notes, not TOML\n",
    "format2.toml": GOOD_PROBLEM.replace("format = 1", "format = 2"),
    "colour.toml": 'colour = "red"\n' + GOOD_PROBLEM,
    "nodynamics.toml": GOOD_PROBLEM.replace("[dynamics]\ndt = 0.05\nduration = 2.0\ndamping = 1.0\n", ""),
    "baddt.toml": GOOD_PROBLEM.replace("dt = 0.05", "dt = -0.05"),
    "happiness.toml": GOOD_PROBLEM.replace('kind = "final_position"\ntarget = [0.3, -0.2]\n[evaluate]',
                                           'kind = "happiness"\n[evaluate]'),
    "shortpoint.toml": GOOD_PROBLEM.replace("target = [0.3, -0.2]\n[evaluate]", "target = [0.3]\n[evaluate]"),
    "custom.toml": GOOD_PROBLEM.replace('kind = "final_position"\ntarget = [0.3, -0.2]\n[evaluate]',
                                        'kind = "custom"\nobject = "no_such_module_here:thing"\n[evaluate]'),
    "late.toml": GOOD_PROBLEM.replace('[[evaluate.success]]\nkind = "final_position"',
                                      '[[evaluate.success]]\nkind = "position_at"\ntime = 5.0'),
    "nosuccess.toml": GOOD_PROBLEM.split("[[evaluate.success]]")[0] + "[train]\niterations = 2\n",
    "unstable.toml": GOOD_PROBLEM.replace("damping = 1.0", "damping = 1.0\nwalls = { k = 1e5, margin = 0.05 }"),
    "groupvelocity.toml": GOOD_PROBLEM.replace(
        "[starts]\nbox = { lower = [-0.8, -0.8], upper = [0.8, 0.8] }",
        '[starts]\nvelocity = [1.0, 0.0]\n[[starts.group]]\nname = "all"\n'
        'box = { lower = [-0.8, -0.8], upper = [0.8, 0.8] }'),
    "startsoutside.toml": GOOD_PROBLEM.replace("box = { lower = [-0.8, -0.8], upper = [0.8, 0.8] }",
                                               "box = { lower = [1.5, -0.8], upper = [1.8, 0.8] }"),
    "groups.toml": GROUPS_PROBLEM,
}

#: A small valid device file (a pin in a plate's hole, on a plane) and the faults made of it:
#: name -> (text replaced, by).
DEVICE = """format = 1
[[part]]
motion = "translation"
direction = [1.0, 0.0]
shapes = [{ circle = { center = [0.0, 0.0], radius = 0.1 } }]
[[part]]
motion = "translation"
direction = [0.0, 1.0]
shapes = [{ rectangle = { lower = [-1.0, -1.0], upper = [1.0, 1.0] }, minus = [{ circle = { center = [0.0, 0.0], radius = 0.5 } }] }]
[cspace]
lower = [-0.5, -0.5]
upper = [0.5, 0.5]
shape = [21, 21]
[energy]
v = 1e-4
r_c = 0.1
springs = [{ axis = 1, k = 1.0, center = 0.0 }]
[dynamics]
mass = [1.0, 1.0]
damping = [1.0, 1.0]
walls = { k = 100.0, margin = 0.01, edges = [[true, true], [true, true]] }
[start]
q = [0.0, 0.0]
"""
BAD_DEVICES = {
    "noformat": ("format = 1\n", ""),
    "format2": ("format = 1", "format = 2"),
    "colour": ("format = 1\n", "format = 1\ncolour = \"red\"\n"),
    "onepart": ("[[part]]\nmotion = \"translation\"\ndirection = [1.0, 0.0]\n"
                "shapes = [{ circle = { center = [0.0, 0.0], radius = 0.1 } }]\n", ""),
    "motion": ("motion = \"translation\"", "motion = \"screw\""),
    "pivot": ("direction = [1.0, 0.0]", "direction = [1.0, 0.0]\npivot = [0.0, 0.0]"),
    "drumless": ("motion = \"translation\"\ndirection = [0.0, 1.0]", "motion = \"drum\""),
    "drumzero": ("motion = \"translation\"\ndirection = [0.0, 1.0]", "motion = \"drum\"\nradius = 0.0"),
    "drumdir": ("motion = \"translation\"\ndirection = [0.0, 1.0]", "motion = \"drum\"\nradius = 1.0\ndirection = [0.0, 1.0]"),
    "ellipse": ("{ rectangle = { lower = [-1.0, -1.0], upper = [1.0, 1.0] }", "{ ellipse = { a = 1.0 }"),
    "radius": ("radius = 0.1", "radius = -0.1"),
    "bowtie": ("minus = [{ circle = { center = [0.0, 0.0], radius = 0.5 } }]",
               "minus = [{ polygon = [[0.0, 0.0], [0.3, 0.3], [0.3, 0.0], [0.0, 0.1]] }]"),
    "bowtie0": ("minus = [{ circle = { center = [0.0, 0.0], radius = 0.5 } }]",
                "minus = [{ polygon = [[0.0, 0.0], [0.2, 0.2], [0.2, 0.0], [0.0, 0.2]] }]"),
    "empty": ("minus = [{ circle = { center = [0.0, 0.0], radius = 0.5 } }]",
              "minus = [{ rectangle = { lower = [-2.0, -2.0], upper = [2.0, 2.0] } }]"),
    "grid": ("shape = [21, 21]", "shape = [21, 1]"),
    "upper": ("upper = [0.5, 0.5]", "upper = [-0.7, 0.5]"),
    "spring": ("axis = 1", "axis = 3"),
    "rmin": ("r_c = 0.1", "r_c = 0.1\nr_min = 0.2"),
    "mass": ("mass = [1.0, 1.0]", "mass = [0, 1.0]"),
    "walls": ("edges = [[true, true], [true, true]]", "edges = [true, true]"),
    "start": ("q = [0.0, 0.0]", "q = [\"zero\", 0.0]"),
    "analysis": ("[start]", "[analysis]\nkind = \"catapult\"\n[start]"),
    "startblocked": ("q = [0.0, 0.0]", "q = [0.45, 0.0]"),
    "startout": ("q = [0.0, 0.0]", "q = [0.0, 5.0]"),
    "blocked": ("radius = 0.5 }", "radius = 0.05 }"),
    "tolerance": ("[energy]", "[geometry]\ntolerance = 10\n[energy]"),
    "drumspan": ("motion = \"translation\"\ndirection = [0.0, 1.0]", "motion = \"drum\"\nradius = 0.1"),
    "margin": ("margin = 0.01", "margin = 5.0"),
    "rcsmall": ("r_c = 0.1", "r_c = 0.01"),
    "realizedkey": ("[start]", "[realized]\ndesign = \"sha256:0\"\nseed = 1\n[start]"),
    "realizeddesign": ("[start]", "[realized]\ndesign = 12\n[start]"),
}
#: Devices whose C-space is a straight free channel along q1 (the plate's hole made a slot for the
#: pin, with no spring or walls on q1: a drive along it runs free to the grid's edge, in well under
#: the 3 s after which progress lines start; an r_min of its own keeps the barrier's stable step
#: large on the fine grid): name -> the replacements that make it.
FREE_Q1 = (("springs = [{ axis = 1, k = 1.0, center = 0.0 }]", "springs = []"),
           ("edges = [[true, true], [true, true]]", "edges = [[true, true], [false, false]]"))
CHANNELS = {
    "narrow": (("{ circle = { center = [0.0, 0.0], radius = 0.5 } }]", "{ rectangle = { lower = [-0.15, -2.0], "
                "upper = [0.15, 2.0] } }]"), ("lower = [-0.5, -0.5]\nupper = [0.5, 0.5]\nshape = [21, 21]",
                "lower = [-0.5, -1.0]\nupper = [0.5, 1.0]\nshape = [21, 41]"), ("r_c = 0.1", "r_c = 0.05"), *FREE_Q1),
    "slot": (("{ circle = { center = [0.0, 0.0], radius = 0.5 } }]", "{ rectangle = { lower = [-0.13, -2.0], "
              "upper = [0.13, 2.0] } }]"), ("lower = [-0.5, -0.5]\nupper = [0.5, 0.5]\nshape = [21, 21]",
              "lower = [-0.5, -1.0]\nupper = [0.5, 1.0]\nshape = [21, 41]"), ("r_c = 0.1", "r_c = 0.1\nr_min = 0.02"),
             *FREE_Q1),
}

def _steep_case() -> dict:
    """A valid case whose grid has two neighbouring nodes at +-1e308: its curvature is beyond float64."""
    case = load_case(CASE)
    values = np.array(case["values"], dtype=np.float64)
    values[1, 1], values[2, 2] = 1e308, -1e308
    return dict(case, values=values)


def make_assets(folder: Path) -> Path:
    """The files every row's folder starts with, made once into ``folder``."""
    shutil.copy(CASE, folder / "case.npz")
    shutil.copy(VECTORS / BAD_CASE["case"], folder / "bad.case.npz")
    write_result(run_case(load_case(CASE)), folder / "result.npz")
    assert cli.main(["design", "funnel", "--smoke", "--quiet", "--out", str(folder / "design.npz")]) == 0
    assert cli.main(["design", "oscillator", "--smoke", "--quiet", "--out", str(folder / "osc.npz")]) == 0
    for name, text in PROBLEM_FILES.items():
        (folder / name).write_text(text)
    assert cli.main(["design", str(folder / "good.toml"), "--quiet", "--out", str(folder / "problem.npz")]) == 0
    assert cli.main(["design", str(folder / "groups.toml"), "--quiet", "--out", str(folder / "groups.npz")]) == 0
    assert cli.main(["design", str(folder / "groups.toml"), "--quiet", "--seed", "1",
                     "--out", str(folder / "groups1.npz")]) == 0
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert cli.main(["realize", str(folder / "groups.npz"), "--as", "contact", "--particles", "4",
                         "--out", str(folder / "gparts")]) == 0
    (folder / "text.npz").write_text("values = [[0, 1], [1, 0]]\nmode = dynamic\n")
    (folder / "notes.txt").write_text("a user's own notes\n")
    (folder / "b-scaling.png").write_bytes(b"a plot the user keeps")
    (folder / "sub").mkdir()
    (folder / "sub" / "keep.txt").write_text("kept\n")
    (folder / "ro").mkdir()
    save_case(folder / "huge-wall.case.npz", **dict(load_case(WALL_CASE), wall_k=np.float64(1e308)))
    save_case(folder / "steep.case.npz", **_steep_case())
    for fuzzed in FUZZ_CASES.glob("*.case.npz"):
        shutil.copy(fuzzed, folder / fuzzed.name)
    (folder / "tiny.toml").write_text(TINY_SWEEP)
    (folder / "sub" / "motion_law.csv").write_text("q_in,q_out\n0,0\n")
    (folder / "sub.toml").mkdir()
    (folder / "parts").mkdir()
    (folder / "parts" / "device.toml").write_text("# a user's own device file\n")
    (folder / "sub2").mkdir()
    (folder / "sub2" / "heightfield.stl").write_text("solid a user's own mesh\n")
    (folder / "dev.toml").write_text(DEVICE)
    shutil.copy(ROOT / "examples" / "devices" / "geneva4.toml", folder / "geneva4.toml")
    (folder / "broken.toml").write_text("format = 1\n[cspace\n")
    for name, (old, new) in BAD_DEVICES.items():
        assert old in DEVICE, name
        (folder / f"dev-{name}.toml").write_text(DEVICE.replace(old, new, 1))
    for name, changes in CHANNELS.items():
        text = DEVICE
        for old, new in changes:
            assert old in text, name
            text = text.replace(old, new, 1)
        (folder / f"dev-{name}.toml").write_text(text)
    return folder


def workspace(assets: Path, root: Path, fault: Fault) -> Path:
    work = root / fault.id
    shutil.copytree(assets, work)
    os.chmod(work / "ro", stat.S_IRUSR | stat.S_IXUSR)
    return work


def snapshot(folder: Path) -> dict:
    """Every file and folder under ``folder`` (hidden ones too): path -> bytes (None for a folder)."""
    out = {}
    for path in sorted(folder.rglob("*")):
        out[str(path.relative_to(folder))] = None if path.is_dir() else path.read_bytes()
    return out


class Outcome(NamedTuple):
    status: int
    out: str
    err: str
    before: dict
    after: dict


def argv_of(row) -> list:
    return shlex.split(row.argv.replace("{python}", shlex.quote(sys.executable)))


def run_python_m(fault: Fault, work: Path, prefix: list = ()) -> Outcome:
    """``fault``'s row as ``python -m pes_ref ARGV``, a new interpreter (after ``prefix``, a command
    that runs it)."""
    before = snapshot(work)
    proc = subprocess.run([*prefix, sys.executable, "-m", "pes_ref", *argv_of(fault)], cwd=work, env=ENV,
                          capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)
    return Outcome(proc.returncode, proc.stdout, proc.stderr, before, snapshot(work))


def run_row(fault: Fault, work: Path) -> Outcome:
    """``fault``'s row in a process forked from one that has imported the command line
    (``tests/_forked.py``); one that needs root's file permissions dropped as :func:`run_python_m`."""
    if getattr(fault, "needs_permissions", False):
        return run_python_m(fault, work, UNPRIVILEGED)
    before = snapshot(work)
    out, err = work.parent / f"{work.name}.stdout", work.parent / f"{work.name}.stderr"
    status = _forked.run(argv_of(fault), work, ENV, out, err, timeout=120)
    return Outcome(status, out.read_text(), err.read_text(), before, snapshot(work))


def run_rows(rows, assets: Path, root: Path, workers: int = 4, run=run_row) -> dict:
    """Every row of ``rows``, run in parallel, each in a folder of its own under ``root``: id -> Outcome."""
    works = {r.id: workspace(assets, root, r) for r in rows}
    try:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            futures = {r.id: pool.submit(run, r, works[r.id]) for r in rows}
            return {rid: fut.result() for rid, fut in futures.items()}
    finally:
        for work in works.values():
            os.chmod(work / "ro", stat.S_IRWXU)


def check_fault(fault: Fault, got: Outcome) -> None:
    """A refused run: one ``error:`` line with the row's tokens, nothing on stdout, the folder as it
    was. Progress lines before it are not compared (:func:`_helpers.without_progress`)."""
    assert "Traceback" not in got.err, got.err
    assert got.after == got.before, changes(got.before, got.after)
    assert got.status == fault.status, got.err
    err = _helpers.without_progress(got.err)
    assert err.startswith("error: ") and err.count("\n") == 1, got.err
    line = err.strip()
    for token in fault.tokens:
        assert token in line, f"{token!r} is not in {line!r}"
    for word in fault.absent:
        assert word not in line, f"{word!r} is in {line!r}"
    assert ".tmp" not in line, line                # no temporary file's name
    assert got.out == "", got.out                  # nothing meaningless returned


def changes(before: dict, after: dict) -> str:
    added = sorted(set(after) - set(before))
    lost = sorted(set(before) - set(after))
    changed = sorted(k for k in set(before) & set(after) if before[k] != after[k])
    return f"added {added}, lost {lost}, changed {changed}"


class Works(NamedTuple):
    """A run that must succeed (a row whose fault was a crash or a refusal of valid input):
    exit 0, no traceback and no ``error:`` line, every token on stdout, and of the folder's
    files only those under ``made`` added (none changed or lost)."""

    id: str
    argv: str
    tokens: tuple
    made: tuple = ()


def check_works(row: Works, got: Outcome) -> None:
    """The run of ``row`` succeeded as :class:`Works` says."""
    assert "Traceback" not in got.err and "error:" not in got.err, got.err
    assert got.status == cli.EXIT_OK, got.err
    for token in row.tokens:
        assert token in got.out, f"{token!r} is not in {got.out!r}"
    kept = {k: v for k, v in got.before.items() if got.after.get(k) != v}
    assert not kept, f"changed or lost: {sorted(kept)}"
    added = {k.split("/")[0] for k in set(got.after) - set(got.before)}
    assert added <= set(row.made), f"left {sorted(added - set(row.made))}"


def works_table(rows: list):
    """A table of :class:`Works` rows as pytest sees it, as :func:`fault_table` gives one of refusals."""
    import pytest

    @pytest.fixture(scope="module")
    def worked(fault_assets, tmp_path_factory):
        return run_rows(rows, fault_assets, tmp_path_factory.mktemp("works"), workers=2)

    @pytest.mark.parametrize("row", rows, ids=[r.id for r in rows])
    def test_works(row, worked):
        check_works(row, worked[row.id])

    return worked, test_works


class Warned(NamedTuple):
    """A run that succeeds but whose figures mean something else than they say: exit 0,
    its figures on stdout, exactly one line ``warning: ...`` holding ``tokens`` on stderr."""

    id: str
    argv: str
    tokens: tuple



#: A sweep of one tiny run (the design command's --smoke preset).
TINY_SWEEP = '''description = "tiny"
kind = "funnel"
eval_seeds = [12345]
eval_particles = 8

[base]
smoke = true

[[variants]]
name = "a"
lr = 0.002
'''


def _result_whole(work: Path, before: dict) -> None:
    result = np.load(work / "out.npz")
    assert {"x", "v", "energy", "loss"} <= set(result.files)


def _design(status: str, least: int, most: int):
    def check(work: Path, before: dict) -> None:
        from pes_ref.synthesis import load_design
        state = load_design(work / "new.npz")
        assert state.status == status and least <= state.iteration <= most, (state.status, state.iteration)
    return check


def _vectors_whole_or_absent(work: Path, before: dict) -> None:
    if (work / "vw").exists():
        manifest = json.loads((work / "vw" / "manifest.json").read_text())
        assert all((work / "vw" / e["case"]).exists() for e in manifest["vectors"])


def _sweep_whole_or_absent(work: Path, before: dict) -> None:
    if (work / "sw").exists():
        assert (work / "sw" / "results.csv").read_text().count("\n") >= 2


def _bench_whole_or_absent(work: Path, before: dict) -> None:
    if (work / "bench.json").exists():
        json.loads((work / "bench.json").read_text())


def _parts_whole_or_absent(work: Path, before: dict) -> None:
    if (work / "rp").exists():
        from pes_ref.devices.device_file import load_device
        assert load_device(work / "rp" / "device.toml").name == "design_contact"
        assert (work / "rp" / "parts.png").read_bytes()[:4] == b"\x89PNG"


class Piped(NamedTuple):
    """A command whose ``closed`` stream(s) (``stdout``, ``stderr`` or ``both``) go into a
    pipe whose reader has gone; ``made`` names the files it may leave and ``check`` what
    they must hold (whole, never half-written; a design saved, never 'running')."""

    id: str
    argv: str
    closed: str
    made: tuple = ()
    check: Callable | None = None


def run_piped(row: Piped, work: Path) -> Outcome:
    read, write = os.pipe()
    os.close(read)                          # the reader is gone before the command writes at all
    streams = {name: write if row.closed in (name, "both") else subprocess.PIPE for name in ("stdout", "stderr")}
    before = snapshot(work)
    try:
        proc = subprocess.run([sys.executable, "-m", "pes_ref", *argv_of(row)], cwd=work, env=ENV, text=True,
                              timeout=300, stdin=subprocess.DEVNULL, **streams)
    finally:
        os.close(write)
    return Outcome(proc.returncode, proc.stdout or "", proc.stderr or "", before, snapshot(work))


def fault_table(rows: list):
    """One command's table as pytest sees it: ``outcomes, test_fault = fault_table(FAULTS)`` in a
    ``tests/cli/test_faults_<command>.py`` gives the module its fixture (every row run once, in
    parallel, each in a folder of its own) and its test (each row refused as :func:`check_fault` says)."""
    import pytest

    @pytest.fixture(scope="module")
    def outcomes(fault_assets, tmp_path_factory):
        return run_rows(rows, fault_assets, tmp_path_factory.mktemp("faults"))

    @pytest.mark.parametrize("fault", rows, ids=[f.id for f in rows])
    def test_fault(fault, outcomes):
        check_fault(fault, outcomes[fault.id])

    return outcomes, test_fault
