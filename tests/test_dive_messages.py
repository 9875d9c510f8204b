"""The dive commands' messages say what is wrong and what to do: a thruster count that does not
match, an empty DOF list, a heading left out as a stuck sensor, a time given as text from Python."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.identify.vehicle.dive import identify_dive
from uuvid.io.dive_channels import DiveDataError, read_dive_channels
from uuvid.simulate.dive_replay import replay_dive

runner = CliRunner()


def _table(n_pwm: int = 6, n: int = 1200, rate: float = 20.0) -> pd.DataFrame:
    """A 60 s dive table: depth 0–2 m, a slow turn, ``n_pwm`` driven servo outputs, 16 V."""
    t = np.arange(n) / rate
    df = pd.DataFrame({"t_s": t, "depth_m": 1.0 - np.cos(t / 10.0),
                       "yaw_rad": 0.3 * np.sin(t / 7.0), "battery_V": 16.0 - 0.001 * t})
    for j in range(1, n_pwm + 1):
        df[f"pwm_{j}"] = np.rint(1500 + 100 * np.sin(t / (3.0 + j)))
    return df


@pytest.mark.parametrize("n_pwm", [3, 8])
def test_a_thruster_count_that_does_not_match_says_what_to_pass(n_pwm):
    """It read "…has 6 thrusters; otherwise pass the vehicle…" with nothing before "otherwise"."""
    with pytest.raises(DiveDataError) as e:
        read_dive_channels(_table(n_pwm), "bluerov2")
    msg = str(e.value)
    assert f"{n_pwm} pwm_ columns" in msg and "has 6 thrusters; pass the vehicle the log was " \
                                              "flown with" in msg
    assert "otherwise" not in msg


def test_outputs_off_throughout_keep_their_otherwise():
    df = _table(8)
    df["pwm_7"] = 0.0
    df["pwm_2"] = 0.0  # one of the six off too: the spares cannot simply be dropped
    with pytest.raises(DiveDataError, match="drop those columns; otherwise pass the vehicle"):
        read_dive_channels(df, "bluerov2")


@pytest.mark.parametrize("command", [["vehicle", "identify", "dive"], ["vehicle", "replay"]])
def test_an_empty_dof_list_says_so_and_names_the_dofs_the_log_has(tmp_path, command):
    """`--dof ''` gave "no DOF could be identified:  (read from …)" with no reason."""
    p = tmp_path / "d.csv"
    _table().to_csv(p, index=False)
    r = runner.invoke(app, [*command, str(p), "--vehicle", "bluerov2", "--dof", ""])
    assert r.exit_code == 2
    text = " ".join(r.output.split())
    assert "the DOF list is empty" in text and "d.csv has the channels for heave, yaw" in text


def test_no_dof_identified_names_the_file_first(tmp_path):
    """A 3-row armed table (every DOF): "error: no DOF could be identified: heave: only 3 depth_m
    samples…" named the file only at the very end, "(read from d.csv)"."""
    p = tmp_path / "d.csv"
    _table(n=3).assign(armed=True).to_csv(p, index=False)
    r = runner.invoke(app, ["vehicle", "identify", "dive", str(p), "--vehicle", "bluerov2"])
    assert r.exit_code == 2
    text = " ".join(r.output.split())
    assert "error: d.csv: no DOF could be identified: heave: only 3 depth_m samples" in text, text
    assert "read from" not in text


def test_a_heading_left_out_as_a_stuck_sensor_is_said_so_not_missing():
    """A constant heading was left out as a stuck sensor, then the error said "no yaw_rad
    samples" though the column had 1200."""
    df = _table()
    df["yaw_rad"] = 0.5
    with pytest.raises(DiveDataError) as e:
        identify_dive(df, "bluerov2", ["yaw"])
    msg = str(e.value)
    assert "no yaw_rad samples left: 1200 were left out as a stuck sensor" in msg, msg
    assert "needs a heading source" not in msg


@pytest.mark.parametrize("fn", [identify_dive, replay_dive])
@pytest.mark.parametrize("kw", [{"t_start": "10"}, {"t_end": "250"}, {"horizon": [5]}])
def test_a_time_given_as_text_from_python_names_the_parameter(fn, kw):
    """`t_start='10'` raised a bare TypeError from a comparison deep in the reader."""
    (name, value), = kw.items()
    with pytest.raises(TypeError, match=rf"^{name} = {value!r}: expected a number of seconds"
                                        .replace("[", r"\[").replace("]", r"\]")):
        fn(_table(), "bluerov2", ["heave"], **kw)


@pytest.mark.parametrize("fn", [identify_dive, replay_dive])
@pytest.mark.parametrize("vehicle", [None, 3])
def test_a_missing_vehicle_from_python_names_the_argument(fn, vehicle):
    """`identify_dive(log, None)` raised a bare "expected str, bytes or os.PathLike object, not
    NoneType" from deep in the vehicle loader."""
    with pytest.raises(TypeError, match=rf"^{fn.__name__}: vehicle: expected the base vehicle, a "
                                        r"preset name \(e\.g\. 'bluerov2'\), a vehicle file's path "
                                        rf"or a Vehicle, got {type(vehicle).__name__} {vehicle!r}$"):
        fn(_table(), vehicle, ["heave"])


@pytest.mark.parametrize("fn", [identify_dive, replay_dive])
def test_a_vehicle_part_is_not_taken_for_the_vehicle(fn):
    """The dives took anything with a ``B`` as the vehicle (their own load-or-check, a copy of
    vehicle.definition.as_vehicle): a thruster layout went on and failed later, in words that
    named neither the function nor the argument.  Refused by the one check, naming both."""
    from uuvid.vehicle.definition import load_vehicle

    layout = load_vehicle("bluerov2").layout
    with pytest.raises(TypeError, match=rf"^{fn.__name__}: vehicle: expected the base vehicle, .*"
                                        r"got ThrusterLayout"):
        fn(_table(), layout, ["heave"])


def test_all_dofs_drop_a_stuck_depth_in_replay_as_in_identify():
    """`--dof all` with a depth at 0 throughout (left out as a stuck sensor): identify dropped
    heave with a warning and went on, replay stopped with an error; heave named stays an error."""
    df = _table().assign(depth_m=0.0)
    res = replay_dive(df, "bluerov2", "all")
    assert "heading" in res.channels and "depth" not in res.channels
    said = [w for w in res.warnings if w.startswith("heave not replayed: <table>: no depth_m "
                                                     "samples left")]
    assert len(said) == 1 and "left out as a stuck sensor" in said[0], res.warnings
    assert any("depth_m repeats 0 exactly" in w for w in res.warnings)
    ident = identify_dive(df, "bluerov2", "all")
    assert "heave" not in ident.estimates
    assert any(w.startswith("heave not identified: <table>: no depth_m samples left")
               for w in ident.warnings)
    for fn in (replay_dive, identify_dive):
        with pytest.raises(DiveDataError, match=r"^<table>: no depth_m samples left: 1200 were left "
                                                r"out as a stuck sensor"):
            fn(df, "bluerov2", ["heave", "yaw"])


def test_messages_name_the_argument_for_python_and_the_option_for_the_command(tmp_path):
    """`identify_dive(t_end=…)`/`replay_dive(horizon=…)` were told "--t-end", "--horizon": the
    options of a command they did not run."""
    df = _table()
    with pytest.raises(DiveDataError, match=r"^<table>: t_start=1e\+06 s is outside the log, whose "
                                            r"times run from 0 to 59\.95 s"):
        identify_dive(df, "bluerov2", ["heave"], t_start=1e6)
    with pytest.raises(DiveDataError, match=r"^t_end=5 s must be after t_start=10 s$"):
        replay_dive(df, "bluerov2", ["heave"], t_start=10.0, t_end=5.0)
    with pytest.raises(DiveDataError, match=r"^horizon=-1: expected a window length > 0 s"):
        replay_dive(df, "bluerov2", ["heave"], horizon=-1.0)
    with pytest.raises(DiveDataError, match=r"window too short to identify heave: .* widen "
                                            r"t_start/t_end or pass a longer dive"):
        identify_dive(df, "bluerov2", ["heave"], t_end=15.0)
    with pytest.raises(DiveDataError, match=r"no usable armed window .* widen t_start/t_end or "
                                            r"shorten horizon"):
        replay_dive(df, "bluerov2", ["heave"], horizon=100.0)
    p = tmp_path / "d.csv"
    df.to_csv(p, index=False)
    for args, said in (
            (["identify", "dive", "--t-start", "1e6"], "d.csv: --t-start 1e+06 s is outside the log"),
            (["identify", "dive", "--dof", "heave", "--t-end", "15"], "widen --t-start/--t-end or "
                                                                       "pass a longer dive"),
            (["replay", "--dof", "heave", "--horizon", "100"], "widen --t-start/--t-end or shorten "
                                                               "--horizon")):
        r = runner.invoke(app, ["vehicle", *args, str(p), "--vehicle", "bluerov2"])
        text = " ".join(r.output.split())
        assert r.exit_code == 2 and said in text, text
    with pytest.raises(DiveDataError, match=r"t_start=1e\+06 s is outside"):  # after a command
        identify_dive(df, "bluerov2", ["heave"], t_start=1e6)


def test_dofs_given_as_a_generator_are_read_once():
    """identify_dive read a generator of DOF names to test it for ["all"], then found the list
    empty ("the DOF list is empty")."""
    res = identify_dive(_table(), "bluerov2", (d for d in ["yaw"]))
    assert list(res.estimates) == ["yaw"]


def _forces(dc) -> np.ndarray:
    return np.vstack([dc.channels[c][1] for c in ("X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm")])


def test_params_reverse_a_tables_motor_as_for_an_ardusub_log(tmp_path):
    """`--params` was silently ignored for CSV/Parquet: MOT_1_DIRECTION,-1 changed nothing and
    the run still said "no reversal applied"."""
    df = _table()
    p = tmp_path / "d.csv"
    df.to_csv(p, index=False)
    prm = tmp_path / "rev.params"
    prm.write_text("MOT_1_DIRECTION,-1\n")
    plain = read_dive_channels(p, "bluerov2")
    rev = read_dive_channels(p, "bluerov2", params=prm)
    assert any("reversed (MOT_n_DIRECTION = -1): motor(s) 1" in w and "rev.params" in w
               for w in rev.warnings), rev.warnings
    assert not any("no reversal applied" in w for w in rev.warnings)
    # the same as mirroring pwm_1 about 1500 µs in the table
    mirrored = df.copy()
    mirrored["pwm_1"] = 3000 - mirrored["pwm_1"]
    ref = read_dive_channels(mirrored, "bluerov2")
    np.testing.assert_allclose(_forces(rev), _forces(ref), atol=1e-9)
    assert not np.allclose(_forces(rev), _forces(plain))
    # a DataFrame and a {NAME: value} mapping alike
    np.testing.assert_allclose(_forces(read_dive_channels(df, "bluerov2",
                                                          params={"MOT_1_DIRECTION": -1})),
                               _forces(ref), atol=1e-9)


def test_a_missing_params_file_is_an_error_for_a_table(tmp_path):
    p = tmp_path / "d.csv"
    _table().to_csv(p, index=False)
    r = runner.invoke(app, ["vehicle", "identify", "dive", str(p), "--vehicle", "bluerov2",
                            "--dof", "heave", "--params", str(tmp_path / "nosuch.params")])
    assert r.exit_code == 2
    assert "nosuch.params: cannot read the parameter file" in " ".join(r.output.split())


def test_params_a_table_cannot_use_are_said(tmp_path):
    df = _table()
    df["Z_N"] = 0.0
    for c in ("X_N", "Y_N", "K_Nm", "M_Nm", "N_Nm"):
        df[c] = 0.0
    dc = read_dive_channels(df, "bluerov2", params={"MOT_1_DIRECTION": -1})
    assert any("force columns X_N … N_Nm are used as they are, so its MOT_n_DIRECTION is not "
               "applied" in w for w in dc.warnings)
    dc = read_dive_channels(_table(), "bluerov2", params={"SERVO1_FUNCTION": 34,
                                                         "SERVO2_FUNCTION": 33})
    assert any("SERVO1_FUNCTION → motor 2" in w and "not applied" in w for w in dc.warnings)


# ---------------------------------------------------------------------------------------------
# Servo outputs that never leave the dead band while armed
# ---------------------------------------------------------------------------------------------
def _neutral(df, *cols):
    out = df.copy()
    for c in cols or [c for c in df.columns if c.startswith("pwm_")]:
        out[c] = 1500.0
    return out


def _idle_said(dc) -> list:
    return [w for w in dc.warnings if "dead band" in w and "never leave" in w or
            "every servo output" in w]


def test_every_output_at_neutral_is_said_and_no_model_is_reported(tmp_path):
    """Every pwm_ at 1500 µs for the whole armed log while the depth moved: the heave fit printed
    "mass 183 ± inf … not identifiable" and exited 0, nothing said that the thrusters sat at
    neutral.  The reader names the outputs; the identification refuses each DOF, naming the
    outputs that give its force, and reports no model."""
    df = _neutral(_table())
    said = _idle_said(read_dive_channels(df, "bluerov2"))
    assert len(said) == 1 and said[0].startswith(
        "<table>: every servo output (pwm_1, pwm_2, pwm_3, pwm_4, pwm_5, pwm_6) stays within the "
        "dead band 1482–1518 µs of t200-physical (at 1500 µs throughout)"), said
    with pytest.raises(DiveDataError) as e:
        identify_dive(df, "bluerov2", ["heave"])
    msg = str(e.value)
    assert msg.startswith("<table>: no heave thrust to identify from: Z_N stays 0 N"), msg
    assert "pwm_5, pwm_6, every output that gives it, never leave the dead band 1482–1518 µs" in msg
    assert "the thrusters sat at neutral" in msg and "no model can be identified" in msg
    p = tmp_path / "neutral.csv"
    df.to_csv(p, index=False)
    r = runner.invoke(app, ["vehicle", "identify", "dive", str(p), "--vehicle", "bluerov2"])
    text = " ".join(r.output.split())
    assert r.exit_code == 2, text
    assert "neutral.csv: no DOF could be identified: heave: no heave thrust" in text
    assert "yaw: no yaw thrust to identify from: N_Nm stays 0 N·m" in text
    assert "pwm_1, pwm_2, pwm_3, pwm_4, every output that gives it" in text
    assert "mass [kg]" not in text


def test_a_force_column_that_never_moves_is_no_thrust_to_identify_from():
    """The same with the table's own forces: Z_N 0 throughout the part fitted."""
    df = _table()
    for c in ("X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm"):
        df[c] = 0.0
    with pytest.raises(DiveDataError, match=r"^<table>: no heave thrust to identify from: Z_N stays "
                                            r"0 N over the armed samples in \[10, 50\] s\. With no "
                                            r"force"):
        identify_dive(df, "bluerov2", ["heave"], t_start=10.0, t_end=50.0)


def test_zero_force_columns_are_said_by_replay_too_and_contradict_driven_pwm(tmp_path):
    """All six force columns at 0: identify refused ("Z_N stays 0 N"), replay said nothing; with
    pwm_ columns that show the thrusters driven, neither said the columns contradict them."""
    zero = _table().assign(**{c: 0.0 for c in ("X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm")})
    p = tmp_path / "zero.csv"
    zero.drop(columns=[f"pwm_{j}" for j in range(1, 7)]).to_csv(p, index=False)
    res = replay_dive(p, "bluerov2", ["heave", "yaw"])
    said = [w for w in res.warnings if w.startswith("zero.csv: no heave thrust in the replay: Z_N "
                                                     "stays 0 N over the armed samples in [0, 59.95] s")]
    assert len(said) == 1 and "pass a dive in which the thrusters drove it" in said[0], res.warnings
    assert "contradict" not in said[0]
    assert any(w.startswith("zero.csv: no yaw thrust in the replay: N_Nm stays 0 N·m")
               for w in res.warnings)
    zero.to_csv(p, index=False)  # with the servo outputs, driven ±100 µs
    res = replay_dive(p, "bluerov2", ["heave"])
    said = [w for w in res.warnings if "no heave thrust in the replay" in w]
    assert len(said) == 1, res.warnings
    clash = ("Yet pwm_5, pwm_6, which give Z_N, leave the dead band 1482–1518 µs of t200-physical "
             "for ")
    assert clash in said[0] and "the force column Z_N contradicts the PWM" in said[0], said
    assert "remove the force columns X_N … N_Nm" in said[0]
    with pytest.raises(DiveDataError) as e:
        identify_dive(p, "bluerov2", ["heave"])
    assert str(e.value).startswith("zero.csv: no heave thrust to identify from: Z_N stays 0 N")
    assert clash in str(e.value) and "the force column Z_N contradicts the PWM" in str(e.value)
    moving = replay_dive(_table(), "bluerov2", ["heave", "yaw"])  # thrust computed from the PWM
    assert not any("thrust in the replay" in w for w in moving.warnings)


def test_one_output_at_neutral_while_those_sharing_its_dofs_are_driven_is_named():
    """pwm_1 (front right, surge/sway/yaw) at 1500 µs throughout while the other three
    horizontal thrusters were driven: read as 'no thrust' silently (the partner check knew only
    thrusters pushing along one line, the vertical pair)."""
    said = _idle_said(read_dive_channels(_neutral(_table(), "pwm_1"), "bluerov2"))
    assert len(said) == 1, said
    assert said[0].startswith("<table>: pwm_1 never leaves the dead band 1482–1518 µs of "
                              "t200-physical (at 1500 µs throughout) in the 60 s armed while "
                              "pwm_2, pwm_3, pwm_4, pwm_5, pwm_6 are driven"), said
    assert "pwm_1 gives surge, sway and yaw with pwm_2, pwm_3, pwm_4, which are driven" in said[0]
    assert "SERVOn_FUNCTION" in said[0]


def test_the_vertical_pair_at_neutral_is_said_and_heave_refused():
    """pwm_5 and pwm_6 at neutral, the horizontal ones driven: no thruster gives heave, said (a
    DOF the pilot may not have commanded), and heave is refused, not fitted to σ = ∞."""
    df = _neutral(_table(), "pwm_5", "pwm_6")
    said = _idle_said(read_dive_channels(df, "bluerov2"))
    assert len(said) == 1 and said[0].startswith("<table>: pwm_5, pwm_6 never leave the dead band")
    assert "no other thruster gives heave, so heave has no thrust to identify from" in said[0]
    with pytest.raises(DiveDataError, match="no heave thrust to identify from.*pwm_5, pwm_6, every "
                                            "output that gives it"):
        identify_dive(df, "bluerov2", ["heave"])


def test_an_output_said_beside_its_driven_partner_is_said_once_and_driven_outputs_not_at_all():
    dc = read_dive_channels(_neutral(_table(), "pwm_5"), "bluerov2")
    about = [w for w in dc.warnings if "pwm_5" in w and "neutral" in w or "never leave" in w]
    assert len(about) == 1 and "pwm_5 sits at 1500 µs (neutral)" in about[0], about
    assert not _idle_said(read_dive_channels(_table(), "bluerov2"))


def test_the_coupled_horizontal_model_is_refused_when_its_thrusters_sat_at_neutral():
    from uuvid.simulate.dive_synth import synthetic_horizontal_dive

    df, _ = synthetic_horizontal_dive(100.0, seed=21)
    for c in ("pwm_1", "pwm_2", "pwm_3", "pwm_4"):
        df.loc[df[c].notna(), c] = 1500.0
    with pytest.raises(DiveDataError, match=r"^<table>: no horizontal thrust to identify from: X_N "
                                            r"stays 0 N, Y_N stays 0 N and N_Nm stays 0 N·m .*"
                                            r"pwm_1, pwm_2, pwm_3, pwm_4, every output that gives "
                                            r"it, never leave the dead band"):
        identify_dive(df, "bluerov2", ["horizontal"])
