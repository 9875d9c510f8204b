"""`--help` of every command shows what its source says: units in brackets, flags without a type."""

import inspect
import re

import pytest
from typer.models import ParameterInfo
from typer.testing import CliRunner

from uuvid import __version__
from uuvid.cli.app import app

runner = CliRunner()
BRACKETED = re.compile(r"\[[^\[\]\n]+\]")


def _commands(typer_app, path=()):
    """(command path, callback) of every command registered on the typer app, recursively."""
    for ci in typer_app.registered_commands:
        name = ci.name or ci.callback.__name__.lower().replace("_", "-")
        yield path + (name,), ci.callback
    for gi in typer_app.registered_groups:
        yield from _commands(gi.typer_instance, path + (gi.name,))


def _source_help(callback) -> list[str]:
    texts = [inspect.getdoc(callback) or ""]
    for p in inspect.signature(callback).parameters.values():
        infos = [p.default] + list(getattr(p.annotation, "__metadata__", ()))
        texts += [i.help for i in infos if isinstance(i, ParameterInfo) and i.help]
    return texts


def _flat(text: str) -> str:
    return re.sub(r"[\s│┃]+", "", text)


@pytest.mark.slow
def test_every_command_help_keeps_its_bracketed_units_and_plain_flags():
    cmds = list(_commands(app))
    assert len(cmds) > 15  # the walk found the whole tree
    checked = 0
    for path, callback in cmds:
        res = runner.invoke(app, [*path, "--help"], env={"TERMINAL_WIDTH": "100"})
        assert res.exit_code == 0, (path, res.output)
        shown = _flat(res.output)
        for text in _source_help(callback):
            for token in BRACKETED.findall(text):
                assert _flat(token) in shown, f"`uuvid {' '.join(path)} --help` lost {token!r}"
                checked += 1
        assert "<bool>" not in res.output, f"`uuvid {' '.join(path)} --help` labels a flag <bool>"
    assert checked > 10  # units such as [s], [m/s], [rad/s] were in the sources and were checked


def test_thruster_simulate_help_shows_seconds():
    res = runner.invoke(app, ["thruster", "simulate", "--help"])
    assert "Simulated time [s]." in res.output


def test_version():
    res = runner.invoke(app, ["--version"])
    assert res.exit_code == 0
    assert res.stdout.strip() == f"uuvid {__version__}"


def test_python_dash_m_runs_the_same_command_line():
    """``python -m uuvid`` (no console script on PATH, a notebook's ``!python -m``) is the CLI."""
    import subprocess
    import sys

    res = subprocess.run([sys.executable, "-m", "uuvid", "--version"], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    assert res.stdout.strip() == f"uuvid {__version__}"


def test_console_tables_wrap_instead_of_cutting():
    import io

    from rich.table import Table

    from uuvid.cli.common import _FoldingConsole

    con = _FoldingConsole(width=24, file=io.StringIO())
    t = Table()
    t.add_column("eta_horizontal_all_the_way_round")
    t.add_row("0.61678 ± 0.00912 (significant)")
    con.print(t)
    out = con.file.getvalue()
    assert "…" not in out
    assert "eta_horizontal_all_the_way_round" in _flat(out)
    assert "0.61678±0.00912(significant)" in _flat(out)


@pytest.mark.slow
def test_out_is_a_folder_and_file_outputs_have_their_own_option(tmp_path):
    from uuvid.thruster.modelfile import load_chain
    from uuvid.thruster.presets import laidani_chain

    new = tmp_path / "new.yaml"
    res = runner.invoke(app, ["thruster", "export", "laidani-a2212", "--out-file", str(new)])
    assert res.exit_code == 0, res.output
    assert load_chain(new) == laidani_chain()
    old = tmp_path / "old.yaml"  # the old spelling still works, with a note on stderr
    res = runner.invoke(app, ["thruster", "export", "laidani-a2212", "--out", str(old)])
    assert res.exit_code == 0 and old.read_text() == new.read_text()
    assert "deprecated" in res.stderr and "--out-file" in res.stderr
    res = runner.invoke(app, ["thruster", "export", "laidani-a2212", "--out", str(old), "--out-file",
                              str(new)])
    assert res.exit_code == 2
    # an old --out without a suffix meant a folder: an error that says so, nothing written
    res = runner.invoke(app, ["thruster", "export", "laidani-a2212", "--out",
                              str(tmp_path / "results")])
    assert res.exit_code == 2 and "has none" in res.stderr and "--out-file" in res.stderr
    assert not (tmp_path / "results").exists()
    # every visible --out is documented as a folder
    import typer

    root = typer.main.get_command(app)

    def walk(cmd, path=()):
        for name, sub in getattr(cmd, "commands", {}).items():
            yield from walk(sub, path + (name,))
        if not getattr(cmd, "commands", None):
            yield path, cmd

    for path, cmd in walk(root):
        for p in cmd.params:
            if "--out" in getattr(p, "opts", ()) and not getattr(p, "hidden", False):
                assert any(w in (p.help or "").lower() for w in ("folder", "here", "dir")), (path, p.help)


def test_group_command_lists_show_each_summary_on_one_line():
    """A docstring's first paragraph spans source lines; the group's command list (which shows
    ``short_help or help``, first paragraph, line breaks kept in rich mode) gets it as one line."""
    import typer

    def walk(cmd, path=()):
        for name, sub in getattr(cmd, "commands", {}).items():
            yield path + (name,), sub
            yield from walk(sub, path + (name,))

    root = typer.main.get_command(app)
    checked = 0
    for path, cmd in walk(root):
        text = cmd.short_help or cmd.help or ""
        first = inspect.cleandoc(text).split("\n\n")[0].strip()
        assert "\n" not in first, f"`uuvid {' '.join(path[:-1])} --help` breaks {path[-1]}: {first!r}"
        checked += bool(first)
    assert checked > 15
    res = runner.invoke(app, ["vehicle", "--help"])
    assert "trim roll/pitch against" in res.output


def test_current_flags_say_which_way_the_water_goes():
    """simulate --current is where the water flows TO (N,E,D); hold --current SPEED,DIR where it
    comes FROM (degrees off the bow): both help texts say so explicitly."""
    import re

    from typer.testing import CliRunner

    from uuvid.cli.app import app

    def flat(args):
        out = CliRunner().invoke(app, args, env={"COLUMNS": "300"}).output
        return re.sub(r"[\s│]+", " ", out)

    assert "flows TO" in flat(["simulate", "--help"])
    assert "comes FROM" in flat(["vehicle", "hold", "--help"])


def test_vehicle_help_summary_names_hold_and_stability():
    from uuvid.cli.vehicle_cmds import vehicle_app

    assert "hold" in vehicle_app.info.help and "stability" in vehicle_app.info.help
