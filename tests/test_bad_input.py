"""Bad input ends in a clear error, never a traceback, a silent NaN or an unbounded run (issue 18).

Each test feeds one class of bad input and fails on an uncaught exception (a traceback), on a
non-finite result passed off as valid, or when the input would run past a size/time budget
instead of being refused before anything is allocated."""

import math

import numpy as np
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app

runner = CliRunner()


def clean_error(res, *needles, code=(1, 2)):
    """A CLI run that failed as a user error: exit status 1/2, no traceback, message named."""
    assert res.exit_code in code, (res.exit_code, res.output, res.exception)
    assert isinstance(res.exception, SystemExit), repr(res.exception)
    assert "Traceback" not in res.output
    for n in needles:
        assert n in res.output, (n, res.output)


# ------------------------------------------------------------------------- result tables
def test_parameter_tables_show_a_missing_sigma_as_a_dash():
    from uuvid.cli.log_options import params_table
    from uuvid.identify.vehicle.procedures import _params_text

    params = {"k": {"estimate": 1.5, "sigma": None, "unit": "N·s/m", "percentile_error": None,
                    "significant": False},
              "k_q": {"estimate": 2.0, "sigma": math.nan, "unit": "", "percentile_error": math.inf,
                      "significant": True}}
    text = _params_text("drag", params)
    assert "—" in text and "1.5" in text
    table = params_table("drag", params)
    assert table.row_count == 2


# ------------------------------------------------------------------------- model files
def test_non_utf8_model_file_names_file_and_line(tmp_path):
    from uuvid.thruster.modelfile import ModelFileError, load_chain

    p = tmp_path / "m.yaml"
    p.write_bytes(b"name: x\nblocks:\n  - type: first_order # \xff\xfe\n")
    with pytest.raises(ModelFileError, match=r"m\.yaml: line 3: not UTF-8"):
        load_chain(p)


@pytest.mark.parametrize("value", ["[quadratic]", "{a: 1}", "3"])
def test_block_type_that_is_not_a_name(tmp_path, value):
    from uuvid.thruster.modelfile import ModelFileError, load_chain

    p = tmp_path / "m.yaml"
    p.write_text(f"blocks:\n  - type: {value}\n")
    with pytest.raises(ModelFileError, match=r"blocks\[0\]\.type: expected a block type name"):
        load_chain(p)


BOMB = "".join(f"{a}: &{a} [{', '.join([f'*{p}'] * 9 if p else ['1'] * 9)}]\n"
               for p, a in zip([None, *"abcdefg"], "abcdefgh"))


def test_yaml_alias_bomb_is_refused_quickly(tmp_path):
    import time

    from uuvid.simulate.scenario import load_scenario
    from uuvid.thruster.modelfile import ModelFileError

    p = tmp_path / "s.yaml"
    p.write_text(BOMB + "current: [*h, *h, *h]\n")  # 9**8 * 3 ≈ 1.3e8 values once expanded
    t0 = time.perf_counter()
    with pytest.raises(ModelFileError, match="alias bomb"):
        load_scenario(p)
    assert time.perf_counter() - t0 < 5.0


def test_recursive_yaml_anchor_is_refused(tmp_path):
    from uuvid.thruster.modelfile import ModelFileError, read_model_text

    p = tmp_path / "v.yaml"
    p.write_text("x: &x [1, *x]\n")
    with pytest.raises(ModelFileError, match=r"x\[1\]: a YAML anchor refers to itself"):
        read_model_text(p)


def test_expanded_size_counts_shared_values_once_per_use():
    from uuvid.thruster.modelfile import check_expanded_size

    leaf = [1, 2, 3]  # 4 values
    assert check_expanded_size({"a": leaf, "b": [leaf, leaf]}, "w") == 1 + 4 + (1 + 8)


# ------------------------------------------------------------------------- vehicle parameters
@pytest.mark.parametrize("field, value", [("linear_damping", np.diag([1e308, 1, 1, 1, 1, 1])),
                                          ("mass", 1e308), ("added_mass", np.eye(6) * 1e200),
                                          ("inertia", [1e300, 1, 1])])
def test_absurd_vehicle_parameters_are_refused_by_name(field, value):
    from uuvid.thruster.blocks import ParameterError
    from uuvid.vehicle.model import VehicleParams

    kw = dict(mass=10.0, inertia=[0.1, 0.1, 0.1], r_g=np.zeros(3), r_b=[0, 0, -0.02],
              weight=98.0, buoyancy=99.0, added_mass=np.zeros(6), linear_damping=np.ones(6),
              quadratic_damping=np.ones(6))
    kw[field] = value
    with pytest.raises(ParameterError, match=f"VehicleParams.{field}") as e:
        VehicleParams(**kw)
    assert e.value.param == field


# ------------------------------------------------------------------------- scenarios
@pytest.mark.slow
@pytest.mark.parametrize("text, needle", [
    ("duration: 0.001\n", "shorter than one step"),
    ("duration: 0.049\ndt: 0.1\n", "shorter than one step"),
    ("duration: 1.0e7\n", "shorten duration or raise dt"),
    ("mission: {kind: waypoints, waypoints: [[0, 0, 0, 0], [1.0e300, 0, 0, 0]]}\n",
     "duration not given"),
    ("mission: {kind: waypoints, waypoints: [[0, 0, 0, 0], [1.0e6, 0, 0, 0]]}\n",
     "shorten duration or raise dt"),
])
def test_scenario_durations_are_bounded_before_allocating(tmp_path, text, needle):
    p = tmp_path / "s.yaml"
    p.write_text(text)
    res = runner.invoke(app, ["simulate", str(p)])
    clean_error(res, "s.yaml", needle)


def test_step_count_budget():
    from uuvid.simulate.vehicle_sim import MAX_STEPS, step_count

    assert step_count(1.0, 0.01) == 100
    assert step_count(MAX_STEPS * 0.01, 0.01) == MAX_STEPS
    # half a step is one step (round(0.5) is 0: a scenario's duration 0.05 at dt 0.1 crashed
    # with an IndexError deep in setup_mission)
    assert step_count(0.05, 0.1) == step_count(0.005, 0.01) == step_count(0.6, 1.0) == 1
    for T, dt in [(0.001, 0.01), (math.inf, 0.01), (math.nan, 0.01), (-1.0, 0.01),
                  (MAX_STEPS * 0.0101, 0.01), (1.0, 0.0), (1.0, math.nan)]:
        with pytest.raises(ValueError, match="t_end|dt"):
            step_count(T, dt)


@pytest.mark.slow
def test_divergence_in_uuvid_simulate_is_an_error_not_a_traceback(tmp_path, monkeypatch):
    import uuvid.simulate.vehicle_sim as vs

    def diverge(setup):
        raise ValueError("the simulation diverged at t = 1.000 s; try a smaller dt or more substeps")

    monkeypatch.setattr(vs, "fly_mission", diverge)
    p = tmp_path / "s.yaml"
    p.write_text("duration: 1.0\n")
    clean_error(runner.invoke(app, ["simulate", str(p)]), "s.yaml", "diverged")


def test_controller_file_without_py_suffix(tmp_path):
    (tmp_path / "ctl.txt").write_text("def make_controller(vehicle, context):\n    return None\n")
    p = tmp_path / "s.yaml"
    p.write_text("controller: {kind: python, file: ctl.txt}\n")
    clean_error(runner.invoke(app, ["simulate", str(p)]), "ctl.txt", "rename it to ctl.py")


# ------------------------------------------------------------------------- sweeps
SWEEP = """name: t
target: {{kind: thruster_step, chain: auv2-tunnel, preset_kwargs: {kw}, signal: {{kind: step,
          amplitude: 24.0}}, t_end: 0.2}}
mode: grid
parameters:
  - {{name: voltage, values: [8, 16]}}
"""


@pytest.mark.parametrize("text, needle", [
    (SWEEP.format(kw="{foo: 1}"), "target.preset_kwargs: unknown keyword(s) 'foo'"),
    (SWEEP.format(kw="{tunnel_length: -1}"), "target.preset_kwargs.tunnel_length"),
    ("name: t\ntarget: {kind: thruster_steady, physical_model: {foo: 1}}\nmode: grid\n"
     "parameters:\n  - {name: R, values: [0.1, 0.2]}\n", "base.physical_model: unknown key(s) 'foo'"),
])
def test_sweep_with_unknown_or_bad_keywords(tmp_path, text, needle):
    p = tmp_path / "sw.yaml"
    p.write_text(text)
    res = runner.invoke(app, ["sweep", str(p), "--out", str(tmp_path / "out")])
    clean_error(res, "sw.yaml", needle)



BIG_GRID = """name: t
target: {kind: thruster_step, t_end: 0.2, substeps: 1}
parameters:
""" + "".join(f"  - {{name: {n}, start: 0.1, stop: 1, num: 100000}}\n"
              for n in ("voltage", "tunnel_length", "added_mass_coefficient", "effective_pitch"))


@pytest.mark.parametrize("text, needles", [
    # 10^20 runs: the count was wrapped (7.8e18) and the option named --runs (Monte Carlo's)
    (BIG_GRID, ["grid of parameters", "100,000,000,000,000,000,000", "GB", "fewer values"]),
    # a target of 1e12 samples: a raw MemoryError (7.28 TiB) traceback
    (SWEEP.format(kw="{}").replace("t_end: 0.2", "t_end: 1e9"), ["target.t_end", "GB",
                                                                 "shorten"]),
    (SWEEP.format(kw="{}").replace("mode: grid", "mode: random\nsamples: 100000000000000"),
     ["samples: 100,000,000,000,000", "GB", "or fewer"]),
])
@pytest.mark.slow
def test_sweep_too_big_is_refused_naming_its_own_keys(tmp_path, text, needles):
    p = tmp_path / "sw.yaml"
    p.write_text(text)
    res = runner.invoke(app, ["sweep", str(p), "--out", str(tmp_path / "out")])
    clean_error(res, "sw.yaml", *needles)
    assert "--runs" not in res.output and not (tmp_path / "out").exists()

# ------------------------------------------------------------------------- logs and clocks
def _dense_boot_from_log(log_t, ref_log, ref_boot, window=5.0):
    """The receive → boot clock mapping with a dense 1 s bin array (the former implementation:
    memory grows with the time span), kept as an independent reference."""
    from scipy.ndimage import minimum_filter1d

    d = ref_log - ref_boot
    origin = ref_log.min()
    b = np.floor(ref_log - origin).astype(np.int64)
    env = np.full(int(b.max()) + 1, np.inf)
    np.minimum.at(env, b, d)
    env = minimum_filter1d(env, size=2 * int(window) + 1, mode="nearest")
    ok = np.isfinite(env)
    return log_t - np.interp(log_t, origin + np.arange(env.size)[ok] + 0.5, env[ok])


@pytest.mark.parametrize("seed", range(8))
def test_receive_clock_mapping_matches_the_dense_reference(seed):
    from uuvid.io.logs import _boot_from_log

    rng = np.random.default_rng(seed)
    boot = np.sort(rng.uniform(0, 300, 400))
    boot = boot[(boot < 100) | (boot > 100 + rng.uniform(5, 60))]  # a gap in the link
    recv = 1.7e9 + boot + 0.3 + rng.exponential(0.05, boot.size) + 1e-4 * boot  # latency, drift
    log_t = np.sort(rng.uniform(recv.min() - 3, recv.max() + 3, 500))
    np.testing.assert_allclose(_boot_from_log(log_t, recv, boot),
                               _dense_boot_from_log(log_t, recv, boot), rtol=0, atol=1e-9)


def test_corrupt_receive_stamp_does_not_allocate_the_time_span():
    import tracemalloc

    from uuvid.io.logs import _boot_from_log

    boot = np.arange(0.0, 200.0, 0.1)
    recv = 1.7e9 + boot + 0.2
    recv[1000] += 4.6e12  # a flipped high bit in one tlog stamp: 146,000 years later
    tracemalloc.start()
    out = _boot_from_log(recv[:999], recv, boot)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 50e6, peak
    np.testing.assert_allclose(out, boot[:999], atol=1e-6)


def test_align_refuses_a_grid_past_its_budget():
    from uuvid.io.logs import LogDataError, TimeResponse, align

    r = TimeResponse(np.array([0.0, 1.0, 1e7]), {"a": np.array([1.0, 2.0, 3.0])}, {})
    with pytest.raises(LogDataError, match="more than 10,000,000; give a larger resampling"):
        align([r], 1e-3)
    assert align([r], 1e5).t.size == 101


def _tlog_frames(b: bytes):
    """(offset, message id) of each record of a MAVLink telemetry log."""
    off, out = 0, []
    while off < len(b) - 10:
        if b[off + 8] == 0xFD:
            n, mid = 10 + b[off + 9] + 2 + (13 if b[off + 10] & 1 else 0), int.from_bytes(
                b[off + 15:off + 18], "little")
        elif b[off + 8] == 0xFE:
            n, mid = 8 + b[off + 9], b[off + 13]
        else:
            break
        out.append((off, mid))
        off += 8 + n
    return out


@pytest.mark.slow
@pytest.mark.realdata
@pytest.mark.parametrize("msgid", [30, 74])  # ATTITUDE (stamped), VFR_HUD (mapped)
def test_tlog_with_a_corrupt_receive_stamp_ends_in_a_clear_error_or_a_result(
        shared_data, tmp_path, msgid):
    from uuvid.io.logs import LogDataError, read_ardusub

    b = bytearray((shared_data / "ardusub-bluerov2" / "small.tlog").read_bytes())
    frames = _tlog_frames(b)
    assert len(frames) > 1000
    k = next(o for o, m in frames[len(frames) // 2:] if m == msgid)
    b[k] ^= 0x40  # the receive stamp's top byte: + 4.6e12 s
    p = tmp_path / "corrupt.tlog"
    p.write_bytes(bytes(b))
    try:
        out = read_ardusub(p, on_duplicate="mean")
    except LogDataError as e:
        assert "corrupt.tlog" in str(e)
    else:
        for r in out.values():
            assert np.all(np.isfinite(r.t)) and r.t.max() - r.t.min() < 1e4


@pytest.mark.slow
@pytest.mark.realdata
def test_bin_with_a_corrupt_format_description_names_the_field(shared_data, tmp_path):
    from uuvid.io.ardusub.reader import read_raw
    from uuvid.io.logs import LogDataError

    b = bytearray((shared_data / "ardusub-bluerov2" / "small.BIN").read_bytes())
    i = b.find(b"\xa3\x95\x80")
    while i >= 0:  # FMT records: BARO's label "Alt" becomes "alt"
        if bytes(b[i + 5:i + 9]) == b"BARO":
            j = bytes(b[i + 25:i + 89]).find(b"Alt")
            b[i + 25 + j] ^= 0x20
        i = b.find(b"\xa3\x95\x80", i + 1)
    p = tmp_path / "corrupt.BIN"
    p.write_bytes(bytes(b))
    with pytest.raises(LogDataError, match=r"corrupt\.BIN: BARO has no field 'Alt'.*FMT"):
        read_raw(p).get("BARO").array("Alt")
    res = runner.invoke(app, ["log", "export", str(p), "--out-file", str(tmp_path / "x.csv")])
    assert "Traceback" not in res.output and "BARO has no field 'Alt'" in res.output


# ------------------------------------------------------------------------- inertia logs
def _inertia_csv(path, jump=0.0):
    import csv
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent))
    from test_log_identify import _jittery_sine

    _, rows, _, _ = _jittery_sine(uniform=True)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["time", "torque", "yaw"])
        for i, r in enumerate(rows):
            w.writerow([f"{float(r[0]) + (jump if i > len(rows) // 2 else 0.0):.4f}", *r[1:]])
    return path


INERTIA = ("vehicle", "identify", "inertia")
COLS = ("--dof", "yaw", "--command-col", "torque", "--position-col", "yaw", "--k", "20.5",
        "--kq", "49.5")


@pytest.mark.slow
@pytest.mark.parametrize("resample", ["auto", "off"])
def test_clock_jump_in_an_inertia_log_is_refused_before_gridding(tmp_path, resample):
    p = _inertia_csv(tmp_path / "jump.csv", jump=1e7)
    res = runner.invoke(app, [*INERTIA, str(p), *COLS, "--resample", resample])
    clean_error(res, "the largest gap is 1e+07 s", "--t-start/--t-end")


@pytest.mark.slow
def test_inertia_resample_step_past_the_grid_budget(tmp_path):
    p = _inertia_csv(tmp_path / "ok.csv")
    res = runner.invoke(app, [*INERTIA, str(p), *COLS, "--resample", "1e-6"])
    clean_error(res, "more than 2,000,000; give a larger --resample step")


# ------------------------------------------------------------------------- compiled entry points
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

BAD = st.sampled_from([math.nan, math.inf, -math.inf])


@pytest.fixture(scope="module")
def short_setup():
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import setup_mission
    from uuvid.vehicle.definition import load_vehicle

    return setup_mission(load_vehicle("bluerov2"), square_mission(speed=0.5), t_end=0.5)


@pytest.mark.slow
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(which=st.sampled_from(["vehicle_params", "thruster_params", "currents"]),
       fast=st.booleans(), runs=st.integers(1, 3), pos=st.integers(0, 10_000), bad=BAD)
def test_batch_runners_refuse_non_finite_inputs_before_compiled_code(short_setup, which, fast,
                                                                     runs, pos, bad):
    from uuvid.simulate.batch import run_batch_fast
    from uuvid.simulate.vehicle_sim import run_batch

    s = short_setup
    args = {"vehicle_params": np.tile(s.vp, (runs, 1)),
            "thruster_params": np.tile(s.bank.params, (runs, 1, 1)),
            "currents": np.zeros((runs, 3))}
    a = args[which]
    a.ravel()[pos % a.size] = bad
    with pytest.raises(ValueError, match=rf"^{which}\[.*\] = -?(nan|inf): expected finite"):
        (run_batch_fast if fast else run_batch)(s, **args)


@pytest.mark.parametrize("fast", [False, True])
@pytest.mark.parametrize("which, shape", [("vehicle_params", (2, 100)),
                                          ("thruster_params", (2, 3, 17)), ("currents", (1, 3))])
def test_batch_runners_refuse_wrong_shapes(short_setup, fast, which, shape):
    from uuvid.simulate.batch import run_batch_fast
    from uuvid.simulate.vehicle_sim import run_batch

    s = short_setup
    args = {"vehicle_params": np.tile(s.vp, (2, 1))}
    args[which] = np.zeros(shape)
    with pytest.raises(ValueError, match=rf"^{which}: expected .*shape"):
        (run_batch_fast if fast else run_batch)(s, **args)


def test_batch_runners_accept_zero_runs(short_setup):
    from uuvid.simulate.batch import run_batch_fast

    assert run_batch_fast(short_setup, np.zeros((0, short_setup.vp.size))).shape[0] == 0


@settings(max_examples=60, deadline=None)
@given(i=st.integers(0, 5), bad=BAD,
       sat=st.sampled_from(["scale", "clip", "none", "priority", "maxscale"]))
def test_allocate_refuses_a_non_finite_wrench(i, bad, sat):
    al = _allocator()
    phi = np.array([10.0, -5.0, 3.0, 0.0, 0.0, 1.0])
    phi[i] = bad
    with pytest.raises(ValueError, match=rf"phi\[{i}\] = -?(nan|inf): expected finite"):
        al.allocate(phi, sat)


_AL = []


def _allocator():
    from uuvid.vehicle.definition import load_vehicle

    if not _AL:
        _AL.append(load_vehicle("bluerov2").allocator())
    return _AL[0]


@pytest.mark.parametrize("kw", [{"dt": 0.0}, {"dt": -1e-3}, {"dt": math.nan},
                                {"settle_time": 0.0}, {"settle_time": math.inf},
                                {"dt": 1e-12}, {"max_passes": 0}])
def test_thruster_sweep_checks_its_step_before_the_kernel(kw):
    from uuvid.thruster.presets import preset_chain

    with pytest.raises(ValueError, match="^sweep: "):
        preset_chain("laidani-a2212").sweep([4.0, 8.0], **kw)


@settings(max_examples=30, deadline=None)
@given(levels=st.lists(st.floats(0, 12), min_size=1, max_size=4), pos=st.integers(0, 3), bad=BAD)
def test_thruster_sweep_refuses_non_finite_levels(levels, pos, bad):
    from uuvid.thruster.presets import preset_chain

    levels[pos % len(levels)] = bad
    with pytest.raises(ValueError, match=r"u\[\d+\] = -?(nan|inf)"):
        preset_chain("laidani-a2212").sweep(levels)


def test_thruster_simulate_refuses_a_run_past_its_memory_budget():
    from uuvid.thruster.chain import MAX_SAMPLES, _n_samples
    from uuvid.thruster.presets import preset_chain

    c = preset_chain("laidani-a2212")
    with pytest.raises(ValueError, match="more than the 2,000,000"):
        c.simulate(1.0, t_end=1e7)
    with pytest.raises(ValueError, match="× 400 runs"):
        c.simulate_batch(np.tile(c.compile().params, (400, 1)), 1.0, t_end=5.0)
    assert _n_samples((MAX_SAMPLES - 1) * 1e-3, 1e-3, 4) == MAX_SAMPLES  # the budget itself
    with pytest.raises(ValueError):
        _n_samples((MAX_SAMPLES + 1) * 1e-3, 1e-3, 4)
    res = runner.invoke(app, ["thruster", "simulate", "t200", "--t-end", "1e7"])
    clean_error(res, "shorten t_end (--t-end) or raise dt (--dt)")


def test_dynamic_fit_with_time_in_microseconds_is_refused_at_once():
    import time

    from uuvid.identify.thruster.dynamic import Run, fit_first_order

    t = np.arange(0.0, 2.0, 0.005)
    y = 100 * (1 - np.exp(-t / 0.1))
    t0 = time.perf_counter()
    with pytest.raises(ValueError, match="time column in ms or µs"):
        fit_first_order([Run(t * 1e6, np.full(t.size, 12.0), y, "prop_speed")])
    assert time.perf_counter() - t0 < 2.0


@pytest.mark.slow
def test_healey_fit_on_vanishing_thrust_is_an_error(tmp_path):
    import csv

    from uuvid.identify.thruster.dynamic_select import reference_two_state_thruster, synthetic_experiments

    recs = synthetic_experiments(reference_two_state_thruster(), (2.0,), rate=200.0, seed=5)
    files = []
    for e in recs:
        p = tmp_path / f"run{e.name}.csv"
        with open(p, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["t", "V", "w", "T"])
            w.writerows(zip(e.t, e.u, e.speed, e.thrust * 1e-300))
        files.append(str(p))
    res = runner.invoke(app, ["thruster", "fit", *files, "--time-col", "t", "--command-col", "V",
                              "--command-unit", "volts", "--speed-col", "w", "--thrust-col", "T",
                              "--model", "healey", "--out-model", str(tmp_path / "h.yaml")])
    clean_error(res, "healey", "thrust column's unit")


# ------------------------------------------------------------------------- generated documents
LEAVES = st.one_of(st.none(), st.booleans(), st.integers(-10**20, 10**20),
                   st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=8),
                   st.sampled_from(["quadratic", "bluerov2", "t200", "esc", "1e7", "-1", ""]))
VALUES = st.recursive(LEAVES, lambda c: st.lists(c, max_size=4)
                      | st.dictionaries(st.text(max_size=6), c, max_size=3), max_leaves=8)


def _paths(doc, prefix=()):
    yield prefix
    items = doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) else ()
    for k, v in items:
        yield from _paths(v, (*prefix, k))


def _mutate(doc, data):
    """A deep copy of ``doc`` with one value (anywhere, the whole document included) replaced or
    one key deleted, drawn by hypothesis."""
    import copy

    doc = copy.deepcopy(doc)
    paths = list(_paths(doc))
    path = data.draw(st.sampled_from(paths), label="path")
    new = data.draw(VALUES, label="value")
    if not path:
        return new
    parent = doc
    for k in path[:-1]:
        parent = parent[k]
    if isinstance(parent, dict) and data.draw(st.booleans(), label="delete"):
        del parent[path[-1]]
    else:
        parent[path[-1]] = new
    return doc


@pytest.mark.slow
@settings(max_examples=150, deadline=None)
@given(data=st.data())
def test_generated_model_files_end_in_a_model_file_error_or_a_valid_chain(data):
    from uuvid.thruster.modelfile import ModelFileError, chain_from_dict
    from uuvid.thruster.presets import preset_chain

    doc = _mutate(preset_chain("t200").to_dict(), data)
    try:
        chain = chain_from_dict(doc, where="m.yaml")
    except ModelFileError as e:
        assert str(e).startswith("m.yaml"), str(e)
        return
    assert chain.n_states >= 0


@pytest.mark.slow
@settings(max_examples=100, deadline=None)
@given(data=st.data())
def test_generated_vehicle_files_end_in_a_vehicle_file_error_or_a_vehicle(data):
    from uuvid.thruster.modelfile import ModelFileError, read_model_text
    from uuvid.vehicle.definition import preset_path, vehicle_from_dict

    doc = _mutate(_BLUEROV2.setdefault("doc", read_model_text(preset_path("bluerov2"))), data)
    try:
        v = vehicle_from_dict(doc, where="v.yaml", base_dir=preset_path("bluerov2").parent)
    except ModelFileError as e:
        assert "v.yaml" in str(e), str(e)
        return
    assert np.all(np.isfinite(v.params.to_array()))


_BLUEROV2: dict = {}
SCENARIO = {"name": "s", "vehicle": "bluerov2", "dt": 0.05, "duration": 2.0,
            "mission": {"kind": "waypoints", "waypoints": [[0, 0, 0, 0], [0, 0, 1, 0]],
                        "speed": 0.3},
            "current": [0.1, 0.0, 0.0], "controller": {"bandwidth": [1.5, 1.5, 1.5, 2.0]}}


@pytest.mark.slow
@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_generated_scenarios_end_in_a_scenario_error_or_a_setup(data, tmp_path_factory):
    from uuvid.simulate.scenario import build, scenario_from_dict
    from uuvid.thruster.modelfile import ModelFileError

    doc = _mutate(SCENARIO, data)
    try:
        _, setup = build(scenario_from_dict(doc, where="s.yaml"), None)
    except (ModelFileError, FileNotFoundError) as e:  # FileNotFoundError: a missing named file
        assert str(e), repr(e)
        return
    assert setup.t.size >= 1 and np.all(np.isfinite(setup.vp))


@pytest.mark.slow
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(raw=st.one_of(st.binary(max_size=200), st.text(max_size=200).map(str.encode)),
       suffix=st.sampled_from([".yaml", ".toml"]))
def test_generated_file_bytes_end_in_a_model_file_error(tmp_path, raw, suffix):
    from uuvid.thruster.modelfile import ModelFileError, load_chain

    p = tmp_path / f"m{suffix}"
    p.write_bytes(b"blocks:\n  - type: quadratic\n" + raw if suffix == ".yaml" else raw)
    try:
        load_chain(p)
    except ModelFileError as e:
        assert str(p) in str(e)


@pytest.mark.slow
@pytest.mark.parametrize("raw, needle", [(b'{"kind": "x\xff"}', "not UTF-8 text"),
                                         (b'{"kind": ', "line 1, column 10: not valid JSON")])
def test_uncertain_model_json_that_cannot_be_read(tmp_path, raw, needle):
    from uuvid.uncertainty.montecarlo import ModelError, load_model

    p = tmp_path / "model.json"
    p.write_bytes(raw)
    with pytest.raises(ModelError, match=f"model.json: {needle}"):
        load_model(p)
    res = runner.invoke(app, ["montecarlo", str(p), "--runs", "2", "--out", str(tmp_path / "o")])
    clean_error(res, "model.json", needle)


@pytest.mark.parametrize("fast", [False, True])
def test_batch_runners_refuse_thruster_parameters_their_blocks_refuse(short_setup, fast):
    """Zero thruster parameters made the kernels divide by zero (ZeroDivisionError from
    run_batch_fast, SystemError from run_batch); the blocks' own rules now apply to raw rows."""
    from uuvid.simulate.batch import run_batch_fast
    from uuvid.simulate.vehicle_sim import _positive_slots, run_batch

    s = short_setup
    names = {name for i, _, name, _ in _positive_slots(s.bank) if i == 0}
    assert "first_order_motor.time_constant" in names and "esc.supply_voltage" in names
    assert "esc.saturation_high" not in names  # a relation to saturation_low, not a sign rule
    TP = np.tile(s.bank.params, (2, 1, 1))
    slot = next(k for i, k, n, _ in _positive_slots(s.bank) if n.endswith("time_constant"))
    TP[1, 3, slot] = 0.0
    with pytest.raises(ValueError, match=rf"thruster_params\[1, 3, {slot}\] = 0.0: .*"
                                         r"time_constant, which must be > 0"):
        (run_batch_fast if fast else run_batch)(s, np.tile(s.vp, (2, 1)), TP)


@pytest.mark.parametrize("waypoints, said", [
    ([[0, 0, 0, 0], [5, 0, -20, 0]], "20 m above the surface: down is positive"),
    ([[0, 0, 2, 0], [5, 0, 2, 90]], "yaw 90: beyond ±2π rad — is it in degrees"),
])
def test_a_scenario_waypoint_above_the_surface_or_in_degrees_is_refused(waypoints, said):
    """Both flew to "completed: true" (a vehicle that cannot climb 20 m out of the water, a yaw
    of 90 rad); a battery at 0 % is refused too."""
    from uuvid.simulate.scenario import ScenarioError, scenario_from_dict

    doc = {"vehicle": "bluerov2", "mission": {"kind": "waypoints", "waypoints": waypoints}}
    with pytest.raises(ScenarioError, match=said):
        scenario_from_dict(doc, where="s.yaml")
    ok = {"vehicle": "bluerov2", "mission": {"kind": "waypoints",
                                             "waypoints": [[0, 0, 0, 0], [5, 0, 2, 1.5]]}}
    scenario_from_dict(ok, where="s.yaml")
    with pytest.raises(ScenarioError, match="battery_soc"):
        scenario_from_dict({"vehicle": "bluerov2", "battery_soc": 0.0}, where="s.yaml")


def test_a_mission_that_empties_the_battery_is_not_completed():
    """The state of charge went below 0 and the mission still said "completed" with no warning:
    the battery model kept delivering charge it did not hold."""
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import fly_mission, setup_mission
    from uuvid.vehicle.definition import load_vehicle

    s = setup_mission(load_vehicle("bluerov2"), square_mission(speed=0.3), battery=True,
                      soc0=1e-4)
    r = fly_mission(s)
    said = [w for w in r.summary["warnings"] if "is empty from t = " in w]
    assert len(said) == 1 and r.summary["completed"] is False, r.summary["warnings"]
    full = fly_mission(setup_mission(load_vehicle("bluerov2"), square_mission(speed=0.3),
                                     battery=True, soc0=1.0))
    assert not [w for w in full.summary["warnings"] if "is empty" in w]


def test_a_vehicle_without_thrusters_is_named_not_a_reshape_error():
    """`simulate` with a vehicle file whose thrusters list is empty said "controller: cannot
    reshape array of size 0 into shape (0)"."""
    import copy

    import yaml

    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import setup_mission
    from uuvid.vehicle.definition import preset_path, vehicle_from_dict

    raw = yaml.safe_load(preset_path("bluerov2").read_text())
    raw = copy.deepcopy(raw)
    raw["thrusters"] = []
    raw.pop("modes", None)
    raw.pop("allocation", None)
    try:
        v = vehicle_from_dict(raw, where="empty.yaml")
    except Exception as e:  # the file itself may be refused: then it names the thrusters
        assert "thruster" in str(e)
        return
    with pytest.raises(ValueError, match="has no thrusters: nothing can fly a mission"):
        setup_mission(v, square_mission())


# ------------------------------------------------------------------- a flight's footprint
def _long_scenario(**kw):
    from uuvid.simulate.scenario import scenario_from_dict

    return scenario_from_dict({"vehicle": "bluerov2", "duration": 199999, "dt": 0.1,
                               "substeps": 100, **kw})


def test_a_flight_whose_outputs_overflow_memory_is_refused_before_it_flies(tmp_path, monkeypatch):
    """duration 199999 s, dt 0.1 s, substeps 100 passed the step cap (1,999,990 < 2,000,000):
    `uuvid simulate --out` flew 177 s, took 3.9 GB of memory and wrote a 1.17 GB
    timeseries.csv without a word.  The cap now counts rows × columns and the output files:
    refused up front, saying how much and what fits (on a machine of 8 GB: a quarter of it is
    the 2 GB floor)."""
    import uuvid.simulate.footprint as fpm
    from uuvid.simulate.scenario import ScenarioError, build

    monkeypatch.setattr(fpm, "physical_memory_bytes", lambda: 8e9)

    with pytest.raises(ScenarioError) as got:
        build(_long_scenario(), out=tmp_path / "out")
    msg = str(got.value)
    assert msg.startswith("duration = 199999 s at dt = 0.1 s is 1,999,990 control steps"), msg
    assert "31 columns written: the flight would take ≈ 5 GB of memory" in msg
    assert "timeseries.csv ≈ 1.2 GB" in msg and "more than the 2 GB one flight may take on this machine" in msg
    assert "shorten duration to ≤ 79668" in msg
    assert "(dt = 0.1 s is at its largest, 0.1 s)" in msg and "raise dt" not in msg
    assert "fly without the output folder (--out: the summary only, ≈ 1.1 GB" in msg
    p = tmp_path / "big.yaml"
    p.write_text("duration: 19999\ndt: 0.01\n")
    res = runner.invoke(app, ["simulate", str(p), "--out", str(tmp_path / "o")])
    clean_error(res, "big.yaml: duration = 19999 s at dt = 0.01 s is 1,999,900 control steps",
                "raise dt to ≥ 0.025 s")
    assert not (tmp_path / "o").exists()


def test_a_long_flight_without_outputs_is_said_before_it_flies():
    """The same flight without outputs holds ≈ 1.1 GB: it flies (a legitimate long mission), with
    warnings saying its size and its 2e8 RK4 steps first."""
    from uuvid.core.checks import InputWarning
    from uuvid.simulate.scenario import build

    with pytest.warns(InputWarning) as got:
        _, setup = build(_long_scenario())
    said = [str(w.message) for w in got]
    assert setup.t.size == 1_999_990
    assert any(s.startswith("a large flight: duration = 199999 s") and "≈ 1.1 GB of memory" in s
               for s in said), said
    assert any("1,999,990 control steps × 100 substeps = 2e+08 RK4 steps" in s for s in said), said


def test_an_ordinary_flight_says_nothing_of_its_size(tmp_path):
    import warnings

    from uuvid.simulate.footprint import flight_footprint
    from uuvid.simulate.scenario import build, scenario_from_dict

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, setup = build(scenario_from_dict({"vehicle": "bluerov2"}), out=tmp_path / "o")
    fp = flight_footprint(setup, outputs=True)
    assert fp.output_columns == 31 and fp.columns == 47 and fp.memory < 1e8


def test_outputs_larger_than_the_free_disk_are_refused(tmp_path, monkeypatch):
    import uuvid.simulate.footprint as fpm
    from uuvid.simulate.scenario import ScenarioError, build, scenario_from_dict

    monkeypatch.setattr(fpm, "_free_space", lambda folder: 1e6)
    with pytest.raises(ScenarioError, match=r"its outputs would take ≈ \d+ MB on disk "
                                            r"\(timeseries\.csv ≈ .*has 1 MB free; shorten"):
        build(scenario_from_dict({"vehicle": "bluerov2", "duration": 2000}), out=tmp_path / "o")


def test_the_flight_memory_limit_is_a_quarter_of_a_larger_machine(monkeypatch):
    """The 2 GB floor on a small machine; a quarter of a larger one's physical memory (the same
    on every run: not the memory free at the moment; a machine that does not say counts as 4 GB,
    core.checks.physical_memory_bytes: the floor)."""
    import uuvid.simulate.footprint as fpm

    for mem, want in ((4e9, 2e9), (8e9, 2e9), (64e9, 16e9)):
        monkeypatch.setattr(fpm, "physical_memory_bytes", lambda m=mem: m)
        assert fpm.flight_memory_limit() == want
    monkeypatch.undo()
    assert fpm.flight_memory_limit() >= 2e9


@pytest.mark.parametrize("bad", ["nan", "inf", "short", "text"])
def test_thruster_simulate_refuses_a_bad_x0_up_front(bad):
    """x0 = [nan] was flown and reported as 'diverged … use a smaller dt' (the step was not the
    fault); a wrong length or text was found only after the signal was sampled and the chain
    compiled.  Refused first, naming x0."""
    from uuvid.thruster.presets import preset_chain

    c = preset_chain("laidani-a2212")
    n = c.n_states
    assert n >= 1
    x0 = {"nan": [math.nan] + [0.0] * (n - 1), "inf": [0.0] * (n - 1) + [math.inf],
          "short": [0.0] * (n + 1), "text": ["a"] * n}[bad]
    match = {"nan": r"^x0\[0\] = nan: expected", "inf": rf"^x0\[{n - 1}\] = inf: expected",
             "short": rf"^x0 has shape \({n + 1},\): expected {n} component", "text": r"^x0 = "}[bad]

    def signal(t):
        raise AssertionError("x0 was not checked before the signal was sampled")

    with pytest.raises(ValueError, match=match):
        c.simulate(signal, t_end=0.1, x0=x0)
