"""Unit tests of pes_ref.core.checks: the validation boundary (docs/decisions.md item 12)."""
import numpy as np
import pytest

from pes_ref.core import checks
from pes_ref.oracle.tolerances import TRAJ_RTOL

NAME = "my_arg"          # a distinctive argument name that every error must quote
NAME_RE = rf"\b{NAME}\b"


def assert_rejects(exc, fn, *args, **kw):
    """``fn(*args, **kw)`` raises one keyed error: a :class:`checks.InputError` whose
    ``key`` is NAME and whose message names it, a ``TypeError`` (an
    :class:`checks.InputTypeError`) exactly when ``exc`` is ``TypeError``."""
    with pytest.raises(checks.InputError, match=NAME_RE) as info:
        fn(*args, **kw)
    assert info.value.key == NAME
    assert isinstance(info.value, ValueError)
    assert isinstance(info.value, TypeError) == (exc is TypeError)
    assert isinstance(info.value, checks.InputTypeError) == (exc is TypeError)


# --------------------------------------------------------------------------- inputs

def _readonly(a):
    a = np.array(a)
    a.setflags(write=False)
    return a


FLOAT_INPUTS = {
    "list_of_int": lambda: [[1, 2], [3, 4]],
    "int64": lambda: np.array([[1, 2], [3, 4]], dtype=np.int64),
    "int8": lambda: np.array([[1, 2], [3, 4]], dtype=np.int8),
    "float32": lambda: np.array([[0.1, 2.5], [3.0, -4.25]], dtype=np.float32),
    "bool": lambda: np.array([[True, False], [False, True]]),
    "float64_readonly": lambda: _readonly([[0.1, 2.5], [3.0, -4.25]]),
    "float64_noncontiguous": lambda: np.arange(16.0).reshape(4, 4)[::2, ::2],
    "float64_transposed": lambda: np.asfortranarray(np.arange(4.0).reshape(2, 2)),
    "float32_readonly_noncontiguous": lambda: _readonly(np.arange(16, dtype=np.float32).reshape(4, 4))[1::2, ::3],
}


@pytest.mark.parametrize("kind", sorted(FLOAT_INPUTS))
def test_as_float_array_promotes_to_float64_with_same_values(kind):
    src = FLOAT_INPUTS[kind]()
    out = checks.as_float_array(NAME, src, shape=(2, 2))
    assert out.dtype == np.float64
    assert out.shape == (2, 2)
    np.testing.assert_array_equal(out, np.asarray(src).astype(np.float64))


@pytest.mark.parametrize("kind", sorted(k for k in FLOAT_INPUTS if k != "list_of_int"))
def test_as_float_array_never_touches_the_callers_array(kind):
    src = FLOAT_INPUTS[kind]()
    before = src.copy()
    writeable = src.flags.writeable
    out = checks.as_float_array(NAME, src, shape=(2, 2))
    assert not np.shares_memory(out, src)
    assert not out.flags.writeable          # the core cannot write into it either
    assert src.flags.writeable == writeable
    np.testing.assert_array_equal(src, before)
    assert src.dtype == before.dtype


def test_as_float_array_of_writeable_float64_is_a_copy_and_caller_stays_writeable():
    src = np.array([1.0, 2.0])
    out = checks.as_float_array(NAME, src, shape=(2,))
    assert src.flags.writeable
    src[0] = 7.0                            # the caller may still write ...
    assert out[0] == 1.0                    # ... without affecting the converted value


@pytest.mark.parametrize("shape_spec, value", [
    ((None, 2), np.zeros((5, 2))),
    ((None, 2), np.zeros((0, 2))),
    ((3, None), np.zeros((3, 7))),
    ((2,), [1, 2]),
    ((), 3),
])
def test_as_float_array_accepts_matching_shapes(shape_spec, value):
    assert checks.as_float_array(NAME, value, shape=shape_spec).shape == np.shape(value)


@pytest.mark.parametrize("value, broadcast_to", [
    (1.0, (4, 2)), ([1.0, 2.0], (4, 2)), (np.ones((4, 1)), (4, 2)), (np.ones((4, 2)), (4, 2)),
])
def test_as_float_array_broadcastable_keeps_own_shape(value, broadcast_to):
    assert checks.as_float_array(NAME, value, broadcast_to=broadcast_to).shape == np.shape(value)


@pytest.mark.parametrize("value, kw, exc", [
    ("abc", {}, TypeError),
    (b"abc", {}, TypeError),
    (np.array(["a", "b"]), {}, TypeError),
    ([1 + 2j, 3], {}, TypeError),
    (np.array([1, None], dtype=object), {}, TypeError),
    ([[1, 2], [3]], {}, TypeError),                       # ragged
    (None, {}, TypeError),
    (np.zeros(3), {"ndim": 2}, ValueError),
    (np.zeros((3, 3)), {"shape": (None, 2)}, ValueError),
    (np.zeros(2), {"shape": (2, 1)}, ValueError),
    (np.zeros(3), {"broadcast_to": (4, 2)}, ValueError),
    (np.zeros((2, 4, 2)), {"broadcast_to": (4, 2)}, ValueError),   # broadcasts, but to a bigger shape
    ([1.0, np.nan], {}, ValueError),
    ([1.0, np.inf], {}, ValueError),
    ([1.0, -np.inf], {}, ValueError),
    ([1.0, 0.0], {"positive": True}, ValueError),
    ([1.0, -1e-300], {"nonneg": True}, ValueError),
])
def test_as_float_array_rejections_name_the_argument(value, kw, exc):
    assert_rejects(exc, checks.as_float_array, NAME, value, **kw)


def test_as_float_array_finite_false_admits_inf():
    out = checks.as_float_array(NAME, [np.inf, 1.0], finite=False)
    assert np.isinf(out[0])


# --------------------------------------------------------------------------- bool arrays

BOOL_INPUTS = {
    "tuple_of_bool": lambda: (True, False),
    "ints_01": lambda: np.array([1, 0]),
    "list_01": lambda: [0, 1],
    "bool_readonly": lambda: _readonly([True, True]),
    "bool_noncontiguous": lambda: np.array([True, False, False, True])[::2],
    "int_readonly_noncontiguous": lambda: _readonly([1, 9, 0, 9])[::2],
}


@pytest.mark.parametrize("kind", sorted(BOOL_INPUTS))
def test_as_bool_array_accepts_and_never_touches_the_input(kind):
    src = BOOL_INPUTS[kind]()
    before = np.array(src, copy=True)
    writeable = src.flags.writeable if isinstance(src, np.ndarray) else None
    out = checks.as_bool_array(NAME, src, shape=(2,))
    assert out.dtype == bool
    np.testing.assert_array_equal(out, np.asarray(before).astype(bool))
    assert not out.flags.writeable
    if isinstance(src, np.ndarray):
        assert not np.shares_memory(out, src)
        assert src.flags.writeable == writeable
        np.testing.assert_array_equal(src, before)


@pytest.mark.parametrize("value, exc", [
    ([2, 0], ValueError),
    ([0.5, 1.0], ValueError),
    ([-1, 0], ValueError),
    (["yes", "no"], TypeError),
    ("yes", TypeError),
    ([1j, 0], TypeError),
    (None, TypeError),
    ([True, False, True], ValueError),
    ([[True, False]], ValueError),
])
def test_as_bool_array_rejections_name_the_argument(value, exc):
    assert_rejects(exc, checks.as_bool_array, NAME, value, shape=(2,))


# --------------------------------------------------------------------------- scalars

FLOAT_SCALARS = [checks.as_finite_float, checks.as_positive_float, checks.as_nonneg_float]


@pytest.mark.parametrize("fn", FLOAT_SCALARS, ids=lambda f: f.__name__)
@pytest.mark.parametrize("value, want", [
    (3, 3.0), (np.int64(3), 3.0), (np.float32(0.5), 0.5), (np.array(2.25), 2.25),
    (np.array(2.25, dtype=np.float32), 2.25), (_readonly(1.5), 1.5),
])
def test_float_scalars_promote_to_python_float(fn, value, want):
    out = fn(NAME, value)
    assert type(out) is float
    assert out == want


@pytest.mark.parametrize("fn, value, exc", [
    (checks.as_finite_float, True, TypeError),
    (checks.as_finite_float, np.bool_(False), TypeError),
    (checks.as_finite_float, "1.0", TypeError),
    (checks.as_finite_float, 1 + 1j, TypeError),
    (checks.as_finite_float, [1.0], ValueError),
    (checks.as_finite_float, np.zeros((2, 2)), ValueError),
    (checks.as_finite_float, np.nan, ValueError),
    (checks.as_finite_float, -np.inf, ValueError),
    (checks.as_positive_float, 0.0, ValueError),
    (checks.as_positive_float, -2, ValueError),
    (checks.as_positive_float, np.inf, ValueError),
    (checks.as_nonneg_float, -1e-300, ValueError),
    (checks.as_nonneg_float, np.nan, ValueError),
], ids=lambda p: getattr(p, "__name__", repr(p)))
def test_float_scalar_rejections_name_the_argument(fn, value, exc):
    assert_rejects(exc, fn, NAME, value)


@pytest.mark.parametrize("fn, value, want", [
    (checks.as_nonneg_int, 0, 0), (checks.as_nonneg_int, np.int32(7), 7),
    (checks.as_positive_int, 1, 1), (checks.as_positive_int, np.array(4), 4),
])
def test_int_scalars_accept_integers(fn, value, want):
    out = fn(NAME, value)
    assert type(out) is int and out == want


@pytest.mark.parametrize("fn, value, exc", [
    (checks.as_nonneg_int, 3.0, TypeError),
    (checks.as_nonneg_int, True, TypeError),
    (checks.as_nonneg_int, "3", TypeError),
    (checks.as_nonneg_int, [3], TypeError),
    (checks.as_nonneg_int, -1, ValueError),
    (checks.as_positive_int, 0, ValueError),
    (checks.as_positive_int, 2.5, TypeError),
], ids=lambda p: getattr(p, "__name__", repr(p)))
def test_int_scalar_rejections_name_the_argument(fn, value, exc):
    assert_rejects(exc, fn, NAME, value)


@pytest.mark.parametrize("fn, least", [(checks.as_positive_int, 1), (checks.as_nonneg_int, 0)])
def test_every_count_below_the_least_gets_the_same_rule(fn, least):
    """``-3`` and ``0`` for a positive count: one rule, '>= 1', not '>= 0' for the one."""
    for value in (least - 1, least - 4):
        with pytest.raises(checks.InputError) as info:
            fn(NAME, value)
        assert str(info.value) == f"{NAME} must be >= {least}, got {value}"


@pytest.mark.parametrize("value", ["a", np.array("a")])
def test_as_choice_accepts_str_and_0d_unicode(value):
    out = checks.as_choice(NAME, value, {"a", "b"})
    assert out == "a" and type(out) is str


@pytest.mark.parametrize("value, exc", [("c", ValueError), (1, TypeError), (None, TypeError),
                                        (np.array(["a"]), TypeError)])
def test_as_choice_rejections_name_the_argument(value, exc):
    assert_rejects(exc, checks.as_choice, NAME, value, {"a", "b"})


# --------------------------------------------------------------------------- reduce_to_shape

BIG = (3, 4, 2)


@pytest.mark.parametrize("small", [(), (1,), (2,), (1, 2), (4, 1), (4, 2), (1, 1), (3, 1, 1), (3, 4, 2), (1, 4, 1)])
def test_reduce_to_shape_is_the_adjoint_of_broadcasting(small):
    """<broadcast(a), g> == <a, reduce(g)> for random a, g (the dot-product identity)."""
    rng = np.random.default_rng([len(small), *small])
    a = rng.standard_normal(small)
    g = rng.standard_normal(BIG)
    r = checks.reduce_to_shape(g, small)
    assert r.shape == small
    lhs = float(np.sum(np.broadcast_to(a, BIG) * g))
    rhs = float(np.sum(a * r))
    assert abs(lhs - rhs) <= TRAJ_RTOL * max(abs(lhs), np.sum(np.abs(g)))


@pytest.mark.parametrize("small", [(), (2,), (4, 1), (1, 2)])
def test_reduce_to_shape_sums_the_broadcast_copies(small):
    """Reducing ones gives the number of copies each entry was broadcast to."""
    r = checks.reduce_to_shape(np.ones(BIG), small)
    copies = int(np.prod(BIG)) // max(int(np.prod(small)), 1)
    np.testing.assert_array_equal(r, np.full(small, float(copies)))
