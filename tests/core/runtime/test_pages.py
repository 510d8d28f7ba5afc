"""The memory of a run's large arrays (pes_ref.core.runtime.pages): anonymous maps without
huge-page advice from THRESHOLD bytes on, NumPy's below."""
import gc
import sys
import weakref

import numpy as np
import pytest

from pes_ref.core.runtime import pages

LARGE = pages.THRESHOLD // 8            # float64 entries of the smallest mapped array
linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/smaps")


def _vm_flags(a: np.ndarray) -> list:
    """The kernel's flags of the mapping that holds ``a``'s middle byte (/proc/self/smaps; NumPy
    advises from the first page boundary inside the array on)."""
    address = a.ctypes.data + a.nbytes // 2
    inside = False
    with open("/proc/self/smaps") as smaps:
        for line in smaps:
            head = line.split()[0]
            if "-" in head and not head.endswith(":"):
                lo, hi = (int(part, 16) for part in head.split("-"))
                inside = lo <= address < hi
            elif inside and head == "VmFlags:":
                return line.split()[1:]
    raise AssertionError(f"no mapping holds {address:#x}")


@pytest.mark.parametrize("make", [pages.empty, pages.zeros], ids=["empty", "zeros"])
@pytest.mark.parametrize("shape", [LARGE, (LARGE,), (3, LARGE // 2 + 1, 2)], ids=["int", "1-d", "3-d"])
@pytest.mark.parametrize("dtype", [np.float64, np.intp])
def test_a_large_array_is_a_whole_map_of_its_own(make, shape, dtype):
    a = make(shape, dtype)
    expected = (shape,) if isinstance(shape, int) else shape
    assert a.shape == expected and a.dtype == dtype
    assert a.flags.c_contiguous and a.flags.writeable and a.flags.aligned
    assert isinstance(a.base, pages.Pages) and len(a.base) == a.nbytes and pages.owns(a)
    a[...] = 7
    assert (a == 7).all()


@pytest.mark.parametrize("make", [pages.empty, pages.zeros], ids=["empty", "zeros"])
def test_a_small_array_is_numpys(make):
    a = make((LARGE - 1,))
    assert a.base is None and a.shape == (LARGE - 1,) and a.dtype == np.float64 and pages.owns(a)


@pytest.mark.parametrize("shape", [(LARGE,), (LARGE - 1,)], ids=["mapped", "numpys"])
def test_zeros_are_zero(shape):
    assert not pages.zeros(shape).any()


@linux
def test_a_mapped_array_has_no_huge_page_advice():
    """What the module is for: NumPy advises huge pages on an array this large, a map made here
    has no such advice (VmFlags ``hg``)."""
    ours = pages.empty((LARGE,))
    assert "hg" not in _vm_flags(ours)


@linux
@pytest.mark.skipif(not np._core.multiarray._get_madvise_hugepage(), reason="NumPy advises no huge pages here")
def test_numpy_advises_huge_pages_on_an_array_this_large():
    """The control of the test above: on this system NumPy's own array of the same size has the advice."""
    assert "hg" in _vm_flags(np.empty((LARGE,)))


@pytest.fixture(autouse=True)
def _nothing_kept():
    """Each test starts and ends with no idle map (a map held by an array stays whatever it does)."""
    pages.release()
    yield
    pages.release()


def test_a_map_is_kept_while_any_view_holds_it():
    a = pages.empty((4, LARGE // 4))
    held = weakref.ref(a.base)
    view = a[1:]
    del a
    gc.collect()
    assert held() is not None and pages.idle_bytes() == 0
    assert not pages.owns(view)                    # a view holds the map, and owns no memory
    other = pages.empty((4, LARGE // 4))           # the map is not idle: another is made
    assert other.base is not held()
    view[...] = 1.0
    other[...] = 2.0
    assert (view == 1.0).all()


def test_an_idle_map_is_reused_by_the_next_array_of_its_size():
    a = pages.empty((2, LARGE // 2))
    first = weakref.ref(a.base)
    a[...] = 3.0
    del a
    assert pages.idle_bytes() == LARGE * 8
    b = pages.empty((LARGE,))                      # the same bytes in another shape
    assert b.base is first() and pages.idle_bytes() == 0
    del b
    z = pages.zeros((LARGE // 2, 2))
    assert z.base is first() and not z.any()       # zeroed: it held 3.0


def test_an_array_of_another_size_gives_the_idle_maps_back():
    a, b = pages.empty((LARGE,)), pages.empty((LARGE,))
    kept = [weakref.ref(a.base), weakref.ref(b.base)]
    del a
    c = pages.empty((LARGE + 1,))                  # no idle map of its size: the idle one goes
    assert kept[0]() is None and kept[1]() is b.base and c.base is not b.base
    del b, c
    assert pages.idle_bytes() == 2 * LARGE * 8 + 8
    pages.release()
    assert pages.idle_bytes() == 0 and kept[1]() is None


def test_two_threads_never_share_a_map():
    """Both halves of a run allocate (pes_ref.accel.halves): every live array has memory of its own."""
    import threading
    seen, errors = [], []

    def work(i):
        try:
            for k in range(40):
                a = pages.empty((LARGE,))
                a.fill(i)
                seen.append(id(a.base))
                assert (a == i).all()          # nobody else wrote into it while it was held
                del a
        except AssertionError as exc:
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors and len(set(seen)) <= 3      # reused: a map each, at most a third between


@pytest.mark.parametrize("make", [pages.empty, pages.zeros], ids=["empty", "zeros"])
def test_memory_the_system_refuses_is_a_memory_error(make):
    """As NumPy's own refusal (which the oracle turns into its refusal naming n_steps), not an
    OSError: 1 PiB is beyond any process's address space."""
    with pytest.raises(MemoryError, match=r"unable to map 1125899906842624 bytes .* shape \(140737488355328,\)"):
        make((1 << 47,))
    assert pages.idle_bytes() == 0


def test_owns():
    mapped, numpys = pages.empty((2, LARGE)), np.empty((2, 3))
    assert pages.owns(mapped) and pages.owns(numpys)
    assert not pages.owns(mapped[:1]) and not pages.owns(numpys[:1]) and not pages.owns(mapped.reshape(-1))


def test_without_anonymous_maps_every_array_is_numpys(monkeypatch):
    monkeypatch.setattr(pages, "_FLAGS", None)
    a, z = pages.empty((LARGE,)), pages.zeros((LARGE,))
    assert a.base is None and z.base is None and not z.any()
