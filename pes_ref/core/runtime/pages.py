"""The memory of a run's large arrays: anonymous maps of the system's base pages.

A run's arrays scale with ``(T+1) N`` ([`pes_ref.core.budget`][pes_ref.core.budget]): the trajectory, its
force schedule, the energy, ``dL/dX`` and ``grad_force`` are hundreds of megabytes each
at N = 65,536. NumPy asks the kernel for 2 MiB pages (``madvise(MADV_HUGEPAGE)``) on
every array of 4 MiB or more. Where transparent huge pages are set to ``madvise`` with
direct compaction (common Linux defaults), the first write into such an array waits
while the kernel compacts memory to find them, and how long depends on how fragmented
the machine's memory is: 0.1 to 1.3 s of system time for one oracle run at N = 65,536,
T = 100 on the reference machine, against a steady 0.35 s with base pages
(docs/performance.md, "Large runs and huge pages").

[`empty`][pes_ref.core.runtime.pages.empty] and [`zeros`][pes_ref.core.runtime.pages.zeros] give
such arrays from anonymous private maps (`mmap`), without that advice. And they reuse them: memory
that is new costs a page fault per 4 KiB page on first touch (about 1.5 us each: 0.71-0.79 s a run
at N = 65,536, T = 100, against 0.61 s in memory touched before). So a map whose arrays are all gone
(nothing refers to it but this module, as its reference count tells) is kept, idle, and the next
array of its size in bytes is made in it (zeroed first for
[`zeros`][pes_ref.core.runtime.pages.zeros]). An allocation that finds no idle map of its size first
gives every idle map back to the system ([`release`][pes_ref.core.runtime.pages.release]), so what
is kept is at most the arrays of the last size of run, and a run of another size starts from nothing
kept; [`idle_bytes`][pes_ref.core.runtime.pages.idle_bytes] counts as available memory for
[`pes_ref.core.budget.available_memory`][pes_ref.core.budget.available_memory]. The maps are shared
by every thread under one lock (both halves of [`pes_ref.accel.halves`][pes_ref.accel.halves]
allocate).

An array of less than `THRESHOLD` bytes, or any array on a system without anonymous maps, comes from
NumPy as usual. A map the system refuses raises `MemoryError`, as NumPy's refusal does.
[`owns`][pes_ref.core.runtime.pages.owns] tells an array made here, which owns its memory as an
array from `numpy.empty` does.
"""
from __future__ import annotations

import errno
import math
import mmap
import sys
import threading

import numpy as np

__all__ = ["THRESHOLD", "Pages", "empty", "zeros", "owns", "idle_bytes", "release"]

#: Arrays of at least this many bytes are mapped here: NumPy's own threshold for asking for
#: huge pages (4 MiB); a smaller array is NumPy's.
THRESHOLD = 1 << 22

#: The flags of a private anonymous map; None on a system without them.
_PRIVATE = getattr(mmap, "MAP_PRIVATE", None)
_ANONYMOUS = getattr(mmap, "MAP_ANONYMOUS", None)
_FLAGS = None if _PRIVATE is None or _ANONYMOUS is None else _PRIVATE | _ANONYMOUS


class Pages(mmap.mmap):
    """An anonymous map that holds one array's memory (the array's ``base``)."""


#: Every map made here and not given back: held by arrays, or idle. Guarded by ``_LOCK``.
_MAPS: list = []
_LOCK = threading.Lock()


def _counts(maps: list) -> list:
    """Each map's reference count, as seen from here."""
    return [sys.getrefcount(m) for m in maps]


#: The count of a map that nothing refers to but ``_MAPS``: that of an object held only by a list.
_UNHELD = _counts([object()])[0]


def _idle() -> list:
    """The maps no array refers to any more (call with ``_LOCK`` held)."""
    return [m for m, count in zip(_MAPS, _counts(_MAPS)) if count <= _UNHELD]


def _mapped(shape, dtype, zero: bool):
    """An array of ``shape`` in a map (an idle one of its size, else a new one), or None where
    NumPy's is to be used."""
    dtype = np.dtype(dtype)
    shape = (shape,) if isinstance(shape, int) else tuple(shape)
    nbytes = math.prod(shape) * dtype.itemsize
    if _FLAGS is None or nbytes < THRESHOLD:
        return None
    with _LOCK:
        kept = next((m for m in _idle() if len(m) == nbytes), None)
        if kept is None:
            _release()
            try:
                kept = Pages(-1, nbytes, flags=_FLAGS)
            except OSError as exc:              # the system's refusal, as NumPy says it
                if exc.errno != errno.ENOMEM:
                    raise
                raise MemoryError(f"unable to map {nbytes} bytes for an array of shape {shape} and data type "
                                  f"{dtype}") from None
            _MAPS.append(kept)
            zero = False                     # a new map's pages are zero pages
        a = np.ndarray(shape, dtype, buffer=kept)
    if zero:
        a.fill(0)
    return a


def _release() -> None:
    idle = {id(m) for m in _idle()}
    _MAPS[:] = [m for m in _MAPS if id(m) not in idle]


def release() -> None:
    """Give every idle map back to the system."""
    with _LOCK:
        _release()


def idle_bytes() -> int:
    """The bytes of the idle maps: memory the next run reuses, or gives back first."""
    with _LOCK:
        return sum(len(m) for m in _idle())


def empty(shape, dtype=np.float64) -> np.ndarray:
    """A new C-contiguous array whose values are to be written, as `numpy.empty`."""
    a = _mapped(shape, dtype, zero=False)
    return np.empty(shape, dtype) if a is None else a


def zeros(shape, dtype=np.float64) -> np.ndarray:
    """A new C-contiguous array of zeros, as `numpy.zeros`."""
    a = _mapped(shape, dtype, zero=True)
    return np.zeros(shape, dtype) if a is None else a


def owns(a: np.ndarray) -> bool:
    """Whether ``a`` holds memory of its own: NumPy's (no ``base``) or a whole map made here."""
    if a.base is None:
        return True
    return isinstance(a.base, Pages) and a.nbytes == len(a.base)
