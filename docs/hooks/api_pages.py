"""The API reference's pages, made when the site is built (an mkdocs hook).

One page per subpackage of ``pes_ref`` (and one for the package itself): each public module
(one whose name has no leading underscore) is rendered by mkdocstrings from its docstrings
(numpydoc style). The list of modules is read from the package, so a new module is in the
reference without anything to edit; ``tests/project/test_docs_site.py`` checks that every
public name has a docstring.
"""
from __future__ import annotations

import pkgutil

import pes_ref

#: The API pages, in the order of the layers (docs/architecture.md), highest first.
SUBPACKAGES = ("cli", "bench", "testing", "sweep", "realize", "synthesis", "rigid", "devices", "oracle", "accel",
               "core")


def public_modules(package: str) -> list:
    """The public modules of ``pes_ref.<package>`` (and their public submodules), sorted."""
    pkg = __import__(f"pes_ref.{package}", fromlist=["__path__"])
    names = [f"pes_ref.{package}"]
    for info in pkgutil.walk_packages(pkg.__path__, f"pes_ref.{package}."):
        if not any(part.startswith("_") for part in info.name.split(".")):
            names.append(info.name)
    return sorted(names)


def page(package: str) -> str:
    """The Markdown of one subpackage's page: a heading and one mkdocstrings block per module."""
    lines = [f"# `pes_ref.{package}`", ""]
    for name in public_modules(package):
        lines += [f"## `{name}`", "", f"::: {name}", "    options:", "      show_root_heading: false",
                  "      heading_level: 3", ""]
    return "\n".join(lines)


def pages() -> dict:
    """Every API page: path under docs/ -> Markdown."""
    out = {"api/index.md": "\n".join(
        ["# API reference", "", "The public API is re-exported from `pes_ref` (below); each subpackage's "
         "page holds its public modules, a layer's from the highest to the lowest (docs/architecture.md).", "",
         "::: pes_ref", "    options:", "      show_root_heading: false", "      heading_level: 2", ""]
        + [f"- [`pes_ref.{p}`]({p}.md)" for p in SUBPACKAGES])}
    for p in SUBPACKAGES:
        out[f"api/{p}.md"] = page(p)
    return out


def on_files(files, config):
    """Add the API pages to the site's files (mkdocs' ``on_files`` event)."""
    from mkdocs.structure.files import File      # here: the test of the docstrings loads this file without mkdocs
    for path, text in pages().items():
        files.append(File.generated(config, path, content=text))
    return files
