"""validation/experiments/rigid_devices.py: the table of docs/rigid.md, rewritten between its
markers and nothing else; here at the ``--smoke`` size (the drum cam alone, dynamically)."""
import json
import shutil
from pathlib import Path

import pytest

import _helpers

ROOT = Path(__file__).resolve().parents[2]


def test_the_smoke_run_rewrites_only_the_table_of_its_page(tmp_path):
    pytest.importorskip("pymunk")
    from pes_ref.rigid.shipped import BEGIN, END
    script = _helpers.load_script(ROOT / "validation" / "experiments" / "rigid_devices.py")
    doc = tmp_path / "rigid.md"
    shutil.copy(ROOT / "docs" / "rigid.md", doc)
    before = doc.read_text()
    assert script.main(["--smoke", "--doc", str(doc), "--out", str(tmp_path / "out")]) == 0
    after = doc.read_text()
    head, tail = before[:before.index(BEGIN)], before[before.index(END):]
    assert after.startswith(head) and after.endswith(tail)
    block = after[len(head):len(after) - len(tail)]
    assert "`make rigid-devices` rewrites this table" in block and "regenerated: " in block
    assert "| drum_cam | dynamic |" in block and "| geneva4 |" not in block
    (row,) = json.loads((tmp_path / "out" / "rows.json").read_text())
    assert row["advance_rigid"] == pytest.approx(1.0, abs=0.01)       # one lead per drum turn
