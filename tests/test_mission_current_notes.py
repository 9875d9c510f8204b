"""A new user's report: what a mission says of a current too strong for the vehicle, and the propeller map's
assumptions beside every number computed with inflow."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app

runner = CliRunner()

T200_LINE = ("propeller map: Wageningen B4-70 P/D 1.0, D = 76 mm (T200 diameter and P/D assumed, "
             "not measured)")


@pytest.fixture(scope="module")
def bluerov2():
    from uuvid.vehicle.definition import load_vehicle

    return load_vehicle("bluerov2")


@pytest.fixture(scope="module")
def heavy():
    from uuvid.vehicle.definition import load_vehicle

    return load_vehicle("bluerov2-heavy")


# --- 1: a current past the level-flight limit is not "nearly" reaching it ------------------------

def _formula_speed(note):
    """The speed a note's "X% of the limit L m/s less the C m/s current" formula gives, if any."""
    m = re.search(r"(\d+)% of the .*?level-flight limit ([\d.]+) m/s less the ([\d.]+) m/s", note)
    return None if m is None else round(int(m[1]) / 100 * float(m[2]) - float(m[3]), 2)


def test_a_current_past_the_level_limit_says_the_mission_cannot_be_flown(bluerov2):
    from uuvid.simulate.reference import MIN_SPEED, cruise_speed

    speed, note = cruise_speed(bluerov2, True, 3.0)
    assert speed == MIN_SPEED
    assert "nearly" not in note and "less the 3.00" not in note  # the old −2.62 "formula"
    assert "exceeds the bluerov2's level-flight limit 0.48 m/s" in note
    assert "top speed 2.56 m/s" in note and "cannot be flown as planned" in note
    assert f"floor speed {MIN_SPEED:g} m/s" in note
    # between the limit and the top speed: no top speed claimed
    _, note = cruise_speed(bluerov2, True, 1.0)
    assert "exceeds" in note and "top speed" not in note


@pytest.mark.parametrize("cur", [0.0, 0.1, 0.2, 0.3, 0.4, 0.47])
def test_a_printed_formula_always_gives_the_speed_flown(bluerov2, cur):
    from uuvid.simulate.reference import cruise_speed

    speed, note = cruise_speed(bluerov2, True, cur)
    assert note.startswith(f"speed {speed:g} m/s")
    got = _formula_speed(note)
    if got is not None and "the floor" not in note:
        assert got == pytest.approx(speed)
    if "the floor" in note:  # clamped: it says what the formula leaves, not that it is the speed
        assert "leaves" in note


def test_a_gauss_markov_current_whose_max_passes_the_limit_is_said_so(bluerov2):
    from uuvid.simulate.currents import GaussMarkovCurrent
    from uuvid.simulate.reference import cruise_speed, current_speed_bound

    gm = GaussMarkovCurrent(mean=1.5, sigma=0.05, min=1.0, max=3.0)
    bound = current_speed_bound(gm)
    assert bound > 0.48
    speed, note = cruise_speed(bluerov2, True, bound)
    assert speed == 0.1 and "nearly" not in note and "cannot be flown as planned" in note


# --- 2: a current faster than the vehicle can hold is named -------------------------------------

def test_a_current_faster_than_the_heavy_flies_is_named(heavy, bluerov2):
    from uuvid.simulate.reference import current_limit_warning

    w = current_limit_warning(heavy, 1.5)
    assert "1.50 m/s" in w and "top speed 0.91 m/s" in w and "`uuvid vehicle hold bluerov2-heavy`" in w
    assert current_limit_warning(heavy, 0.2) == ""
    assert current_limit_warning(bluerov2, 0.2) == ""
    assert current_limit_warning(bluerov2, 0.0) == ""
    w = current_limit_warning(bluerov2, 1.0)  # flies it, but not level whichever way it faces
    assert "level-flight limit in every horizontal direction" in w


def test_flying_the_heavy_into_a_fast_current_warns_first(heavy):
    from uuvid.simulate.reference import WaypointMission
    from uuvid.simulate.vehicle_sim import fly_mission, setup_mission

    m = WaypointMission(((0, 0, 1, 0), (3, 0, 1, 0)), speed=0.3, name="short")
    s = fly_mission(setup_mission(heavy, m, current=np.array([-1.5, 0.0, 0.0]))).metrics
    assert s["warnings"][0].startswith("the current reaches 1.50 m/s, faster than the bluerov2-heavy")


def _top_speeds(vehicle):
    """(bollard, four-quadrant inflow) top speed over the horizontal directions, m/s."""
    from uuvid.vehicle.envelope import speed_envelope

    dirs = ("forward", "backward", "starboard", "port")
    return tuple(max(abs(r.speed) for r in speed_envelope(vehicle, inflow=inf).rows
                     if r.direction in dirs) for inf in ("none", "four-quadrant"))


def test_with_inflow_a_current_past_the_inflow_top_speed_is_named(heavy):
    """With four-quadrant inflow the thrust falls with the water speed: the Heavy holds 0.87 m/s,
    not its bollard 0.91 m/s.  A current between the two was not warned of with inflow on."""
    from uuvid.simulate.reference import current_limit_warning

    dry, wet = _top_speeds(heavy)
    assert wet < dry - 0.02
    cur = 0.5 * (wet + dry)
    assert current_limit_warning(heavy, cur) == ""  # inflow off: the bollard top speed holds it
    assert current_limit_warning(heavy, cur, "none") == ""
    w = current_limit_warning(heavy, cur, "four-quadrant")
    assert w.startswith(f"the current reaches {cur:.2f} m/s, faster than the bluerov2-heavy"), w
    assert (f"top speed {wet:.2f} m/s with four-quadrant inflow, the thrust falling with the water "
            f"speed; {dry:.2f} m/s at bollard thrust") in w
    assert current_limit_warning(heavy, 0.5 * wet, "four-quadrant") == ""  # below both: silent
    w = current_limit_warning(heavy, dry + 0.1)  # past both, inflow off: says bollard
    assert f"top speed {dry:.2f} m/s, bollard thrust" in w and "inflow" not in w


def test_a_mission_flown_with_inflow_warns_of_the_inflow_top_speed(heavy):
    from uuvid.simulate.reference import WaypointMission
    from uuvid.simulate.vehicle_sim import fly_mission, setup_mission

    dry, wet = _top_speeds(heavy)
    cur = 0.5 * (wet + dry)
    m = WaypointMission(((0, 0, 1, 0), (1, 0, 1, 0)), speed=0.2, name="short")
    said = {}
    for inflow in ("none", "four-quadrant"):
        s = setup_mission(heavy, m, current=np.array([-cur, 0.0, 0.0]), inflow=inflow, t_end=2.0)
        said[inflow] = fly_mission(s).metrics["warnings"]
    assert not any("faster than the bluerov2-heavy" in w for w in said["none"]), said["none"]
    assert said["four-quadrant"][0].startswith(f"the current reaches {cur:.2f} m/s"), said
    assert "with four-quadrant inflow" in said["four-quadrant"][0]


def test_the_square_in_a_light_current_stays_silent():
    res = runner.invoke(app, ["simulate", "mission", "square", "--current", "0.2,0,0", "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout[res.stdout.index("{"):])
    assert not any("current reaches" in w for w in doc["warnings"])


# --- 3: inflow numbers carry the propeller map's assumptions ------------------------------------

def test_the_propeller_line_names_assumed_and_measured_maps():
    from uuvid.thruster.inflow import map_from_section, t200_inflow
    from uuvid.vehicle.propeller_note import propeller_map_note

    assert propeller_map_note(t200_inflow().map, [0.0] * 8) == T200_LINE + (
        "; wake w = 0 for every thruster")
    sec = {"form": "four-quadrant", "diameter_m": 0.09,
           "parameters": {"a_0": {"estimate": 0.3}, "a_1": {"estimate": 0.1},
                          "b_1": {"estimate": -0.5}}}
    line = propeller_map_note(map_from_section(sec, "my_thruster.yaml: inflow"), [0.0, 0.1])
    assert "my_thruster.yaml" in line and "measured" in line and "assumed" not in line
    assert "D = 90 mm" in line and "wake w per thruster 0, 0.1" in line


@pytest.mark.slow
def test_envelope_and_stability_name_the_assumed_map(bluerov2):
    from uuvid.vehicle.envelope import speed_envelope
    from uuvid.vehicle.stability import static_stability

    assert any(n.startswith(T200_LINE) for n in speed_envelope(bluerov2, inflow="four-quadrant").notes)
    assert not any("propeller map:" in n for n in speed_envelope(bluerov2, inflow="none").notes)
    st = static_stability(bluerov2, inflow="four-quadrant")
    assert any(n.startswith(T200_LINE) for n in st.notes)


def test_a_mission_with_inflow_names_the_assumed_map(bluerov2):
    from uuvid.simulate.mission_report import mission_text
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import fly_mission, setup_mission

    m = square_mission(side=1.0, speed=0.3)
    r = fly_mission(setup_mission(bluerov2, m, inflow="four-quadrant"))
    assert r.metrics["propeller_map"].startswith(T200_LINE)
    assert T200_LINE in mission_text(r)
    off = fly_mission(setup_mission(bluerov2, m, inflow="none")).metrics
    assert "propeller_map" not in off


def test_hold_names_the_assumed_map(bluerov2):
    from uuvid.analysis import hold

    cap = hold.capability(bluerov2, step_deg=180, inflow="four-quadrant")
    assert T200_LINE in cap.summary() and cap.to_dict()["propeller_map"].startswith(T200_LINE)


def test_thruster_show_t200_names_its_map_and_inflow_coefficient():
    res = runner.invoke(app, ["thruster", "show", "t200"])
    assert res.exit_code == 0, res.output
    assert T200_LINE in res.output
    assert "inflow coefficient k_a" in res.output
