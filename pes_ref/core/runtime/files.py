"""Writing a file all at once: the one atomic writer of the package.

Every file the package writes for a user (results, cases, design files, manifests,
check reports, a sweep's ``results.csv`` and ``summary.png``, the benchmark's JSON and
plot) goes through [`atomic_file`][pes_ref.core.runtime.files.atomic_file]: the bytes go to a temporary file in the
destination folder, which is then published under its name in one step, so a reader
never sees half a file and a crash of the writing process leaves at most a hidden
``.<name>.<random>.tmp`` behind (the file is not synced to the disk: that would double
the time of writing the conformance vectors, and a power loss is not this writer's
concern). The published file has the mode any new file of the user gets (0o666 less
the umask).

- ``overwrite=True``: `os.replace`, which swaps the name over atomically;
- ``overwrite=False``: `os.link` of the temporary file to the name, which the
  file system refuses if the name exists, whoever made it and whenever (no
  check-then-replace race), then the temporary name is removed. On a file system
  without hard links the name is reserved with ``O_CREAT | O_EXCL`` (again refused if it
  exists) and the finished file replaces that empty reservation.

An existing file that is not to be replaced raises [`ResultExistsError`][pes_ref.core.runtime.files.ResultExistsError].

A set of files that belong together (the conformance vectors and their manifest) is made whole in a
staging folder beside the destination, then [`move_into`][pes_ref.core.runtime.files.move_into]
moves each into place with `os.replace`; the caller writes the set's index last, through
[`atomic_file`][pes_ref.core.runtime.files.atomic_file], so a stop part-way leaves the old set's
index in place.
"""
from __future__ import annotations

import errno
import os
from contextlib import contextmanager

__all__ = ["atomic_file", "move_into", "ResultExistsError"]

#: The errors of `os.link` on a file system that has no hard links.
_NO_HARD_LINKS = frozenset({errno.EPERM, errno.EOPNOTSUPP, errno.ENOTSUP, errno.ENOSYS, errno.EMLINK})


class ResultExistsError(FileExistsError):
    """The file to write exists already and ``overwrite`` was not asked for.

    Parameters
    ----------
    path : str or os.PathLike
    what : str
        What the file is ("result", "design", ...), for the message.
    """

    def __init__(self, path, what: str = "result"):
        self.path = os.fspath(path)
        super().__init__(f"{what} file {self.path!r} exists already; refusing to overwrite it "
                         "(pass overwrite=True, or --force on the command line)")

    def __str__(self):
        return self.args[0]


@contextmanager
def atomic_file(path, *, overwrite: bool = False, what: str = "result"):
    """A binary file to write whose bytes appear at ``path`` all at once, when the block
    ends without an error (see the module docstring).

    Parameters
    ----------
    path : str or os.PathLike
    overwrite : bool
        Replace an existing file; otherwise raise [`ResultExistsError`][pes_ref.core.runtime.files.ResultExistsError],
        before
        writing anything if ``path`` exists already, and at publication if it appeared
        in the meantime (the file there is left as it is).
    what : str
        What the file is, for the message of [`ResultExistsError`][pes_ref.core.runtime.files.ResultExistsError].

    Yields
    ------
    file
        Opened ``"xb"`` in the folder of ``path``; if the block raises, it is removed
        and nothing is published.

    Examples
    --------
    >>> with atomic_file("notes.txt", overwrite=True) as fh:   # doctest: +SKIP
    ...     fh.write(b"all or nothing")
    """
    path = os.fspath(path)
    if not overwrite and os.path.lexists(path):
        raise ResultExistsError(path, what)   # early, to write nothing; publication checks again, atomically
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        if os.path.exists(folder):
            raise NotADirectoryError(errno.ENOTDIR, "this is a file, not a folder to write into", folder)
        raise FileNotFoundError(errno.ENOENT, "the folder to write into does not exist", folder)
    tmp = os.path.join(folder, f".{os.path.basename(path)}.{os.urandom(6).hex()}.tmp")   # not secrets: ~4 ms to import
    try:
        fh = open(tmp, "xb")
    except PermissionError:              # named by the folder: the temporary name means nothing to a user
        raise PermissionError(errno.EACCES, "the folder to write into is not writable", folder) from None
    try:
        with fh:
            yield fh
        _publish(tmp, path, overwrite, what)
    finally:
        if os.path.lexists(tmp):
            os.unlink(tmp)


def _publish(tmp: str, path: str, overwrite: bool, what: str) -> None:
    """Give the finished file ``tmp`` the name ``path`` in one step."""
    if overwrite:
        os.replace(tmp, path)
        return
    try:
        os.link(tmp, path)            # atomic "create if absent"; the caller removes tmp
    except FileExistsError:
        raise ResultExistsError(path, what) from None
    except OSError as exc:
        if exc.errno not in _NO_HARD_LINKS:
            raise
        _publish_without_links(tmp, path, what)


def _publish_without_links(tmp: str, path: str, what: str) -> None:
    """Reserve ``path`` with ``O_CREAT | O_EXCL`` (refused if it exists), then replace
    the empty reservation with ``tmp``."""
    try:
        os.close(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644))
    except FileExistsError:
        raise ResultExistsError(path, what) from None
    try:
        os.replace(tmp, path)
    except BaseException:
        os.unlink(path)               # our own empty reservation
        raise


def move_into(paths, directory) -> None:
    """Move each finished file of ``paths`` into ``directory`` under its own name, each
    in one step (`os.replace`, replacing a file of that name). ``paths`` must be on
    the file system of ``directory`` (a staging folder beside it)."""
    for path in paths:
        os.replace(path, os.path.join(directory, os.path.basename(path)))
