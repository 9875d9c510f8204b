"""Static stability in steady flight (issue 10): trim against speed and the speed where a vehicle
can no longer stay level."""

import math

import pytest

from uuvid.vehicle.definition import load_vehicle
from uuvid.vehicle.stability import static_stability, trim_state


@pytest.fixture(scope="module")
def bluerov2():
    return load_vehicle("bluerov2")


@pytest.fixture(scope="module")
def stab(bluerov2):
    return static_stability(bluerov2)


def _small_angle_pitch(v, U):
    """Hand-derived small-angle surge trim: the surge thrust at height z_T balances drag X(U) and
    the along-body weight component (W − B)θ; the Munk moment (A₃₃ − A₁₁)U²θ opposes BG·W θ."""
    p = v.params
    z_t = float(v.layout.thrusters[0].position[2])  # horizontal thrusters, 0.02 m below CO
    X = p.linear_damping[0, 0] * U + p.quadratic_damping[0, 0] * U * U
    bgw = p.weight * p.r_g[2] - p.buoyancy * p.r_b[2]
    munk = p.added_mass[2, 2] - p.added_mass[0, 0]
    return math.degrees(z_t * X / (bgw - z_t * p.net_weight - munk * U * U))


@pytest.mark.slow
def test_small_angle_trim_matches_the_hand_derivation(bluerov2, stab):
    c = stab["forward"]
    assert c.free == ("roll", "pitch")
    for i in (3, 6):  # 0.19 and 0.38 m/s, below the limit
        U = c.speeds[i]
        assert U < c.limit_speed
        assert c.tilt_small_deg["pitch"][i] == pytest.approx(_small_angle_pitch(bluerov2, U), rel=1e-4)
        # small angles: the nonlinear trim agrees with the linear one to second order
        assert c.tilt_deg["pitch"][i] == pytest.approx(c.tilt_small_deg["pitch"][i], rel=0.02)
        assert abs(c.tilt_deg["roll"][i]) < 1e-9
    assert stab["backward"].tilt_deg["pitch"][5] == pytest.approx(-c.tilt_deg["pitch"][5])
    assert c.righting["pitch"] == pytest.approx(112.8 * 0.02)  # W z_G − B z_B


@pytest.mark.slow
def test_limit_is_where_the_trim_reaches_the_tilt_limit(bluerov2, stab):
    for d, ang in (("forward", "pitch"), ("starboard", "roll")):
        c = stab[d]
        assert c.limited and c.limit_dof == ang and c.limit_speed < c.max_speed
        t = trim_state(bluerov2, c.dof, c.sign, c.limit_speed)
        assert t["ok"] and t["stable"]
        assert abs(t["tilt_deg"][ang]) == pytest.approx(stab.max_tilt_deg, abs=0.1)
    # a looser tilt limit allows more speed (the trim grows monotonically with speed)
    loose = static_stability(bluerov2, max_tilt_deg=40.0)["forward"]
    assert loose.limit_speed > stab["forward"].limit_speed
    assert not stab["diving"].limited  # vertical thrust at the CG: no moment


@pytest.mark.slow
def test_vehicles_with_attitude_control_have_no_free_angle():
    res = static_stability(load_vehicle("bluerov2-heavy"))
    assert all(c.free == () and not c.limited for c in res.cases)
    assert "held by thrusters" in res.summary()


@pytest.mark.slow
def test_result_serialises_and_plots(stab, tmp_path):
    d = stab.to_dict()
    assert d["cases"][0]["limit"].startswith("stability")
    assert (stab.plot(tmp_path / "s.png")).exists()


# --- speeds in the text: distinct speeds read distinct ------------------------------------------

def _speeds_said(text):
    """Every "<number> m/s" a stability text says, as printed."""
    import re

    return re.findall(r"([-+]?\d[\d.e+-]*) m/s", text)


@pytest.mark.slow
def test_trim_speeds_with_and_without_inflow_read_differently(bluerov2, stab):
    """The bollard and four-quadrant trims of the BlueROV2 going forward are shown at 0.384 and
    0.377 m/s: they were both printed "at 0.38 m/s", as if at the same speed."""
    inflow = static_stability(bluerov2, inflow="four-quadrant")
    dry = next(ln for ln in stab.summary().splitlines() if " forward " in ln)
    wet = next(ln for ln in inflow.summary().splitlines() if " forward " in ln)
    assert "at 0.384 m/s" in dry and "at 0.377 m/s" in wet
    assert set(_speeds_said(dry)) != set(_speeds_said(wet))


@pytest.mark.slow
def test_table_and_summary_give_speeds_three_significant_digits(stab):
    assert stab["forward"].limit_text() == "stability 0.481 m/s (pitch)"  # was "0.48"
    assert all(r["limit"] == stab[r["direction"]].limit_text(3) for r in stab.rows())
    json_case = stab.to_dict()["cases"][0]
    assert json_case["limit_speed"] == stab.cases[0].limit_speed  # JSON keeps the full number


def test_speed_digits_grow_until_distinct_speeds_print_distinctly():
    from uuvid.vehicle.stability import speed_digits

    assert speed_digits([0.3837, 0.3770]) == 3
    assert speed_digits([0.48085, 0.48097]) == 4  # 0.481 both at 3 digits
    assert speed_digits([0.377030562918, 0.377030562919 + 1e-16]) == 3  # rounding noise: alike
    assert speed_digits([1.0, math.inf, math.nan]) == 3
    assert speed_digits([0.1234567, 0.1234568]) == 6  # capped


@pytest.mark.slow
def test_cli_stability_table_says_the_limit_to_three_digits():
    from typer.testing import CliRunner

    from uuvid.cli.app import app

    res = CliRunner().invoke(app, ["vehicle", "stability", "bluerov2"])
    assert res.exit_code == 0, res.output
    text = " ".join(res.stdout.split())
    assert "stability 0.481 m/s (pitch)" in text and "at 0.384 m/s" in text
    assert "0.48 m/s" not in text and "0.38 m/s" not in text
