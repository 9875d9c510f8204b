"""A dive table (CSV, Parquet, DataFrame) with the traps real logs have — a logger restart,
duplicated stamps, a second sensor in one column, a column in another unit, an unreadable file —
gives a clear error naming the file, column and row, or a warning saying what was assumed; never
a traceback or a silently wrong channel."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from uuvid.io.dive_channels import DiveDataError, read_dive_channels


def _table(n: int = 1200, rate: float = 20.0) -> pd.DataFrame:
    """A plausible 60 s dive table: depth 0–2 m, a slow turn, six servo outputs, 16 V."""
    t = np.arange(n) / rate
    df = pd.DataFrame({"t_s": t, "depth_m": 1.0 - np.cos(t / 10.0),
                       "yaw_rad": 0.3 * np.sin(t / 7.0), "battery_V": 16.0 - 0.001 * t,
                       "u_mps": 0.3 * np.sin(t / 5.0), "v_mps": 0.1 * np.cos(t / 5.0)})
    for j in range(1, 7):
        df[f"pwm_{j}"] = np.rint(1500 + 100 * np.sin(t / (3.0 + j)))
    return df


def _read(df, tmp_path=None, name="d.csv"):
    if tmp_path is None:
        return read_dive_channels(df, "bluerov2")
    p = tmp_path / name
    df.to_csv(p, index=False)
    return read_dive_channels(p, "bluerov2")


def test_a_plausible_table_reads_without_unit_complaints():
    dc = _read(_table())
    assert not any("merged" in w or "read as" in w or "0 µs" in w for w in dc.warnings)
    assert dc.channels["depth_m"][0].size == 1200


def test_a_logger_restart_is_an_error_naming_the_row(tmp_path):
    df = _table()
    df.loc[600:, "t_s"] -= df.loc[600, "t_s"]  # time starts again at 0 halfway
    with pytest.raises(DiveDataError, match=r"d\.csv: column t_s, row 602: 0 s is before the "
                                            r"previous row's 29\.95 s"):
        _read(df, tmp_path)


def test_same_stamp_rows_merge_when_they_agree_and_are_refused_when_they_clash(tmp_path):
    df = _table()
    rep = pd.concat([df, df.iloc[100:150]]).sort_values("t_s", kind="stable")
    dc = _read(rep.reset_index(drop=True))
    assert dc.channels["depth_m"][0].size == 1200  # each repeated row counted once
    assert any("50 rows share the previous row's time stamp" in w for w in dc.warnings)
    # two senders filling different columns at one stamp: one sample, no error
    a, b = df.iloc[[10]].copy(), df.iloc[[10]].copy()
    a["depth_m"], b["yaw_rad"] = np.nan, np.nan
    two = pd.concat([df.iloc[:10], a, b, df.iloc[11:]]).reset_index(drop=True)
    assert _read(two).channels["depth_m"][0].size == 1200
    clash = rep.reset_index(drop=True)
    i = int(np.flatnonzero(np.diff(clash["t_s"].to_numpy()) == 0)[0]) + 1
    clash.loc[i, "depth_m"] += 1.0  # a second depth sensor writing into the same column
    with pytest.raises(DiveDataError, match=rf"column depth_m, rows {i + 1} and {i + 2}: two "
                                            r"different values"):
        _read(clash, tmp_path)


@pytest.mark.parametrize("column, scale, expected", [
    ("depth_m", 100.0, r"column depth_m changes by .* is it in cm or mm"),
    ("yaw_rad", 180.0 / np.pi, r"column yaw_rad turns at .* is it in degrees"),
    ("u_mps", 100.0, r"column u_mps is .* is it in cm/s or mm/s"),
    ("battery_V", 1000.0, r"column battery_V has median 1\.59\de\+04.* is it in mV"),
    ("t_s", 1000.0, r"column t_s: the median step between rows is 50 s.* milliseconds"),
])
def test_a_column_in_another_unit_is_an_error_saying_which(column, scale, expected):
    df = _table()
    if column == "yaw_rad":  # a heading in degrees, wrapped at ±180 as loggers do
        df[column] = (np.degrees(np.arange(1200) / 20.0 * 0.8) + 180) % 360 - 180
    else:
        df[column] = df[column] * scale
    with pytest.raises(DiveDataError, match=expected):
        _read(df)
    ok = _table()  # the same checks pass the plausible table's real motion
    ok["yaw_rad"] = np.arange(1200) / 20.0 * 0.8  # 0.8 rad/s, unwrapped
    _read(ok)


def test_servo_outputs_in_another_unit_or_off(tmp_path):
    df = _table()
    df["pwm_2"] = (df["pwm_2"] - 1500) / 400  # normalised −1…1
    with pytest.raises(DiveDataError, match=r"column pwm_2 holds .* not pulse widths"):
        _read(df)
    off = _table()
    off["pwm_5"] = 0.0
    assert any("pwm_5 is 0 µs throughout" in w for w in _read(off).warnings)


@pytest.mark.parametrize("content, expected", [
    (b"", r"e\.csv: not a readable CSV table \(EmptyDataError"),
    (bytes(range(256)) * 20, r"e\.csv: not a readable CSV table"),
    (b"t_s;depth_m\n0,0;1,5\n0,1;1,6\n", r"separated by ';'"),
    (b"t_s,depth_m\n", r"no data rows under the header"),
    (b"t_s,depth_m\n0.0,1.0\n1970-01-01 00:00:01,1.1\n", r"column t_s, row 3: '1970-01-01 "
                                                          r"00:00:01' is not a number.*date"),
    (b"t_s,depth_m\n0.0,1.0\n0.1,abc\n", r"column depth_m, row 3: 'abc' is not a number"),
    (b"t_s,depth_m\n0.0,1.0\n,1.1\n", r"column t_s, row 3: an empty cell is not a number"),
])
def test_unreadable_files_are_errors_naming_the_file(tmp_path, content, expected):
    p = tmp_path / "e.csv"
    p.write_bytes(content)
    with pytest.raises(DiveDataError, match=expected):
        read_dive_channels(p, "bluerov2")
    (tmp_path / "dir.csv").mkdir()
    with pytest.raises(DiveDataError, match=r"dir\.csv: a folder"):
        read_dive_channels(tmp_path / "dir.csv", "bluerov2")


def test_a_known_column_with_other_case_or_spaces_is_read_and_said():
    df = _table().rename(columns={"depth_m": "Depth_m ", "pwm_3": "PWM_3"})
    dc = _read(df)
    assert dc.channels["depth_m"][0].size == 1200 and "3" in dc.pwm
    assert any("'Depth_m ' read as depth_m" in w and "'PWM_3' read as pwm_3" in w
               for w in dc.warnings)


def test_pwm_columns_that_do_not_share_rows_name_the_column_and_time():
    df = _table()
    df.loc[100:120, "pwm_3"] = np.nan
    with pytest.raises(DiveDataError, match=r"pwm_3 has no value at t = 5 s, where pwm_1 has "
                                            r"one"):
        _read(df)


def test_an_armed_value_that_is_no_flag_and_too_few_samples_are_named():
    df = _table()
    df["armed"] = "true"
    df.loc[30, "armed"] = "maybe"
    with pytest.raises(DiveDataError, match=r"column armed, row 32: 'maybe'; expected "
                                            r"true/false"):
        _read(df)
    df.loc[30, "armed"] = None  # empty: not armed
    assert _read(df).armed
    two = _table().iloc[:2]
    with pytest.raises(DiveDataError, match=r"only 2 depth_m samples \(need at least 4\): heave "
                                            r"needs .*; pass a log that has it"):
        _read(two).require("heave")
