"""The ``t200`` preset chain against Blue Robotics' T200 sheets (12 V and 16 V, Sept. 2019)."""

import numpy as np
import pytest

from uuvid.core import units as U
from uuvid.identify.thruster.t200_preset import (
    NAMES,
    SHEET_POINTS_KGF,
    fit_t200_preset,
    preset_vs_sheet_points,
    read_sheets,
    refit_t200_preset,
    sheet_errors,
)
from uuvid.io.bench import BenchData
from uuvid.thruster.blocks import ESC, FirstOrderMotor, QuadraticMap
from uuvid.thruster.presets import (
    T200_SHEET_TOLERANCE,
    T200_STEADY,
    T200_TIME_CONSTANT,
    T200Steady,
    t200_chain,
)

T200 = "t200-bluerobotics-2019"
FIELDS = ("curvature_fwd", "curvature_rev", "kt_fwd", "kt_rev", "full_speed", "speed_exponent")


def test_preset_follows_the_quoted_sheet_points():
    """At the rows quoted from both sheets (dead-band edge, low, mid and full command, both
    directions) the preset's steady thrust is within the stated tolerance of the sheet's max."""
    rows = preset_vs_sheet_points()
    assert len(rows) == sum(len(p) for p in SHEET_POINTS_KGF.values())
    for r in rows:
        assert abs(r["error_pct_of_max"]) <= 100 * T200_SHEET_TOLERANCE, r
    # the case that was wrong: 1580 µs at 16 V is 0.3992 kgf = 3.9 N on the sheet (was 1.0 N)
    f = t200_chain(16.0).steady_thrust([1580.0])[0]
    assert abs(f - U.kgf(0.3992)) <= T200_SHEET_TOLERANCE * U.kgf(5.245)


def test_preset_is_esc_first_order_motor_quadratic_with_the_documented_lag():
    """Static ESC → one exact first-order motor (τ = T200_TIME_CONSTANT) → static K_T Ω|Ω|: the
    shape the SIMD batch kernel takes; no dead band; full command reaches the sheet's speed."""
    for volts in (12.0, 16.0):
        esc, motor, prop = t200_chain(volts).blocks
        assert isinstance(esc, ESC) and isinstance(motor, FirstOrderMotor)
        assert isinstance(prop, QuadraticMap)
        assert motor.time_constant == T200_TIME_CONSTANT
        assert esc.deadzone_low == esc.deadzone_high == 1500.0
        assert esc.voltage(1900.0) == pytest.approx(volts) and esc.voltage(1100.0) == -volts
        full = motor.gain * volts
        assert full == pytest.approx(T200_STEADY.full_speed * (volts / 16.0)
                                     ** T200_STEADY.speed_exponent)
    # a 0.5 ≤ γ ≤ 1 power law lies between a resistance- and a back-EMF-dominated motor
    assert 0.5 <= T200_STEADY.speed_exponent <= 1.0


def test_preset_warns_outside_the_sheets_voltages():
    with pytest.warns(UserWarning, match="outside the sheets"):
        t200_chain(20.0)


def test_bluerov2_square_mission_stays_on_the_batch_fast_path():
    from uuvid.simulate import batch
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import setup_mission
    from uuvid.vehicle.definition import load_vehicle

    for name in ("bluerov2", "bluerov2-heavy"):
        assert batch.fast_path_reason(setup_mission(load_vehicle(name), square_mission(),
                                                    t_end=1.0)) is None


def _synthetic_sheet(steady: T200Steady, volts: float) -> BenchData:
    chain = t200_chain(volts, steady, warn=False)
    c = np.arange(1100.0, 1901.0, 4.0)
    w = chain.blocks[1].gain * chain.blocks[0].voltage(c)
    return BenchData(command=c, thrust=chain.steady_thrust(c), speed=w, supply_voltage=volts,
                     source=f"synthetic {volts:g} V", neutral=1500.0)


def test_fit_recovers_the_constants_of_synthetic_sheets():
    """Sheets made by a known preset at 12 V and 16 V are fitted back to its constants (from a
    start 10–30 % off), with the residual at rounding level."""
    truth = T200Steady(-0.2, -0.4, 3.2e-4, 2.6e-4, 360.0, 0.7)
    sheets = [_synthetic_sheet(truth, v) for v in (12.0, 16.0)]
    fit = fit_t200_preset(sheets, T200Steady(-0.26, -0.3, 3.6e-4, 3.0e-4, 330.0, 0.6))
    for name, field in zip(NAMES, FIELDS):
        assert fit[name].value == pytest.approx(getattr(truth, field), rel=1e-6), name
    assert fit.rmse < 1e-8


def test_fit_needs_two_supply_voltages():
    s = _synthetic_sheet(T200_STEADY, 16.0)
    with pytest.raises(ValueError, match="two supply voltages"):
        fit_t200_preset([s, s])


@pytest.mark.realdata
def test_shipped_constants_equal_a_refit_of_the_sheets(shared_data):
    """The constants in uuvid.thruster.presets are fit_t200_preset on the two sheets, within one σ
    of that refit (they are its values rounded to 4 digits)."""
    steady, fit = refit_t200_preset(shared_data / T200)
    assert not fit.at_bound
    for name, field in zip(NAMES, FIELDS):
        assert getattr(steady, field) == fit[name].value
        assert abs(getattr(T200_STEADY, field) - fit[name].value) <= fit[name].stderr, name


@pytest.mark.realdata
@pytest.mark.parametrize("volts", [12, 16])
def test_preset_follows_every_row_of_the_sheet(shared_data, volts):
    """Every row of the sheet (1100…1900 µs in 4 µs steps) within the stated tolerance of its max
    |thrust|; the full-command thrust (what the vehicles' allocation limits quote) within it too."""
    sheet = read_sheets(shared_data / T200)[0 if volts == 12 else 1]
    chain = t200_chain(float(volts))
    e = sheet_errors(chain.steady_thrust, sheet)
    assert e["max_abs_error_pct"] <= 100 * T200_SHEET_TOLERANCE
    for p in e["points"]:
        assert abs(p["error_N"]) <= T200_SHEET_TOLERANCE * e["max_thrust_N"]



def test_demo_section_shows_the_sheet_table(tmp_path):
    from uuvid.core.html import Report
    from uuvid.demo import _t200_sheet_section

    rep = Report("t200")
    d = _t200_sheet_section(rep)
    assert len(d["rows"]) == 24 and d["max_abs_error_pct_of_max"] <= 100 * T200_SHEET_TOLERANCE
    rep.write(tmp_path)
    assert "sheets" in (tmp_path / "index.html").read_text()


def test_cli_predict_builds_the_preset_at_the_supply_voltage():
    """``uuvid thruster predict t200 --supply-voltage 12`` is the 12 V preset (speed ∝ V^γ), not
    the 16 V ESC rescaled (which would give (12/16)² of the 16 V thrust)."""
    import json

    from typer.testing import CliRunner

    from uuvid.cli.app import app
    from uuvid.thruster.presets import preset_chain

    res = CliRunner().invoke(app, ["thruster", "predict", "t200", "--pwm", "1100,1600,1900",
                                   "--supply-voltage", "12", "--json"])
    assert res.exit_code == 0, res.output
    got = json.loads(res.stdout)["thrust_N"]
    np.testing.assert_allclose(got, t200_chain(12.0).steady_thrust([1100.0, 1600.0, 1900.0]))
    assert abs(got[2] - U.kgf(3.7142)) <= T200_SHEET_TOLERANCE * U.kgf(3.7142)
    with pytest.raises(ValueError, match="no ESC"):
        preset_chain("auv2-tunnel", 12.0)
