"""A realizable problem file that draws no shape starts from its smooth design's paths (engine.paths_start)."""
from __future__ import annotations

import numpy as np
import pytest

from _helpers import drop_problem
from pes_ref import synthesis
from pes_ref.synthesis import design_inputs, needs_paths_start, paths_start, start_design
from pes_ref.synthesis.engine import runs

pytest.importorskip("shapely")

DRAWN = 'blocked = [{ rectangle = { lower = [-1.0, 0.0], upper = [-0.5, 0.5] } }]'


def drop(contact="realizable = true"):
    """Particles dropped along the top, 0 < q0 < 0.6 at the bottom edge to pass."""
    return drop_problem(surface="shape = [16, 16]", contact=contact, dt=0.02, steps=150, noise=0.1, center=0.3,
                        starts="box = { lower = [-0.9, 1.9], upper = [0.9, 1.9] }")


@pytest.mark.parametrize("contact, needs", [("realizable = true", True), (f"realizable = true\n{DRAWN}", False),
                                            ("", False)])
def test_only_a_realizable_file_without_drawn_shapes_starts_from_paths(contact, needs):
    assert needs_paths_start(drop(contact)) is needs


def test_the_funnel_and_a_file_without_contact_draw_their_own_starts():
    assert not needs_paths_start(synthesis.FunnelProblem(realizable=True))
    plain = synthesis.with_sets(drop(), {"surface.contact": None})
    assert plain.contact is None
    assert not needs_paths_start(plain)


def test_the_start_is_the_same_to_the_bit_free_at_the_starts_and_blocked_where_no_path_goes():
    problem = drop()
    a, smooth = paths_start(problem, 3, 4)
    b, _ = paths_start(problem, 3, 4)
    np.testing.assert_array_equal(a, b)
    assert smooth.iteration == 4 and smooth.problem.level_set is None      # the smooth design: energies
    phi = a + problem.contact.r_c                                           # free where phi >= 0
    q0, q1 = (problem.nodes(problem.shape(), d) for d in (0, 1))
    top = np.abs(q1 - 1.9).argmin()
    assert np.all(phi[np.abs(q0) <= 0.9, top] >= 0.0)                        # every start is free
    assert phi[np.abs(q0 + 0.95).argmin(), np.abs(q1 - 0.1).argmin()] < 0.0  # far left of the band, low down
    other, _ = paths_start(problem, 4, 4)
    assert not np.array_equal(a, other)


def test_a_fresh_run_starts_there_and_a_resumed_one_does_not_make_it_again(monkeypatch):
    problem = drop()
    inputs = design_inputs(problem, {"iterations": 4})
    state = start_design(inputs, seed=3)
    np.testing.assert_array_equal(state.values, paths_start(problem, 3, 4)[0])

    def made_again(*args, **kwargs):
        raise AssertionError("a resumed run made its start again")
    monkeypatch.setattr(runs, "paths_start", made_again)
    assert start_design(inputs, seed=3, resume=state) is state


def test_new_design_alone_refuses_the_problem_and_names_start_design():
    with pytest.raises(ValueError, match=r"drop: a realizable design that draws no blocked shapes .*start_design"):
        synthesis.new_design(drop(), plan=synthesis.Plan(iterations=2, n_particles=4))


def test_a_stop_while_the_start_is_made_stops_the_run(monkeypatch):
    from pes_ref.synthesis.engine import paths_start as module

    def stopped(state, iterations, callback=None):
        state.status = "interrupted"
        return state
    monkeypatch.setattr(module, "run_stages", stopped)
    with pytest.raises(KeyboardInterrupt):
        paths_start(drop(), 3, 4)


def test_the_runs_memory_is_checked_before_the_start_is_made(monkeypatch):
    def refused(problem, plan, polish):
        raise ValueError("refused for its memory")

    def made(*args, **kwargs):
        raise AssertionError("the start was made before the memory check")
    monkeypatch.setattr(runs, "check_run_memory", refused)
    monkeypatch.setattr(runs, "paths_start", made)
    with pytest.raises(ValueError, match="refused for its memory"):
        start_design(design_inputs(drop(), {"iterations": 4}), seed=3)


@pytest.mark.parametrize("values, match", [(np.zeros((3, 3)), r"start_values.*shape"),
                                           (np.full((16, 16), np.nan), r"start_values.*finite")])
def test_a_start_given_to_new_design_is_the_problems_grid_of_finite_values(values, match):
    with pytest.raises(ValueError, match=match):
        synthesis.new_design(drop(), plan=synthesis.Plan(iterations=2, n_particles=4), start_values=values)
