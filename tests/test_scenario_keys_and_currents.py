"""Scenario keys and files a new user got silently wrong (fix-f2, items 2-4): controller gains
that did nothing, a current CSV whose typo'd or duplicated columns were dropped, implausible
vertical currents and depths accepted without a word."""

import math
import warnings

import numpy as np
import pytest

from uuvid.simulate.scenario import ScenarioError, scenario_from_dict

GAINS = [1.0, 1.0, 1.0, 1.0]


@pytest.mark.parametrize("controller, said", [
    ({"kd": [1000, 1000, 1000, 1000]}, r"controller: kd: given without kp.*ki/kd need kp"),
    ({"ki": GAINS}, r"controller: ki: given without kp.*ki/kd need kp"),
    ({"kind": "lqr", "bandwidth": GAINS}, r"controller: bandwidth: only with kind: pid"),
    ({"kind": "lqr", "kp": GAINS}, r"controller: kp: only with kind: pid"),
    ({"kind": "lqr", "kp": GAINS, "kd": GAINS}, r"controller: kp, kd: only with kind: pid"),
    ({"kp": GAINS, "bandwidth": GAINS}, r"controller: bandwidth and kp are exclusive"),
])
def test_controller_gains_that_would_do_nothing_are_refused(controller, said):
    """`{kd: [1000]*4}` flew exactly as `{kd: [0]*4}` (no kp: the bandwidth's gains); an lqr with
    bandwidth or kp flew the LQI unchanged; kp beside bandwidth dropped the bandwidth."""
    with pytest.raises(ScenarioError, match=said):
        scenario_from_dict({"controller": controller}, where="s.yaml")


@pytest.mark.parametrize("controller", [
    {"kp": GAINS, "kd": GAINS}, {"kp": GAINS}, {"bandwidth": GAINS}, {"kind": "lqr"},
    {"kind": "pid", "kp": GAINS, "ki": GAINS, "kd": GAINS},
])
def test_controller_gains_that_fly_are_still_taken(controller):
    scenario_from_dict({"controller": controller}, where="s.yaml")


@pytest.mark.parametrize("text, said", [
    ("time,north,east,dwn\n0,0,0,0.5\n10,0,0,0.5\n",
     r"c\.csv: unknown column 'dwn'; expected time, north, east and optionally down"),
    ("time,north,east,east\n0,0,0,0.5\n10,0,0,0.5\n", r"c\.csv: column 'east' given twice"),
    ("time,North,east,north\n0,0,0,0\n10,0,0,0\n", r"c\.csv: column 'north' given twice"),
    ("time,north,east\n0,abc,0\n10,0,0\n",
     r"c\.csv: row 1 \(line 2\), column 'north': 'abc' is not a number"),
    ("time,north,east\n0,0,0\n10,,0\n", r"c\.csv: row 2 \(line 3\), column 'north': empty"),
    ("time,north,east\n0,0,0\n10,nan,0\n", r"c\.csv: row 2 \(line 3\), column 'north': NaN"),
    ("time,north,east,down\n0,0,0,0\n10,0,0,inf\n",
     r"c\.csv: row 2 \(line 3\), column 'down': inf is not finite"),
    ("time,north\n0,0\n10,0\n", r"c\.csv: missing column 'east'"),
])
def test_a_current_csv_with_a_bad_column_or_cell_is_refused_naming_it(tmp_path, text, said):
    """`dwn` flew with no vertical current, a second `east` was dropped, and `abc` said only
    "could not convert string to float: 'abc'" — no file, row or column."""
    from uuvid.simulate.currents import TimeSeriesCurrent

    p = tmp_path / "c.csv"
    p.write_text(text)
    with pytest.raises(ValueError, match=said):
        TimeSeriesCurrent.from_csv(p)


def test_a_good_current_csv_still_loads(tmp_path):
    from uuvid.simulate.currents import TimeSeriesCurrent

    p = tmp_path / "c.csv"
    p.write_text(" Time , North,east,DOWN\n0,0.1,0,0\n10,0.2,0.1,0.05\n")
    c = TimeSeriesCurrent.from_csv(p)
    np.testing.assert_allclose(c.velocity[1], [0.2, 0.1, 0.05])
    p.write_text("time,north,east\n0,0.1,0\n10,0.2,0.1\n")  # down optional: zero
    assert np.all(TimeSeriesCurrent.from_csv(p).velocity[:, 2] == 0)


def _scenario(tmp_path, text):
    from uuvid.simulate.scenario import build, load_scenario

    p = tmp_path / "s.yaml"
    p.write_text(text)
    return build(load_scenario(p), tmp_path)


def test_a_current_series_shorter_than_the_flight_is_warned_of(tmp_path):
    from uuvid.core.checks import InputWarning

    (tmp_path / "c.csv").write_text("time,north,east\n0,0,0\n5,0.2,0.1\n")
    with pytest.warns(InputWarning, match=r"c\.csv covers 0–5 s of a 20 s flight.*held at its "
                                          r"last values from 5 s"):
        _scenario(tmp_path, "vehicle: bluerov2\ncurrent: {kind: timeseries, file: c.csv}\n"
                            "duration: 20\n")
    (tmp_path / "c.csv").write_text("time,north,east\n0,0,0\n30,0.2,0.1\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error", InputWarning)
        _scenario(tmp_path, "vehicle: bluerov2\ncurrent: {kind: timeseries, file: c.csv}\n"
                            "duration: 20\n")


@pytest.mark.parametrize("current, said", [
    ([0.0, 0.0, 3.0], r"current: down: 3 m/s: a vertical current beyond 1 m/s"),
    ([0.0, 0.0, -1.5], r"current: down: -1.5 m/s: a vertical current beyond 1 m/s"),
    ({"kind": "constant", "speed": 0.2, "down": 3.0},
     r"current: down: 3 m/s: a vertical current beyond 1 m/s"),
])
def test_a_vertical_current_no_ocean_has_is_refused(current, said):
    """3 m/s down was flown without a word while horizontal currents stop at 6 m/s."""
    with pytest.raises(ScenarioError, match=said):
        scenario_from_dict({"current": current}, where="s.yaml")
    scenario_from_dict({"current": [0.3, 0.0, 0.05]}, where="s.yaml")  # an upwelling: flown


def test_a_vertical_current_in_a_series_names_its_row(tmp_path):
    from uuvid.simulate.currents import TimeSeriesCurrent

    p = tmp_path / "c.csv"
    p.write_text("time,north,east,down\n0,0,0,0\n10,0,0,2.5\n")
    with pytest.raises(ValueError, match=r"c\.csv: row 2 \(line 3\), column 'down': 2\.5 m/s: a "
                                         r"vertical current beyond 1 m/s"):
        TimeSeriesCurrent.from_csv(p)


@pytest.mark.parametrize("mission, said", [
    ({"depth": 10000.0 * 1.2}, r"mission.depth: 12000 m is deeper than the deepest ocean"),
    ({"kind": "waypoints", "waypoints": [[0, 0, 0, 0], [0, 0, 12000, 0]]},
     r"waypoint 1 is at down = 12000 m, deeper than the deepest ocean"),
])
def test_a_depth_below_the_ocean_floor_is_refused(mission, said):
    with pytest.raises(ScenarioError, match=said):
        scenario_from_dict({"mission": mission}, where="s.yaml")
    scenario_from_dict({"mission": {"depth": 10000}}, where="s.yaml")  # the Mariana Trench: flown


def test_the_step_limit_says_the_exact_step_count():
    """"duration = 20012 s … is 2e+06 steps, more than the 2,000,000" hid why."""
    from uuvid.simulate.vehicle_sim import step_count

    with pytest.raises(ValueError, match=r"duration = 20012 s at dt = 0\.01 s is 2,001,200 steps, "
                                         r"more than the 2,000,000"):
        step_count(20012.0, 0.01, "duration", "dt")
    assert math.isfinite(step_count(20000.0, 0.01, "duration", "dt"))


@pytest.mark.parametrize("ctrl", [
    {}, {"bandwidth": GAINS}, {"kp": GAINS, "ki": GAINS}, {"kind": "lqr", "weights": {"position": 0.1}},
    {"kind": "lqr"}])
def test_a_controller_spec_rechecks_as_itself_after_a_dump(ctrl):
    """A sweep or Monte Carlo worker rebuilds the scenario from ``model_dump``: a dump writes every
    field, so the default bandwidth once read as given and refused kp/lqr specs on every run."""
    from uuvid.simulate.scenario import ControllerSpec

    s = ControllerSpec.model_validate(ctrl)
    again = ControllerSpec.model_validate(s.model_dump(mode="json"))
    assert again == s


def test_a_spreadsheets_trailing_comma_is_no_column(tmp_path):
    """Exports that end every line with a comma read as before the CSV checks (pandas ignored the
    unnamed empty column); a named column's empty cell is still refused."""
    from uuvid.simulate.currents import TimeSeriesCurrent

    p = tmp_path / "c.csv"
    p.write_text("time,north,east,\n0,0.1,0,\n10,0.2,0,\n")
    c = TimeSeriesCurrent.from_csv(p)
    assert np.array_equal(c.velocity, [[0.1, 0, 0], [0.2, 0, 0]])
    p.write_text("time,north,east,\n0,0.1,,\n10,0.2,0,\n")
    with pytest.raises(ValueError, match="row 1"):
        TimeSeriesCurrent.from_csv(p)


@pytest.mark.parametrize("scenario", [
    {"vehicle": "bluerov2", "mission": {"kind": "waypoints", "waypoints": [[0, 0, 1, 0], [2, 0, 1, 0]]},
     "duration": 5},
    {"vehicle": "bluerov2", "mission": {"kind": "square", "depth": 3}, "duration": 5,
     "controller": {"kind": "lqr"}},
    {"vehicle": "bluerov2", "duration": 5, "controller": {"kp": GAINS, "kd": GAINS},
     "current": [0.2, 0.0, 0.0]}])
def test_a_scenario_rechecks_as_itself_after_a_dump(scenario):
    """Sweeps, Monte Carlo and ``vehicle hold`` rebuild a scenario from its ``model_dump``: every
    field is written there, so a check of what the file 'gave' must go by value (a waypoint
    mission's default depth, side and yaw were refused on every run)."""
    s = scenario_from_dict(scenario)
    again = scenario_from_dict(s.model_dump(mode="json"))
    assert again == s
