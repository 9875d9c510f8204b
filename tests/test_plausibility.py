"""Plausibility checks: a unit or sign mistake that gives a "valid" result is warned or refused."""

from __future__ import annotations

import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from uuvid.cli.app import app

runner = CliRunner()


def _predict(*args):
    res = runner.invoke(app, ["thruster", "predict", *map(str, args), "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


# ------------------------------------------------------------------ thruster predict
def test_duty_given_as_pwm_is_warned_with_the_expected_range():
    doc = _predict("t200", "--pwm", "0:1:0.25")
    (w,) = doc["warnings"]
    assert "1100–1900 µs" in w and "look like duties" in w


def test_pwm_in_range_has_no_warning():
    assert _predict("t200", "--pwm", "1100:1900:100")["warnings"] == []


@pytest.mark.parametrize("model", ["t200", "t200-physical"])
@pytest.mark.parametrize("volts, warned", [(48, True), (6, True), (12, False), (16, False),
                                           (16.8, False)])
def test_supply_voltage_outside_the_sheets_is_warned(model, volts, warned):
    doc = _predict(model, "--pwm", "1900", "--supply-voltage", volts)
    hit = [w for w in doc["warnings"] if "outside the data's 12–16 V" in w]
    assert bool(hit) == warned, doc["warnings"]


def test_supply_voltage_of_a_model_file_is_checked_against_its_esc(tmp_path):
    from uuvid.thruster.modelfile import save_chain
    from uuvid.thruster.presets import preset_chain

    p = save_chain(preset_chain("laidani-a2212"), tmp_path / "m.yaml")
    v0 = preset_chain("laidani-a2212").blocks[0].supply_voltage
    assert not [w for w in _predict(p, "--pwm", "1600", "--supply-voltage", v0)["warnings"]
                if "supply voltage" in w]
    doc = _predict(p, "--pwm", "1600", "--supply-voltage", 4 * v0)
    # a file records its ESC's voltage, not its data's: said as such (a physical model fitted on
    # both T200 sheets was said to be "outside the data's 12 V" at 14 V)
    assert any(f"differs from the {v0:g} V this model file's ESC is set for (the file does not "
               "record the voltages it was fitted at)" in w for w in doc["warnings"])
    assert not any("outside the data's" in w for w in doc["warnings"])


# ------------------------------------------------------------------ vehicle identification
def _pool_log(tmp_path, name, *, heading_sign=1.0, heading_scale=1.0, time_scale=1.0):
    """Constant-torque yaw segments of ROMEO (Caccia et al. 2000), heading in rad × scale."""
    import csv

    import numpy as np

    from uuvid.identify.vehicle.fit import simulate_one_dof
    from uuvid.vehicle.model import OneDofModel

    dt, seg = 0.1, 30.0
    rng = np.random.default_rng(0)
    f = np.concatenate([np.full(int(seg / dt), L) for L in (2.0, 5.0, 9.0, 14.0, -3.0, -7.0,
                                                          -12.0, -18.0)])
    t = np.arange(f.size) * dt
    r = simulate_one_dof(OneDofModel(84.0, 20.5, 49.5), t, f)
    psi = np.concatenate([[0.0], np.cumsum(0.5 * (r[1:] + r[:-1]) * dt)])
    psi = heading_sign * heading_scale * (psi + rng.normal(0, 0.004, t.size))
    p = tmp_path / name
    with open(p, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["time", "torque", "heading"])
        w.writerows([f"{a * time_scale:.3f}", b, c] for a, b, c in zip(t, f, psi))
    return p


def _steady(p, **kw):
    from uuvid.identify.vehicle.procedures import identify_steady

    kw = {"settle": 10, "min_duration": 10, **kw}
    return identify_steady(p, dof="yaw", command_col="torque", position_col="heading", **kw)


def test_heading_reversed_gives_a_negative_drag_warning(tmp_path):
    good = _steady(_pool_log(tmp_path, "good.csv"))
    assert not [w for w in good.warnings if "implausible" in w]
    bad = _steady(_pool_log(tmp_path, "bad.csv", heading_sign=-1.0))
    hits = [w for w in bad.warnings if w.startswith("implausible yaw") and "drag" in w]
    assert hits and "opposite signs" in hits[0]
    assert bad.to_dict()["warnings"] == bad.warnings  # in the JSON too


def test_degrees_read_as_radians_are_warned_and_the_unit_fixes_it(tmp_path):
    import math

    p = _pool_log(tmp_path, "deg.csv", heading_scale=180 / math.pi)
    res = _steady(p)
    hits = [w for w in res.warnings if "implausible yaw rates" in w]
    assert hits and "read in rad, the default" in hits[0] and "--angle-unit deg" in hits[0]
    fixed = _steady(p, angle_unit="deg")
    assert not [w for w in fixed.warnings if "implausible" in w]


def test_time_in_milliseconds_read_as_seconds_is_warned_and_the_unit_fixes_it(tmp_path):
    """A pool log's time column in ms read as s: every velocity ÷1000, so the drag came out
    ×1000 and the rate check (a slow heading looks plausible) said nothing."""
    p = _pool_log(tmp_path, "ms.csv", time_scale=1000.0)
    res = _steady(p, settle=10_000, min_duration=10_000)
    hits = [w for w in res.warnings if "s apart (median)" in w]
    assert len(hits) == 1 and "100 s apart" in hits[0] and "--time-unit ms" in hits[0], res.warnings
    fixed = _steady(p, time_unit="ms")
    assert not [w for w in fixed.warnings if "apart" in w]
    good = _steady(_pool_log(tmp_path, "s.csv"))
    assert not [w for w in good.warnings if "apart" in w]
    assert fixed.fit.k == pytest.approx(good.fit.k, rel=1e-6)


def test_centimetres_read_as_metres_are_warned(tmp_path):
    import numpy as np

    from uuvid.identify.plausibility import rate_warnings

    t = np.arange(0, 60, 0.1)
    x = 0.3 * t  # 0.3 m/s
    assert rate_warnings(t, x, "surge", "m", True, angular=False) == []
    (w,) = rate_warnings(t, 100 * x, "surge", "m", True, angular=False)
    assert "read in m, the default" in w and "--position-unit" in w


def test_a_heading_wrapping_while_spinning_is_not_a_unit_mistake():
    import numpy as np

    from uuvid.identify.plausibility import rate_warnings

    t = np.arange(0, 60, 0.1)
    psi = (1.5 * t + np.pi) % (2 * np.pi) - np.pi  # 1.5 rad/s, wrapped every 4.2 s
    assert rate_warnings(t, psi, "yaw", "rad", True, angular=True) == []
    (w,) = rate_warnings(t, np.degrees(psi), "yaw", "rad", True, angular=True)
    assert "--angle-unit deg" in w


def test_negative_inertia_is_warned(tmp_path):
    from uuvid.identify.plausibility import inertia_warnings

    assert inertia_warnings(84.0, 3.0, "yaw", "kg·m²") == []
    (w,) = inertia_warnings(-84.0, 3.0, "yaw", "kg·m²")
    assert "implausible yaw inertia -84" in w


@pytest.mark.parametrize("reversed_", ["torque", "heading"])
def test_inertia_from_a_reversed_channel_is_flagged(tmp_path, reversed_):
    import csv

    import numpy as np

    from uuvid.identify.vehicle.fit import simulate_one_dof
    from uuvid.identify.vehicle.procedures import identify_inertia
    from uuvid.vehicle.model import OneDofModel

    t = np.arange(0.0, 130.0, 0.1)
    cmd = -5.0 + 4.0 * np.sin(2 * np.pi * t / 24.0)
    r = simulate_one_dof(OneDofModel(84.0, 20.5, 49.5), t, cmd)
    psi = np.concatenate([[0.0], np.cumsum(0.5 * (r[1:] + r[:-1]) * 0.1)])
    psi += np.random.default_rng(1).normal(0, 0.004, t.size)

    def run(name, c, h):
        p = tmp_path / name
        with open(p, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["time", "torque", "heading"])
            w.writerows([f"{a:.3f}", b, x] for a, b, x in zip(t, c, h))
        return identify_inertia(p, dof="yaw", k=20.5, k_q=49.5, command_col="torque",
                                position_col="heading").document["warnings"]

    assert not [w for w in run("good.csv", cmd, psi) if "implausible" in w]
    bad = run("bad.csv", -cmd, psi) if reversed_ == "torque" else run("bad.csv", cmd, -psi)
    assert any(w.startswith(("implausible yaw fit", "implausible yaw inertia"))
               and "opposite signs" in w for w in bad)


def test_inertia_refuses_a_negative_drag_naming_the_sign(tmp_path):
    from uuvid.identify.vehicle.procedures import identify_inertia

    drag = _steady(_pool_log(tmp_path, "bad.csv", heading_sign=-1.0))
    with pytest.raises(ValueError, match="is negative .*opposite signs"):
        identify_inertia(_pool_log(tmp_path, "x.csv"), dof="yaw", drag=drag, command_col="torque",
                         position_col="heading")


# ------------------------------------------------------------------ bench commands in their unit
def test_bench_commands_must_fit_their_unit():
    import numpy as np

    from uuvid.identify.plausibility import check_bench_commands
    from uuvid.io.bench import BenchData, BenchDataError

    duty = np.linspace(-1, 1, 41)
    thrust = 40 * duty * np.abs(duty)
    check_bench_commands(BenchData(command=duty, thrust=thrust, command_unit="duty"))
    check_bench_commands(BenchData(command=1500 + 400 * duty, thrust=thrust))
    with pytest.raises(BenchDataError, match=r"b.csv: the commands hold -1…1, not pulse widths.*"
                                             r"pwm_us \(the default\).*--command-unit duty"):
        check_bench_commands(BenchData(command=duty, thrust=thrust, source="b.csv"))
    with pytest.raises(BenchDataError, match="look like pulse widths: give --command-unit pwm_us"):
        check_bench_commands(BenchData(command=1500 + 400 * duty, thrust=thrust,
                                       command_unit="duty"))


# ------------------------------------------------------------------ generated inputs
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(kt_f=st.floats(1e-5, 1e-3), kt_r=st.floats(1e-5, 1e-3), noise=st.floats(0.0, 0.3),
       neutral=st.floats(1450.0, 1550.0), seed=st.integers(0, 2**16))
def test_generated_reversed_bench_files_never_give_a_silent_model(kt_f, kt_r, noise, neutral, seed):
    """Any bench sweep with its thrust negated is refused; the same sweep unreversed fits a map
    whose thrust has the command's sign."""
    import numpy as np

    from uuvid.identify.thruster.steady import fit_quadratic_speed, fit_table
    from uuvid.io.bench import BenchData, BenchDataError

    rng = np.random.default_rng(seed)
    pwm = np.arange(1100.0, 1901.0, 20.0)
    w = 0.9 * (pwm - neutral)
    t = np.where(w >= 0, kt_f, kt_r) * w * np.abs(w) + rng.normal(0, noise, w.size)
    good = BenchData(command=pwm, thrust=t, speed=w, neutral=neutral)
    bad = BenchData(command=pwm, thrust=-t, speed=w, neutral=neutral)
    for fit in (fit_quadratic_speed, fit_table):
        with pytest.raises(BenchDataError, match="opposite sign"):
            fit(bad)
    q = fit_quadratic_speed(good).block
    assert q.k_pos > 0 and q.k_neg > 0
    assert np.all(np.sign(q.thrust(w[w != 0])) == np.sign(w[w != 0]))


_keys = st.text("abcdefgh_", min_size=1, max_size=6)
_trees = st.recursive(st.integers(-5, 5) | st.floats(-1e3, 1e3, allow_nan=False),
                      lambda kids: st.lists(kids, max_size=3)
                      | st.dictionaries(_keys, kids, min_size=1, max_size=4), max_leaves=12)


@pytest.mark.slow
@settings(max_examples=60, deadline=None)
@given(doc=st.dictionaries(_keys, _trees, min_size=1, max_size=4), data=st.data())
def test_generated_yaml_with_a_repeated_key_is_refused_with_its_path(doc, data):
    """Dump a random document, repeat one mapping key somewhere: the reader names its path."""
    import yaml

    from uuvid.thruster.modelfile import ModelFileError, load_yaml_unique

    assert load_yaml_unique(yaml.safe_dump(doc), "g.yaml") == doc
    # every mapping with its key path
    maps, stack = [], [(doc, "")]
    while stack:
        node, path = stack.pop()
        if isinstance(node, dict):
            maps.append((node, path))
            stack += [(v, f"{path}.{k}" if path else k) for k, v in node.items()]
        elif isinstance(node, list):
            stack += [(v, f"{path}[{i}]") for i, v in enumerate(node)]
    target, path = data.draw(st.sampled_from(maps))
    key = data.draw(st.sampled_from(sorted(target)))
    target["zz_dup_marker"] = None  # placeholder replaced in the text below
    text = yaml.safe_dump(doc, sort_keys=False, default_flow_style=True, width=10**6)
    del target["zz_dup_marker"]
    text = text.replace("zz_dup_marker: null", f"{key}: 0", 1)
    with pytest.raises(ModelFileError) as exc:
        load_yaml_unique(text, "g.yaml")
    full = f"{path}.{key}" if path else key
    assert str(exc.value).startswith(f"g.yaml: duplicated key {full} ")


def test_a_field_read_says_which_default_depth_it_took(tmp_path):
    pytest.importorskip("pymavlink")
    import struct

    import numpy as np
    from pymavlink import mavutil
    from pymavlink.dialects.v20 import ardupilotmega as mv

    from uuvid.identify.vehicle.logs import read_vehicle_log

    p = tmp_path / "heave.tlog"
    p.touch()
    log = mavutil.mavlink_connection(str(p), write=True)
    sub = mv.MAVLink(None, srcSystem=1, srcComponent=1)
    for k in range(200):
        ms = 5000 + 100 * k
        for msg in (sub.global_position_int_encode(ms, 0, 0, 0, int(-1000 - 5 * k), 0, 0, 0, 0),
                    sub.named_value_float_encode(ms, b"heave", float(np.sin(k / 20)))):
            log.write(struct.pack(">Q", int(1.7e15 + ms * 1000)) + msg.pack(sub))
    log.close()
    data = read_vehicle_log(p, "heave", fields=["command=NAMED_VALUE_FLOAT.value"])
    assert any(n.startswith("depth: -GLOBAL_POSITION_INT.relative_alt, the default of a --field")
               for n in data.notes), data.notes


def test_a_model_that_gives_zero_thrust_everywhere_is_warned(tmp_path):
    from uuvid.thruster.blocks import QuadraticMap
    from uuvid.thruster.chain import ThrusterChain
    from uuvid.thruster.modelfile import save_chain

    zero = save_chain(ThrusterChain((QuadraticMap(k_pos=0.0, k_neg=0.0),), "speed", "z"),
                      tmp_path / "z.yaml")
    doc = _predict(zero, "--speed", "-300:300:100")
    assert any("zero output at all 6 inputs" in w for w in doc["warnings"])
    # a model that pushes is not warned
    assert not [w for w in _predict("t200", "--pwm", "1100:1900:100")["warnings"]
                if "zero output" in w]


@pytest.mark.parametrize("row, fit", [(150, "table"), (150, "deadzone"), (60, "table")])
def test_one_reversed_row_in_still_water_is_an_error_naming_it(row, fit):
    """One row of a clean sweep with its thrust negated (a sign slip): the table fit flattened it
    away with a note, the dead-zone curve bent around it.  Now it is refused with the row."""
    import numpy as np

    from uuvid.identify.thruster.steady import fit_deadzone_curve, fit_table
    from uuvid.io.bench import BenchData, BenchDataError

    rng = np.random.default_rng(row)
    pwm = np.arange(1100.0, 1901.0, 2.0)
    w = pwm - 1500.0
    t = 4e-4 * w * np.abs(w) + rng.normal(0, 0.05, w.size)
    f = {"table": fit_table, "deadzone": fit_deadzone_curve}[fit]
    f(BenchData(command=pwm, thrust=t, source="sweep.csv"))  # the clean sweep fits
    t[row] = -t[row]
    with pytest.raises(BenchDataError, match=rf"sweep\.csv: thrust reverses at row {row + 1} of "
                                             rf"the data: command {pwm[row]:g} pwm_us"):
        f(BenchData(command=pwm, thrust=t, source="sweep.csv"))


def test_a_step_response_is_not_a_reversal():
    """Command steps 1700 ↔ 1300 µs with the thrust lagging 0.15 s: after each step the thrust
    keeps its old sign for a moment — a thruster's lag, not a sign slip (the single-row check
    refused this valid file: it applies to steady sweeps only)."""
    import numpy as np

    from uuvid.identify.plausibility import check_bench_signs
    from uuvid.io.bench import BenchData

    t = np.arange(0.0, 4.0, 0.005)
    cmd = np.where((t // 1.0) % 2 == 0, 1700.0, 1300.0)
    target = np.where(cmd > 1500, 20.0, -16.0)
    thrust = np.empty_like(t)
    thrust[0] = 0.0
    for k in range(1, t.size):
        thrust[k] = thrust[k - 1] + 0.005 / 0.15 * (target[k] - thrust[k - 1])
    check_bench_signs(BenchData(command=cmd, thrust=thrust, time=t, source="steps.csv"))
