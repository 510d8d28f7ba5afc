"""validation/experiments/oscillator_table.py: the default oscillator's table of docs/synthesis.md.

The script runs the designs and rewrites only the lines between its two markers; here at
the ``--smoke`` size (seconds). The full table is ``make oscillator-table``, not part of
``make test``.
"""
from __future__ import annotations

import re

import pytest
from _helpers import ROOT, load_script, run_script

from pes_ref.synthesis import load_design

SCRIPT = ROOT / "validation" / "experiments" / "oscillator_table.py"
table = load_script(SCRIPT)

BEFORE = "# A document\n\ntext before, kept byte for byte  \n\n"
AFTER = "\ntext after\n<!-- not a marker -->\n"


def _doc(tmp_path, inside="an old table\n"):
    path = tmp_path / "doc.md"
    path.write_text(f"{BEFORE}{table.BEGIN}\n{inside}{table.END}{AFTER}")
    return path


def test_rewrite_replaces_only_the_lines_between_the_markers():
    text = f"{BEFORE}{table.BEGIN}\nold 1\nold 2\n{table.END}{AFTER}"
    assert table.rewrite(text, ["new"]) == f"{BEFORE}{table.BEGIN}\nnew\n{table.END}{AFTER}"
    assert table.rewrite(table.rewrite(text, ["new"]), ["new"]) == table.rewrite(text, ["new"])


@pytest.mark.parametrize("text, said", [
    (f"{BEFORE}{AFTER}", "found it 0 times"),
    (f"{table.BEGIN}\n{table.END}\n{table.BEGIN}\n", "found it 2 times"),
    (f"{table.END}\n{table.BEGIN}\n", "comes before"),
])
def test_bad_markers_are_refused(text, said):
    with pytest.raises(ValueError, match=said):
        table.rewrite(text, [])


def test_a_document_without_markers_is_one_line_and_left_alone(tmp_path):
    doc = tmp_path / "doc.md"
    doc.write_text(BEFORE)
    proc = run_script(SCRIPT, "--smoke", "--backends", "numpy", "--doc", doc, "--out", tmp_path / "out")
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith(f"error: {doc}: expected the line")
    assert doc.read_text() == BEFORE and not (tmp_path / "out").exists()


def test_a_smoke_run_rewrites_the_table_and_nothing_else(tmp_path):
    doc = _doc(tmp_path)
    out = tmp_path / "designs"
    assert table.main(["--smoke", "--seeds", "3", "--held-out", "12345,9191", "--workers", "1",
                       "--backends", "numpy", "--doc", str(doc), "--out", str(out)]) == 0
    text = doc.read_text()
    head, rest = text.split(table.BEGIN + "\n")
    block, tail = rest.split(table.END)
    assert (head, tail) == (BEFORE, AFTER)
    lines = block.splitlines()
    assert lines[0].startswith("`python validation/experiments/oscillator_table.py --smoke ")
    assert "--seeds 3` rewrites this table. Conditions: " in lines[0]
    assert "UTC" not in lines[0] and "commit" not in lines[0]           # no clock time, provenance apart
    assert lines[1] == "" and re.fullmatch(r"regenerated: \d{4}-\d{2}-\d{2}, commit `[^`]+`", lines[2])
    assert lines[3] == ""
    rows = [line for line in lines[4:] if not line.startswith("|---")]
    assert rows[0].startswith("| backend | design seed | held-out seed | captured | sweep | grid |")
    assert [r.split("|")[1:4] for r in rows[1:]] == [[" numpy ", " 3 ", " 12345 "], ["  ", "  ", " 9191 "]]
    state = load_design(out / "osc3-numpy.npz")
    assert state.seed == 3 and state.stage == "polish" and state.status == "done" and state.backend == "numpy"
    assert f"`{table.values_sha256(state.values)[:16]}`" in rows[1]


def test_the_command_is_the_make_target_for_the_default_table():
    every = table.installed_backends()
    assert table.command(table.DESIGN_SEEDS, table.HELD_OUT, False, every) == "make oscillator-table"
    assert table.command((3, 4), table.HELD_OUT, False, every) == \
        "python validation/experiments/oscillator_table.py --seeds 3,4"
    assert table.command(table.DESIGN_SEEDS, table.HELD_OUT, False, ("numpy",)) == \
        "python validation/experiments/oscillator_table.py --backends numpy"


def _doc_rows() -> list:
    text = (ROOT / "docs" / "synthesis.md").read_text()
    block = text.split(table.BEGIN)[1].split(table.END)[0]
    return [[c.strip() for c in line.split("|")[1:-1]] for line in block.splitlines()
            if line.startswith("| ") and not line.startswith("| backend")]


def test_the_docs_table_is_the_scripts_for_each_backend_and_design_seeds_0_to_2_on_both_held_out_seeds():
    rows = _doc_rows()
    backends, seeds, held = [], [], []
    for cells in rows:
        backends.append(cells[0] or backends[-1])
        seeds.append(cells[1] or seeds[-1])
        held.append(cells[2])
    assert list(zip(backends, seeds, held)) == [(b, str(s), str(h)) for b in table.BACKENDS
                                                for s in table.DESIGN_SEEDS for h in table.HELD_OUT]


def test_print_only_writes_no_document(tmp_path, capsys):
    doc = _doc(tmp_path)
    before = doc.read_bytes()
    assert table.main(["--smoke", "--seeds", "0", "--held-out", "12345", "--workers", "1", "--print-only",
                       "--backends", "numpy",
                       "--doc", str(doc), "--out", str(tmp_path / "designs")]) == 0
    assert doc.read_bytes() == before
    assert "| numpy | 0 | 12345 |" in capsys.readouterr().out


@pytest.mark.parametrize("page, target", [("synthesis.md", "oscillator-table"), ("problems.md", "design-study")])
def test_the_docs_blocks_open_with_the_head_the_scripts_write(page, target):
    """What rewrites the table and its conditions, then one provenance line; no clock time."""
    text = (ROOT / "docs" / page).read_text()
    block = text.split(f"<!-- {target}:begin (make {target} writes what follows) -->\n")[1].split(f"<!-- {target}:end -->")[0]
    head = block.strip("\n").split("\n")[:3]
    assert head[0].startswith(f"`make {target}` rewrites this table. Conditions: ") and "UTC" not in head[0]
    assert head[1] == "" and re.fullmatch(r"regenerated: \d{4}-\d{2}-\d{2}, commit `[0-9a-f]{7,}`", head[2])
