"""The ``conformance`` command: ``conformance --write [DIR] | --check [DIR]`` regenerates the
conformance vectors, or regenerates them into a scratch folder and compares them with the
shipped ones."""
from __future__ import annotations

import os

from pes_ref.cli.common import EXIT_FAIL, EXIT_OK, add_command, error, input_folder, output_folder


def add_parser(sub) -> None:
    from pes_ref.oracle.conformance import LATEST as VERSION   # not .generate: json, hashlib at every start-up
    p = add_command(sub, "conformance", help="write or check the shipped conformance vectors",
        description="The conformance vectors are oracle cases with their reference results and invalid "
                    "cases, listed in manifest.json (pes_ref/oracle/conformance/<version>/). --write regenerates "
                    "them; --check regenerates them into a temporary folder and compares them with the "
                    "shipped ones (cases identical, results within the tolerances of docs/spec.md section "
                    "11), printing one line per vector; it exits 1 if any differs.",
        examples=['conformance --check', 'conformance --write /tmp/pes_ref-vectors && '
                  'python -m pes_ref conformance --check /tmp/pes_ref-vectors --quiet'])
    mode = p.add_mutually_exclusive_group(required=True)
    mode.add_argument("--write", nargs="?", const="", default=None, metavar="DIR",
                      help="regenerate the vectors into DIR (default: the package's own folder)")
    mode.add_argument("--check", nargs="?", const="", default=None, metavar="DIR",
                      help="compare freshly generated vectors with those in DIR (default: the shipped ones)")
    p.add_argument("--vectors", default=VERSION, choices=[VERSION],
                   help=f"the vector set version (default {VERSION}; only the newest can be generated)")
    p.add_argument("--quiet", action="store_true", help="print only the summary line")
    p.set_defaults(func=_run_conformance)


def _write_target(path: str) -> str:
    """Refuse a --write folder that cannot be made, or one holding files but no vector set
    (regenerating removes stale vector files there: never a user's own)."""
    output_folder(path)
    if os.path.isdir(path) and os.listdir(path) and not os.path.exists(os.path.join(path, "manifest.json")):
        raise FileExistsError(f"--write {path}: the folder holds files but no vector set (manifest.json); "
                              "write into a new or empty folder")
    return path


def _check_source(path: str) -> str:
    """Refuse a --check folder that holds no vector set, before generating anything."""
    input_folder(path, "--check folder")
    if not os.path.isfile(os.path.join(path, "manifest.json")):
        raise FileNotFoundError(f"--check folder {path} holds no vector set (no manifest.json)")
    return path


def _run_conformance(args) -> int:
    import tempfile

    from pes_ref.oracle.conformance import generate, vectors_dir
    if args.write is not None:
        try:
            target = _write_target(args.write) if args.write else vectors_dir(args.vectors)
            manifest = generate.write_vectors(target, quiet=args.quiet)
        except OSError as exc:
            return error(exc)
        entries = manifest["vectors"]
        n_valid = sum(e["kind"] == "valid" for e in entries)
        print(f"wrote {len(entries)} vectors ({n_valid} valid, {len(entries) - n_valid} invalid) to {target}")
        return EXIT_OK
    try:
        shipped = _check_source(args.check) if args.check else vectors_dir(args.vectors)
    except OSError as exc:
        return error(exc)
    with tempfile.TemporaryDirectory(prefix="pes_ref-conformance-") as fresh:
        generate.write_vectors(fresh)
        try:
            rows = generate.compare_dirs(shipped, fresh)
        except OSError as exc:
            return error(exc)
    for vid, ok, err, detail in rows:
        if not args.quiet or not ok:
            print(f"{'ok' if ok else 'FAIL':4s}  {vid:40s} max rel err {err:.1e}" + ("" if ok else f"  {detail}"))
    failed = [r for r in rows if not r[1]]
    if failed:
        print(f"conformance check FAILED: {len(failed)} of {len(rows)} vectors differ from {shipped}")
        return EXIT_FAIL
    print(f"conformance check ok: {len(rows)} vectors match {shipped}")
    return EXIT_OK
