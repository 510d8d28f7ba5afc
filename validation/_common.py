"""What every validation script shares: its command line, timing, tables, plots and its
report fragment (``DIR/<topic>.md``). Not a validation script itself (the leading
underscore keeps ``run_all.py`` from running it).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402,F401  (re-exported for the scripts)

DEFAULT_OUT = ROOT / "validation" / "out"


def analytic_potential(q0, q1, L):
    """The smooth test potential on a torus of period L per axis:
    ``U = cos(k q0) + cos(k q1) + sin(k (q0 + q1)) / 2``, ``k = 2 pi / L``."""
    k = 2 * np.pi / L
    return np.cos(k * q0) + np.cos(k * q1) + 0.5 * np.sin(k * (q0 + q1))


def analytic_force(q, L):
    """``-grad U`` of :func:`analytic_potential` at points q (N, 2)."""
    k = 2 * np.pi / L
    c = 0.5 * k * np.cos(k * (q[:, 0] + q[:, 1]))
    return -np.stack((-k * np.sin(k * q[:, 0]) + c, -k * np.sin(k * q[:, 1]) + c), axis=1)


def option_available(kind: str) -> bool:
    """Whether the package has ``Scene(integrator="gjf")`` / ``Surface(interpolation="bicubic")``."""
    import pes_ref as pr
    try:
        s = pr.Surface(np.zeros((3, 3)), (0, 0), (1, 1), (True, True),
                       **({"interpolation": "bicubic"} if kind == "bicubic" else {}))
        pr.Scene(s, dt=0.1, n_steps=1, **({"integrator": "gjf"} if kind == "gjf" else {}))
        return True
    except (TypeError, ValueError):
        return False


def parse_args(doc: str, argv=None) -> argparse.Namespace:
    """``--smoke`` (tiny sizes, a few seconds) and ``--out DIR`` (default validation/out)."""
    p = argparse.ArgumentParser(description=doc.strip().splitlines()[0])
    p.add_argument("--smoke", action="store_true", help="tiny sizes (seconds), for make test")
    p.add_argument("--out", type=Path, default=DEFAULT_OUT, help="output folder (default validation/out)")
    args = p.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    return args


def wall_time(fn, *, repeat: int = 3, min_time: float = 0.0) -> float:
    """The best of ``repeat`` wall-clock timings of ``fn()`` in seconds (each timing
    loops until at least ``min_time`` has passed and divides by the calls)."""
    best = np.inf
    for _ in range(repeat):
        calls, t0 = 0, time.perf_counter()
        while True:
            fn()
            calls += 1
            el = time.perf_counter() - t0
            if el >= min_time:
                break
        best = min(best, el / calls)
    return float(best)


def fit_order(h, err) -> float:
    """Least-squares slope of ``log err`` against ``log h`` (entries with err > 0)."""
    h, err = np.asarray(h, float), np.asarray(err, float)
    ok = (err > 0) & np.isfinite(err)
    if ok.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(h[ok]), np.log(err[ok]), 1)[0])


def fmt(x, digits: int = 3) -> str:
    """A number for a table: ``3.14e-05`` style, integers as integers."""
    if isinstance(x, str):
        return x
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    x = float(x)
    if not np.isfinite(x):
        return str(x)
    if x == 0:
        return "0"
    if 1e-3 <= abs(x) < 1e4:
        return f"{x:.{digits}g}"
    return f"{x:.{digits - 1}e}"


def table(headers, rows) -> str:
    """A markdown table."""
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    lines += ["| " + " | ".join(fmt(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


class Fragment:
    """A script's report fragment: tables, sentences and images, in order.

    ``write()`` prints the tables to stdout as they are added and writes
    ``DIR/<topic>.md`` (a ``## `` heading, the tables, image links, one sentence per
    result, each computed from the measured numbers by the caller).
    """

    def __init__(self, topic: str, title: str, out: Path, intro: str = ""):
        self.topic, self.title, self.out = topic, title, Path(out)
        self.parts = [f"## {title}", ""]
        if intro:
            self.parts += [intro, ""]

    def table(self, headers, rows, caption: str = "") -> None:
        text = table(headers, rows)
        print(("\n" + caption if caption else "") + "\n" + text + "\n", flush=True)
        if caption:
            self.parts += [caption, ""]
        self.parts += [text, ""]

    def figure(self, fig, name: str, alt: str) -> None:
        path = self.out / f"{name}.png"
        fig.savefig(path, dpi=110, bbox_inches="tight")
        plt.close(fig)
        self.parts += [f"![{alt}]({name}.png)", ""]

    def sentence(self, text: str) -> None:
        print("- " + text, flush=True)
        self.parts.append("- " + text)

    def write(self) -> Path:
        path = self.out / f"{self.topic}.md"
        path.write_text("\n".join(self.parts).rstrip() + "\n")
        return path


def topic_of(file: str) -> str:
    return os.path.splitext(os.path.basename(file))[0]
