"""What the TOML input files share (pes_ref.core.runtime.keyfile): a bad value is shown in TOML's spelling."""
import pytest

from pes_ref.core.runtime.keyfile import show

#: (a value as tomllib reads it, how a refusal shows it)
SHOWN = [
    (True, "true"),
    ([True, False], "[true, false]"),
    ([[True, True], [False, True]], "[[true, true], [false, true]]"),
    ({"lower": [0, 0.5], "free": False}, "{ lower = [0, 0.5], free = false }"),
    ({}, "{}"),
    ("zero", "'zero'"),
    (-0.05, "-0.05"),
    (float("inf"), "inf"),
    (float("nan"), "nan"),
    (list(range(40)), "[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16..."),
]


@pytest.mark.parametrize("value, text", SHOWN, ids=[t[:30] for _, t in SHOWN])
def test_a_value_is_shown_as_toml_spells_it(value, text):
    assert show(value) == text
