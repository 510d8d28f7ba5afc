"""The benchmark's files: the results as JSON and the scaling plot beside them, each written atomically."""
from __future__ import annotations

import json
import os

import numpy as np

from pes_ref.core.runtime.files import atomic_file

__all__ = ["plot_scaling", "output_paths", "write_outputs"]


def plot_scaling(res: dict, path: str, overwrite: bool = True) -> None:
    """Time per step against N, forward and forward+adjoint, both modes (log-log)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4.2))
    for mode, ls in (("dynamic", "-"), ("quasistatic", "--")):
        rows = [r for r in res["scaling"] if r["mode"] == mode]
        n = [r["N"] for r in rows]
        for key, marker, label in (("forward", "o", "forward"), ("forward_adjoint", "s", "forward + adjoint")):
            med = np.array([r[key]["median"] for r in rows]) * 1e6
            lo = med - np.array([r[key]["min"] for r in rows]) * 1e6
            hi = np.array([r[key]["max"] for r in rows]) * 1e6 - med
            ax.errorbar(n, med, yerr=[lo, hi], ls=ls, marker=marker, ms=4, capsize=2, label=f"{label}, {mode}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("particles N")
    ax.set_ylabel("time per step (us)")
    ax.set_title(f"pes_ref on a {res['config']['grid']}x{res['config']['grid']} grid "
                 f"(median of {res['config']['repeats']}, bars min-max)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    with atomic_file(path, overwrite=overwrite, what="plot") as fh:
        fig.savefig(fh, format="png", dpi=150)
    plt.close(fig)


def _jsonable(o):
    """NumPy scalars and arrays as plain Python values for ``json.dump``."""
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not JSON serializable: {type(o).__name__}")


def output_paths(json_path: str) -> tuple:
    """The files [`write_outputs`][pes_ref.bench.outputs.write_outputs] writes for ``json_path``: it, and beside it the
    plot
    ``scaling.png`` (or ``<stem>-scaling.png``)."""
    folder = os.path.dirname(os.path.abspath(json_path))
    stem = os.path.splitext(os.path.basename(json_path))[0]
    return json_path, os.path.join(folder, "scaling.png" if stem == "bench" else f"{stem}-scaling.png")


def write_outputs(res: dict, json_path: str, overwrite: bool) -> tuple:
    """Write the JSON and, beside it, ``scaling.png`` (or ``<stem>-scaling.png``), each
    atomically ([`pes_ref.core.runtime.files.atomic_file`][pes_ref.core.runtime.files.atomic_file]).

    Refuses (FileExistsError) to replace an existing file unless ``overwrite``: both are
    checked before anything is written, and each again as it is published."""
    folder = os.path.dirname(os.path.abspath(json_path))
    png = output_paths(json_path)[1]
    for path in (json_path, png):
        if os.path.exists(path) and not overwrite:
            raise FileExistsError(f"{path} exists; pass --force to replace it")
    os.makedirs(folder, exist_ok=True)
    text = json.dumps(res, indent=1, default=_jsonable)
    with atomic_file(json_path, overwrite=overwrite, what="benchmark") as fh:
        fh.write(text.encode("utf-8"))
    plot_scaling(res, png, overwrite=overwrite)
    return json_path, png
