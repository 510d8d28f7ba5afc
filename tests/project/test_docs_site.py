"""The documentation site is whole: every public name of pes_ref has a docstring (mkdocstrings
shows no object without one), every page of docs/ is in mkdocs.yml's nav and every nav entry is
a page, and the site builds strictly (``make docs``: a warning, such as a broken reference,
fails it).

The public modules are the API pages' own (``public_modules`` of docs/hooks/api_pages.py, the
mkdocs hook that makes those pages), so this checks what the site shows."""
import dataclasses
import importlib
import inspect
import os
import pkgutil
import re
import subprocess
import sys
import types

import pytest
import yaml

import pes_ref
from _helpers import ROOT, load_script

#: The mkdocs hook that makes the API pages (docs/ is not a package: loaded from its path).
HOOK = load_script(ROOT / "docs" / "hooks" / "api_pages.py")


def public_modules() -> list:
    """Every module the API reference renders: ``pes_ref`` and each subpackage's public modules."""
    return ["pes_ref"] + [name for package in HOOK.SUBPACKAGES for name in HOOK.public_modules(package)]


def docstring(obj) -> str:
    """The docstring mkdocstrings shows for ``obj``, which it reads from the source: its own,
    not one :func:`inspect.getdoc` finds on a base class, nor the signature that ``@dataclass``
    or ``NamedTuple`` writes into a class that has none."""
    if inspect.isclass(obj):
        doc = vars(obj).get("__doc__")
        if doc and dataclasses.is_dataclass(obj):
            try:
                if doc == obj.__name__ + str(inspect.signature(obj)).replace(" -> None", ""):
                    return ""
            except (TypeError, ValueError):
                pass
        if doc and hasattr(obj, "_fields") and doc == f"{obj.__name__}({', '.join(obj._fields)})":
            return ""
    else:
        doc = obj.__doc__
    return inspect.cleandoc(doc) if doc else ""


def undocumented(module) -> list:
    """What of ``module`` has no docstring, by dotted name: the module itself, each class and
    function of its ``__all__`` defined in it (not re-exported), and each public method,
    class method, static method and property of those classes."""
    name = module.__name__
    missing = [] if inspect.getdoc(module) else [name]
    for attr in getattr(module, "__all__", ()):
        obj = getattr(module, attr)
        if not (inspect.isclass(obj) or inspect.isfunction(obj)) or obj.__module__ != name:
            continue
        if not docstring(obj):
            missing.append(f"{name}.{attr}")
        if inspect.isclass(obj):
            for member, value in vars(obj).items():
                fn = value.fget if isinstance(value, property) else getattr(value, "__func__", value)
                if not member.startswith("_") and inspect.isfunction(fn) and not docstring(fn):
                    missing.append(f"{name}.{attr}.{member}")
    return missing


def test_every_public_subpackage_has_an_api_page():
    public = {m.name for m in pkgutil.iter_modules(pes_ref.__path__) if not m.name.startswith("_")}
    assert public == set(HOOK.SUBPACKAGES), "docs/hooks/api_pages.py SUBPACKAGES must list every subpackage"


def test_every_public_name_has_a_docstring():
    modules = public_modules()
    assert len(modules) > 100 and "pes_ref.core.scene" in modules
    missing = [m for name in modules for m in undocumented(importlib.import_module(name))]
    assert not missing, (f"public names without a docstring, which the API reference does not show "
                         f"({len(missing)}):\n" + "\n".join(missing))


def test_undocumented_finds_what_the_site_would_not_show():
    class Base:
        def inherited(self):
            """Documented on the base class only."""

    @dataclasses.dataclass
    class Plain(Base):
        def inherited(self):
            pass

        @property
        def size(self):
            return 0

        @classmethod
        def make(cls):
            return cls()

        def _private(self):
            pass

    def bare():
        pass

    module = types.ModuleType("fake", "A module.")
    Plain.__module__ = bare.__module__ = "fake"
    module.__all__ = ["Plain", "bare", "HOOK"]
    module.Plain, module.bare, module.HOOK = Plain, bare, HOOK
    assert undocumented(module) == ["fake.Plain", "fake.Plain.inherited", "fake.Plain.size", "fake.Plain.make",
                                    "fake.bare"]
    assert undocumented(types.ModuleType("empty")) == ["empty"]


def nav_pages(nav) -> list:
    """The page paths of an mkdocs ``nav``: entries ``path``, ``{title: path}`` or ``{title: [...]}``."""
    out = []
    for entry in nav:
        for value in (entry.values() if isinstance(entry, dict) else [entry]):
            out += nav_pages(value) if isinstance(value, list) else [value]
    return out


def test_every_page_is_in_the_nav_and_every_nav_entry_is_a_page():
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    nav = nav_pages(config["nav"])
    generated = set(HOOK.pages())
    written = {p.relative_to(ROOT / "docs").as_posix() for p in (ROOT / "docs").rglob("*.md")
               if not {"hooks", "tutorial"} & set(p.relative_to(ROOT / "docs").parts)}
    # the tutorial's page is made by the build from its script (mkdocs-gallery)
    generated |= {f"tutorial/{p.stem}.md" for p in (ROOT / "examples" / "tutorial").glob("plot_*.py")}
    assert len(nav) == len(set(nav)), f"pages twice in the nav: {sorted(p for p in nav if nav.count(p) > 1)}"
    assert not written - set(nav), f"pages of docs/ not in mkdocs.yml's nav: {sorted(written - set(nav))}"
    assert not generated - set(nav), f"API pages not in mkdocs.yml's nav: {sorted(generated - set(nav))}"
    assert not set(nav) - written - generated, f"nav entries that are no page: {sorted(set(nav) - written - generated)}"
    assert nav_pages([{"A": "a.md"}, {"B": ["b.md", {"C": "c.md"}]}, "d.md"]) == ["a.md", "b.md", "c.md", "d.md"]


def test_the_site_builds_strictly(tmp_path):
    pytest.importorskip("mkdocs", reason="the docs extra (in the test extra) builds the site")
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1", PES_REF_TUTORIAL="smoke", MPLBACKEND="Agg",
               PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-d", str(tmp_path / "site")],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    output = proc.stdout + proc.stderr
    assert proc.returncode == 0 and not re.search(r"^WARNING\b", output, re.M), f"mkdocs build --strict:\n{output}"
    assert "not included in the \"nav\"" not in output, output
    assert (tmp_path / "site" / "api" / "core" / "index.html").is_file()
    assert (tmp_path / "site" / "tutorial" / "plot_device_to_part" / "index.html").is_file()
    raw = {str(page.relative_to(tmp_path / "site")): sorted(set(SPHINX_ROLE.findall(_text(page))))
           for page in (tmp_path / "site").rglob("*.html")}
    assert not {page: roles for page, roles in raw.items() if roles}, "raw Sphinx roles on the site"
    core = (tmp_path / "site" / "api" / "core" / "index.html").read_text()
    assert core.count('class="autorefs autorefs-internal"') >= 300    # the docstrings' cross-references, linked


#: A Sphinx role (``:func:`name```), which mkdocstrings does not render: it would show as raw text.
SPHINX_ROLE = re.compile(r":(?:py:)?(?:func|class|meth|attr|data|mod|exc|obj|const|ref):`?")


def _text(page) -> str:
    """The text of an HTML page as a reader sees it (tags and their attributes left out)."""
    import html
    return html.unescape(re.sub(r"<[^>]*>", " ", page.read_text()))


def test_the_docstrings_use_no_sphinx_role():
    """The docstrings are numpydoc for mkdocstrings: a cross-reference is ``[`name`][pes_ref.module.name]``,
    which the strict build resolves, never a Sphinx role, which it would print as it is."""
    found = [f"{path.relative_to(ROOT)}:{i}" for path in sorted((ROOT / "pes_ref").rglob("*.py"))
             for i, line in enumerate(path.read_text().splitlines(), 1) if SPHINX_ROLE.search(line)]
    assert not found, found
