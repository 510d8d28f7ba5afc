"""``.npz`` archives of named arrays: read without pickle, written reproducibly and atomically.

The case and result files of the oracle ([`pes_ref.oracle.case`][pes_ref.oracle.case]) are such archives;
any other ``.npz`` the package writes (design files) goes through [`write_npz`][pes_ref.oracle.npz.write_npz] too,
which writes through the package's one atomic writer,
[`pes_ref.core.runtime.files.atomic_file`][pes_ref.core.runtime.files.atomic_file]: a reader never sees half a file, and
an existing
file is never replaced unless asked.
"""
from __future__ import annotations

import os
import zipfile
from collections.abc import Mapping

import numpy as np

from pes_ref.core.runtime.files import atomic_file
from pes_ref.oracle.errors import CaseError, CaseTypeError

__all__ = ["read_npz", "write_npz"]

_ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06")   # a zip's first member, or an empty zip
_NPY_MAGIC = b"\x93NUMPY"
_FIXED_DATE = (1980, 1, 1, 0, 0, 0)   # the zip epoch: written files do not depend on the clock
_ZIP64_ABOVE = 1 << 30                # zip64 headers only for members that may need them


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

    The archive is written through [`atomic_file`][pes_ref.core.runtime.files.atomic_file], so a reader never sees half
    a
    file and an existing file is never replaced unless ``overwrite``. Every member
    carries the same fixed date, so the same arrays always give the same bytes.

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
