"""Sweeps: the batched step-metric kernel, McLean's Table I as points of a sweep grid, sweep files,
parameter names, invalid values, vehicle parameter rows and reports."""

import math
import time

import numpy as np
import pytest

from uuvid.core import units as U
from uuvid.papers import mclean1991 as mc
from uuvid.thruster.presets import MCLEAN, auv2_rig_chain, t200_chain
from uuvid.uncertainty import params as PR
from uuvid.uncertainty.sweep import SweepError, SweepSpec, SweepStudy, load_sweep, run_sweep, sweep_from_dict
from uuvid.uncertainty.targets import ThrusterStepTarget, plan_for

BASE_PE_FT = 0.75 * MCLEAN.pitch_ft_per_rad  # 0.054075 ft/rad


def table1_rows_of(table):
    """Table I cases (except the Coulomb one) located in a McLean sweep table."""
    base = {"tunnel_length": U.inch(10.5), "added_mass_coefficient": 0.25,
            "effective_pitch": U.ft_per_rad(BASE_PE_FT), "voltage": 24.0}
    out = {}
    for case in mc.table1_cases():
        if case.name == "coulomb":
            continue
        want = dict(base, voltage=case.voltage)
        want.update(case.overrides)
        m = np.ones(len(table), dtype=bool)
        for k, v in want.items():
            m &= np.isclose(table[k].to_numpy(float), v, rtol=1e-9, atol=1e-12)
        assert m.sum() == 1, case.name
        out[case.name] = table[m].iloc[0]
    return out


def check_table1(rows):
    for name, r in rows.items():
        ours = dict(zip(mc.TABLE1_FIELDS, (
            U.to_lbf(r["peak_output_thrust"]), U.to_lbf(r["max_true_thrust"]),
            U.to_lbf(r["steady_thrust"]), r["time_constant_speed"], U.to_rpm(r["steady_speed"]))))
        for f, thesis in zip(mc.TABLE1_FIELDS, mc.TABLE1_THESIS[name]):
            if name == "Pe=0" and f == "time_constant_s":
                assert 0 < ours[f] < thesis
                continue
            if thesis == 0:
                assert abs(ours[f]) < 1e-9
                continue
            tol = 0.15 if f == "steady_lbf" else 0.06
            assert abs(ours[f] - thesis) / thesis < tol, (name, f, ours[f], thesis)


# ------------------------------------------------------------------------------------------------
def test_step_kernel_equals_step_response_metrics():
    """The in-kernel metrics are those of TimeResponse.metrics() (uuvid.core.metrics)."""
    plan = plan_for(ThrusterStepTarget(t_end=0.8), ["tunnel_length", "voltage", "coulomb"])
    vals = {"tunnel_length": np.array([0.12, 0.2667, 0.5]), "voltage": np.array([-12.0, 24.0, 6.0]),
            "coulomb": np.array([False, True, False], dtype=object)}
    ev = plan.evaluate(vals, 3)
    for r in range(3):
        ch = auv2_rig_chain(tunnel_length=vals["tunnel_length"][r], coulomb=bool(vals["coulomb"][r]))
        m = ch.simulate(float(vals["voltage"][r]), 0.8).metrics().as_dict()
        for k, v in m.items():
            got = ev.metrics[k][r]
            assert (math.isnan(v) and math.isnan(got)) or got == pytest.approx(v, rel=1e-12, abs=1e-12), (r, k)


def test_step_kernel_without_load_cell_or_speed():
    """A chain without a load cell: the output thrust is the true thrust; T200 chain (command)."""
    plan = plan_for(ThrusterStepTarget(chain="t200", signal={"kind": "step", "amplitude": 1800.0},
                                       t_end=1.0, dt=2e-3, substeps=1), ["command"])
    ev = plan.evaluate({"command": np.array([1800.0, 1300.0])}, 2)
    for r, c in enumerate((1800.0, 1300.0)):
        m = t200_chain().simulate(c, 1.0, dt=2e-3, substeps=1).metrics().as_dict()
        assert ev.metrics["steady_thrust"][r] == pytest.approx(m["steady_thrust"], rel=1e-12)
        assert ev.metrics["peak_output_thrust"][r] == pytest.approx(m["peak_output_thrust"], rel=1e-12)


def test_one_ms_rk4_matches_the_table1_reproduction():
    """The sweep's RK4 at 1 ms (substeps 1) gives Table I's numbers to 1e-6 of the 0.25 ms runs."""
    ref = {r["case"]: r for r in mc.table1()[0]}
    for case in mc.table1_cases():
        row = mc.table1_row(case, mc.simulate_case(case, substeps=1))
        for f in mc.TABLE1_FIELDS:
            assert row[f] == pytest.approx(ref[case.name][f], rel=1e-6, abs=1e-9)


def test_mclean_corners_of_a_small_grid_reproduce_table1():
    spec = SweepSpec.model_validate({
        "name": "mclean-corners",
        "target": {"kind": "thruster_step", "chain": "auv2-tunnel", "t_end": 1.333, "substeps": 1},
        "parameters": [
            {"name": "tunnel_length", "unit": "in", "values": [5, 10.5, 20]},
            {"name": "added_mass_coefficient", "values": [0.25, 0.5, 1.0]},
            {"name": "effective_pitch", "unit": "ft/rad", "values": [0, 0.027, BASE_PE_FT, 0.0721]},
            {"name": "voltage", "values": [8, 16, 24]}],
        "metrics": ["peak_output_thrust", "max_true_thrust", "steady_thrust", "time_constant_speed",
                    "steady_speed"]})
    assert spec.n_runs == 108
    res = run_sweep(spec, None, backend="inprocess", progress=False)
    assert res.info["succeeded"] == 108 and not res.partial
    check_table1(table1_rows_of(res.table))


@pytest.mark.slow
def test_mclean_sensitivity_10000_runs_under_a_minute():
    spec = load_sweep("mclean-sensitivity")
    assert spec.n_runs >= 10_000
    study = SweepStudy(spec)
    run_sweep(SweepSpec.model_validate({**spec.model_dump(mode="json"), "parameters": [
        {"name": a.name, "unit": a.unit, "values": a.values[:2]} for a in spec.parameters]}),
        None, backend="inprocess", progress=False)  # load the compiled kernels
    from uuvid.uncertainty.execute import run_study

    t0 = time.perf_counter()
    res = run_study(study, None, backend="inprocess", progress=False)
    wall = time.perf_counter() - t0
    assert res.info["succeeded"] == spec.n_runs
    assert wall < 60.0, wall
    check_table1(table1_rows_of(res.table))


# ------------------------------------------------------------------------------------------------
def test_builtin_sweep_holds_table1_values():
    spec = load_sweep("mclean-sensitivity")
    assert spec.shape == (10, 10, 10, 10)
    grids = {a.name: a.grid() for a in spec.parameters}
    assert any(math.isclose(v, U.inch(10.5)) for v in grids["tunnel_length"])
    assert any(math.isclose(v, U.ft_per_rad(BASE_PE_FT)) for v in grids["effective_pitch"])
    assert {8.0, 16.0, 24.0} <= set(grids["voltage"])
    rov = load_sweep("bluerov2-added-mass-current")
    assert rov.n_runs == 25 and rov.target.kind == "vehicle_mission"


def test_grid_order_list_and_random_modes():
    tgt = {"kind": "thruster_step", "t_end": 0.2, "substeps": 1}
    g = SweepStudy(SweepSpec.model_validate({"target": tgt, "parameters": [
        {"name": "voltage", "values": [1, 2]}, {"name": "tunnel_length", "start": 0.1, "stop": 0.3, "num": 3}]}))
    t = g.parameter_table(0, g.n_runs)
    assert list(t["voltage"]) == [1, 1, 1, 2, 2, 2]  # last axis fastest
    assert list(t["tunnel_length"]) == pytest.approx([0.1, 0.2, 0.3] * 2)
    assert g.parameter_table(2, 4)["run"].tolist() == [2, 3]
    lst = SweepStudy(SweepSpec.model_validate({"target": tgt, "mode": "list",
                                               "runs": [{"voltage": 3}, {"voltage": 5}]}))
    assert lst.parameter_table(0, 2)["voltage"].tolist() == [3, 5]
    rnd = SweepSpec.model_validate({"target": tgt, "mode": "random", "samples": 50, "seed": 7,
                                    "parameters": [{"name": "voltage", "start": 4, "stop": 24},
                                                   {"name": "tunnel_length", "start": 0.1, "stop": 1, "log": True}]})
    a = SweepStudy(rnd).parameter_table(0, 50)
    b = SweepStudy(rnd).parameter_table(20, 50)  # another chunking: same values per run
    assert np.array_equal(a.iloc[20:].to_numpy(), b.to_numpy())
    assert a["voltage"].between(4, 24).all() and a["tunnel_length"].between(0.1, 1).all()
    c = SweepStudy(rnd.model_copy(update={"seed": 8})).parameter_table(0, 50)
    assert not np.array_equal(a["voltage"], c["voltage"])


def test_sweep_file_errors_name_the_key(tmp_path):
    with pytest.raises(SweepError, match=r"bad.yaml: parameters\[0\].vlues: unknown key"):
        p = tmp_path / "bad.yaml"
        p.write_text("target: {kind: thruster_step}\nparameters:\n  - {name: voltage, vlues: [1]}\n")
        load_sweep(p)
    with pytest.raises(SweepError, match="mode list needs runs"):
        sweep_from_dict({"target": {"kind": "thruster_step"}, "mode": "list"})
    with pytest.raises(SweepError, match="unknown unit"):
        sweep_from_dict({"target": {"kind": "thruster_step"},
                         "parameters": [{"name": "voltage", "unit": "furlong", "values": [1]}]})
    spec = sweep_from_dict({"target": {"kind": "thruster_step"},
                            "parameters": [{"name": "blocks[0].tunel_length", "values": [0.2]}]})
    with pytest.raises(PR.ParameterNameError, match="tunnel_thruster has no parameter 'tunel_length'"):
        SweepStudy(spec).check()
    spec = sweep_from_dict({"target": {"kind": "thruster_step"}, "metrics": ["peak"],
                            "parameters": [{"name": "voltage", "values": [1]}]})
    with pytest.raises(PR.ParameterNameError, match="unknown metric 'peak'"):
        SweepStudy(spec).check()
    with pytest.raises(FileNotFoundError, match="mclean-sensitivity"):
        load_sweep("no-such-sweep")



def _axes(n_axes, num=100000):
    names = ["voltage", "tunnel_length", "added_mass_coefficient", "effective_pitch"]
    return [{"name": n, "start": 0.1, "stop": 1.0, "num": num} for n in names[:n_axes]]


def test_sweep_size_is_exact_and_its_refusal_names_the_sweeps_own_keys():
    """A 10^20-run grid read as 7.8e18 runs (np.prod wrapped past 2^63), and the memory refusal
    named `runs=` (--runs, a Monte Carlo option): it gives the grid's shape and what to reduce."""
    tgt = {"kind": "thruster_step", "t_end": 0.2, "substeps": 1}
    study = SweepStudy(sweep_from_dict({"target": tgt, "parameters": _axes(4)}))
    assert study.n_runs == 10**20
    with pytest.raises(ValueError, match=r"^the grid of parameters \(voltage 100,000 × tunnel_length "
                       r"100,000 × .*\) = 100,000,000,000,000,000,000 runs: the results would take "
                       r"≈ .* GB .*give at most [\d,]+ runs: fewer values") as e:
        study.check_memory()
    assert "runs=" not in str(e.value)
    rnd = SweepStudy(sweep_from_dict({"target": tgt, "mode": "random", "samples": 10**14,
                                      "parameters": [{"name": "voltage", "start": 1, "stop": 24}]}))
    with pytest.raises(ValueError, match=r"^samples: 100,000,000,000,000: .*give samples: [\d,]+ "
                       r"or fewer, or split the sweep into several \(other seeds\)"):
        rnd.check_memory()


def test_sweep_disk_refusal_names_the_grid(tmp_path, monkeypatch):
    import shutil
    from collections import namedtuple

    study = SweepStudy(sweep_from_dict({"target": {"kind": "thruster_step"}, "parameters": _axes(2, 100)}))
    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(1e9, 1e9 - 1e5, 1e5))
    with pytest.raises(OSError, match=r"out: the grid of parameters \(voltage 100 × tunnel_length "
                       r"100\) = 10,000 runs would write .* give at most [\d,]+ runs: fewer values"):
        study.check_disk(tmp_path / "out")


def test_sweep_target_longer_than_a_simulation_may_hold_is_refused_before_allocating():
    """t_end = 1e9 s at 1 ms: the plan allocated its time grid first, a MemoryError of 7.3 TiB;
    now a run's input must fit what a chunk holds (MAX_INPUT_SAMPLES, 8 bytes a sample: a sweep
    keeps no channels), naming the file's keys.  An hour at 1 ms (3.6 M samples, 29 MB), which
    ran before, still runs: the simulate command's 2 M-sample limit counts channels a sweep
    does not keep."""
    from uuvid.uncertainty.targets import MAX_INPUT_SAMPLES

    spec = sweep_from_dict({"target": {"kind": "thruster_step", "t_end": 1e9, "dt": 1e-3},
                            "parameters": [{"name": "voltage", "values": [12, 24]}]})
    with pytest.raises(ValueError, match=r"^target.t_end = 1e\+09 s at target.dt = 0.001 s is "
                       r"1e\+12 samples \(≈ 8e\+03 GB\), more than the 16,000,000 a simulation "
                       r"may hold in memory; shorten target.t_end or raise target.dt$"):
        SweepStudy(spec).check()
    hour = plan_for(ThrusterStepTarget(t_end=3600.0, dt=1e-3, substeps=1), ["voltage"])
    assert hour.t.size == 3_600_001 <= MAX_INPUT_SAMPLES
    spec = sweep_from_dict({"target": {"kind": "thruster_step", "t_end": 100.0, "dt": 1e-3,
                                       "substeps": 1000},
                            "parameters": [{"name": "voltage", "values": [12, 24]}]})
    with pytest.raises(ValueError, match=r"RK4 steps, more than .* lower target.substeps"):
        SweepStudy(spec).check()
    spec = sweep_from_dict({"target": {"kind": "vehicle_mission",
                                       "velocity_response": {"t_end": 1e9, "dt": 1e-3}},
                            "parameters": [{"name": "current_speed", "values": [0, 0.1]}]})
    with pytest.raises(ValueError, match=r"^target.velocity_response.t_end = 1e\+09 s at "
                       r"target.velocity_response.dt = 0.001 s is 1,000,000,000,000 steps, more than the "
                       r"2,000,000 one flight may hold in memory"):
        SweepStudy(spec).check()


@pytest.mark.parametrize("raw, needle", [
    ({"parameters": []}, "mode grid needs parameters"),
    ({"mode": "random", "samples": 3, "parameters": []}, "mode random needs parameters"),
    ({"mode": "random", "samples": 3, "parameters": [{"name": "voltage", "start": 24, "stop": 1}]},
     r"parameters\[0\] \(voltage\): start 24 > stop 1; .* give start <= stop"),
    ({"parameters": [{"name": "voltage", "start": 1e308, "stop": -1e308, "num": 3}]},
     r"parameters\[0\]: parameter 'voltage': start 1e\+308 … stop -1e\+308 gives non-finite"),
    ({"parameters": [{"name": "voltage", "start": 1, "stop": 24, "num": 1}]},
     r"parameters\[0\] \(voltage\): num 1 gives start 1 alone \(stop 24 unused\)"),
])
def test_sweep_grids_that_ran_silently_or_crashed_are_refused(raw, needle):
    """An empty grid ran the baseline once (random: N identical runs); a reversed random range
    said 'high - low < 0'; a range beyond the floats gave NaN values and an IndexError."""
    with pytest.raises(SweepError, match=r"^s.yaml: " + needle):
        sweep_from_dict({"target": {"kind": "thruster_step"}, **raw}, where="s.yaml")


def test_a_random_axis_takes_any_num():
    """num is a grid's: a random axis draws between start and stop whatever num says."""
    spec = sweep_from_dict({"target": {"kind": "thruster_step"}, "mode": "random", "samples": 4,
                            "parameters": [{"name": "voltage", "start": 8, "stop": 24, "num": 1}]})
    assert spec.n_runs == 4


def test_run_sweep_takes_a_dict_like_a_sweep_file():
    """A notebook's dict went to Path(): 'TypeError: expected str, bytes or os.PathLike'."""
    res = run_sweep({"target": {"kind": "thruster_step", "t_end": 0.2, "substeps": 1},
                     "parameters": [{"name": "voltage", "values": [12, 24]}]}, None,
                    backend="inprocess", progress=False)
    assert res.info["succeeded"] == 2
    with pytest.raises(SweepError, match="parameters"):
        run_sweep({"target": {"kind": "thruster_step"}}, None, progress=False)


def test_a_chunk_of_long_runs_holds_a_bounded_input(monkeypatch):
    """Every run with its own signal (a swept voltage) kept its whole input in the chunk's input
    array and in the plan's cache: 2,500 runs of 2 M samples held 40 GB.  A chunk whose inputs
    pass MAX_INPUT_SAMPLES is evaluated in parts, with the same results."""
    from uuvid.uncertainty import _kernels
    from uuvid.uncertainty import targets as TG

    plan = plan_for(ThrusterStepTarget(t_end=0.2, substeps=1), ["voltage"])
    volts = np.linspace(4.0, 24.0, 10)
    whole = plan.evaluate({"voltage": volts}, 10)
    rows = []

    def spy(real):
        def run(*a):
            rows.append(a[8].shape[0])  # U: one row per distinct input
            return real(*a)
        return run

    for name in ("step_metrics_batch", "step_metrics_serial"):  # (threads or not, by batch size)
        monkeypatch.setattr(_kernels, name, spy(getattr(_kernels, name)))
    monkeypatch.setattr(TG, "MAX_INPUT_SAMPLES", 3 * plan.t.size, raising=False)
    plan._signals.clear()
    parts = plan.evaluate({"voltage": volts + 0.0}, 10)
    assert rows == [3, 3, 3, 1] and len(plan._signals) <= 3
    assert list(parts.status) == list(whole.status) == ["ok"] * 10
    for m in whole.metrics:
        assert np.array_equal(parts.metrics[m], whole.metrics[m], equal_nan=True), m

def test_dotted_block_names_and_invalid_values_are_reported_per_run():
    spec = SweepSpec.model_validate({
        "target": {"kind": "thruster_step", "t_end": 0.3, "substeps": 1},
        "mode": "list",
        "runs": [{"blocks[0].tunnel_length": 0.2667, "blocks[0].motor.coulomb_torque": 0.0,
                  "blocks[0].propeller_efficiency": 0.75},
                 {"blocks[0].tunnel_length": -0.1, "blocks[0].motor.coulomb_torque": 0.0,
                  "blocks[0].propeller_efficiency": 0.75},
                 {"blocks[0].tunnel_length": 0.2667, "blocks[0].motor.coulomb_torque": 0.01,
                  "blocks[0].propeller_efficiency": 1.2}]})
    res = run_sweep(spec, None, backend="inprocess", progress=False)
    t = res.table
    assert t["status"].tolist() == ["ok", "invalid", "invalid"]
    assert "tunnel_length" in t.loc[1, "message"]
    assert "propeller_efficiency must be <= 1" in t.loc[2, "message"]
    assert res.info["succeeded"] == 1 and res.info["status_counts"] == {"ok": 1, "invalid": 2}
    ref = auv2_rig_chain().simulate(24.0, 0.3, substeps=1).metrics()
    assert t.loc[0, "peak_output_thrust"] == pytest.approx(ref.peak_output_thrust, rel=1e-12)


# ------------------------------------------------------------------------------------------------
def test_vehicle_rows_match_vehicle_params():
    import dataclasses

    from uuvid.vehicle.definition import load_vehicle

    p = load_vehicle("bluerov2").params
    P, VC, msg = PR.vehicle_rows(p, {}, 2)
    assert np.array_equal(P[0], p.to_array()) and VC is None and list(msg) == ["", ""]
    MA = np.array(p.added_mass)
    MA[0, 0], MA[5, 5] = 7.0, 0.3
    DL = np.array(p.linear_damping) * 1.5
    DQ = np.array(p.quadratic_damping) * 1.5
    want = dataclasses.replace(p, mass=12.0, added_mass=MA, linear_damping=DL,
                               quadratic_damping=DQ).to_array()
    P, VC, msg = PR.vehicle_rows(p, {"mass": np.array([12.0, -1.0]),
                                     "added_mass[surge]": np.array([7.0, 7.0]),
                                     "added_mass[5]": np.array([0.3, 0.3]),
                                     "damping_scale": np.array([1.5, 1.5]),
                                     "current_speed": np.array([0.2, 0.2]),
                                     "current_direction": np.array([90.0, 90.0])}, 2)
    assert np.allclose(P[0, :189], want[:189], rtol=1e-13, atol=1e-15)
    assert VC[0] == pytest.approx([0.0, 0.2, 0.0], abs=1e-12)
    assert msg[0] == "" and "mass must be > 0" in msg[1]
    P, _, msg = PR.vehicle_rows(p, {"linear_damping[sway]": np.array([-0.5])}, 1)
    assert "linear_damping[sway] = -0.5 < 0" in msg[0]
    with pytest.raises(PR.ParameterNameError, match="unknown vehicle parameter"):
        PR.parse_vehicle_name("added_mas[0]")
    with pytest.raises(PR.ParameterNameError, match="index must be"):
        PR.parse_vehicle_name("added_mass[7]")


@pytest.mark.slow
def test_vehicle_sweep_added_mass_times_damping(tmp_path):
    spec = SweepSpec.model_validate({
        "name": "rov-am-damping",
        "target": {"kind": "vehicle_mission", "scenario": {"vehicle": "bluerov2"}},
        "parameters": [{"name": "added_mass_scale", "values": [0.5, 1.5]},
                       {"name": "damping_scale", "values": [0.5, 2.0]}],
        "requirement": {"metric": "max_tracking_error_m", "below": 0.5}})
    res = run_sweep(spec, tmp_path / "out", backend="inprocess", progress=False)
    t = res.table
    assert t["status"].eq("ok").all() and len(t) == 4
    assert (t["max_tracking_error_m"] > 0).all()
    assert (t["max_thrust_N"] > 0).all() and (t["min_allocation_scale"] <= 1).all()
    req = res.info["requirement"]
    assert req["runs_simulated"] == 4 and 0 <= req["probability"] <= 1
    assert res.info["target"]["vehicle"] == "bluerov2"
    for f in ("results.csv", "summary.json", "index.html"):
        assert (tmp_path / "out" / f).exists()
    assert any(f.startswith("heatmap") for f in res.info["figures"])


@pytest.mark.slow
def test_vehicle_sweep_added_mass_times_current():
    """BlueROV2 added mass ± 50 % × current speed → square-mission tracking error."""
    spec = SweepSpec.model_validate({
        "name": "rov-am-current",
        "target": {"kind": "vehicle_mission", "scenario": {"vehicle": "bluerov2"}},
        "parameters": [{"name": "added_mass_scale", "values": [0.5, 1.5]},
                       {"name": "current_speed", "values": [0.0, 0.3]}]})
    t = run_sweep(spec, None, backend="inprocess", progress=False).table
    assert t["status"].eq("ok").all()
    # a current makes tracking worse
    assert (t[t.current_speed == 0.3]["rms_tracking_error_m"].to_numpy()
            > t[t.current_speed == 0.0]["rms_tracking_error_m"].to_numpy()).all()
