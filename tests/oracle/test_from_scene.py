"""pes_ref.oracle.case_from_scene: a Scene, its state and an objective written as a case
file and run by the oracle give what value_and_grad gives on the scene itself."""
import numpy as np
import pytest

import pes_ref as pr
from pes_ref import cli
from pes_ref.oracle import case_from_scene, read_npz, save_case

X0 = np.array([[0.3, 0.4], [0.6, 0.55], [0.45, 0.2]])
V0 = np.array([[0.5, 0.0], [-0.2, 0.3], [0.0, 0.1]])


def _surface(periodic):
    return pr.Surface(np.random.default_rng(2).uniform(0, 0.3, (6, 5)), (0.0, 0.0), (1.0, 1.2), periodic)


SCENES = {
    "effects": lambda: pr.Scene(_surface((False, False)), dt=0.02, n_steps=12, damping=(0.3, 0.1),
                                spring=pr.Spring((2.0, 1.0), (0.5, 0.6)),
                                walls=pr.Walls(k=50.0, margin=0.05, edges=[[True, True], [True, False]]),
                                effects=(pr.Constant((0.1, -0.2)), pr.Noise((0.3, 0.1), seed=4),
                                         pr.Window(pr.Constant((0.5, 0.0)), 0.05, 0.15),
                                         pr.PerParticle([[0.0, 0.1], [0.2, 0.0], [-0.1, -0.1]]))),
    "one-effect": lambda: pr.Scene(_surface((True, False)), dt=0.02, n_steps=8, mass=(1.5, 0.5),
                                   effects=pr.Constant((0.0, -0.5))),
    "quasistatic": lambda: pr.Scene(_surface((True, True)), dt=0.01, n_steps=10, mode="quasistatic",
                                    mobility=(0.04, 0.02), effects=(pr.Noise((0.2, 0.2), seed=1),)),
}
OBJECTIVES = {
    "effects": pr.Funnel(target=0.5, when="every_step"),
    "one-effect": pr.Oscillator(amplitude=0.3, omega=2.0),
    "quasistatic": pr.Funnel(target=0.4),
}


@pytest.mark.parametrize("name", SCENES)
def test_a_scene_written_as_a_case_runs_to_the_same_result(name, tmp_path):
    scene, objective = SCENES[name](), OBJECTIVES[name]
    v0 = None if scene.mode == "quasistatic" else V0
    save_case(tmp_path / "c.npz", **case_from_scene(scene, X0, v0, objective, regularization=1e-3))
    assert cli.main(["oracle", str(tmp_path / "c.npz"), str(tmp_path / "r.npz")]) == 0
    got = read_npz(tmp_path / "r.npz", what="result")
    # the oracle runs NumPy's loops (the compiled ones' grid gradient sums in another order)
    loss, grads, traj = pr.value_and_grad(scene, X0, v0, objective, regularization_weight=1e-3, backend="numpy")
    np.testing.assert_array_equal(got["x"], traj.x)
    np.testing.assert_array_equal(got["v"], traj.v)
    np.testing.assert_array_equal(got["loss"], loss)
    compared = [k for k in grads if k != "force"]
    assert {"values", "x0"} <= set(compared)
    for k in compared:
        np.testing.assert_array_equal(got["grad_" + k], grads[k], err_msg=k)


def test_the_force_a_scene_realizes_is_the_case_force():
    scene = SCENES["effects"]()
    case = case_from_scene(scene, X0, V0, OBJECTIVES["effects"])
    np.testing.assert_array_equal(case["force"], scene.schedule(len(X0)))
