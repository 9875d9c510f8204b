"""Numbers of the Python API given as text (or None, a bool) are refused at the call, with the
argument's name and what is expected: ``square_mission(speed="0.3")`` was stored and failed when the
mission was set up (``unsupported operand type(s) for /: 'float' and 'str'``), a chain's
``simulate(t_end="1.3")`` said ``must be real number, not str`` without naming t_end."""

import math

import pytest

from uuvid.core.checks import real
from uuvid.simulate.reference import WaypointMission, square_mission

WPS = ((0.0, 0.0, 0.0, 0.0), (1.0, 0.0, 1.0, 0.0))


@pytest.mark.parametrize("kw, name", [
    ({"speed": "0.3"}, "speed"), ({"depth": "2"}, "depth"), ({"side": "10"}, "side"),
    ({"vertical_speed": "0.25"}, "vertical_speed"), ({"hold": None}, "hold"),
    ({"speed": True}, "speed"),
])
def test_square_mission_refuses_text_naming_the_argument(kw, name):
    with pytest.raises(TypeError, match=rf"^{name} = .*expected a finite .*got "):
        square_mission(**kw)


@pytest.mark.parametrize("kw", [{"depth": math.inf}, {"side": math.nan}, {"speed": math.nan}])
def test_square_mission_refuses_non_finite(kw):
    (name,) = kw
    with pytest.raises(ValueError, match=rf"^{name} = .*finite"):
        square_mission(**kw)


@pytest.mark.parametrize("field", ["speed", "vertical_speed", "yaw_rate", "ramp_time", "hold"])
def test_waypoint_mission_fields_refuse_text(field):
    with pytest.raises(TypeError, match=rf"^{field} = '1': expected a finite number"):
        WaypointMission(WPS, **{field: "1"})


def test_waypoint_mission_refuses_a_waypoint_given_as_text():
    with pytest.raises(TypeError, match=r"waypoints\[1\]\[2\] = '1'"):
        WaypointMission(((0.0, 0.0, 0.0, 0.0), (1.0, 0.0, "1", 0.0)))


def test_numbers_of_any_real_type_still_fly():
    np = pytest.importorskip("numpy")
    m = WaypointMission(((0, 0, np.float32(1), 0), (1, 0, 0, 0)), speed=np.float64(0.5), hold=5)
    assert m.duration > 5
    assert square_mission(depth=2, side=10, speed=0.3).duration > 0


@pytest.mark.parametrize("kw, name", [({"t_end": "1.3"}, "t_end"), ({"dt": "0.001"}, "dt"),
                                      ({"substeps": "4"}, "substeps"), ({"t_end": None}, "t_end")])
def test_chain_simulate_names_a_time_argument_given_as_text(kw, name):
    from uuvid.simulate.signals import Step
    from uuvid.thruster import presets

    ch = presets.PRESETS["t200"]()
    args = {"t_end": 0.2, **kw}
    with pytest.raises(TypeError, match=rf"^{name} = .*expected .*got "):
        ch.simulate(Step(24), **args)
    with pytest.raises(TypeError, match=rf"^{name} = "):
        ch.simulate_batch(ch.compile().params[None], Step(24), **args)


def test_chain_simulate_refuses_a_fractional_substeps():
    from uuvid.simulate.signals import Step
    from uuvid.thruster import presets

    with pytest.raises(ValueError, match=r"^substeps = 2.5: .*whole number"):
        presets.PRESETS["t200"]().simulate(Step(24), t_end=0.2, substeps=2.5)


def test_real_helper():
    assert real("x", 3) == 3
    with pytest.raises(TypeError, match="x = '3'"):
        real("x", "3")
    with pytest.raises(ValueError, match="whole number"):
        real("n", math.nan, "a count", integer=True)
    assert real("n", 4.0, "a count", integer=True) == 4.0


def test_open_loop_min_duration_is_checked(tmp_path):
    """``dive.open_loop(min_duration="5")`` raised a bare TypeError from a comparison, and NaN
    was taken silently (every stretch kept)."""
    pytest.importorskip("pymavlink")
    from test_ardusub import scenario, write_bin

    from uuvid.io.ardusub import load_dive

    d = load_dive(write_bin(tmp_path / "a.BIN", scenario(n=120)))
    with pytest.raises(TypeError, match=r"min_duration = '5': expected a finite number of seconds"):
        d.open_loop(min_duration="5")
    for bad in (math.nan, -1.0):
        with pytest.raises(ValueError, match="min_duration"):
            d.open_loop(min_duration=bad)
    assert d.open_loop(min_duration=2.0)[0].sum() > 0
