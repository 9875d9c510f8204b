"""A new user's report (items 1 and 4): a heading in radians read with ``--angle-unit deg`` is said (steady and
inertia), a negative installation coefficient η is a warning, and a drag file without ``k_q`` or
with a drag that dominates the command by orders of magnitude is said so."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from uuvid.examples import write_examples
from uuvid.identify.vehicle.logs import LogSpec, heading_unit_warnings, read_vehicle_log
from uuvid.identify.vehicle.procedures import eta_warnings, identify_inertia, identify_steady

READ = {"command_col": "torque", "position_col": "heading_deg", "angle_unit": "deg"}


@pytest.fixture(scope="module")
def examples(tmp_path_factory):
    d = tmp_path_factory.mktemp("ex43")
    write_examples(["yaw-steady", "yaw-sine"], d)
    for name in ("yaw_steady", "yaw_sine"):
        t = pd.read_csv(d / f"{name}.csv")
        t["heading_deg"] = np.radians(t["heading_deg"])
        t.to_csv(d / f"{name}_rad.csv", index=False)
    return d


def _wrapping_radians(n=600, dt=0.1):
    t = np.arange(n) * dt
    return t, np.mod(0.3 * t, 2 * np.pi)  # rad, wrapped to [0, 2π)


def test_radians_read_as_degrees_is_said_synthetic():
    t, rad = _wrapping_radians()
    w = heading_unit_warnings(t, np.radians(rad), "deg", "heading_deg", "yaw")
    assert len(w) == 1 and "wraps at 2π" in w[0] and "--angle-unit rad" in w[0]
    assert "heading_deg" in w[0] and "6.28" in w[0]


def test_degrees_and_radians_given_right_are_not_said():
    t, rad = _wrapping_radians()
    assert heading_unit_warnings(t, rad, "rad", "h", "yaw") == []  # radians read as radians
    deg = np.degrees(rad)
    assert heading_unit_warnings(t, np.radians(deg), "deg", "h", "yaw") == []
    small = 3 * np.sin(0.5 * t)  # a small yaw test in degrees (±3°, no wraps)
    assert heading_unit_warnings(t, np.radians(small), "deg", "h", "yaw") == []
    assert heading_unit_warnings(t, np.radians(rad), "deg", "z", "heave") == []


def test_read_vehicle_log_warns_on_a_csv(tmp_path):
    t, rad = _wrapping_radians()
    p = tmp_path / "h.csv"
    pd.DataFrame({"time": t, "torque": np.ones_like(t), "heading_deg": rad}).to_csv(p, index=False)
    data = read_vehicle_log(LogSpec(p, "yaw", **READ))
    assert any("wraps at 2π" in w for w in data.warnings), data.warnings


def test_negative_eta_is_a_warning():
    params = {"k": {"estimate": 20.0, "sigma": 1.0},
              "eta_a_neg": {"estimate": -0.11, "sigma": 0.15},
              "eta_b": {"estimate": 0.6, "sigma": 0.01}}
    w = eta_warnings(params, "yaw")
    assert len(w) == 1 and "eta_a_neg" in w[0] and "backwards" in w[0]


def test_steady_on_radians_read_as_degrees_warns(examples):
    res = identify_steady(examples / "yaw_steady_rad.csv", "yaw", mode_col="mode",
                          open_water=["yaw_fl_rr+"], **READ)
    ws = res.document["warnings"]
    assert any("wraps at 2π" in w and "--angle-unit rad" in w for w in ws), ws
    assert any("installation coefficient" in w for w in ws), ws
    assert "wraps at 2π" in res.summary()


def test_steady_in_degrees_has_no_such_warning(examples):
    res = identify_steady(examples / "yaw_steady.csv", "yaw", mode_col="mode",
                          open_water=["yaw_fl_rr+"], **READ)
    ws = res.document["warnings"]
    assert not any("wraps at 2π" in w or "installation coefficient" in w for w in ws), ws


def test_inertia_on_radians_read_as_degrees_warns(examples):
    res = identify_inertia(examples / "yaw_sine_rad.csv", "yaw", k=19.1, k_q=0.0, **READ)
    assert any("wraps at 2π" in w for w in res.document["warnings"])


def test_drag_without_k_q_is_said(examples, tmp_path):
    p = tmp_path / "drag_noq.json"
    p.write_text(json.dumps({"k": 19.1}))
    res = identify_inertia(examples / "yaw_sine.csv", "yaw", drag=str(p), **READ)
    said = res.document["warnings"] + res.document["notes"]
    assert any("k_q not given" in m and "0 assumed" in m for m in said), said
    assert "k_q not given" in res.summary()
    p.write_text(json.dumps({"k": 19.1, "k_q": 0}))  # given as 0: nothing said
    res = identify_inertia(examples / "yaw_sine.csv", "yaw", drag=str(p), **READ)
    assert not any("k_q not given" in m for m in res.document["warnings"] + res.document["notes"])


def test_drag_that_dominates_the_command_is_said(examples, tmp_path):
    p = tmp_path / "drag_big.json"
    p.write_text(json.dumps({"k": 1e12, "k_q": 0}))
    res = identify_inertia(examples / "yaw_sine.csv", "yaw", drag=str(p), **READ)
    ws = res.document["warnings"]
    assert any("implausible drag for this record" in w for w in ws), ws
    assert not any("opposite signs" in w for w in ws), ws
    res = identify_inertia(examples / "yaw_sine.csv", "yaw", k=19.1, k_q=0.0, **READ)
    assert not any("implausible drag" in w for w in res.document["warnings"])


def test_small_steps_in_degrees_are_not_called_radians_and_every_degree_alias_is_checked():
    """A ±3° yaw step at 5 Hz spans ≈ 6° and 'jumps' by ≈ 6 between two samples, but does not
    move between them as a turning heading in radians does; '°' and 'cdeg' are degree units too."""
    import math

    import numpy as np

    from uuvid.identify.vehicle.logs import heading_unit_warnings

    t = np.arange(0.0, 20.0, 0.2)
    step = np.where((t > 5) & (t < 12), 3.05, -3.05) * math.pi / 180
    assert heading_unit_warnings(t, step, "deg", "heading", "yaw") == []
    rad = np.linspace(0.0, 20.0, t.size) % (2 * math.pi)  # a turning heading in radians
    for unit, f in (("°", math.pi / 180), ("cdeg", math.pi / 18000)):
        w = heading_unit_warnings(t, rad * f, unit, "heading", "yaw")
        assert len(w) == 1 and "radians?" in w[0], (unit, w)
