"""pes_ref.core.runtime.files: the one atomic writer. (Its publication rules, with and without
hard links and against a concurrent writer, are tested through the .npz writer in
tests/oracle/test_npz.py.)"""
import os

import pytest

from pes_ref.core.runtime.files import ResultExistsError, atomic_file


def test_the_bytes_appear_at_once_when_the_block_ends(tmp_path):
    path = tmp_path / "notes.txt"
    with atomic_file(path) as fh:
        fh.write(b"all or ")
        assert not path.exists()                   # nothing under the name while writing
        fh.write(b"nothing")
    assert path.read_bytes() == b"all or nothing" and os.listdir(tmp_path) == ["notes.txt"]


def test_a_failed_write_leaves_nothing(tmp_path):
    class Boom(Exception):
        pass

    with pytest.raises(Boom):
        with atomic_file(tmp_path / "r.bin") as fh:
            fh.write(b"half")
            raise Boom
    assert os.listdir(tmp_path) == []


def test_an_existing_file_is_kept_unless_overwrite(tmp_path):
    path = tmp_path / "r.csv"
    path.write_bytes(b"mine")
    with pytest.raises(ResultExistsError, match="results file .* exists already"):
        with atomic_file(path, what="results") as fh:
            fh.write(b"theirs")
    assert path.read_bytes() == b"mine"
    with atomic_file(path, overwrite=True) as fh:
        fh.write(b"theirs")
    assert path.read_bytes() == b"theirs" and os.listdir(tmp_path) == ["r.csv"]


@pytest.mark.parametrize("overwrite", [False, True])
def test_the_file_gets_the_umasks_mode(tmp_path, overwrite):
    old = os.umask(0o027)
    try:
        with atomic_file(tmp_path / "f", overwrite=overwrite) as fh:
            fh.write(b"x")
    finally:
        os.umask(old)
    assert (tmp_path / "f").stat().st_mode & 0o777 == 0o640
