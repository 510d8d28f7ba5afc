"""pes_ref.cli.files: a file's kind read from its contents (`what`), and every command that reads
one kind refusing each other kind in one line that names what the file is (`expect`)."""
import zipfile

import numpy as np
import pytest

from pes_ref import cli
from pes_ref.cli.files import FILE_KINDS, expect, what
from pes_ref.oracle import run_case, save_case, write_result
from pes_ref.oracle.case import REQUIRED_KEYS, TRAJECTORY_KEYS

CASE = dict(values=np.zeros((3, 3)), lower=[0.0, 0.0], upper=[1.0, 1.0], periodic=[False, False], dt=0.05,
            n_steps=3, mode="dynamic", mass=1.0, damping=0.0, x0=[[0.3, 0.4]], v0=[[0.1, 0.0]],
            objective="funnel", target=0.5, when="final")


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """One file of each kind the package knows, and files of none."""
    from pes_ref.synthesis import Plan, new_design, save_design
    folder = tmp_path_factory.mktemp("kinds")
    save_design(folder / "design.npz", new_design("funnel", plan=Plan(iterations=1, n_particles=2), grid=6))
    save_case(folder / "case.npz", **CASE)
    write_result(run_case(CASE), folder / "result.npz")
    np.savez(folder / "plain.npz", x=np.zeros(3))
    np.savez(folder / "tagged.npz", format=np.array("someone.else"), values=np.zeros(3))
    np.savez(folder / "numbertag.npz", format=np.array(3))
    with zipfile.ZipFile(folder / "text.zip", "w") as z:
        z.writestr("notes.txt", "hello")
    (folder / "text.npz").write_text("not a zip")
    (folder / "folder").mkdir()
    return folder


@pytest.mark.parametrize("name, kind", [("design.npz", "design"), ("case.npz", "case"), ("result.npz", "result")])
def test_each_kind_is_recognized(files, name, kind):
    assert what(files / name) == kind
    assert what(str(files / name)) == kind


@pytest.mark.parametrize("name", ["plain.npz", "tagged.npz", "numbertag.npz", "text.zip", "text.npz", "folder",
                                  "missing.npz"])
def test_anything_else_is_of_no_kind(files, name):
    assert what(files / name) is None


def test_a_design_is_known_by_its_tag_alone(files, tmp_path):
    """Only the tag tells a design file: with another tag, the same members are no design."""
    with np.load(files / "design.npz") as z:
        arrays = dict(z)
    arrays["format"] = np.array("pes_ref.designs")
    np.savez(tmp_path / "d.npz", **arrays)
    assert what(tmp_path / "d.npz") is None
    arrays["format"] = np.array("pes_ref.design")
    np.savez(tmp_path / "d.npz", **arrays)
    assert what(tmp_path / "d.npz") == "design"


@pytest.mark.parametrize("key", REQUIRED_KEYS)
def test_a_case_lacking_a_required_key_is_no_case(tmp_path, key):
    """... but a file for the oracle to refuse naming that key (docs/spec.md section 8)."""
    save_case(tmp_path / "c.npz", **{k: v for k, v in CASE.items() if k != key})
    assert what(tmp_path / "c.npz") is None


@pytest.mark.parametrize("key", TRAJECTORY_KEYS)
def test_a_result_lacking_a_trajectory_key_is_no_result(files, tmp_path, key):
    with np.load(files / "result.npz") as z:
        np.savez(tmp_path / "r.npz", **{k: v for k, v in z.items() if k != key})
    assert what(tmp_path / "r.npz") is None


def test_expect_passes_its_own_kind_and_files_of_no_kind(files):
    assert expect(str(files / "design.npz"), "design") == str(files / "design.npz")
    assert expect(str(files / "plain.npz"), "case") == str(files / "plain.npz")   # its reader says what is wrong


def test_expect_refuses_a_missing_file_as_every_command_does(files):
    with pytest.raises(FileNotFoundError, match="^design file .*missing.npz does not exist$"):
        expect(str(files / "missing.npz"), "design")
    with pytest.raises(IsADirectoryError, match="^case file .*folder is a folder, not a file$"):
        expect(str(files / "folder"), "case")


#: What each kind's refusal says after its path: what it is, and what reads it.
SAYS = {
    "design": "is a design file, not {wanted}; evaluate reads it: python -m pes_ref evaluate {path}",
    "case": "is an oracle case file, not {wanted}; the oracle runs it: python -m pes_ref oracle {path} RESULT.npz",
    "result": "is an oracle result file, not {wanted}; it holds an oracle run's output (the oracle wrote it)",
}
#: Each command that reads a file of one kind: its arguments around the file, and that kind.
READERS = {
    "oracle": (["oracle", "{path}", "{out}/r.npz"], "case"),
    "evaluate": (["evaluate", "{path}"], "design"),
    "realize": (["realize", "{path}", "--as", "contact", "--out", "{out}/parts"], "design"),
    "design --resume": (["design", "--resume", "{path}"], "design"),
}
ROWS = [(command, kind) for command, (_, reads) in READERS.items() for kind in FILE_KINDS if kind != reads]


def _realize_extra_or_skip():
    from pes_ref.core.runtime.extras import MissingExtraError
    from pes_ref.realize.extra import require_realize
    try:
        require_realize()
    except MissingExtraError:
        pytest.skip("the extra 'realize' is not installed (realize refuses that first)")


@pytest.mark.parametrize("command, kind", ROWS, ids=[f"{c}-{k}" for c, k in ROWS])
def test_each_reader_refuses_each_other_kind_in_one_line(files, tmp_path, capsys, command, kind):
    words, reads = READERS[command]
    if command == "realize":
        _realize_extra_or_skip()
    path = str(files / f"{kind}.npz")
    assert cli.main([w.format(path=path, out=tmp_path) for w in words]) == cli.EXIT_ERROR
    wanted = {"design": "a design file", "case": "an oracle case file"}[reads]
    assert capsys.readouterr().err == f"error: {path} " + SAYS[kind].format(wanted=wanted, path=path) + "\n"
    assert list(tmp_path.iterdir()) == []              # nothing written
