"""Gradient-descent optimizers for design runs: RMSprop (as the paper uses it), Adam, clipping.

The paper (sections "Contribution 3" and "Contribution 4") runs RMSprop on the grid
values ``G`` of the potential energy surface; it gives no hyper-parameters, so the
defaults here are the usual ones (``docs/synthesis.md``, "Optimizers").

Every optimizer is a small stateful object whose whole state is a dict of plain NumPy
arrays and Python numbers (`state_dict` / `load_state_dict`), so a run can be
saved to a ``.npz`` design file and resumed bit-exactly. One `step` takes the
parameter array ``p`` (any shape, float64) and its gradient ``g`` and returns the updated
parameters as a new array; ``p`` and ``g`` are never modified.

Examples
--------
>>> import numpy as np
>>> opt = RMSprop(lr=0.1)
>>> p = np.array([1.0, -2.0])
>>> for _ in range(500):
...     p = opt.step(p, 2.0 * p)          # gradient of |p|^2
>>> bool(np.all(np.abs(p) < 0.1))
True
"""
from __future__ import annotations

import numpy as np

from pes_ref.core import checks

__all__ = ["RMSprop", "Adam", "clip_by_norm", "make_optimizer", "optimizer_from_state", "OPTIMIZERS"]


def clip_by_norm(g: np.ndarray, max_norm: float | None) -> np.ndarray:
    """Scale ``g`` down so that its Euclidean norm is at most ``max_norm``.

    ``g * min(1, max_norm / |g|)``; ``max_norm = None`` returns ``g`` unchanged. The paper
    suggests clipping to keep updates gradual where the gradients grow very large.
    """
    if max_norm is None:
        return g
    norm = float(np.sqrt(np.sum(g * g)))
    if norm > max_norm:
        return g * (max_norm / norm)
    return g


class _Optimizer:
    """Shared state handling: ``t`` (steps taken) plus the named moment arrays."""

    kind = ""
    _moments: tuple = ()

    def __init__(self, lr: float, eps: float, clip: float | None):
        self.lr = checks.as_positive_float("lr", lr)
        self.eps = checks.as_positive_float("eps", eps)
        self.clip = None if clip is None else checks.as_positive_float("clip", clip)
        self.t = 0
        for name in self._moments:
            setattr(self, name, None)

    def _prepare(self, p, g):
        p = np.asarray(p, dtype=np.float64)
        g = np.asarray(g, dtype=np.float64)
        if g.shape != p.shape:
            raise ValueError(f"gradient shape {g.shape} differs from parameter shape {p.shape}")
        for name in self._moments:
            m = getattr(self, name)
            if m is None:
                setattr(self, name, np.zeros_like(p))
            elif m.shape != p.shape:
                raise ValueError(f"{self.kind} state {name} has shape {m.shape}, parameters {p.shape}; "
                                 "call reset() after changing the grid")
        self.t += 1
        return p, clip_by_norm(g, self.clip)

    def reset(self) -> None:
        """Forget the moments (e.g. after resampling the grid to a new resolution)."""
        self.t = 0
        for name in self._moments:
            setattr(self, name, None)

    def hyper(self) -> dict:
        """The hyper-parameters as plain floats (``clip`` as NaN when off)."""
        raise NotImplementedError

    def state_dict(self) -> dict:
        """Everything needed to resume: hyper-parameters, ``t`` and the moments.

        Keys map to plain arrays (a moment never started is an empty (0,) array).
        """
        out = {"kind": np.array(self.kind), "t": np.array(self.t, dtype=np.int64)}
        for k, v in self.hyper().items():
            out[k] = np.array(np.nan if v is None else v, dtype=np.float64)
        for name in self._moments:
            m = getattr(self, name)
            out[name] = np.zeros(0) if m is None else m.copy()
        return out

    def load_state_dict(self, state: dict) -> None:
        """Restore `state_dict`'s output (bit-exact)."""
        kind = str(np.asarray(state["kind"]))
        if kind != self.kind:
            raise ValueError(f"optimizer state is for {kind!r}, not {self.kind!r}")
        self.t = int(state["t"])
        for name in self._moments:
            m = np.asarray(state[name], dtype=np.float64)
            setattr(self, name, None if m.size == 0 else m.copy())


class RMSprop(_Optimizer):
    """RMSprop: ``s <- rho s + (1 - rho) g^2``, ``p <- p - lr g / (sqrt(s) + eps)``.

    The form of PyTorch's ``torch.optim.RMSprop`` (eps outside the root, no momentum, no
    bias correction). ``g`` is first clipped to norm ``clip`` when given.

    Parameters
    ----------
    lr : float > 0
    rho : float in [0, 1)
        Decay of the running mean of squared gradients.
    eps : float > 0
    clip : float > 0 or None
    """

    kind = "rmsprop"
    _moments = ("s",)

    def __init__(self, lr: float = 1e-3, rho: float = 0.99, eps: float = 1e-8, clip: float | None = None):
        super().__init__(lr, eps, clip)
        self.rho = _unit_interval("rho", rho)

    def hyper(self) -> dict:
        """The hyper-parameters by name: ``lr``, ``rho``, ``eps`` and ``clip`` (None when off)."""
        return {"lr": self.lr, "rho": self.rho, "eps": self.eps, "clip": self.clip}

    def step(self, p, g) -> np.ndarray:
        """One update; returns the new parameters (``p``, ``g`` are not modified)."""
        p, g = self._prepare(p, g)
        self.s = self.rho * self.s + (1.0 - self.rho) * (g * g)
        return p - self.lr * g / (np.sqrt(self.s) + self.eps)


class Adam(_Optimizer):
    """Adam (Kingma & Ba 2015) with bias correction.

    ``m <- b1 m + (1 - b1) g``, ``v <- b2 v + (1 - b2) g^2``,
    ``p <- p - lr (m / (1 - b1^t)) / (sqrt(v / (1 - b2^t)) + eps)``.
    """

    kind = "adam"
    _moments = ("m", "v")

    def __init__(self, lr: float = 1e-3, beta1: float = 0.9, beta2: float = 0.999, eps: float = 1e-8,
                 clip: float | None = None):
        super().__init__(lr, eps, clip)
        self.beta1 = _unit_interval("beta1", beta1)
        self.beta2 = _unit_interval("beta2", beta2)

    def hyper(self) -> dict:
        """The hyper-parameters by name: ``lr``, ``beta1``, ``beta2``, ``eps`` and ``clip`` (None when
        off)."""
        return {"lr": self.lr, "beta1": self.beta1, "beta2": self.beta2, "eps": self.eps, "clip": self.clip}

    def step(self, p, g) -> np.ndarray:
        """One update; returns the new parameters (``p``, ``g`` are not modified)."""
        p, g = self._prepare(p, g)
        self.m = self.beta1 * self.m + (1.0 - self.beta1) * g
        self.v = self.beta2 * self.v + (1.0 - self.beta2) * (g * g)
        mhat = self.m / (1.0 - self.beta1 ** self.t)
        vhat = self.v / (1.0 - self.beta2 ** self.t)
        return p - self.lr * mhat / (np.sqrt(vhat) + self.eps)


OPTIMIZERS = {"rmsprop": RMSprop, "adam": Adam}


def make_optimizer(kind: str, **hyper):
    """An optimizer by name (``"rmsprop"`` or ``"adam"``) with its hyper-parameters."""
    kind = checks.as_choice("optimizer", kind, set(OPTIMIZERS))
    return OPTIMIZERS[kind](**hyper)


def optimizer_from_state(state: dict):
    """Rebuild an optimizer, moments included, from `state_dict`'s output."""
    kind = str(np.asarray(state["kind"]))
    cls = OPTIMIZERS.get(kind)
    if cls is None:
        raise ValueError(f"unknown optimizer kind {kind!r}; expected one of {sorted(OPTIMIZERS)}")
    names = [k for k in cls(**{}).hyper()]
    hyper = {}
    for k in names:
        val = float(np.asarray(state[k]))
        hyper[k] = None if (k == "clip" and np.isnan(val)) else val
    opt = cls(**hyper)
    opt.load_state_dict(state)
    return opt


def _unit_interval(name: str, value) -> float:
    value = checks.as_nonneg_float(name, value)
    if not value < 1.0:
        raise ValueError(f"{name} must be in [0, 1), got {value!r}")
    return value
