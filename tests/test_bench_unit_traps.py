"""Bench data in a wrong unit are not fitted silently: a supply voltage in mV or a current in mA
is an error, a thrust beyond the momentum-theory bound of its electrical power (grams read as N)
is an error, and a huge thrust without electrical data or a speed in rpm read as rad/s is a
warning in the fit's outcome.  Small synthetic T200-like sweeps (steady fits only, no numba)."""

from __future__ import annotations

import csv
import re

import numpy as np
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.identify.plausibility import (
    bench_unit_warnings,
    check_bench_signs,
    check_bench_units,
    thrust_power_ratios,
)
from uuvid.identify.thruster.workflow import ReadOptions, run_fit
from uuvid.io.bench import BenchData, BenchDataError, header_unit, read_bench, read_t200

G_PER_N = 1000 / 9.80665  # grams-force per newton
PWM = np.arange(1100.0, 1901.0, 20.0)
D = (PWM - 1500.0) / 400.0  # −1…1
#: T200-like: up to 50 N forward / 40 N reverse, 25 A at 16 V, ≈ 400 rad/s (3800 rpm)
THRUST = np.where(D >= 0, 50.0, 40.0) * D * np.abs(D)
CURRENT = 0.2 + 24.8 * np.abs(D) ** 3
VOLTS = np.full(PWM.size, 16.0)
SPEED = 400.0 * D  # rad/s


def _write(path, **columns):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["pwm", *columns])
        for i, c in enumerate(PWM):
            w.writerow([repr(float(c))] + [repr(float(v[i])) for v in columns.values()])
    return path


def _read(path, **kw):
    cols = {"thrust": "thrust_col", "current": "current_col", "voltage": "voltage_col",
            "speed": "speed_col"}
    with open(path) as fh:
        header = next(csv.reader(fh))
    args = {cols[c]: c for c in header if c in cols}
    return read_bench(path, command_col="pwm", **args, **kw)


def _bound(power):
    """Actuator disk of 1 m² in sea water, by hand: T = (2ρAP²)^(1/3)."""
    return (2 * 1025.0 * 1.0 * power**2) ** (1 / 3)


# ------------------------------------------------------------------ a plausible file passes
def test_a_plausible_bench_file_passes_without_unit_warnings(tmp_path):
    f = _write(tmp_path / "t200like.csv", thrust=THRUST, current=CURRENT, voltage=VOLTS,
               speed=SPEED)
    d = _read(f)
    check_bench_signs(d)  # no error
    assert bench_unit_warnings(d) == []
    # the ratio the check tests, against the bound computed by hand: ≈ 0.07 at full power
    r = thrust_power_ratios(d)
    top = np.abs(D) == 1
    expected = np.abs(THRUST[top]) / _bound(16.0 * CURRENT[top])
    assert 0.03 < np.median(r) < 0.15
    assert np.median(r) == pytest.approx(np.median(expected), rel=0.3)
    assert max(r) == pytest.approx(max(expected), rel=1e-9)
    out = run_fit([f], "table", ReadOptions(command_col="pwm", thrust_col="thrust",
                                             current_col="current", voltage_col="voltage"))
    assert not [w for w in out.warnings if "implausible" in w]


def test_the_real_t200_sheets_pass_well_below_the_bound(shared_data):
    for volts in (12, 16):
        d = read_t200(shared_data / "t200-bluerobotics-2019" / f"T200_{volts}V.csv")
        check_bench_signs(d)
        assert bench_unit_warnings(d) == []
        assert 0.05 < float(np.median(thrust_power_ratios(d))) < 0.12


# ------------------------------------------------------------------ mV, mA: errors
def test_a_voltage_column_in_millivolts_is_refused_naming_it(tmp_path):
    f = _write(tmp_path / "mv.csv", thrust=THRUST, current=CURRENT, voltage=1000 * VOLTS)
    d = _read(f)
    with pytest.raises(BenchDataError, match=r"^mv.csv: the supply voltage column .*median of "
                                             r"16000 V .*data row \d+: 16000.*millivolts \(mV\)"
                                             r".*divide the voltage column by 1000"):
        check_bench_signs(d)
    check_bench_signs(_read(_write(tmp_path / "v.csv", thrust=THRUST, current=CURRENT,
                                   voltage=VOLTS)))


def test_a_supply_voltage_given_in_millivolts_is_refused_with_the_fix():
    d = BenchData(command=PWM, thrust=THRUST, supply_voltage=16000.0, source="s.csv")
    with pytest.raises(BenchDataError, match=r"s.csv: .*--supply-voltage 16000.*mV.*"
                                             r"--supply-voltage 16$"):
        check_bench_units(d)
    check_bench_units(BenchData(command=PWM, thrust=THRUST, supply_voltage=48.0))


def test_a_current_column_in_milliamperes_is_refused(tmp_path):
    f = _write(tmp_path / "ma.csv", thrust=THRUST, current=1000 * CURRENT, voltage=VOLTS)
    with pytest.raises(BenchDataError, match=r"^ma.csv: the supply current column .*reaches "
                                             r"25000 A .*milliamperes \(mA\).*by 1000"):
        check_bench_signs(_read(f))


# ------------------------------------------------------------------ grams read as N: error
def test_grams_read_as_newtons_are_refused_against_the_electrical_power(tmp_path):
    f = _write(tmp_path / "grams.csv", thrust=G_PER_N * THRUST, current=CURRENT, voltage=VOLTS)
    with pytest.raises(BenchDataError) as exc:
        check_bench_signs(_read(f))
    msg = str(exc.value)
    assert msg.startswith("grams.csv: the thrust is too large for its electrical power")
    assert "grams" in msg and "give --thrust-unit g" in msg
    # the numbers: a row's thrust, its power and the bound at that power, and the median ratio
    m = re.search(r"thrust \+?(-?[\d.]+) N at ([\d.]+) W .* at most "
                  r"\(2ρAP²\)\^\(1/3\) = ([\d.]+) N.* is ([\d.]+) over", msg)
    t, p, b, med = map(float, m.groups())
    assert b == pytest.approx(_bound(p), rel=1e-3)
    assert 5 < med < 12 and abs(t) / b == pytest.approx(med, rel=0.2)
    # the same file read in grams is a plausible T200
    d = _read(f, thrust_unit="g")
    check_bench_signs(d)
    assert bench_unit_warnings(d) == []
    assert np.max(np.abs(d.thrust)) == pytest.approx(50.0)


def test_the_power_bound_uses_still_water_rows_only():
    """A run in a flow is not bounded by the bollard formula: no error, but the warning of a
    thrust with nothing to check it against."""
    kw = dict(command=PWM, thrust=G_PER_N * THRUST, current=CURRENT, supply_voltage=16.0,
              source="flow.csv")
    with pytest.raises(BenchDataError, match="thrust is too large"):
        check_bench_units(BenchData(**kw, flow_speed=np.zeros(PWM.size)))
    flowing = BenchData(**kw, flow_speed=np.full(PWM.size, 1.5))
    check_bench_units(flowing)
    assert any("check the thrust unit (grams read as N?" in w
               for w in bench_unit_warnings(flowing))


# ------------------------------------------------------------------ warnings in the outcome
def test_a_huge_thrust_without_electrical_data_is_warned_in_the_fit_outcome(tmp_path):
    opts = ReadOptions(command_col="pwm", thrust_col="thrust")
    big = run_fit([_write(tmp_path / "big.csv", thrust=100 * THRUST)], "table", opts)
    said = [w for w in big.warnings if "check the thrust unit (grams read as N?)" in w]
    assert len(said) == 1 and said[0].startswith("big.csv: ") and "5000 N" in said[0]
    assert said[0] in big.to_dict()["warnings"]
    ok = run_fit([_write(tmp_path / "ok.csv", thrust=30 * THRUST)], "table", opts)  # 1500 N
    assert not [w for w in ok.warnings if "thrust unit" in w]


def test_rpm_read_as_rad_per_s_is_warned_and_the_unit_silences_it(tmp_path):
    rpm = 3800.0 * D
    f = _write(tmp_path / "rpm.csv", thrust=THRUST, speed=rpm)
    opts = dict(command_col="pwm", thrust_col="thrust", speed_col="speed")
    out = run_fit([f], "quadratic", ReadOptions(**opts))
    said = [w for w in out.warnings if "looks like rpm; give --speed-unit rpm" in w]
    assert len(said) == 1 and "3800 rad/s" in said[0]
    fixed = run_fit([f], "quadratic", ReadOptions(**opts, speed_unit="rpm"))
    assert not [w for w in fixed.warnings if "rpm" in w]
    # 1400 rad/s (≈ 13 400 rpm) is a fast motor, not a unit mistake
    assert bench_unit_warnings(_read(_write(tmp_path / "fast.csv", speed=1400.0 * D))) == []


# ------------------------------------------------------------------ through the CLI
def test_the_cli_exits_2_with_the_fix_and_fits_with_it(tmp_path):
    f = _write(tmp_path / "grams.csv", thrust=G_PER_N * THRUST, current=CURRENT, voltage=VOLTS)
    args = ["thruster", "fit", str(f), "--model", "table", "--command-col", "pwm",
            "--thrust-col", "thrust", "--current-col", "current", "--voltage-col", "voltage",
            "--out-model", str(tmp_path / "m.yaml")]
    runner = CliRunner()
    res = runner.invoke(app, args)
    assert res.exit_code == 2, res.output
    msg = " ".join(res.stderr.split())
    assert "grams.csv" in msg and "grams" in msg and "--thrust-unit g" in msg
    assert not (tmp_path / "m.yaml").exists()
    res = runner.invoke(app, [*args, "--thrust-unit", "g"])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "m.yaml").exists() and "implausible" not in res.stderr


def test_an_all_zero_current_column_is_refused(tmp_path):
    """The physical fit read a current column of zeros as a motor drawing nothing: R = 432 Ω,
    K_e = 98 V·s/rad, the model written with exit 0."""
    f = _write(tmp_path / "zeros.csv", thrust=THRUST, current=0 * CURRENT, voltage=VOLTS,
               speed=SPEED)
    with pytest.raises(BenchDataError, match=r"zeros\.csv: current is 0 in every row while the "
                                             r"command moves .*--current-col"):
        check_bench_signs(_read(f))


def test_one_file_at_several_supply_voltages_is_refused_for_a_map_of_the_command(tmp_path):
    """Rows at 12 V and 16 V in one file (a voltage column): --model table averaged them (43.9 N
    at 1900 µs, the mean of 36.4 and 51.4); two files at those voltages were already refused.
    A battery sagging under load (one voltage per command) passes."""
    from uuvid.identify.thruster.workflow import FitError

    both = tmp_path / "both.csv"
    a = _write(tmp_path / "a.csv", thrust=THRUST, voltage=VOLTS).read_text().splitlines()
    b = _write(tmp_path / "b.csv", thrust=THRUST * 0.56, voltage=0.75 * VOLTS).read_text().splitlines()
    both.write_text("\n".join(a + b[1:]) + "\n")
    opts = ReadOptions(command_col="pwm", thrust_col="thrust", voltage_col="voltage")
    with pytest.raises(FitError, match=r"--model table: both\.csv holds rows at supply voltages "
                                       r"33 % apart for one command \(12 V and 16 V at 1100\)"):
        run_fit([both], "table", opts)
    sag = _write(tmp_path / "sag.csv", thrust=THRUST, voltage=16.0 - 1.5 * np.abs(D))
    run_fit([sag], "table", opts)
    # a 4S pack drained over the session (two sweeps at 16.4 and 14.8 V: 11 %) passes too
    drain = tmp_path / "drain.csv"
    c = _write(tmp_path / "c.csv", thrust=THRUST, voltage=16.4 + 0 * VOLTS).read_text().splitlines()
    e = _write(tmp_path / "e.csv", thrust=0.9 * THRUST, voltage=14.8 + 0 * VOLTS).read_text().splitlines()
    drain.write_text("\n".join(c + e[1:]) + "\n")
    run_fit([drain], "table", opts)


def test_percent_commands_declared_as_volts_are_refused(tmp_path):
    """±100 "V" on a 16 V supply passed for the table and physical models."""
    from uuvid.io.bench import read_bench

    p = tmp_path / "pct.csv"
    rows = ["pct,thrust,voltage"] + [f"{100 * d:.6g},{t:.6g},16" for d, t in zip(D, THRUST)]
    p.write_text("\n".join(rows) + "\n")
    data = read_bench(p, command_col="pct", thrust_col="thrust", voltage_col="voltage",
                      command_unit="volts")
    with pytest.raises(BenchDataError, match=r"pct\.csv: the commands hold -100…100 V, beyond the "
                                             r"16 V supply.*look like percent"):
        check_bench_signs(data)
    volts = tmp_path / "volts.csv"
    volts.write_text("\n".join(["v,thrust,voltage"] + [f"{16 * d:.6g},{t:.6g},16"
                                                      for d, t in zip(D, THRUST)]) + "\n")
    check_bench_signs(read_bench(volts, command_col="v", thrust_col="thrust",
                                 voltage_col="voltage", command_unit="volts"))


def test_a_t200_sheet_refuses_units_it_would_ignore(shared_data):
    """``--format t200`` read its own units and dropped ``--thrust-unit lbf`` without a word."""
    from uuvid.identify.thruster.workflow import FitError

    f = shared_data / "t200-bluerobotics-2019" / "T200_16V.csv"
    with pytest.raises(FitError, match=r"--format t200 reads the sheet's own columns and units.*"
                                       r"--thrust-unit lbf would be ignored"):
        run_fit([f], "quadratic", ReadOptions(fmt="t200", thrust_unit="lbf"))
    run_fit([f], "quadratic", ReadOptions(fmt="t200"))


def test_a_physical_fit_of_one_direction_names_the_file_and_the_fix(tmp_path):
    f = _write(tmp_path / "fwd.csv", thrust=np.abs(THRUST), current=CURRENT, voltage=VOLTS,
               speed=np.abs(SPEED))
    opts = ReadOptions(command_col="pwm", thrust_col="thrust", current_col="current",
                       voltage_col="voltage", speed_col="speed")
    fwd_only = tmp_path / "fwd_only.csv"
    lines = f.read_text().splitlines()
    fwd_only.write_text("\n".join([lines[0]] + [r for r in lines[1:] if float(r.split(",")[0]) >= 1500])
                        + "\n")
    with pytest.raises(BenchDataError, match=r"fwd_only\.csv: no measured reverse samples .*--model "
                                             r"quadratic/polynomial/table"):
        run_fit([fwd_only], "physical", opts)


# ------------------------------------------------------------------ the unit in a column's header
def _hdr_file(path, thrust_header, speed_header=None):
    """A T200-like sweep with the thrust in the unit its header names (kgf, lbf, N)."""
    unit = header_unit(thrust_header, "thrust") or "N"
    per_n = {"N": 1.0, "kgf": 1 / 9.80665, "lbf": 1 / 4.4482216152605}[unit]
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["PWM [us]", thrust_header] + ([speed_header] if speed_header else []))
        for i, c in enumerate(PWM):
            w.writerow([c, THRUST[i] * per_n] + ([abs(SPEED[i]) * 60 / (2 * np.pi)]
                                                 if speed_header else []))
    return path


def test_a_thrust_header_in_kgf_is_read_in_kgf_and_said(tmp_path):
    """`--thrust-col "Thrust [kgf]"` without --thrust-unit fitted kgf as N (9.8× too small), silently."""
    f = _hdr_file(tmp_path / "kgf_hdr.csv", "Thrust [kgf]")
    d = read_bench(f, command_col="PWM [us]", thrust_col="Thrust [kgf]")
    np.testing.assert_allclose(d.thrust, THRUST, rtol=1e-9, atol=1e-12)
    assert len(d.notes) == 1 and "'Thrust [kgf]'" in d.notes[0] and "kgf" in d.notes[0]
    out = run_fit([f], "table", ReadOptions(command_col="PWM [us]", thrust_col="Thrust [kgf]"))
    assert d.notes[0] in out.notes
    # the same through the CLI: fitted in N, and the note on stderr
    res = CliRunner().invoke(app, ["thruster", "fit", str(f), "--command-col", "PWM [us]",
                                   "--thrust-col", "Thrust [kgf]", "--model", "table",
                                   "--out-model", str(tmp_path / "o.yaml")])
    assert res.exit_code == 0, res.output
    msg = " ".join(res.stderr.split())
    assert "'Thrust [kgf]'" in msg and "read in kgf" in msg and "converted to N" in msg
    assert "thrust -40 … 50 N" in res.stdout  # in kgf read as N: -4.079 … 5.099


def test_a_unit_given_against_the_header_is_refused(tmp_path, shared_data):
    sheet = shared_data / "t200-bluerobotics-2019" / "T200_16V.csv"
    with pytest.raises(BenchDataError, match=r"T200_16V.csv: column 'Force \(Kg f\)' is in kgf by "
                                             r"its header, but the thrust unit given is N .*"
                                             r"leave out --thrust-unit .*--thrust-unit kgf"):
        read_bench(sheet, command_col="PWM (us)", thrust_col="Force (Kg f)", thrust_unit="N")
    res = CliRunner().invoke(app, ["thruster", "fit", str(sheet), "--command-col", "PWM (us)",
                                   "--thrust-col", "Force (Kg f)", "--thrust-unit", "N",
                                   "--model", "table", "--out-model", str(tmp_path / "o.yaml")])
    assert res.exit_code == 2 and "'Force (Kg f)'" in res.stderr
    assert not (tmp_path / "o.yaml").exists()
    # the unit the header says, given or not, reads the sheet as read_t200 does
    ref = read_t200(sheet)
    for kw in ({}, {"thrust_unit": "kgf", "speed_unit": "rpm"}):
        d = read_bench(sheet, command_col="PWM (us)", thrust_col="Force (Kg f)", speed_col="RPM",
                       speed_sign="command", **kw)
        np.testing.assert_allclose(d.thrust, ref.thrust)
        np.testing.assert_allclose(d.speed, ref.speed)
        assert len(d.notes) == (2 if not kw else 0)
    # a speed column in rpm by its header, read as rad/s: refused the same way
    with pytest.raises(BenchDataError, match=r"column 'RPM' is in rpm by its header, but the "
                                             r"speed unit given is rad/s .*--speed-unit rpm"):
        read_bench(sheet, command_col="PWM (us)", speed_col="RPM", speed_unit="rad/s")


def test_a_suffix_names_the_unit_and_a_plain_header_changes_nothing(tmp_path):
    f = _hdr_file(tmp_path / "lbf.csv", "thrust_lbf")
    d = read_bench(f, command_col="PWM [us]", thrust_col="thrust_lbf")
    np.testing.assert_allclose(d.thrust, THRUST, rtol=1e-9, atol=1e-12)
    assert "read in lbf" in d.notes[0]
    plain = _hdr_file(tmp_path / "plain.csv", "thrust", "speed")
    for kw in ({}, {"thrust_unit": "N"}, {"thrust_unit": "kgf"}):
        d = read_bench(plain, command_col="PWM [us]", thrust_col="thrust", **kw)
        np.testing.assert_allclose(d.thrust, THRUST * (9.80665 if kw.get("thrust_unit") == "kgf"
                                                       else 1.0))
        assert d.notes == ()
    d = read_bench(plain, command_col="PWM [us]", speed_col="speed")  # no header unit: rad/s
    assert d.notes == () and np.max(np.abs(d.speed)) == pytest.approx(400 * 60 / (2 * np.pi))
    # a header that states N agrees with --thrust-unit N; a one-letter suffix says nothing
    n = _hdr_file(tmp_path / "n.csv", "Thrust [N]")
    assert read_bench(n, command_col="PWM [us]", thrust_col="Thrust [N]", thrust_unit="N").notes == ()
    assert header_unit("thrust_g", "thrust") is None and header_unit("Thrust (g)", "thrust") == "g"
    assert header_unit("Efficiency (g/W)", "thrust") is None
    assert header_unit("RPM [rpm]", "speed") == "rpm" and header_unit("w [rad/s]", "speed") == "rad/s"


def test_thruster_replay_says_which_unit_it_took_from_a_header(tmp_path):
    """`thruster replay` read a `thrust [kgf]` column in kgf (the header's unit) but did not say so,
    as `thruster fit` does."""
    from typer.testing import CliRunner

    from uuvid.cli.app import app

    run = tmp_path / "run.csv"
    run.write_text("time,command,thrust [kgf]\n" + "".join(
        f"{0.01 * i:.2f},{1500 if i < 100 else 1700},{0 if i < 100 else 2.0}\n" for i in range(300)))
    res = CliRunner().invoke(app, ["thruster", "replay", "t200", str(run), "--command-unit", "pwm_us",
                                   "--thrust-col", "thrust [kgf]"])
    said = " ".join(res.output.split())
    assert res.exit_code == 0, said
    assert "note:" in said and "kgf" in said and "unit in its header" in said, said


def test_rev_per_s_and_ounce_force_headers_are_read_in_their_units(tmp_path):
    """`speed [rev/s]`, `n (rps)`, `speed_hz` were read as rad/s and `Thrust [ozf]`, `thrust (oz)`
    as N, silently (rev/s as rpm would be 60× off, ounces as N 3.6× too large)."""
    from uuvid.core import units as U
    from uuvid.io.bench import SPEED_UNITS, THRUST_UNITS

    assert THRUST_UNITS["ozf"] == U.OZF == pytest.approx(0.27801385095378125, rel=1e-15)
    assert SPEED_UNITS["rev/s"] == U.REV_S == 2 * np.pi
    assert SPEED_UNITS["rev/s"] == pytest.approx(60 * SPEED_UNITS["rpm"], rel=1e-15)
    for h in ("speed [rev/s]", "n (rps)", "speed_hz", "Speed (Hz)", "omega (r/s)", "n_rev_s", "rps"):
        assert header_unit(h, "speed") == "rev/s", h
    for h in ("Thrust [ozf]", "thrust (oz)", "Thrust [oz-f]", "thrust_ozf", "thrust (ounce-force)"):
        assert header_unit(h, "thrust") == "ozf", h
    assert header_unit("Thrust (Hz)", "thrust") is None  # Hz is a shaft speed only
    for speed_h, thrust_h in (("speed [rev/s]", "Thrust [ozf]"), ("n (rps)", "thrust (oz)"),
                              ("speed_hz", "thrust_oz")):
        f = tmp_path / "rev.csv"
        with open(f, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["pwm", speed_h, thrust_h])
            for i, c in enumerate(PWM):
                w.writerow([c, repr(float(SPEED[i] / (2 * np.pi))), repr(float(THRUST[i] / 0.27801385095378125))])
        d = read_bench(f, command_col="pwm", speed_col=speed_h, thrust_col=thrust_h)
        np.testing.assert_allclose(d.speed, SPEED, rtol=1e-12)
        np.testing.assert_allclose(d.thrust, THRUST, rtol=1e-12, atol=1e-12)
        assert any("read in rev/s" in n for n in d.notes) and any("read in ozf" in n for n in d.notes)
        # the header's unit given agrees; another one contradicts it and is refused
        read_bench(f, command_col="pwm", speed_col=speed_h, speed_unit="rev/s")
        with pytest.raises(BenchDataError, match=r"is in rev/s by its header, but the speed unit "
                                                 r"given is rpm .*--speed-unit rev/s"):
            read_bench(f, command_col="pwm", speed_col=speed_h, speed_unit="rpm")
        with pytest.raises(BenchDataError, match=r"is in ozf by its header, but the thrust unit "
                                                 r"given is N .*--thrust-unit ozf"):
            read_bench(f, command_col="pwm", thrust_col=thrust_h, thrust_unit="N")
    # the options name the new units on a plain header (library and CLI)
    plain = _write(tmp_path / "plain.csv", thrust=THRUST / U.OZF, speed=SPEED / U.REV_S)
    d = _read(plain, thrust_unit="ozf", speed_unit="rev/s")
    np.testing.assert_allclose(d.thrust, THRUST, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(d.speed, SPEED, rtol=1e-12)
    res = CliRunner().invoke(app, ["thruster", "fit", str(plain), "--command-col", "pwm",
                                   "--thrust-col", "thrust", "--thrust-unit", "ozf", "--model", "table",
                                   "--out-model", str(tmp_path / "o.yaml")])
    assert res.exit_code == 0, res.output
    assert "thrust -40 … 50 N" in res.stdout


def test_a_t200_sheet_says_a_unit_option_contradicts_its_header(shared_data):
    """`--format t200 --thrust-unit N` (the result's unit, not the sheet's kgf) stays refused, and
    the message says why: the option names the unit of the file's column, which is kgf."""
    from uuvid.identify.thruster.workflow import FitError

    f = shared_data / "t200-bluerobotics-2019" / "T200_16V.csv"
    with pytest.raises(FitError, match=r"--thrust-unit N contradicts the sheet: its column "
                                       r"'Force \(Kg f\)' is in kgf by its header \(read in kgf and "
                                       r"converted to N; --thrust-unit names the unit of the "
                                       r"file's column, not of the result\)"):
        run_fit([f], "quadratic", ReadOptions(fmt="t200", thrust_unit="N"))
    with pytest.raises(FitError, match=r"--speed-unit rpm is the sheet's own unit"):
        run_fit([f], "quadratic", ReadOptions(fmt="t200", speed_unit="rpm"))


# ------------------------------------------------------------------ current and voltage units in a header
def test_a_current_header_in_milliamperes_is_read_in_milliamperes_and_said(tmp_path):
    """`Current [mA]` of a small thruster (peak < 1000 mA: no guard fires) was read as A: a physical
    fit wrote R off by 1000×, with only a note."""
    small = CURRENT / 30.0  # peak ≈ 0.84 A
    f = tmp_path / "small_ma.csv"
    with open(f, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["pwm", "thrust", "Current [mA]", "voltage_mv"])
        for i, c in enumerate(PWM):
            w.writerow([c, THRUST[i] / 30.0, 1000 * small[i], 16000.0])
    d = read_bench(f, command_col="pwm", thrust_col="thrust", current_col="Current [mA]",
                   voltage_col="voltage_mv")
    np.testing.assert_allclose(d.current, small, rtol=1e-12)
    np.testing.assert_allclose(d.supply_voltage, 16.0)
    said = " ".join(d.notes)
    assert "'Current [mA]'" in said and "read in mA" in said and "converted to A" in said
    assert "'voltage_mv'" in said and "read in mV" in said
    out = run_fit([f], "table", ReadOptions(command_col="pwm", thrust_col="thrust",
                                            current_col="Current [mA]", voltage_col="voltage_mv"))
    assert d.notes[0] in out.notes


def test_a_current_or_voltage_header_in_amperes_or_volts_changes_nothing(tmp_path):
    f = tmp_path / "a.csv"
    with open(f, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["pwm", "thrust", "Current (A)", "Voltage (V)"])
        for i, c in enumerate(PWM):
            w.writerow([c, THRUST[i], CURRENT[i], VOLTS[i]])
    d = read_bench(f, command_col="pwm", thrust_col="thrust", current_col="Current (A)",
                   voltage_col="Voltage (V)")
    np.testing.assert_allclose(d.current, CURRENT, rtol=1e-12)
    assert d.notes == ()


@pytest.mark.parametrize("header, role", [("Current [kgf]", "current"),
                                          ("Voltage [rpm]", "supply voltage")])
def test_a_unit_a_current_or_voltage_column_cannot_carry_is_refused(tmp_path, header, role):
    f = tmp_path / "bad.csv"
    with open(f, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["pwm", "thrust", header])
        for i, c in enumerate(PWM):
            w.writerow([c, THRUST[i], 16.0])
    kw = {"current_col": header} if role == "current" else {"voltage_col": header}
    units = "A, mA" if role == "current" else "V, mV"
    with pytest.raises(BenchDataError, match=rf"^bad.csv: column '{re.escape(header)}': '\w+' in "
                                             rf"its header is no {role} unit \({units} are read\)"):
        read_bench(f, command_col="pwm", thrust_col="thrust", **kw)


@pytest.mark.parametrize("cur, volt, scale", [("Current [A] (ESC)", "Voltage [V] (supply)", 1.0),
                                              ("Current (battery)", "Voltage (VDC)", 1.0),
                                              ("Current (A DC)", "Voltage [mV] (bus)", 1000.0)])
def test_a_word_in_brackets_beside_or_instead_of_a_unit_is_no_unit(tmp_path, cur, volt, scale):
    """A bracket that holds no unit ('(ESC)', '(battery)') or a unit with DC after it was refused
    as 'no current unit' once current and voltage headers were read for their units: they are
    read in A and V (or the unit in another bracket), as before."""
    f = tmp_path / "h.csv"
    with open(f, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["pwm", "thrust", cur, volt])
        for i, c in enumerate(PWM):
            w.writerow([c, THRUST[i], CURRENT[i], scale * VOLTS[i]])
    d = read_bench(f, command_col="pwm", thrust_col="thrust", current_col=cur, voltage_col=volt)
    np.testing.assert_allclose(d.current, CURRENT, rtol=1e-12)
    np.testing.assert_allclose(d.supply_voltage, VOLTS, rtol=1e-12)


# ------------------------------------------------------------------ a unit row under the header
def _unit_row_file(path, units, header=("pwm", "rpm", "current", "voltage", "thrust")):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerow(units)
        for i, c in enumerate(PWM):
            w.writerow([c, abs(SPEED[i]) * 60 / (2 * np.pi), CURRENT[i], 1000 * VOLTS[i],
                        THRUST[i] / 9.80665])
    return path


def test_a_unit_row_under_the_header_gives_the_columns_units_and_is_said(tmp_path):
    """A logger's `us,rpm,A,mV,kgf` row under the header was refused: "'us' is not numeric"."""
    f = _unit_row_file(tmp_path / "unitrow.csv", ["us", "rpm", "A", "mV", "kgf"])
    d = read_bench(f, command_col="pwm", speed_col="rpm", current_col="current",
                   voltage_col="voltage", thrust_col="thrust")
    assert len(d) == PWM.size
    np.testing.assert_allclose(d.thrust, THRUST, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(d.speed, SPEED, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(d.supply_voltage, VOLTS, rtol=1e-12)
    said = " ".join(d.notes)
    assert "CSV line 2 is a unit row (us, rpm, A, mV, kgf)" in said
    assert "'thrust': the thrust is read in kgf, the unit in the unit row (CSV line 2)" in said
    # rows keep their CSV lines in messages: the first data row is line 3
    bad = tmp_path / "neg.csv"
    lines = open(f).read().splitlines()
    lines[2] = lines[2].replace("1100.0", "-1100.0", 1)
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(BenchDataError, match=r"data row 1 \(CSV line 3\)"):
        read_bench(bad, command_col="pwm", thrust_col="thrust")


@pytest.mark.parametrize("units, col, pattern", [
    (["us", "rpm", "A", "V", "furlong"], "thrust", r"'furlong' under column 'thrust' is no thrust "
                                                   r"unit known here \(N, kgf"),
    (["%", "rpm", "A", "V", "kgf"], "pwm", r"'%' under column 'pwm' is no command unit"),
])
def test_a_unit_row_with_a_unit_unknown_for_its_column_is_refused_with_the_fix(tmp_path, units, col,
                                                                              pattern):
    f = _unit_row_file(tmp_path / "unitrow.csv", units)
    with pytest.raises(BenchDataError) as exc:
        read_bench(f, command_col="pwm", speed_col="rpm", thrust_col="thrust")
    msg = str(exc.value)
    assert msg.startswith("unitrow.csv: CSV line 2 looks like a unit row"), msg
    assert re.search(pattern, msg), msg
    assert f"'{col} [unit]'" in msg and "delete line 2" in msg


def test_a_unit_row_against_the_header_or_the_command_unit_is_refused(tmp_path):
    f = _unit_row_file(tmp_path / "clash.csv", ["us", "rpm", "A", "V", "kgf"],
                       header=("pwm", "rpm", "current", "voltage", "thrust [lbf]"))
    with pytest.raises(BenchDataError, match=r"column 'thrust \[lbf\]' is in lbf by its header but "
                                             r"in kgf by the unit row \(CSV line 2\)"):
        read_bench(f, command_col="pwm", thrust_col="thrust [lbf]")
    f = _unit_row_file(tmp_path / "duty.csv", ["duty", "rpm", "A", "V", "kgf"])
    with pytest.raises(BenchDataError, match=r"by the unit row .*--command-unit duty"):
        read_bench(f, command_col="pwm", thrust_col="thrust")


def test_a_first_row_of_words_that_are_no_units_is_still_refused_as_not_numeric(tmp_path):
    f = _unit_row_file(tmp_path / "words.csv", ["left", "right", "up", "down", "here"])
    with pytest.raises(BenchDataError, match=r"'left' is not numeric"):
        read_bench(f, command_col="pwm", thrust_col="thrust")


def test_a_thrust_header_with_another_channels_unit_is_refused_and_an_earlier_bracket_read(tmp_path):
    """'Thrust [mA]' was read in N without a word (only current and voltage headers refused
    another channel's unit), and 'thrust [kgf] (load cell)' lost its kgf to the last bracket."""
    def write(header, scale):
        f = tmp_path / "t.csv"
        with open(f, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["pwm", header])
            for i, c in enumerate(PWM):
                w.writerow([c, THRUST[i] * scale])
        return f

    with pytest.raises(BenchDataError, match=r"column 'Thrust \[mA\]': 'mA' in its header is no "
                                             r"thrust unit .* Fix: name the right column"):
        read_bench(write("Thrust [mA]", 1.0), command_col="pwm", thrust_col="Thrust [mA]")
    d = read_bench(write("thrust [kgf] (load cell)", 1 / 9.80665), command_col="pwm",
                   thrust_col="thrust [kgf] (load cell)")
    np.testing.assert_allclose(d.thrust, THRUST, rtol=1e-9)
