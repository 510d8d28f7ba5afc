"""``.npz`` archives of named arrays: read without pickle, written reproducibly and atomically.

The case and result files of the oracle (:mod:`pes_ref.oracle.case`) are such archives;
any other ``.npz`` the package writes (design files) goes through :func:`write_npz` too.
There is one writer, :func:`atomic_file`: the bytes go to a temporary file in the destination
folder, which is then published under its name in one step, so a reader never sees
half a file and a crash of the writing process leaves at most a hidden
``.<name>.<random>.tmp`` behind (the file is not synced to the disk: that would double
the time of writing the conformance vectors, and a power loss is not this writer's
concern):

- ``overwrite=True``: :func:`os.replace`, which swaps the name over atomically;
- ``overwrite=False``: :func:`os.link` of the temporary file to the name, which the
  file system refuses if the name exists, whoever made it and whenever (no
  check-then-replace race), then the temporary name is removed. On a file system
  without hard links the name is reserved with ``O_CREAT | O_EXCL`` (again refused if it
  exists) and the finished file replaces that empty reservation.
"""
from __future__ import annotations

import errno
import os
import zipfile
from collections.abc import Mapping
from contextlib import contextmanager

import numpy as np

from pes_ref.oracle.errors import CaseError, CaseTypeError, ResultExistsError

__all__ = ["read_npz", "write_npz", "atomic_file"]

_ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06")   # a zip's first member, or an empty zip
_NPY_MAGIC = b"\x93NUMPY"
_FIXED_DATE = (1980, 1, 1, 0, 0, 0)   # the zip epoch: written files do not depend on the clock
_ZIP64_ABOVE = 1 << 30                # zip64 headers only for members that may need them
#: The errors of :func:`os.link` on a file system that has no hard links.
_NO_HARD_LINKS = frozenset({errno.EPERM, errno.EOPNOTSUPP, errno.ENOTSUP, errno.ENOSYS, errno.EMLINK})


def read_npz(path, *, what: str = "case") -> dict:
    """Read every array of an ``.npz`` file without pickle.

    Parameters
    ----------
    path : str or os.PathLike
    what : str
        "case" or "result", for the error messages.

    Returns
    -------
    dict of str -> ndarray

    Raises
    ------
    OSError
        The file cannot be opened (missing, a directory, no permission).
    CaseError
        The file is not an ``.npz`` archive (judged by its first bytes, not by numpy's
        guess that anything else is pickled data), is a damaged one, or a member cannot
        be read without pickle.
    """
    path = os.fspath(path)
    with open(path, "rb") as fh:        # OSError: missing, a folder, no permission
        head = fh.read(len(_NPY_MAGIC))
    if head.startswith(_NPY_MAGIC):
        raise CaseError(None, f"{what} file {path!r} holds a single .npy array, not an .npz archive of named arrays")
    if not head.startswith(_ZIP_MAGIC):   # numpy would take it for pickled data and say so
        raise CaseError(None, f"{what} file {path!r} is not an .npz archive (a zip of .npy arrays)")
    try:
        npz = np.load(path, allow_pickle=False)
    except OSError:
        raise
    except Exception as exc:  # a truncated or otherwise damaged zip
        raise CaseError(None, f"{what} file {path!r} is a damaged .npz archive ({exc})") from None
    out = {}
    with npz:
        for key in npz.files:
            try:
                value = npz[key]
            except ValueError as exc:
                raise CaseTypeError(key, f"cannot be read without pickle ({exc}); {what}s hold "
                                         "numeric, bool or unicode arrays only") from None
            except Exception as exc:
                raise CaseError(key, f"cannot be read from {path!r} ({exc})") from None
            if not isinstance(value, np.ndarray):
                raise CaseTypeError(key, f"is not a .npy array inside {path!r}")
            out[key] = value
    return out


def _as_storable(key, value) -> np.ndarray:
    if not isinstance(key, str) or not key.isidentifier():
        raise ValueError(f"array names must be identifiers, got {key!r}")
    arr = np.asarray(value)   # a Python str becomes a 0-d unicode array
    if arr.dtype.hasobject:
        raise TypeError(f"{key}: object arrays cannot be stored (they would need pickle)")
    return arr


def write_npz(path, arrays: Mapping, *, overwrite: bool = False, compress: bool = True,
              what: str = "result") -> None:
    """Write named arrays to an ``.npz`` file atomically and reproducibly.

    The archive is written through :func:`atomic_file`, so a reader never sees half a
    file and an existing file is never replaced unless ``overwrite``. Every member
    carries the same fixed date, so the same arrays always give the same bytes.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write (no ``.npz`` suffix is added).
    arrays : mapping of str -> array_like
        Python strings become 0-d unicode arrays; object arrays are refused.
    overwrite : bool
        Replace an existing file; otherwise raise :class:`ResultExistsError`.
    compress : bool
        Deflate the members (``np.load`` reads both).
    what : str
        What the file is ("result", "design", ...), for the message of :class:`ResultExistsError`.

    Raises
    ------
    ResultExistsError
        ``path`` exists (or appears while the archive is written) and ``overwrite`` is
        False; nothing is written.
    FileNotFoundError
        The folder of ``path`` does not exist.
    """
    items = [(k, _as_storable(k, v)) for k, v in arrays.items()]
    method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    with atomic_file(path, overwrite=overwrite, what=what) as fh, \
            zipfile.ZipFile(fh, "w", compression=method) as zf:
        for key, arr in items:
            info = zipfile.ZipInfo(key + ".npy", date_time=_FIXED_DATE)
            info.compress_type = method
            info.external_attr = 0o644 << 16
            with zf.open(info, "w", force_zip64=arr.nbytes > _ZIP64_ABOVE) as member:
                np.lib.format.write_array(member, arr, allow_pickle=False)


@contextmanager
def atomic_file(path, *, overwrite: bool = False, what: str = "result"):
    """A binary file to write whose bytes appear at ``path`` all at once, when the block
    ends without an error (see the module docstring).

    Parameters
    ----------
    path : str or os.PathLike
    overwrite : bool
        Replace an existing file; otherwise raise :class:`ResultExistsError`, before
        writing anything if ``path`` exists already, and at publication if it appeared
        in the meantime (the file there is left as it is).
    what : str
        What the file is, for the message of :class:`ResultExistsError`.

    Yields
    ------
    file
        Opened ``"xb"`` in the folder of ``path``; if the block raises, it is removed
        and nothing is published.

    Example
    -------
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
