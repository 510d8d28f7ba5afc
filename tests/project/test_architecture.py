"""The architecture holds: pes_ref's subpackages import only downward (cli > bench |
testing > synthesis > devices > oracle > core) and no package has an import cycle between
its modules. The contracts are import-linter's, in setup.cfg; this runs ``lint-imports``
on this checkout, so that ``make test`` fails on an upward import or a cycle and prints
import-linter's report of it."""
import os
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
    assert "Contracts: 2 kept, 0 broken." in proc.stdout
