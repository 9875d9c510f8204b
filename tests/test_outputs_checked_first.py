"""A command's output paths are checked before it computes or writes anything: a --report or --out
that is an existing file ends the run at once, naming the option, with nothing written (it failed
after the work — 35 s of `study` — or after `identify dive` had written --out-vehicle)."""

from __future__ import annotations

import pandas as pd
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.examples import generate_example

runner = CliRunner()
FORCES = ["X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"]


@pytest.fixture(scope="module")
def pwm6(tmp_path_factory):
    p = tmp_path_factory.mktemp("dive") / "pwm6.csv"
    pd.DataFrame(generate_example("dive")).drop(columns=FORCES).to_csv(p, index=False)
    return p


@pytest.fixture
def afile(tmp_path):
    f = tmp_path / "afile.txt"
    f.write_text("keep\n")
    return f


def _said(r) -> str:
    return " ".join(r.output.split())


def test_identify_dive_writes_no_vehicle_when_the_report_cannot_be_written(pwm6, afile, tmp_path,
                                                                           monkeypatch):
    """It wrote half.yaml, then failed with "cannot write: File exists (afile.txt)" and never
    said half.yaml was written."""
    import uuvid.identify.vehicle.dive as dive

    def no_fit(*a, **k):
        raise AssertionError("identified before the outputs were checked")

    monkeypatch.setattr(dive, "identify_dive", no_fit)
    half = tmp_path / "half.yaml"
    r = runner.invoke(app, ["vehicle", "identify", "dive", str(pwm6), "--vehicle", "bluerov2",
                            "--dof", "heave", "--out-vehicle", str(half), "--report", str(afile)])
    assert r.exit_code == 2, r.output
    assert f"--report {afile}: a file of that name is in the way" in _said(r)
    assert "nothing was written" in _said(r)
    assert not half.exists() and afile.read_text() == "keep\n"
    r = runner.invoke(app, ["vehicle", "identify", "dive", str(pwm6), "--vehicle", "bluerov2",
                            "--dof", "heave", "--out-vehicle", str(afile / "x.yaml")])
    assert r.exit_code == 2 and f"{afile} is a file, not a folder" in _said(r)


def test_identify_dive_says_what_it_wrote_before_a_later_output_failed(pwm6, tmp_path,
                                                                      monkeypatch):
    from uuvid.identify.vehicle.dive import DiveIdentification

    def disk_full(self, folder):
        raise OSError(28, "No space left on device", str(folder))

    monkeypatch.setattr(DiveIdentification, "report", disk_full)
    out = tmp_path / "v.yaml"
    r = runner.invoke(app, ["vehicle", "identify", "dive", str(pwm6), "--vehicle", "bluerov2",
                            "--dof", "heave", "--out-vehicle", str(out), "--report",
                            str(tmp_path / "rep")])
    assert r.exit_code == 2, r.output
    assert "No space left on device" in _said(r) and f"{out} had been written before" in _said(r)


@pytest.mark.parametrize("command, target", [
    (["study", "--bandwidths", "1"], "uuvid.papers.thruster_loop_study.run_study"),
    (["vehicle", "hold", "bluerov2"], "uuvid.analysis.hold._capability"),
    (["simulate", "mission", "square"], "uuvid.simulate.vehicle_sim.fly_mission"),
])
def test_out_is_checked_before_the_work(command, target, afile, monkeypatch):
    """`uuvid study --out afile.txt` failed after 35 s of computing; hold and simulate alike."""
    mod, name = target.rsplit(".", 1)

    def no_work(*a, **k):
        raise AssertionError("computed before --out was checked")

    monkeypatch.setattr(__import__(mod, fromlist=[name]), name, no_work)
    r = runner.invoke(app, [*command, "--out", str(afile)])
    assert r.exit_code == 2, (r.output, r.exception)
    assert f"--out {afile}: a file of that name is in the way" in _said(r)
    assert "nothing was written" in _said(r) and afile.read_text() == "keep\n"


def test_replay_out_is_checked_before_the_replay(pwm6, afile, monkeypatch):
    import uuvid.simulate.dive_replay as dr

    monkeypatch.setattr(dr, "replay_dive", lambda *a, **k: pytest.fail("replayed first"))
    r = runner.invoke(app, ["vehicle", "replay", str(pwm6), "--vehicle", "bluerov2", "--out",
                            str(afile)])
    assert r.exit_code == 2 and "--out" in _said(r) and "nothing was written" in _said(r)


def test_a_folder_that_does_not_exist_yet_is_not_created_by_the_check(tmp_path, monkeypatch):
    """The check creates nothing: a run that then fails on its input leaves no empty folder."""
    r = runner.invoke(app, ["vehicle", "identify", "dive", str(tmp_path / "nosuch.csv"),
                            "--vehicle", "bluerov2", "--report", str(tmp_path / "new" / "rep")])
    assert r.exit_code == 2 and not (tmp_path / "new").exists()


def test_vehicle_stability_checks_out_before_the_work(afile, monkeypatch):
    """It made the folder and plotted into it after the analysis: a file in the way was a
    traceback (FileExistsError), not a message naming --out."""
    import uuvid.vehicle.stability as stab

    def no_work(*a, **k):
        raise AssertionError("analysed before --out was checked")

    monkeypatch.setattr(stab, "static_stability", no_work)
    r = runner.invoke(app, ["vehicle", "stability", "bluerov2", "--out", str(afile)])
    assert r.exit_code == 2, r.output
    assert f"--out {afile}: a file of that name is in the way" in _said(r)
    assert afile.read_text() == "keep\n"
