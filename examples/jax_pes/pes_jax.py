#!/usr/bin/env python3
"""pes_jax: an independent JAX implementation of the pes_ref case format (SPEC section 6).

    python pes_jax.py [--refusals FILE.jsonl] CASE.npz RESULT.npz [CASE2.npz RESULT2.npz ...]

Reads each case, validates it against SPEC.md (and the format rules of docs/oracle.md),
runs the forward pass of SPEC sections 1-3 with ``jax.lax.scan`` under ``jax.jit`` in
float64, takes the loss of section 4 and every gradient section 5 owes with
``jax.value_and_grad`` (reverse-mode autodiff, no hand-written adjoint), and writes the
result ``.npz`` (``x, v, energy, loss, grad_<name>``) atomically. A case that breaks
the SPEC gets one line ``error: ...`` on stderr, no result file, and exit status 2.
Pairs are independent; the exit status is 2 if any case was refused. With
``--refusals FILE.jsonl`` each refusal is also appended to FILE as one JSON line
``{"case": <case path>, "key": <key or null>, "error": "ValueError" | "TypeError",
"message": ...}`` (the ``{refusals}`` of ``pes_ref check``, docs/spec.md section 13).

Written from SPEC.md, docs/decisions.md, docs/oracle.md and docs/adjoint.md; where
they leave the order of floating-point operations open, the choice (and the pes_ref
code that decided it) is noted at the place in the code and in README.md.

Environment:
    PES_JAX_CACHE_DIR   persistent XLA compilation cache (default: the folder
                        pes_jax_xla_cache-<uid> in the system temporary folder;
                        empty string: no persistent cache)
    PES_JAX_PAD=0       do not pad shapes to buckets (one compilation per exact shape)
    PES_JAX_SLOPE=spec  evaluate the grid force by the SPEC section 1 slope formula
                        literally instead of the regrouped affine form (see README)
    PES_JAX_STABILITY=0 do not refuse a step past the stability limit of its
                        stiffest term (docs/spec.md section 10) before the run
"""
from __future__ import annotations

import os
import re
import sys
import tempfile
import zipfile

import numpy as np

PAD = os.environ.get("PES_JAX_PAD", "1") != "0"
SLOPE_SPEC = os.environ.get("PES_JAX_SLOPE", "") == "spec"
STABILITY = os.environ.get("PES_JAX_STABILITY", "1") != "0"

# jax is imported only once a case has passed validation (_init_jax), so that refusing
# an invalid case costs a NumPy import, not a JAX start-up.
jax = jnp = lax = safe_sqrt = None


def _init_jax() -> None:
    """Configure XLA, import jax in float64 and enable the persistent compilation cache.

    Two XLA rewrites change the last bit of a result, which chaotic runs amplify until a
    1e-12 match with the NumPy reference is impossible:
    - the CPU backend contracts a*b + c into one fused multiply-add when the ISA has FMA;
      capping the ISA at SSE4.2 keeps every multiply and add separately rounded;
    - the algebraic simplifier turns a division by a broadcast value, such as
      (q - lower) / h, into a multiplication by its reciprocal; the pass is disabled
      (its other rewrites do not matter for programs this small).
    Both are checked at start-up (_check_exact_arithmetic). Compile time dominates a
    run (the programs execute in milliseconds); LLVM's cheaper pipeline (two more flags)
    cuts it ~2.5x without licensing any value-changing rewrite (there is no fast-math).
    A user's own setting of any of these flags is respected. Our flags go first: XLA
    stops reading XLA_FLAGS at a word without leading dashes (e.g. a stray
    "intra_op_parallelism_threads=1"), so flags after one would be lost."""
    global jax, jnp, lax, safe_sqrt
    if jax is not None:
        return
    flags = os.environ.get("XLA_FLAGS", "")
    m = re.search(r"--xla_disable_hlo_passes=(\S*)", flags)
    if m and "algsimp" not in m.group(1).split(","):
        flags = flags[:m.end(1)] + ("," if m.group(1) else "") + "algsimp" + flags[m.end(1):]
    for name, value in (("xla_cpu_multi_thread_eigen", "false"), ("xla_cpu_max_isa", "SSE4_2"),
                        ("xla_disable_hlo_passes", "algsimp"),
                        ("xla_backend_optimization_level", "0"), ("xla_llvm_disable_expensive_passes", "true")):
        if name not in flags:
            flags = f"--{name}={value} " + flags
    os.environ["XLA_FLAGS"] = flags.strip()
    os.environ.setdefault("JAX_PLATFORMS", "cpu")
    os.environ.setdefault("TF_CPP_MIN_LOG_LEVEL", "2")
    import jax as _jax
    _jax.config.update("jax_enable_x64", True)
    import jax.numpy as _jnp
    from jax import lax as _lax
    jax, jnp, lax = _jax, _jnp, _lax
    cache = os.environ.get("PES_JAX_CACHE_DIR",
                           os.path.join(tempfile.gettempdir(), f"pes_jax_xla_cache-{getattr(os, 'getuid', lambda: 0)()}"))
    if cache:
        try:
            os.makedirs(cache, exist_ok=True)
            jax.config.update("jax_compilation_cache_dir", cache)
            jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
            jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
        except Exception:  # an unwritable folder, an older jax: run without the persistent cache
            pass

    @jax.custom_jvp
    def _safe_sqrt(s):
        return jnp.sqrt(s)

    @_safe_sqrt.defjvp
    def _safe_sqrt_jvp(primals, tangents):
        (s,), (t,) = primals, tangents
        r = jnp.sqrt(s)
        pos = s > 0
        # SPEC section 4: where the root's argument is 0 its derivative is taken as 0
        return r, jnp.where(pos, t / (2.0 * jnp.where(pos, r, 1.0)), 0.0)

    safe_sqrt = _safe_sqrt
    _check_exact_arithmetic()


# =========================================================================== the case format

MODES = ("dynamic", "quasistatic")
REQUIRED_KEYS = ("values", "lower", "upper", "periodic", "dt", "n_steps", "mode",
                 "mass", "damping", "x0", "v0", "objective")
OPTIONAL_KEYS = ("t0", "mobility", "force", "spring_k", "spring_center",
                 "wall_k", "wall_margin", "walls", "regularization")
OBJECTIVE_PARAMS = {"funnel": ("target", "when"),
                    "oscillator": ("amplitude", "omega"),
                    "quadratic": ("wx", "wv", "xref", "vref")}
CASE_KEYS = REQUIRED_KEYS + OPTIONAL_KEYS + tuple(p for ps in OBJECTIVE_PARAMS.values() for p in ps)
KEY_GROUPS = (("spring_k", "spring_center"), ("wall_k", "wall_margin", "walls"))
GRADIENT_NAMES = ("values", "x0", "v0", "force", "mass", "damping", "spring_k", "spring_center", "mobility")


class CaseError(ValueError):
    """A case that breaks the SPEC; ``key`` names the key at fault (None: not an .npz)."""

    def __init__(self, key, reason, kind="ValueError"):
        self.key, self.kind = key, kind
        reason = " ".join(str(reason).split())
        super().__init__(reason if key is None else f"case key {key!r}: {reason}")


def _typeerr(key, reason):
    return CaseError(key, reason, kind="TypeError")


def _desc(a) -> str:
    return f"dtype {a.dtype}, shape {a.shape}"


def _short(a) -> str:
    text = " ".join(np.array2string(np.asarray(a), threshold=6, edgeitems=2).split())
    return text if len(text) <= 60 else text[:57] + "..."


def read_case(path) -> dict:
    """Every member of the .npz, read without pickle."""
    try:
        npz = np.load(path, allow_pickle=False)
    except OSError as exc:
        raise CaseError(None, f"cannot read case file {path!r} ({exc.strerror or exc})") from None
    except Exception as exc:
        raise CaseError(None, f"case file {path!r} is not a readable .npz archive ({exc})") from None
    if not isinstance(npz, np.lib.npyio.NpzFile):
        raise CaseError(None, f"case file {path!r} holds a single .npy array, not an .npz archive")
    out = {}
    with npz:
        for key in npz.files:
            try:
                out[key] = npz[key]
            except ValueError as exc:
                raise _typeerr(key, f"cannot be read without pickle ({exc})") from None
            except Exception as exc:
                raise CaseError(key, f"cannot be read ({exc})") from None
    return out


def _numeric(key, a) -> np.ndarray:
    a = np.asarray(a)
    if a.dtype.kind not in "iuf":
        raise _typeerr(key, f"{key} must be a real number array of integer or float dtype, got {_desc(a)}")
    return a


def _finite(key, a) -> np.ndarray:
    with np.errstate(over="ignore", invalid="ignore"):
        f = a.astype(np.float64)
    if not np.all(np.isfinite(f)):
        raise CaseError(key, f"{key} must be finite, got {_short(a)}")
    return f


def _float_array(key, a, shape=None, ndim=None) -> np.ndarray:
    a = _numeric(key, a)
    if ndim is not None and a.ndim != ndim:
        raise CaseError(key, f"{key} must be {ndim}-D, got shape {a.shape}")
    if shape is not None and (len(shape) != a.ndim or any(s is not None and s != t for s, t in zip(shape, a.shape))):
        want = "(" + ", ".join("N" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"
        raise CaseError(key, f"{key} must have shape {want}, got shape {a.shape}")
    return _finite(key, a)


def _scalar(key, a) -> float:
    a = _numeric(key, a)
    if a.ndim != 0:
        raise CaseError(key, f"{key} must be a scalar (a 0-d array), got shape {a.shape}")
    return float(_finite(key, a))


def _string(key, a, choices) -> str:
    if not (isinstance(a, np.ndarray) and a.dtype.kind == "U" and a.ndim == 0):
        raise _typeerr(key, f"{key} must be a string stored as a 0-d unicode array, got "
                            f"{_desc(np.asarray(a)) if not isinstance(a, str) else repr(a)}")
    s = str(a)
    if s not in choices:
        raise CaseError(key, f"{key} must be one of {list(choices)}, got {s!r}")
    return s


def _flags(key, a, shape) -> np.ndarray:
    a = np.asarray(a)
    if a.dtype.kind not in "biu":
        raise _typeerr(key, f"{key} must be a bool array (or integers 0/1), got {_desc(a)}")
    if a.shape != shape:
        raise CaseError(key, f"{key} must have shape {shape}, got shape {a.shape}")
    if a.dtype.kind != "b" and not np.all((a == 0) | (a == 1)):
        raise CaseError(key, f"{key} must hold 0/1 flags, got {_short(a)}")
    return a.astype(bool)


def _per_particle(key, a, n) -> np.ndarray:
    """Broadcasts to (N, 2) with at most 2 dimensions (scalar, (2,), (N, 1), (N, 2), (1,) ...)."""
    a = _numeric(key, a)
    ok = a.ndim <= 2
    if ok:
        try:
            np.broadcast_shapes(a.shape, (n, 2))
            ok = np.broadcast_shapes(a.shape, (n, 2)) == (n, 2)
        except ValueError:
            ok = False
    if not ok:
        raise CaseError(key, f"{key} must broadcast to (N, 2) = ({n}, 2), got shape {a.shape}")
    return _finite(key, a)


def _sign(key, a, positive=False, nonneg=False):
    if positive and not np.all(a > 0):
        raise CaseError(key, f"{key} must be > 0, got {_short(a)}")
    if nonneg and not np.all(a >= 0):
        raise CaseError(key, f"{key} must be >= 0, got {_short(a)}")
    return a


def validate(raw: dict) -> dict:
    """Check a case (SPEC section 6; the rules and their order as docs/oracle.md lists them)
    and return its normalized float64 contents."""
    for key in sorted(raw):
        if key not in CASE_KEYS:
            raise CaseError(key, f"unknown key; a case holds only {list(CASE_KEYS)}")
    for key in REQUIRED_KEYS:
        if key not in raw:
            raise CaseError(key, "missing required key")
    mode = _string("mode", raw["mode"], MODES)
    objective = _string("objective", raw["objective"], tuple(OBJECTIVE_PARAMS))
    own = OBJECTIVE_PARAMS[objective]
    for name, params in OBJECTIVE_PARAMS.items():
        for p in params:
            if name != objective and p in raw and p not in own:
                raise CaseError(p, f"is a parameter of objective {name!r}, not of {objective!r} (which takes {list(own)})")
    for p in own:
        if p not in raw:
            raise CaseError(p, f"missing required key (objective {objective!r} takes {list(own)})")
    if mode == "quasistatic" and "mobility" not in raw:
        raise CaseError("mobility", "missing required key (quasistatic mode needs a mobility, shape (2,), > 0)")
    if mode == "dynamic" and "mobility" in raw:
        raise CaseError("mobility", "is only for quasistatic mode; this case is dynamic")
    for group in KEY_GROUPS:
        present = [k for k in group if k in raw]
        if present and len(present) < len(group):
            missing = [k for k in group if k not in raw][0]
            raise CaseError(missing, f"missing: the keys {list(group)} come together; the case has only {present}")

    c = {"mode": mode, "objective": objective}
    values = _float_array("values", raw["values"], ndim=2)
    if values.shape[0] < 2 or values.shape[1] < 2:
        raise CaseError("values", f"values must have at least 2 nodes per axis, got shape {values.shape}")
    lower = _float_array("lower", raw["lower"], shape=(2,))
    upper = _float_array("upper", raw["upper"], shape=(2,))
    if not np.all(upper > lower):
        raise CaseError("upper", f"upper must be > lower on both axes, got lower={lower.tolist()}, upper={upper.tolist()}")
    periodic = _flags("periodic", raw["periodic"], (2,))
    c.update(values=values, lower=lower, upper=upper, periodic=periodic)

    dt = _scalar("dt", raw["dt"])
    _sign("dt", dt, positive=True)
    ns = np.asarray(raw["n_steps"])
    if ns.dtype.kind not in "iu":
        raise _typeerr("n_steps", f"n_steps must be an integer (a 0-d integer array), got {_desc(ns)}")
    if ns.ndim != 0:
        raise CaseError("n_steps", f"n_steps must be a scalar (a 0-d array), got shape {ns.shape}")
    n_steps = int(ns)
    if n_steps < 0:
        raise CaseError("n_steps", f"n_steps must be >= 0, got {n_steps}")
    t0 = _scalar("t0", raw["t0"]) if "t0" in raw else 0.0
    c.update(dt=dt, n_steps=n_steps, t0=t0)

    x0 = _float_array("x0", raw["x0"], shape=(None, 2))
    if x0.shape[0] < 1:
        raise CaseError("x0", "x0 must hold at least one particle, got shape (0, 2)")
    n = x0.shape[0]
    v0 = _finite("v0", _numeric("v0", raw["v0"]))
    if v0.shape != (n, 2):
        raise CaseError("v0", f"v0 must have shape (N, 2) = ({n}, 2) like x0, got shape {v0.shape}")
    c.update(x0=x0, v0=v0, n=n)

    c["mass"] = _sign("mass", _per_particle("mass", raw["mass"], n), positive=True)
    c["damping"] = _sign("damping", _per_particle("damping", raw["damping"], n), nonneg=True)
    if mode == "quasistatic":
        c["mobility"] = _sign("mobility", _float_array("mobility", raw["mobility"], shape=(2,)), positive=True)
    c["has_spring"] = "spring_k" in raw
    if c["has_spring"]:
        c["spring_k"] = _sign("spring_k", _per_particle("spring_k", raw["spring_k"], n), nonneg=True)
        c["spring_center"] = _per_particle("spring_center", raw["spring_center"], n)
    c["has_walls"] = "walls" in raw
    if c["has_walls"]:
        wk = _sign("wall_k", _scalar("wall_k", raw["wall_k"]), positive=True)
        wm = _sign("wall_margin", _scalar("wall_margin", raw["wall_margin"]), nonneg=True)
        edges = _flags("walls", raw["walls"], (2, 2))
        # SPEC section 2: a wall at a = lower + w, b = upper - w; where both walls of an
        # axis are enabled they must leave room between them (a < b).
        a_pos, b_pos = lower + wm, upper - wm
        for d in range(2):
            if periodic[d] and edges[d].any():
                raise CaseError("walls", f"axis {d} is periodic and cannot have a wall (walls[{d}] = {edges[d].tolist()})")
            if edges[d].all() and not a_pos[d] < b_pos[d]:
                raise CaseError("wall_margin", f"wall_margin={wm} leaves no room between the two walls of axis {d} "
                                               f"(a = {a_pos[d]}, b = {b_pos[d]}, need a < b)")
        c.update(wall_k=wk, wall_lo=np.where(edges[:, 0], a_pos, -np.inf),
                 wall_hi=np.where(edges[:, 1], b_pos, np.inf), wall_edges=edges)
    # spec section 8.6: on a periodic axis x0 lies within 2**52 cells of lower (farther,
    # float64 holds no fraction of a cell); checked after the scene's keys, as the reference does
    nodes = np.array(values.shape, dtype=float)
    with np.errstate(over="ignore"):
        reach = 2.0 ** 52 * (upper - lower) / np.where(periodic, nodes, nodes - 1.0)
        far = periodic & np.any(np.abs(x0 - lower) >= reach, axis=0)
    if far.any():
        d = int(np.argmax(far))
        raise CaseError("x0", f"x0 on periodic axis {d} lies 2**52 cells or more from lower, where float64 "
                              "holds no fraction of a cell")
    shape = (n_steps + 1, n, 2)
    if "force" in raw:
        f = _finite("force", _numeric("force", raw["force"]))
        if f.shape != shape:
            raise CaseError("force", f"force must have shape (T+1, N, 2) = {shape}, got shape {f.shape}")
        c["force"] = f
    else:
        c["force"] = np.zeros(shape)
    if objective == "funnel":
        c["target"] = _scalar("target", raw["target"])
        c["when"] = _string("when", raw["when"], ("final", "every_step"))
    elif objective == "oscillator":
        c["amplitude"] = _scalar("amplitude", raw["amplitude"])
        c["omega"] = _scalar("omega", raw["omega"])
    else:
        for p in OBJECTIVE_PARAMS["quadratic"]:
            a = _numeric(p, raw[p])
            try:
                ok = np.broadcast_shapes(a.shape, shape) == shape
            except ValueError:
                ok = False
            if not ok:
                raise CaseError(p, f"{p} must broadcast to (T+1, N, 2) = {shape}, got shape {a.shape}")
            c[p] = _finite(p, a)
    reg = _scalar("regularization", raw["regularization"]) if "regularization" in raw else 0.0
    c["regularization"] = _sign("regularization", reg, nonneg=True)
    if STABILITY:
        _check_stability(c)
    return c


def _grid_curvature(c: dict) -> float:
    """docs/spec.md 10.1: c = max over cells |G11 - G10 - G01 + G00| / (h0 h1), over the
    grid closed by wrap-around on periodic axes, h_d = L_d / n_d (periodic) or
    L_d / (n_d - 1)."""
    G = c["values"]
    n = np.array(G.shape)
    h = (c["upper"] - c["lower"]) / np.where(c["periodic"], n, n - 1)
    for d in range(2):
        if c["periodic"][d]:
            G = np.concatenate((G, np.take(G, [0], axis=d)), axis=d)
    with np.errstate(over="ignore", invalid="ignore"):
        return float(np.max(np.abs(G[1:, 1:] - G[1:, :-1] - G[:-1, 1:] + G[:-1, :-1])) / (h[0] * h[1]))


def _check_stability(c: dict) -> None:
    """docs/spec.md section 10: refuse a step past the explicit stability limit of its
    stiffest term, even when the numbers would stay finite.

    The terms, per axis d, one at a time (not summed): the spring k_d = max_i
    spring_k[i, d], the wall k_w on an axis with an enabled wall, and the grid's cross
    curvature c (the same on both axes). Dynamic: refused iff max dt sqrt(K / m_d) > 2,
    m_d = min_i mass[i, d]; quasistatic: iff max mobility_d K > 2. A case of n_steps = 0
    is never refused. The stable value named is half the limit of the stiffest term.
    PES_JAX_STABILITY=0 turns the check off (the reference's --allow-unstable)."""
    if c["n_steps"] == 0:
        return
    n = c["n"]
    terms = [("grid curvature", np.full(2, _grid_curvature(c)))]      # (name, K per axis (2,))
    if c["has_spring"]:
        terms.append(("spring", np.max(np.broadcast_to(c["spring_k"], (n, 2)), axis=0)))
    if c["has_walls"]:
        terms.append(("wall", np.where(c["wall_edges"].any(axis=1), c["wall_k"], 0.0)))
    K = np.array([k for _, k in terms])                                # (terms, 2)
    if c["mode"] == "dynamic":
        m = np.min(np.broadcast_to(c["mass"], (n, 2)), axis=0)
        with np.errstate(over="ignore", invalid="ignore"):
            reach = c["dt"] * np.sqrt(K / m)
        t, d = np.unravel_index(int(np.argmax(reach)), reach.shape)
        if reach[t, d] > 2.0:
            limit = 2.0 / np.sqrt(K[t, d] / m[d])
            raise CaseError("dt", f"dt={c['dt']:g} is past the stability limit of its stiffest term, the "
                                  f"{terms[t][0]} (dt sqrt(K/m) = {reach[t, d]:.6g} > 2 on axis {d}; the limit is "
                                  f"dt < {limit:.6g}); a stable dt is {0.5 * limit:.6g}")
    else:
        mu = c["mobility"]
        reach = mu * K
        t, d = np.unravel_index(int(np.argmax(reach)), reach.shape)
        if reach[t, d] > 2.0:
            kmax = np.max(K, axis=0)
            good = np.where(mu * kmax > 2.0, 1.0 / np.where(kmax > 0, kmax, 1.0), mu)
            raise CaseError("mobility", f"mobility={mu.tolist()} is past the stability limit of its stiffest term, "
                                        f"the {terms[t][0]} (mu K = {reach[t, d]:.6g} > 2 on axis {d}; the limit "
                                        f"is mu_d < 2/K_d); a stable mobility is {good.tolist()}")


def grad_names(c: dict) -> tuple:
    used = {"values", "x0", "force"}
    used |= {"v0", "mass", "damping"} if c["mode"] == "dynamic" else {"mobility"}
    if c["has_spring"]:
        used |= {"spring_k", "spring_center"}
    return tuple(g for g in GRADIENT_NAMES if g in used)


# =========================================================================== the numerics

def _floor_grad(u, uc, inside):
    """``uc`` in value; its derivative in ``u`` is 1 where the point is inside the axis's
    span (``s_d = 1`` for ``0 <= u <= n_d - 1``, SPEC section 1) and 0 outside. (jnp.clip's
    own derivative at the clip edge is 1/2, which is no one-sided value.)"""
    return jnp.where(inside, u, lax.stop_gradient(uc))


def locate(x, g):
    """SPEC section 1 for points x (P, 2): corner indices (P, 2) x 2, fractions f and
    switches s (P, 2). ``g`` holds lower, h, nf (float n), ni (int n), periodic."""
    u = (x - g["lower"]) / g["h"]
    nf, ni, per = g["nf"], g["ni"], g["periodic"]
    # periodic axis: k = floor(u), f = u - k, i0 = k mod n, i1 = (k + 1) mod n
    kp = jnp.floor(u)
    fp = u - kp
    i0p = jnp.clip(jnp.mod(kp, nf), 0, nf - 1).astype(jnp.int64)   # fmod: exact on floats
    i1p = jnp.where(i0p + 1 >= ni, 0, i0p + 1)
    # non-periodic: uc = clip(u, 0, n - 1), i0 = min(floor(uc), n - 2), f = uc - i0, s = [0 <= u <= n - 1]
    uc = jnp.clip(u, 0.0, nf - 1.0)
    inside = u == uc
    kn = jnp.minimum(jnp.floor(uc), nf - 2.0)
    fn = _floor_grad(u, uc, inside) - kn
    i0n = jnp.clip(kn, 0, nf - 2).astype(jnp.int64)
    f = jnp.where(per, fp, fn)
    i0 = jnp.where(per, i0p, i0n)
    i1 = jnp.where(per, i1p, i0n + 1)
    s = jnp.where(per, 1.0, inside.astype(jnp.float64))
    return i0, i1, f, s


def _corners(values, n1b, i0, i1):
    flat = values.reshape(-1)
    take = lambda i, j: jnp.take(flat, i * n1b + j, mode="clip")  # noqa: E731
    return (take(i0[..., 0], i0[..., 1]), take(i1[..., 0], i0[..., 1]),
            take(i0[..., 0], i1[..., 1]), take(i1[..., 0], i1[..., 1]))


def grid_force(values, x, g):
    """-dE/dq of the bilinear surface at x (P, 2) (SPEC section 1).

    The SPEC's slope is s0/h0 [(1-f1)(G10-G00) + f1 (G11-G01)]. Evaluated as written it
    differs from the reference in the last bits (pes_ref evaluates the same affine
    function of f1 regrouped, pes_ref/core/bilinear.py); since the trajectories are
    compared to 1e-12 and chaotic runs amplify the last bit, the default here is that
    grouping: F0 = s0 (A0 + f1 D0), A0 = (G10 - G00)(-1/h0),
    D0 = ((G11 - G01) - (G10 - G00))(-1/h0), and F1 likewise (PES_JAX_SLOPE=spec for the
    literal formula)."""
    i0, i1, f, s = locate(x, g)
    g00, g10, g01, g11 = _corners(values, values.shape[1], i0, i1)
    f0, f1, s0, s1 = f[..., 0], f[..., 1], s[..., 0], s[..., 1]
    h0, h1 = g["h"][0], g["h"][1]
    if SLOPE_SPEC:
        F0 = -((s0 / h0) * ((1 - f1) * (g10 - g00) + f1 * (g11 - g01)))
        F1 = -((s1 / h1) * ((1 - f0) * (g01 - g00) + f0 * (g11 - g10)))
    else:
        nih0, nih1 = -1.0 / h0, -1.0 / h1
        d0a, d0b, d1a, d1b = g10 - g00, g11 - g01, g01 - g00, g11 - g10
        F0 = ((d0b - d0a) * nih0 * f1 + d0a * nih0) * s0
        F1 = ((d1b - d1a) * nih1 * f0 + d1a * nih1) * s1
    return jnp.stack([F0, F1], axis=-1)


def grid_energy(values, x, g):
    """E = (1-f0)(1-f1) G00 + f0(1-f1) G10 + (1-f0) f1 G01 + f0 f1 G11, in that order."""
    i0, i1, f, _ = locate(x, g)
    g00, g10, g01, g11 = _corners(values, values.shape[1], i0, i1)
    f0, f1 = f[..., 0], f[..., 1]
    return (1 - f0) * (1 - f1) * g00 + f0 * (1 - f1) * g10 + (1 - f0) * f1 * g01 + f0 * f1 * g11


def spring_delta(x, center, g):
    """q - c, the minimum image ((q - c + L/2) mod L) - L/2 on a periodic axis (SPEC section 2)."""
    delta = x - center
    L = g["length"]
    half = 0.5 * L
    return jnp.where(g["periodic"], jnp.mod(delta + half, L) - half, delta)


def wall_clip(x, g):
    """clip(q, a, b) with derivative 1 on the closed interval (the inside one-sided value at
    the wall's onset; jnp.clip would give 1/2 there)."""
    lo, hi = g["wall_lo"], g["wall_hi"]
    return jnp.where(x < lo, lo, jnp.where(x > hi, hi, x))


def total_force(p, x, fe, g):
    """F(x) + F_ext: grid, then spring (F - k delta), then walls (+ k_w (clip(q, a, b) - q)),
    then the external force, each rounded in that order (pes_ref/core/forces.py adds the
    terms in this order; the SPEC fixes only U = U_grid + U_spring + U_wall). A case
    without spring or walls has k = 0 there, which adds an exact 0."""
    F = grid_force(p["values"], x, g)
    F = F - p["spring_k"] * spring_delta(x, p["spring_center"], g)
    F = F + g["wall_k"] * (wall_clip(x, g) - x)
    F = F + fe
    return jnp.where(g["pmask"][:, None], F, 0.0)   # padding particles never move


def potential(p, x, g):
    """U per point: U_grid + U_spring + U_wall (SPEC section 2), x (..., N, 2)."""
    u = grid_energy(p["values"], x, g)
    d = spring_delta(x, p["spring_center"], g)
    kd = p["spring_k"] * d * d
    u = u + 0.5 * (kd[..., 0] + kd[..., 1])
    below = jnp.maximum(g["wall_lo"] - x, 0.0)
    above = jnp.maximum(x - g["wall_hi"], 0.0)
    w = below * below + above * above
    return u + 0.5 * g["wall_k"] * (w[..., 0] + w[..., 1])


def simulate(p, g, mode):
    """The trajectory of SPEC section 3: xs, vs and the forces F_n, each (Tb+1, Nb, 2)."""
    fext = p["force"]
    x0 = p["x0"]
    active = g["active"]                        # (Tb,): step n -> n+1 is a real step (n < T)
    if mode == "dynamic":
        mass = p["mass"]
        dt = g["dt"]
        a = dt / (2.0 * mass)                       # a = dt / 2m
        cdamp = dt * p["damping"] / (2.0 * mass)    # c = dt gamma / 2m
        inv1pc = 1.0 / (1.0 + cdamp)
        v0 = p["v0"]
        F0 = total_force(p, x0, fext[0], g)

        def step(carry, inp):
            # docs/adjoint.md (S1)-(S4); rounding order as pes_ref/core/integrator.py:
            x, v, F = carry
            fe, on = inp
            P = a * F + v                           # (S1) half kick
            x1 = P * dt + x                         # (S2) drift
            F1 = total_force(p, x1, fe, g)          # (S3) force
            v1 = a * F1 + P                         # (S4) kick ...
            v1 = (v1 - cdamp * v) * inv1pc          # ... damped: (P + a F1 - c V) / (1 + c); exact no-op at gamma = 0
            x1 = jnp.where(on, x1, x)
            v1 = jnp.where(on, v1, v)
            F1 = jnp.where(on, F1, F)
            return (x1, v1, F1), (x1, v1, F1)

        _, (xs, vs, fs) = lax.scan(step, (x0, v0, F0), (fext[1:], active))
        xs = jnp.concatenate([x0[None], xs], axis=0)
        vs = jnp.concatenate([v0[None], vs], axis=0)
        fs = jnp.concatenate([F0[None], fs], axis=0)
        return xs, vs, fs
    mu = p["mobility"]

    def qstep(x, inp):
        fe, on = inp
        F = total_force(p, x, fe, g)                # (Q1)
        x1 = mu * F + x                             # (Q2) X + mu F
        x1 = jnp.where(on, x1, x)
        return x1, (x1, F)

    xT, (xs, fs) = lax.scan(qstep, x0, (fext[:-1], active))
    xs = jnp.concatenate([x0[None], xs], axis=0)
    # F_T moves nothing; it is computed only for the finiteness check (as pes_ref does)
    fT = lax.stop_gradient(total_force(p, xT, fext[-1], g))
    fs = jnp.concatenate([fs, fT[None]], axis=0)   # padded steps repeat the force at X_T
    return xs, jnp.zeros_like(xs), fs


OBJECTIVE_INDEX = {"funnel": 0, "oscillator": 1, "quadratic": 2}


def objective_value(xs, vs, g):
    """sum_n l_n (SPEC section 4) over the real steps and particles only; the objective is
    chosen at run time (lax.switch), so that one compiled program serves all three."""
    return lax.switch(g["objective"], (_funnel, _oscillator, _quadratic), xs, vs, g)


def _funnel(xs, vs, g):
    m2 = g["smask"][:, None] & g["pmask"][None, :]          # (Tb+1, Nb)
    e = xs[:, :, 0] - g["target"]
    return jnp.sum(jnp.where(m2 & g["fmask"][:, None], e * e, 0.0))


def _oscillator(xs, vs, g):
    m2 = g["smask"][:, None] & g["pmask"][None, :]
    A, w = g["amplitude"], g["omega"]
    t = g["t0"] + g["dt"] * jnp.arange(xs.shape[0], dtype=jnp.float64)   # t_n = t0 + n dt
    ex = xs[:, :, 0] - (A * jnp.cos(w * t))[:, None]
    ev = vs[:, :, 0] + (A * w * jnp.sin(w * t))[:, None]                 # (A w) sin(w t_n)
    S = jnp.sum(jnp.where(m2, ex * ex + ev * ev, 0.0), axis=1)
    root = safe_sqrt(S)
    return jnp.sum(jnp.where(g["smask"], root, 0.0)) / g["n2"]           # (sum_n root_n) / N^2


def _quadratic(xs, vs, g):
    m3 = (g["smask"][:, None] & g["pmask"][None, :])[:, :, None]
    dx = xs - g["xref"]
    dv = vs - g["vref"]
    val = 0.5 * jnp.sum(jnp.where(m3, g["wx"] * dx * dx, 0.0))
    return val + 0.5 * jnp.sum(jnp.where(m3, g["wv"] * dv * dv, 0.0))


def _program(mode):
    def loss_fn(p, g):
        xs, vs, fs = simulate(p, g, mode)
        loss = objective_value(xs, vs, g)
        loss = loss + g["reg"] * jnp.sum(p["values"] * p["values"])       # eq. (7)
        xs_, vs_ = lax.stop_gradient(xs), lax.stop_gradient(vs)
        u = potential(lax.stop_gradient(p), xs_, g)
        mv = lax.stop_gradient(p["mass"]) * vs_ * vs_
        energy = u + 0.5 * (mv[:, :, 0] + mv[:, :, 1])
        return loss, (xs, vs, energy, lax.stop_gradient(fs))
    return jax.jit(jax.value_and_grad(loss_fn, has_aux=True))


_PROGRAMS: dict = {}


def _bucket(n: int, minimum: int = 1, smallest: int = 1) -> int:
    """Round a size up to a power of 2 (at least ``smallest``), so that cases of nearby
    sizes share one compiled program: compiling takes ~1-2 s, a padded step microseconds."""
    n = max(int(n), minimum)
    if not PAD:
        return n
    return max(smallest, 1 << (n - 1).bit_length())


def _pad(a, shape, fill=0.0):
    out = np.full(shape, fill, dtype=np.float64)
    out[tuple(slice(0, s) for s in a.shape)] = a
    return out


def _reduce_to(gr: np.ndarray, shape: tuple) -> np.ndarray:
    """The adjoint of broadcasting an input of ``shape`` to gr.shape: sum the broadcast axes."""
    lead = gr.ndim - len(shape)
    if lead:
        gr = gr.sum(axis=tuple(range(lead)))
    axes = tuple(i for i, s in enumerate(shape) if s == 1 and gr.shape[i] != 1)
    if axes:
        gr = gr.sum(axis=axes, keepdims=True)
    return gr.reshape(shape)


def run(c: dict, raw: dict):
    """Run a validated case: the result dict (float64 NumPy arrays), and whether every
    force F_0..F_T was finite."""
    T, N = c["n_steps"], c["n"]
    n0, n1 = c["values"].shape
    # a padded step costs ~20 us and a compilation ~1-3 s: generous buckets
    Tb, Nb = _bucket(T, 1, 512), _bucket(N, 1, 8)
    n0b, n1b = _bucket(n0, 2, 16), _bucket(n1, 2, 16)
    per = c["periodic"]
    nf = np.array([n0, n1], dtype=np.float64)
    lower, upper = c["lower"], c["upper"]
    h = (upper - lower) / np.where(per, nf, nf - 1.0)     # SPEC section 1 spacing
    bN = lambda key, fill=0.0: _pad(np.broadcast_to(c[key], (N, 2)), (Nb, 2), fill)  # noqa: E731
    p = {
        "values": _pad(c["values"], (n0b, n1b)),
        "x0": _pad(c["x0"], (Nb, 2)) + _pad(np.zeros((N, 2)), (Nb, 2), 1.0) * lower,  # padding at `lower`
        "v0": _pad(c["v0"], (Nb, 2)),
        "force": _pad(c["force"], (Tb + 1, Nb, 2)),
        "mass": bN("mass", 1.0),
        "damping": bN("damping"),
        "spring_k": bN("spring_k") if c["has_spring"] else np.zeros((Nb, 2)),
        "spring_center": bN("spring_center") if c["has_spring"] else np.zeros((Nb, 2)),
        "mobility": c["mobility"] if c["mode"] == "quasistatic" else np.ones(2),
    }
    steps = np.arange(Tb + 1)
    g = {
        "lower": lower, "h": h, "nf": nf, "ni": np.array([n0, n1], dtype=np.int64),
        "periodic": per, "length": upper - lower,
        "dt": np.float64(c["dt"]), "t0": np.float64(c["t0"]),
        "active": steps[:-1] < T, "smask": steps <= T, "pmask": np.arange(Nb) < N,
        "n2": np.float64(N * N),
        "wall_k": np.float64(c["wall_k"] if c["has_walls"] else 0.0),
        "wall_lo": c["wall_lo"] if c["has_walls"] else np.full(2, -np.inf),
        "wall_hi": c["wall_hi"] if c["has_walls"] else np.full(2, np.inf),
        "reg": np.float64(c["regularization"]),
        # objective parameters (all present, so that one program serves every objective's layout)
        "target": np.float64(c.get("target", 0.0)),
        "fmask": (steps == T) if c.get("when", "final") == "final" else (steps <= T),
        "amplitude": np.float64(c.get("amplitude", 0.0)), "omega": np.float64(c.get("omega", 0.0)),
        "objective": np.int32(OBJECTIVE_INDEX[c["objective"]]),
    }
    for q in ("wx", "wv", "xref", "vref"):
        g[q] = _pad(np.broadcast_to(c[q], (T + 1, N, 2)), (Tb + 1, Nb, 2)) if q in c else np.zeros((Tb + 1, Nb, 2))
    mode = c["mode"]
    if mode not in _PROGRAMS:
        _PROGRAMS[mode] = _program(mode)
    (loss, (xs, vs, energy, fs)), grads = _PROGRAMS[mode](p, g)
    forces_finite = bool(np.all(np.isfinite(np.asarray(fs)[:T + 1, :N])))

    out = {"x": np.asarray(xs)[:T + 1, :N], "v": np.asarray(vs)[:T + 1, :N],
           "energy": np.asarray(energy)[:T + 1, :N], "loss": np.asarray(loss, dtype=np.float64).reshape(())}
    crop = {"values": (slice(0, n0), slice(0, n1)), "force": (slice(0, T + 1), slice(0, N)),
            "mobility": (slice(None),)}
    for name in grad_names(c):
        gr = np.asarray(grads[name])[crop.get(name, (slice(0, N),))]
        if name in ("mass", "damping", "spring_k", "spring_center"):
            gr = _reduce_to(gr, np.shape(raw[name]))
        out["grad_" + name] = np.asarray(gr, dtype=np.float64)
    return out, forces_finite


def check_finite(c: dict, out: dict, forces_finite: bool = True) -> None:
    """A run that leaves the finite numbers is refused (SPEC section 6: 'a result that
    overflows is never written'), blamed on dt (dynamic) or mobility (quasistatic). Like
    pes_ref, the forces F_0..F_T count too (also the quasistatic F_T, which moves nothing)."""
    bad = [k for k, a in out.items() if not np.all(np.isfinite(a))] + ([] if forces_finite else ["forces"])
    if bad:
        key = "dt" if c["mode"] == "dynamic" else "mobility"
        xs_ok = np.isfinite(out["x"]).all(axis=(1, 2)) & np.isfinite(out["v"]).all(axis=(1, 2))
        where = f" at step {int(np.argmin(xs_ok))}" if not xs_ok.all() else ""
        val = c["dt"] if key == "dt" else c["mobility"].tolist()
        raise CaseError(key, f"the run left the finite numbers{where} ({', '.join(bad)} not finite) with "
                             f"{key}={val}; the step is probably past the stability limit of the stiffest term: reduce it")


def write_result(path: str, out: dict) -> None:
    """np.savez into a temporary file in the destination folder, then os.replace."""
    path = os.path.abspath(path)
    folder = os.path.dirname(path)
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "wb") as fh, zipfile.ZipFile(fh, "w", compression=zipfile.ZIP_DEFLATED) as zf:
            for k, a in out.items():
                with zf.open(k + ".npy", "w", force_zip64=a.nbytes > (1 << 30)) as member:
                    np.lib.format.write_array(member, np.array(a, dtype=np.float64, order="C"), allow_pickle=False)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def run_file(case_path: str, result_path: str) -> None:
    raw = read_case(case_path)
    c = validate(raw)
    _init_jax()
    try:
        with np.errstate(over="ignore", invalid="ignore"):
            out, forces_finite = run(c, raw)
    except MemoryError:
        raise CaseError("n_steps", f"a run of n_steps={c['n_steps']} with N={c['n']} does not fit in memory") from None
    except Exception as exc:   # XLA's allocation failure is an XlaRuntimeError
        if "RESOURCE_EXHAUSTED" in str(exc) or "Out of memory" in str(exc):
            raise CaseError("n_steps", f"a run of n_steps={c['n_steps']} with N={c['n']} does not fit in memory") from None
        raise
    check_finite(c, out, forces_finite)
    write_result(result_path, out)


def _check_exact_arithmetic() -> None:
    """Warn if XLA fuses a*b + c into an FMA or divides by multiplying with a reciprocal
    (results would then differ from the reference in the last bits; see _init_jax)."""
    a = np.array([1.0 + 2.0 ** -30, 1.0, 0.1])
    b = np.array([1.0 - 2.0 ** -30, 1.0, 3.0])
    c = np.array([-1.0, 0.0, 0.0])
    rng = np.random.default_rng(0)                  # (q - lower) / h as locate computes it
    q, lo, h = rng.normal(size=(64, 2)), rng.normal(size=2), rng.uniform(0.1, 1.0, size=2)
    fma, div = jax.jit(lambda a, b, c, q, lo, h: (a * b + c, (q - lo) / h))(a, b, c, q, lo, h)
    if not np.array_equal(np.asarray(fma), a * b + c):
        print("pes_jax: warning: XLA contracts a*b+c into an FMA here; results may differ from pes_ref "
              "in the last bits (XLA_FLAGS=--xla_cpu_max_isa=SSE4_2 prevents it)", file=sys.stderr)
    if not np.array_equal(np.asarray(div), (q - lo) / h):
        print("pes_jax: warning: XLA rewrites x/h as x*(1/h) here; results may differ from pes_ref "
              "in the last bits (XLA_FLAGS=--xla_disable_hlo_passes=algsimp prevents it)", file=sys.stderr)


def _record_refusal(path: str, case_path: str, key, kind: str, message: str) -> None:
    """One JSON line per refused case in the --refusals file."""
    import json
    with open(path, "a", encoding="utf-8") as fh:
        fh.write(json.dumps({"case": case_path, "key": key, "error": kind, "message": message}) + "\n")


def main(argv=None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    refusals = None
    if args[:1] == ["--refusals"] and len(args) >= 2:
        refusals, args = args[1], args[2:]
    if not args or len(args) % 2 or any(a in ("-h", "--help") for a in args):
        print("usage: pes_jax.py [--refusals FILE.jsonl] CASE.npz RESULT.npz [CASE2.npz RESULT2.npz ...]",
              file=sys.stderr)
        return 0 if any(a in ("-h", "--help") for a in args) else 2
    pairs = list(zip(args[0::2], args[1::2]))
    status = 0
    for case_path, result_path in pairs:
        try:
            if os.path.abspath(case_path) == os.path.abspath(result_path):
                raise CaseError(None, f"the result path {result_path!r} is the case file itself")
            run_file(case_path, result_path)
        except CaseError as exc:
            prefix = "error: " if len(pairs) == 1 else f"error: {case_path}: "
            print(prefix + str(exc), file=sys.stderr)
            if refusals is not None:
                _record_refusal(refusals, case_path, exc.key, exc.kind, str(exc))
            status = 2
        except Exception as exc:   # cannot write the result, or a bug: one line, and go on with the next pair
            prefix = "error: " if len(pairs) == 1 else f"error: {case_path}: "
            print(prefix + f"{type(exc).__name__}: " + " ".join(str(exc).split()), file=sys.stderr)
            status = max(status, 1)
    return status


if __name__ == "__main__":
    sys.exit(main())
