"""Vehicle files a new user wrote that load but cannot be flown as written: thrust limits no
thruster has, no drag in a DOF, a dead or one-way thruster (new-user test, items 5–7)."""

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
