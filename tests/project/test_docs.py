"""The examples in docstrings and in the README run and say what they claim."""
import doctest
import importlib
import pathlib
import re

import numpy as np
import pytest
from _helpers import without_progress

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("module", ["pes_ref.core.scene", "pes_ref.oracle.case", "pes_ref.synthesis.common.optimizers"])
def test_docstring_examples(module):
    result = doctest.testmod(importlib.import_module(module), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0


def test_readme_example_runs(monkeypatch):
    code = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    assert code, "the README has a Python example"
    monkeypatch.chdir(ROOT)                      # its device file's path is the repository's
    namespace = {}
    exec(compile(code[0], "README.md", "exec"), namespace)
    assert namespace["grads"]["values"].shape == (40, 40)
    assert namespace["traj"].x.shape == (201, 2, 2)
    assert namespace["law"].advance_per_cycle == pytest.approx(-np.pi / 2, abs=1e-3)


def _readme_commands(word: str) -> list:
    """The README's shell lines that run ``python -m pes_ref WORD``, without their comments."""
    blocks = re.findall(r"```sh\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    return [line.split("#")[0].split() for block in blocks for line in block.splitlines()
            if f"-m pes_ref {word} " in line]


def test_readme_oracle_example_runs_as_written(tmp_path):
    """Its case is a shipped vector of the newest set, and the command runs from the
    repository's root (into a scratch folder here, so that nothing is left behind)."""
    import shutil
    import subprocess
    import sys

    from pes_ref.oracle.conformance import LATEST
    argv = _readme_commands("oracle")[0]          # the first: one shipped case
    assert argv[0] == ".venv/bin/python" and argv[1:4] == ["-m", "pes_ref", "oracle"]
    case, result = argv[4], argv[5]
    assert case.startswith(f"pes_ref/oracle/conformance/{LATEST}/") and (ROOT / case).is_file()
    shutil.copytree(ROOT / "pes_ref" / "oracle" / "conformance" / LATEST, tmp_path / case.rsplit("/", 1)[0])
    proc = subprocess.run([sys.executable, "-m", "pes_ref", "oracle", case, result], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120,
                          env={**__import__("os").environ, "PYTHONPATH": str(ROOT)})
    assert proc.returncode == 0 and without_progress(proc.stderr) == "", proc.stderr
    assert proc.stdout.startswith(f"wrote {result}: ") and (tmp_path / result).is_file()


# ------------------------------------------------------------------ the docs name what exists

#: The prose a reader follows: every ``pes_ref/...`` path and dotted ``pes_ref`` name in it must exist.
DOCS = sorted([*ROOT.glob("docs/*.md"), ROOT / "README.md", ROOT / "tests" / "README.md",
               *ROOT.glob("examples/*/README.md")])
#: A repository path (a file or a folder) that starts with pes_ref/.
DOC_PATH = re.compile(r"(?<![\w./-])pes_ref/[\w./-]*[\w/]")
#: A dotted name under pes_ref: a module, then attributes.
DOC_NAME = re.compile(r"(?<![\w./-])pes_ref(?:\.[A-Za-z_]\w*)+")


def _resolves(name: str) -> bool:
    """Whether the dotted ``name`` is a module, or attributes of its longest importable prefix."""
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ModuleNotFoundError:
            continue
        for attr in parts[i:]:
            if not hasattr(obj, attr):
                return False
            obj = getattr(obj, attr)
        return True
    return False


def broken_references(text: str) -> list:
    """``line: reference`` for each path under pes_ref/ that does not exist and each dotted
    pes_ref name that does not import or resolve, in the order they appear."""
    out = []
    for lineno, line in enumerate(text.splitlines(), 1):
        out += [f"{lineno}: {p}" for p in DOC_PATH.findall(line) if not (ROOT / p).exists()]
        out += [f"{lineno}: {n}" for n in DOC_NAME.findall(line) if not _resolves(n)]
    return out


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_pes_ref_path_and_name_in_the_docs_exists(doc):
    assert broken_references(doc.read_text()) == []


def test_a_stale_reference_is_found():
    text = ("`pes_ref/core/grid.py` and `pes_ref.core.grid.Locator` hold;\n"
            "`pes_ref/surface.py`, `pes_ref.surface.Locator` and `pes_ref.core.grid.Nowhere` do not.")
    assert broken_references(text) == ["2: pes_ref/surface.py", "2: pes_ref.surface.Locator",
                                       "2: pes_ref.core.grid.Nowhere"]


def test_check_transcripts_count_what_the_code_ships():
    """Each transcript of ``pes_ref check`` in docs/oracle.md closes with the number of cases
    it runs: every vector of the newest set, its random cases and the mixed batch, in three
    processes (docs/spec.md 13.2)."""
    from pes_ref.testing.conformance import load_manifest
    n_vectors = len(load_manifest()["vectors"])
    transcripts = re.findall(r"```\n\$ (.*?)\n(.*?)```", (ROOT / "docs" / "oracle.md").read_text(), re.S)
    checks = [(cmd, out) for cmd, out in transcripts if "pes_ref check" in cmd or cmd.startswith("make check-example")]
    assert len(checks) == 2
    for cmd, out in checks:
        full = out.splitlines()[0] if cmd.startswith("make") else cmd
        n = n_vectors + int(re.search(r"--random (\d+)", full).group(1)) + 1
        assert out.rstrip().splitlines()[-1] == f"{n} passed, 0 failed", cmd
        assert re.search(rf"^{n} cases in 3 processes of the program", out, re.M), cmd


# ------------------------------------------------------------------ the docs say what is, not how it came to be

#: decisions.md records how things came to be, as CHANGELOG.md does, so it may name issues and times.
HISTORY_EXCLUDED = {"docs/decisions.md"}
PAGES = sorted(p for p in [*ROOT.glob("docs/*.md"), ROOT / "README.md"] if str(p.relative_to(ROOT)) not in HISTORY_EXCLUDED)
#: "issue 15", "issues 4 and 15", "Issue 30": a number a reader cannot follow (the repository has no tracker).
ISSUE = re.compile(r"\bissues? #?\d+", re.I)
#: A clock time: "21:31 UTC", "05:35-05:38 UTC".
CLOCK = re.compile(r"\b\d{1,2}:\d{2}(?:-\d{1,2}:\d{2})? ?UTC\b")
#: A generated block: between a ``<!-- NAME:begin ... -->`` line and its ``<!-- NAME:end -->``.
GENERATED = re.compile(r"^<!-- ([\w-]+):begin\b.*?^<!-- \1:end -->$", re.M | re.S)


def history_in(text: str) -> list:
    """``line: text`` for each issue number anywhere and each clock time outside a generated block."""
    outside = GENERATED.sub(lambda m: "\n" * m.group(0).count("\n"), text)
    out = [f"{n}: {m.group(0)}" for n, line in enumerate(text.splitlines(), 1) for m in ISSUE.finditer(line)]
    out += [f"{n}: {m.group(0)}" for n, line in enumerate(outside.splitlines(), 1) for m in CLOCK.finditer(line)]
    return sorted(out, key=lambda s: int(s.split(":")[0]))


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_page_tells_history(page):
    """How things came to be lives in CHANGELOG.md and docs/decisions.md; a page says what the code is."""
    assert history_in(page.read_text()) == []


def test_history_is_found():
    text = ("# Synthesis (issues 4 and 15)\nMeasured at 05:35-05:38 UTC, load 2.\nIssue 30 asked.\n"
            "<!-- t:begin (make t writes what follows) -->\nregenerated: 2026-11-28 04:54 UTC, commit `26790f3`\n"
            "<!-- t:end -->\nat 21:31 UTC; see the issue tracker, 15 issues in all.\n")
    assert history_in(text) == ["1: issues 4", "2: 05:35-05:38 UTC", "3: Issue 30", "7: 21:31 UTC"]


def test_the_quick_start_is_the_same_in_the_readme_and_on_the_site():
    """One quick start, shown twice: the README's and the site's first page's shell blocks are
    the same lines."""
    def block(path):
        text = (ROOT / path).read_text()
        after = text[text.index("## Quick start"):]
        return re.search(r"```sh\n(.*?)```", after, re.S).group(1)
    assert block("README.md") == block("docs/index.md")
    assert block("README.md").splitlines()[0].startswith("make venv ")


def test_every_docs_page_is_reachable_from_the_readme():
    """The README's table of the docs links every page of docs/ (the site's home, index.md,
    is the site's own) and no page that does not exist."""
    readme = (ROOT / "README.md").read_text()
    linked = set(re.findall(r"\]\((docs/[^)#]+\.md)\)", readme))
    pages = {str(p.relative_to(ROOT)) for p in ROOT.glob("docs/*.md")} - {"docs/index.md"}
    assert pages - linked == set(), "pages the README does not link"
    assert linked - pages == set(), "links to pages that do not exist"
    assert len(readme.splitlines()) < 130
