"""Every command's --help: every option and argument explained, defaults shown, and an
epilog of real invocations that parse, and (the quick ones) run as written."""
import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import pes_ref
from pes_ref.cli import build_parser
from pes_ref.oracle.conformance import LATEST

ROOT = Path(pes_ref.__file__).resolve().parent.parent


def _parsers():
    """(name, parser) of the top level, every command and every analyze device."""
    top = build_parser()
    out = [("pes_ref", top)]

    def walk(parser, name):
        for action in parser._actions:
            choices = getattr(action, "choices", None)
            for sub, child in (choices.items() if isinstance(choices, dict) else ()):
                if hasattr(child, "_actions"):
                    out.append((f"{name} {sub}", child))
                    walk(child, f"{name} {sub}")
    walk(top, "pes_ref")
    return out


PARSERS = _parsers()
IDS = [name for name, _ in PARSERS]


def test_every_command_and_device_is_here():
    assert {"pes_ref oracle", "pes_ref check", "pes_ref conformance", "pes_ref analyze", "pes_ref analyze ratchet",
            "pes_ref analyze dartgun", "pes_ref design", "pes_ref evaluate", "pes_ref bench"} <= set(IDS)


@pytest.mark.parametrize("name, parser", PARSERS, ids=IDS)
def test_every_option_and_argument_has_help(name, parser):
    for action in parser._actions:
        assert action.help and action.help.strip(), f"{name}: {action.option_strings or action.dest} has no help"


@pytest.mark.parametrize("name, parser", PARSERS, ids=IDS)
def test_defaults_are_shown(name, parser):
    help_text = parser.format_help()
    text = help_text[help_text.index("\noptions:"):]
    for action in parser._actions:
        if action.option_strings and action.default not in (None, False, [], "==SUPPRESS=="):
            flag = action.option_strings[-1]
            block = text[text.index(flag):]
            entry = block[:block.find("\n  -", 1) if "\n  -" in block[1:] else len(block)]
            assert "default" in entry, f"{name} {flag}: the default {action.default!r} is not shown"


def examples(parser) -> list:
    """The epilog's invocations, each as the commands of an ``a && b`` chain (argv lists)."""
    lines = [line.strip() for line in (parser.epilog or "").splitlines() if line.strip().startswith("python ")]
    return [[shlex.split(part)[3:] for part in line.split("&&")] for line in lines]


@pytest.mark.parametrize("name, parser", PARSERS, ids=IDS)
def test_every_parser_shows_examples_that_parse(name, parser):
    chains = examples(parser)
    assert 1 <= len(chains) <= 3, f"{name}: {len(chains)} examples"
    for chain in chains:
        for argv in chain:
            try:
                build_parser().parse_args(argv)
            except SystemExit:
                pytest.fail(f"{name}: example {' '.join(argv)} does not parse")


#: The examples quick enough to run here, as written (in a scratch folder holding the
#: shipped vectors at their path in the repository).
QUICK = ["pes_ref oracle", "pes_ref check", "pes_ref analyze ratchet", "pes_ref evaluate", "pes_ref realize"]
#: What each command's examples read, made first by the commands that write it.
SETUP = {
    "pes_ref evaluate": ("design funnel --smoke --quiet --out funnel.npz",
                         "design oscillator --smoke --quiet --out osc.npz",
                         "realize funnel.npz --as contact --out funnel_parts"),
    "pes_ref realize": ("design funnel --smoke --quiet --out funnel.npz",
                        "design oscillator --smoke --quiet --out osc.npz"),
}


#: The realize and evaluate examples design, realize and evaluate at full size (56 s of the
#: suite): make test-thorough runs them; in make test, tests/cli/test_cli_realize.py and
#: tests/cli/test_cli_evaluate.py run the same commands (realize --as contact, evaluate,
#: --realized) on smoke designs, and test_every_parser_shows_examples_that_parse parses them.
_LONG = {"pes_ref evaluate", "pes_ref realize"}


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.thorough) if n in _LONG else n for n in QUICK])
def test_quick_examples_run_as_written(name, tmp_path):
    parser = dict(PARSERS)[name]
    shutil.copytree(ROOT / "pes_ref" / "oracle" / "conformance" / LATEST,
                    tmp_path / "pes_ref" / "oracle" / "conformance" / LATEST)
    env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1")
    for argv in SETUP.get(name, ()):        # its examples read what other commands' examples write
        subprocess.run([sys.executable, "-m", "pes_ref", *argv.split()], cwd=tmp_path, env=env, check=True,
                       capture_output=True, timeout=120)
    for chain in examples(parser):
        for argv in chain:
            argv = [sys.executable if a == "python" else
                    a.replace("python ", shlex.quote(sys.executable) + " ", 1) if a.startswith("python ") else a
                    for a in argv]          # this interpreter, also inside a --cmd template
            proc = subprocess.run([sys.executable, "-m", "pes_ref", *argv], cwd=tmp_path, env=env,
                                  capture_output=True, text=True, timeout=300)
            assert proc.returncode == 0, f"{' '.join(argv)}: {proc.stderr}"
