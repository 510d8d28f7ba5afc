"""``.npz`` archives of named arrays: read without pickle, written reproducibly and atomically.

Every ``.npz`` the package reads or writes goes through here (the oracle's cases and results, design
files). [`write_npz`][pes_ref.core.runtime.npz.write_npz] writes through the package's one atomic
writer, [`pes_ref.core.runtime.files.atomic_file`][pes_ref.core.runtime.files.atomic_file]: a reader
never sees half a file, and an existing file is never replaced unless asked.

The reader knows no format: its refusals are [`NpzError`][pes_ref.core.runtime.npz.NpzError] (a ``ValueError``
carrying the member at fault, or None for the file as a whole), which each format turns into
its own error where it reads its files (the oracle's ``CaseError``, a design file's ``DesignFileError``).
"""
from __future__ import annotations

import os
import zipfile
from collections.abc import Mapping

import numpy as np

from pes_ref.core.runtime.files import atomic_file

__all__ = ["read_npz", "write_npz", "NpzError", "NpzTypeError"]

_ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06")   # a zip's first member, or an empty zip
_NPY_MAGIC = b"\x93NUMPY"
_FIXED_DATE = (1980, 1, 1, 0, 0, 0)   # the zip epoch: written files do not depend on the clock
_ZIP64_ABOVE = 1 << 30                # zip64 headers only for members that may need them


class NpzError(ValueError):
    """An ``.npz`` file that cannot be read as named arrays without pickle.

    The message is ``reason`` for the file as a whole (``key`` None), else
    ``"<what> key '<key>': <reason>"``, one line.

    Parameters
    ----------
    key : str or None
        The member at fault (its array name), or None when the file as a whole is no readable ``.npz``.
    reason : str
        What is wrong with it.
    what : str
        What the file is ("case", "design", ...), for the message.
    """

    def __init__(self, key: str | None, reason: str, what: str = "npz"):
        self.key = key
        self.reason = " ".join(str(reason).split())
        super().__init__(self.reason if key is None else f"{what} key {key!r}: {self.reason}")


class NpzTypeError(NpzError, TypeError):
    """A member that holds no plain array (one that would need pickle). Both an
    [`NpzError`][pes_ref.core.runtime.npz.NpzError] and a ``TypeError``."""


def read_npz(path, *, what: str = "npz") -> dict:
    """Read every array of an ``.npz`` file without pickle.

    Parameters
    ----------
    path : str or os.PathLike
    what : str
        What the file is ("case", "result", "design"), for the error messages.

    Returns
    -------
    dict of str -> ndarray

    Raises
    ------
    OSError
        The file cannot be opened (missing, a directory, no permission).
    NpzError
        The file is not an ``.npz`` archive (judged by its first bytes, not by numpy's
        guess that anything else is pickled data), is a damaged one, or a member cannot
        be read (an [`NpzTypeError`][pes_ref.core.runtime.npz.NpzTypeError] if only pickle could read it).
    """
    path = os.fspath(path)
    with open(path, "rb") as fh:        # OSError: missing, a folder, no permission
        head = fh.read(len(_NPY_MAGIC))
    if head.startswith(_NPY_MAGIC):
        raise NpzError(None, f"{what} file {path!r} holds a single .npy array, not an .npz archive of named arrays")
    if not head.startswith(_ZIP_MAGIC):   # numpy would take it for pickled data and say so
        raise NpzError(None, f"{what} file {path!r} is not an .npz archive (a zip of .npy arrays)")
    try:
        npz = np.load(path, allow_pickle=False)
    except OSError:
        raise
    except Exception as exc:  # a truncated or otherwise damaged zip
        raise NpzError(None, f"{what} file {path!r} is a damaged .npz archive ({exc})") from None
    out = {}
    with npz:
        for key in npz.files:
            try:
                value = npz[key]
            except ValueError as exc:
                raise NpzTypeError(key, f"cannot be read without pickle ({exc}); {what}s hold "
                                        "numeric, bool or unicode arrays only", what) from None
            except Exception as exc:
                raise NpzError(key, f"cannot be read from {path!r} ({exc})", what) from None
            if not isinstance(value, np.ndarray):
                raise NpzTypeError(key, f"is not a .npy array inside {path!r}", what)
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

    The archive is written through [`atomic_file`][pes_ref.core.runtime.files.atomic_file], so a
    reader never sees half a file and an existing file is never replaced unless ``overwrite``. Every
    member carries the same fixed date, so the same arrays always give the same bytes.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write (no ``.npz`` suffix is added).
    arrays : mapping of str -> array_like
        Python strings become 0-d unicode arrays; object arrays are refused.
    overwrite : bool
        Replace an existing file; otherwise raise [`ResultExistsError`][pes_ref.core.runtime.files.ResultExistsError].
    compress : bool
        Deflate the members (``np.load`` reads both).
    what : str
        What the file is ("result", "design", ...), for the message of
        [`ResultExistsError`][pes_ref.core.runtime.files.ResultExistsError].

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
