"""A scene, its initial state and an objective as a case of the interchange format.

[`case_from_scene`][pes_ref.oracle.from_scene.case_from_scene] is the inverse of
[`pes_ref.oracle.validate_case`][pes_ref.oracle.case.validate_case]: it turns
what a Python user builds (a [`pes_ref.Scene`][pes_ref.core.scene.Scene], ``x0``, ``v0``, an objective) into
the keys of docs/spec.md section 8, so the same run can be handed to another
implementation. The scene's external force effects (constant, per-particle, noise,
windows, schedules) are realized into the case's ``force`` array, exactly as
[`pes_ref.simulate`][pes_ref.core.scene.simulate] realizes them.

Examples
--------
>>> import numpy as np, pes_ref as pr
>>> from pes_ref.oracle import case_from_scene, validate_case
>>> surf = pr.Surface(np.zeros((4, 4)), lower=(0, 0), upper=(1, 1), periodic=(True, False))
>>> scene = pr.Scene(surf, dt=0.01, n_steps=5, damping=0.1)
>>> case = case_from_scene(scene, [[0.2, 0.5]], None, pr.Funnel(target=0.5))
>>> sorted(case)[:4]
['damping', 'dt', 'lower', 'mass']
>>> validate_case(case).grad_names
('values', 'x0', 'v0', 'force', 'mass', 'damping')
"""
from __future__ import annotations

import numpy as np

from pes_ref.core import checks
from pes_ref.core.objectives import Funnel, Oscillator, Quadratic
from pes_ref.core.scene import Scene

__all__ = ["case_from_scene"]

#: How each objective class becomes case keys: the objective's name and its parameters.
_OBJECTIVE_KEYS = {
    Funnel: lambda o: {"objective": "funnel", "target": o.target, "when": o.when},
    Oscillator: lambda o: {"objective": "oscillator", "amplitude": o.amplitude, "omega": o.omega},
    Quadratic: lambda o: {"objective": "quadratic", "wx": o.wx, "wv": o.wv, "xref": o.xref, "vref": o.vref},
}


def _objective_keys(objective) -> dict:
    to_keys = _OBJECTIVE_KEYS.get(type(objective))
    if to_keys is None:
        raise TypeError(f"objective must be one of {[c.__name__ for c in _OBJECTIVE_KEYS]} to be written as a "
                        f"case, got {type(objective).__name__}")
    return to_keys(objective)


def case_from_scene(scene: Scene, x0, v0, objective, *, regularization: float = 0.0) -> dict:
    """The case keys of a run (docs/spec.md section 8).

    Parameters
    ----------
    scene : Scene
        Bilinear interpolation and the paper's Verlet step (the case format has no key
        for the bicubic and GJF options).
    x0 : array_like (N, 2)
    v0 : array_like (N, 2) or None
        None: at rest.
    objective : Funnel, Oscillator or Quadratic
    regularization : float >= 0

    Returns
    -------
    dict of str -> ndarray
        Strings as 0-d unicode arrays; ready for [`pes_ref.oracle.save_case`][pes_ref.oracle.case.save_case].
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"scene must be a pes_ref.Scene, got {type(scene).__name__}")
    if scene.surface.interpolation != "bilinear":
        raise ValueError(f"interpolation={scene.surface.interpolation!r} has no case key; "
                         "the case format is bilinear only")
    if scene.integrator != "verlet":
        raise ValueError(f"integrator={scene.integrator!r} has no case key; the case format is verlet only")
    x0 = checks.as_float_array("x0", x0, shape=(None, 2))
    n = x0.shape[0]
    v0 = np.zeros((n, 2)) if v0 is None else checks.as_float_array("v0", v0, shape=(n, 2))
    s = scene.surface
    case = {
        "values": s.values, "lower": s.lower, "upper": s.upper, "periodic": np.array(s.periodic),
        "dt": scene.dt, "n_steps": np.int64(scene.n_steps), "mode": scene.mode, "t0": scene.t0,
        "mass": scene.mass, "damping": 0.0 if scene.damping is None else scene.damping,
        "x0": x0, "v0": v0,
    }
    if scene.mobility is not None:
        case["mobility"] = scene.mobility
    if scene.spring is not None:
        case["spring_k"], case["spring_center"] = scene.spring.k, scene.spring.center
    if scene.walls is not None:
        case["wall_k"], case["wall_margin"], case["walls"] = scene.walls.k, scene.walls.margin, scene.walls.edges
    schedule = scene.schedule(n)
    if schedule is not None:
        case["force"] = schedule
    case.update(_objective_keys(objective))
    case["regularization"] = checks.as_nonneg_float("regularization", regularization)
    return {k: (np.array(v) if isinstance(v, str) else np.asarray(v)) for k, v in case.items()}
