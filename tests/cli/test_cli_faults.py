"""The fault suite of the command line: every subcommand, every fault a user can cause.

Each row runs ``python -m pes_ref ARGV`` for real (a subprocess, in a folder of its own
holding a case, an invalid case, a result, a design, a plain-text file named ``.npz``, a
user's notes and a subfolder) and checks that the command

- exits with the expected status (2: refused) and prints no traceback,
- prints exactly one line ``error: ...`` on stderr naming the argument or flag and the
  bad value (every token of the row is in it), and nothing on stdout,
- leaves the folder as it was: every file there before is there after with the same
  bytes, and no file (not even a hidden temporary one) is added.

The rows run in parallel on a small thread pool (each is a process of its own); every
refusal comes before any computing, so the whole table takes seconds. Rows that need a
read-only folder run without the capability that lets root write anywhere (``setpriv``),
so that they run, and mean something, as root too.

Three more tables: :data:`WARNINGS` (runs that succeed but whose figures mean something
else than they say: one ``warning:`` line), :data:`CLOSED_PIPES` (every command with its
output going into a pipe its reader has closed: the one rule of
:func:`pes_ref.cli.common.watch_pipes`) and :data:`INTERRUPTED_IMPORTS` (Ctrl-C while the
command line is still being imported).
"""
from __future__ import annotations

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
import pytest

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


#: Every subcommand's faults. Paths are relative to the row's own folder (see :func:`_workspace`).
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
    # ------------------------------------------------------------------ analyze ratchet
    Fault("ratchet-torque-negative", "analyze ratchet --smoke --torque -1", ("--torque", "-1")),
    Fault("ratchet-torque-text", "analyze ratchet --smoke --torque strong", ("--torque", "'strong'")),
    Fault("ratchet-duration-zero", "analyze ratchet --smoke --duration 0", ("--duration", "0")),
    Fault("ratchet-duration-nan", "analyze ratchet --smoke --duration nan", ("--duration", "nan")),
    Fault("ratchet-duration-too-long-for-memory", "analyze ratchet --smoke --duration 1e9",
          ("--duration = 1e+09 (500000000000 steps of dt 0.002)", "GiB", "available; reduce --duration")),
    Fault("ratchet-search-tol-zero", "analyze ratchet --smoke --search-tol 0", ("--search-tol", "0")),
    Fault("ratchet-search-tol-below-float", "analyze ratchet --smoke --search-tol 1e-300",
          ("--search-tol = 1e-300 is finer than float64 can resolve", "--search-tol >= 2e-12")),
    Fault("ratchet-misspelled-option", "analyze ratchet --smoke --torqe 2",
          ("pes_ref analyze ratchet: unrecognized arguments: --torqe 2", "(see pes_ref analyze ratchet --help)")),
    Fault("ratchet-search-hi-too-low", "analyze ratchet --smoke --search-hi 0.01", ("--search-hi", "0.01")),
    Fault("ratchet-unknown-option", "analyze ratchet --smoke --bogus", ("--bogus",)),
    Fault("analyze-no-device", "analyze", ("DEVICE",)),
    Fault("analyze-unknown-device", "analyze catapult", ("'catapult'",)),
    # ------------------------------------------------------------------ analyze dartgun
    Fault("dartgun-reload-force-zero", "analyze dartgun --smoke --reload-force 0", ("--reload-force", "0")),
    Fault("dartgun-reload-time-negative", "analyze dartgun --smoke --reload-time -1", ("--reload-time", "-1")),
    Fault("dartgun-trigger-forces-text", "analyze dartgun --smoke --trigger-forces 10,x", ("--trigger-forces", "'x'")),
    Fault("dartgun-trigger-forces-empty", "analyze dartgun --smoke --trigger-forces ,", ("--trigger-forces", "','")),
    Fault("dartgun-trigger-forces-empty-entry", "analyze dartgun --smoke --trigger-forces 10,,20",
          ("--trigger-forces", "'10,,20'", "an empty entry")),
    Fault("dartgun-search-tol-below-float", "analyze dartgun --smoke --search-tol 1e-14",
          ("--search-tol = 1e-14 is finer than float64",)),
    Fault("dartgun-trigger-forces-negative", "analyze dartgun --smoke --trigger-forces=-5",
          ("--trigger-forces", "-5")),
    Fault("dartgun-fire-time-zero", "analyze dartgun --smoke --fire-time 0", ("--fire-time", "0")),
    Fault("dartgun-search-hi-too-low", "analyze dartgun --smoke --search-hi 1", ("--search-hi", "1")),
    Fault("dartgun-unknown-option", "analyze dartgun --bogus", ("--bogus",)),
    # ------------------------------------------------------------------ analyze DEVICE.toml (a device file)
    Fault("device-missing-file", "analyze nothing.toml --drive 0 --load 1", ("device file nothing.toml does not exist",)),
    Fault("device-file-is-a-folder", "analyze sub.toml --drive 0 --load 1", ("device file sub.toml is a folder",)),
    Fault("device-not-toml", "analyze broken.toml --drive 0 --load 1", ("broken.toml", "not valid TOML")),
    Fault("device-format-missing", "analyze dev-noformat.toml --drive 0 --load 1", ("dev-noformat.toml: format: missing",)),
    Fault("device-format-other", "analyze dev-format2.toml --drive 0 --load 1",
          ("dev-format2.toml: format:", "format 1", "format = 2")),
    Fault("device-unknown-top-key", "analyze dev-colour.toml --drive 0 --load 1", ("dev-colour.toml: colour: unknown key",)),
    Fault("device-one-part", "analyze dev-onepart.toml --drive 0 --load 1", ("part: expected exactly two [[part]] tables",)),
    Fault("device-bad-motion", "analyze dev-motion.toml --drive 0 --load 1", ("part[0].motion", "'screw'")),
    Fault("device-pivot-on-translation", "analyze dev-pivot.toml --drive 0 --load 1",
          ("part[0].pivot: a translating part has a direction",)),
    Fault("device-drum-no-radius", "analyze dev-drumless.toml --drive 0 --load 1", ("part[1].radius: missing",)),
    Fault("device-drum-radius-zero", "analyze dev-drumzero.toml --drive 0 --load 1",
          ("part[1].radius: expected a number > 0, got 0",)),
    Fault("device-drum-with-direction", "analyze dev-drumdir.toml --drive 0 --load 1",
          ("part[1].direction: a drum has a radius, not a direction",)),
    Fault("device-unknown-shape", "analyze dev-ellipse.toml --drive 0 --load 1", ("part[1].shapes[0].ellipse: unknown key",)),
    Fault("device-radius-negative", "analyze dev-radius.toml --drive 0 --load 1",
          ("part[0].shapes[0].circle.radius: expected a number > 0, got -0.1",)),
    Fault("device-polygon-crossing", "analyze dev-bowtie.toml --drive 0 --load 1",
          ("part[1].shapes[0].minus[0].polygon", "simple polygon")),
    Fault("device-cut-leaves-nothing", "analyze dev-empty.toml --drive 0 --load 1", ("part[1].shapes", "leave nothing")),
    Fault("device-shape-one", "analyze dev-grid.toml --drive 0 --load 1", ("cspace.shape[1]: expected an integer >= 2, got 1",)),
    Fault("device-upper-below-lower", "analyze dev-upper.toml --drive 0 --load 1", ("cspace.upper[0]: expected upper > lower",)),
    Fault("device-spring-axis", "analyze dev-spring.toml --drive 0 --load 1", ("energy.springs[0].axis: expected 0 or 1, got 3",)),
    Fault("device-r-min-above-r-c", "analyze dev-rmin.toml --drive 0 --load 1", ("energy.r_min: expected r_min < r_c",)),
    Fault("device-mass-zero", "analyze dev-mass.toml --drive 0 --load 1", ("dynamics.mass[0]: expected a number > 0, got 0",)),
    Fault("device-walls-edges", "analyze dev-walls.toml --drive 0 --load 1",
          ("dynamics.walls.edges", "[[lower0, upper0]", "got [true, true]")),
    Fault("device-start-text", "analyze dev-start.toml --drive 0 --load 1", ("start.q[0]: expected a finite number, got 'zero'",)),
    Fault("device-analysis-kind", "analyze dev-analysis.toml --drive 0 --load 1", ("analysis.kind", "'catapult'")),
    Fault("device-drive-two", "analyze dev.toml --drive 2 --load 1", ("--drive must be 0 or 1, got 2",)),
    Fault("device-drive-text", "analyze dev.toml --drive x --load 1", ("--drive", "'x'")),
    Fault("device-drive-missing", "analyze dev.toml --load 1", ("--drive",)),
    Fault("device-load-zero", "analyze dev.toml --drive 0 --load 0", ("--load must be non-zero",)),
    Fault("device-load-nan", "analyze dev.toml --drive 0 --load nan", ("--load", "nan")),
    Fault("device-cycles-translation", "analyze dev.toml --drive 0 --load 1 --cycles 2",
          ("--cycles counts turns of a periodic input", "q0 is not periodic")),
    Fault("device-cycles-zero", "analyze dev.toml --drive 0 --load 1 --cycles 0", ("--cycles must be an integer >= 1, got 0",)),
    Fault("device-start-one-number", "analyze dev.toml --drive 0 --load 1 --start 0.1", ("--start", "'0.1'")),
    Fault("device-start-outside", "analyze dev.toml --drive 0 --load 1 --start 9,0", ("--start q0 = 9 is outside the grid",)),
    Fault("device-threshold-negative", "analyze dev.toml --drive 0 --load 1 --threshold -1", ("--threshold", "-1")),
    Fault("device-shape-one-cli", "analyze dev.toml --drive 0 --load 1 --shape 1,5", ("--shape", "'1,5'")),
    Fault("device-mode-unknown", "analyze dev.toml --drive 0 --load 1 --mode fast", ("--mode", "'fast'")),
    Fault("device-json-exists", "analyze dev.toml --drive 0 --load 1 --json notes.txt", ("notes.txt", "exists")),
    Fault("device-plot-extension", "analyze dev.toml --drive 0 --load 1 --plot law.txt", ("--plot law.txt", ".png")),
    Fault("device-out-under-a-file", "analyze dev.toml --drive 0 --load 1 --out text.npz/law", ("text.npz", "not a folder")),
    Fault("device-out-law-exists", "analyze dev.toml --drive 0 --load 1 --out sub", ("sub/motion_law.csv", "exists")),
    # ------------------------------------------------------------------ design
    Fault("design-particles-zero", "design funnel --smoke --out new.npz --particles 0", ("--particles", "0")),
    Fault("design-particles-negative", "design funnel --smoke --out new.npz --particles -2",
          ("--particles must be >= 1", "-2")),
    Fault("design-particles-float", "design funnel --smoke --out new.npz --particles 2.5", ("--particles", "'2.5'")),
    Fault("design-lr-negative", "design funnel --smoke --out new.npz --lr -1", ("--lr must be > 0", "-1")),
    Fault("design-lr-nan", "design funnel --smoke --out new.npz --lr nan", ("--lr", "nan")),
    Fault("design-lr-final-zero", "design funnel --smoke --out new.npz --lr-final 0", ("--lr-final must be > 0", "0")),
    Fault("design-clip-negative", "design funnel --smoke --out new.npz --clip -1", ("--clip must be > 0", "-1")),
    Fault("design-iterations-negative", "design funnel --smoke --out new.npz --iterations -3",
          ("--iterations must be >= 1, got -3",)),
    Fault("design-iterations-zero", "design funnel --smoke --out new.npz --iterations 0",
          ("--iterations must be >= 1, got 0",)),
    Fault("design-seed-negative", "design funnel --smoke --out new.npz --seed -1", ("--seed must be >= 0", "-1")),
    Fault("design-set-dt-zero", "design funnel --smoke --out new.npz --set dt=0", ("--set dt must be > 0, got 0",)),
    Fault("design-set-dt-negative", "design funnel --smoke --out new.npz --set dt=-0.01",
          ("--set dt must be > 0, got -0.01",)),
    Fault("design-set-width-zero", "design funnel --smoke --out new.npz --set width=0",
          ("--set width must be > 0, got 0",), absent=("upper", "lower")),
    Fault("design-set-omega-zero", "design oscillator --smoke --out new.npz --set omega=0",
          ("--set omega must be > 0, got 0",)),
    Fault("design-set-torque-max-below-min", "design oscillator --smoke --out new.npz --set torque_max=0.1",
          ("--set torque_max must be >= --set torque_min = 0.5, got 0.1",)),
    Fault("design-grid-too-large-for-memory", "design funnel --out new.npz --set grid=100000",
          ("--set grid = 100000 makes a surface of 100000 x 100000 nodes", "GiB", "reduce --set grid")),
    Fault("design-smoke-grid-too-large-for-memory", "design funnel --smoke --out new.npz --set grid=100000",
          ("--set grid = 100000", "GiB")),
    Fault("design-stage-grid-too-large-for-memory", "design funnel --out new.npz --stages 0:25,10:100000",
          ("--stages = 100000 makes a surface of 100000 x 100000 nodes", "reduce --stages")),
    Fault("design-set-n-steps-negative", "design funnel --smoke --out new.npz --set n_steps=-4",
          ("--set n_steps", "-4")),
    Fault("design-particles-too-many-for-memory", "design funnel --smoke --out new.npz --particles 100000000",
          ("--set n_steps = 60 with --particles = 100000000", "GiB", "reduce --set n_steps or --particles")),
    Fault("design-stage-too-long-for-memory", "design oscillator --plan eq6 --out new.npz --particles 30000000",
          ("--stages of 1000 steps with --particles = 30000000", "reduce --stages or --particles")),
    Fault("design-resume-too-many-for-memory", "design funnel --resume design.npz --out new.npz --particles 100000000",
          ("--particles = 100000000", "GiB")),
    Fault("design-set-grid-one", "design funnel --smoke --out new.npz --set grid=1", ("--set grid", "1")),
    Fault("design-set-grid-float", "design funnel --smoke --out new.npz --set grid=2.5", ("--set 'grid=2.5'",)),
    Fault("design-set-unknown", "design funnel --smoke --out new.npz --set colour=red", ("--set 'colour=red'",)),
    Fault("design-set-no-value", "design funnel --smoke --out new.npz --set dt", ("--set 'dt'", "NAME=VALUE")),
    Fault("design-stages-bad", "design funnel --smoke --out new.npz --stages 0-25", ("--stages '0-25'",)),
    Fault("design-stages-late-start", "design funnel --smoke --out new.npz --stages 5:10", ("--stages", "(5, 10")),
    Fault("design-stages-grid-one", "design funnel --smoke --out new.npz --stages 0:1", ("--stages", "(0, 1")),
    Fault("design-optimizer-unknown", "design funnel --smoke --out new.npz --optimizer sgd", ("--optimizer", "'sgd'")),
    Fault("design-plan-funnel", "design funnel --smoke --out new.npz --plan eq6",
          ("--plan eq6", "oscillator")),
    Fault("design-progress-nan", "design funnel --smoke --out new.npz --progress nan", ("--progress", "nan")),
    Fault("design-out-exists", "design funnel --smoke --out design.npz", ("design.npz", "exists")),
    Fault("design-out-no-folder", "design funnel --smoke --out nodir/new.npz", ("nodir", "does not exist")),
    Fault("design-out-under-a-file", "design funnel --smoke --out text.npz/new.npz", ("text.npz", "not a folder")),
    Fault("design-out-is-a-folder", "design funnel --smoke --out sub", ("cannot write sub", "is a folder")),
    Fault("design-resume-missing", "design funnel --resume nothing.npz", ("design file nothing.npz does not exist",)),
    Fault("design-resume-text", "design funnel --resume text.npz", ("text.npz", "is not an .npz archive")),
    Fault("design-resume-case", "design funnel --resume case.npz", ("case.npz is an oracle case file", "oracle")),
    Fault("design-resume-other-kind", "design oscillator --resume design.npz --out new.npz",
          ("a funnel design, not an oscillator design",)),
    Fault("design-resume-other-seed", "design funnel --resume design.npz --seed 5 --out new.npz",
          ("--seed 5 differs from the resumed run's (0)",)),
    Fault("design-resume-other-backend", "design funnel --resume design.npz --backend numpy --out new.npz",
          ("--backend numpy differs from the resumed run's numba",)),
    Fault("design-backend-unknown", "design funnel --smoke --out new.npz --backend cuda", ("--backend", "'cuda'")),
    Fault("design-unknown-kind", "design catapult", ("'catapult'",)),
    Fault("design-unknown-option", "design funnel --smoke --out new.npz --bogus", ("--bogus",)),
    Fault("design-read-only-folder", "design funnel --smoke --out ro/new.npz", ("ro", "not writable"),
          needs_permissions=True),
    # ------------------------------------------------------------------ design PROBLEM.toml (docs/problems.md)
    Fault("problem-missing", "design nothing.toml --out new.npz", ("problem file nothing.toml does not exist",)),
    Fault("problem-a-folder", "design sub --out new.npz", ("problem file sub is a folder",)),
    Fault("problem-not-toml", "design notes.toml --out new.npz", ("notes.toml: not valid TOML",)),
    Fault("problem-format", "design format2.toml --out new.npz",
          ("format2.toml: format: this pes_ref reads problem files of format 1, got 2",)),
    Fault("problem-unknown-key", "design colour.toml --out new.npz", ("colour.toml: colour: unknown key",)),
    Fault("problem-missing-section", "design nodynamics.toml --out new.npz",
          ("nodynamics.toml: dynamics: missing",)),
    Fault("problem-bad-value", "design baddt.toml --out new.npz",
          ("baddt.toml: dynamics.dt: expected a number > 0, got -0.05",)),
    Fault("problem-unknown-term", "design happiness.toml --out new.npz",
          ("happiness.toml: objective[0].kind: expected one of", "got 'happiness'")),
    Fault("problem-term-key", "design shortpoint.toml --out new.npz",
          ("shortpoint.toml: objective[0].target: expected a list of two values, got [0.3]",)),
    Fault("problem-custom-import", "design custom.toml --out new.npz",
          ("custom.toml: objective[0].object: cannot import it", "no_such_module_here")),
    Fault("problem-time-after-end", "design late.toml --out new.npz",
          ("late.toml: evaluate.success[0].time: 5 is after the end of the run (2, dynamics)",)),
    Fault("problem-no-success-test", "design nosuccess.toml --out new.npz",
          ("nosuccess.toml: evaluate.success: missing",)),
    Fault("problem-unstable", "design unstable.toml --out new.npz", ("unstable.toml: dynamics.dt:", "stability limit")),
    Fault("problem-set-bad-value", "design good.toml --out new.npz --set dynamics.damping=-1",
          ("good.toml: dynamics.damping: expected a number >= 0, got -1",)),
    Fault("problem-set-unknown-key", "design good.toml --out new.npz --set dynamics.colour=1",
          ("good.toml: dynamics.colour: unknown key",)),
    Fault("problem-set-no-value", "design good.toml --out new.npz --set dynamics.dt",
          ("--set 'dynamics.dt'", "NAME=VALUE")),
    Fault("problem-set-no-entry", "design good.toml --out new.npz --set objective.3.weight=1",
          ("objective.3.weight: objective has entries 0 to 0",)),
    Fault("problem-plan", "design good.toml --out new.npz --plan eq6", ("--plan eq6", "only the oscillator")),
    Fault("problem-polish-option", "design good.toml --out new.npz --evaluations 5", ("--evaluations", "no polish")),
    Fault("problem-grid-too-large-for-memory", "design good.toml --out new.npz --set 'surface.shape=[100000, 100000]'",
          ("good.toml: surface.shape: shape = [100000, 100000] makes a surface of 100000 x 100000 nodes", "GiB")),
    Fault("problem-too-many-for-memory", "design good.toml --out new.npz --particles 100000000",
          ("dynamics.duration / dt = 40 with --particles = 100000000", "GiB")),
    Fault("problem-resume-changed", "design good2.toml --resume problem.npz --out new.npz",
          ("the problem file good2.toml differs from the one the design was made with: dynamics.damping = 2.0 "
           "there, 1.0 in the design's problem",)),
    Fault("problem-resume-set", "design --resume problem.npz --out new.npz --set dynamics.damping=2.0",
          ("--set: a resumed design keeps its problem; dynamics.damping = 2.0, 1.0 in the design's problem",)),
    Fault("problem-resume-built-in", "design funnel --resume problem.npz --out new.npz",
          ("the resume file is a problem design, not a funnel design",)),
    Fault("design-nothing", "design --out new.npz", ("give what to design", "--resume")),
    # ------------------------------------------------------------------ evaluate
    Fault("evaluate-missing", "evaluate nothing.npz", ("design file nothing.npz does not exist",)),
    Fault("evaluate-folder", "evaluate sub", ("design file sub is a folder",)),
    Fault("evaluate-text-named-npz", "evaluate text.npz", ("text.npz", "is not an .npz archive")),
    Fault("evaluate-case-file", "evaluate case.npz", ("case.npz is an oracle case file", "oracle")),
    Fault("evaluate-result-file", "evaluate result.npz", ("result.npz is an oracle result file",)),
    Fault("evaluate-particles-zero", "evaluate design.npz --particles 0", ("--particles must be >= 1", "0")),
    Fault("evaluate-particles-negative", "evaluate design.npz --particles -3", ("--particles must be >= 1", "-3")),
    Fault("evaluate-seed-negative", "evaluate design.npz --seed -1", ("--seed must be >= 0", "-1")),
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
    Fault("realize-heightfield-pin-radius", "realize design.npz --as heightfield --out newparts --pin-radius 0.1",
          ("--pin-radius goes with --as contact, not --as heightfield",)),
    Fault("realize-contact-g", "realize design.npz --as contact --out newparts --g 9.81",
          ("--g goes with --as heightfield, not --as contact",)),
    Fault("realize-heightfield-existing", "realize design.npz --as heightfield --out sub2",
          ("STL file", "sub2/heightfield.stl", "exists already")),
    Fault("realize-heightfield-problem-design", "realize problem.npz --as heightfield --out newparts",
          ("--as heightfield checks funnel designs", "'problem' design")),
    Fault("realize-unknown-option", "realize design.npz --as contact --out newparts --bogus", ("--bogus",)),
    Fault("realize-clearance-negative", "realize design.npz --as contact --out newparts --clearance -0.01",
          ("--clearance must be >= 0", "-0.01")),
    Fault("realize-clearance-too-large", "realize design.npz --as contact --out newparts --clearance 5",
          ("--pin-radius + --clearance must be below half the design's shortest side",)),
    Fault("realize-restitution-above-one", "realize design.npz --as contact --out newparts --restitution 1.5",
          ("--restitution must be in [0, 1]", "1.5")),
    Fault("realize-restitution-heightfield", "realize design.npz --as heightfield --out newparts --restitution 0.5",
          ("--restitution goes with --as contact, not --as heightfield",)),
    Fault("evaluate-engine-unknown", "evaluate design.npz --engine soft", ("--engine 'soft'", "surface, rigid, both")),
    Fault("evaluate-engine-without-realized", "evaluate design.npz --engine rigid", ("--engine rigid", "--realized")),
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
    # ------------------------------------------------------------------ bench
    Fault("bench-out-no-folder", "bench --quick --out nodir/b.json", ("nodir", "does not exist")),
    Fault("bench-out-under-a-file", "bench --quick --out text.npz/b.json", ("text.npz", "not a folder")),
    Fault("bench-out-exists", "bench --quick --out notes.txt", ("notes.txt", "exists")),
    Fault("bench-plot-exists", "bench --quick --out b.json", ("b-scaling.png", "exists")),
    Fault("bench-out-is-a-folder", "bench --quick --out sub", ("cannot write sub", "is a folder")),
    Fault("bench-unknown-option", "bench --quick --bogus", ("--bogus",)),
    # ------------------------------------------------------------------ sweep
    Fault("sweep-missing-file", "sweep nothing.toml", ("sweep file nothing.toml does not exist",)),
    Fault("sweep-not-toml", "sweep notes.txt", ("notes.txt", "not valid TOML")),
    Fault("sweep-workers-zero", "sweep notes.txt --workers 0", ("--workers must be >= 1", "0")),
    Fault("sweep-progress-negative", "sweep notes.txt --progress -1", ("--progress must be > 0", "-1")),
    Fault("sweep-unknown-option", "sweep notes.txt --bogus", ("--bogus",)),
    # ------------------------------------------------------------------ the top level
    Fault("no-command", "", ("COMMAND",)),
    Fault("unknown-command", "frobnicate", ("'frobnicate'",)),
]

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
}

#: The commands the suite must cover: every one of the command line (tested below).
COVERED = {f.argv.split()[0] for f in FAULTS if f.argv} | {"analyze ratchet", "analyze dartgun", "analyze DEVICE.toml"}


def _steep_case() -> dict:
    """A valid case whose grid has two neighbouring nodes at +-1e308: its curvature is beyond float64."""
    case = load_case(CASE)
    values = np.array(case["values"], dtype=np.float64)
    values[1, 1], values[2, 2] = 1e308, -1e308
    return dict(case, values=values)


@pytest.fixture(scope="module")
def assets(tmp_path_factory):
    """The files every row's folder starts with, made once."""
    folder = tmp_path_factory.mktemp("assets")
    shutil.copy(CASE, folder / "case.npz")
    shutil.copy(VECTORS / BAD_CASE["case"], folder / "bad.case.npz")
    write_result(run_case(load_case(CASE)), folder / "result.npz")
    assert cli.main(["design", "funnel", "--smoke", "--quiet", "--out", str(folder / "design.npz")]) == 0
    assert cli.main(["design", "oscillator", "--smoke", "--quiet", "--out", str(folder / "osc.npz")]) == 0
    for name, text in PROBLEM_FILES.items():
        (folder / name).write_text(text)
    assert cli.main(["design", str(folder / "good.toml"), "--quiet", "--out", str(folder / "problem.npz")]) == 0
    (folder / "text.npz").write_text("values = [[0, 1], [1, 0]]\nmode = dynamic\n")
    (folder / "notes.txt").write_text("a user's own notes\n")
    (folder / "b-scaling.png").write_bytes(b"a plot the user keeps")
    (folder / "sub").mkdir()
    (folder / "sub" / "keep.txt").write_text("kept\n")
    (folder / "ro").mkdir()
    save_case(folder / "huge-wall.case.npz", **dict(load_case(WALL_CASE), wall_k=np.float64(1e308)))
    save_case(folder / "steep.case.npz", **_steep_case())
    (folder / "tiny.toml").write_text(TINY_SWEEP)
    (folder / "sub" / "motion_law.csv").write_text("q_in,q_out\n0,0\n")
    (folder / "sub.toml").mkdir()
    (folder / "parts").mkdir()
    (folder / "parts" / "device.toml").write_text("# a user's own device file\n")
    (folder / "sub2").mkdir()
    (folder / "sub2" / "heightfield.stl").write_text("solid a user's own mesh\n")
    (folder / "dev.toml").write_text(DEVICE)
    (folder / "broken.toml").write_text("format = 1\n[cspace\n")
    for name, (old, new) in BAD_DEVICES.items():
        assert old in DEVICE, name
        (folder / f"dev-{name}.toml").write_text(DEVICE.replace(old, new, 1))
    return folder


def _workspace(assets: Path, root: Path, fault: Fault) -> Path:
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


def _argv(row) -> list:
    return shlex.split(row.argv.replace("{python}", shlex.quote(sys.executable)))


def _run(fault: Fault, work: Path) -> Outcome:
    before = snapshot(work)
    prefix = UNPRIVILEGED if getattr(fault, "needs_permissions", False) else []
    proc = subprocess.run([*prefix, sys.executable, "-m", "pes_ref", *_argv(fault)], cwd=work, env=ENV,
                          capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)
    return Outcome(proc.returncode, proc.stdout, proc.stderr, before, snapshot(work))


@pytest.fixture(scope="module")
def outcomes(assets, tmp_path_factory):
    """Every row, run in parallel (each in a folder of its own)."""
    root = tmp_path_factory.mktemp("faults")
    rows = FAULTS
    works = {f.id: _workspace(assets, root, f) for f in rows}
    with ThreadPoolExecutor(max_workers=4) as pool:
        futures = {f.id: pool.submit(_run, f, works[f.id]) for f in rows}
        results = {fid: fut.result() for fid, fut in futures.items()}
    for work in works.values():
        os.chmod(work / "ro", stat.S_IRWXU)
    return results


def test_the_ids_are_unique():
    assert len({f.id for f in FAULTS}) == len(FAULTS)


def test_every_command_is_covered():
    commands = set(cli.COMMANDS)
    devices = {f"analyze {a.split()[1]}" for a in (f.argv for f in FAULTS) if a.startswith("analyze ")
               and len(a.split()) > 1}
    assert commands <= COVERED
    assert {"analyze ratchet", "analyze dartgun"} <= devices
    assert any(d.endswith(".toml") for d in devices)


@pytest.mark.parametrize("fault", FAULTS, ids=[f.id for f in FAULTS])
def test_fault(fault, outcomes):
    got = outcomes[fault.id]
    assert "Traceback" not in got.err, got.err
    assert got.after == got.before, _changes(got.before, got.after)
    assert got.status == fault.status, got.err
    assert got.err.startswith("error: ") and got.err.count("\n") == 1, got.err
    line = got.err.strip()
    for token in fault.tokens:
        assert token in line, f"{token!r} is not in {line!r}"
    for word in fault.absent:
        assert word not in line, f"{word!r} is in {line!r}"
    assert ".tmp" not in line, line                # no temporary file's name
    assert got.out == "", got.out                  # nothing meaningless returned


def _changes(before: dict, after: dict) -> str:
    added = sorted(set(after) - set(before))
    lost = sorted(set(before) - set(after))
    changed = sorted(k for k in set(before) & set(after) if before[k] != after[k])
    return f"added {added}, lost {lost}, changed {changed}"


def test_the_assets_are_what_the_rows_say(assets):
    """The rows rely on these: a valid case, a design, a result, an invalid case keyed 'mass'."""
    from pes_ref.synthesis import load_design
    assert load_design(assets / "design.npz").kind == "funnel" and load_design(assets / "design.npz").seed == 0
    assert sorted(load_case(assets / "case.npz")) == sorted(load_case(CASE))
    assert "x" in np.load(assets / "result.npz")


# =========================================================================== late refusals (a long case)

@pytest.fixture(scope="module")
def long_case(tmp_path_factory):
    """A case that computes for several seconds (2048 particles, 3000 steps)."""
    case = load_case(CASE)
    rng = np.random.default_rng(0)
    n, lower, upper = 2048, case["lower"], case["upper"]
    case.update(x0=lower + (upper - lower) * rng.uniform(0.2, 0.8, size=(n, 2)), v0=np.zeros((n, 2)),
                n_steps=np.int64(3000))
    path = tmp_path_factory.mktemp("long") / "long.case.npz"
    from pes_ref.oracle import save_case
    save_case(path, **case)
    return path


def _refused_at_once(long_case, result, capsys, monkeypatch):
    """Run ``oracle LONG RESULT`` in this process; return (seconds, stderr), watching that
    the case is never run."""
    import time

    from pes_ref.oracle import case as oracle_case
    runs = []
    run = oracle_case.run_case
    monkeypatch.setattr(oracle_case, "run_case", lambda *a, **k: runs.append(1) or run(*a, **k))
    t = time.perf_counter()
    code = cli.main(["oracle", str(long_case), str(result)])
    seconds = time.perf_counter() - t
    err = capsys.readouterr().err
    assert code == cli.EXIT_ERROR and not runs, err
    return seconds, err


@pytest.mark.parametrize("where", ["nodir/r.npz", "file.txt/r.npz"], ids=["no-folder", "under-a-file"])
def test_a_destination_that_cannot_be_written_is_refused_before_computing(where, long_case, tmp_path, capsys,
                                                                          monkeypatch):
    (tmp_path / "file.txt").write_text("a file")
    before = snapshot(tmp_path)
    seconds, err = _refused_at_once(long_case, tmp_path / where, capsys, monkeypatch)
    assert seconds < 0.5, f"refused after {seconds:.1f} s"
    assert err.startswith("error: cannot write ") and err.count("\n") == 1
    assert ".tmp" not in err and "/." not in err               # no temporary file's name
    assert snapshot(tmp_path) == before


#: Runs the command line on its arguments and prints, last, how often the oracle ran a
#: case and how long the command took, in seconds.
_WATCH_RUNS = """
import sys, time
from pes_ref.oracle import case
runs = []
run = case.run_case
case.run_case = lambda *a, **k: runs.append(1) or run(*a, **k)
from pes_ref.cli import main
t = time.perf_counter()
code = main(sys.argv[1:])
print(len(runs), time.perf_counter() - t)
sys.exit(code)
"""


def test_a_read_only_folder_is_refused_before_computing(long_case, tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    os.chmod(ro, stat.S_IRUSR | stat.S_IXUSR)
    try:
        proc = subprocess.run([*UNPRIVILEGED, sys.executable, "-c", _WATCH_RUNS, "oracle", str(long_case),
                               str(ro / "r.npz")], capture_output=True, text=True, env=ENV, timeout=120)
    finally:
        os.chmod(ro, stat.S_IRWXU)
    runs, seconds = proc.stdout.split()
    assert proc.returncode == cli.EXIT_ERROR and runs == "0", proc.stderr
    assert float(seconds) < 0.5 and proc.stderr.count("\n") == 1 and "not writable" in proc.stderr
    assert ".tmp" not in proc.stderr and not os.listdir(ro)


def test_the_long_case_is_long(long_case):
    """What makes the two tests above mean something: the case takes seconds to run."""
    assert int(load_case(long_case)["n_steps"]) * load_case(long_case)["x0"].shape[0] >= 6_000_000


#: The rows where a file or folder to read is missing: every command says it in the same words.
MISSING = ["oracle-missing-case", "evaluate-missing", "design-resume-missing", "check-missing-program",
           "conformance-check-missing"]


def test_a_missing_input_is_said_the_same_way_by_every_command(outcomes):
    import re
    for fid in MISSING:
        line = outcomes[fid].err.strip()
        assert re.fullmatch(r"error: (case file|design file|--cmd: program|--check folder) "
                            r"(nothing\.npz|\./nothing\.sh|nodir) does not exist", line), (fid, line)


# =========================================================================== warnings

class Warned(NamedTuple):
    """A run that succeeds but whose figures mean something else than they say: exit 0,
    its figures on stdout, exactly one line ``warning: ...`` holding ``tokens`` on stderr."""

    id: str
    argv: str
    tokens: tuple


WARNINGS = [
    Warned("ratchet-torque-overwhelms-the-barrier", "analyze ratchet --smoke --torque 1e30",
           ("warning: the torque 1e+30 torque-unit exceeds", "barrier_torque_max", "overwhelms the barrier")),
    Warned("dartgun-reload-does-not-latch", "analyze dartgun --smoke --reload-force 1e12",
           ("warning: the reload with force 1e+12 did not latch", "reference latch")),
]


@pytest.fixture(scope="module")
def warned(assets, tmp_path_factory):
    root = tmp_path_factory.mktemp("warnings")
    with ThreadPoolExecutor(max_workers=2) as pool:
        futures = {w.id: pool.submit(_run, w, _workspace(assets, root, w)) for w in WARNINGS}
        return {wid: fut.result() for wid, fut in futures.items()}


@pytest.mark.parametrize("row", WARNINGS, ids=[w.id for w in WARNINGS])
def test_warning(row, warned):
    got = warned[row.id]
    assert got.status == cli.EXIT_OK and "Traceback" not in got.err, got.err
    assert got.err.startswith("warning: ") and got.err.count("\n") == 1, got.err
    for token in row.tokens:
        assert token in got.err, f"{token!r} is not in {got.err!r}"
    assert got.out and all(": " in line for line in got.out.splitlines()), got.out
    assert got.after == got.before, _changes(got.before, got.after)


# =========================================================================== closed pipes

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


CLOSED_PIPES = [
    Piped("oracle", "oracle case.npz out.npz", "stdout", ("out.npz",), _result_whole),
    Piped("oracle-head-0", "oracle case.npz out.npz", "both", ("out.npz",), _result_whole),
    Piped("check", "check --cmd '{python} -m pes_ref oracle {pairs}' --only plane-dynamic", "stdout"),
    Piped("check-progress", "check --cmd '{python} -m pes_ref oracle {pairs}' --no-vectors --random 2", "stderr"),
    Piped("conformance", "conformance --check", "stdout"),
    Piped("conformance-write", "conformance --write vw", "stdout", ("vw",), _vectors_whole_or_absent),
    Piped("analyze", "analyze ratchet --smoke", "stdout"),
    Piped("design", "design funnel --smoke --out new.npz", "stdout", ("new.npz",), _design("done", 6, 6)),
    Piped("design-progress", "design funnel --smoke --iterations 300 --progress 0 --out new.npz", "stderr",
          ("new.npz",), _design("interrupted", 1, 299)),
    Piped("design-head-1", "design funnel --smoke --iterations 300 --progress 0 --out new.npz", "both",
          ("new.npz",), _design("interrupted", 1, 299)),
    Piped("evaluate", "evaluate design.npz --particles 8", "stdout"),
    Piped("realize", "realize design.npz --as contact --out rp", "stdout", ("rp",), _parts_whole_or_absent),
    Piped("sweep", "sweep tiny.toml --out sw --workers 1", "stderr", ("sw",), _sweep_whole_or_absent),
    Piped("bench", "bench --quick --no-autodiff --out bench.json", "stdout", ("bench.json", "bench-scaling.png"),
          _bench_whole_or_absent),
]


def _run_piped(row: Piped, work: Path) -> Outcome:
    read, write = os.pipe()
    os.close(read)                          # the reader is gone before the command writes at all
    streams = {name: write if row.closed in (name, "both") else subprocess.PIPE for name in ("stdout", "stderr")}
    before = snapshot(work)
    try:
        proc = subprocess.run([sys.executable, "-m", "pes_ref", *_argv(row)], cwd=work, env=ENV, text=True,
                              timeout=300, stdin=subprocess.DEVNULL, **streams)
    finally:
        os.close(write)
    return Outcome(proc.returncode, proc.stdout or "", proc.stderr or "", before, snapshot(work))


@pytest.fixture(scope="module")
def piped(assets, tmp_path_factory):
    root = tmp_path_factory.mktemp("pipes")
    works = {p.id: _workspace(assets, root, p) for p in CLOSED_PIPES}
    with ThreadPoolExecutor(max_workers=4) as pool:
        futures = {p.id: pool.submit(_run_piped, p, works[p.id]) for p in CLOSED_PIPES}
        return {pid: (fut.result(), works[pid]) for pid, fut in futures.items()}


def test_every_command_is_tested_under_a_closed_pipe():
    assert {p.argv.split()[0] for p in CLOSED_PIPES} == set(cli.COMMANDS)


@pytest.mark.parametrize("row", CLOSED_PIPES, ids=[p.id for p in CLOSED_PIPES])
def test_closed_pipe(row, piped):
    """The one rule (pes_ref.cli.common.watch_pipes): the command stops as Ctrl-C stops it,
    keeps what it saved whole, says nothing more and exits 141."""
    got, work = piped[row.id]
    said = got.out + got.err                # what went to the stream that stayed open
    for word in ("Traceback", "Exception ignored", "error", "BrokenPipe"):
        assert word not in said, said
    assert got.status == cli.EXIT_PIPE, (got.status, said)
    unchanged = {k: v for k, v in got.before.items() if got.after.get(k) != v}
    assert not unchanged, f"changed or lost: {sorted(unchanged)}"
    added = {k.split("/")[0] for k in set(got.after) - set(got.before)}
    assert added <= set(row.made), f"left {sorted(added - set(row.made))}"
    if row.check is not None and added:
        row.check(work, got.before)
    if row.made and row.check is not None and row.check.__name__.startswith("_result"):
        assert "out.npz" in added                    # the result was written before the line that failed


# =========================================================================== Ctrl-C while importing

#: Runs ``python -m pes_ref ARGV`` as ``pes_ref.__main__`` does, with Ctrl-C arriving while
#: the module ``sys.argv[1]`` is being imported: raised as KeyboardInterrupt (``raise``), or
#: turned into an ImportError as a C extension's import may turn it (``lost``).
_INTERRUPT_IMPORT = """
import signal, sys
target, how = sys.argv[1], sys.argv[2]


class Interrupt:
    def find_spec(self, name, path=None, target_module=None):
        if name == target:
            sys.meta_path.remove(self)
            try:
                signal.raise_signal(signal.SIGINT)
            except KeyboardInterrupt:
                if how == "lost":
                    raise ImportError(name + ": an extension's import turned Ctrl-C into this") from None
                raise
        return None


sys.meta_path.insert(0, Interrupt())
sys.argv = ["pes_ref", *sys.argv[3:]]
from pes_ref.__main__ import run
sys.exit(run())
"""

#: (module being imported, how Ctrl-C arrives): from the command line's first module to the
#: libraries the chosen command imports.
INTERRUPTED_IMPORTS = [("pes_ref.cli", "raise"), ("argparse", "raise"), ("pes_ref.cli.design", "raise"),
                       ("numpy", "raise"), ("numpy", "lost"), ("pes_ref.synthesis", "raise"),
                       ("pes_ref.synthesis", "lost")]


@pytest.mark.parametrize("module, how", INTERRUPTED_IMPORTS, ids=[f"{m}-{h}" for m, h in INTERRUPTED_IMPORTS])
def test_ctrl_c_while_importing(module, how, tmp_path):
    proc = subprocess.run([sys.executable, "-c", _INTERRUPT_IMPORT, module, how, "design", "funnel", "--smoke",
                           "--out", str(tmp_path / "new.npz")], capture_output=True, text=True, env=ENV, timeout=120)
    assert (proc.returncode, proc.stderr, proc.stdout) == (cli.EXIT_INTERRUPTED, "interrupted\n", "")
    assert os.listdir(tmp_path) == []
