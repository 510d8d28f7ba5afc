"""``python -m pes_ref analyze ratchet|dartgun``: output lines, help and errors (pes_ref.cli.analyze)."""
import re

import pytest

from pes_ref.cli import EXIT_ERROR, EXIT_OK, main

#: ``name: value unit``; names may carry a bracketed argument, values may be a range "a .. b".
LINE = re.compile(r"^[a-z_0-9]+(\[[a-z_]+=[-0-9.e+]+\])?: \S+( \.\. \S+)? \S+.*$")


def run(capsys, *argv):
    code = main(["analyze", *argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("device, option", [("ratchet", "--torque"), ("dartgun", "--trigger-forces")])
def test_help_explains_the_options(capsys, device, option):
    code, out, _ = run(capsys, device, "--help")
    assert code == EXIT_OK
    assert option in out and "--smoke" in out


@pytest.mark.parametrize("device, module, name, table", [
    ("ratchet", "pes_ref.devices.ratchet", "analyze_ratchet", "RATCHET_ANALYSIS"),
    ("dartgun", "pes_ref.devices.dartgun", "analyze_dartgun", "DARTGUN_ANALYSIS"),
])
def test_without_options_the_command_runs_the_analysis_with_its_defaults(capsys, monkeypatch, device, module, name,
                                                                         table):
    """The defaults live in the device module (its table, which the function's signature
    reads); the command passes them unchanged and its help shows each one."""
    import importlib
    import inspect

    mod = importlib.import_module(module)
    signature = [p.default for p in inspect.signature(getattr(mod, name)).parameters.values()][1:]
    got = []

    class Report:
        def as_lines(self):
            return []

        def warnings(self):
            return []

    def analysis(design, *values):
        got.extend(tuple(v) if isinstance(v, list) else v for v in values)
        return Report()
    monkeypatch.setattr(mod, name, analysis)
    assert run(capsys, device)[0] == EXIT_OK
    assert got == signature
    help_text = " ".join(run(capsys, device, "--help")[1].split())
    for value in getattr(mod, table).values():
        assert f"default {','.join(map(repr, value)) if isinstance(value, tuple) else repr(value)})" in help_text


def figures(capsys, *argv) -> dict:
    """Run a command that must succeed; its lines as {name: "value unit"}."""
    code, out, err = run(capsys, *argv)
    assert code == EXIT_OK and err == ""
    lines = out.splitlines()
    assert all(LINE.match(line) for line in lines), lines
    return dict(line.split(": ", 1) for line in lines)


def test_ratchet_prints_one_line_per_figure(capsys):
    values = figures(capsys, "ratchet", "--smoke", "--duration", "2", "--search-tol", "0.5")
    assert float(values["net_rotation_plus"].split()[0]) > float(values["net_rotation_minus"].split()[0])
    assert {"min_advancing_torque", "time_runs", "dt_stability_limit"} <= set(values)


def test_dartgun_prints_one_line_per_figure(capsys):
    values = figures(capsys, "dartgun", "--smoke", "--trigger-forces", "30", "--search-tol", "20")
    assert values["reload_latched"] == "True bool"
    assert float(values["exit_speed[trigger_force=30]"].split()[0]) > 0
    assert {"min_reload_force", "reload_bbox_q0", "fire_bbox_q1"} <= set(values)


@pytest.mark.parametrize("argv, quoted", [
    (("ratchet", "--torque", "abc"), "'abc'"),
    (("ratchet", "--torque", "-1"), "-1"),
    (("ratchet", "--duration", "nan"), "nan"),
    (("ratchet", "--search-tol", "0"), "0"),
    (("dartgun", "--reload-force", "inf"), "inf"),
    (("dartgun", "--trigger-forces", "10,x"), "'x'"),
    (("dartgun", "--trigger-forces", ","), "','"),
    (("dartgun", "--trigger-forces", "5,-2"), "-2"),
    (("dartgun", "--fire-time", "0"), "0"),
])
def test_bad_values_give_one_error_line(capsys, argv, quoted):
    code, out, err = run(capsys, *argv)
    assert code == EXIT_ERROR and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and argv[1] in lines[0] and quoted in lines[0]
