"""A bad number on the command line ends in one error line (exit status 2) that names the option,
never a traceback, a hang, an out-of-memory, a NaN table or a silently clamped value.

Every case here failed before its fix (a traceback: exit status 1; a silent result: exit status
0; an unbounded run: past the time budget) and must fire before any simulation or compilation,
so each call gets :data:`BUDGET_S` seconds (an alarm ends a hang as a failed test; a call that
would hang in compiled code, where no alarm reaches, runs in a process that is killed)."""

import math
import os
import signal
import subprocess
import sys
from contextlib import contextmanager

import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app

runner = CliRunner()

#: Seconds one refused call may take (they take about one; a simulation or a compile takes more).
BUDGET_S = 30


@contextmanager
def _budget(seconds: int):
    def timeout(signum, frame):
        raise TimeoutError(f"the call ran past {seconds} s: the error did not fire first")

    old = signal.signal(signal.SIGALRM, timeout)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def invoke(args: list[str]):
    with _budget(BUDGET_S):
        return runner.invoke(app, args)


class _Ran:
    """A finished ``uuvid`` process, shaped like a ``CliRunner`` result for :func:`refused`."""

    def __init__(self, p: subprocess.CompletedProcess):
        self.exit_code = p.returncode
        self.output = p.stdout + p.stderr
        self.exception = SystemExit(p.returncode)


def invoke_process(args: list[str]):
    """:func:`invoke` in its own process, for a call that would run in compiled code when the
    check is missing (an alarm does not stop a compiled loop; a killed process does)."""
    try:
        p = subprocess.run([sys.executable, "-m", "uuvid.cli.app", *args], capture_output=True,
                           text=True, timeout=BUDGET_S, env={**os.environ, "COLUMNS": "200"})
    except subprocess.TimeoutExpired:
        pytest.fail(f"uuvid {' '.join(args)} ran past {BUDGET_S} s: the error did not fire first")
    return _Ran(p)


def refused(res, *needles):
    """Exit status 2 (a user error), no traceback, the option and the expectation named."""
    out = res.output
    assert res.exit_code == 2, (res.exit_code, out, repr(res.exception))
    assert isinstance(res.exception, SystemExit), repr(res.exception)
    assert "Traceback" not in out
    for n in needles:
        assert n in out, (n, out)


@pytest.fixture(scope="module")
def examples(tmp_path_factory):
    """The built-in example logs the commands read (the quick ones: no simulation)."""
    from uuvid.examples import write_example

    folder = tmp_path_factory.mktemp("examples")
    for name in ("yaw-steady", "yaw-sine", "thruster-flow"):
        write_example(name, folder)
    return folder


# ------------------------------------------------------------------------- thruster
@pytest.mark.parametrize("args, needles", [
    (["--dt", "1e12"], ["at least 3", "--dt"]),
    (["--t-end", "0.001", "--dt", "0.001"], ["at least 3"]),
    (["--substeps", "1000000000"], ["--substeps", "10,000"]),
    (["--substeps", "5000", "--t-end", "20"], ["RK4 steps", "--substeps"]),
])
@pytest.mark.slow
def test_thruster_simulate(args, needles):
    refused(invoke_process(["thruster", "simulate", "t200", *args]), *needles)


@pytest.mark.parametrize("args, needles", [
    (["--table-points", "1000000000"], ["--table-points", "GB", "at most 2,000,000"]),
    (["--thruster-id", "-1"], ["--thruster-id", ">= 0"]),
])
def test_thruster_export(args, needles):
    refused(invoke(["thruster", "export", "t200", "--to", "uuv-simulator", *args]), *needles)


@pytest.mark.parametrize("args, needles", [
    (["--pwm", "1100:1900:100", "--supply-voltage", "nan"], ["--supply-voltage", "> 0"]),
    (["--pwm", "1100:1900:100", "--supply-voltage", "inf"], ["--supply-voltage", "> 0"]),
    (["--pwm", "1100:1900:100", "--supply-voltage", "1e12"], ["--supply-voltage", "1000 V"]),
    (["--pwm", "0:1e12:1"], ["--pwm", "100,000", "larger step"]),
    (["--pwm", "1100:1900:1e-9"], ["--pwm", "100,000"]),
    (["--pwm", "1100:inf:1"], ["--pwm", "finite"]),
    (["--pwm", "nan"], ["--pwm", "finite"]),
    (["--pwm", "inf,1500"], ["--pwm", "finite"]),
])
def test_thruster_predict(args, needles):
    refused(invoke(["thruster", "predict", "t200", *args]), *needles)


@pytest.mark.parametrize("args, needles", [
    (["--model", "four-quadrant", "--speed-col", "speed", "--thrust-col", "thrust",
      "--diameter", "1e12"], ["--diameter", "20 m"]),
    (["--model", "quadratic", "--speed-col", "speed", "--thrust-col", "thrust",
      "--neutral", "nan"], ["--neutral", "finite"]),
    (["--model", "table", "--thrust-col", "thrust", "--flow-speed-col", "none",
      "--table-points", "0"], ["--table-points", "at least 2"]),
])
def test_thruster_fit(examples, tmp_path, args, needles):
    refused(invoke(["thruster", "fit", str(examples / "thruster_flow.csv"), "--command-col",
                    "command", "--out-model", str(tmp_path / "m.yaml"), *args]), *needles)


def test_thruster_fit_table_says_when_it_keeps_every_knot(examples, tmp_path):
    """More knots than distinct commands: the table keeps them all and says so (not silently)."""
    res = invoke(["thruster", "fit", str(examples / "thruster_flow.csv"), "--model", "table",
                  "--thrust-col", "thrust", "--command-col", "command", "--flow-speed-col",
                  "none", "--table-points", "1000000000", "--out-model", str(tmp_path / "t.yaml")])
    assert res.exit_code == 0, res.output
    assert "1,000,000,000 knots asked for" in res.output


@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_thruster_replay_neutral(examples, value):
    res = invoke(["thruster", "replay", "t200", str(examples / "thruster_flow.csv"), "--neutral",
                  value])
    refused(res, "--neutral", "finite")


def test_thruster_replay_neutral_a_command_model_would_ignore(tmp_path):
    """A PWM-driven model's ESC holds its own neutral; another ``--neutral`` was ignored."""
    run = tmp_path / "run.csv"
    run.write_text("time,command,thrust\n" + "".join(
        f"{0.01 * i:.2f},{1500 if i < 100 else 1700},{0 if i < 100 else 20}\n" for i in range(300)))
    base = ["thruster", "replay", "t200", str(run), "--command-unit", "pwm_us", "--thrust-col",
            "thrust"]
    refused(invoke(base + ["--neutral", "1400"]), "--neutral 1400", "neutral command 1500")
    for same in (["--neutral", "1500"], []):
        res = invoke(base + same)
        assert res.exit_code == 0, res.output


# ------------------------------------------------------------------------- vehicle
@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf", "90", "1e12"])
def test_vehicle_stability_max_tilt(value):
    refused(invoke(["vehicle", "stability", "bluerov2", "--max-tilt", value]), "--max-tilt",
            "between 0 and 90")


@pytest.mark.parametrize("args, needles", [
    (["--step", "0"], ["--step", "> 0"]),
    (["--step", "-1"], ["--step", "> 0"]),
    (["--step", "nan"], ["--step", "> 0"]),
    (["--step", "inf"], ["--step", "> 0"]),
    (["--step", "1e12"], ["--step", "at most 180"]),
    (["--step", "1e-9"], ["--step", "at least 0.1"]),
    (["--current", "nan"], ["--current", "finite"]),
    (["--current", "inf"], ["--current", "finite"]),
    (["--current", "0.5,nan"], ["--current", "finite"]),
    (["--current", "0.5,inf"], ["--current", "finite"]),
    (["--simulate", "nan"], ["--simulate", "finite"]),
    (["--simulate", "inf"], ["--simulate", "finite"]),
    (["--voltage", "1e12"], ["--voltage", "1000 V"]),
    (["--voltage", "nan"], ["--voltage", "> 0"]),
    (["--battery", "1.5"], ["--battery", "within 0..1"]),
])
def test_vehicle_hold(args, needles):
    refused(invoke(["vehicle", "hold", "bluerov2", *args]), *needles)


DESIGN = ["vehicle", "design-input", "--dof", "yaw"]
DESIGN_OK = {"--k": "28.6", "--mass-air": "93.75", "--speed": "-0.175"}


def _design(**over):
    opts = {**DESIGN_OK, **over}
    return DESIGN + [x for k, v in opts.items() for x in (k, v)]


@pytest.mark.parametrize("option, value, needles", [
    ("--speed", "nan", ["--speed", "finite"]),
    ("--speed", "inf", ["--speed", "finite"]),
    ("--w", "nan", ["--w", "finite"]),
    ("--w", "inf", ["--w", "finite"]),
    ("--settle-tau", "nan", ["--settle-tau", ">= 0"]),
    ("--settle-tau", "inf", ["--settle-tau", ">= 0"]),
    ("--settle-tau", "1e12", ["samples", "--sample-time"]),
    ("--lead-in", "nan", ["--lead-in", ">= 0"]),
    ("--lead-in", "inf", ["--lead-in", ">= 0"]),
    ("--lead-in", "1e12", ["samples", "--lead-in"]),
    ("--n-periods", "1e12", ["samples", "--n-periods"]),
    ("--mass", "1e12", ["samples", "GB"]),
    ("--mass-air", "1e12", ["samples", "GB"]),
    ("--mass-air", "0", ["--mass-air", "positive"]),
    ("--added-mass-range", "0,1e12", ["samples", "GB"]),
    ("--sample-time", "1e12", ["--sample-time", "Nyquist"]),
])
def test_design_input(option, value, needles):
    refused(invoke(_design(**{option: value})), *needles)


STEADY = ["--dof", "yaw", "--command-col", "torque", "--position-col", "heading_deg",
          "--angle-unit", "deg", "--mode-col", "mode", "--open-water-mode", "yaw_fl_rr+"]


@pytest.mark.parametrize("option, value, needle", [
    ("--settle", "nan", "expected a settling time"), ("--settle", "inf", "expected a settling"),
    ("--min-duration", "inf", "expected a duration"), ("--tol", "nan", "expected an absolute"),
    ("--tol", "inf", "expected an absolute"), ("--rel-tol", "nan", "expected a relative"),
    ("--rel-tol", "inf", "expected a relative"), ("--threshold", "0", "expected an outlier"),
    ("--threshold", "-1", "expected an outlier"), ("--threshold", "nan", "expected an outlier"),
    ("--threshold", "inf", "expected an outlier"), ("--t-start", "nan", "finite time"),
    ("--t-start", "-inf", "finite time"), ("--t-end", "inf", "finite time"),
    ("--t-end", "nan", "finite time"),
])
@pytest.mark.slow
def test_identify_steady(examples, option, value, needle):
    res = invoke(["vehicle", "identify", "steady", str(examples / "yaw_steady.csv"), *STEADY,
                  option, value])
    refused(res, option, needle)
    assert "segment 0:" not in res.output  # refused once, up front, not once per segment


def test_identify_steady_bandwidth_without_hac_is_refused(examples):
    """``--hac-lags`` with the default classical covariance was ignored without a word."""
    res = invoke(["vehicle", "identify", "steady", str(examples / "yaw_steady.csv"), *STEADY,
                  "--hac-lags", "3"])
    refused(res, "--hac-lags 3", "--cov-type HAC")
    ok = invoke(["vehicle", "identify", "steady", str(examples / "yaw_steady.csv"), *STEADY,
                 "--hac-lags", "3", "--cov-type", "HAC"])
    assert ok.exit_code == 0, ok.output


INERTIA = ["--dof", "yaw", "--command-col", "torque", "--position-col", "heading_deg",
           "--angle-unit", "deg", "--k", "28.6"]


@pytest.mark.parametrize("args, needles", [
    (["--omega", "1e12"], ["--omega", "Nyquist"]),
    (["--cov-type", "HAC", "--hac-lags", "-1"], ["--hac-lags", ">= 0"]),
    (["--max-filled", "-1"], ["--max-filled", ">= 0"]),
    (["--t-start", "nan"], ["--t-start", "finite"]),
    (["--t-end", "inf"], ["--t-end", "finite"]),
])
def test_identify_inertia(examples, args, needles):
    res = invoke(["vehicle", "identify", "inertia", str(examples / "yaw_sine.csv"), *INERTIA,
                  *args])
    refused(res, *needles)


def test_identify_inertia_huge_hac_bandwidth_is_quick_and_said(examples):
    """A HAC bandwidth of 10⁹ points summed 10⁹ empty lags (a hang); now as many as there are
    rows (the same σ) and a note that it is no HAC bandwidth."""
    res = invoke(["vehicle", "identify", "inertia", str(examples / "yaw_sine.csv"), *INERTIA,
                  "--hac-lags", "1000000000"])
    assert res.exit_code == 0, res.output
    assert "is not shorter than the" in res.output


@pytest.mark.parametrize("command", [["vehicle", "identify", "dive"], ["vehicle", "replay"]])
@pytest.mark.parametrize("option, value, needle", [
    ("--t-start", "nan", "finite"), ("--t-start", "-inf", "finite"),
    ("--t-end", "nan", "finite"), ("--t-end", "inf", "finite"),
    ("--horizon", "0", "> 0 s"), ("--horizon", "-1", "> 0 s"), ("--horizon", "nan", "> 0 s"),
    ("--horizon", "-inf", "> 0 s"),
])
@pytest.mark.slow
def test_dive_windows(tmp_path, command, option, value, needle):
    log = tmp_path / "dive.csv"  # refused before the log is read
    log.write_text("t_s,depth_m\n0,1\n")
    run = invoke_process if option == "--horizon" else invoke  # a replay's compiled loop
    refused(run([*command, str(log), "--vehicle", "bluerov2", "--dof", "heave", option, value]),
            option, needle)


# ------------------------------------------------------------------------- studies
@pytest.mark.parametrize("args, needles", [
    (["--runs", "1000000000"], ["--runs", "GB", "give at most"]),
    (["--runs", "4", "--seed", "-1"], ["--seed"]),
    (["--runs", "4", "--max-draws", "0"], ["--max-draws"]),
    (["--runs", "4", "--workers", "0"], ["--workers", ">= 1"]),
    (["--runs", "4", "--workers", "-1"], ["--workers", ">= 1"]),
    (["--runs", "4", "--workers", "1000000000"], ["--workers", "GB"]),
    (["--runs", "4", "--chunk-size", "0"], ["--chunk-size"]),
    (["--runs", "4", "--retries", "1000000000"], ["--retries", "0..100"]),
    (["--runs", "4", "--requirement", "steady_thrust<1e999"], ["--requirement", "finite"]),
])
@pytest.mark.slow
def test_montecarlo(args, needles):
    # in a process: the study's chunk loop would take an alarm for a failed chunk and go on
    res = invoke_process(["montecarlo", "t200-physical", *args])
    refused(res, *needles)
    assert "pydantic" not in res.output  # one line, not a validation dump


@pytest.mark.slow
def test_sweep_workers_past_memory(tmp_path):
    refused(invoke_process(["sweep", "mclean-sensitivity", "--out", str(tmp_path / "s"), "--workers",
                    "1000000000"]), "--workers", "GB")


def test_caccia_seed():
    refused(invoke(["reproduce", "caccia2000", "--fast", "--seed", "-1"]), "--seed")


@pytest.mark.slow
@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf", "-inf"])
def test_study_bandwidths(value):
    refused(invoke_process(["study", "thruster-loop", "--bandwidths", f"1,{value}"]),
            "--bandwidths", "314 rad/s")


@pytest.mark.parametrize("args, needles", [
    (["--current", "inf,0,0"], ["--current", "finite"]),
    (["--current", "nan,0,0"], ["--current", "finite"]),
    (["--speed", "-1"], ["--speed -1"]),
    (["--dt", "0"], ["--dt 0"]),
    (["--side", "inf"], ["--side inf"]),
])
def test_simulate_mission(args, needles):
    refused(invoke(["simulate", "mission", "square", *args]), *needles)


@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf"])
def test_log_export_dt(tmp_path, value):
    log = tmp_path / "x.tlog"  # refused before the log is read
    log.write_bytes(b"")
    refused(invoke(["log", "export", str(log), "--out-file", str(tmp_path / "d.csv"), "--dt",
                    value]), "--dt", "> 0 s")


@pytest.mark.slow
def test_log_export_dt_past_the_log_or_memory(shared_data, tmp_path):
    tlog = shared_data / "ardusub-bluerov2" / "small.tlog"
    for value, needle in (("1e12", "longest stretch"), ("1e-9", "GB of table")):
        refused(invoke(["log", "export", str(tlog), "--out-file", str(tmp_path / "d.csv"),
                        "--dt", value]), "--dt", needle)


# ------------------------------------------------------------------------- the library checks
def test_library_checks_name_the_parameter():
    from uuvid.core.checks import finite, positive, supply_voltage, time_window

    with pytest.raises(ValueError, match=r"^x = nan: expected a finite number"):
        finite("x", math.nan)
    with pytest.raises(ValueError, match=r"^x = 0: expected a finite number > 0"):
        positive("x", 0)
    with pytest.raises(ValueError, match=r"1000 V"):
        supply_voltage("v", 16e3)
    assert supply_voltage("v", 16) == 16.0
    with pytest.raises(ValueError, match=r"--horizon 0"):
        time_window(horizon=0)
    time_window(1.0, 2.0, 5.0)  # a valid window passes


@pytest.mark.parametrize("args", [["simulate", "mission", "square", "--current", "100,0,0"],
                                  ["vehicle", "hold", "bluerov2", "--current", "100"]])
def test_a_current_faster_than_any_sea_is_refused_with_the_unit_hint(args):
    """--current 100,0,0 flew until 'the simulation diverged … try a smaller dt'."""
    res = runner.invoke(app, args)
    assert res.exit_code == 2, res.output
    text = " ".join(res.output.split())
    assert "a current of 100 m/s is faster than any sea or river current" in text
    assert "in cm/s" in text
