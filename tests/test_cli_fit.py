"""``uuvid thruster fit``: every model kind on small synthetic CSVs made from known parameters
(recovered within 3σ where the model is the truth), the written model loads back and predicts,
the report folder is complete, bad data exit 2 naming file/column/row, and the T200 sheets."""

from __future__ import annotations

import csv
import json
import math
import re

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from uuvid.cli.fit_cmd import register
from uuvid.thruster import presets as P
from uuvid.thruster.blocks import BessaDynamics, FirstOrderMotor, Yoerger
from uuvid.thruster.chain import ThrusterChain
from uuvid.thruster.modelfile import load_chain
from uuvid.thruster.physical import PhysicalModel

runner = CliRunner()

TRUTH = PhysicalModel(back_emf_constant=0.02, resistance=0.25, kq_fwd=3e-6, kq_rev=3.3e-6,
                      kt_fwd=3.6e-4, kt_rev=2.9e-4, edge_fwd=1520, edge_rev=1478, full_fwd=1900,
                      full_rev=1100, curvature_fwd=0.15, curvature_rev=0.1, viscous=2e-5)
KGF = 9.80665
RPM = 2 * math.pi / 60


def _app() -> typer.Typer:
    app = typer.Typer()
    thruster = typer.Typer()
    app.add_typer(thruster, name="thruster")
    register(thruster)

    @app.callback()
    def _root():  # keep "thruster" a sub-command even with one command
        pass

    return app


APP = _app()


def _fit(*args):
    return runner.invoke(APP, ["thruster", "fit", *map(str, args)])


def _write_csv(path, columns: dict):
    names = list(columns)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(names)
        for row in zip(*columns.values()):
            w.writerow([repr(float(v)) for v in row])
    return path


def _sheet(path, volts, seed, noise_kgf=0.005):
    """A T200-like sheet (kgf, unsigned rpm, current, voltage) from TRUTH at ``volts``."""
    rng = np.random.default_rng(seed)
    pwm = np.arange(1100.0, 1901.0, 10.0)
    p = TRUTH.predict(pwm, volts)
    return _write_csv(path, {
        "PWM": pwm,
        "Force (kgf)": p.thrust / KGF + rng.normal(0, noise_kgf, pwm.size),
        "RPM": np.abs(p.speed) / RPM + rng.normal(0, 1.0, pwm.size) * (p.speed != 0),
        "Current": p.current + rng.normal(0, 0.03, pwm.size),
        "Voltage": np.full(pwm.size, volts)})


SHEET_COLS = ["--command-col", "PWM", "--thrust-col", "Force (kgf)", "--thrust-unit", "kgf",
              "--speed-col", "RPM", "--speed-unit", "rpm"]


@pytest.fixture(scope="module")
def sheets(tmp_path_factory):
    d = tmp_path_factory.mktemp("sheets")
    return _sheet(d / "s12.csv", 12.0, 1), _sheet(d / "s16.csv", 16.0, 2)


def _json(res) -> dict:
    assert res.exit_code == 0, (res.stdout, res.stderr)
    return json.loads(res.stdout)


def _sigma_ok(doc, name, truth, n=3.0):
    p = doc["parameters"][name]
    assert p["sigma"] is not None and p["sigma"] > 0, p
    assert abs(p["estimate"] - truth) <= n * p["sigma"] + 1e-12 * abs(truth), (name, p, truth)
    assert p["percentile_error"] == pytest.approx(100 * p["sigma"] / abs(p["estimate"]))


# ------------------------------------------------------------------------------ steady models
@pytest.mark.slow
def test_quadratic_recovers_kt_and_writes_report(sheets, tmp_path):
    out, rep = tmp_path / "q.yaml", tmp_path / "rep"
    doc = _json(_fit(sheets[0], *SHEET_COLS, "--model", "quadratic", "--out", out,
                     "--report", rep, "--json"))
    assert doc["model"] == "quadratic" and doc["out"] == str(out)
    # thrust = K_T Ω|Ω| exactly in the truth: K_T within 3σ (speed noise is small)
    _sigma_ok(doc, "K_T_fwd", 3.6e-4)
    _sigma_ok(doc, "K_T_rev", 2.9e-4)
    assert doc["rmse"] < 0.2
    chain = load_chain(out)
    assert chain.input_kind == "speed"
    assert chain.steady_thrust([300.0, -300.0]) == pytest.approx(
        [doc["parameters"]["K_T_fwd"]["estimate"] * 9e4,
         -doc["parameters"]["K_T_rev"]["estimate"] * 9e4])
    for f in ("index.html", "fit.png", "parameters.csv", "fit_report.txt", "summary.json"):
        assert (rep / f).is_file(), f
    html = (rep / "index.html").read_text()
    assert "data:image/png;base64," in html and "K_T_fwd" in html
    assert "K_T_fwd" in (rep / "parameters.csv").read_text()


@pytest.mark.slow
def test_polynomial_selects_a_degree_with_a_reason(sheets, tmp_path):
    out, rep = tmp_path / "p.toml", tmp_path / "rep"
    doc = _json(_fit(sheets[0], *SHEET_COLS, "--model", "polynomial", "--out", out,
                     "--report", rep, "--json"))
    sel = doc["selected_degree"]
    assert set(sel) == {"forward", "reverse"}
    assert all(1 <= d <= 8 for d in sel.values())
    assert "CV" in doc["reason"]["forward"]
    assert [r["degree"] for r in doc["degree_table"]["forward"]] == list(range(1, 9))
    assert "forward.c0" in doc["parameters"] and "reverse.c0" in doc["parameters"]
    assert all(p["sigma"] is not None for p in doc["parameters"].values())
    chain = load_chain(out)  # TOML by suffix
    w = TRUTH.predict(1800.0, 12.0).speed
    assert chain.steady_thrust(w)[0] == pytest.approx(TRUTH.kt_fwd * w * w, rel=0.02)
    assert (rep / "degree_table.png").is_file() and (rep / "degree_table_forward.csv").is_file()
    # a fixed degree is honoured and the rule's own choice is still reported
    doc = _json(_fit(sheets[0], *SHEET_COLS, "--model", "polynomial", "--degree", "2",
                     "--out", out, "--json"))
    assert doc["selected_degree"] == {"forward": 2, "reverse": 2}
    assert "--degree" in doc["reason"]["forward"]


def test_deadzone_on_speed_and_on_pwm(sheets, tmp_path):
    doc = _json(_fit(sheets[0], *SHEET_COLS, "--model", "deadzone", "--out", tmp_path / "d.yaml",
                     "--json"))
    assert doc["map_input"] == "speed"
    assert {"rotor_constant_l", "rotor_constant_r", "delta_l", "delta_r"} <= set(doc["parameters"])
    assert load_chain(tmp_path / "d.yaml").input_kind == "speed"
    # on the command: the file takes raw PWM (a unit-gain ESC subtracts the neutral)
    doc = _json(_fit(sheets[0], "--command-col", "PWM", "--thrust-col", "Force (kgf)",
                     "--thrust-unit", "kgf", "--model", "deadzone", "--out",
                     tmp_path / "dc.yaml", "--json"))
    assert doc["map_input"] == "command"
    chain = load_chain(tmp_path / "dc.yaml")
    assert chain.input_kind == "command" and chain.blocks[0].TYPE == "esc"
    t = chain.steady_thrust([1500.0, 1900.0, 1100.0])
    assert t[0] == 0.0
    assert t[1] == pytest.approx(TRUTH.thrust(1900.0, 12.0), rel=0.1)
    assert t[2] == pytest.approx(TRUTH.thrust(1100.0, 12.0), rel=0.1)


def test_table_round_trip(sheets, tmp_path):
    doc = _json(_fit(sheets[0], *SHEET_COLS, "--model", "table", "--table-points", "25",
                     "--out", tmp_path / "t.yaml", "--json"))
    assert doc["knots"] == 25
    chain = load_chain(tmp_path / "t.yaml")
    assert chain.steady_thrust([1700.0])[0] == pytest.approx(TRUTH.thrust(1700.0, 12.0), rel=0.05)


def test_cv_on_a_voltage_command(tmp_path):
    rng = np.random.default_rng(3)
    v = np.linspace(-12, 12, 49)
    thrust = np.where(v >= 0, 1.02, 1.09) * v * np.abs(v) + rng.normal(0, 0.5, v.size)
    f = _write_csv(tmp_path / "cv.csv", {"V": v, "T": thrust})
    doc = _json(_fit(f, "--command-col", "V", "--command-unit", "volts", "--thrust-col", "T",
                     "--model", "cv", "--out", tmp_path / "cv.yaml", "--json"))
    _sigma_ok(doc, "c_V_fwd", 1.02)
    _sigma_ok(doc, "c_V_rev", 1.09)
    assert load_chain(tmp_path / "cv.yaml").input_kind == "voltage"
    # a PWM command is refused with a hint
    res = _fit(f, "--command-col", "V", "--thrust-col", "T", "--neutral", "0", "--model", "cv",
               "--out", tmp_path / "x.yaml")
    assert res.exit_code == 2 and "--command-unit volts" in res.stderr


@pytest.mark.slow
def test_physical_two_sheets_chain_at_supply_voltage(sheets, tmp_path):
    out, rep = tmp_path / "phys.yaml", tmp_path / "rep"
    doc = _json(_fit(*sheets, *SHEET_COLS, "--current-col", "Current", "--voltage-col", "Voltage",
                     "--model", "physical", "--supply-voltage", "14", "--out", out, "--report",
                     rep, "--json"))
    assert doc["supply_voltage_V"] == 14.0
    assert doc["parameters"]["K_T_fwd"]["estimate"] == pytest.approx(3.6e-4, rel=0.02)
    assert all(p["sigma"] is not None for p in doc["parameters"].values())
    assert doc["rmse"] < 0.2
    chain = load_chain(out)
    pwm = np.array([1150.0, 1300.0, 1600.0, 1850.0])
    assert chain.steady_thrust(pwm) == pytest.approx(TRUTH.thrust(pwm, 14.0), rel=0.02)
    assert (rep / "fit.png").is_file()
    assert not any("outside the data" in w for w in doc["warnings"])


@pytest.mark.slow
def test_physical_chain_outside_the_sheets_voltages_is_warned(sheets, tmp_path):
    doc = _json(_fit(*sheets, *SHEET_COLS, "--current-col", "Current", "--voltage-col", "Voltage",
                     "--model", "physical", "--supply-voltage", "48", "--out", tmp_path / "p.yaml",
                     "--json"))
    assert any("48 V is outside the data's 12–16 V" in w for w in doc["warnings"])
    doc = _json(_fit(*sheets, *SHEET_COLS, "--current-col", "Current", "--voltage-col", "Voltage",
                     "--model", "physical", "--out", tmp_path / "q.yaml", "--json"))
    assert any("first file's supply voltage (the default" in n for n in doc["notes"])


# ------------------------------------------------------------------------------ dynamic models
def _step_csv(path, chain, level, t_end, dt, channel, noise, seed, t0=0.05):
    rng = np.random.default_rng(seed)
    t = np.arange(round(t_end / dt) + 1) * dt
    u = np.where(t >= t0, level, 0.0)
    y = chain.simulate(u, t[-1], dt=dt)[channel] + rng.normal(0, noise, t.size)
    return _write_csv(path, {"time": t, "u": u, "y": y})


DYN_COLS = ["--time-col", "time", "--command-col", "u", "--command-unit", "volts"]


@pytest.mark.slow
def test_first_order_from_a_voltage_step(tmp_path):
    truth = ThrusterChain((FirstOrderMotor(gain=131.3016, time_constant=0.01021),),
                          input_kind="voltage")
    f = _step_csv(tmp_path / "fo.csv", truth, 6.0, 0.1, 1e-3, "prop_speed", 5.0, 4, t0=0.02)
    out, rep = tmp_path / "fo.yaml", tmp_path / "rep"
    doc = _json(_fit(f, *DYN_COLS, "--speed-col", "y", "--model", "first-order", "--out", out,
                     "--report", rep, "--json"))
    _sigma_ok(doc, "blocks[0].gain", 131.3016)
    _sigma_ok(doc, "blocks[0].time_constant", 0.01021)
    assert doc["rmse_unit"] == "rad/s" and doc["rmse"] == pytest.approx(5.0, rel=0.2)
    chain = load_chain(out)
    assert chain.blocks[0].TYPE == "first_order_motor"
    assert (rep / "fit.png").is_file()


@pytest.mark.slow
def test_yoerger_on_pwm_steps_gets_a_neutral_shifting_esc(tmp_path):
    truth = ThrusterChain((Yoerger(alpha=0.02, beta=5.0),), input_kind="command")
    files = []
    for k, lvl in enumerate((100.0, -60.0)):  # PWM offsets from 1500 µs
        rng = np.random.default_rng(5 + k)
        t = np.arange(601) * 5e-3
        u = np.where(t >= 0.1, lvl, 0.0)
        y = truth.simulate(u, t[-1], dt=5e-3)["prop_speed"] + rng.normal(0, 0.5, t.size)
        files.append(_write_csv(tmp_path / f"y{k}.csv", {"time": t, "pwm": 1500 + u, "w": y}))
    out = tmp_path / "y.yaml"
    doc = _json(_fit(*files, "--time-col", "time", "--command-col", "pwm", "--speed-col", "w",
                     "--model", "yoerger", "--out", out, "--json"))
    _sigma_ok(doc, "blocks[0].alpha", 0.02)
    _sigma_ok(doc, "blocks[0].beta", 5.0)
    assert len(doc["runs"]) == 2
    chain = load_chain(out)
    assert [b.TYPE for b in chain.blocks] == ["esc", "yoerger"]
    # what was done is a note, not a warning
    assert any(n.startswith("block 0 is a unit-gain ESC") for n in doc["notes"])
    assert not any("block 0" in w for w in doc["warnings"])
    assert not any(w.startswith("only ") for w in doc["warnings"])  # both directions recorded
    err = " ".join(runner.invoke(APP, ["thruster", "fit", *map(str, files), "--time-col", "time",
                                       "--command-col", "pwm", "--speed-col", "w", "--model",
                                       "yoerger", "--out", str(out)]).stderr.split())
    assert "note: block 0 is a unit-gain ESC" in err and "warning: block 0" not in err
    w = chain.steady_thrust([1600.0])[0]  # x² = βu/α
    assert w == pytest.approx(math.sqrt(5.0 * 100 / 0.02), rel=0.01)


def test_bessa_reports_the_identifiable_combinations(tmp_path):
    truth = ThrusterChain((BessaDynamics(jmsp=0.002, kv1=0.001, kv2=1e-5, kt=1.0, rm=1.0),),
                          input_kind="command")
    f = _step_csv(tmp_path / "b.csv", truth, 12.0, 2.0, 5e-3, "prop_speed", 1.0, 6, t0=0.1)
    doc = _json(_fit(f, *DYN_COLS, "--speed-col", "y", "--model", "bessa", "--out",
                     tmp_path / "b.yaml", "--json"))
    ident = doc["identifiable"]
    assert ident["Kv2/Jmsp"]["estimate"] == pytest.approx(1e-5 / 0.002, rel=0.05)
    assert all(p["sigma"] is not None for p in doc["parameters"].values())
    load_chain(tmp_path / "b.yaml")


@pytest.mark.slow
def test_mclean_tunnel_thruster_from_two_rig_steps(tmp_path):
    rig = P.auv2_rig_chain()
    files = [_step_csv(tmp_path / f"m{v:g}.csv", rig, v, 1.0, 2e-3, "measured_thrust", 0.2,
                       7 + k) for k, v in enumerate((24.0, 16.0))]
    out = tmp_path / "m.yaml"
    doc = _json(_fit(*files, *DYN_COLS, "--thrust-col", "y", "--model", "mclean", "--out", out,
                     "--json"))
    _sigma_ok(doc, "blocks[0].energy_correction", 3.0)
    _sigma_ok(doc, "blocks[0].momentum_correction", 0.185)
    _sigma_ok(doc, "blocks[0].added_mass_coefficient", 0.25)
    chain = load_chain(out)
    assert [b.TYPE for b in chain.blocks] == ["tunnel_thruster", "load_cell"]


# ------------------------------------------------------------------------------ bad input
def test_bad_cell_names_file_column_and_row(sheets, tmp_path):
    lines = sheets[0].read_text().splitlines()
    cells = lines[3].split(",")
    cells[1] = "oops"
    lines[3] = ",".join(cells)
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(lines) + "\n")
    res = _fit(bad, *SHEET_COLS, "--model", "quadratic", "--out", tmp_path / "x.yaml")
    assert res.exit_code == 2
    msg = " ".join(res.stderr.split())
    assert "bad.csv" in msg and "'Force (kgf)'" in msg and "data row 3" in msg and "'oops'" in msg
    assert not (tmp_path / "x.yaml").exists()


@pytest.mark.parametrize("args, needle", [
    (["--model", "quadratic", "--command-col", "PWM", "--thrust-col", "Thrust"], "no column 'Thrust'"),
    (["--model", "quadratic", "--command-col", "PWM"],
     "needs a thrust column (--thrust-col / thrust_col=) and a propeller speed column"),
    (["--model", "first-order", *SHEET_COLS], "needs a time column (--time-col"),
    (["--model", "table", *SHEET_COLS, "--degree", "3"], "--degree applies"),
])
def test_missing_columns_and_channels_exit_2(sheets, tmp_path, args, needle):
    res = _fit(sheets[0], *args, "--out", tmp_path / "x.yaml")
    assert res.exit_code == 2, res.stdout
    assert needle in " ".join(res.stderr.split())


def test_t200_sheet_without_its_format_is_told_to_use_it(tmp_path):
    f = _write_csv(tmp_path / "T200.csv", {"PWM (us)": [1100, 1500, 1900], "RPM": [3400, 0, 3500],
                                           "Force (Kg f)": [-4.0, 0.0, 5.0]})
    res = _fit(f, "--model", "quadratic", "--out", tmp_path / "x.yaml")
    assert res.exit_code == 2 and "--format t200" in " ".join(res.stderr.split())
    res = _fit(f, "--model", "quadratic", "--command-col", "nope", "--out", tmp_path / "x.yaml")
    assert "--format t200" in " ".join(res.stderr.split())
    g = _write_csv(tmp_path / "other.csv", {"u": [1, 2, 3], "RPM": [1, 2, 3]})
    res = _fit(g, "--model", "quadratic", "--out", tmp_path / "x.yaml")
    assert res.exit_code == 2 and "t200" not in res.stderr


@pytest.mark.slow
def test_warnings_are_said_once(sheets, tmp_path):
    """Without --json the report on stdout carries the warnings; stderr does not repeat them."""
    args = [*sheets, *SHEET_COLS, "--voltage-col", "Voltage", "--model", "physical",
            "--out-model", tmp_path / "p.yaml"]
    doc = _json(_fit(*args, "--json"))
    assert doc["warnings"]  # no current column: K_e and R cannot be separated
    res = _fit(*args)
    assert res.exit_code == 0
    both = " ".join((res.stdout + res.stderr).split())
    for w in doc["warnings"]:
        assert both.count(" ".join(w.split())) == 1, w


@pytest.mark.parametrize("model", ["quadratic", "polynomial", "table", "deadzone", "physical"])
def test_thrust_sign_reversed_exits_2_naming_the_fix(sheets, tmp_path, model):
    rows = list(csv.reader(open(sheets[0])))
    k = rows[0].index("Force (kgf)")
    path = tmp_path / "reversed.csv"
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(rows[0])
        for r in rows[1:]:
            r[k] = repr(-float(r[k]))
            w.writerow(r)
    out = tmp_path / "m.yaml"
    res = _fit(path, *SHEET_COLS, "--voltage-col", "Voltage", "--current-col", "Current",
               "--model", model, "--out-model", out)
    assert res.exit_code == 2, res.output
    assert "reversed.csv: thrust has the opposite sign of the command" in res.output
    assert "negate the thrust column" in res.output and not out.exists()


@pytest.mark.slow
@pytest.mark.parametrize("model, extra", [("table", []), ("deadzone", ["--map-input", "command"])])
def test_command_maps_refuse_sheets_at_different_voltages(sheets, tmp_path, model, extra):
    out = tmp_path / "m.yaml"
    res = _fit(*sheets, *SHEET_COLS, "--voltage-col", "Voltage", "--model", model, *extra,
               "--out-model", out)
    assert res.exit_code == 2, res.output
    assert "s12.csv at 12 V, s16.csv at 16 V" in res.output and "--model physical" in res.output
    assert not out.exists()
    # one voltage (two runs at 12 V) is fine
    assert _fit(sheets[0], sheets[0], *SHEET_COLS, "--voltage-col", "Voltage", "--model", model,
                *extra, "--out-model", out).exit_code == 0


@pytest.mark.realdata
def test_table_on_the_12_and_16_volt_t200_sheets_is_refused(shared_data, tmp_path):
    d = shared_data / "t200-bluerobotics-2019"
    res = _fit(d / "T200_12V.csv", d / "T200_16V.csv", "--format", "t200", "--model", "table",
               "--out-model", tmp_path / "t.yaml")
    assert res.exit_code == 2 and "T200_12V.csv at 12 V, T200_16V.csv at 16 V" in res.output


def test_missing_file_exit_2(tmp_path):
    res = _fit(tmp_path / "nope.csv", "--model", "table", "--out", tmp_path / "x.yaml")
    assert res.exit_code == 2 and "no such bench file" in " ".join(res.stderr.split())


# ------------------------------------------------------------------------------ real data
@pytest.mark.slow
@pytest.mark.realdata
def test_t200_physical_on_both_sheets(shared_data, tmp_path):
    d = shared_data / "t200-bluerobotics-2019"
    out, rep = tmp_path / "t200.yaml", tmp_path / "rep"
    doc = _json(_fit(d / "T200_12V.csv", d / "T200_16V.csv", "--format", "t200", "--model",
                     "physical", "--out", out, "--report", rep, "--json"))
    assert doc["supply_voltage_V"] == 12.0
    per = doc["per_sheet"]
    assert all(s["thrust_rmse_pct"] < 1.5 for s in per.values())
    chain = load_chain(out)
    t = chain.steady_thrust([1100.0, 1900.0])
    assert t[1] == pytest.approx(3.71 * KGF, rel=0.03)  # the sheet's 3.71 kgf forward at 12 V
    assert t[0] == pytest.approx(-2.92 * KGF, rel=0.03)
    assert (rep / "index.html").is_file()


@pytest.mark.slow
def test_fit_checks_the_file_then_reports_every_missing_option(tmp_path):
    from typer.testing import CliRunner

    from uuvid.cli.app import app

    r = CliRunner()
    res = r.invoke(app, ["thruster", "fit", str(tmp_path / "nope.csv")])
    assert res.exit_code == 2 and "no such bench file" in res.output
    f = tmp_path / "b.csv"
    f.write_text("command,thrust\n1100,-30\n1300,-10\n1500,0\n1700,12\n1900,40\n")
    res = r.invoke(app, ["thruster", "fit", str(f)])
    assert res.exit_code == 2 and "--out-model" in res.output and "--model" in res.output


def test_fit_without_speed_names_the_column_and_us_is_pwm(tmp_path):
    from typer.testing import CliRunner

    from uuvid.cli.app import app
    from uuvid.io.bench import read_bench

    f = tmp_path / "b.csv"
    f.write_text("command,thrust\n1100,-30\n1300,-10\n1500,0\n1700,12\n1900,40\n")
    for m in ("quadratic", "polynomial"):
        res = CliRunner().invoke(app, ["thruster", "fit", str(f), "--thrust-col", "thrust",
                                       "--model", m, "--out-model", str(tmp_path / "m.yaml")])
        assert res.exit_code == 2 and "--speed-col" in res.output and "fit_" not in res.output
    assert read_bench(f, command_col="command", thrust_col="thrust",
                      command_unit="us").command_unit == "pwm_us"


def test_table_without_repeats_says_sigma_unknown_not_insignificant(tmp_path):
    from uuvid.identify.thruster.steady import fit_table
    from uuvid.io.bench import read_bench

    f = tmp_path / "b.csv"
    f.write_text("command,thrust\n1100,-30\n1300,-10\n1500,0\n1700,12\n1900,40\n1900,41\n")
    sf = fit_table(read_bench(f, command_col="command", thrust_col="thrust"))
    text = sf.fits["all"].summary()
    assert text.count("σ unknown") == 4 and text.count("not significant") == 0
    assert any("σ unknown (no repeats) for 4 of 5" in n for n in sf.info["notes"])


def test_a_report_that_cannot_be_written_leaves_the_old_model_file(sheets, tmp_path):
    """Every destination is checked before any is written: a --report folder under a file made
    the command fail *after* it had replaced the model file."""
    out = tmp_path / "keep.yaml"
    out.write_text("old model\n")
    (tmp_path / "afile").write_text("x")
    res = runner.invoke(_app(), ["thruster", "fit", str(sheets[0]), *map(str, SHEET_COLS),
                                 "--model", "quadratic", "--out-model", str(out),
                                 "--report", str(tmp_path / "afile" / "rep")])
    assert res.exit_code == 2, res.output
    assert "nothing was written" in " ".join(res.output.split())
    assert out.read_text() == "old model\n"


def test_a_fit_with_no_more_rows_than_parameters_is_refused(tmp_path):
    """One forward row for the quadratic map's forward coefficient: the fit passed through it
    (RMSE 0, σ undefined) and a model was written.  Now an error saying how many are needed."""
    p = tmp_path / "one.csv"
    _write_csv(p, {"command": [1650.0], "speed": [120.0], "thrust": [5.1]})
    out = tmp_path / "x.yaml"
    res = _fit(p, "--speed-col", "speed", "--thrust-col", "thrust", "--model", "quadratic",
               "--out-model", out)
    assert res.exit_code == 2 and not out.exists(), res.output
    assert "1 usable sample(s) for 1 free parameter(s)" in " ".join(res.output.split())
    _write_csv(p, {"command": [1650.0, 1700.0], "speed": [120.0, 150.0], "thrust": [5.1, 8.0]})
    assert _fit(p, "--speed-col", "speed", "--thrust-col", "thrust", "--model", "quadratic",
                "--out-model", out).exit_code == 0


def test_an_all_zero_thrust_column_and_a_mostly_censored_sheet_are_said(tmp_path):
    p = tmp_path / "zero.csv"
    _write_csv(p, {"command": [1600.0, 1700.0, 1800.0, 1300.0], "speed": [90.0, 180, 270, -180],
                   "thrust": [0.0, 0.0, 0.0, 0.0]})
    res = _fit(p, "--speed-col", "speed", "--thrust-col", "thrust", "--model", "quadratic",
               "--out-model", tmp_path / "x.yaml")
    assert res.exit_code == 2 and "thrust is 0 in every row" in " ".join(res.output.split())
    # a sheet's rpm read as rad/s: most readings fall below the censoring speed
    from uuvid.identify.plausibility import bench_unit_warnings
    from uuvid.io.bench import BenchData

    pwm = np.arange(1100.0, 1901.0, 10.0)
    w = (pwm - 1500.0) * 0.9 * RPM  # rad/s numbers that were rpm
    cens = np.abs(w) < 300 * RPM
    sheet = BenchData(command=pwm, thrust=1e-4 * w * np.abs(w), speed=w, censored=cens,
                      censor_speed=300 * RPM, source="t200.csv")
    said = [m for m in bench_unit_warnings(sheet) if "are censored" in m]
    assert len(said) == 1 and "another unit" in said[0], said
    ok = BenchData(command=pwm, thrust=1e-4 * w * np.abs(w), speed=w / RPM,
                   censored=np.abs(w / RPM) < 300 * RPM, censor_speed=300 * RPM)
    assert not [m for m in bench_unit_warnings(ok) if "are censored" in m]



@pytest.mark.slow
def test_a_dynamic_fit_on_forward_runs_only_says_its_reverse_is_not_fitted(tmp_path):
    """The example's forward voltage runs alone: the model file holds reverse parameters (a copy
    of the forward thrust coefficient, a zero dead band) that nothing fitted — said as a
    warning (the steady fits already said "no reverse samples")."""
    from uuvid.examples import write_example

    runs = [p for p in write_example("thruster-runs", tmp_path) if p.name.startswith("run_+")]
    assert runs
    doc = _json(_fit(*runs, "--time-col", "t", "--command-col", "V", "--command-unit", "volts",
                     "--speed-col", "w", "--thrust-col", "T", "--model", "first-order",
                     "--out-model", tmp_path / "x.yaml", "--json"))
    said = [w for w in doc["warnings"] if w.startswith("only forward runs")]
    assert len(said) == 1 and "not fitted" in said[0], doc["warnings"]


@pytest.mark.slow
def test_a_time_column_in_ms_is_said_for_a_dynamic_fit(tmp_path):
    """The example's runs with their time in ms (read as s): the fit made a 60 s thruster time
    constant from 5 s samples without a word."""
    import pandas as pd

    from uuvid.examples import write_example

    runs = sorted(p for p in write_example("thruster-runs", tmp_path) if p.name.startswith("run_"))
    args = ["--time-col", "t", "--command-col", "V", "--command-unit", "volts", "--speed-col", "w",
            "--thrust-col", "T", "--model", "first-order", "--json"]
    doc = _json(_fit(*runs[:2], *args, "--out-model", tmp_path / "ok.yaml"))
    assert not any("is the time column in ms" in w for w in doc["warnings"])
    ms = []
    for p in runs[:2]:
        df = pd.read_csv(p)
        df["t"] = df["t"] * 1000.0
        ms.append(tmp_path / f"ms_{p.name}")
        df.to_csv(ms[-1], index=False)
    res = _fit(*ms, *args, "--out-model", tmp_path / "ms.yaml")
    assert "is the time column in ms" in " ".join(res.output.split())


def _forward_only(path, tmp_path):
    import pandas as pd

    df = pd.read_csv(path)
    p = tmp_path / "fwd.csv"
    df[df["PWM"] >= 1500].to_csv(p, index=False)
    return p


@pytest.mark.parametrize("model", ["quadratic", "polynomial"])
def test_a_one_direction_fit_warns_that_the_file_mirrors_it(sheets, tmp_path, model):
    """A forward-only sheet wrote k_neg = k_pos (reverse thrust 27 % above a real T200's) with
    only a note in the report text; it is a warning on stderr and in the JSON, saying the file
    mirrors the forward map."""
    res = _fit(_forward_only(sheets[0], tmp_path), *SHEET_COLS, "--model", model,
               "--out", tmp_path / "m.yaml")
    assert res.exit_code == 0, res.output
    assert re.search(r"warning: no reverse samples: the reverse \w+ is not identified — the model "
                     r"file copies the forward one, so reverse thrust mirrors forward", res.stderr)


def test_a_table_of_one_direction_or_too_few_knots_is_warned(sheets, tmp_path):
    """A forward-only table gave 0 N for every reverse command; a 2-knot table gave 5.8 N at
    neutral (the sheet's dead band).  Both are warnings; a table of all the data is silent."""
    doc = _json(_fit(_forward_only(sheets[0], tmp_path), *SHEET_COLS, "--model", "table",
                     "--out", tmp_path / "f.yaml", "--json"))
    assert any(re.search(r"the table's commands span 1500…1900 µs with thrust of one sign only: the "
                         r"reverse thrust is not identified.*every reverse command gives -?0(\.\d+)? N", w)
               for w in doc["warnings"]), doc["warnings"]
    doc = _json(_fit(sheets[1], *SHEET_COLS, "--model", "table", "--table-points", "2",
                     "--out", tmp_path / "t2.yaml", "--json"))
    assert any(re.search(r"the table's 2 knots miss the data by up to .* N \(at \d+ µs\), \d+ % of "
                         r"the largest thrust: give more --table-points", w)
               for w in doc["warnings"]), doc["warnings"]
    doc = _json(_fit(sheets[1], *SHEET_COLS, "--model", "table", "--out", tmp_path / "t.yaml",
                     "--json"))
    assert not [w for w in doc["warnings"] if "the table's" in w]


def test_a_polynomial_of_the_wrong_sign_below_the_data_is_warned():
    """Readings under 300 rpm are zeroed in the T200 sheets, and the cross-validated cubic pushed
    the wrong way from 0 to 15 rad/s (−0.13 N): said with where; a map that keeps its sign there
    is silent."""
    from uuvid.identify.thruster.steady import _below_data_sign

    (w,) = _below_data_sign((1e-4, 3e-3, -0.02, -0.1), 36.0, 50.0, "forward")
    assert re.match(r"wrong-sign thrust below the data: the forward polynomial gives -0\.13 N at "
                    r"2\.86 rad/s \(negative from 0 to 8 rad/s, below the slowest measured 36 "
                    r"rad/s\)", w), w
    assert _below_data_sign((3.6e-4, 0.0, 0.0), 36.0, 50.0, "forward") == []  # K_T Ω²
    assert _below_data_sign((3.6e-4, 1e-3, 0.0), 36.0, 50.0, "reverse") == []


@pytest.mark.realdata
def test_the_t200_sheet_polynomial_warns_of_its_sign_below_the_data(shared_data, tmp_path):
    doc = _json(_fit(shared_data / "t200-bluerobotics-2019" / "T200_12V.csv", "--format", "t200",
                     "--model", "polynomial", "--out", tmp_path / "p.yaml", "--json"))
    assert any(w.startswith("wrong-sign thrust below the data: the forward polynomial")
               for w in doc["warnings"]), doc["warnings"]


def test_too_few_levels_to_choose_a_degree_say_where_and_what_to_do(tmp_path):
    """Three rows (one level each way): the degree rule said 'degree 1 polynomial with 5-fold CV
    (training samples per fold): 0 usable sample(s) for 3 parameter(s)' — no file, no direction,
    and a degree-1 polynomial has 2 parameters."""
    f = _write_csv(tmp_path / "three.csv", {"pwm": [1180, 1500, 1820], "thrust": [-21.0, 0.0, 26.6],
                                           "rpm": [-2575.5, 0.0, 2584.6]})
    res = _fit(f, "--command-col", "pwm", "--thrust-col", "thrust", "--speed-col", "rpm",
               "--speed-unit", "rpm", "--model", "polynomial", "--out", tmp_path / "o.yaml")
    said = " ".join(res.output.split())
    assert res.exit_code != 0 and "three.csv: forward (1 sample(s) at non-zero speed)" in said, said
    assert "degree 1 polynomial (2 parameters)" in said and "--degree" in said, said
    assert not (tmp_path / "o.yaml").exists()
