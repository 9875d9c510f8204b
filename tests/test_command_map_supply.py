"""A map fitted on the PWM command (deadzone, table, dynamics behind the unit-gain ``command −
neutral`` stage) carries no voltage law: ``--supply-voltage`` must not rescale it.  Its first
block was an ESC at a placeholder 'supply' of half the command span (400 V), so predict and
export at the bench's real 16 V scaled the thrust down 625×.  A fit also records the supply
voltages of its data (``fit_supply_voltages``), and predict/export say whether a supply asked of
the model lies inside them."""

import json
import re

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.thruster.blocks import ESC, FirstOrderMotor, QuadraticMap
from uuvid.thruster.chain import ThrusterChain
from uuvid.thruster.modelfile import load_chain, save_chain
from uuvid.thruster.resolve import export_supply

runner = CliRunner()


def _bench(tmp_path, volts=16.0):
    pwm = np.arange(1100, 1901, 20.0)
    x = pwm - 1500
    thrust = np.where(x > 0, 3.5e-4, 2.8e-4) * x * np.abs(x)
    f = tmp_path / "bench.csv"
    f.write_text("pwm,thrust\n" + "".join(f"{p:g},{t:.5f}\n" for p, t in zip(pwm, thrust)))
    return f


def _predict(model, *extra):
    res = runner.invoke(app, ["thruster", "predict", str(model), "--pwm", "1100,1900", "--json",
                              *extra])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout), re.sub(r"\s+", " ", res.output)


def test_a_command_map_gives_the_same_thrust_at_any_supply_voltage(tmp_path):
    model = tmp_path / "dz.yaml"
    res = runner.invoke(app, ["thruster", "fit", str(_bench(tmp_path)), "--command-col", "pwm",
                              "--thrust-col", "thrust", "--model", "deadzone", "--map-input",
                              "command", "--supply-voltage", "16", "--out-model", str(model)])
    assert res.exit_code == 0, res.output
    doc = yaml.safe_load(model.read_text())
    assert doc["blocks"][0]["follows_supply"] is False
    assert doc["fit_supply_voltages"] == [16.0]  # the bench voltage, recorded
    own, _ = _predict(model)
    at16, out16 = _predict(model, "--supply-voltage", "16")
    at12, out12 = _predict(model, "--supply-voltage", "12")
    assert own["thrust_N"][1] == pytest.approx(56.0, rel=0.02)
    assert at16["thrust_N"] == own["thrust_N"] == at12["thrust_N"]
    assert not at16["warnings"]
    assert "does not depend on the supply voltage" in at16["supply_voltage_source"]
    assert any("measured at 16 V" in w and "not rescaled to 12 V" in w for w in at12["warnings"])
    tables = []
    for v in ([], ["--supply-voltage", "16"], ["--supply-voltage", "12"]):
        r = runner.invoke(app, ["thruster", "export", str(model), "--to", "uuv-simulator", *v])
        assert r.exit_code == 0, r.output
        tables.append(re.findall(r"<outputValues>(.*?)</outputValues>", r.stdout, re.S))
    assert tables[0] and tables[0] == tables[1] == tables[2]


def test_a_command_map_file_written_before_the_flag_is_not_rescaled(tmp_path):
    esc = dict(type="esc", a_fwd=1.0, b_fwd=-1500.0, a_rev=1.0, b_rev=-1500.0, neutral=1500.0,
               deadzone_low=1500.0, deadzone_high=1500.0, saturation_low=1100.0,
               saturation_high=1900.0, supply_voltage=400.0, command_unit="pwm_us")
    dz = dict(type="deadzone", rotor_constant_l=2.8e-4, rotor_constant_r=3.6e-4, delta_l=0.0,
              delta_r=0.0)
    f = tmp_path / "old.yaml"
    f.write_text(yaml.safe_dump({"name": "old", "input": "command", "blocks": [esc, dz]}))
    own, _ = _predict(f)
    at16, _ = _predict(f, "--supply-voltage", "16")
    assert at16["thrust_N"] == own["thrust_N"]
    assert own["thrust_N"][1] == pytest.approx(3.6e-4 * 400**2)
    assert any("does not record" in w for w in at16["warnings"])


def test_a_voltage_esc_still_follows_the_supply(tmp_path):
    esc = ESC.from_range(1500, 50, 1100, 1900, 16.0)
    chain = ThrusterChain((esc,), name="v")
    f = save_chain(chain, tmp_path / "v.yaml")
    assert "follows_supply" not in f.read_text()
    same, _ = export_supply(str(f), load_chain(f), 8.0)
    assert same.blocks[0].a_fwd == pytest.approx(esc.a_fwd / 2)


def _physical_like(tmp_path, volts):
    esc = ESC.from_range(1500, 50, 1100, 1900, 12.0, command_unit="pwm_us")
    motor = FirstOrderMotor(gain=20.0, time_constant=0.05)
    chain = ThrusterChain((esc, motor, QuadraticMap(k_pos=1e-5)), name="phys",
                          fit_supply_voltages=volts)
    return save_chain(chain, tmp_path / "phys.yaml")


def test_fit_voltages_are_kept_and_a_supply_inside_them_is_not_warned_about(tmp_path):
    f = _physical_like(tmp_path, (12.0, 16.0))
    assert load_chain(f).fit_supply_voltages == (12.0, 16.0)
    at16, out = _predict(f, "--supply-voltage", "16")
    assert not at16["warnings"], at16["warnings"]
    assert "inside the 12–16 V the model was fitted at" in at16["supply_voltage_source"]
    at24, _ = _predict(f, "--supply-voltage", "24")
    assert any("outside the data's 12–16 V" in w for w in at24["warnings"])
    _, lines = export_supply(str(f), load_chain(f), 16.0)
    assert "inside the 12–16 V" in lines[0] and not any(s.startswith("warning") for s in lines)


def test_a_file_without_fit_voltages_still_loads_and_warns_as_before(tmp_path):
    f = _physical_like(tmp_path, None)
    assert "fit_supply_voltages" not in f.read_text()
    at16, _ = _predict(f, "--supply-voltage", "16")
    assert any("does not record the voltages it was fitted at" in w for w in at16["warnings"])


def _bessa_csv(tmp_path, thrust_of_x, name):
    pwm = np.arange(1100, 1901, 8.0)
    x = pwm - 1500
    f = tmp_path / name
    f.write_text("pwm,thrust\n" + "".join(f"{p:g},{t:.6f}\n" for p, t in zip(pwm, thrust_of_x(x))))
    return f


def _fit_deadzone_json(f):
    res = runner.invoke(app, ["thruster", "fit", str(f), "--command-col", "pwm", "--thrust-col",
                              "thrust", "--model", "deadzone", "--map-input", "command", "--json",
                              "--out-model", str(f.with_suffix(".yaml"))])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def test_the_deadzone_fit_recovers_a_known_dead_band_and_says_no_lack_of_fit(tmp_path):
    def bessa(x):
        b = x * np.abs(x)
        return np.where(b > 900, 3.5e-4 * (b - 900), np.where(b < -1600, 2.8e-4 * (b + 1600), 0.0))

    doc = _fit_deadzone_json(_bessa_csv(tmp_path, bessa, "bessa.csv"))
    p = {k.split(".")[-1]: v["estimate"] for k, v in doc["parameters"].items()}
    assert p["delta_r"] == pytest.approx(900, rel=0.05)
    assert p["delta_l"] == pytest.approx(-1600, rel=0.05)
    assert not any("lack of fit" in w for w in doc["warnings"])


def test_the_deadzone_fit_warns_when_the_family_misses_the_ends_and_the_dead_band(tmp_path):
    # a T200-like curve: thrust nearly linear in the command past a measured ±28 µs dead band
    def t200_like(x):
        return np.where(x > 28, 0.14 * (x - 28), np.where(x < -28, 0.11 * (x + 28), 0.0))

    doc = _fit_deadzone_json(_bessa_csv(tmp_path, t200_like, "t200_like.csv"))
    (w,) = [w for w in doc["warnings"] if w.startswith("lack of fit")]
    assert "at command 1900 µs" in w and "% in magnitude" in w
    assert "zero-thrust band (command 1476…1524 µs)" in w
    assert "--model table" in w


def test_a_voltage_esc_shaped_like_a_command_stage_keeps_its_supply_law_through_a_save(tmp_path):
    """A linear 1100–1900 µs ESC on a 400 V bus has the shape of the unit-gain command stage
    (gain 1, −neutral, no dead band, supply half the span): saved without ``follows_supply`` it
    was read back as a command stage and stopped following the supply."""
    esc = ESC.from_range(1500, 0, 1100, 1900, 400.0)
    assert esc.follows_supply
    f = save_chain(ThrusterChain((esc,), name="hv"), tmp_path / "hv.yaml")
    back = load_chain(f).blocks[0]
    assert back.follows_supply
    assert back.with_supply(300.0).a_fwd == pytest.approx(esc.a_fwd * 0.75)


def test_a_battery_run_of_a_command_map_is_refused_not_scaled_by_its_placeholder_supply():
    """A battery run rescaled the thrusters' first block by V / its supply: a map fitted on the
    command (unit-gain stage, 'supply' 400) flew at 16/400 of its command — thrust limits of
    0.009 N instead of 5.6 N.  A map of the command has no voltage law to follow the pack."""
    from uuvid.identify.thruster.workflow import offset_esc
    from uuvid.simulate.vehicle_sim import ThrusterBank, battery_tables
    from uuvid.thruster.blocks import FirstOrderMotor
    from uuvid.vehicle.definition import load_vehicle

    ch = ThrusterChain((offset_esc(1500, 1100, 1900, "pwm_us"), FirstOrderMotor(0.1, 0.05),
                        QuadraticMap(0.0035, 0.0027)), "command", "fo-map")
    v = load_vehicle("bluerov2-heavy")
    bank = ThrusterBank.from_chains([ch] * len(v.layout))
    with pytest.raises(ValueError, match="fo-map is a map fitted on the command"):
        battery_tables(bank, v.battery, 1.0)


def test_exact_data_without_a_dead_band_is_no_lack_of_fit():
    """T = c·x|x| exactly (δ = 0), on a 0.01 N load cell: the few samples next to neutral read 0
    N and were taken for a zero-thrust band the fit 'misses' — a 'family is wrong' warning on a
    fit with an RMSE of 0.003 N.  A band is said only where the fitted thrust is well above it."""
    from uuvid.identify.thruster.steady import _deadzone_misses
    from uuvid.thruster.blocks import DeadZoneMap

    x = np.arange(-400.0, 401.0, 4.0)
    t = np.round(np.where(x >= 0, 3.6e-4, 2.8e-4) * x * np.abs(x), 2)
    fit = DeadZoneMap(rotor_constant_l=2.8e-4, rotor_constant_r=3.6e-4, delta_l=0.0, delta_r=0.0)
    assert _deadzone_misses(x, t, fit, 1500.0, "command", "pwm_us") is None
    band = np.where(np.abs(x) <= 28, 0.0, t)  # a measured dead band of ±28 µs the fit lacks
    assert "zero-thrust band" in _deadzone_misses(x, band, fit, 1500.0, "command", "pwm_us")


def test_a_dive_thrust_model_of_a_command_map_says_so_not_no_esc(tmp_path):
    """A command map used as the dive's thrust model was described as 'the chain has no ESC
    block', against its file: it says it is a map of the command, not rescaled to the log's
    voltage."""
    from uuvid.identify.thruster.workflow import offset_esc
    from uuvid.io.ardusub.thrust import load_thrust_model

    ch = ThrusterChain((offset_esc(1500, 1100, 1900, "pwm_us"), QuadraticMap(3.6e-4, 2.8e-4)),
                       "command", "cmap")
    m = load_thrust_model(save_chain(ch, tmp_path / "cmap.yaml"))
    assert "map of the command" in m.voltage and "no ESC block" not in m.voltage
