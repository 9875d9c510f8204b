"""Bench columns found by name as documented, and readings no bench can produce refused per row
(new-user test: ``flow [kn]`` not read, ``--time-col t`` matching the thrust ``T``, 1e300 in a
thrust or command, a negative pulse width)."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from uuvid.io.bench import MAX_BENCH_THRUST, BenchDataError, read_bench

FLOW = """command,speed,thrust,{h}
1600,100,3.0,0.0
1700,150,7.0,0.0
1600,100,2.0,1.0
1700,150,5.5,1.0
1400,-100,-2.5,0.0
1300,-150,-6.0,0.0
"""


def write(tmp_path: Path, text: str, name: str = "bench.csv") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


@pytest.mark.parametrize("header, scale", [("flow [kn]", 0.514444), ("flow speed", 1.0),
                                           ("flow_speed []", 1.0), ("Flow-Speed (m/s)", 1.0)])
def test_documented_flow_headers_are_detected(tmp_path, header, scale):
    d = read_bench(write(tmp_path, FLOW.format(h=header)), command_col="command",
                   speed_col="speed", thrust_col="thrust")
    assert d.flow_speed is not None, header
    assert d.flow_speed_column == header
    np.testing.assert_allclose(d.flow_speed.max(), scale, rtol=1e-4)


@pytest.mark.parametrize("header", ["Flow", "flow [l/min]"])
def test_a_flow_column_without_a_water_speed_unit_is_not_taken_for_one(tmp_path, header):
    """A bare ``Flow`` (a coolant's) was read as the water speed in m/s and changed the fit; one in
    l/min refused the file: neither is read, both are said."""
    d = read_bench(write(tmp_path, FLOW.format(h=header)), command_col="command",
                   speed_col="speed", thrust_col="thrust")
    assert d.flow_speed is None and d.flow_speed_column is None
    assert any(repr(header) in n and "--flow-speed-col" in n for n in d.notes)


def test_flow_like_column_not_read_is_said(tmp_path):
    d = read_bench(write(tmp_path, FLOW.format(h="water_flow")), command_col="command",
                   speed_col="speed", thrust_col="thrust")
    assert d.flow_speed is None
    assert any("'water_flow'" in n and "--flow-speed-col" in n for n in d.notes)


RUN = """{t},V,w,T
0.0,0,0,0
0.1,3,10,0.5
0.2,3,20,1.0
0.3,3,25,1.2
"""


def test_time_col_matches_header_with_unit_not_thrust_by_case(tmp_path):
    p = write(tmp_path, RUN.format(t="t [s]"))
    d = read_bench(p, command_col="V", speed_col="w", thrust_col="T", time_col="t",
                   command_unit="volts")
    np.testing.assert_allclose(d.time, [0.0, 0.1, 0.2, 0.3])
    np.testing.assert_allclose(d.thrust, [0, 0.5, 1.0, 1.2])


def test_time_col_never_falls_back_to_another_letter_case(tmp_path):
    p = write(tmp_path, RUN.format(t="time"))
    with pytest.raises(BenchDataError, match=r"no column 't' for the time; available columns: "
                                             r"'time', 'V', 'w', 'T'"):
        read_bench(p, command_col="V", speed_col="w", thrust_col="T", time_col="t",
                   command_unit="volts")
    # a name longer than one letter still matches ignoring case
    d = read_bench(p, command_col="v".upper(), speed_col="w", thrust_col="T", time_col="TIME",
                   command_unit="volts")
    assert d.time is not None


def test_absurd_thrust_is_an_error_naming_the_row(tmp_path):
    text = FLOW.format(h="flow_speed").replace("1700,150,5.5,1.0", "1700,150,1e300,1.0")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy overflow leaks
        with pytest.raises(BenchDataError, match=r"bench.csv: column 'thrust', data row 4 \(CSV "
                                                 r"line 5\): thrust 1e\+300 N"):
            read_bench(write(tmp_path, text), command_col="command", speed_col="speed",
                       thrust_col="thrust")
    ok = FLOW.format(h="flow_speed").replace("5.5", f"{MAX_BENCH_THRUST / 2:g}")
    read_bench(write(tmp_path, ok), command_col="command", thrust_col="thrust")


def test_absurd_command_volts_is_an_error_naming_the_row(tmp_path):
    p = write(tmp_path, RUN.format(t="t").replace("0.2,3,20", "0.2,1e300,20"))
    with pytest.raises(BenchDataError, match=r"column 'V', data row 3 \(CSV line 4\): command "
                                             r"1e\+300 V"):
        read_bench(p, command_col="V", speed_col="w", thrust_col="T", time_col="t",
                   command_unit="volts")


def test_negative_pulse_width_is_said_before_the_thrust_sign(tmp_path):
    text = FLOW.format(h="flow_speed").replace("1600,100,2.0,1.0", "-1500,100,3.3,0.0")
    with pytest.raises(BenchDataError, match=r"column 'command', data row 3 \(CSV line 4\): "
                                             r"command -1500 µs is not a pulse width"):
        read_bench(write(tmp_path, text), command_col="command", speed_col="speed",
                   thrust_col="thrust")


def test_flow_speed_unit_without_a_flow_column_is_refused(tmp_path):
    """``--flow-speed-col none --flow-speed-unit cm/s`` dropped the unit silently."""
    p = write(tmp_path, FLOW.format(h="flow_speed"))
    with pytest.raises(BenchDataError, match=r"bench.csv: a water speed unit was given .*cm/s.* "
                                             r"\(--flow-speed-col none\).*no effect"):
        read_bench(p, command_col="command", thrust_col="thrust", flow_speed_col=None,
                   flow_speed_unit="cm/s")
    q = write(tmp_path, "command,thrust\n1600,3.0\n1400,-2.5\n", "still.csv")
    with pytest.raises(BenchDataError, match=r"still.csv: a water speed unit was given .*kn"):
        read_bench(q, command_col="command", thrust_col="thrust", flow_speed_unit="kn")


def test_t200_sheet_refuses_a_flow_column_it_would_ignore(shared_data):
    """``--format t200 --flow-speed-col RPM`` was accepted with no effect."""
    from uuvid.identify.thruster.workflow import FitError, ReadOptions, run_fit

    f = shared_data / "t200-bluerobotics-2019" / "T200_16V.csv"
    with pytest.raises(FitError, match=r"--flow-speed-col RPM would be ignored"):
        run_fit([f], "quadratic", ReadOptions(fmt="t200", flow_speed_col="RPM"))
    with pytest.raises(FitError, match=r"--flow-speed-col none would be ignored"):
        run_fit([f], "quadratic", ReadOptions(fmt="t200", flow_speed_col=None))


def test_two_water_speed_columns_are_an_error_not_a_silent_choice(tmp_path):
    text = FLOW.format(h="flow_speed,flow [kn]").replace("\n", ",0\n").replace(
        "flow [kn],0", "flow [kn]")
    with pytest.raises(BenchDataError, match=r"columns 'flow_speed', 'flow \[kn\]' could each be "
                                             r"the water speed"):
        read_bench(write(tmp_path, text), command_col="command", thrust_col="thrust")
    d = read_bench(write(tmp_path, text), command_col="command", thrust_col="thrust",
                   flow_speed_col="flow_speed")
    assert d.flow_speed_column == "flow_speed"


DUTY = """duty,thrust
-1.0,-30
-0.5,-8
0.0,0
0.5,10
{last},40
"""


@pytest.mark.parametrize("last, hint", [("1e300", "a corrupt cell"), ("75", "in percent"),
                                        ("1900", "--command-unit pwm_us"), ("-1.5", "a corrupt")])
def test_duty_beyond_one_is_an_error_naming_the_row(tmp_path, last, hint):
    """A duty of 1e300 (or 75, a percent) was read and only refused later, for the whole file
    ('the commands hold -1…1e+300'), naming no row; PWM and volts were refused per row."""
    with pytest.raises(BenchDataError, match=rf"column 'duty', data row 5 \(CSV line 6\): command "
                                             rf"{re.escape(format(float(last), 'g'))} is not a duty.*−1…1.*{hint}"):
        read_bench(write(tmp_path, DUTY.format(last=last)), command_col="duty", thrust_col="thrust",
                   command_unit="duty")
    d = read_bench(write(tmp_path, DUTY.format(last="1.0")), command_col="duty", thrust_col="thrust",
                   command_unit="duty")
    assert d.command.max() == 1.0
