"""The realizations by name: each one's options refused by the other, its files known before anything
is computed, and the library's `realize` giving the command's report."""
from __future__ import annotations

import types

import numpy as np
import pytest

from pes_ref.core.checks import InputError
from pes_ref.realize.files import CONTACT_FILES, HEIGHTFIELD_FILES
from pes_ref.realize.realizations import REALIZATIONS, check_options, realize
from pes_ref.synthesis.kinds.funnel import FunnelProblem

pytest.importorskip("ezdxf")
pytest.importorskip("trimesh")


@pytest.mark.parametrize("kind, other", [("contact", "heightfield"), ("heightfield", "contact")])
def test_an_option_of_the_other_realization_is_refused_naming_both(kind, other):
    for key in REALIZATIONS[other].options:
        with pytest.raises(InputError, match=f"^{key} goes with as {other}, not as {kind}$") as info:
            check_options(kind, {key: 1.0})
        assert info.value.names == (key, "as")
    assert check_options(kind, {key: None for key in REALIZATIONS[other].options}) is REALIZATIONS[kind]


def test_an_unknown_realization_is_refused_naming_as():
    with pytest.raises(InputError, match="as must be one of contact, heightfield, got 'mould'"):
        check_options("mould", {})


def test_the_files_are_known_from_the_problem_alone():
    problem = FunnelProblem(grid=21, n_steps=50)
    assert REALIZATIONS["contact"].files(problem) == CONTACT_FILES["pin-in-plate"]
    assert REALIZATIONS["heightfield"].files(problem) == HEIGHTFIELD_FILES


def test_realize_writes_the_files_and_reports_the_check(tmp_path):
    problem = FunnelProblem(grid=41, n_steps=300)
    q0 = np.linspace(problem.lower[0], problem.upper[0], 41)[:, None]
    q1 = np.linspace(problem.lower[1], problem.upper[1], 41)[None, :]
    values = 0.2 * np.clip((np.abs(q0) - (0.25 + 0.4 * q1)) / 0.1, 0.0, 1.0) * problem.mask((41, 41))
    state = types.SimpleNamespace(problem=problem, values=values)
    outputs = {key: tmp_path / name for key, (name, _) in REALIZATIONS["contact"].files(problem).items()}
    report = realize(state, "contact", {key: str(path) for key, path in outputs.items()},
                     {"rule": "value", "level": 0.1, "n_particles": 10}, name="v")
    names = [name for name, _ in report]
    assert names[:3] == ["rule", "level", "blocked_share"] and dict(report)["rule"] == "value"
    assert "device_blocked_share" in names and "plate_watertight" in names
    assert all(path.exists() for path in outputs.values())
