"""Second round of new-user traps in ``uuvid log`` on the real small ArduSub logs (skip when
../shared/data is absent): an absurd --dt, NaN and empty --t-start/--t-end, logs joined by
``cat``, cut-off files, and gaps in the log bridged by interpolation."""

from __future__ import annotations

import math

import pytest

pytest.importorskip("pymavlink")

from typer.testing import CliRunner  # noqa: E402

from uuvid.cli.app import app  # noqa: E402
from uuvid.io.ardusub import load_dive  # noqa: E402
from uuvid.io.logs import LogDataError  # noqa: E402


@pytest.fixture
def logs(shared_data):
    return shared_data / "ardusub-bluerov2"


def _export(log, tmp_path, *args):
    return CliRunner().invoke(app, ["log", "export", str(log), "--out-file",
                                    str(tmp_path / "x.csv"), *args])


def test_a_tiny_dt_is_refused_before_the_grid_is_built(logs, tmp_path):
    """--dt 1e-6 on the 23.6 s small.BIN headed for 23.6 M rows; now refused naming --dt and the
    row count (more than 100× the densest channel's samples)."""
    r = _export(logs / "small.BIN", tmp_path, "--dt", "1e-6")
    assert r.exit_code != 0
    assert "--dt 1e-06" in r.output and "rows" in r.output and "densest" in r.output
    assert not (tmp_path / "x.csv").exists()


@pytest.mark.parametrize("opt", ["--t-start", "--t-end"])
def test_a_nan_time_bound_is_refused(logs, tmp_path, opt):
    """--t-start nan failed with "cannot convert float NaN to integer"; --t-end nan exported the
    whole log."""
    r = _export(logs / "small.BIN", tmp_path, opt, "nan")
    assert r.exit_code != 0 and f"{opt} nan: expected a finite time in s" in r.output
    with pytest.raises(LogDataError, match="expected a finite time in s"):
        load_dive(logs / "small.BIN", **{opt[2:].replace("-", "_"): math.nan})


def test_an_empty_or_outside_range_is_said_without_dt_or_none(logs, tmp_path):
    """[5, 5] s blamed a --dt nobody gave; --t-end -5 printed "t_start = None"."""
    r = _export(logs / "small.BIN", tmp_path, "--t-start", "5", "--t-end", "5")
    assert r.exit_code != 0 and "--dt" not in r.output and "after --t-start 5" in r.output
    r = _export(logs / "small.BIN", tmp_path, "--t-end", "-5")
    assert r.exit_code != 0 and "None" not in r.output
    assert "outside the log (0–23.6 s)" in r.output
    r = _export(logs / "small.BIN", tmp_path, "--t-start", "5", "--t-end", "5.01")
    assert r.exit_code != 0 and "--dt" not in r.output and "longer range" in r.output
