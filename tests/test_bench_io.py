"""Bench data in (uuvid.io.bench): units, sign conventions, censoring and every error message."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from uuvid.core import units as U
from uuvid.io.bench import (
    BenchData,
    BenchDataError,
    concat,
    read_bench,
    read_t200,
    require_samples,
)

T200 = "t200-bluerobotics-2019"


def write(tmp_path: Path, text: str, name: str = "bench.csv") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


GOOD = """time,pwm,thrust_kgf,rpm,amps,volts
0.0,1500,0,0,0.0,12
0.1,1600,0.5,1000,1.0,12
0.2,1700,1.0,1500,2.0,12
0.3,1400,-0.4,900,0.8,12
"""


# ------------------------------------------------------------------------------ happy paths
def test_units_and_signs(tmp_path):
    p = write(tmp_path, GOOD)
    d = read_bench(p, command_col="pwm", thrust_col="thrust_kgf", speed_col="rpm",
                   current_col="amps", voltage_col="volts", time_col="time",
                   thrust_unit="kgf", speed_unit="rpm")
    assert d.source == "bench.csv"
    np.testing.assert_allclose(d.thrust, np.array([0, 0.5, 1.0, -0.4]) * U.G0)
    # unsigned rpm: sign from the command direction (1400 < neutral 1500 → negative)
    np.testing.assert_allclose(d.speed, np.array([0, 1000, 1500, -900]) * 2 * math.pi / 60)
    np.testing.assert_allclose(d.current, [0, 1, 2, 0.8])
    np.testing.assert_allclose(d.supply_voltage_array(), 12.0)
    np.testing.assert_allclose(d.time, [0, 0.1, 0.2, 0.3])
    assert not d.censored.any()
    assert d.neutral == 1500.0 and len(d) == 4
    np.testing.assert_array_equal(d.direction, [0, 1, 1, -1])


@pytest.mark.parametrize("unit,factor", [("N", 1.0), ("kgf", U.G0), ("lbf", U.LBF),
                                         ("g", U.G0 / 1000.0)])
def test_thrust_units(tmp_path, unit, factor):
    p = write(tmp_path, "pwm,f\n1600,2\n1400,-1\n")
    d = read_bench(p, command_col="pwm", thrust_col="f", thrust_unit=unit)
    np.testing.assert_allclose(d.thrust, np.array([2.0, -1.0]) * factor)


def test_signed_speed_and_scalar_supply(tmp_path):
    p = write(tmp_path, "duty,w\n0.5,100\n-0.5,-90\n0.0,0\n")
    d = read_bench(p, command_col="duty", speed_col="w", command_unit="duty", supply_voltage=16)
    assert d.neutral == 0.0
    np.testing.assert_allclose(d.speed, [100, -90, 0])  # signed column kept as is
    assert d.supply_voltage == 16.0 and d.nominal_voltage() == 16.0


def test_column_names_match_loosely_and_censoring(tmp_path):
    p = write(tmp_path, "PWM (µs),RPM\n1500,0\n1540,250\n1560,400\n1440,500\n")
    d = read_bench(p, command_col="pwm (us)", speed_col="rpm", speed_unit="rpm",
                   censor_speed_below=300)
    np.testing.assert_array_equal(d.censored, [True, True, False, False])
    assert d.censor_speed == pytest.approx(300 * U.RPM)


def test_duplicated_command_levels_are_fine_in_a_steady_sheet(tmp_path):
    p = write(tmp_path, "pwm,f\n1600,1\n1600,1.1\n1500,0\n")
    d = read_bench(p, command_col="pwm", thrust_col="f")
    assert len(d) == 3


def test_blank_lines_are_skipped_and_line_numbers_stay_true(tmp_path):
    p = write(tmp_path, "pwm,f\n1600,1\n\n1700,x\n")
    with pytest.raises(BenchDataError, match=r"data row 2 \(CSV line 4\)"):
        read_bench(p, command_col="pwm", thrust_col="f")


def test_subset_concat_and_summary(tmp_path):
    p = write(tmp_path, GOOD)
    d = read_bench(p, command_col="pwm", thrust_col="thrust_kgf", voltage_col="volts")
    f = d.forward()
    assert len(f) == 2 and np.all(f.command > 1500)
    assert len(d.reverse()) == 1
    both = concat([d, d.subset(np.array([1, 2]))])
    assert len(both) == 6 and both.supply_voltage_array().shape == (6,)
    s = d.summary()
    assert s["samples"] == 4 and s["supply_voltage"] == 12.0


def test_benchdata_direct_construction_checks():
    with pytest.raises(BenchDataError, match="thrust has shape"):
        BenchData(command=[1, 2, 3], thrust=[1, 2])
    with pytest.raises(BenchDataError, match="unknown command_unit"):
        BenchData(command=[1, 2], command_unit="furlongs")
    with pytest.raises(BenchDataError, match="supply_voltage must be a positive"):
        BenchData(command=[1, 2], supply_voltage=-3)
    d = BenchData(command=[1500, 1600])
    with pytest.raises(BenchDataError, match="needs a thrust column"):
        d.require("thrust", what="a fit")
    with pytest.raises(BenchDataError, match="no supply voltage"):
        d.supply_voltage_array()


# ------------------------------------------------------------------------------ errors
def test_missing_column_lists_available(tmp_path):
    p = write(tmp_path, GOOD)
    with pytest.raises(BenchDataError) as e:
        read_bench(p, command_col="pwm", thrust_col="Force")
    msg = str(e.value)
    assert "bench.csv" in msg and "'Force'" in msg and "thrust" in msg
    assert "available columns: 'time', 'pwm', 'thrust_kgf', 'rpm', 'amps', 'volts'" in msg


@pytest.mark.parametrize("sep, said", [(";", "';'"), ("\t", "a tab")])
def test_a_file_separated_by_another_character_says_so(tmp_path, sep, said):
    p = write(tmp_path, sep.join(["pwm", "thrust"]) + "\n1500" + sep + "0\n1600" + sep + "1,5\n")
    with pytest.raises(BenchDataError, match=f"separated by {said}.*re-save"):
        read_bench(p, command_col="pwm", thrust_col="thrust")


def test_empty_cell(tmp_path):
    p = write(tmp_path, "pwm,f\n1600,1\n1700,\n")
    with pytest.raises(BenchDataError) as e:
        read_bench(p, command_col="pwm", thrust_col="f")
    msg = str(e.value)
    assert msg.startswith("bench.csv: column 'f', data row 2 (CSV line 3): empty cell")
    assert "expected a number (thrust, N)" in msg


def test_nan_cell(tmp_path):
    p = write(tmp_path, "pwm,f\n1600,nan\n")
    with pytest.raises(BenchDataError, match=r"column 'f', data row 1 \(CSV line 2\): NaN"):
        read_bench(p, command_col="pwm", thrust_col="f")


def test_non_numeric_cell(tmp_path):
    p = write(tmp_path, "pwm,f\n1600,1\n17OO,2\n")
    with pytest.raises(BenchDataError) as e:
        read_bench(p, command_col="pwm", thrust_col="f")
    msg = str(e.value)
    assert "column 'pwm', data row 2 (CSV line 3)" in msg and "'17OO' is not numeric" in msg
    assert "command, pwm_us" in msg


def test_infinite_cell(tmp_path):
    p = write(tmp_path, "pwm,f\n1600,inf\n")
    with pytest.raises(BenchDataError, match="not finite"):
        read_bench(p, command_col="pwm", thrust_col="f")


def test_ragged_row(tmp_path):
    p = write(tmp_path, "pwm,f\n1600,1\n1700\n")
    with pytest.raises(BenchDataError, match=r"CSV line 3 has 1 cells but the header has 2"):
        read_bench(p, command_col="pwm", thrust_col="f")


def test_unsorted_time(tmp_path):
    p = write(tmp_path, "t,pwm\n0.0,1600\n0.2,1600\n0.1,1600\n")
    with pytest.raises(BenchDataError) as e:
        read_bench(p, command_col="pwm", time_col="t")
    msg = str(e.value)
    assert "column 't', data row 3 (CSV line 4)" in msg and "not increasing (unsorted)" in msg
    assert "strictly increasing" in msg


def test_duplicated_time(tmp_path):
    p = write(tmp_path, "t,pwm\n0.0,1600\n0.1,1600\n0.1,1700\n")
    with pytest.raises(BenchDataError, match=r"data row 3 \(CSV line 4\).*duplicated"):
        read_bench(p, command_col="pwm", time_col="t")


def test_command_never_leaves_neutral(tmp_path):
    p = write(tmp_path, "pwm,f\n1500,0\n1500,0.01\n")
    with pytest.raises(BenchDataError, match=r"column 'pwm': the command never leaves neutral"):
        read_bench(p, command_col="pwm", thrust_col="f")


@pytest.mark.parametrize("kw,what", [({"thrust_unit": "stone"}, "thrust_unit"),
                                     ({"speed_unit": "deg/s"}, "speed_unit"),
                                     ({"command_unit": "percent"}, "command_unit")])
def test_unknown_unit(tmp_path, kw, what):
    p = write(tmp_path, "pwm,f,w\n1600,1,1\n")
    with pytest.raises(BenchDataError, match=f"unknown {what}.*expected one of"):
        read_bench(p, command_col="pwm", thrust_col="f", speed_col="w", **kw)


def test_units_are_case_insensitive(tmp_path):
    p = write(tmp_path, "pwm,f,w\n1600,1,60\n")
    d = read_bench(p, command_col="pwm", thrust_col="f", speed_col="w", thrust_unit="KGF",
                   speed_unit="RPM")
    assert d.thrust[0] == pytest.approx(U.G0) and d.speed[0] == pytest.approx(2 * math.pi)


def test_non_positive_supply_voltage(tmp_path):
    p = write(tmp_path, "pwm,v\n1600,12\n1700,0\n")
    with pytest.raises(BenchDataError, match=r"column 'v', data row 2 \(CSV line 3\): supply "
                                             r"voltage 0 V"):
        read_bench(p, command_col="pwm", voltage_col="v")


def test_voltage_column_and_scalar_conflict(tmp_path):
    p = write(tmp_path, "pwm,v\n1600,12\n")
    with pytest.raises(BenchDataError, match="either voltage_col or supply_voltage"):
        read_bench(p, command_col="pwm", voltage_col="v", supply_voltage=12)


def test_negative_speed_declared_unsigned(tmp_path):
    p = write(tmp_path, "pwm,w\n1600,10\n1400,-10\n")
    with pytest.raises(BenchDataError, match="negative speed"):
        read_bench(p, command_col="pwm", speed_col="w", speed_sign="command")


def test_empty_and_headless_files(tmp_path):
    with pytest.raises(BenchDataError, match="empty"):
        read_bench(write(tmp_path, ""), command_col="pwm")
    with pytest.raises(BenchDataError, match="no data rows"):
        read_bench(write(tmp_path, "pwm,f\n", "h.csv"), command_col="pwm")
    with pytest.raises(BenchDataError, match="no such bench file"):
        read_bench(tmp_path / "absent.csv", command_col="pwm")


def test_duplicate_header(tmp_path):
    with pytest.raises(BenchDataError, match="'f' appear more than once"):
        read_bench(write(tmp_path, "pwm,f,f\n1600,1,2\n"), command_col="pwm")


def test_require_samples():
    require_samples(3, 3, "ok")
    with pytest.raises(BenchDataError, match=r"quadratic: 2 usable sample\(s\) for 3 parameter"):
        require_samples(2, 3, "quadratic")


def test_parquet_needs_pyarrow(tmp_path):
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        p = tmp_path / "bench.parquet"
        p.write_bytes(b"PAR1")
        with pytest.raises(ImportError, match="pip install pyarrow"):
            read_bench(p, command_col="pwm")
    else:  # pragma: no cover - depends on the environment
        import pyarrow as pa
        import pyarrow.parquet as pq

        p = tmp_path / "bench.parquet"
        pq.write_table(pa.table({"pwm": [1500.0, 1600.0], "f": [0.0, 1.0]}), p)
        d = read_bench(p, command_col="pwm", thrust_col="f")
        np.testing.assert_allclose(d.thrust, [0, 1])


# ------------------------------------------------------------------------------ T200 sheets
@pytest.mark.realdata
@pytest.mark.parametrize("volts,band,fmax,fmin", [(12, (1464, 1536), 3.71, -2.92),
                                                  (16, (1472, 1528), 5.25, -4.07)])
def test_t200_reader(shared_data, volts, band, fmax, fmin):
    d = read_t200(shared_data / T200 / f"T200_{volts}V.csv")
    assert len(d) == 201 and d.source == f"T200_{volts}V.csv"
    assert d.command_unit == "pwm_us" and d.neutral == 1500
    np.testing.assert_allclose(d.supply_voltage_array(), volts)
    # SOURCE.md: max thrust (kgf), all-zero rows under 300 rpm are censored
    assert d.thrust.max() / U.G0 == pytest.approx(fmax, abs=0.01)
    assert d.thrust.min() / U.G0 == pytest.approx(fmin, abs=0.01)
    cens = d.command[d.censored]
    assert cens.min() == band[0] and cens.max() == band[1]
    assert np.all(d.thrust[d.censored] == 0) and np.all(d.speed[d.censored] == 0)
    # speed signed from the command; thrust and speed agree in sign
    m = d.measured & (d.command != 1500)
    assert np.all(np.sign(d.speed[m]) == np.sign(d.command[m] - 1500))
    assert np.all(np.sign(d.thrust[m]) == np.sign(d.speed[m]))
    assert d.speed.max() == pytest.approx(d.summary()["speed_range"][1])
    assert d.censor_speed == pytest.approx(300 * U.RPM)


def test_t200_reader_accepts_micro_sign_and_rejects_other_layouts(tmp_path):
    p = write(tmp_path, "PWM (µs),RPM,Current (A),Voltage (V),Force (Kg f)\n"
                        "1500,0,0,12,0\n1600,1000,1,12,0.4\n1400,900,1,12,-0.3\n", "t.csv")
    d = read_t200(p)
    assert d.censored.tolist() == [True, False, False]
    assert d.speed[2] < 0
    with pytest.raises(BenchDataError, match="not a T200 performance sheet"):
        read_t200(write(tmp_path, "pwm,f\n1600,1\n", "x.csv"))


def test_bench_data_built_in_python_with_a_nan_names_the_field_and_index():
    """A NaN in a BenchData built in a notebook reached the fits, whose errors were cryptic
    ("Initial guess is outside of provided bounds", "TableMap values must be finite")."""
    import numpy as np
    import pytest

    from uuvid.io.bench import BenchData, BenchDataError

    thrust = np.linspace(-5.0, 5.0, 9)
    thrust[4] = np.nan
    with pytest.raises(BenchDataError, match=r"sheet\.csv: thrust\[4\] is nan \(1 non-finite "
                                             r"value\(s\)\): every sample must be a finite number"):
        BenchData(command=np.linspace(1100, 1900, 9), thrust=thrust, source="sheet.csv")
    with pytest.raises(BenchDataError, match=r"supply_voltage\[0\] is inf"):
        BenchData(command=np.linspace(1100, 1900, 3), supply_voltage=[np.inf, 16.0, 16.0])
