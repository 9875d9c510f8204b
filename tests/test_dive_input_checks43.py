"""Input checks of the dive commands (issue 43): a horizon within the initial-state span, force
columns in a wrong unit, a time range outside the log, a log of the wrong type, a time column
in a wrong unit, and the messages' readability."""

import warnings

import pandas as pd
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.examples import write_examples
from uuvid.identify.vehicle.dive import identify_dive
from uuvid.simulate.dive_replay import replay_dive

runner = CliRunner()


@pytest.fixture(scope="module")
def dive_csv(tmp_path_factory):
    out = tmp_path_factory.mktemp("ex43")
    write_examples(["dive"], out)
    return out / "dive.csv"


@pytest.fixture(scope="module")
def table(dive_csv):
    return pd.read_csv(dive_csv)


# --- 1. a horizon no longer than the initial-state span --------------------------------------

def test_replay_horizon_within_state_span_is_an_error_naming_the_dof(table):
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(ValueError, match=r"heave.*must exceed the 2 s") as e:
            replay_dive(table, "bluerov2", ["heave"], horizon=2.0)
    assert "at least" in str(e.value)


def test_replay_cli_horizon_within_state_span_exits_2(dive_csv):
    r = runner.invoke(app, ["vehicle", "replay", str(dive_csv), "--vehicle", "bluerov2",
                            "--dof", "yaw", "--horizon", "0.5"])
    assert r.exit_code == 2, r.output
    assert "yaw" in r.output and "must exceed" in r.output and "nan" not in r.output


def test_identify_cli_horizon_within_state_span_exits_2(dive_csv, tmp_path):
    r = runner.invoke(app, ["vehicle", "identify", "dive", str(dive_csv), "--vehicle", "bluerov2",
                            "--dof", "heave", "--horizon", "2", "--t-end", "150",
                            "--out-vehicle", str(tmp_path / "h.yaml")])
    assert r.exit_code == 2, r.output
    assert "must exceed" in r.output and "not stay finite" not in r.output
    assert "RuntimeWarning" not in r.output


def test_identify_api_horizon_within_state_span_is_a_value_error(table):
    with pytest.raises(ValueError, match="initial state"):
        identify_dive(table, "bluerov2", ["heave"], horizon=1.5)
