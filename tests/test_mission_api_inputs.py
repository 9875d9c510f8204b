"""setup_mission / fly_mission from a notebook: bad arguments are named before the compiled loop
runs (it cannot be interrupted), and results do not share arrays with the setup they came from."""

from __future__ import annotations

import numpy as np
import pytest

from uuvid.simulate.reference import square_mission
from uuvid.simulate.vehicle_sim import MAX_INTEGRATION_STEPS, MAX_SUBSTEPS, fly_mission, setup_mission
from uuvid.vehicle.definition import load_vehicle


@pytest.fixture(scope="module")
def rov():
    return load_vehicle("bluerov2")


@pytest.fixture(scope="module")
def mission():
    return square_mission(speed=0.3)


@pytest.mark.parametrize("kw, err, words", [
    (dict(substeps=10**9), ValueError, ["substeps", f"{MAX_SUBSTEPS:,}"]),
    (dict(substeps=MAX_SUBSTEPS), ValueError, ["substeps", "RK4 steps", f"{MAX_INTEGRATION_STEPS:,}"]),
    (dict(substeps=2.5), ValueError, ["substeps", "whole"]),
    (dict(substeps="2"), TypeError, ["substeps"]),
    (dict(substeps=0), ValueError, ["substeps"]),
    (dict(dt="0.01"), TypeError, ["dt"]),
    (dict(dt=None), TypeError, ["dt"]),
    (dict(dt=float("nan")), ValueError, ["dt"]),
    (dict(current="0.3,0,0"), TypeError, ["current"]),
    (dict(current=None), TypeError, ["current"]),
    (dict(max_steps=-1), ValueError, ["max_steps", ">= 1"]),
    (dict(max_steps="10"), TypeError, ["max_steps"]),
    (dict(t_end="5"), TypeError, ["t_end"]),
    (dict(gains={"kp": 1}), TypeError, ["gains", "DPGains"]),
])
def test_setup_mission_names_the_bad_argument(rov, mission, kw, err, words):
    with pytest.raises(err) as e:
        setup_mission(rov, mission, **kw)
    for w in words:
        assert w in str(e.value)


@pytest.mark.parametrize("bad", [None, [1, 2], 3.0])
def test_setup_mission_mission_type(rov, bad):
    with pytest.raises(TypeError, match="mission: expected a WaypointMission"):
        setup_mission(rov, bad)


@pytest.mark.parametrize("bad", [None, 3, object()])
def test_setup_mission_vehicle_type(mission, bad):
    with pytest.raises(TypeError, match="vehicle: expected a Vehicle"):
        setup_mission(bad, mission)


def test_setup_mission_takes_a_preset_name(rov, mission):
    s = setup_mission("bluerov2", mission)
    assert s.vehicle.name == rov.name
    np.testing.assert_array_equal(s.B, setup_mission(rov, mission).B)


def test_fly_mission_names_its_argument(rov):
    with pytest.raises(TypeError, match="setup: expected a MissionSetup"):
        fly_mission(rov)


def test_mission_result_does_not_share_the_setup_arrays(rov):
    s = setup_mission(rov, square_mission(speed=0.3), t_end=2.0)
    r = fly_mission(s)
    t0, p0, y0 = float(r.t[0]), float(r.ref_pos[0, 0]), float(r.ref_yaw[0])
    r.t[0], r.ref_pos[0, 0], r.ref_yaw[0] = 99.0, 99.0, 99.0
    r2 = fly_mission(s)
    assert (r2.t[0], r2.ref_pos[0, 0], r2.ref_yaw[0]) == (t0, p0, y0)
    assert s.t[0] == t0 and s.ref[0][0, 0] == p0
