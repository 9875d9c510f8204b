"""A dive table (CSV, Parquet, DataFrame) with the traps real logs have — a logger restart,
duplicated stamps, a second sensor in one column, a column in another unit, an unreadable file, a
folder or a file of unknown kind given as the log, a motor whose direction the table lacks —
gives a clear error naming the file, column and row, or a warning saying what was assumed; never
a traceback or a silently wrong channel."""

from __future__ import annotations

import re

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
    assert not _reversed(dc)  # its motion is unrelated to its PWM: no evidence either way
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
    (b"", r"e\.csv: the file is empty \(0 bytes\)"),
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


def test_a_semicolon_csv_with_decimal_commas_gets_the_semicolon_message(tmp_path):
    """Rows of "0,03;;-2,6;…" split into more fields than the header's one: pandas' "ParserError:
    Error tokenizing data. C error: Expected 5 fields in line 14, saw 14" was shown."""
    p = tmp_path / "dc.csv"
    p.write_text("t_s;depth_m;yaw_rad;mode;armed\n0,03;;-2,6;MANUAL;False\n"
                 + "".join(f"{i},5;1,{i};0,{i};MANUAL;True\n" for i in range(1, 20)))
    with pytest.raises(DiveDataError) as e:
        read_dive_channels(p, "bluerov2")
    msg = str(e.value)
    assert msg.startswith("dc.csv: the columns are separated by ';'"), msg
    assert "decimal commas" in msg and "row 2, column t_s ('0,03')" in msg
    assert "'.' as the decimal point" in msg and "ParserError" not in msg


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


# ---------------------------------------------------------------------------------------------
# A folder, a missing path or a file of unknown kind given as the log
# ---------------------------------------------------------------------------------------------
KINDS = (r"expected a dive table \(\.csv or \.parquet\), an ArduSub log \(\.bin, \.tlog or "
         r"\.log\), a ROS 1 \.bag file or a ROS 2 bag folder \(holding metadata\.yaml\)")


def test_a_folder_given_as_the_log_says_what_it_holds(tmp_path):
    dive = tmp_path / "mydive"
    dive.mkdir()
    with pytest.raises(DiveDataError, match=rf"mydive: a folder, not a dive log, and an empty "
                                            rf"one; {KINDS}"):
        read_dive_channels(dive, "bluerov2")
    _table().to_csv(dive / "a.csv", index=False)
    _table().to_csv(dive / "b.csv", index=False)
    with pytest.raises(DiveDataError, match=r"mydive: a folder, not a dive log: it holds 2 "
                                            r"possible dive logs \(a\.csv, b\.csv\); pass one of "
                                            r"them, e\.g\. .*mydive/a\.csv"):
        read_dive_channels(dive, "bluerov2")
    other = tmp_path / "notes"
    other.mkdir()
    (other / "readme.txt").write_text("dive 3")
    with pytest.raises(DiveDataError, match=rf"notes: a folder, not a dive log, and nothing in "
                                            rf"it is one \(1 entry: readme\.txt\); {KINDS}"):
        read_dive_channels(other, "bluerov2")
    half = tmp_path / "rosbag2_dive"  # a ROS 2 bag that lost its metadata.yaml
    half.mkdir()
    (half / "rosbag2_dive_0.db3").write_bytes(b"SQLite format 3\x00")
    with pytest.raises(DiveDataError, match=r"rosbag2_dive: .*ROS 2 bag storage "
                                            r"\(rosbag2_dive_0\.db3\) but no metadata\.yaml.*ros2 "
                                            r"bag reindex"):
        read_dive_channels(half, "bluerov2")
    # with its metadata.yaml it is a ROS 2 bag again: the bag reader, not the folder error, answers
    (half / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    with pytest.raises(DiveDataError) as e:
        read_dive_channels(half, "bluerov2")
    assert "a folder, not" not in str(e.value) and "rosbag2_dive" in str(e.value)


def test_a_missing_path_or_a_file_of_unknown_kind_names_the_kinds(tmp_path):
    _table().to_csv(tmp_path / "d.csv", index=False)
    with pytest.raises(DiveDataError, match=rf"d: no such file or folder \(there is d\.csv beside "
                                            rf"it\); {KINDS}"):
        read_dive_channels(tmp_path / "d", "bluerov2")
    with pytest.raises(DiveDataError, match=rf"nope\.csv: no such file or folder; {KINDS}"):
        read_dive_channels(tmp_path / "nope.csv", "bluerov2")
    _table().to_csv(tmp_path / "dive", index=False)
    with pytest.raises(DiveDataError, match=rf"dive: no file suffix; it looks like a CSV table "
                                            rf"\(first line 't_s,depth_m,.*name it \.csv; the "
                                            rf"reader goes by the suffix: {KINDS}"):
        read_dive_channels(tmp_path / "dive", "bluerov2")
    _table().to_parquet(tmp_path / "dive.dat")
    with pytest.raises(DiveDataError, match=r"dive\.dat: unknown dive log type '\.dat'; it looks "
                                            r"like a Parquet table: name it \.parquet"):
        read_dive_channels(tmp_path / "dive.dat", "bluerov2")
    (tmp_path / "blank").write_bytes(b"")
    with pytest.raises(DiveDataError, match=r"blank: no file suffix; it looks like nothing: the "
                                            r"file is empty"):
        read_dive_channels(tmp_path / "blank", "bluerov2")
    (tmp_path / "x.bin").mkdir()  # a folder named like a log is still a folder
    with pytest.raises(DiveDataError, match=r"x\.bin: a folder, not a bin file"):
        read_dive_channels(tmp_path / "x.bin", "bluerov2")


@pytest.mark.parametrize("command", [["vehicle", "identify", "dive"], ["vehicle", "replay"]])
def test_the_dive_commands_refuse_a_folder_in_one_line(tmp_path, command):
    from typer.testing import CliRunner

    from uuvid.cli.app import app

    dive = tmp_path / "mydive"
    dive.mkdir()
    _table().to_csv(dive / "dive.csv", index=False)
    res = CliRunner().invoke(app, [*command, str(dive), "--vehicle", "bluerov2"])
    assert res.exit_code == 2, res.output
    assert "mydive: a folder, not a dive log: it holds 1 possible dive log (dive.csv)" in \
        " ".join(res.output.split())
    assert "Traceback" not in res.output


# ---------------------------------------------------------------------------------------------
# A motor whose direction the table lacks (its pwm_ column mirrored about 1500 µs)
# ---------------------------------------------------------------------------------------------
def _physical_table(seed: int = 0, duration: float = 240.0, rate: float = 20.0, *,
                    gain: float = 1.0, astern: float = 1.0, lag: int = 0,
                    noise: float = 0.005) -> pd.DataFrame:
    """A dive table like :func:`_table` whose depth and heading obey the servo outputs: a
    BlueROV2-like heave (m + Z_ẇ = 26.07 kg, linear + quadratic drag, 2 N of net buoyancy up) and
    yaw (I_z + N_ṙ = 0.28 kg·m²), both thrusters of the vertical pair on one command, the four
    horizontal ones mixing yaw and surge sticks; pilot sticks change every 2–6 s and keep the
    vehicle 1.5–8 m down.  The true thrust is the T200 model's at 16 V times ``gain`` (astern
    also times ``astern``), applied ``lag`` rows late: a model the reader's is not.  NumPy only."""
    from uuvid.io.ardusub.thrust import default_t200

    rng = np.random.default_rng(seed)
    dt, sub = 1.0 / rate, 5
    h = dt / sub
    n = int(duration * rate)
    grid = np.arange(1100.0, 1901.0)
    thrust = default_t200().thrust(grid, np.full(grid.size, 16.0))
    yaw_sign = np.array([1, -1, -1, 1])  # bluerov2: N = 0.189 (T1 − T2 − T3 + T4)
    surge_sign = np.array([-1, -1, 1, 1])  # X = 0.707 (−T1 − T2 + T3 + T4)
    z, w, psi, r = 3.0, 0.0, 0.0, 0.0
    heave = yaw = surge = 0.0
    t_next = 0.0
    out = np.empty((n, 9))
    for k in range(n):
        t = k * dt
        if t >= t_next:
            heave, yaw, surge = (rng.uniform(-0.7, 0.7), rng.uniform(-0.7, 0.7),
                                 rng.uniform(-0.5, 0.5))
            t_next = t + rng.uniform(2.0, 6.0)
        if z < 1.5:
            heave = abs(heave) + 0.2
        elif z > 8.0:
            heave = -abs(heave) - 0.2
        pv = np.rint(1500 + 250 * heave)
        out[k, 3:] = np.concatenate([np.rint(1500 + 200 * yaw * yaw_sign
                                             + 150 * surge * surge_sign), [pv, pv]])
        T = gain * np.interp(out[max(k - lag, 0), 3:], grid, thrust)
        T = np.where(T < 0, astern * T, T)
        Z, N = T[4] + T[5], 0.189 * (T[0] - T[1] - T[2] + T[3])
        for _ in range(sub):
            w += h * (Z - 6.0 * w - 25.0 * w * abs(w) - 2.0) / 26.07
            z += h * w
            r += h * (N - 0.4 * r - 0.8 * r * abs(r)) / 0.28
            psi += h * r
        out[k, :3] = t, z, psi
    df = pd.DataFrame(out, columns=["t_s", "depth_m", "yaw_rad",
                                    *(f"pwm_{j}" for j in range(1, 7))])
    df["depth_m"] += noise * rng.standard_normal(n)
    df["yaw_rad"] = (df["yaw_rad"] + 0.003 * rng.standard_normal(n) + np.pi) % (2 * np.pi) - np.pi
    df["battery_V"] = 16.0
    return df


def _reversed(dc) -> list:
    return [w for w in dc.warnings if "reversed" in w and "no reversal applied" not in w]


def _mirror(df, *cols):
    out = df.copy()
    for c in cols:
        out[c] = 3000.0 - out[c]
    return out


@pytest.mark.parametrize("seed", range(5))
def test_the_direction_check_is_silent_on_a_dive_whose_motors_are_right(seed):
    assert not _reversed(_read(_physical_table(seed)))


@pytest.mark.parametrize("model", [dict(gain=0.6), dict(gain=1.5), dict(astern=0.6),
                                   dict(lag=4), dict(noise=0.05),
                                   dict(gain=0.5, astern=0.7, lag=6, noise=0.03)])
@pytest.mark.slow
def test_the_direction_check_is_silent_when_only_the_thrust_model_or_timing_is_off(model):
    """Thrust 40 % weaker or 50 % stronger than the reader's model, astern weaker, 0.2–0.3 s of
    actuator lag, 5 cm depth noise: none of these reverses a force, none is reported as such."""
    for seed in range(3):
        assert not _reversed(_read(_physical_table(seed, **model)))


@pytest.mark.parametrize("seed", range(3))
def test_a_mirrored_vertical_motor_is_named_with_its_evidence_and_fix(seed):
    df = _mirror(_physical_table(seed), "pwm_5")
    ws = _reversed(_read(df))
    assert len(ws) == 1, ws
    w = ws[0]
    assert w.startswith("<table>: pwm_5 is probably reversed: its thruster's heave force opposes "
                        "the heave acceleration measured from depth_m (driven in step with pwm_6")
    c, s = re.search(r"coefficient ([-+][\d.e-]+) ± ([\d.e-]+) m/s² per N", w).groups()
    assert float(c) < -4 * float(s)
    assert "the vehicle's 1/(m + Z_ẇ) is 0.0384" in w
    assert w.endswith("the motor direction (SERVOn_REVERSED / MOT_n_DIRECTION) is not applied in "
                      "this table: mirror that column (pwm_5) about 1500 µs (pwm → 3000 − pwm)")
    fixed = _mirror(df, "pwm_5")  # doing what it says silences it
    assert not _reversed(_read(fixed))


def test_a_mirrored_horizontal_motor_is_named_from_the_yaw():
    ws = _reversed(_read(_mirror(_physical_table(1), "pwm_2")))
    assert len(ws) == 1 and ws[0].startswith("<table>: pwm_2 is probably reversed: its thruster's "
                                             "yaw force opposes the yaw acceleration"), ws
    assert "rad/s² per N·m" in ws[0]


def test_a_channel_of_the_other_sign_is_said_as_such_not_as_one_motor():
    df = _physical_table(2)
    up = df.assign(depth_m=-df["depth_m"])  # a height, or depth logged positive up
    ws = _reversed(_read(up))
    assert len(ws) == 1 and "opposes the heave force computed from every thruster that gives " \
        "one (pwm_5, pwm_6)" in ws[0] and "is depth_m positive up" in ws[0], ws
    both = _reversed(_read(_mirror(df, "pwm_5", "pwm_6")))  # or the whole pair reversed
    assert len(both) == 1 and "mirror those columns (pwm_5 and pwm_6)" in both[0], both
    enu = df.assign(yaw_rad=-df["yaw_rad"])
    ws = _reversed(_read(enu))
    assert len(ws) == 1 and "is yaw_rad counter-clockwise (ENU" in ws[0], ws


def _with_forces(df) -> pd.DataFrame:
    """``df`` with the six force columns the reader computes from its PWM (kept beside them)."""
    dc = _read(df)
    out = df.copy()
    for c in ("X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"):
        t, v = dc.channels[c]
        out[c] = np.interp(df["t_s"], t, v)
    return out


def test_a_depth_positive_up_is_asked_about_with_force_columns_too():
    """The sign check ran only on forces computed from the PWM: with the table's own Z_N a height
    (depth positive up) was said as nothing but a mass ×10⁶ off and 'check the motor directions'.
    The force columns go through the same fit: the same question, the column's sign the other
    suspect; the right signs stay silent."""
    df = _with_forces(_physical_table(2))
    assert not [w for w in _read(df).warnings if "opposes" in w]
    up = _read(df.assign(depth_m=-df["depth_m"]))
    ws = [w for w in up.warnings if "opposes" in w]
    assert len(ws) == 1 and ws[0].startswith("<table>: the heave acceleration measured from "
                                             "depth_m opposes the heave force logged in Z_N: "
                                             "coefficient -"), ws
    assert "is depth_m positive up (a height, or depth with the wrong sign)?" in ws[0]
    assert "the vehicle's 1/(m + Z_ẇ) is 0.0384" in ws[0]
    assert ws[0].endswith("otherwise Z_N has the wrong sign: expected the body-frame force, z "
                          "down (a positive Z_N pushes the vehicle deeper)")
    assert up.opposed == ["heave"]
    assert _read(df.assign(Z_N=-df["Z_N"])).opposed == ["heave"]  # or the force's own sign
    enu = _read(df.assign(yaw_rad=-df["yaw_rad"]))
    assert enu.opposed == ["yaw"] and any("opposes the yaw force logged in N_Nm" in w and
                                          "is yaw_rad counter-clockwise" in w for w in enu.warnings)


def test_the_direction_check_needs_forces_from_the_pwm_and_enough_data():
    df = _mirror(_physical_table(0), "pwm_5")
    given = df.assign(Z_N=0.0, N_Nm=0.0)  # the table's own forces: the PWM is not used for them
    assert not _reversed(_read(given))
    assert not _reversed(_read(df.iloc[:400]))  # 20 s: too short to tell


@pytest.mark.slow
def test_the_direction_check_on_the_projects_synthetic_dives():
    """The project's simulated piloted dives (closed-loop ALT_HOLD/STABILIZE, tether drag,
    sagging battery, surface contacts, depth at 3 Hz): silent as generated over several seeds;
    with one vertical motor's column mirrored it names that column, never its partner."""
    from uuvid.simulate.dive_synth import synthetic_dive

    forces = ["X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"]
    for seed in range(4):
        df, _ = synthetic_dive(300.0, seed=seed, pwm_rate=10.0, surge=0.0)
        df = df.drop(columns=forces)  # forces from the PWM, as in a table of servo outputs
        assert not _reversed(_read(df)), seed
        on = df["pwm_5"].notna()
        bad = df.copy()
        bad.loc[on, "pwm_5"] = 3000.0 - bad.loc[on, "pwm_5"]
        ws = _reversed(_read(bad))
        assert len(ws) == 1 and ws[0].startswith("<table>: pwm_5 is probably reversed"), (seed, ws)
    df, _ = synthetic_dive(600.0, seed=7)  # the defaults: PWM at 2 Hz
    assert not _reversed(_read(df.drop(columns=forces)))


def test_a_pwm_spike_is_an_error_naming_the_cell_not_saturation(tmp_path):
    """One 65535 (a logger's overflow) among pulse widths was counted as a saturated sample."""
    df = _table()
    df.loc[700, "pwm_2"] = 65535
    with pytest.raises(DiveDataError, match=r"d\.csv: column pwm_2, row 702: 65535 is not a pulse "
                                            r"width \(1 such cell"):
        _read(df, tmp_path)


def test_a_column_name_twice_is_an_error_not_one_sensor_dropped(tmp_path):
    df = _table()
    df.insert(2, "depth_m_2", df["depth_m"] + 2.0)
    df.columns = [c if c != "depth_m_2" else "depth_m" for c in df.columns]  # two 'depth_m'
    for source in (df, tmp_path):  # a DataFrame holds both; a CSV reads the second as depth_m.1
        with pytest.raises(DiveDataError, match=r"column 'depth_m' appears twice \(columns 2 and 3\)"):
            _read(df, None if source is df else tmp_path)
    ok = _table()
    ok["notes.1"] = 0.0  # a name with a dot that is no copy of a channel stays allowed
    assert _read(ok).channels["depth_m"][0].size == 1200


def test_an_infinite_cell_is_an_error_not_a_dropped_sample(tmp_path):
    df = _table()
    df.loc[300, "depth_m"] = np.inf
    with pytest.raises(DiveDataError, match=r"column depth_m, row 302: inf is not a measurement"):
        _read(df, tmp_path)


def test_a_pause_in_the_log_is_named_with_its_row(tmp_path):
    df = _table()
    df.loc[600:, "t_s"] += 3600.0
    dc = _read(df, tmp_path)
    assert any(re.search(r"column t_s, row 602: the log stops for 3600 s \(from 29\.95 s\)", w)
               for w in dc.warnings)
    assert not any("the log stops" in w for w in _read(_table()).warnings)
    # the armed time is two runs, one on each side: none spans the hour with no data
    assert len(dc.armed) == len(_read(_table()).armed) + 1
    assert not any(a < 30.0 and b > 3600.0 for a, b in dc.armed)
    assert any(abs(b - 29.95) < 1e-9 for _, b in dc.armed)
    short = _table()  # a 2 s hiccup is no pause: not said, and no run is cut there
    short.loc[600:, "t_s"] += 2.0
    sc = _read(short, tmp_path)
    assert not any("the log stops" in w for w in sc.warnings)
    assert len(sc.armed) == len(_read(_table()).armed)


def test_a_dead_output_while_armed_is_named_with_its_time_span():
    """pwm_3 at 0 µs from 30 s on while the others are driven: read as 'no thrust', said."""
    df = _table()
    df.loc[df["t_s"] >= 30.0, "pwm_3"] = 0.0
    w = [x for x in _read(df).warnings if "pwm_3 is 0 µs (no pulse)" in x]
    assert len(w) == 1 and re.search(r"from 30 to 59\.95 s while armed", w[0])
    short = _table()
    short.loc[(short["t_s"] >= 30.0) & (short["t_s"] < 33.0), "pwm_3"] = 0.0  # 3 s: a glitch
    assert not any("no pulse" in x for x in _read(short).warnings)


def test_an_output_at_neutral_while_its_parallel_partner_is_driven_is_named():
    """pwm_5 at 1500 µs throughout while pwm_6 (the other vertical thruster) is driven: a motor
    wired to another output read as idle; said with its partner.  Neutral alone (a horizontal
    dive with both vertical outputs at 1500) is no evidence and stays silent."""
    df = _table()
    df["pwm_5"] = 1500.0
    w = [x for x in _read(df).warnings if "(neutral)" in x]
    assert len(w) == 1 and re.search(r"pwm_5 sits at 1500 µs \(neutral\) for 48\.4 s while armed "
                                      r"and pwm_6 .* is driven", w[0]), w
    both = _table()
    both["pwm_5"] = both["pwm_6"] = 1500.0
    assert not any("(neutral)" in x for x in _read(both).warnings)
    assert not any("(neutral)" in x for x in _read(_table()).warnings)
    near = _table()  # within 25 µs of neutral is the dead band: the partner is not driven
    near["pwm_5"] = 1500.0
    near["pwm_6"] = np.rint(1500 + 20 * np.sin(near["t_s"] / 3.0))
    assert not any("(neutral)" in x for x in _read(near).warnings)


def test_the_neutral_check_pairs_outputs_as_the_forces_do_and_only_as_the_mixer_drives_them():
    """No false alarm: (1) a surge dive with idle vertical outputs whose table lists pwm_5, pwm_6
    first (columns are thrusters by number, not by position); (2) a dead ESC (0 µs) beside an idle
    output: no pulse is not 'driven'; (3) a turning circle, surge = yaw command, which leaves the
    diagonal horizontal thrusters 1 and 3 at neutral while 4 and 2, parallel to them, run — the
    mixer drives them apart.  The pinned vertical output is still named when listed first."""
    t = _table()["t_s"].to_numpy()

    def neutral(df):
        return [x for x in _read(df).warnings if "(neutral)" in x]

    surge = _table()
    f = np.rint(100 * np.sin(t / 6.0))
    for j, sg in zip(range(1, 5), (-1, -1, 1, 1)):  # ArduSub's vectored forward factors
        surge[f"pwm_{j}"] = 1500 + sg * f
    surge["pwm_5"] = surge["pwm_6"] = 1500.0
    first = ["t_s", "depth_m", "yaw_rad", "pwm_5", "pwm_6", "pwm_1", "pwm_2", "pwm_3", "pwm_4"]
    assert not neutral(surge[first])
    dead = _table()
    dead["pwm_5"] = dead["pwm_6"] = 1500.0
    dead.loc[(dead["t_s"] > 20) & (dead["t_s"] < 50), "pwm_6"] = 0.0
    assert not neutral(dead)
    circle = _table()
    c = np.rint(150 * np.clip(t / 5.0, 0, 1))
    for j, (fy, ff) in enumerate(((1, -1), (-1, -1), (-1, 1), (1, 1)), 1):  # yaw, forward factors
        circle[f"pwm_{j}"] = 1500 + fy * c + ff * c
    circle["pwm_5"] = circle["pwm_6"] = np.rint(1500 + 30 * np.sin(t / 4))
    assert not neutral(circle)
    pinned = _table()
    pinned["pwm_5"] = 1500.0
    w = neutral(pinned[first])
    assert len(w) == 1 and "pwm_5 sits at 1500" in w[0] and "pwm_6" in w[0]
    wobble = _table()  # PWM captured off the vehicle: ±1 µs around neutral is still pinned
    wobble["pwm_5"] = 1500.0 + np.resize([-1.0, 0.0, 1.0], len(wobble))
    assert len(neutral(wobble)) == 1


@pytest.mark.parametrize("offset", [-0.5, -3.0])
def test_a_depth_above_the_water_is_said_with_the_cut_off_it_misleads(offset):
    """Depth read 0.5 m (or 3 m) too shallow — the surface pressure taken at depth — reads above
    the water; the surface cut-off acts on it as logged, so it is said.  A clean table's surface
    noise (a few cm above zero) is not."""
    df = _table()
    df["depth_m"] = df["depth_m"] + offset
    w = [x for x in _read(df).warnings if "above the water" in x]
    assert len(w) == 1 and re.search(rf"down to {offset:.3g} m, first at t = 0 s\).*surface "
                                     r"cut-off \(depth < 0\.2 m\)", w[0]), w
    assert (", 100 % (" in w[0]) == (offset == -3.0)  # the whole log: 100 %, not 1e+02 %
    noisy = _table()
    noisy["depth_m"] = np.clip(noisy["depth_m"], 0.0, None) - 0.05 * (np.arange(len(noisy)) % 2)
    assert not any("above the water" in x for x in _read(noisy).warnings)


def test_forces_and_pwm_in_one_table_say_which_is_used():
    df = _table()
    for c in ("X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"):
        df[c] = 0.0
    assert any("the forces are used and the pwm_ columns are not" in x for x in _read(df).warnings)


@pytest.mark.slow
@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_a_mirrored_motor_among_several_driven_together_is_named(tmp_path, k):
    """The example dive: the four horizontal motors share the yaw (their forces correlate beyond
    the grouping threshold), so one mirrored among them cannot show a negative coefficient of its
    own — the fit with it mirrored back explains several times more of the yaw acceleration,
    mirroring any other alone does not, and that is what is said."""
    from uuvid.examples import write_example

    df = pd.read_csv(write_example("dive", tmp_path)[0])
    df = df.drop(columns=["X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"])
    assert not _reversed(_read(df))
    ws = _reversed(_read(_mirror(df, f"pwm_{k}")))
    assert len(ws) == 1, ws
    assert ws[0].startswith(f"<table>: pwm_{k} is probably reversed: it is driven in step with ")
    r2 = re.search(r"explain (\d+)% of the yaw acceleration measured from yaw_rad instead of "
                   r"(\d+)% as logged", ws[0])
    assert r2 and int(r2.group(1)) >= 2 * int(r2.group(2)), ws[0]
    assert ws[0].endswith(f"mirror that column (pwm_{k}) about 1500 µs (pwm → 3000 − pwm)")
    assert not _reversed(_read(_mirror(df, f"pwm_{k}", f"pwm_{k}")))


@pytest.mark.slow
@pytest.mark.parametrize("a, b", [(1, 2), (1, 3), (1, 4), (2, 3), (2, 4), (3, 4)])
def test_two_mirrored_motors_among_several_driven_together_are_named(tmp_path, a, b):
    """Two of the four horizontal motors mirrored: as logged their yaw forces cancel the other
    two's, the groups re-form around the wrong signs and no coefficient is negative enough to
    name one, and no single mirror gains enough — they escaped.  Mirroring each pair of grouped
    outputs finds the one pair that explains the motion; both are named in one warning."""
    from uuvid.examples import write_example

    df = pd.read_csv(write_example("dive", tmp_path)[0])
    df = df.drop(columns=["X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"])
    ws = _reversed(_read(_mirror(df, f"pwm_{a}", f"pwm_{b}")))
    assert len(ws) == 1, ws
    assert ws[0].startswith(f"<table>: pwm_{a} and pwm_{b} are probably both reversed"), ws[0]
    r2 = re.search(r"explain (\d+)% of the yaw acceleration measured from yaw_rad instead of "
                   r"(\d+)% as logged", ws[0])
    assert r2 and int(r2.group(1)) >= 2 * int(r2.group(2)), ws[0]
    assert ws[0].endswith(f"mirror those columns (pwm_{a} and pwm_{b}) about 1500 µs "
                          "(pwm → 3000 − pwm)"), ws[0]


@pytest.mark.slow
@pytest.mark.parametrize("seed", [40, 41, 42])
def test_the_pair_search_is_silent_on_right_motors_with_a_wrong_thrust_model(seed):
    """Synthetic piloted dives (seeds the thresholds never saw) with every motor right, read with
    the thrust 25 % off (battery voltage) or the PWM three rows late: no pair (and no single
    output) is named."""
    from uuvid.simulate.dive_synth import synthetic_dive

    df, _ = synthetic_dive(300.0, seed=seed)
    df = df.drop(columns=[c for c in ("X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm") if c in df])
    volt = df.copy()
    volt["battery_V"] = 0.75 * volt["battery_V"]
    lag = df.copy()
    pwm = [c for c in df if c.startswith("pwm_")]
    lag[pwm] = lag[pwm].shift(3).bfill()
    for table in (df, volt, lag):
        assert not _reversed(_read(table))


@pytest.mark.parametrize("seed", range(10, 13))
@pytest.mark.parametrize("model", [dict(gain=0.6), dict(astern=0.6), dict(lag=4),
                                   dict(gain=0.5, astern=0.7, lag=6, noise=0.03)])
@pytest.mark.slow
def test_the_group_search_is_silent_when_only_the_thrust_model_is_off(seed, model):
    """The search for one reversed motor inside a group (mirror each alone) stays silent on
    right motors with a wrong thrust model or lag — checked on seeds the thresholds never saw."""
    assert not _reversed(_read(_physical_table(seed, **model)))


def test_a_zero_volt_battery_sample_is_left_out_and_said():
    """Two battery_V cells at 0 V (a glitch of the power sensor) made every thrust NaN and every
    identified parameter NaN, blamed on the replay's step.  They are left out, interpolated
    across, and said with the first one's time; the forces stay finite."""
    df = _physical_table(0)
    df.loc[[500, 900], "battery_V"] = 0.0
    dc = _read(df)
    said = [w for w in dc.warnings if "battery_V is outside" in w]
    assert len(said) == 1 and "on 2 sample(s)" in said[0] and "t = 25 s: 0 V" in said[0], said
    for c in ("Z_N", "N_Nm"):
        assert np.all(np.isfinite(dc.channels[c][1])), c
    assert not [w for w in _read(_physical_table(0)).warnings if "battery_V is outside" in w]


@pytest.mark.parametrize("col", ["yaw_rad", "depth_m"])
def test_a_channel_stuck_at_one_value_while_armed_is_left_out_and_said(col):
    """A heading (or depth) that repeats one value exactly for a minute while the thrusters are
    driven is a stuck sensor: fitted as a vehicle that did not move it biased drag and inertia.
    The stretch is left out and said; the intact table says nothing of the kind."""
    df = _physical_table(3)
    assert not [w for w in _read(df).warnings if "stuck sensor" in w]
    rows = (df["t_s"] >= 100.0) & (df["t_s"] < 160.0)
    df.loc[rows, col] = 0.0 if col == "yaw_rad" else 4.0
    dc = _read(df)
    said = [w for w in dc.warnings if "stuck sensor" in w]
    assert len(said) == 1 and said[0].startswith(f"<table>: {col} repeats "), said
    t = dc.channels[col][0]
    assert not np.any((t >= 100.5) & (t < 159.5)) and np.any(t > 160.0)


# ---------------------------------------------------------------------------------------------
# From a new user's trial (stop 36): outputs the frame does not have, a heartbeat-logged armed
# state, columns under other names, a quiet stretch hiding degrees, a surface read too deep,
# times outside the log
# ---------------------------------------------------------------------------------------------
def test_spare_outputs_off_throughout_are_left_out_and_other_extra_columns_named():
    """An export of a 6-thruster frame carries outputs 7–8 at 0 µs: the error said "pass
    bluerov2-heavy for 8", which read the log with the wrong geometry.  Off spare outputs beyond
    the vehicle's count are left out (said); an off output among the first six is named."""
    df = _table()
    df["pwm_7"], df["pwm_8"] = 0.0, 0.0
    dc = _read(df)
    assert sorted(dc.pwm, key=int) == [str(j) for j in range(1, 7)]
    assert any("pwm_7, pwm_8 are off throughout" in w and "left out" in w for w in dc.warnings)
    assert not any("pwm_7 is 0 µs throughout" in w for w in dc.warnings)
    mid = _table()
    mid["pwm_3"], mid["pwm_7"] = 0.0, 1500.0 + 50 * np.sin(mid["t_s"].to_numpy())
    with pytest.raises(DiveDataError, match=r"7 pwm_ columns .* has 6 thrusters; pwm_3 are off "
                                            r"throughout .*drop those columns"):
        _read(mid)


def test_an_armed_state_logged_on_its_own_rows_holds_until_the_next():
    """``armed`` filled only on 1 Hz heartbeat rows (empty between, as any channel's cells): every
    other row was taken as disarmed — "0 usable armed windows"."""
    df = _table()
    hb = pd.DataFrame({"t_s": np.arange(0.525, 60.0, 1.0)})
    hb["armed"] = hb["t_s"] > 10.0
    both = pd.concat([df, hb], ignore_index=True).sort_values("t_s", kind="stable")
    dc = _read(both.reset_index(drop=True))
    assert len(dc.armed) == 1 and dc.armed[0][0] == pytest.approx(10.525)
    assert dc.armed[0][1] == pytest.approx(df["t_s"].iloc[-1])
    assert any("column armed is filled on 60 of" in w for w in dc.warnings)
    # all true (a log kept only while armed, LOG_DISARMED = 0): held too
    hb["armed"] = True
    dc = _read(pd.concat([df, hb], ignore_index=True).sort_values("t_s", kind="stable")
               .reset_index(drop=True))
    assert len(dc.armed) == 1 and dc.armed[0][0] == pytest.approx(0.525)
    # a column filled in a block, empty elsewhere (even with one "0"): empty means not armed
    only_true = df.assign(armed=np.where(df["t_s"] > 10.0, "true", ""))
    only_true.loc[0, "armed"] = "0"
    dc = _read(only_true)
    assert dc.armed[0][0] == pytest.approx(10.05)
    assert not any("column armed is filled" in w for w in dc.warnings)


def test_columns_under_other_names_are_said_not_dropped_silently():
    """``heading_deg`` and ``servo1 …`` were ignored without a word (``--dof all`` skipped yaw,
    and the missing-force error never named ``pwm_<n>``)."""
    df = _table().rename(columns={"yaw_rad": "heading_deg"})
    dc = _read(df)
    assert "yaw_rad" not in dc.channels and dc.unread == ["heading_deg (yaw_rad?)"]
    assert any("column(s) heading_deg (yaw_rad?) not read" in w and "yaw_rad [rad" in w
               for w in dc.warnings)
    servo = _table().rename(columns={f"pwm_{j}": f"servo{j}" for j in range(1, 7)})
    with pytest.raises(DiveDataError, match=r"no Z_N samples .* servo-output columns pwm_1 … "
                                            r"pwm_n .* columns servo1 \(pwm_1\?\), servo2 "
                                            r"\(pwm_2\?\).* are not read"):
        _read(servo).require("heave")
    # columns uuvid reads nothing from (a second clock, a temperature, the current): not named
    plain = _read(_table().assign(notes="x", lat=1.0, timestamp=0.0, altitude=1.0,
                                  battery_current_A=3.0, thruster_temp=30.0, level=1.0))
    assert plain.unread == []


@pytest.mark.slow
def test_a_column_with_a_unit_in_its_name_and_other_columns_are_said_not_read(tmp_path):
    """``depth [cm]`` (values ×100) and ``temp [C]`` were ignored without a word: identify
    `--dof all` gave yaw only, exit 0, and said neither that the depth was not read nor that heave
    was left out (``depth_cm`` did get the "not read" warning)."""
    from uuvid.identify.vehicle.dive import identify_dive
    from uuvid.simulate.dive_replay import replay_dive

    df = _table().drop(columns=["u_mps", "v_mps"])
    df = df.rename(columns={"depth_m": "depth [cm]"}).assign(**{"temp [C]": 20.0, "foo bar": 1})
    df["depth [cm]"] *= 100.0
    dc = _read(df, tmp_path, "unit.csv")
    assert "depth_m" not in dc.channels and dc.unread == ["depth [cm] (depth_m? in m, not cm)"]
    said = [w for w in dc.warnings if "not read" in w]
    assert said[0].startswith("unit.csv: column(s) depth [cm] (depth_m? in m, not cm) not read "
                              "(uuvid reads t_s [s], depth_m [m, down]"), said
    assert said[1].startswith("unit.csv: column(s) temp [C], foo bar not read: not a channel uuvid "
                              "uses (uuvid reads t_s [s]"), said
    assert len(said) == 2
    same = _read(_table().rename(columns={"depth_m": "Depth (m)", "yaw_rad": "heading [rad]"}))
    assert same.unread == ["Depth (m) (depth_m?)", "heading [rad] (yaw_rad?)"]
    left = ("unit.csv: of all the DOFs (dofs=all, the default) heave (no depth_m), surge (no u_mps), "
            "sway (no v_mps) left out: the log has no such channel; its columns depth [cm] (depth_m? in m, not "
            "cm) are not read")
    res = identify_dive(tmp_path / "unit.csv", "bluerov2", "all")
    assert list(res.estimates) == ["yaw"]
    assert any(w.startswith(left) for w in res.warnings), res.warnings
    rep = replay_dive(tmp_path / "unit.csv", "bluerov2", "all")
    assert any(n.startswith(left) for n in rep.notes), rep.notes
    named = identify_dive(tmp_path / "unit.csv", "bluerov2", ["yaw"])  # DOFs named: nothing left out
    assert not any("left out heave" in w for w in named.warnings)


def test_a_heading_in_degrees_is_caught_behind_a_long_quiet_stretch():
    """20 minutes disarmed with a still heading, then a dive turning in degrees: the 90th
    percentile rate over the whole log passed; the check now looks at the armed samples."""
    quiet = pd.DataFrame({"t_s": np.arange(0, 1200, 0.05)})
    quiet["depth_m"], quiet["yaw_rad"], quiet["armed"] = 0.0, 0.5, False
    dive = _table()
    dive["t_s"] += 1200.0
    dive["yaw_rad"] = np.degrees(dive["yaw_rad"]) * 5  # ±86° of turning
    dive["armed"] = True
    df = pd.concat([quiet, dive], ignore_index=True)
    with pytest.raises(DiveDataError, match=r"column yaw_rad turns at .* is it in degrees"):
        _read(df)
    dive["yaw_rad"] = np.radians(dive["yaw_rad"])
    _read(pd.concat([quiet, dive], ignore_index=True))  # radians: read


def _deck_then_dive(offset: float) -> pd.DataFrame:
    deck = pd.DataFrame({"t_s": np.arange(0, 120, 0.05)})
    rng = np.random.default_rng(3)
    deck["depth_m"] = 0.005 * rng.standard_normal(deck["t_s"].size)
    deck["yaw_rad"], deck["armed"] = 0.2, False
    dive = _table()
    dive["t_s"] += 120.0
    dive["armed"] = True
    df = pd.concat([deck, dive], ignore_index=True)
    df["depth_m"] += offset
    return df


def test_a_surface_read_too_deep_is_said_with_the_offset():
    """A +0.3 m depth offset (the surface pressure of another place): on deck and at the surface
    the depth read 0.3 m, past the 0.2 m surface cut-off, and windows on deck were fitted as water
    (yaw inertia ×7.7) without a word."""
    ws = [w for w in _read(_deck_then_dive(0.3)).warnings if "too deep" in w]
    assert len(ws) == 1 and "reads 0.3 m" in ws[0] and "depth_m − 0.3" in ws[0], ws
    assert not any("too deep" in w for w in _read(_deck_then_dive(0.0)).warnings)
    # disarmed at 1.5 m (a log started under water, the vehicle rising later): no surface there
    sub = _deck_then_dive(0.0)
    sub.loc[sub["armed"] == False, "depth_m"] += 1.5  # noqa: E712
    assert not any("too deep" in w for w in _read(sub).warnings)


def test_times_outside_the_log_are_an_error_naming_its_span():
    """A log stamped in epoch seconds with ``--t-end 180`` (meant from its start): the error said
    "0 usable windows in [1.7e9, 180] s", and a replay with ``--t-start 180`` replayed it all."""
    from uuvid.identify.vehicle.dive import identify_dive
    from uuvid.simulate.dive_replay import replay_dive

    df = _table()
    df["t_s"] += 1.7e9
    df["armed"] = True
    with pytest.raises(DiveDataError, match=r"t_end=180 s is outside the log, whose times run "
                                            r"from 1700000000 to .*seconds since 1970.*e\.g\. "
                                            r"1700000180"):
        identify_dive(df, "bluerov2", ["heave"], t_end=180.0)
    with pytest.raises(DiveDataError, match=r"t_start=180 s is outside the log"):
        replay_dive(df, "bluerov2", ["heave"], t_start=180.0)
    rel = _table().assign(armed=True)
    with pytest.raises(DiveDataError, match=r"t_start=500 s is outside the log, whose times run "
                                            r"from 0 to 59\.95 s: give"):
        identify_dive(rel, "bluerov2", ["heave"], t_start=500.0)


@pytest.mark.parametrize("kind", ["datetime", "timedelta"])
def test_a_parquet_time_column_of_dates_or_durations_is_read_in_seconds(tmp_path, kind):
    """A Parquet ``t_s`` of datetime64/timedelta64 was read as its nanosecond integers ("median
    step 3e7 s … is the time in milliseconds?": the advice did not help)."""
    df = _table()
    secs = df["t_s"].to_numpy()
    df["t_s"] = (pd.Timestamp("2024-05-01 10:00") + pd.to_timedelta(secs + 5.0, unit="s")
                 if kind == "datetime" else pd.to_timedelta(secs + 5.0, unit="s"))
    p = tmp_path / "dt.parquet"
    df.to_parquet(p)
    dc = read_dive_channels(p, "bluerov2")
    t = dc.channels["depth_m"][0]
    if kind == "datetime":  # seconds from the first stamp
        np.testing.assert_allclose(t, secs, atol=1e-6)
        assert any("holds dates and times: read as seconds from its first stamp" in w
                   for w in dc.warnings)
    else:  # a duration is a time already
        np.testing.assert_allclose(t, secs + 5.0, atol=1e-6)
        assert any("holds durations: read in seconds" in w for w in dc.warnings)


def test_time_in_ms_behind_a_fast_stream_is_named_where_the_horizon_fails():
    """Time in ms with a 400 Hz attitude stream among the rows: the median row step (2.5) passed
    the ms check, and the error asked for a 1000-s horizon instead of naming the unit."""
    from uuvid.identify.vehicle.dive import identify_dive

    df = _table().assign(armed=True)
    df["t_s"] *= 1000.0
    fast = pd.DataFrame({"t_s": np.arange(0.0, 60000.0, 2.5) + 0.1, "roll_rad": 0.0,
                         "armed": True})
    both = pd.concat([df, fast], ignore_index=True).sort_values("t_s", kind="stable")
    with pytest.raises(DiveDataError, match=r"median step 50 s\).*is the time in milliseconds"):
        identify_dive(both.reset_index(drop=True), "bluerov2", ["heave"])


@pytest.fixture(scope="module")
def pwm_dive(tmp_path_factory):
    """The example dive with its thrust from the servo outputs (its force columns dropped)."""
    from uuvid.examples import write_example

    df = pd.read_csv(write_example("dive", tmp_path_factory.mktemp("pwm_dive"))[0])
    return df.drop(columns=["X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"])


def _short_yaw(dc, tmp_path):
    """A quick yaw fit of a read dive and the refused write-back of it."""
    from uuvid.identify.vehicle.dive import identify_dive
    from uuvid.vehicle.writeback import WritebackError

    res = identify_dive(None, "bluerov2", ["yaw"], t_start=100.0, t_end=145.0, dive=dc)
    with pytest.raises(WritebackError) as e:
        res.write_vehicle(tmp_path / "v.yaml")
    assert not (tmp_path / "v.yaml").exists()
    return res.estimates["yaw"], str(e.value)


@pytest.mark.slow
def test_a_motor_named_reversed_makes_the_dofs_it_drives_no_model_to_write(pwm_dive, tmp_path):
    dc = _read(_mirror(pwm_dive, "pwm_3"))
    assert _reversed(dc) and dc.faulty["3"][1] == ["yaw", "surge", "sway"], dc.faulty
    assert not _read(pwm_dive).faulty
    e, refused = _short_yaw(dc, tmp_path)
    said = [w for w in e.unusable if w.startswith("pwm_3 is probably reversed")]
    assert len(said) == 1 and "N_Nm" in said[0] and "mirror that column (pwm_3)" in said[0], e.unusable
    assert "yaw is not a model to use (" in refused and "pwm_3 is probably reversed" in refused
    assert "better)" not in "\n".join(e.summary_lines(145.0))


@pytest.mark.slow
def test_a_thruster_of_the_vehicle_off_throughout_is_said_strongly_and_blocks_its_dofs(
        pwm_dive, tmp_path):
    dc = _read(pwm_dive.assign(pwm_4=pwm_dive["pwm_4"] * 0.0))  # (its empty cells kept)
    said = [w for w in dc.warnings if "pwm_4 is 0 µs throughout" in w]
    assert len(said) == 1 and "thruster 4 of bluerov2" in said[0], said
    assert "missing from the computed N_Nm/X_N/Y_N (yaw, surge, sway)" in said[0]
    assert "SERVO4_FUNCTION" in said[0] and "logger" in said[0]
    assert dc.faulty["4"][1] == ["yaw", "surge", "sway"]  # not heave: a horizontal thruster
    e, refused = _short_yaw(dc, tmp_path)
    assert any(w.startswith("pwm_4 is 0 µs throughout") for w in e.unusable), e.unusable
    assert "pwm_4" in refused and "SERVO4_FUNCTION" in refused
    # the table's own force columns are used: the output off takes nothing from them
    cols = _read(pwm_dive.assign(pwm_4=pwm_dive["pwm_4"] * 0.0, X_N=0.0, Y_N=0.0, Z_N=0.0, K_Nm=0.0, M_Nm=0.0,
                                 N_Nm=0.0))
    assert not cols.faulty and any("pwm_4 is 0 µs throughout: that output is off" in w
                                   for w in cols.warnings)


def test_an_output_off_blocks_only_the_dofs_whose_force_it_computes(pwm_dive):
    """A table giving Z_N and N_Nm itself, the other forces from the servo outputs: a vertical
    thruster's output at 0 µs throughout blocked heave ('missing from the computed Z_N') although
    Z_N is the table's own column and the heave fit was as good as the clean one.  A horizontal
    one still blocks surge and sway (computed), not yaw (the table's N_Nm)."""
    zn = pwm_dive.assign(Z_N=1.0, N_Nm=0.5)
    vert = _read(zn.assign(pwm_5=pwm_dive["pwm_5"] * 0.0))
    assert not vert.faulty, vert.faulty
    assert any("pwm_5 is 0 µs throughout: that output is off" in w and "own force columns" in w
               for w in vert.warnings), vert.warnings
    horiz = _read(zn.assign(pwm_4=pwm_dive["pwm_4"] * 0.0))
    assert horiz.faulty["4"][1] == ["surge", "sway"], horiz.faulty
