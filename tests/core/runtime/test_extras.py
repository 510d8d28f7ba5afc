"""The optional extras' one check (pes_ref.core.runtime.extras): a missing or too old module is
one MissingExtraError naming what needs it, the module, the version wanted and the pip line."""
import sys
import types

import pytest

from pes_ref.core.runtime.extras import MissingExtraError, found, pip_line, require


def test_the_pip_line():
    assert pip_line("rigid") == "pip install 'pes_ref[rigid]'"


def test_a_missing_module_names_what_needs_it_and_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "pymunk", None)            # import pymunk -> ImportError
    with pytest.raises(MissingExtraError) as info:
        require("pymunk", "rigid", "the rigid engine", major=7, version="version")
    assert str(info.value) == "the rigid engine needs pymunk 7 (the optional extra 'rigid'): pip install 'pes_ref[rigid]'"
    assert isinstance(info.value, ImportError)


@pytest.mark.parametrize("have, least, major, ok", [
    ("2.1.0", (2,), None, True), ("1.8.5", (2,), None, False), ("3.2.1", (3, 2), None, True),
    ("3.1.9", (3, 2), None, False), ("7.1.0", (), 7, True), ("6.9.0", (), 7, False), ("8.0.0", (), 7, False),
])
def test_the_version_is_checked_from_below_and_against_its_major(monkeypatch, have, least, major, ok):
    monkeypatch.setitem(sys.modules, "fake_extra_module", types.SimpleNamespace(__version__=have))
    if ok:
        assert require("fake_extra_module", "x", "a test", least=least, major=major).__version__ == have
    else:
        with pytest.raises(MissingExtraError, match=rf"a test needs fake_extra_module .*found {have}: "
                                                    rf"pip install 'pes_ref\[x\]'"):
            require("fake_extra_module", "x", "a test", least=least, major=major)


def test_found_looks_without_importing():
    found("json", "x", "a test")
    with pytest.raises(MissingExtraError, match="a test needs no_such_module_here"):
        found("no_such_module_here", "x", "a test")
