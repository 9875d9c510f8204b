"""Station keeping (uuvid.analysis.hold), voltage-true thrusters and the battery (issue 11)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from uuvid.analysis import hold
from uuvid.thruster.physical import physical_model
from uuvid.vehicle.definition import load_vehicle
from uuvid.vehicle.power import SupplyThruster, limits_at


def test_required_wrench_balances_the_model():
    """τ_req makes the vehicle at rest in the current stay at rest (ν̇ = 0)."""
    v = load_vehicle("bluerov2-heavy")
    c = hold.current_ned(0.4, 30.0)
    tau = hold.required_wrench(v, c)
    assert np.max(np.abs(hold._accel(v, c, 2.0, 0.0, 0.0, tau))) < 1e-9
    assert tau[0] > 0  # a head-on component must be pushed against


@pytest.mark.slow
@pytest.mark.parametrize("deg", [0.0, 90.0])
def test_capability_analytic_matches_simulation_heavy(deg):
    """The analytic boundary (allocation within limits + steady drag) and the simulated one
    (bisection on closed-loop holds) agree within 5 %."""
    v = load_vehicle("bluerov2-heavy")
    vmax = hold.max_current(v, deg)[0]
    sim = hold.simulate_boundary(v, deg, vmax, iterations=5)
    assert abs(sim / vmax - 1) < 0.05


@pytest.mark.slow
@pytest.mark.parametrize("name", ["bluerov2-heavy", "bluerov2"])
def test_capability_analytic_matches_simulation_all(name):
    r = hold.capability(load_vehicle(name), step_deg=45, simulate_deg=(0, 45, 90, 135, 180))
    assert np.all(np.abs(r.agreement - 1) < 0.05), r.summary()


@pytest.mark.slow
def test_closed_loop_stability_bounds_the_bluerov2_head_on():
    """The BlueROV2 (no roll/pitch control) held against a current from ahead: the steady
    allocation and the pitch balance hold up to 0.58 m/s, but the DP loop linearised there has
    an unstable yaw oscillation (Munk moment) from 0.38 m/s; the analytic boundary says so, and
    the simulated hold (gust-excited) keeps its heading just below it and not just above."""
    v = load_vehicle("bluerov2")
    static = hold.max_current(v, 0.0, stability=False, tol=1e-3)[0]
    vmax, info = hold.max_current(v, 0.0, tol=1e-3)
    assert info["limit"] == "stability" and vmax < 0.8 * static
    assert hold.holds_in_simulation(v, 0.0, 0.95 * vmax)[0]
    held, r = hold.holds_in_simulation(v, 0.0, 1.05 * vmax)
    assert not held and np.max(np.abs(r.tracking_error[r.t > 130])) < 0.5  # heading, not position


@pytest.mark.slow
def test_capability_shrinks_with_the_battery():
    v = load_vehicle("bluerov2-heavy")
    full = hold.max_current(v, 0.0, soc=1.0)
    low = hold.max_current(v, 0.0, soc=0.15)
    assert low[0] < full[0]
    assert low[1]["supply_voltage_V"] < full[1]["supply_voltage_V"]


def test_held_command_compensates_for_voltage():
    st = SupplyThruster(physical_model())
    c12, c16 = st.command_for(20.0, 12.0), st.command_for(20.0, 16.0)
    assert c12 > c16 > 1500  # a sagging pack needs a larger command for the same thrust
    m = physical_model()
    assert abs(m.thrust(c12, 12.0) - 20.0) < 0.05 and abs(m.thrust(c16, 16.0) - 20.0) < 0.05
    assert limits_at(load_vehicle("bluerov2"), 12.0)[0, 1] < limits_at(load_vehicle("bluerov2"),
                                                                          16.0)[0, 1]


@pytest.mark.slow
def test_endurance_run_limit_shrinks_and_command_rises():
    v = load_vehicle("bluerov2-heavy")
    e = hold.endurance(v, 0.5, 0.0, dsoc=0.05)
    assert e.endurance_s > 0 and np.all(np.diff(e.time_s) > 0)
    assert np.all(np.diff(e.max_forward_thrust) < 0)  # the limit shrinks as the pack sags
    assert np.all(np.diff(e.voltage) < 0)
    busiest = int(np.argmax(np.abs(e.thrust[0])))
    assert np.allclose(e.thrust[:, busiest], e.thrust[0, busiest], rtol=1e-6)  # same thrust held
    dc = np.abs(e.command[:, busiest] - 1500.0)
    assert np.all(np.diff(dc) > 0)  # ... by a growing command
    faster = hold.endurance(v, 0.6, 0.0, dsoc=0.05)
    assert faster.endurance_s < e.endurance_s


@pytest.mark.realdata
def test_t200_limits_match_the_sheets(shared_data):
    """The shipped voltage-aware T200 model's full-command thrusts at 12 V and 16 V are within 3 %
    of Blue Robotics' sheets (the model was fitted to them; the limits are its extrapolation to
    the command extremes, not read off the sheets)."""
    st = SupplyThruster(physical_model())
    for volt in (12, 16):
        df = pd.read_csv(shared_data / "t200-bluerobotics-2019" / f"T200_{volt}V.csv")
        f = df["Force (Kg f)"].to_numpy() * 9.80665
        lo, hi = st.limits(float(volt))
        assert abs(hi / f.max() - 1) < 0.03
        assert abs(lo / f.min() - 1) < 0.03


def test_vehicle_file_battery_errors_name_the_key():
    import yaml

    from uuvid.vehicle.definition import VehicleFileError, preset_path, vehicle_from_dict

    raw = yaml.safe_load(preset_path("bluerov2").read_text())
    raw["battery"]["ocv_voltage"] = raw["battery"]["ocv_voltage"][::-1]
    with pytest.raises(VehicleFileError, match="battery"):
        vehicle_from_dict(raw, "x.yaml")


@pytest.mark.slow
def test_battery_mission_limit_shrinks_and_command_compensates():
    """Supply voltage as a state of the mission loop: holding station in a 0.5 m/s current on a
    part-charged pack, the voltage sags, the thrust limit (at that voltage) shrinks, the held
    thrust stays, and the commands grow to keep it."""
    from uuvid.simulate.currents import TimeSeriesCurrent
    from uuvid.simulate.reference import WaypointMission
    from uuvid.simulate.vehicle_sim import fly_mission, setup_mission

    v = load_vehicle("bluerov2-heavy")
    c = hold.current_ned(0.5, 0.0)
    cur = TimeSeriesCurrent(np.array([0.0, 20.0, 1e4]), np.vstack([0 * c, c, c]))
    wp = (0.0, 0.0, 2.0, 0.0)
    s = setup_mission(v, WaypointMission((wp, wp), hold=400.0), current=cur, battery=True,
                      soc0=0.25, dt=0.02)
    r = fly_mission(s)
    V, amps, soc, cmd = r.supply[:, 0], r.supply[:, 1], r.supply[:, 2], r.supply[:, 3:]
    a, b = np.searchsorted(r.t, 100.0), -1  # after the current has built up and settled
    assert V[b] < V[a] - 0.05 and soc[b] < soc[a]
    lim_a, lim_b = (np.interp(x, _vgrid(s), _vhi(s))
                    for x in (V[a], V[b]))
    assert lim_b < lim_a
    k = int(np.argmax(np.abs(r.thrust[a])))
    assert abs(r.thrust[b, k] - r.thrust[a, k]) < 0.02 * abs(r.thrust[a, k])
    assert abs(cmd[b, k] - 1500) > abs(cmd[a, k] - 1500) + 1.0
    assert r.metrics["max_tracking_error_m"] < 0.5 and np.all(amps > 0)


def _vgrid(s):
    B = s.battery_array
    no, nv = int(B[7]), int(B[5])
    return B[8 + 2 * no:8 + 2 * no + nv]


def _vhi(s):
    B = s.battery_array
    no, nv = int(B[7]), int(B[5])
    return B[8 + 2 * no + 2 * nv:8 + 2 * no + 3 * nv]


@pytest.mark.slow
def test_cli_hold_json(tmp_path):
    import json

    from typer.testing import CliRunner

    from uuvid.cli.app import app

    res = CliRunner().invoke(app, ["vehicle", "hold", "bluerov2-heavy", "--current", "0.4,30",
                                   "--voltage", "16", "--step", "90", "--out", str(tmp_path),
                                   "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["at_current"]["holds"] and len(doc["capability"]["max_current_m_s"]) == 4
    assert (tmp_path / "capability.png").is_file()
    bad = CliRunner().invoke(app, ["vehicle", "hold", "bluerov2", "--current", "fast"])
    assert bad.exit_code == 2 and "--current" in bad.output


@pytest.mark.slow
def test_romeo_holds_with_installation_coefficients_below_one():
    """ROMEO's vertical mode delivers η = 0.56 of a downward command: the DP integrator raises
    the command until the delivered wrench balances the 0.7 N buoyancy, so the hold allocates
    τ/η against the limits (it reported 0 m/s at every angle, "0.392 N delivered").  The analytic
    boundary is confirmed by simulation on both sides."""
    v = load_vehicle("romeo")
    vmax, info = hold.max_current(v, 0.0, tol=1e-3)
    assert vmax > 0 and info["limit"] == "thrust" and info["reason"]
    assert hold.holds_in_simulation(v, 0.0, 0.95 * vmax)[0]
    assert not hold.holds_in_simulation(v, 0.0, 1.1 * vmax)[0]


@pytest.mark.slow
def test_auv2_uncontrolled_surge_drifts_and_is_named():
    """AUV II has no surge thruster: its position along surge is a neutral (λ = 0) mode, not an
    instability; a current with a surge component cannot be held (and says why), one from the
    beam can."""
    v = load_vehicle("auv2")
    al = hold._allocator(v)
    g, drifting = hold.closed_loop_modes(v, np.zeros(3), al, hold.hold_gains(v), 2.0, 0.0, 0.0)
    assert drifting == ["surge"] and g < 0
    v0, info0 = hold.max_current(v, 0.0)
    assert v0 == 0.0 and info0["limit"] == "uncontrolled" and "surge" in info0["reason"]
    assert hold.max_current(v, 90.0)[0] > 0
    cap = hold.capability(v, step_deg=90.0)
    text = cap.summary()
    assert "holds nothing at 2 of 4 angles" in text and "surge" in text
    assert cap.to_dict()["drifting"] == ["surge"]


@pytest.mark.slow
def test_hold_and_stability_share_one_tilt_limit():
    """Station keeping against a beam current is the steady-flight balance at the same relative
    water speed: with one tilt limit (stability.MAX_TILT_DEG, 20°; hold used 45° and said the
    BlueROV2 holds 1.15 m/s where stability says it stops being level at 0.84) the two agree."""
    from uuvid.vehicle.stability import MAX_TILT_DEG, static_stability

    v = load_vehicle("bluerov2")
    vmax, info = hold.max_current(v, 90.0, tol=1e-3)
    assert info["limit"] == "attitude" and abs(abs(info["roll_deg"]) - MAX_TILT_DEG) < 0.1
    case = next(c for c in static_stability(v).cases if c.direction == "starboard")
    assert case.limit_dof == "roll" and abs(vmax / case.limit_speed - 1) < 0.03


@pytest.mark.slow
def test_capability_and_endurance_report_progress_off_a_terminal(capsys, monkeypatch):
    """Long hold runs are not silent: one stderr line per angle (and per 10 % of charge)."""
    monkeypatch.delenv("UUVID_NO_PROGRESS", raising=False)
    v = load_vehicle("auv2")
    hold.capability(v, step_deg=90.0)
    err = capsys.readouterr().err
    assert "auv2 capability: current from 90° (2/4" in err and "auv2 capability: done in" in err
    hold.capability(v, step_deg=90.0, progress=False)
    assert capsys.readouterr().err == ""
    hold.endurance(load_vehicle("bluerov2-heavy"), 0.3, 0.0, soc0=0.3, dsoc=0.05)
    err = capsys.readouterr().err
    assert "bluerov2-heavy endurance: holding 0.3 m/s at SOC" in err and "done in" in err


@pytest.mark.parametrize("name, rel, roll, pitch", [
    ("bluerov2", 45.0, 0.05, -0.03), ("bluerov2-heavy", 135.0, 0.0, 0.0),
    ("romeo", 0.0, 0.02, 0.01), ("auv2", 90.0, 0.0, 0.04)])
def test_compiled_loop_jacobian_is_the_python_one(name, rel, roll, pitch):
    """The station-keeping loop's Jacobian (compiled: PID, bounded allocation, η, the 6-DOF model
    and the Euler kinematics in one kernel) equals the one built through Allocator.allocate in
    Python, entry by entry, to the rounding that central differences amplify."""
    from uuvid.analysis.hold import (
        _allocator,
        _closed_loop_jacobian_py,
        _loop_point,
        current_ned,
        hold_gains,
    )
    from uuvid.analysis.hold_linear import closed_loop_jacobian

    v = load_vehicle(name)
    al = _allocator(v)
    gains = hold_gains(v)
    cur = current_ned(0.3, rel)
    G, P, c, s0 = _loop_point(v, cur, gains, 2.0, roll, pitch)
    ep, en = al.eta
    A = closed_loop_jacobian(s0, G, P, c, 2.0, al.to_array("priority"),
                             np.ascontiguousarray(al.B), np.ascontiguousarray(ep, dtype=float),
                             np.ascontiguousarray(en, dtype=float))
    ref = _closed_loop_jacobian_py(v, cur, al, gains, 2.0, roll, pitch)
    assert np.max(np.abs(A - ref)) <= 1e-8 * max(1.0, np.max(np.abs(ref)))
    assert np.count_nonzero(np.abs(ref) > 1e-6) > 20  # the loop couples the states


@pytest.mark.parametrize("volts", [10.5, 14.8, 16.0, 20.0])
def test_limits_and_current_from_one_grid_are_the_two_calls(volts):
    """Battery.supply reads the limits off the command grid's end points and the current from
    the same grid: the same numbers as limits() and current(clip(thrust)) called apart."""
    st = SupplyThruster(physical_model("t200-physical"))
    thrusts = np.array([-60.0, -20.0, -0.01, 0.0, 0.3, 12.0, 33.0, 80.0])
    (lo, hi), cur = st.limits_and_current(thrusts, volts)
    assert (lo, hi) == st.limits(volts)
    assert np.array_equal(cur, st.current(np.clip(thrusts, lo, hi), volts))
    assert lo < 0 < hi and np.all(cur >= 0)


def test_a_supply_voltage_far_outside_the_sheets_is_warned():
    """`vehicle hold bluerov2 --voltage 1000` gave limits as if the thrusters ran on 1 kV, without
    a word (thruster predict warned); a 4S battery's range stays silent."""
    import warnings

    from uuvid.vehicle import power
    from uuvid.vehicle.definition import load_vehicle
    from uuvid.vehicle.power import SupplyVoltageWarning, limits_at

    power._WARNED.clear()  # once per model and side in a process
    v = load_vehicle("bluerov2")
    with pytest.warns(SupplyVoltageWarning, match="1000 V is far outside the 12–16 V"):
        limits_at(v, 1000.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error", SupplyVoltageWarning)
        for volts in (12.0, 14.8, 16.8):
            limits_at(v, volts)


def _preset_with(model: str, name="heavy-other"):
    import yaml

    from uuvid.vehicle.definition import preset_path

    raw = yaml.safe_load(preset_path("bluerov2-heavy").read_text())
    raw["name"] = name
    for t in raw["thrusters"]:
        t["model"] = model
    return raw


def test_limits_at_a_supply_voltage_follow_each_thrusters_own_model():
    """`hold --voltage` put the T200's limits on every thruster: eight laidani-a2212s (≈ 12 N)
    held a 16 V T200's current.  A thruster that is not a T200 takes its own chain's thrust at
    full command with its ESC at that supply; T200 thrusters keep the power model's."""
    import numpy as np

    from uuvid.thruster.presets import preset_chain
    from uuvid.vehicle.definition import vehicle_from_dict

    v = vehicle_from_dict(_preset_with("laidani-a2212"), "a2212.yaml")
    lim = limits_at(v, 12.0)
    f = preset_chain("laidani-a2212", 12.0).steady_thrust(np.array([-1e9, 1e9]))
    np.testing.assert_allclose(lim, np.tile([f.min(), f.max()], (8, 1)), rtol=1e-12)
    assert lim[0, 1] < 0.4 * limits_at(load_vehicle("bluerov2-heavy"), 12.0)[0, 1]  # 12 N vs 37 N
    mixed = _preset_with("t200")
    mixed["thrusters"][0]["model"] = "laidani-a2212"
    lim_m = limits_at(vehicle_from_dict(mixed, "mixed.yaml"), 12.0)
    np.testing.assert_array_equal(lim_m[0], lim[0])
    np.testing.assert_array_equal(lim_m[1:], limits_at(load_vehicle("bluerov2-heavy"), 12.0)[1:])


def test_a_battery_hold_refuses_thrusters_its_power_model_does_not_describe():
    from uuvid.analysis.hold import hold_on_battery
    from uuvid.vehicle.definition import vehicle_from_dict

    v = vehicle_from_dict(_preset_with("laidani-a2212"), "a2212.yaml")
    with pytest.raises(ValueError, match=r"thruster power model t200-physical \(the T200 "
                                         r"preset's\), and thrusters T1_front_right, .* "
                                         r"\(laidani-a2212\) have another model.*--voltage V"):
        hold_on_battery(v, [0.2, 0.0, 0.0], 0.5)


def test_a_t200_model_file_is_the_t200_and_a_model_without_esc_keeps_its_file_limits(tmp_path):
    """A file `thruster export t200` wrote is the T200 the power model describes (it was refused
    by name); a thruster without an ESC (ROMEO's c_V V|V|) keeps the vehicle file's limits at a
    supply voltage, said — it was given the T200's, silently."""
    import numpy as np

    from uuvid.analysis.hold import hold_on_battery
    from uuvid.thruster.modelfile import save_chain
    from uuvid.thruster.presets import preset_chain
    from uuvid.vehicle.definition import vehicle_from_dict
    from uuvid.vehicle.power import SupplyVoltageWarning

    save_chain(preset_chain("t200"), tmp_path / "t200_file.yaml")
    raw = _preset_with(str(tmp_path / "t200_file.yaml"))
    v = vehicle_from_dict(raw, "t200file.yaml")
    np.testing.assert_array_equal(limits_at(v, 14.0), limits_at(load_vehicle("bluerov2-heavy"), 14.0))
    hold_on_battery(v, [0.1, 0.0, 0.0], 0.8)  # not refused
    romeo = load_vehicle("romeo")
    with pytest.warns(SupplyVoltageWarning, match=r"their models have no ESC.*the vehicle file's "
                                                  r"limits are used at 14 V"):
        np.testing.assert_array_equal(limits_at(romeo, 14.0), np.asarray(romeo.layout.limits))


def test_an_unknown_battery_power_model_is_refused_when_the_file_is_read():
    """A fitted model file as `battery.thruster_power_model` loaded, then `hold --battery` died
    with a KeyError traceback."""
    from uuvid.vehicle.definition import VehicleFileError, vehicle_from_dict

    raw = _preset_with("t200")
    raw["battery"]["thruster_power_model"] = "m12_physical.yaml"
    with pytest.raises(VehicleFileError, match=r"x\.yaml: battery\.thruster_power_model "
                                               r"'m12_physical\.yaml': unknown; the thruster power "
                                               r"models are t200-physical"):
        vehicle_from_dict(raw, "x.yaml")


def test_a_hold_the_battery_cannot_give_says_so_not_the_attitude():
    """On a nearly empty battery every angle said 'holds nothing … no statically stable roll/pitch
    balance': the loaded voltage below the battery's minimum is the reason, and said so; SOC 0
    itself is a state of charge (the endurance run steps down to it), not an error."""
    from uuvid.analysis.hold import hold_on_battery

    v = load_vehicle("bluerov2-heavy")
    vmax, info = hold.max_current(v, 0.0, soc=0.001, stability=False)
    assert vmax == 0.0 and info["limit"] == "battery", info
    assert "below the minimum" in info["reason"] and "roll/pitch" not in info["reason"], info
    h = hold_on_battery(v, (0.0, 0.0, 0.0), 0.0)
    assert not h.held and h.battery_limit.startswith("loaded voltage")
    for soc in (-0.1, float("nan"), 1.5):
        with pytest.raises(ValueError, match="expected a state of charge within 0..1"):
            hold_on_battery(v, (0.3, 0.0, 0.0), soc)
