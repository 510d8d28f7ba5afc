"""Fixtures of the command line's tests."""
import pytest

from _faults import make_assets


@pytest.fixture(scope="session")
def fault_assets(tmp_path_factory):
    """The files every fault row's folder starts with (``tests/_faults.py``), made once per test process."""
    return make_assets(tmp_path_factory.mktemp("assets"))
