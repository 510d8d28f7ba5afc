"""The stability refusal rule (docs/spec.md section 10) at the public boundary.

A scene whose step is past the explicit stability limit of its stiffest term is refused
by :func:`pes_ref.simulate` and :func:`pes_ref.value_and_grad` before anything runs, even
when its numbers would stay finite; ``allow_unstable=True`` runs it anyway. The terms are
taken one at a time, per axis: a spring ``k_d``, a wall ``k_w``, the grid's cross
curvature ``c``. Dynamic: refused iff ``dt sqrt(K / min m_d) > 2``; quasistatic: iff
``mobility_d K > 2``. A run of ``n_steps = 0`` takes no step and is never refused.
"""
from dataclasses import replace

import numpy as np
import pytest

import pes_ref as pr
from pes_ref.core import checks, stability
from pes_ref.testing import strategies as pst
from hypothesis import given

#: The grid ``C q0 q1`` sampled on [0, 1]^2 with 5 nodes per axis: every cell's cross
#: curvature is exactly C, and every second difference is 0.
C = 12.0
_NODES = np.linspace(0.0, 1.0, 5)


def _surface(values=None):
    return pr.Surface(np.zeros((5, 5)) if values is None else values, (0.0, 0.0), (1.0, 1.0), (False, False))


#: One stiff term each, with a mass per axis (so the axis matters): name -> (scene
#: keywords, the stiffest term's K and axis). The limit is 2 / sqrt(K / m_axis).
MASS = np.array([0.5, 2.0])
TERMS = {
    "spring": (dict(spring=pr.Spring([8.0, 2.0], [0.5, 0.5])), 8.0, 0),
    "wall": (dict(walls=pr.Walls(50.0, 0.1, [[False, False], [True, False]])), 50.0, 1),
    "grid curvature": (dict(surface=_surface(C * np.outer(_NODES, _NODES))), C, 0),
}


def _scene(term, mode, factor, n_steps=12):
    """The scene of ``term`` at ``factor`` times its stability limit (dt or mobility)."""
    kw, K, axis = TERMS[term]
    kw = dict(kw)
    surface = kw.pop("surface", _surface())
    if mode == "dynamic":
        return pr.Scene(surface, dt=factor * 2.0 / np.sqrt(K / MASS[axis]), n_steps=n_steps, mass=MASS, **kw)
    mobility = np.full(2, 1e-3)
    mobility[axis] = factor * 2.0 / K
    return pr.Scene(surface, dt=0.1, n_steps=n_steps, mode="quasistatic", mobility=mobility, mass=MASS, **kw)


X0 = np.array([[0.45, 0.5], [0.6, 0.85]])
V0 = np.array([[0.2, -0.1], [0.0, 0.3]])
KEY = {"dynamic": "dt", "quasistatic": "mobility"}


@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
@pytest.mark.parametrize("term", list(TERMS))
def test_just_inside_the_limit_runs(term, mode):
    scene = _scene(term, mode, 0.99)
    assert np.isfinite(pr.simulate(scene, X0, V0).x).all()
    loss, _, _ = pr.value_and_grad(scene, X0, V0, pr.Funnel(0.5))
    assert np.isfinite(loss)


@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
@pytest.mark.parametrize("term", list(TERMS))
def test_just_past_the_limit_is_refused_naming_the_key_and_the_term(term, mode):
    scene = _scene(term, mode, 1.01)
    key = KEY[mode]
    for run in (lambda **kw: pr.simulate(scene, X0, V0, **kw),
                lambda **kw: pr.value_and_grad(scene, X0, V0, pr.Funnel(0.5), **kw)):
        with pytest.raises(checks.InputError) as err:
            run()
        msg = str(err.value)
        assert err.value.key == key
        assert isinstance(err.value, stability.UnstableStepError)
        assert "\n" not in msg and len(msg) < 200, msg
        assert msg.startswith(f"{key} = ") and "1.01x the stability limit" in msg, msg
        assert f"({term} " in msg, msg
        assert f"a stable {key} is" in msg and "docs/spec.md section 10" in msg, msg
        # the opt-out runs it (its numbers stay finite this close to the limit)
        out = run(allow_unstable=True)
        traj = out if isinstance(out, pr.Trajectory) else out[2]
        assert np.isfinite(traj.x).all()


@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
@pytest.mark.parametrize("term", list(TERMS))
def test_the_refusal_happens_before_the_run(term, mode, monkeypatch):
    """Nothing is stepped: the stepper registry is never consulted."""
    from pes_ref.core import scene as scene_mod

    def boom(*a, **k):
        raise AssertionError("the run started")
    monkeypatch.setattr(scene_mod, "_stepper", boom)
    with pytest.raises(stability.UnstableStepError):
        pr.simulate(_scene(term, mode, 1.01), X0, V0)
    with pytest.raises(stability.UnstableStepError):
        pr.value_and_grad(_scene(term, mode, 1.01), X0, V0, pr.Funnel(0.5))


@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
def test_the_suggested_value_runs(mode):
    scene = _scene("spring", mode, 30.0)
    with pytest.raises(stability.UnstableStepError):
        pr.simulate(scene, X0, V0)
    good = stability.stability_limit(scene).suggestion
    good_scene = replace(scene, dt=good) if mode == "dynamic" else replace(scene, mobility=good)
    stability.check_stable(good_scene)
    assert np.isfinite(pr.simulate(good_scene, X0, V0).x).all()


@pytest.mark.parametrize("mode", ["dynamic", "quasistatic"])
def test_zero_steps_are_never_refused(mode):
    scene = _scene("spring", mode, 100.0, n_steps=0)
    assert pr.simulate(scene, X0, V0).x.shape == (1, 2, 2)
    pr.value_and_grad(scene, X0, V0, pr.Funnel(0.5))
    stability.check_stable(scene)


def test_the_rule_is_per_term_not_summed():
    """A spring and the grid together, each at 0.8 of its own limit: the summed bound
    (:func:`stability.stability_limit`) is past 1, the per-term rule is not."""
    K = 8.0
    surface = _surface(K * np.outer(_NODES, _NODES))            # c = 8 too
    scene = pr.Scene(surface, dt=0.8 * 2.0 / np.sqrt(K), n_steps=5, spring=pr.Spring(K, [0.5, 0.5]))
    assert stability.stability_limit(scene).ratio > 1.0
    lim = stability.stability_limit(scene, "rule")
    assert lim.ratio == pytest.approx(0.8)
    pr.simulate(scene, X0, V0)


def test_second_differences_are_not_a_term():
    """The slope's jumps at cell edges enter the conservative bound, not the rule."""
    q = np.linspace(-1.0, 1.0, 21)
    surface = pr.Surface(np.outer(25.0 * q ** 2, np.ones(4)), (-1, 0), (1, 1), (False, False))
    scene = pr.Scene(surface, dt=1.0, n_steps=3)              # 5x the limit of K_0 = 50
    assert stability.stability_limit(scene).ratio > 3.0
    assert stability.stability_limit(scene, "rule").ratio == 0.0
    stability.check_stable(scene)


def test_a_scene_without_stiffness_has_no_limit():
    scene = pr.Scene(_surface(), dt=1e6, n_steps=3)
    for bound in stability.BOUNDS:
        lim = stability.stability_limit(scene, bound)
        assert lim.ratio == 0.0 and lim.limit == np.inf and lim.term == "" and lim.suggestion == scene.dt
    stability.check_stable(scene)


def test_the_message_of_the_brief():
    """A dynamic case past its grid curvature reads as one line, e.g. "dt = 5 is 4.7x
    the stability limit 1.06 of its stiffest term (grid curvature 3.55); a stable dt is
    0.106 (docs/spec.md section 10)"."""
    scene = _scene("grid curvature", "dynamic", 4.7)
    with pytest.raises(stability.UnstableStepError) as err:
        stability.check_stable(scene)
    lim = stability.stability_limit(scene)
    dt_lim = 2.0 / np.sqrt(C / MASS[0])
    assert str(err.value) == (f"dt = {scene.dt:.3g} is 4.7x the stability limit {dt_lim:.3g} of its stiffest term "
                              f"(grid curvature {C:.3g}); a stable dt is {lim.suggestion:.3g} "
                              f"(docs/spec.md section 10)")


@given(case=pst.scene_cases())
def test_drawn_scenes_are_inside_the_rule(case):
    """The hypothesis strategies draw only scenes the rule accepts: their step is sized
    by ``max_omega_dt = 0.5`` of the summed stiffness, a quarter of the limit at most."""
    scene, _, _ = case
    assert stability.stability_limit(scene, "rule").ratio <= 0.25 * (1 + 1e-12)
    stability.check_stable(scene)


@pytest.mark.parametrize("integrator", ["verlet", "gjf"])
def test_both_dynamic_integrators_are_refused(integrator):
    scene = replace(_scene("spring", "dynamic", 1.5), integrator=integrator, damping=0.1)
    with pytest.raises(stability.UnstableStepError, match=r"^dt = "):
        pr.simulate(scene, X0, V0)


def test_a_non_finite_run_says_so_in_one_short_line():
    """Past the limit on purpose, the run that overflows raises NonFiniteError with one
    line naming the step, the key, the limit and a stable value, saying "stability
    limit" once."""
    scene = pr.Scene(_surface(), dt=1.0, n_steps=2000, spring=pr.Spring(1e4, [0.5, 0.5]))
    with pytest.raises(pr.NonFiniteError) as err:
        pr.simulate(scene, [[0.6, 0.45]], [[0.0, 0.0]], allow_unstable=True)
    msg = str(err.value)
    assert "\n" not in msg and len(msg) <= 200, (len(msg), msg)
    assert msg.count("stability limit") == 1, msg
    assert "non-finite at step" in msg and "a stable dt is" in msg, msg


@pytest.mark.parametrize("kw, name", [(dict(allow_unstable="yes"), "allow_unstable"), (dict(progress=3), "progress")])
def test_the_new_keywords_are_checked(kw, name):
    scene = _scene("spring", "dynamic", 0.5)
    for run in (lambda: pr.simulate(scene, X0, V0, **kw), lambda: pr.value_and_grad(scene, X0, V0, pr.Funnel(0.5), **kw)):
        with pytest.raises(TypeError, match=name):
            run()


def test_one_limit_under_either_bound():
    """The summed bound and the rule are one computation over one stiffness table: a lone
    spring gives both the same limit, and the sum adds the grid's cell edges."""
    scene = pr.Scene(_surface(), dt=0.1, n_steps=3, mass=2.0, spring=pr.Spring([8.0, 2.0], [0.5, 0.5]))
    rule, summed = (stability.stability_limit(scene, bound) for bound in ("rule", "sum"))
    assert (rule.term, rule.axis, rule.stiffness) == ("spring", 0, 8.0)
    assert summed.term == "all terms" and summed.limit == rule.limit == pytest.approx(1.0)
    assert set(summed.terms) == {"grid_edges", *stability.RULE_TERMS} and set(rule.terms) == set(stability.RULE_TERMS)
    with pytest.raises(ValueError, match="bound must be one of"):
        stability.stability_limit(scene, "max")


def test_a_stiffness_that_overflows_is_past_every_limit():
    """Terms that sum to inf (wall_k = 1e308 beside a spring) give an infinite ratio and a
    zero limit under the summed bound, not a division by zero."""
    scene = pr.Scene(_surface(), dt=0.1, n_steps=3, spring=pr.Spring(1e308, [0.5, 0.5]),
                     walls=pr.Walls(1e308, 0.1, [[True, True], [True, True]]))
    with np.errstate(over="ignore"):
        lim = stability.stability_limit(scene)
        message = stability.advice(scene)
    assert lim.ratio == np.inf and lim.limit == 0.0 and "is infx it" in message
    with pytest.raises(stability.UnstableStepError, match="dt = 0.1 is"):
        stability.check_stable(scene)
