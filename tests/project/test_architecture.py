"""The architecture holds: pes_ref's subpackages import only downward, through the layers
listed once, in setup.cfg's import-linter contract, and no package has an import cycle
between its modules. This runs ``lint-imports`` on this checkout, so that ``make test``
fails on an upward import or a cycle and prints import-linter's report of it; and it
checks that docs/architecture.md draws those layers."""
import configparser
import os
import re
import subprocess
import sys

from _helpers import ROOT

#: ``lint-imports`` as the command line runs it, for this interpreter.
LINT_IMPORTS = "import sys; from importlinter.cli import lint_imports_command; sys.exit(lint_imports_command())"


def test_import_contracts_hold():
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    proc = subprocess.run([sys.executable, "-c", LINT_IMPORTS, "--config", str(ROOT / "setup.cfg"), "--no-cache",
                           "--no-logo"], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"import-linter (setup.cfg's contracts):\n{proc.stdout}\n{proc.stderr}"
    assert "Contracts: 5 kept, 0 broken." in proc.stdout


def setup_cfg_layers(contract: str = "layers") -> list:
    """The layers of one of setup.cfg's layers contracts, highest first, each a tuple of subpackages."""
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg")
    lines = cfg[f"importlinter:contract:{contract}"]["layers"].splitlines()
    return [tuple(name.strip() for name in line.split("|")) for line in lines if line.strip()]


def drawn_layers(text: str) -> list:
    """The layers of the diagram in ``text`` (docs/architecture.md's first code block):
    each line that starts with two spaces and the layer's ``a | b`` names."""
    block = re.search(r"```\n(.*?)```", text, re.S).group(1)
    return [tuple(name.strip() for name in m.group(1).split("|"))
            for m in re.finditer(r"^  (\w+(?: \| \w+)*)(?: {2,}|$)", block, re.M)]


def test_the_architecture_page_draws_the_layers_of_setup_cfg():
    layers = setup_cfg_layers()
    assert layers[0] == ("cli",) and layers[-1] == ("core",)
    assert drawn_layers((ROOT / "docs" / "architecture.md").read_text()) == layers


def test_the_architecture_page_draws_the_rooms_of_synthesis():
    rooms = setup_cfg_layers("synthesis")
    assert rooms[0] == ("engine",) and len(rooms) == 4
    text = (ROOT / "docs" / "architecture.md").read_text()
    assert drawn_layers(text[text.index("## synthesis's rooms"):]) == rooms


def test_a_diagram_without_a_layer_differs():
    diagram = "```\n  cli          the commands\n   |\n  bench | testing   the benchmark |\n" \
              "                    more words\n   |\n  core         the core\n```\n"
    assert drawn_layers(diagram) == [("cli",), ("bench", "testing"), ("core",)]


def test_the_walk_of_a_case_names_what_exists():
    """The path of a case's ``values`` to its ``grad_values`` (docs/architecture.md) names the
    functions each step runs, as ``core.scene.value_and_grad``: every such name resolves."""
    import importlib
    text = (ROOT / "docs" / "architecture.md").read_text()
    walk = text[text.index("## The path of a case's `values`"):]
    names = set(re.findall(r"`((?:core|oracle|cli)(?:\.\w+)+)", walk))
    assert len(names) >= 15, names
    missing = []
    for name in sorted(names):
        parts = ("pes_ref." + name).split(".")
        for cut in range(len(parts), 1, -1):
            try:
                obj = importlib.import_module(".".join(parts[:cut]))
            except ImportError:
                continue
            try:
                for attr in parts[cut:]:
                    obj = getattr(obj, attr)
            except AttributeError:
                missing.append(name)
            break
        else:
            missing.append(name)
    assert missing == [], missing


def test_no_code_asks_for_a_backend_by_its_name():
    """What a backend computes of its own is in its entry of ``core.backends.BACKENDS``
    (``kernels``), so a new backend is one entry: nothing compares a backend's name."""
    import re
    found = [f"{path.relative_to(ROOT)}:{i}" for path in sorted((ROOT / "pes_ref").rglob("*.py"))
             for i, line in enumerate(path.read_text().splitlines(), 1) if re.search(r"backend\s*[=!]=\s*['\"]", line)]
    assert not found, found


def test_one_registry_of_engines():
    """The engines are one registry (``pes_ref.rigid.engines.ENGINES``): no other module of the
    package binds a name ``ENGINES``."""
    import re
    found = [str(path.relative_to(ROOT)) for path in sorted((ROOT / "pes_ref").rglob("*.py"))
             if re.search(r"^ENGINES\s*[:=]", path.read_text(), re.M)]
    assert found == ["pes_ref/rigid/engines.py"], found
