"""The examples in docstrings and in the README run and say what they claim."""
import doctest
import importlib
import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("module", ["pes_ref.core.scene", "pes_ref.oracle.case", "pes_ref.synthesis.optimizers"])
def test_docstring_examples(module):
    result = doctest.testmod(importlib.import_module(module), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0


def test_readme_example_runs():
    code = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    assert code, "the README has a Python example"
    namespace = {}
    exec(compile(code[0], "README.md", "exec"), namespace)
    assert namespace["grads"]["values"].shape == (40, 40)
    assert namespace["traj"].x.shape == (201, 2, 2)
