"""McLean (1991, NPS thesis), Appendix A: load matching of the AUV II thruster propeller.

Each test names the thesis statement it checks (App. A, section C.3 "Discussion", and eq. A.1).
"""

from __future__ import annotations

import math

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from uuvid.core import units
from uuvid.thruster.load_matching import (
    PITTMAN_9514,
    PITTMAN_14202,
    TABLE_A1,
    THESIS_CASES,
    LoadCurve,
    PittmanMotor,
    continuous_torque,
    load_matching_table,
    max_continuous_speed,
    operating_point,
    plot_load_matching,
    propeller_thrust,
)


def lb(point) -> float:
    return point.thesis_units()["thrust_lbf"]


# --------------------------------------------------------------------------- eq. (A.1)
def test_eq_A1_9514_at_1750_rpm_hand_value():
    # sqrt(130/17.1 − 0.677·1750/1352)·0.71·2.05 − 0.677 = 3.10 oz·in
    hand = math.sqrt(130 / 17.1 - 0.677 * 1750 / 1352) * 0.71 * 2.05 - 0.677
    assert hand == pytest.approx(3.098, abs=1e-3)
    t = continuous_torque(PITTMAN_9514, units.rpm(1750.0))
    # SI form uses the exact oz·in·rpm→W factor 1352.28 instead of 1352: differs by < 0.01 %.
    assert units.to_oz_in(t) == pytest.approx(hand, rel=1e-4)


def test_eq_A1_at_rest_and_beyond_thermal_limit():
    t0 = continuous_torque(PITTMAN_14202, 0.0)
    assert units.to_oz_in(t0) == pytest.approx(math.sqrt(130 / 9.0) * 0.71 * 5.81 - 1.79, rel=1e-9)
    w_max = max_continuous_speed(PITTMAN_9514)
    assert units.to_rpm(w_max) == pytest.approx(130 / 17.1 / 0.677 * 1352, rel=1e-3)
    # Past the thermal limit the square root's argument is negative: NaN, documented.
    assert math.isnan(continuous_torque(PITTMAN_9514, 1.01 * w_max))
    arr = continuous_torque(PITTMAN_9514, np.array([0.0, 0.5 * w_max, 2 * w_max]))
    assert arr.shape == (3,) and np.isfinite(arr[:2]).all() and np.isnan(arr[2])
    assert arr[1] < arr[0]  # capability falls with speed


# --------------------------------------------------------------------------- App. B presets
def test_app_B_presets_round_trip_to_thesis_units():
    m = PITTMAN_9514
    assert units.to_oz_in(m.torque_constant) == pytest.approx(4.13)
    assert units.to_oz_in(m.friction_torque) == pytest.approx(0.677)
    assert units.to_oz_in(m.motor_constant) == pytest.approx(2.05)
    assert units.to_oz_in(m.stall_torque) == pytest.approx(24.0)
    assert units.to_rpm(m.no_load_speed) == pytest.approx(7370.0)
    assert units.to_rpm(PITTMAN_14202.no_load_speed) == pytest.approx(3820.0)
    assert units.to_oz_in(PITTMAN_14202.stall_torque) == pytest.approx(106.0)
    # In SI the torque constant and the back-EMF constant are the same number (App. B, both motors).
    for motor in (PITTMAN_9514, PITTMAN_14202):
        assert motor.torque_constant == pytest.approx(motor.back_emf_constant, rel=0.01)


def test_app_B_friction_torque_is_no_load_current_times_KT():
    # eq. A.1 definitions: T_F = I_NL · K_T (9514: 0.164 A · 4.13 oz·in/A = 0.677 oz·in)
    m = PITTMAN_9514
    assert m.no_load_current * m.torque_constant == pytest.approx(m.friction_torque, rel=0.01)


# --------------------------------------------------------------------------- Table A-I
def test_table_A1_torque_column_is_motor_law_and_prop_torque_is_2p5_times():
    # Column 4 = K_T·i (4.13 · 3.20 = 13.2 oz·in); the FORTRAN load torques are 2.5 × column 4.
    for _thrust, current, prop_rpm, torque, motor_rpm in TABLE_A1:
        assert 4.13 * current == pytest.approx(torque, abs=0.06)
        assert motor_rpm == pytest.approx(2.5 * prop_rpm, rel=0.005)  # printed rounded
    load = LoadCurve.thesis()
    fortran = {100: 4.65, 245: 8.25, 360: 12.4, 550: 20.65, 700: 29.0, 775: 33.0}
    for rpm_, q in fortran.items():
        assert units.to_oz_in(load.torque(units.rpm(rpm_))) == pytest.approx(q, abs=1e-9)
    # FORTRAN "Load Matching #3" extrapolation
    assert units.to_oz_in(load.torque(units.rpm(975.0))) == pytest.approx(55.0)
    assert not load.is_extrapolated(units.rpm(775.0)) and load.is_extrapolated(units.rpm(800.0))


def test_quadratic_fit_follows_table_A1():
    fit = LoadCurve.quadratic_fit()
    for _, _, prop_rpm, torque, _ in TABLE_A1:
        assert units.to_oz_in(fit.torque(units.rpm(prop_rpm))) == pytest.approx(
            2.5 * torque, abs=0.35
        )


def test_linear_thrust_law_of_the_fortran_listings():
    # THRUST = .0015625 * SS  (lb, prop rpm): 640 rpm → 1 lb
    assert units.to_lbf(propeller_thrust(units.rpm(640.0))) == pytest.approx(1.0)
    # table option reproduces the printed thrust column
    for thrust, _, prop_rpm, _, _ in TABLE_A1:
        assert units.to_lbf(propeller_thrust(units.rpm(prop_rpm), "table")) == pytest.approx(thrust)


# --------------------------------------------------------------------------- App. A conclusions
def test_app_A_9514_at_2p5_cannot_hold_one_pound_continuously():
    # "the Model 9514 motor coupled with a 2.5:1 reduction gear will not provide the desired
    #  design thrust of one pound for an extended period of time"
    p = operating_point(PITTMAN_9514, 2.5)
    u = p.thesis_units()
    assert u["thrust_lbf"] < 0.5  # well under 1 lb
    assert u["prop_rpm"] == pytest.approx(245, abs=10)
    assert u["motor_rpm"] == pytest.approx(610, abs=20)
    # at the operating point the motor torque equals eq. A.1 and the load torque over N
    assert p.motor_torque == pytest.approx(continuous_torque(PITTMAN_9514, p.motor_speed), rel=1e-9)
    assert p.motor_torque == pytest.approx(p.prop_torque / 2.5, rel=1e-12)
    assert p.motor_speed == pytest.approx(2.5 * p.prop_speed)


def test_app_A_9514_at_10_reaches_only_about_0p9_lb():
    # "the continuous thrust for a 10:1 gear ratio will only reach approximately 0.9 pounds"
    p = operating_point(PITTMAN_9514, 10.0)
    assert 0.9 <= lb(p) <= 1.0
    assert p.thesis_units()["prop_rpm"] == pytest.approx(615, abs=10)
    assert not p.exceeds_no_load_speed


def test_app_A_14202_at_2p5_about_1p1_lb_large_improvement_over_9514():
    # "for a 2.5:1 gear ratio the continuous thrust will be approximately 1.1 pounds,
    #  which is a large improvement over the Model 9514"
    p = operating_point(PITTMAN_14202, 2.5)
    assert 1.1 <= lb(p) <= 1.2
    assert p.thesis_units()["prop_rpm"] == pytest.approx(742, abs=10)
    assert lb(p) > 2.5 * lb(operating_point(PITTMAN_9514, 2.5))
    assert not p.exceeds_no_load_speed and not p.load_extrapolated


def test_app_A_14202_doubling_gear_ratio_gives_only_27_percent():
    # "the improvement due to a doubling in the gear ratio accounts for only 27% increase in thrust"
    p25 = operating_point(PITTMAN_14202, 2.5)
    p5 = operating_point(PITTMAN_14202, 5.0)
    assert lb(p5) / lb(p25) == pytest.approx(1.27, abs=0.01)
    # The thesis ignores that 5·n_p is then above the 3820 rpm no-load speed: flagged here.
    assert p5.exceeds_no_load_speed and p5.load_extrapolated
    assert p5.thesis_units()["motor_rpm"] > 3820


def test_app_A_larger_gear_ratio_gives_more_continuous_thrust():
    # "The larger the gear ratio, the faster the motor can be driven ... the larger gear ratio is desired"
    for motor, ratios in THESIS_CASES:
        thrusts = [lb(operating_point(motor, n)) for n in ratios]
        assert thrusts == sorted(thrusts)


def test_quadratic_load_option_keeps_the_first_three_conclusions():
    fit = LoadCurve.quadratic_fit()
    assert lb(operating_point(PITTMAN_9514, 2.5, load=fit)) < 0.5
    assert 0.9 <= lb(operating_point(PITTMAN_9514, 10.0, load=fit)) <= 1.0
    assert 1.1 <= lb(operating_point(PITTMAN_14202, 2.5, load=fit)) <= 1.2


def test_load_matching_table_default_is_the_seven_thesis_cases():
    rows = load_matching_table()
    assert [(r["motor"], r["gear_ratio"]) for r in rows] == [
        ("Pittman 9514", 2.5),
        ("Pittman 9514", 3.67),
        ("Pittman 9514", 5.0),
        ("Pittman 9514", 10.0),
        ("Pittman 14202", 2.5),
        ("Pittman 14202", 3.67),
        ("Pittman 14202", 5.0),
    ]
    assert set(rows[0]) == {"motor", "gear_ratio", "prop_rpm", "thrust_lbf"}
    for r in rows:
        assert r["thrust_lbf"] == pytest.approx(0.0015625 * r["prop_rpm"], rel=1e-9)
    # a mapping and a single ratio are accepted too
    one = load_matching_table({PITTMAN_14202: 2.5})
    assert len(one) == 1 and one[0]["thrust_lbf"] == pytest.approx(rows[4]["thrust_lbf"])


def test_thesis_units_round_trip():
    p = operating_point(PITTMAN_14202, 3.67)
    u = p.thesis_units()
    assert units.rpm(u["prop_rpm"]) == pytest.approx(p.prop_speed)
    assert units.oz_in(u["motor_torque_oz_in"]) == pytest.approx(p.motor_torque)
    assert units.lbf(u["thrust_lbf"]) == pytest.approx(p.thrust)


def test_plot_load_matching_returns_figure():
    import matplotlib.pyplot as plt

    fig = plot_load_matching(PITTMAN_14202, (2.5, 3.67, 5.0))
    try:
        ax = fig.axes[0]
        assert ax.get_xlabel() == "propeller speed (rpm)"
        assert len(ax.lines) >= 7  # 3 T_cont curves + 3 markers + load curve
    finally:
        plt.close(fig)


# --------------------------------------------------------------------------- invalid inputs
@pytest.mark.parametrize("bad", [0.0, -2.5, float("nan"), float("inf"), "x", None])
def test_invalid_gear_ratio_raises(bad):
    with pytest.raises(ValueError, match="gear ratio"):
        operating_point(PITTMAN_9514, bad)


def test_invalid_inputs_raise():
    with pytest.raises(ValueError, match="motor speed"):
        continuous_torque(PITTMAN_9514, -1.0)
    with pytest.raises(ValueError, match="ambient"):
        continuous_torque(PITTMAN_9514, 0.0, ambient_temp=160.0)
    with pytest.raises(ValueError, match="thrust law"):
        operating_point(PITTMAN_9514, 2.5, thrust="quadratic")
    with pytest.raises(ValueError, match="PittmanMotor"):
        operating_point("9514", 2.5)
    with pytest.raises(ValueError, match="torque_constant"):
        PittmanMotor("bad", 0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="strictly increasing"):
        LoadCurve(kind="piecewise", speeds=(0.0, 2.0, 1.0), torques=(0.0, 1.0, 2.0))
    with pytest.raises(ValueError, match="gear ratio"):
        load_matching_table([(PITTMAN_9514, (2.5, -1.0))])


def test_no_intersection_raises_clear_error():
    # a load that already needs more torque at rest than the motor can give continuously
    heavy = LoadCurve(kind="quadratic", coeffs=(0.0, 0.0, 10.0))
    with pytest.raises(ValueError, match="no operating point"):
        operating_point(PITTMAN_9514, 2.5, load=heavy)
