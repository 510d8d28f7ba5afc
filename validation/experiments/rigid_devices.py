"""The shipped devices on both engines: the table of docs/rigid.md, regenerated from the code.

``make rigid-devices`` runs it: every drive of :data:`pes_ref.rigid.shipped.DRIVES` in both
modes on the surface and the rigid engine (:func:`pes_ref.rigid.shipped.measure_all`); prints
each row as it comes, writes the rows to ``validation/out/rigid_devices/rows.json`` and
replaces the table between the marker lines of docs/rigid.md (nothing else in the file),
with the date, the commit and the load average it was measured at. ``--smoke`` measures the
drum cam alone, dynamically, into the files ``--doc`` and ``--out`` name (what the test suite
runs).
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import subprocess
import sys
from pathlib import Path

from pes_ref.rigid.shipped import DRIVES, markdown_table, measure_all, rewrite

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "rigid.md"
OUT = ROOT / "validation" / "out" / "rigid_devices"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--smoke", action="store_true", help="the drum cam alone, dynamically")
    ap.add_argument("--doc", default=str(DOC), help="the page whose table is rewritten")
    ap.add_argument("--out", default=str(OUT), help="the folder of rows.json")
    args = ap.parse_args(argv)
    cases = tuple(c for c in DRIVES if c.name == "drum_cam") if args.smoke else DRIVES
    modes = ("dynamic",) if args.smoke else ("quasistatic", "dynamic")
    load = os.getloadavg()
    rows = measure_all(str(ROOT), cases, modes, report=lambda row: print(json.dumps(row), flush=True))
    load = tuple(max(a, b) for a, b in zip(load, os.getloadavg()))
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                            text=True).stdout.strip() or "unknown"
    today = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d")
    table = markdown_table(rows)
    stamp = (f"`make rigid-devices` rewrites this table. Conditions: load average up to {load[0]:.1f} (1 min), "
             f"{load[1]:.1f} (5 min); times are each engine's whole drive, the C-space built before.\n\n"
             f"regenerated: {today}, commit `{commit}`")
    print(table)
    out, doc = Path(args.out), Path(args.doc)
    out.mkdir(parents=True, exist_ok=True)
    (out / "rows.json").write_text(json.dumps(rows, indent=1) + "\n")
    doc.write_text(rewrite(doc.read_text(), stamp + "\n\n" + table))
    return 0


if __name__ == "__main__":
    sys.exit(main())
