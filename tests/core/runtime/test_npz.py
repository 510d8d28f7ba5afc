"""pes_ref.core.runtime.npz: the .npz writer (through the one atomic writer,
pes_ref.core.runtime.files.atomic_file) and reader.

A file is published in one step: a reader never sees half of it, a failed write leaves
nothing behind, and without ``overwrite`` an existing file is never replaced, not even
one that appears while the archive is being written (no check-then-replace race), with
or without hard links.
"""
import errno
import os

import numpy as np
import pytest

from pes_ref.core.runtime import files
from pes_ref.core.runtime.files import ResultExistsError
from pes_ref.core.runtime import npz

ARRAYS = {"a": np.arange(6.0).reshape(2, 3), "name": "text", "n": np.int64(3)}


def _concurrent_writer(monkeypatch, path, content=b"theirs"):
    """Make another writer create ``path`` while our archive is being written (between
    the early existence check and the publication)."""
    write_array = np.lib.format.write_array

    def write_then_race(*args, **kwargs):
        if not os.path.lexists(path):
            path.write_bytes(content)
        return write_array(*args, **kwargs)

    monkeypatch.setattr(np.lib.format, "write_array", write_then_race)


def _no_hard_links(monkeypatch):
    def link(src, dst, *args, **kwargs):
        raise PermissionError(errno.EPERM, "Operation not permitted", src)
    monkeypatch.setattr(os, "link", link)


def test_round_trip(tmp_path):
    npz.write_npz(tmp_path / "r.npz", ARRAYS)
    back = npz.read_npz(tmp_path / "r.npz")
    assert sorted(back) == sorted(ARRAYS)
    np.testing.assert_array_equal(back["a"], ARRAYS["a"])
    assert back["name"].dtype.kind == "U" and str(back["name"]) == "text"
    assert os.listdir(tmp_path) == ["r.npz"]      # no temporary file left


def test_same_arrays_same_bytes(tmp_path):
    npz.write_npz(tmp_path / "a.npz", ARRAYS)
    npz.write_npz(tmp_path / "b.npz", ARRAYS)
    assert (tmp_path / "a.npz").read_bytes() == (tmp_path / "b.npz").read_bytes()


@pytest.mark.parametrize("links", [True, False], ids=["hard-links", "no-hard-links"])
def test_a_file_that_appears_while_writing_is_never_replaced(tmp_path, monkeypatch, links):
    path = tmp_path / "r.npz"
    _concurrent_writer(monkeypatch, path)
    if not links:
        _no_hard_links(monkeypatch)
    with pytest.raises(ResultExistsError):
        npz.write_npz(path, ARRAYS)
    assert path.read_bytes() == b"theirs"
    assert os.listdir(tmp_path) == ["r.npz"]


@pytest.mark.parametrize("links", [True, False], ids=["hard-links", "no-hard-links"])
def test_publishes_a_new_file(tmp_path, monkeypatch, links):
    if not links:
        _no_hard_links(monkeypatch)
    npz.write_npz(tmp_path / "r.npz", ARRAYS)
    np.testing.assert_array_equal(npz.read_npz(tmp_path / "r.npz")["a"], ARRAYS["a"])
    assert os.listdir(tmp_path) == ["r.npz"]


def test_an_existing_file_is_refused_before_writing(tmp_path, monkeypatch):
    (tmp_path / "r.npz").write_bytes(b"precious")
    monkeypatch.setattr(np.lib.format, "write_array", None)   # writing anything would fail otherwise
    with pytest.raises(ResultExistsError, match="design file .* exists already"):
        npz.write_npz(tmp_path / "r.npz", ARRAYS, what="design")
    assert (tmp_path / "r.npz").read_bytes() == b"precious"


def test_overwrite_replaces(tmp_path, monkeypatch):
    path = tmp_path / "r.npz"
    _concurrent_writer(monkeypatch, path)
    npz.write_npz(path, ARRAYS, overwrite=True)
    np.testing.assert_array_equal(npz.read_npz(path)["a"], ARRAYS["a"])
    assert os.listdir(tmp_path) == ["r.npz"]


def test_a_failed_write_leaves_nothing(tmp_path):
    class Boom(Exception):
        pass

    with pytest.raises(Boom):
        with files.atomic_file(tmp_path / "r.bin") as fh:
            fh.write(b"half")
            raise Boom
    assert os.listdir(tmp_path) == []


def test_other_link_errors_are_not_hidden(tmp_path, monkeypatch):
    def link(src, dst, *args, **kwargs):
        raise OSError(errno.EIO, "Input/output error", src)
    monkeypatch.setattr(os, "link", link)
    with pytest.raises(OSError) as info:
        npz.write_npz(tmp_path / "r.npz", ARRAYS)
    assert info.value.errno == errno.EIO
    assert os.listdir(tmp_path) == []


def test_missing_folder(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        npz.write_npz(tmp_path / "no" / "r.npz", ARRAYS)


def test_a_folder_that_cannot_be_written_is_named_not_the_temporary_file(tmp_path, monkeypatch):
    """(Provoked by a stand-in for open: root, who runs some test machines, writes anywhere.)"""
    def refused(name, mode="r", *args, **kwargs):
        raise PermissionError(errno.EACCES, "Permission denied", name)
    monkeypatch.setattr(files, "open", refused, raising=False)
    with pytest.raises(PermissionError) as info:
        npz.write_npz(tmp_path / "r.npz", ARRAYS)
    assert info.value.filename == str(tmp_path) and ".tmp" not in str(info.value)
    assert not os.listdir(tmp_path)


def test_a_file_in_place_of_the_folder_is_said_to_be_a_file(tmp_path):
    (tmp_path / "f").write_text("a file")
    with pytest.raises(NotADirectoryError, match="a file, not a folder"):
        npz.write_npz(tmp_path / "f" / "r.npz", ARRAYS)
    assert os.listdir(tmp_path) == ["f"]


@pytest.mark.parametrize("umask", [0o022, 0o077, 0o002])
def test_design_files_and_results_get_the_umasks_mode(tmp_path, umask):
    """Like any file a user creates: 0o666 less the umask (the temporary file's own
    mode, 0o600 if made by tempfile, must not leak into the published file)."""
    from pes_ref.oracle import run_case, write_result
    from pes_ref.synthesis import new_design, save_design, Plan
    old = os.umask(umask)
    try:
        write_result(run_case(_small_case()), tmp_path / "r.npz")
        save_design(tmp_path / "d.npz", new_design("funnel", plan=Plan(iterations=1, n_particles=2), grid=6))
        npz.write_npz(tmp_path / "o.npz", ARRAYS, overwrite=True)   # the replacing path too
    finally:
        os.umask(old)
    modes = {p.name: p.stat().st_mode & 0o777 for p in tmp_path.iterdir()}
    assert modes == dict.fromkeys(["r.npz", "d.npz", "o.npz"], 0o666 & ~umask)


def _small_case():
    return dict(values=np.zeros((3, 3)), lower=[0.0, 0.0], upper=[1.0, 1.0], periodic=[False, False], dt=0.05,
                n_steps=3, mode="dynamic", mass=1.0, damping=0.0, x0=[[0.3, 0.4]], v0=[[0.1, 0.0]],
                objective="funnel", target=0.5, when="final")


def test_the_readers_refusals_are_its_own_keyed_by_the_member(tmp_path):
    """Each format turns them into its own errors (the oracle's CaseError, DesignFileError)."""
    (tmp_path / "t.npz").write_text("hello")
    with pytest.raises(npz.NpzError, match=r"^design file '.*t\.npz' is not an \.npz archive") as info:
        npz.read_npz(tmp_path / "t.npz", what="design")
    assert info.value.key is None and not isinstance(info.value, TypeError)
    np.savez(tmp_path / "p.npz", a=np.zeros(2), o=np.array([None, 1], dtype=object))   # np.savez pickles it
    with pytest.raises(npz.NpzTypeError, match="^design key 'o': cannot be read without pickle") as info:
        npz.read_npz(tmp_path / "p.npz", what="design")
    assert info.value.key == "o" and isinstance(info.value, ValueError)
