"""``uuvid thruster fit --select`` / ``--model healey`` and ``uuvid thruster replay`` on bench-shaped
CSVs from a known two-state thruster with a dead band (analog volts command, speed and thrust)."""

from __future__ import annotations

import csv
import json

import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.identify.thruster.dynamic_select import reference_two_state_thruster, synthetic_experiments
from uuvid.thruster.modelfile import load_chain

runner = CliRunner()
COLS = ["--time-col", "t", "--command-col", "V", "--command-unit", "volts", "--speed-col", "w",
        "--thrust-col", "T"]


def _write(path, e):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t", "V", "w", "T"])
        for row in zip(e.t, e.u, e.speed, e.thrust):
            w.writerow([f"{v:.9g}" for v in row])
    return path


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("runs")
    recs = synthetic_experiments(reference_two_state_thruster(), (2.0, 3.0), rate=200.0, seed=5)
    return {e.name: _write(d / f"run{e.name}.csv", e) for e in recs}


def _json(res):
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout[res.stdout.index("{"):])


@pytest.mark.slow  # fits every family (≈ 3 s); the library selection runs in the default suite
def test_select_prints_the_table_and_writes_the_chosen_chain(files, tmp_path):
    out = tmp_path / "sel.yaml"
    res = runner.invoke(app, ["thruster", "fit", *map(str, files.values()), *COLS, "--select",
                              "--families", "first-order,healey", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "leave-one-level-out" in res.stdout and "chosen: healey+deadband" in res.stdout
    chain = load_chain(out)
    assert [b.TYPE for b in chain.blocks] == ["driver", "healey"]


@pytest.mark.slow
def test_select_over_every_family_writes_the_report(files, tmp_path):
    out, rep = tmp_path / "sel.yaml", tmp_path / "rep"
    res = runner.invoke(app, ["thruster", "fit", *map(str, files.values()), *COLS, "--select",
                              "--out", str(out), "--report", str(rep)])
    assert res.exit_code == 0, res.output
    assert "chosen: healey+deadband" in res.stdout
    assert (rep / "held_out.png").is_file() and (rep / "selection.csv").is_file()


@pytest.mark.slow
def test_healey_fit_then_replay_at_a_new_level(files, tmp_path):
    out = tmp_path / "h.yaml"
    doc = _json(runner.invoke(app, ["thruster", "fit", str(files["+2V"]), str(files["-2V"]), *COLS,
                                    "--model", "healey", "--out", str(out), "--json"]))
    assert set(doc["noise"]) == {"speed", "thrust"}
    assert "k_a/m_f" in doc["identifiable"]
    rdir = tmp_path / "replay"
    rep = _json(runner.invoke(app, ["thruster", "replay", str(out), str(files["+3V"]), *COLS,
                                    "--out", str(rdir), "--json"]))
    got = {r["channel"]: r["nrmse_%"] for r in rep["records"]}
    ins = {c: sum(r["nrmse_%"] for r in doc["in_sample_nrmse"] if r["channel"] == c) / 2
           for c in ("speed", "thrust")}
    for c in ("speed", "thrust"):
        assert got[c] <= 1.5 * ins[c]
    assert (rdir / "run+3V.predicted.csv").is_file() and (rdir / "index.html").is_file()
    # the simulate --signal form gives the same numbers
    sim = _json(runner.invoke(app, ["thruster", "simulate", str(out), "--signal",
                                    f"kind=sampled,file={files['+3V']},time_col=t,command_col=V,"
                                    "speed_col=w,thrust_col=T", "--json"]))
    assert sim["records"] == rep["records"]


@pytest.mark.slow
def test_first_order_with_thrust_is_fitted_jointly_with_a_map(files, tmp_path):
    out = tmp_path / "fo.yaml"
    doc = _json(runner.invoke(app, ["thruster", "fit", str(files["+2V"]), *COLS, "--model",
                                    "first-order", "--out", str(out), "--json"]))
    assert [b.TYPE for b in load_chain(out).blocks] == ["driver", "first_order_motor", "quadratic"]
    assert set(doc["noise"]) == {"speed", "thrust"}


@pytest.mark.slow
def test_select_needs_two_levels(files, tmp_path):
    res = runner.invoke(app, ["thruster", "fit", str(files["+2V"]), str(files["-2V"]), *COLS,
                              "--select", "--out", str(tmp_path / "x.yaml")])
    assert res.exit_code == 2 and "2 command levels" in res.output


def test_select_and_model_are_exclusive(files, tmp_path):
    res = runner.invoke(app, ["thruster", "fit", str(files["+2V"]), *COLS, "--select", "--model",
                              "healey", "--out", str(tmp_path / "x.yaml")])
    assert res.exit_code == 2 and "leave out --model" in res.output


def test_a_volt_driven_model_given_pwm_widths_is_warned_before_it_runs():
    """McLean's tunnel thruster takes its motor voltage: a step 'to 1500' (PWM thinking) pushed
    825 N without a word, and 1e9 'diverged' with advice to shorten dt."""
    from typer.testing import CliRunner

    from uuvid.cli.app import app

    r = CliRunner().invoke(app, ["thruster", "simulate", "auv2-tunnel", "--t-end", "0.2", "--signal",
                                 "kind=step,amplitude=1500"])
    said = " ".join(r.output.split())
    assert r.exit_code == 0 and "above 100 V (e.g. 1500 V)" in said and "PWM pulse widths" in said, said
    r = CliRunner().invoke(app, ["thruster", "simulate", "auv2-tunnel", "--t-end", "0.2", "--signal",
                                 "kind=step,amplitude=1e9"])
    said = " ".join(r.output.split())
    assert "above 100 V (e.g. 1e+09 V)" in said and "PWM" not in said, said
    r = CliRunner().invoke(app, ["thruster", "simulate", "auv2-tunnel", "--t-end", "0.2"])
    assert r.exit_code == 0 and "above 100 V" not in r.output


def test_a_step_metric_the_response_lacks_is_said_not_printed_as_nan_seconds():
    """A T200 step does not overshoot: the table printed 'time_constant_decay  nan  s'."""
    from typer.testing import CliRunner

    from uuvid.cli.app import app

    r = CliRunner().invoke(app, ["thruster", "simulate", "t200", "--t-end", "1"])
    assert r.exit_code == 0, r.output
    row = next(ln for ln in r.output.splitlines() if "time_constant_decay" in ln)
    assert "none in this response" in row and "nan" not in row, row
