"""
# From a device file to a part you can make

This page runs `pes_ref` from end to end, the way a designer would at the command line:

1. a device file: two parts, each with one degree of freedom (a 4-slot Geneva drive);
2. `analyze` drives its crank and follows its wheel, on the potential energy surface and on
   the parts in rigid contact (pymunk), with the motion law drawn;
3. a problem file states a device to design: a latch that loads, holds and fires;
4. `design` finds its surface with the default plan, printing its progress, and `evaluate`
   draws its held-out particles;
5. `realize` turns the design into parts: a plate and a pin, as a device file, DXF and STL;
6. `evaluate --realized ... --engine rigid` runs the design's own evaluation on those parts
   in rigid contact.

Every command is run here as you would type it (`python -m pes_ref ...`), in a scratch
folder; its output follows it. With `PES_REF_TUTORIAL=smoke` in the environment the same
walk runs at a tiny size (the test suite does that).
"""

# %%
# ## Setting up
# A scratch folder for the files the commands write, and a helper that runs one command,
# prints it and what it printed, and stops the page if the command fails.
import os
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

import matplotlib.image as mpimg
import matplotlib.pyplot as plt

import pes_ref

SMOKE = os.environ.get("PES_REF_TUTORIAL") == "smoke"
ROOT = Path(pes_ref.__file__).resolve().parent.parent          # the repository: its examples/
WORK = Path(tempfile.mkdtemp(prefix="pes_ref_tutorial_"))


def pes_ref_cmd(*args: str) -> None:
    """Run ``python -m pes_ref ARGS`` in WORK; print the command, then what it printed on stdout
    and stderr in the order it printed it (one stream, as a terminal shows them)."""
    print("$ python -m pes_ref " + " ".join(shlex.quote(a) for a in args))
    proc = subprocess.run([sys.executable, "-m", "pes_ref", *args], cwd=WORK, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True,
                          env=dict(os.environ, PYTHONPATH=str(ROOT), PYTHONUNBUFFERED="1"))
    print(proc.stdout.rstrip("\n"))
    if proc.returncode != 0:
        raise SystemExit(f"the command failed with exit status {proc.returncode}")


def show(png: Path, title: str) -> None:
    """Draw a PNG a command wrote, so that it appears on this page."""
    image = mpimg.imread(png)
    fig, ax = plt.subplots(figsize=(9, 9 * image.shape[0] / image.shape[1]))
    ax.imshow(image)
    ax.set_title(title)
    ax.axis("off")
    plt.show()


# %%
# ## 1. A device file
# A device file describes two rigid parts completely (`docs/devices.md`): their shapes
# (polygons, circles, rectangles, with cut-outs), how each moves (a rotation about a pivot,
# a translation, a drum), the grid of their configuration space, eq. (1)'s barrier, springs,
# masses and damping. Here is the shipped 4-slot Geneva drive, its first part in full:
geneva = ROOT / "examples" / "devices" / "geneva4.toml"
text = geneva.read_text()
print(text[:text.index("[[part]]", text.index("[[part]]") + 1)])

# %%
# ## 2. Drive it, on the surface and on the rigid parts
# `analyze` applies a constant torque to the crank (`--drive 0 --load 1`) and follows the
# wheel. `--engine both` runs the drive twice: on the potential energy surface (eq. (1) of the
# distance to blocked configurations) and on the parts themselves in rigid contact (pymunk),
# and prints the two side by side with their difference. The wheel turns a quarter turn per
# crank turn on both: `advance_per_cycle` is -pi/2.
shape = ["--shape", "192,96"] if SMOKE else []
pes_ref_cmd("analyze", str(geneva), "--drive", "0", "--load", "1", "--engine", "both", "--cycles", "2",
            *shape, "--plot", "geneva.png")
show(WORK / "geneva.png", "the Geneva's motion law on both engines")

# %%
# ## 3. A problem file
# A problem file states what a design must do (`docs/problems.md`): the surface's grid, the
# dynamics, where particles start, the forces in phases, and the success tests a held-out
# particle must pass. The shipped `latch_contact` is a latch (load it by a push along q0,
# hold it, fire it by a push along q1) whose surface is always eq. (1) of a blocked shape,
# so that it can be made as a plate and a pin. Its first tables:
from pes_ref.synthesis.problem.problem_file import shipped_problem  # noqa: E402

problem = Path(shipped_problem("latch_contact")).read_text()
print(problem[problem.index("format"):problem.index("[[forces]]")])

# %%
# ## 4. Design it, and look at the design
# `design` runs the default plan (coarse to fine, validated on particles of its own, stopped
# early at its target) and prints a progress line every few seconds; Ctrl-C saves the run,
# and `--resume` continues it. `evaluate` runs held-out particles (a seed the design never
# saw) and draws their paths: green where a particle passed every test, red where it did not.
smoke = ["--smoke"] if SMOKE else []
pes_ref_cmd("design", "latch_contact", *smoke, "--progress", "5", "--out", "latch.npz")
particles = ["--particles", "20"] if SMOKE else []
pes_ref_cmd("evaluate", "latch.npz", "--seed", "12345", *particles, "--plot", "latch_plot")
show(next((WORK / "latch_plot").glob("*.png")), "held-out particles on the design")

# %%
# ## 5. Realize it as parts
# `realize --as contact` cuts the design's blocked region out of a plate that slides along q1,
# with a pin that slides along q0: a device file of its own, the plate as DXF (for a laser
# cutter) and STL, and a drawing of the parts with the pin at three moments of one path.
pes_ref_cmd("realize", "latch.npz", "--as", "contact", "--out", "latch_parts", *particles)
show(WORK / "latch_parts" / "parts.png", "the latch as a plate and a pin")

# %%
# ## 6. Check the parts in rigid contact
# The last check runs the design's own held-out evaluation (the same starts, pushes and noise
# draws) on the parts rebuilt from their device file, in rigid contact: what a machined plate
# and pin would do. Each figure is printed for the design and for the parts.
pes_ref_cmd("evaluate", "latch.npz", "--realized", "latch_parts/device.toml", "--engine", "rigid",
            "--seed", "12345", *particles)
