"""docs/devices.md documents every declared key of a device file, and no other."""
import re

import pytest

from _helpers import ROOT

from pes_ref.devices import device_file as df

TEXT = (ROOT / "docs" / "devices.md").read_text()


def _section(heading: str) -> str:
    return TEXT.split(f"{heading}\n", 1)[1].split("\n### ", 1)[0].split("\n## ", 1)[0]


def _first_column(heading: str, header: str = "| key |") -> set:
    """The names in the first column of the table whose header starts ``header`` under ``heading``:
    every backticked name, brackets and ``[i]`` dropped (```springs[i].axis``` -> ``springs.axis``)."""
    table = _section(heading).split(header, 1)[1].split("\n\n", 1)[0]
    cells = [cell for cell in re.findall(r"^\| (.*?) \|", table, re.M) if set(cell) != {"-"}]
    names = {name for cell in cells for name in re.findall(r"`([^`]+)`", cell)}
    return {re.sub(r"\[i\]|\[|\]", "", name) for name in names}


def _nested(keys: dict, prefix: str) -> set:
    return {f"{prefix}.{name}" for name in keys}


@pytest.mark.parametrize("heading, keys", [
    ("## The device file (format 1)", set(df.TOP_KEYS)),
    ("### `[[part]]`, exactly two", set(df.PART_KEYS)),
    ("### `[cspace]`", set(df.CSPACE_KEYS)),
    ("### `[geometry]`", set(df.GEOMETRY_KEYS)),
    ("### `[energy]`", set(df.ENERGY_KEYS) | _nested(df.SPRING_KEYS, "springs")),
    ("### `[dynamics]`", set(df.DYNAMICS_KEYS)),
    ("### `[rigid]`", set(df.RIGID_KEYS)),
    ("### `[realized]`", set(df.REALIZED_KEYS)),
    ("### `[start]` and `[analysis]`", _nested(df.START_KEYS, "start") | {"analysis.kind"}
     | {f"analysis.{name}" for keys in df.ANALYSES.values() for name in keys}),
])
def test_every_key_is_documented(heading, keys):
    assert _first_column(heading) == keys


def test_the_shapes_and_the_walls_keys_are_documented():
    shapes = _section("### `[[part]]`, exactly two")
    for kind, keys in df.SHAPES.items():
        assert f"{{ {kind} = " in shapes, kind
        for name in keys if isinstance(keys, dict) else ():
            assert f"{name} = " in shapes, (kind, name)
    assert "`minus = [shape, ...]`" in shapes and set(df.SHAPE_KEYS) == {"minus"}
    walls = _section("### `[dynamics]`").split("| `walls` |", 1)[1].split("\n", 1)[0]
    for name in df.WALL_KEYS:
        assert f"`{name}`" in walls or f" {name} " in walls, name
