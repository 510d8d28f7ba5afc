"""A sweep's results: ``results.csv`` (one row per run) and ``summary.png``.

Columns of ``results.csv``, in order: ``run`` (the run's id, also its design file's stem),
the swept options (``variant`` first when the file has several), ``seed``, ``status``
(``ok``, ``failed``, ``interrupted``, ``pending``), every figure of ``evaluate`` as the
mean over the held-out seeds (``in_band_fraction``) and per held-out seed
(``in_band_fraction@12345``), ``wall_s`` (the last attempt's), ``worker`` (its address),
``attempts``, ``from_iteration`` (the design iteration the last attempt started from: > 0
when it resumed its design file), ``iterations_done``, ``error`` (every failed attempt's),
``design_file``, ``eval_seeds``, ``eval_particles``, then the options every run shares. Numbers are written with
``repr`` (exact); a missing value is empty.

A row whose status is ``ok`` and whose held-out seeds and particles are the sweep's is a
finished run ([`is_finished`][pes_ref.sweep.results.is_finished]); the sweep keeps it and does not run it again.
"""
from __future__ import annotations

import csv
import io
import json
import math
import os

from pes_ref.core.runtime.files import atomic_file

__all__ = ["new_row", "record", "is_finished", "read_results", "write_results", "columns", "figure_names",
           "plot_summary", "CSV_NAME", "PLOT_NAME"]

CSV_NAME = "results.csv"
PLOT_NAME = "summary.png"
#: ``evaluate`` output that is a setting, not a figure (written as ``eval_particles``).
_NOT_FIGURES = ("particles",)
_TAIL = ("wall_s", "worker", "attempts", "from_iteration", "iterations_done", "error", "design_file", "eval_seeds",
         "eval_particles")


def _eval_settings(sweep) -> tuple:
    return " ".join(map(str, sweep.eval_seeds)), "" if sweep.eval_particles is None else str(sweep.eval_particles)


def new_row(run, sweep, design_file: str) -> dict:
    """The row of a run not done yet (status ``pending``)."""
    seeds, particles = _eval_settings(sweep)
    return {"run": run.id, "variant": run.variant, **run.options, "seed": run.seed, "status": "pending",
            "attempts": 0, "design_file": design_file, "eval_seeds": seeds, "eval_particles": particles}


def record(row: dict, outcome: dict, attempts: int) -> dict:
    """``row`` updated with a task's outcome ([`pes_ref.sweep.task.run_task`][pes_ref.sweep.task.run_task])."""
    stale = {k.split("@")[0] for k in row if "@" in k}
    row = {k: v for k, v in row.items() if "@" not in k and k not in stale}
    row.update(status=outcome["status"], error=outcome.get("error", ""), attempts=attempts,
               worker=outcome.get("worker", ""), wall_s=outcome.get("wall_s", ""),
               from_iteration=outcome.get("from_iteration", ""), iterations_done=outcome.get("iterations", ""))
    if outcome.get("design_file"):
        row["design_file"] = outcome["design_file"]
    per_seed = outcome.get("figures") or {}
    names = [n for n in next(iter(per_seed.values()), {}) if n not in _NOT_FIGURES]
    for name in names:
        values = [float(per_seed[seed][name]) for seed in per_seed]
        row[name] = _mean(values)
        for seed, value in zip(per_seed, values):
            row[f"{name}@{seed}"] = value
    return row


def _mean(values) -> float:
    finite = [v for v in values if math.isfinite(v)]
    return sum(finite) / len(finite) if finite else float("nan")


def is_finished(row: dict | None, sweep) -> bool:
    """A run recorded ``ok`` with this sweep's held-out seeds and particles."""
    if row is None or row.get("status") != "ok":
        return False
    return (str(row.get("eval_seeds", "")), str(row.get("eval_particles", ""))) == _eval_settings(sweep)


def figure_names(rows) -> list:
    """The figures the rows have (``NAME`` for every ``NAME@SEED`` column), in ``evaluate``'s order."""
    out = []
    for row in rows:
        for key in row:
            name = key.split("@")[0]
            if "@" in key and name not in out:
                out.append(name)
    return out


def columns(sweep, rows) -> list:
    """The CSV's columns for ``rows`` (see the module's docstring)."""
    figures = figure_names(rows)
    per_seed = [f"{name}@{seed}" for name in figures for seed in sweep.eval_seeds]
    swept = list(sweep.swept)
    shared = sorted({k for r in sweep.runs for k in r.options} - set(swept))
    return ["run", *swept, "seed", "status", *figures, *per_seed, *_TAIL, *shared]


def _text(value) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (list, tuple, dict)):
        return json.dumps(value)
    return str(value)


def write_results(path, sweep, rows) -> None:
    """Write ``rows`` to the CSV at ``path`` atomically ([`pes_ref.core.runtime.files.atomic_file`][pes_ref.core.runtime.files.atomic_file])."""
    cols = columns(sweep, rows)
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(cols)
    for row in rows:
        writer.writerow([_text(row.get(c)) for c in cols])
    with atomic_file(path, overwrite=True, what="results") as fh:
        fh.write(buf.getvalue().encode("utf-8"))


def read_results(path) -> dict:
    """Rows of an earlier ``results.csv``: run id -> row (column -> text); empty when there is none."""
    path = os.fspath(path)
    if not os.path.exists(path):
        return {}
    with open(path, newline="", encoding="utf-8") as fh:
        rows = [{k: v for k, v in row.items() if k is not None} for row in csv.DictReader(fh)]
    return {row.get("run", ""): row for row in rows}


# --------------------------------------------------------------------------- summary plot

def _number(value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return float("nan")


def _axis(values):
    """x positions of option ``values``: the numbers themselves, or category indices and labels."""
    nums = [_number(v) for v in values]
    if all(math.isfinite(x) for x in nums):
        return nums, None
    labels = []
    for v in map(_text, values):
        if v not in labels:
            labels.append(v)
    return [labels.index(_text(v)) for v in values], labels


def plot_summary(path, sweep, rows) -> None:
    """Each figure (mean over held-out seeds) against each axis of the sweep; runs not ``ok`` left out.

    The axes are the variants (when several) and the grid's options (`Sweep.axes`),
    or the seed when the file sweeps nothing else. One panel per figure and axis: with one
    axis, the figures' panels in rows of three; with several, one row of panels per
    figure and one column per axis.
    """
    from matplotlib.figure import Figure

    figures = figure_names(rows)
    options = list(sweep.axes) or ["seed"]
    ok = [r for r in rows if r.get("status") == "ok"]
    panels = [(name, option) for name in figures for option in options]
    ncols = 3 if len(options) == 1 else len(options)
    nrows = max(1, math.ceil(len(panels) / ncols))
    fig = Figure(figsize=(3.3 * ncols, 2.5 * nrows + 0.4))
    fig.suptitle(f"{sweep.name}: {len(ok)} of {len(rows)} runs ok (dots: runs, line: mean per value)", fontsize=10)
    if not panels:
        fig.text(0.5, 0.5, "no finished run yet", ha="center")
    for k, (name, option) in enumerate(panels):
        ax = fig.add_subplot(nrows, ncols, k + 1)
        _panel(ax, ok, option, name)
        ax.set_xlabel(option, fontsize=8)
        ax.set_title(name, fontsize=9)
    fig.tight_layout()
    with atomic_file(path, overwrite=True, what="summary plot") as fh:
        fig.savefig(fh, format="png", dpi=100)


def _panel(ax, rows, option, name) -> None:
    raw = [r.get(option) for r in rows]
    ys = [_number(r.get(name)) for r in rows]
    xs, labels = _axis(raw)
    ax.plot(xs, ys, "o", ms=4, alpha=0.6, color="tab:blue")
    means = {}
    for x, y in zip(xs, ys):
        if math.isfinite(y):
            means.setdefault(x, []).append(y)
    if means:
        mx = sorted(means)
        ax.plot(mx, [sum(means[x]) / len(means[x]) for x in mx], "-", color="tab:orange", lw=1)
    if labels is not None:
        ax.set_xticks(range(len(labels)))
        ax.set_xticklabels(labels, rotation=30, ha="right", fontsize=7)
    else:
        if xs and min(xs) > 0 and max(xs) >= 10 * min(xs):
            ax.set_xscale("log")
        ticks = sorted(set(xs))
        if len(ticks) <= 8:
            ax.set_xticks(ticks)
            ax.set_xticklabels([f"{t:.4g}" for t in ticks], fontsize=7)
    ax.tick_params(labelsize=7)
    ax.grid(alpha=0.3)
