"""A direction that full command makes no way in keeps the sign of its speed (issue 40).

A BlueROV2 made 10 N positively buoyant (buoyancy 122.8 N against a weight of 112.8 N) whose two
vertical thrusters push at most 1 N each rises at full dive command: the envelope, its table,
its JSON and the stability scan used to print the size of that speed as a diving speed ("diving
0.4003 m/s", "stays level to 0.4 m/s").  With every thrust limit at zero it "dived" at the rate
its buoyancy lifts it."""

import json
import re

import pytest
import yaml
from typer.testing import CliRunner

from uuvid.analysis.envelope_check import confirm_envelope
from uuvid.cli.app import app
from uuvid.vehicle.definition import load_vehicle, preset_path
from uuvid.vehicle.envelope import speed_envelope
from uuvid.vehicle.stability import static_stability

DIVE_NO_WAY = "cannot dive: rises at 0.40 m/s at full dive command"


def _write(folder, name, vertical=None, every=None):
    raw = yaml.safe_load(preset_path("bluerov2").read_text())
    # the file's convention: weight and buoyancy in N, both positive (2 N positively buoyant)
    assert raw["rigid_body"]["buoyancy"] - raw["rigid_body"]["weight"] == pytest.approx(2.0)
    raw["rigid_body"]["buoyancy"] = 122.8  # 10 N positively buoyant
    for t in raw["thrusters"]:
        if every is not None:
            t["limits"] = list(every)
        elif vertical is not None and "vertical" in t["name"]:
            t["limits"] = list(vertical)
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False, allow_unicode=True))
    return path


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("veh")
    return {"weak": _write(d, "buoyant_weak", vertical=(-1.0, 1.0)),
            "none": _write(d, "no_thrust", every=(0.0, 0.0))}


@pytest.fixture(scope="module")
def weak(files):
    return load_vehicle(files["weak"])


# ------------------------------------------------------------------ library
def test_envelope_row_says_full_dive_command_rises(weak):
    env = speed_envelope(weak)
    dive, climb = env["diving"], env["climbing"]
    assert dive.force == pytest.approx(2.0) and dive.speed == pytest.approx(-0.40028, abs=1e-5)
    assert dive.along == pytest.approx(-0.40028, abs=1e-5) and dive.makes_way is False
    assert dive.no_way() == DIVE_NO_WAY
    assert climb.along == pytest.approx(0.50384, abs=1e-5) and climb.makes_way and not climb.no_way()
    for d in ("forward", "backward", "starboard", "port", "yaw + (clockwise)"):
        assert env[d].along > 0 and env[d].makes_way, d
    text = env.summary()
    line = next(ln for ln in text.splitlines() if " diving " in ln)
    assert "-0.4 m/s" in line and f"warning: diving: {DIVE_NO_WAY}" in text
    row = next(r for r in env.to_dict()["rows"] if r["direction"] == "diving")
    assert row["speed"] < 0 and row["makes_way"] is False and row["no_way"] == DIVE_NO_WAY


def test_stability_says_no_stays_level_on_a_speed_of_the_wrong_sign(weak):
    st = static_stability(weak)
    dive = st["diving"]
    assert dive.limit_text() == DIVE_NO_WAY and "stays level" not in dive.limit_text()
    assert dive.max_speed < 0 and not dive.makes_way and not dive.limited
    assert list(dive.speeds) == [0.0]  # only the trim at rest: no speed to scan downwards
    assert st["climbing"].limit_text() == "stays level to 0.504 m/s"
    assert st["forward"].limit_text().startswith("stability 0.498 m/s")
    d = st.to_dict()
    assert d["warnings"] == [f"diving: {DIVE_NO_WAY}"]
    assert next(c for c in d["cases"] if c["direction"] == "diving")["makes_way"] is False


def test_check_rows_and_table_keep_the_sign(weak):
    check = confirm_envelope(weak, simulate=False)
    assert check["diving"]["makes_way"] is False and check["diving"]["limit"] == DIVE_NO_WAY
    assert check["diving"]["speed"] < 0 and check["diving"]["allocator_speed"] < 0
    assert check["climbing"]["makes_way"] is True and check["backward"]["makes_way"] is True
    assert check.warnings() == [f"diving: {DIVE_NO_WAY}"]
    rows = {r["direction"]: r for r in check.table_rows(("direction", "speed", "allocator_speed",
                                                           "limit"))}
    # along the direction named: negative where full command moves the vehicle the other way
    assert rows["diving"]["speed"] == "-0.4003 m/s" == rows["diving"]["allocator_speed"]
    assert rows["climbing"]["speed"] == "0.5038 m/s" and rows["backward"]["speed"] == "2.558 m/s"
    assert rows["yaw - (counter-clockwise)"]["speed"] == "4.696 rad/s"
    assert check.to_dict()["warnings"] == [f"diving: {DIVE_NO_WAY}"]


def test_no_thrust_moves_nowhere_and_rises_at_full_dive_command(files):
    v = load_vehicle(files["none"])
    env = speed_envelope(v)
    assert env["diving"].no_way() == "cannot dive: rises at 0.45 m/s at full dive command"
    assert env["forward"].no_way() == "cannot go forward: does not move at full forward command"
    assert env["climbing"].makes_way  # the buoyancy alone lifts it
    check = confirm_envelope(v, simulate=False)
    assert check.table_rows(("direction", "speed"))[4] == {"direction": "diving",
                                                          "speed": "-0.4546 m/s"}
    st = static_stability(v, envelope=env)
    assert st["diving"].limit_text().startswith("cannot dive: rises at 0.45 m/s")
    assert st["forward"].limit_text().startswith("cannot go forward")
    assert not any("stays level" in c.limit_text() for c in st.cases if c.direction != "climbing")


# ------------------------------------------------------------------ CLI
def _table_cells(text: str) -> dict[str, list[str]]:
    """The envelope table's rows by direction, each cell's wrapped lines joined (a row starts
    where its force cell does: the direction itself may wrap)."""
    rows: list[list[list[str]]] = []
    for ln in text.splitlines():
        if not ln.startswith("│"):
            continue
        cells = [c.strip() for c in ln.strip().strip("│").split("│")]
        if cells[1] or not rows:
            rows.append([[c] for c in cells])
        else:
            for i, c in enumerate(cells):
                if c:
                    rows[-1][i].append(c)
    return {" ".join(r[0]): [" ".join(p) for p in r] for r in rows}


@pytest.mark.slow
def test_cli_envelope_and_stability_say_it_cannot_dive(files):
    run = CliRunner()
    res = run.invoke(app, ["vehicle", "envelope", str(files["weak"])])
    assert res.exit_code == 0, res.output
    rows = _table_cells(res.stdout)
    dive = rows["diving"]
    assert dive[2] == "-0.4003 m/s" and dive[3] == "-0.4003 m/s"  # speed, allocator speed
    assert dive[4] == "-0.4003 m/s"  # simulated: it rises
    assert " ".join(dive[-1].split()) == DIVE_NO_WAY
    assert rows["climbing"][2] == "0.5038 m/s"
    assert "stays level to 0.4 m/s" not in " ".join(res.stdout.split())
    assert f"warning: diving: {DIVE_NO_WAY}" in " ".join(res.stderr.split())

    res = run.invoke(app, ["vehicle", "envelope", str(files["weak"]), "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    row = next(r for r in doc["rows"] if r["direction"] == "diving")
    assert row["speed"] < 0 and row["simulated_speed"] < 0 and row["makes_way"] is False
    assert row["limit"] == DIVE_NO_WAY and row["note"].startswith(DIVE_NO_WAY)
    assert doc["warnings"] == [f"diving: {DIVE_NO_WAY}"]
    case = next(c for c in doc["stability"]["cases"] if c["direction"] == "diving")
    assert case["limit"] == DIVE_NO_WAY and case["max_speed"] < 0

    res = run.invoke(app, ["vehicle", "stability", str(files["weak"])])
    assert res.exit_code == 0, res.output
    text = " ".join(res.stdout.split())
    assert "stays level to 0.4 m/s" not in text and re.search(r"diving +" + re.escape(DIVE_NO_WAY),
                                                               res.stdout)
    assert "stays level to 0.504 m/s" in text
    assert f"warning: diving: {DIVE_NO_WAY}" in " ".join(res.stderr.split())


def test_a_tumble_note_names_only_the_tilts_the_flight_reached():
    from uuvid.analysis.envelope_check import _tilt_words

    assert _tilt_words((0.2, 35.4)) == "up to 35° pitch"
    assert _tilt_words((12.0, 40.0)) == "up to 12° roll, 40° pitch"
    assert _tilt_words((71.0, 0.0)) == "up to 71° roll"
