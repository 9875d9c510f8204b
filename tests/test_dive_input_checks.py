"""Input checks of the dive commands (a new user's report): a horizon within the initial-state span, force
columns in a wrong unit, a time range outside the log, a log of the wrong type, a time column
in a wrong unit, and the messages' readability."""

import re
import warnings

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.examples import write_examples
from uuvid.identify.vehicle.dive import identify_dive
from uuvid.simulate.dive_replay import replay_dive

runner = CliRunner()


@pytest.fixture(scope="module")
def dive_csv(tmp_path_factory):
    out = tmp_path_factory.mktemp("ex43")
    write_examples(["dive"], out)
    return out / "dive.csv"


@pytest.fixture(scope="module")
def table(dive_csv):
    return pd.read_csv(dive_csv)


# --- 1. a horizon no longer than the initial-state span --------------------------------------

def test_replay_horizon_within_state_span_is_an_error_naming_the_dof(table):
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(ValueError, match=r"heave.*must exceed the 2 s") as e:
            replay_dive(table, "bluerov2", ["heave"], horizon=2.0)
    assert "at least" in str(e.value)


def test_replay_cli_horizon_within_state_span_exits_2(dive_csv):
    r = runner.invoke(app, ["vehicle", "replay", str(dive_csv), "--vehicle", "bluerov2",
                            "--dof", "yaw", "--horizon", "0.5"])
    assert r.exit_code == 2, r.output
    assert "yaw" in r.output and "must exceed" in r.output and "nan" not in r.output


def test_identify_cli_horizon_within_state_span_exits_2(dive_csv, tmp_path):
    r = runner.invoke(app, ["vehicle", "identify", "dive", str(dive_csv), "--vehicle", "bluerov2",
                            "--dof", "heave", "--horizon", "2", "--t-end", "150",
                            "--out-vehicle", str(tmp_path / "h.yaml")])
    assert r.exit_code == 2, r.output
    assert "must exceed" in r.output and "not stay finite" not in r.output
    assert "RuntimeWarning" not in r.output


def test_identify_api_horizon_within_state_span_is_a_value_error(table):
    with pytest.raises(ValueError, match="initial state"):
        identify_dive(table, "bluerov2", ["heave"], horizon=1.5)


# --- 2. force columns in a wrong unit ---------------------------------------------------------

FORCES = ["X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"]


@pytest.fixture(scope="module")
def lbf_table(table):
    t = table.copy()
    t[FORCES] = t[FORCES] / 4.44822
    return t


def test_force_columns_against_the_pwm_columns(table, lbf_table):
    from uuvid.io.dive_channels import read_dive_channels
    from uuvid.vehicle.definition import load_vehicle

    veh = load_vehicle("bluerov2")
    ok = read_dive_channels(table, veh)
    assert not [w for w in ok.warnings if "the pwm_ columns give" in w], ok.warnings
    bad = read_dive_channels(lbf_table, veh)
    said = [w for w in bad.warnings if "the pwm_ columns give" in w]
    assert len(said) == 1 and "Z_N is 0.22×" in said[0] and "lbf" in said[0], bad.warnings


def test_mass_below_rigid_body_is_a_warning_of_every_run(lbf_table):
    res = identify_dive(lbf_table, "bluerov2", ["heave"], horizon=8.0)
    w = res.estimates["heave"].warnings
    assert any("below the rigid-body mass" in x and "Z_N" in x for x in w), w
    doc = res.to_dict()
    import json
    assert "below the rigid-body mass" in json.dumps(doc)


def test_inertia_below_rigid_body_within_2_sigma_is_said_as_the_write_back_refuses_it(table, tmp_path):
    from uuvid.vehicle.definition import load_vehicle
    from uuvid.vehicle.writeback import WritebackError

    short = table.drop(columns=["X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"])
    short = short[(short.t_s > 100) & (short.t_s < 145)]
    res = identify_dive(short, "bluerov2", ["yaw"])
    e = res.estimates["yaw"]
    iz = float(load_vehicle("bluerov2").params.M_RB[5, 5])
    assert e.values["mass"] < iz and e.values["mass"] + 2 * e.sigma["mass"] >= iz  # the case
    said = [w for w in e.warnings if "below the rigid-body inertia" in w]
    assert len(said) == 1 and "within 2σ" in said[0] and "--out-vehicle" in said[0], e.warnings
    assert "below the rigid-body inertia" in res.summary()
    with pytest.raises(WritebackError, match="below the rigid-body inertia"):
        res.write_vehicle(tmp_path / "v.yaml")
    assert not (tmp_path / "v.yaml").exists()


# --- 3. a time range past either end of the log ----------------------------------------------

@pytest.mark.parametrize("kw", [{"t_end": 500.0}, {"t_start": -50.0}])
def test_a_range_past_the_log_is_an_error_naming_its_span(table, kw):
    for call in (identify_dive, replay_dive):
        with pytest.raises(ValueError, match=r"outside the log, whose times run from 0\.0368"):
            call(table, "bluerov2", ["heave"], **kw)


def test_a_range_inside_a_logging_pause_names_the_pause_and_its_row(table, tmp_path):
    gap = tmp_path / "gap.csv"
    table[(table.t_s <= 100) | (table.t_s >= 160)].to_csv(gap, index=False)
    row = int(np.flatnonzero(table[(table.t_s <= 100) | (table.t_s >= 160)].t_s >= 160)[0]) + 2
    with pytest.raises(ValueError, match=rf"\[110, 150\] s lies inside the logging pause "
                                         rf"99\.9\d*–160\.\d+ s \(column t_s, row {row}\): no "
                                         "samples there") as e:
        identify_dive(gap, "bluerov2", ["heave", "yaw"], t_start=110.0, t_end=150.0)
    assert "one side of it" in str(e.value) and str(e.value).count("lies inside") == 1
    r = runner.invoke(app, ["vehicle", "identify", "dive", str(gap), "--vehicle", "bluerov2",
                            "--t-start", "110", "--t-end", "150"])
    assert r.exit_code == 2 and "lies inside the logging pause" in r.output, r.output


def test_a_range_past_the_log_exits_2_in_the_commands(dive_csv):
    for cmd in (["vehicle", "identify", "dive"], ["vehicle", "replay"]):
        r = runner.invoke(app, cmd + [str(dive_csv), "--vehicle", "bluerov2", "--dof", "heave",
                                      "--t-end", "500"])
        assert r.exit_code == 2 and "outside the log" in r.output, r.output


# --- 4. a log of the wrong type -----------------------------------------------------------------

@pytest.mark.parametrize("log", [np.zeros((3, 3)), [1, 2, 3], None])
def test_a_log_of_the_wrong_type_is_named(log):
    from uuvid.io.dive_channels import read_dive_channels

    name = type(log).__name__
    for call in (lambda: identify_dive(log, "bluerov2", ["heave"]),
                 lambda: replay_dive(log, "bluerov2", ["heave"]),
                 lambda: read_dive_channels(log, "bluerov2")):
        with pytest.raises(TypeError, match=rf"^log: expected a path .*DataFrame, got {name}$"):
            call()


# --- 5. a time column in another unit ---------------------------------------------------------

@pytest.mark.parametrize("scale, say", [(1 / 60, r"minutes\? multiply it by 60"),
                                        (1 / 3600, r"hours\? multiply it by 3600"),
                                        (1e6, r"microseconds\? divide it by 1e\+06"),
                                        (1e3, r"milliseconds\? divide it by 1000")])
def test_a_time_column_in_another_unit_is_said_with_its_factor(table, scale, say):
    from uuvid.io.dive_channels import read_dive_channels

    t = table.assign(t_s=table["t_s"] * scale)
    with pytest.raises(ValueError, match=say) as e:
        read_dive_channels(t, "bluerov2")
    assert "cm or mm" not in str(e.value)


# --- 6. readable messages ---------------------------------------------------------------------

def test_a_huge_sigma_ratio_is_readable():
    from uuvid.identify.vehicle.dive import inflow_warnings

    w = inflow_warnings({"inflow": 1.1e-12}, {"inflow": 2.6e5}, np.eye(5))
    assert len(w) == 1 and "poorly determined" in w[0]
    assert not re.search(r"\d{7,}", w[0]), w[0]  # no 18-digit percentage
    assert "2.4e+17" in w[0]


def test_the_held_out_start_of_an_epoch_log_keeps_its_digits(table):
    t = table.assign(t_s=table["t_s"] + 1.7e9)
    res = identify_dive(t, "bluerov2", ["heave"], t_end=1.7e9 + 250, horizon=8.0)
    assert "held-out (t > 1700000250 s)" in res.summary()


def test_the_refined_starts_note_says_start_and_final_costs(table):
    res = identify_dive(table, "bluerov2", ["yaw"], t_start=100.0, t_end=200.0)
    note = next(n for n in res.estimates["yaw"].notes if "refined from" in n)
    finals = [float(x) for x in re.findall(r"final cost ([0-9.e+-]+)\)", note)]
    kept = re.search(r"kept the fit from the (\w+) start \(lowest final cost\)", note).group(1)
    mine = float(re.search(rf"the {kept} start .*?final cost ([0-9.e+-]+)\)", note).group(1))
    assert len(finals) >= 2 and mine == min(finals) and "start cost" in note


def test_a_case_misspelt_column_is_said_as_read():
    from uuvid.io.dive_channels import read_dive_channels

    t = pd.DataFrame({"t_s": np.arange(0, 30, 0.1), "Depth_m": 1.0, "yaw_rad": 0.0})
    w = [x for x in read_dive_channels(t, "bluerov2").warnings if "Depth_m" in x]
    assert w and "read as depth_m" in w[0] and "sensitive" not in w[0], w



def test_thrust_from_pwm_columns_says_a_voltage_outside_the_thruster_data(table):
    """A table's pwm_ columns go through the same voltage check as log export (a 6S pack on the
    T200 model, whose data end at 16 V); the example's own voltages stay silent."""
    from uuvid.io.dive_channels import read_dive_channels

    pwm_only = table.drop(columns=["X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"])
    said = [w for w in read_dive_channels(pwm_only, vehicle="bluerov2").warnings if "outside the data" in w]
    assert said == []
    six_s = pwm_only.assign(battery_V=pwm_only["battery_V"] * 1.45)
    said = [w for w in read_dive_channels(six_s, vehicle="bluerov2").warnings if "outside the data" in w]
    assert len(said) == 1 and "battery_V" in said[0] and " rows (t = " in said[0], said


def test_mass_below_rigid_body_unit_hint_beyond_2_sigma_noise_within_and_torque_units_for_yaw():
    from uuvid.identify.vehicle.dive import below_rigid_body
    from uuvid.io.dive_channels import unit_guess
    from uuvid.vehicle.definition import load_vehicle

    veh = load_vehicle("bluerov2")
    rigid = float(veh.params.M_RB[2, 2])
    assert below_rigid_body(veh, "heave", rigid + 0.05, 1.5) is None  # above: nothing to say
    near = below_rigid_body(veh, "heave", rigid - 0.05, 1.5)  # within noise: said as possibly so
    assert near and "within 2σ" in near and "refused" in near and "lbf" not in near
    unknown = below_rigid_body(veh, "heave", rigid * 0.6, float("nan"))
    assert unknown and "σ not determined" in unknown
    w = below_rigid_body(veh, "heave", rigid * 0.6, 0.5)
    assert w and "lbf: ×4.448 → N" in w and "Z_N" in w
    iz = float(veh.params.M_RB[5, 5])
    w = below_rigid_body(veh, "yaw", iz * 0.3, iz * 0.01)
    assert w and "lbf·ft" in w and "N_Nm" in w and "lbf: ×4.448" not in w
    assert unit_guess("N_Nm", 1 / 1.3558).startswith("lbf·ft")
    assert unit_guess("Z_N", 1 / 4.448).startswith("lbf")
    assert unit_guess("Z_N", 0.5) is None
