"""docs/problems.md documents every key of a problem file, and no other; its example file and
its Python example run."""
import os
import re

import pytest

from _helpers import ROOT

from pes_ref.synthesis import FORCES, OBJECTIVE_TERMS, SUCCESS_TESTS
from pes_ref.synthesis.problem import problem_file as pf

TEXT = (ROOT / "docs" / "problems.md").read_text()


def _section(heading: str) -> str:
    return TEXT.split(f"### {heading}\n", 1)[1].split("\n### ", 1)[0].split("\n## ", 1)[0]


def _keys(heading: str) -> set:
    """The first-column names of the key table (``| key | type | ...``) under ``heading``."""
    table = _section(heading).split("| key | type |", 1)[1].split("\n\n", 1)[0]
    return set(re.findall(r"^\| `(\w+)` \|", table, re.M))


def _kinds(heading: str, marker: str) -> dict:
    """Kind -> the backticked names of its row, in the table whose header starts ``| kind | keys``
    after ``marker`` under ``heading``."""
    table = _section(heading).split(marker, 1)[1]
    return {kind: set(re.findall(r"`(\w+)`", keys)) for kind, keys in
            re.findall(r"^\| `(\w+)` \| (.*?) \|", table, re.M)}


@pytest.mark.parametrize("heading, keys", [
    ("top level", pf.TOP_KEYS),
    ("[surface]", {**pf.SURFACE_KEYS, "hold": None, "contact": None}),
    ("[surface.contact]", pf.CONTACT_KEYS),
    ("[dynamics]", {**pf.DYNAMICS_KEYS, "spring": None, "walls": None}),
    ("[starts]", {**pf.STARTS_KEYS, "group": None}),
    ("[[forces]]", {**pf.FORCE_KEYS, **{k: None for keys, _ in FORCES.values() for k in keys}}),
    ("[evaluate]", {**pf.EVALUATE_KEYS, "success": None, "scenario": None, "share": None}),
    ("[train]", pf.TRAIN_KEYS),
])
def test_every_key_is_documented(heading, keys):
    assert _keys(heading) == set(keys)


def test_the_nested_keys_are_documented():
    dynamics = _section("[dynamics]")
    for key in (*pf.SPRING_KEYS, *pf.WALL_KEYS):
        assert f"`{key}`" in dynamics
    for key in (*pf.GROUP_KEYS, *pf.TEST_KEYS, *pf.SHARE_KEYS):
        assert f"`{key}`" in _section("[starts]") + _section("[evaluate]")
    for key in (*pf.HOLD_KEYS, *pf.SCENARIO_KEYS):
        assert f"`{key}`" in TEXT


@pytest.mark.parametrize("heading, marker, registry", [
    ("[[objective]]", "| kind | keys", OBJECTIVE_TERMS),
    ("[evaluate]", "| kind | keys", SUCCESS_TESTS),
])
def test_every_kind_and_its_keys_are_documented(heading, marker, registry):
    rows = _kinds(heading, marker)
    assert set(rows) == set(registry)
    for kind, cls in registry.items():
        assert set(cls.KEYS) <= rows[kind], kind


def test_the_example_file_and_the_python_example_run(tmp_path, monkeypatch):
    toml = re.findall(r"```toml\n(.*?)```", TEXT, re.S)[0]
    (tmp_path / "stop.toml").write_text(toml.replace("iterations = 300", "iterations = 3"))
    code = re.findall(r"```python\n(.*?)```", TEXT, re.S)[0]
    monkeypatch.chdir(tmp_path)
    namespace = {"print": lambda *a: None}
    exec(compile(code, "docs/problems.md", "exec"), namespace)
    assert namespace["state"].iteration == 3 and namespace["problem"].dt == 0.01
    assert os.path.exists(tmp_path / "stop.npz")
