"""Vehicle files a new user wrote that load but cannot be flown as written: thrust limits no
thruster has, no drag in a DOF, a dead or one-way thruster (new-user test, items 5–7)."""

import copy
import warnings

import pytest
import yaml

from uuvid.vehicle import VehicleFileError, definition, vehicle_from_dict
from uuvid.vehicle.definition import preset_path


def bluerov2_raw() -> dict:
    return yaml.safe_load(preset_path("bluerov2").read_text())


def build(raw, where="v.yaml"):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return vehicle_from_dict(raw, where=where)


def test_thrust_limits_no_thruster_has_are_refused_naming_file_thruster_and_value():
    raw = bluerov2_raw()
    for t in raw["thrusters"]:
        t["limits"] = [-1e300, 1e300]
    with pytest.raises(VehicleFileError) as e:
        build(raw, "limits_huge.yaml")
    text = str(e.value)
    assert "limits_huge.yaml: thrusters[0].limits: T1_front_right" in text
    assert "1e+300" in text and f"{definition.MAX_THRUST_N:g} N" in text and "expected" in text


def test_thrust_limits_of_a_real_thruster_load():
    raw = bluerov2_raw()
    raw["thrusters"][0]["limits"] = [-5e4, 5e4]
    build(raw)  # large, but a thruster can give it


def _envelope(raw):
    from uuvid.vehicle.envelope import speed_envelope

    return speed_envelope(build(raw))


def test_a_dead_thruster_is_left_out_of_the_allocation_and_said_on_load():
    raw = bluerov2_raw()
    raw["thrusters"][0]["limits"] = [0.0, 0.0]
    with pytest.warns(UserWarning, match=r"dead\.yaml: thrusters\[0\] \(T1_front_right\): limits "
                      r"\[0, 0\] N: gives no thrust either way; the allocation leaves it out"):
        vehicle_from_dict(copy.deepcopy(raw), where="dead.yaml")
    env = _envelope(raw)
    for r in env.rows:  # the allocator gives what any thrust combination gives (it was 0 N)
        assert r.force > 0.0
        assert r.force_allocator == pytest.approx(r.force, rel=1e-6), r.direction
        assert r.makes_way, r.direction
    assert env["forward"].force_allocator == pytest.approx(72.81, abs=0.01)


@pytest.mark.parametrize("limits", [[-39.913, 0.0], [0.0, 51.485]])
def test_a_one_way_thruster_leaves_the_allocator_the_directions_other_mixes_give(limits):
    raw = bluerov2_raw()
    raw["thrusters"][0]["limits"] = limits
    env = _envelope(raw)
    for r in env.rows:  # uniform scaling of T φ gave 0 in half of these
        assert r.force_allocator == pytest.approx(r.force, rel=1e-6), r.direction
        assert r.makes_way, r.direction
    assert any("T1_front_right" in n and "bounded allocation" in n for n in env.notes)


def test_the_allocation_of_a_vehicle_without_dead_thrusters_is_unchanged():
    import numpy as np

    from uuvid.vehicle.allocation import constrained_allocation_matrix

    v = build(bluerov2_raw())
    al = v.allocator()
    T = constrained_allocation_matrix(v.B, al.controlled, None, np.zeros((0, v.layout.n)))
    assert np.array_equal(al.T, T)


def _no_drag_raw():
    raw = bluerov2_raw()
    raw["hydrodynamics"]["linear_damping"] = [0.0] * 6
    raw["hydrodynamics"]["quadratic_damping"] = [0.0] * 6
    return raw


def test_a_dof_without_drag_is_said_on_load():
    import re

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        vehicle_from_dict(_no_drag_raw(), where="zero_damp.yaml")
    said = [str(w.message) for w in caught]
    assert any(re.search(r"zero_damp\.yaml: hydrodynamics: no drag in surge, sway, heave, yaw "
                         r"\(linear_damping and quadratic_damping both 0 there\): the steady speed "
                         r"is unbounded.*expected positive damping", m) for m in said), said
    assert any("no drag in roll, pitch" in m for m in said), said


def test_without_drag_the_envelope_says_unbounded_not_inf_nor_the_other_way():
    from uuvid.analysis.envelope_check import confirm_envelope

    v = build(_no_drag_raw())
    check = confirm_envelope(v, simulate=False)
    env_rows = {r["direction"]: r for r in check.table_rows(("direction", "speed", "allocator_speed",
                                                             "limit", "note"))}
    for direction, r in env_rows.items():
        if direction.startswith(("roll", "nose")):
            continue
        assert r["speed"] == r["allocator_speed"] == "unbounded (no drag)", r
        assert "inf" not in r["limit"] and "cannot" not in r["limit"], r
        assert "no drag" in r["limit"] and "damping" in r["note"], r
    assert not check.warnings()  # no "cannot go backward: goes forward at inf m/s"


def test_without_drag_stability_says_why_it_has_no_case():
    from uuvid.vehicle.stability import static_stability

    res = static_stability(build(_no_drag_raw()))
    assert not res.cases
    assert any("no stability case for forward, backward" in n and "no drag" in n
               for n in res.notes)


def test_without_drag_a_mission_does_not_say_the_vehicle_stays_level():
    from uuvid.simulate.reference import cruise_speed

    speed, note = cruise_speed(build(_no_drag_raw()))
    assert "stays level there" not in note
    assert "no drag in surge" in note and "not known" in note


def test_one_rule_says_which_thrusters_are_dead():
    """A dead thruster (limits [0, 0]) was recognised in three places — the allocation (left out
    of T), the vehicle file's warnings and the envelope's one-way thrusters — each with its own
    expression; one function now, and all three agree with it."""
    import numpy as np

    from uuvid.vehicle.allocation import dead_thrusters
    from uuvid.vehicle.envelope import one_way_thrusters

    inf = np.inf
    lim = np.array([[0.0, 0.0], [-inf, inf], [0.0, 5.0], [-3.0, 0.0], [-0.0, 0.0], [-1.0, 2.0]])
    assert dead_thrusters(lim).tolist() == [0, 4]
    assert one_way_thrusters(lim) == [2, 3]  # one side zero, not both
    assert dead_thrusters(np.zeros((0, 2))).tolist() == []
    raw = bluerov2_raw()
    for i in (1, 4):
        raw["thrusters"][i]["limits"] = [0.0, 0.0]
    v = build(raw)
    assert dead_thrusters(v.layout.limits).tolist() == [1, 4]
    al = v.allocator()
    assert np.allclose(al.T[[1, 4]], 0.0) and not np.allclose(al.T[[0, 2, 3, 5]], 0.0)
    said = definition._dead_thruster_warnings(v)
    assert len(said) == 1 and said[0].startswith("thrusters[1] (") and ", thrusters[4] (" in said[0]
