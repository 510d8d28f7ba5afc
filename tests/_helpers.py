"""Small helpers shared by the unit tests (not a test module)."""
import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from pes_ref.core.runtime.progress import is_progress_line
from pes_ref.oracle.compare import relative_error
from pes_ref.oracle.tolerances import FD_RTOL
from pes_ref.testing.finite_differences import central_gradient
from pes_ref.testing.kinks import distance_to_kinks

def without_progress(err: str) -> str:
    """A command's stderr without its progress lines (:func:`pes_ref.core.runtime.progress.is_progress_line`),
    which is what a test compares: a command that may run long prints a progress line once it
    has run :data:`pes_ref.core.runtime.progress.LONG_RUN` seconds, so whether one is there depends on
    the machine's speed and load, never on the command's answer (docs/testing.md)."""
    return "".join(line for line in err.splitlines(keepends=True) if not is_progress_line(line.rstrip("\n")))


#: A dot-product test whose VJP side is below this carries no information.
NONTRIVIAL = 1e-8

TOPOLOGIES = {
    "plane": (False, False),
    "cylinder0": (True, False),
    "cylinder1": (False, True),
    "torus": (True, True),
}


def assert_dot(lhs: float, rhs: float) -> None:
    """The two sides of a dot-product (VJP) test agree to FD_RTOL, and are not trivially 0."""
    assert abs(rhs) > NONTRIVIAL, f"degenerate dot-product test: <J^T w, u> = {rhs!r}"
    assert abs(lhs - rhs) <= FD_RTOL * max(abs(lhs), abs(rhs)), f"<w, J u> = {lhs!r} but <J^T w, u> = {rhs!r}"


def kink_distance(field, x) -> float:
    """The smallest distance from any position in ``x`` (..., N, 2) to a kink of the
    force of ``field`` (the core's plain-array description of a scene, SPEC section 5):
    :func:`pes_ref.testing.kinks.distance_to_kinks` of its grid, walls and spring."""
    walls = None if field.walls is None else field.walls[1:]
    return distance_to_kinks(x, field.lower, field.h, field.values.shape, field.periodic, field.length,
                             walls=walls, spring=field.spring)


#: The repository (the folder of ``pes_ref``, ``validation``, ``figures``).
ROOT = Path(__file__).resolve().parents[1]


def load_script(path):
    """Import the script at ``path`` (under ``validation/``, say) as a module, from its
    path: nothing is put on ``sys.path``. It is registered in ``sys.modules`` under a
    name of its own (dataclasses look their module up there), once per run.

    Only for scripts that import nothing from their own folder."""
    path = Path(path).resolve()
    name = "_script_" + "_".join(path.relative_to(ROOT).with_suffix("").parts)
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        try:
            spec.loader.exec_module(module)
        except BaseException:
            del sys.modules[name]
            raise
    return sys.modules[name]


#: ``python -c`` code that runs ``argv[1]`` as ``python SCRIPT ARGS`` would (its folder
#: first on sys.path, as ``__main__``), with floating-point errors raising as
#: tests/conftest.py makes them in this process.
_RUN_STRICT = """import os, runpy, sys
import numpy
numpy.seterr(over="raise", invalid="raise", divide="raise", under="ignore")
script = sys.argv[1]
sys.argv = sys.argv[1:]
sys.path.insert(0, os.path.dirname(script))
runpy.run_path(script, run_name="__main__")
"""


def run_script(path, *args, timeout: float = 300) -> subprocess.CompletedProcess:
    """Run the script at ``path`` with ``args`` in a fresh Python (this interpreter, this
    checkout's ``pes_ref`` first), floating-point errors raising; stdout and stderr
    captured as text."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])),
               MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-c", _RUN_STRICT, str(path), *map(str, args)], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=timeout)


class GatherAt:
    """A user's own objective for problem files in tests (``custom = "_helpers:GATHER"``):
    ``sum_i |X_{T,i} - point|^2``, written as a user would."""

    def __init__(self, point):
        self.point = point

    def value_and_grad(self, x, v, t):
        import numpy as np
        gx = np.zeros_like(x)
        e = x[-1] - np.asarray(self.point)
        gx[-1] = 2 * e
        return float(np.sum(e * e)), gx, None


#: :class:`GatherAt` the point (0.3, -0.2).
GATHER = GatherAt((0.3, -0.2))


def gather_problem(*, name: str | None = "gather", walls: bool = False, noise: bool = False,
                   eval_particles: int = 12, radius: float = 0.3, iterations: int = 4,
                   train_particles: int = 6) -> str:
    """The text of a small problem file as a stranger writes it: particles gather at
    (0.3, -0.2) on an 8 x 8 plane (docs/problems.md); the keywords change its few settings."""
    return "\n".join(
        ["format = 1"] + ([f'name = "{name}"'] if name else []) +
        ["[surface]", "lower = [-1.0, -1.0]", "upper = [1.0, 1.0]", "shape = [8, 8]",
         "[dynamics]", "dt = 0.05", "duration = 2.0", "damping = 1.0"] +
        (["walls = { k = 100.0, margin = 0.05 }"] if walls else []) +
        ["[starts]", "box = { lower = [-0.8, -0.8], upper = [0.8, 0.8] }"] +
        (["[[forces]]", 'kind = "noise"', "std = 0.1"] if noise else []) +
        ["[[objective]]", 'kind = "final_position"', "target = [0.3, -0.2]",
         "[evaluate]", f"particles = {eval_particles}",
         "[[evaluate.success]]", 'kind = "final_position"', "target = [0.3, -0.2]", f"radius = {radius}",
         "[train]", f"iterations = {iterations}", f"particles = {train_particles}"]) + "\n"


class _Band:
    """A user's own success test for the problem-file tests: q0 ends in [0, 0.5]."""

    def passes(self, x, v, t):
        return (x[-1, :, 0] >= 0.0) & (x[-1, :, 0] <= 0.5)


class _BandWithCost(_Band):
    def cost(self, x, v, t, margin):
        e = x[-1, :, 0] - np.clip(x[-1, :, 0], 0.0, 0.5)
        gx = np.zeros_like(x)
        gx[-1, :, 0] = 2 * e
        return e * e, gx, None


class _Uncharged(_Band):
    """A test no particle of the tests' problems passes (q0 ends beyond 5) whose cost charges nothing."""

    def passes(self, x, v, t):
        return x[-1, :, 0] > 5.0

    def cost(self, x, v, t, margin):
        return np.zeros(x.shape[1]), None, None


BAND_TEST = _BandWithCost()
UNCHARGED_TEST = _Uncharged()
BAND_TEST_WITHOUT_COST = _Band()


def check_state_derivatives(objective, x, v, t):
    """``objective.value_and_grad(x, v, t)``'s derivatives against central differences, entry
    by entry (within FD_RTOL); returns the value."""
    value, gx, gv = objective.value_and_grad(x, v, t)
    gx = np.zeros_like(x) if gx is None else gx
    gv = np.zeros_like(v) if gv is None else gv
    fx = central_gradient(lambda z: objective.value_and_grad(z, v, t)[0], x)
    fv = central_gradient(lambda z: objective.value_and_grad(x, z, t)[0], v)
    assert relative_error(gx, fx) < FD_RTOL, (gx, fx)
    assert relative_error(gv, fv) < FD_RTOL, (gv, fv)
    return value


class _Raises:
    """A user's own success test that fails in both of its methods."""

    def passes(self, x, v, t):
        raise RuntimeError("boom")

    def cost(self, x, v, t, margin):
        raise ValueError("bang")


RAISES_TEST = _Raises()


#: A realizable problem file (``[surface.contact]`` without drawn shapes): particles dropped near the
#: top of a 2 x 2 plane under a push of 1 down leave its bottom edge, in the band ``center +- 0.3``
#: to pass; the held box is the top strip. The tests of a start made from paths fill it in.
DROP_TEXT = """format = 1
name = "drop"
[surface]
lower = [-1.0, 0.0]
upper = [1.0, 2.0]
{surface}
[surface.contact]
v = 1e-4
r_c = 0.1
{contact}
[[surface.hold]]
lower = [-1.0, 1.8]
upper = [1.0, 2.0]
[dynamics]
dt = {dt}
n_steps = {steps}
damping = 1.0
walls = {{ k = 100.0, margin = 0.05, edges = {edges} }}
[starts]
{starts}
[[forces]]
kind = "constant"
force = [0.0, -1.0]
[[forces]]
kind = "noise"
std = {noise}
[[evaluate.success]]
kind = "exit"
edge = "q1_lower"
center = {center}
halfwidth = 0.3
"""


def drop_problem(*, surface: str = "shape = [21, 21]", contact: str = "realizable = true", edges: str = "[[true, true], [false, true]]",
                 starts: str = "points = [[0.0, 1.9]]", noise: float = 0.0, center: float = 0.0, dt: float = 0.01,
                 steps: int = 300):
    """`DROP_TEXT` read as a problem (its bottom edge open unless ``edges`` says otherwise)."""
    from pes_ref.synthesis import problem_from_text
    return problem_from_text(DROP_TEXT.format(surface=surface, contact=contact, edges=edges, starts=starts, noise=noise,
                                              center=center, dt=dt, steps=steps))
