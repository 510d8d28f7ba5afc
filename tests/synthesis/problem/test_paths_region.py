"""The region a smooth design's passing paths cover (pes_ref.synthesis.problem.paths_region)."""
from __future__ import annotations

import numpy as np
import pytest

from _helpers import drop_problem
from pes_ref.synthesis.problem import paths_region

shapely = pytest.importorskip("shapely")

def drop(edges="[[true, true], [false, true]]", center=0.0):
    return drop_problem(edges=edges, center=center)


def test_a_passing_path_is_cut_where_it_leaves_and_carried_straight_out():
    problem = drop()
    flat = np.zeros(problem.shape())
    (path,) = paths_region.passing_paths(problem, flat, seed=0, n_particles=1)
    inside = path[:-2]
    assert np.all(inside[:, 1] >= 0.0) and path[-2, 1] < 0.0         # up to its first state past the edge
    reach = paths_region.EXIT_REACH * problem.contact.r_c
    np.testing.assert_allclose(path[-1] - path[-2], [0.0, -reach], atol=1e-15)   # then straight out
    np.testing.assert_allclose(path[:, 0], 0.0, atol=1e-12)


def test_a_walled_edge_cuts_nothing_and_a_failing_particle_gives_no_path():
    walled = drop(edges="[[true, true], [true, true]]", center=0.0)
    flat = np.zeros(walled.shape())
    (path,) = paths_region.passing_paths(walled, flat, seed=0, n_particles=1)  # pressed past the soft wall
    assert path.min(axis=0)[1] < 0.0 and len(path) == walled.n_steps + 1         # and kept whole
    missed = drop(center=0.8)
    assert paths_region.passing_paths(missed, flat, seed=0, n_particles=1) == []


def test_the_region_holds_the_starts_the_held_box_and_the_bundle_not_a_stray_path_or_a_hole():
    problem = drop()
    r_c = problem.contact.r_c
    bundle = [np.array([[x, 1.9], [x, -0.2]]) for x in np.linspace(-0.1, 0.1, 11)]
    stray = [np.array([[0.7, 1.0], [0.7, 0.2]])]                      # one tube, narrower than the opening
    ring = [np.array([[-0.9, 1.2], [-0.3, 1.2], [-0.3, 0.6], [-0.9, 0.6], [-0.9, 1.2]]) + [[dx, dy]]
            for dx in np.linspace(-0.06, 0.06, 5) for dy in np.linspace(-0.06, 0.06, 5)]
    region = paths_region.free_region(problem, bundle + stray + ring)
    covers = lambda x, y: bool(shapely.contains_xy(region, x, y))          # noqa: E731
    assert covers(0.0, 1.0) and covers(0.0, 0.0)                            # the bundle, through the edge
    assert covers(0.95, 1.95) and covers(-0.95, 1.85)                       # the held box
    assert not covers(0.7, 0.6)                                             # the stray path opened away
    assert covers(-0.6, 0.9)                                                # the ring's hole filled
    assert not covers(0.5, 0.3) and not covers(-0.5, 0.1)
    grown = paths_region.START_BUFFER * r_c
    assert covers(0.0, 1.9 + 0.9 * grown)                                   # the start point, grown


def test_the_signed_distance_is_positive_inside_and_repeats_along_a_periodic_axis():
    problem = drop()
    box = shapely.box(-0.5, 0.5, 0.5, 1.5)
    d = paths_region.region_distance(problem, box, problem.shape())
    q0, q1 = problem.nodes(problem.shape(), 0), problem.nodes(problem.shape(), 1)
    x, y = np.meshgrid(q0, q1, indexing="ij")
    inside = (np.abs(x) < 0.5) & (np.abs(y - 1.0) < 0.5)
    exact_in = np.minimum(0.5 - np.abs(x), 0.5 - np.abs(y - 1.0))
    np.testing.assert_allclose(d[inside], exact_in[inside], atol=1e-12)
    assert np.all(d[~inside & ((np.abs(x) > 0.5 + 1e-9) | (np.abs(y - 1.0) > 0.5 + 1e-9))] < 0.0)
    ring = drop_problem(edges="[[false, false], [false, true]]", surface="shape = [20, 21]\nperiodic = [true, false]")
    strip = shapely.box(0.9, 0.5, 1.0, 1.5)                                 # at the right end of the period
    d = paths_region.region_distance(ring, strip, ring.shape())
    q0 = ring.nodes(ring.shape(), 0)
    j = int(np.argmin(np.abs(ring.nodes(ring.shape(), 1) - 1.0)))
    assert d[0, j] == pytest.approx(0.0)                                    # q0 = -1 is q0 = 1: on the edge
    assert d[1, j] == pytest.approx(-(q0[1] + 1.0))                         # the strip's copy one period left


def test_a_finished_design_from_paths_ends_on_its_shape_without_the_notch_gradient_steps_cut():
    problem = drop_problem(surface="shape = [81, 81]")
    assert problem.paths_start
    shape = problem.shape()
    channel = shapely.box(-0.5, -0.5, 0.5, 2.5)
    notch = shapely.box(0.45, 0.95, 0.7, 1.05)                              # 0.1 wide, narrower than 2 r_c
    values = problem.level_set.from_distance(
        paths_region.region_distance(problem, channel.union(notch), shape)) * problem.mask(shape)
    phi = lambda v, x, y: v[round((x + 1.0) / 0.025), round(y / 0.025)] + problem.contact.r_c   # noqa: E731
    assert phi(values, 0.625, 1.0) > 0.0                                    # the notch is free
    final = problem.final_values(values)
    assert phi(final, 0.625, 1.0) < 0.0                                     # and blocked once smoothed
    assert phi(final, 0.0, 1.0) > 0.0 and phi(final, 0.0, 0.0) > 0.0         # the channel, to the open edge
    assert phi(final, -0.8, 1.0) < 0.0 and phi(final, 0.8, 0.5) < 0.0
    drawn = drop_problem(contact="realizable = true\nblocked = [{ rectangle = { lower = [-1, 0], upper = [-0.5, 1] } }]")
    v = np.zeros(drawn.shape())
    assert drawn.final_values(v) is v                                       # a drawn start's design: as it is


def test_the_parts_of_a_design_from_paths_keep_eq1s_standoff_unless_the_file_states_a_clearance():
    from pes_ref.devices.cspace import apf_standoff
    from pes_ref.synthesis import kind_of
    problem = drop()
    c = problem.contact
    assert problem.parts_clearance == apf_standoff(1.0, c.v, c.r_c, c.r_min)          # the push of 1 down
    assert 0.0 < problem.parts_clearance < c.r_c
    assert kind_of(problem).realizable.parts(problem) == {"clearance": problem.parts_clearance}
    stated = drop_problem(contact="realizable = true\nclearance = 0.01\nrestitution = 0.5")
    assert kind_of(stated).realizable.parts(stated) == {"clearance": 0.01, "restitution": 0.5}
    drawn = drop_problem(contact="realizable = true\nblocked = [{ rectangle = { lower = [-1, 0], upper = [-0.5, 1] } }]")
    assert drawn.parts_clearance == 0.0
