"""Ctrl-C never leaves an empty or partial output folder a run created, and always says
"interrupted": ``vehicle hold --out`` interrupted after the capability was "done" (while its
figure was drawn) left an empty folder and said nothing."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from uuvid.analysis import hold
from uuvid.cli.app import app
from uuvid.core import progress


@pytest.fixture(autouse=True)
def _fresh_interrupt_flag(monkeypatch):
    monkeypatch.setattr(progress, "_INTERRUPT_SAID", [False])


def _interrupt_while_plotting(monkeypatch):
    def plot(self, path=None, mark=None):
        path.write_bytes(b"half a png")  # the folder exists and holds a partial file
        raise KeyboardInterrupt

    monkeypatch.setattr(hold.CapabilityResult, "plot", plot)


def test_hold_interrupted_while_writing_leaves_no_folder_and_says_so(tmp_path, monkeypatch):
    _interrupt_while_plotting(monkeypatch)
    out = tmp_path / "hold_15"
    res = CliRunner().invoke(app, ["vehicle", "hold", "bluerov2", "--step", "90", "--voltage", "14",
                                   "--current", "0.3,0", "--out", str(out)])
    assert res.exit_code == 130, res.output
    assert "interrupted" in res.output
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []  # no temporary folder either


def test_hold_interrupted_keeps_an_old_report_whole(tmp_path, monkeypatch):
    out = tmp_path / "hold"
    res = CliRunner().invoke(app, ["vehicle", "hold", "bluerov2", "--step", "90", "--out", str(out)])
    assert res.exit_code == 0, res.output
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    _interrupt_while_plotting(monkeypatch)
    res = CliRunner().invoke(app, ["vehicle", "hold", "bluerov2", "--step", "90", "--out", str(out)])
    assert res.exit_code == 130 and "interrupted" in res.output
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_interrupted_is_said_once_when_a_progress_line_said_it(monkeypatch, capsys):
    from uuvid.cli.helptext import TidyHelpGroup

    group = TidyHelpGroup()

    def command(self, ctx):  # a task that reports its own interruption, then Ctrl-C reaches us
        if ctx == "task":
            progress.say_interrupted("task: interrupted after 1.0 s")
        raise KeyboardInterrupt

    monkeypatch.setattr(TidyHelpGroup.__mro__[1], "invoke", command)
    for ctx in ("task", None):  # each command says it once
        with pytest.raises(KeyboardInterrupt):
            group.invoke(ctx)
    assert capsys.readouterr().err == "task: interrupted after 1.0 s\ninterrupted\n"


def test_main_says_interrupted_for_a_ctrl_c_outside_the_command(monkeypatch, capsys):
    import uuvid.cli.app as cli

    def app_():  # as typer ends a Ctrl-C: Exit(130) from the KeyboardInterrupt, then sys.exit
        try:
            try:
                raise KeyboardInterrupt
            except KeyboardInterrupt as e:
                raise RuntimeError("exit") from e
        except RuntimeError:
            raise SystemExit(130)  # noqa: B904 - chained implicitly, as sys.exit() in typer

    monkeypatch.setattr(cli, "_app", app_)
    monkeypatch.setattr(cli, "_register_subcommands", lambda command=None: None)
    with pytest.raises(SystemExit):
        cli.main()
    assert "interrupted" in capsys.readouterr().err

    def exits_on_its_own():  # a command that said its own "interrupted: …" (raise … from None)
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise SystemExit(130) from None

    monkeypatch.setattr(progress, "_INTERRUPT_SAID", [False])
    monkeypatch.setattr(cli, "_app", exits_on_its_own)
    with pytest.raises(SystemExit):
        cli.main()
    assert capsys.readouterr().err == ""


def _interrupt(*args, **kwargs):
    for a in args:  # write half a file where the figure goes, then Ctrl-C
        if hasattr(a, "write_bytes"):
            a.write_bytes(b"half a png")
    raise KeyboardInterrupt


def test_thruster_simulate_interrupted_while_writing_leaves_no_folder(tmp_path, monkeypatch):
    import uuvid.core.plots as plots

    monkeypatch.setattr(plots, "save_figure", lambda fig, path, *a, **k: _interrupt(path))
    out = tmp_path / "sim"
    res = CliRunner().invoke(app, ["thruster", "simulate", "t200", "--t-end", "0.2", "--out", str(out)])
    assert res.exit_code == 130 and "interrupted" in res.output, res.output
    assert list(tmp_path.iterdir()) == []


def test_vehicle_stability_interrupted_while_writing_leaves_no_folder(tmp_path, monkeypatch):
    from uuvid.vehicle.stability import StabilityResult

    monkeypatch.setattr(StabilityResult, "plot", lambda self, path=None: _interrupt(path))
    out = tmp_path / "stab"
    res = CliRunner().invoke(app, ["vehicle", "stability", "bluerov2", "--out", str(out)])
    assert res.exit_code == 130 and "interrupted" in res.output, res.output
    assert list(tmp_path.iterdir()) == []


def test_mission_outputs_interrupted_while_writing_leave_no_folder(tmp_path, monkeypatch):
    import pandas as pd

    from uuvid.simulate import mission_report

    class Flight:
        metrics = {"vehicle": "v", "mission": "m"}

        def to_frame(self):
            return pd.DataFrame({"t_s": [0.0, 0.1]})

    monkeypatch.setattr(mission_report, "mission_figures", _interrupt)
    with pytest.raises(KeyboardInterrupt):
        mission_report.write_mission_outputs(Flight(), None, tmp_path / "flight")
    assert list(tmp_path.iterdir()) == []


@pytest.fixture(scope="module")
def dive_csv(tmp_path_factory):
    import pandas as pd

    from uuvid.examples import generate_example

    p = tmp_path_factory.mktemp("dive") / "dive.csv"
    tb = pd.DataFrame(generate_example("dive"))
    tb[tb["t_s"] <= 200].to_csv(p, index=False)
    return p


@pytest.mark.slow
def test_identify_dive_interrupted_in_the_report_leaves_no_folder_and_names_the_vehicle_file(
        dive_csv, tmp_path, monkeypatch):
    """Ctrl-C while the replay figure was drawn left a report folder with result.json and
    summary.txt but no index.html, and a complete --out-vehicle file the console never named."""
    from uuvid.identify.vehicle.dive import DiveIdentification

    monkeypatch.setattr(DiveIdentification, "plot", lambda self, path=None: _interrupt(path))
    rep, veh = tmp_path / "rep", tmp_path / "v.yaml"
    res = CliRunner().invoke(app, ["vehicle", "identify", "dive", str(dive_csv), "--vehicle",
                                   "bluerov2", "--dof", "heave", "--out-vehicle", str(veh),
                                   "--report", str(rep)])
    assert res.exit_code == 130 and "interrupted" in res.output, res.output
    assert f"wrote {veh} before the interrupt" in " ".join(res.output.split())
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v.yaml"]  # no (temporary) folder


def test_replay_interrupted_in_the_report_leaves_no_folder(dive_csv, tmp_path, monkeypatch):
    from uuvid.simulate.dive_replay import DiveReplay

    monkeypatch.setattr(DiveReplay, "plot", lambda self, path=None: _interrupt(path))
    res = CliRunner().invoke(app, ["vehicle", "replay", str(dive_csv), "--vehicle", "bluerov2",
                                   "--dof", "heave", "--out", str(tmp_path / "rep")])
    assert res.exit_code == 130 and "interrupted" in res.output, res.output
    assert list(tmp_path.iterdir()) == []
