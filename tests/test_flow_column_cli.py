"""``uuvid thruster fit`` with a water speed column (a bench in a flow), as a new user met it.

The inputs are the project's own examples (``uuvid examples thruster-runs`` / ``thruster-flow``)
changed the way a user's files differ:

1. an all-zero ``flow_speed`` column beside the thruster runs (what the tool tells a user to add to
   a file recorded in still water) stopped the dynamic fit at the first ramp step, where the
   thrust is noise about zero; the file must fit as without the column, and a real reversal must
   still be refused;
2. a flow column's unit in its header (``flow [kn]``, ``flow_speed (kn)``, ``flow [cm/s]``) was
   ignored (knots read as m/s: k_a 0.0167 instead of 0.0324) and an error named a column
   ``'flow_speed'`` the file did not have;
3. ``--model four-quadrant`` on a flow column of the wrong sign wrote a map whose thrust rises
   with the water from ahead without a word, where ``--model quadratic`` warns.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.examples import write_example
from uuvid.io.bench import BenchDataError, header_unit, read_bench

runner = CliRunner()
KNOT = 1852.0 / 3600.0
RUN_ARGS = ["--time-col", "t", "--command-col", "V", "--command-unit", "volts", "--speed-col", "w",
            "--thrust-col", "T", "--model", "first-order", "--json"]
FLOW_ARGS = ["--model", "quadratic", "--speed-col", "speed", "--thrust-col", "thrust", "--json"]


def _fit(*args):
    return runner.invoke(app, ["thruster", "fit", *map(str, args)])


def _said(res) -> str:
    return " ".join(res.output.split())


def _doc(res) -> dict:
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout[res.stdout.index("{"):])


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("runs")
    paths = {p.name: p for p in write_example("thruster-runs", d)}
    return [paths[f"run_{n}.csv"] for n in ("+2V", "-2V", "+3V")]


@pytest.fixture(scope="module")
def flow_file(tmp_path_factory):
    return write_example("thruster-flow", tmp_path_factory.mktemp("flow"))[0]


def _with_zero_flow(paths, folder):
    out = []
    for p in paths:
        df = pd.read_csv(p)
        df["flow_speed"] = 0.0
        out.append(folder / f"zflow_{p.name[4:]}")
        df.to_csv(out[-1], index=False)
    return out


# ----------------------------------------------------------------- 1. an all-zero flow column
@pytest.mark.slow
def test_an_all_zero_flow_column_fits_the_runs_as_without_it(runs, tmp_path):
    """The example runs' first ramp step (0.013 V) gives a thrust of −0.12 N: noise about zero,
    which the still-water check tolerates (5 % of the largest |thrust| or 6× the row-to-row
    scatter); the check in a flow refused it at 2 %."""
    plain = _doc(_fit(*runs, *RUN_ARGS, "--out-model", tmp_path / "plain.yaml"))
    res = _fit(*_with_zero_flow(runs, tmp_path), *RUN_ARGS, "--out-model", tmp_path / "zero.yaml")
    zero = _doc(res)
    assert zero["parameters"] == plain["parameters"]
    assert zero["rmse"] == plain["rmse"]


def test_a_real_reversal_in_still_water_is_still_refused(runs, tmp_path):
    """A few rows of the held +2 V plateau with the thrust negated (−2.8 N against a forward
    command, far beyond the noise) stay an error naming the file, the column and the row."""
    files = _with_zero_flow(runs, tmp_path)
    df = pd.read_csv(files[0])
    i = int(np.flatnonzero((df["V"] == 2.0) & (df["t"] > 2.5))[0])
    df.loc[i:i + 3, "T"] *= -1.0
    df.to_csv(files[0], index=False)
    res = _fit(*files, *RUN_ARGS, "--out-model", tmp_path / "bad.yaml")
    assert res.exit_code == 2, res.output
    assert f"zflow_+2V.csv: column 'T', data row {i + 1}" in _said(res)
    assert "cannot oppose the command" in _said(res)
    assert not (tmp_path / "bad.yaml").exists()


def test_a_time_series_reversing_its_command_in_still_water_is_no_reversal(tmp_path):
    """A step from +2 V straight to −2 V: the thrust keeps its old sign for the thruster's lag
    (a few samples of +2.6 N at −2 V), which is no sign error; the same thrust negated later in
    the −2 V hold, once the thrust has reached its new side, is one."""
    from uuvid.identify.thruster.dynamic_select import reference_two_state_thruster

    dt = 0.005
    t = np.arange(0.0, 3.0 + dt / 2, dt)
    u = np.where(t < 0.2, 0.0, np.where(t < 1.5, 2.0, -2.0))
    r = reference_two_state_thruster().simulate(u, t[-1], dt=dt, substeps=1)
    rng = np.random.default_rng(1)
    thrust = r["thrust"] + 0.15 * rng.standard_normal(t.size)
    assert np.any((u < 0) & (thrust > 1.0))  # the lag: the design's point
    df = pd.DataFrame({"t": t, "V": u, "w": r["prop_speed"], "T": thrust, "flow_speed": 0.0})
    df.to_csv(tmp_path / "step.csv", index=False)
    kw = dict(command_col="V", command_unit="volts", time_col="t", speed_col="w", thrust_col="T")
    assert read_bench(tmp_path / "step.csv", **kw).flow_speed is not None
    i = int(np.flatnonzero(t > 2.5)[0])
    df.loc[i:i + 3, "T"] *= -1.0
    df.to_csv(tmp_path / "slip.csv", index=False)
    with pytest.raises(BenchDataError, match=rf"slip\.csv: column 'T', data row {i + 1} .*astern"):
        read_bench(tmp_path / "slip.csv", **kw)


# ----------------------------------------------------------------- 2. a flow column's unit
@pytest.mark.parametrize("header, unit, scale", [
    ("flow [kn]", "kn", 1.0 / KNOT),
    ("flow_speed (kn)", "kn", 1.0 / KNOT),
    ("flow [cm/s]", "cm/s", 100.0),
    ("flow_speed [km/h]", "km/h", 3.6),
    ("flow_mm_s", "mm/s", 1000.0),
])
@pytest.mark.slow
def test_a_flow_columns_header_unit_is_converted_and_said(flow_file, tmp_path, header, unit, scale):
    ref = _doc(_fit(flow_file, *FLOW_ARGS, "--out-model", tmp_path / "ref.yaml"))
    df = pd.read_csv(flow_file)
    df[header] = df.pop("flow_speed") * scale
    p = tmp_path / "h.csv"
    df.to_csv(p, index=False)
    res = _fit(p, *FLOW_ARGS, "--flow-speed-col", header, "--out-model", tmp_path / "h.yaml")
    doc = _doc(res)
    assert doc["parameters"]["k_a"]["estimate"] == pytest.approx(
        ref["parameters"]["k_a"]["estimate"], rel=1e-9)
    assert doc["inflow"]["flow_levels_m_s"] == pytest.approx(ref["inflow"]["flow_levels_m_s"])
    said = [n for n in doc["notes"] if header in n]
    assert len(said) == 1 and f"read in {unit}" in said[0] and "m/s" in said[0], doc["notes"]


def test_the_flow_columns_unit_by_option_and_a_header_found_by_itself(flow_file, tmp_path):
    """``--flow-speed-unit`` for a header without one; ``flow_speed [cm/s]`` is found without
    ``--flow-speed-col``; an option against the header is refused, as for thrust and speed."""
    ref = _doc(_fit(flow_file, *FLOW_ARGS, "--out-model", tmp_path / "ref.yaml"))
    ka = ref["parameters"]["k_a"]["estimate"]
    df = pd.read_csv(flow_file)
    df["flow"] = df.pop("flow_speed") * 100.0
    df.to_csv(tmp_path / "plain.csv", index=False)
    doc = _doc(_fit(tmp_path / "plain.csv", *FLOW_ARGS, "--flow-speed-col", "flow",
                    "--flow-speed-unit", "cm/s", "--out-model", tmp_path / "a.yaml"))
    assert doc["parameters"]["k_a"]["estimate"] == pytest.approx(ka, rel=1e-9)
    df.rename(columns={"flow": "flow_speed [cm/s]"}).to_csv(tmp_path / "auto.csv", index=False)
    doc = _doc(_fit(tmp_path / "auto.csv", *FLOW_ARGS, "--out-model", tmp_path / "b.yaml"))
    assert doc["parameters"]["k_a"]["estimate"] == pytest.approx(ka, rel=1e-9)
    res = _fit(tmp_path / "auto.csv", *FLOW_ARGS, "--flow-speed-unit", "m/s",
               "--out-model", tmp_path / "c.yaml")
    assert res.exit_code == 2 and "'flow_speed [cm/s]' is in cm/s by its header" in _said(res)


def test_an_unknown_flow_unit_and_a_flow_error_name_the_real_column(flow_file, tmp_path):
    df = pd.read_csv(flow_file)
    df.rename(columns={"flow_speed": "flow [furlong]"}).to_csv(tmp_path / "unk.csv", index=False)
    res = _fit(tmp_path / "unk.csv", *FLOW_ARGS, "--flow-speed-col", "flow [furlong]",
               "--out-model", tmp_path / "u.yaml")
    assert res.exit_code == 2
    assert "unk.csv: column 'flow [furlong]': 'furlong' in its header is no water speed unit" \
        in _said(res)
    df = pd.read_csv(flow_file)
    df["flow"] = df.pop("flow_speed") * 100.0  # cm/s, no unit anywhere
    df.to_csv(tmp_path / "cms.csv", index=False)
    res = _fit(tmp_path / "cms.csv", *FLOW_ARGS, "--flow-speed-col", "flow",
               "--out-model", tmp_path / "c.yaml")
    assert res.exit_code == 2
    assert "cms.csv: column 'flow' reaches 80 m/s" in _said(res) and "'flow_speed'" not in \
        _said(res).split("column 'flow' reaches")[0]
    res = _fit(tmp_path / "cms.csv", "--model", "polynomial", "--speed-col", "speed",
               "--thrust-col", "thrust", "--flow-speed-col", "flow", "--out-model",
               tmp_path / "p.yaml")
    assert res.exit_code == 2 and "cms.csv: column 'flow', data row" in _said(res)


def test_header_unit_reads_water_speed_units():
    assert header_unit("flow [kn]", "flow speed") == "kn"
    assert header_unit("flow_speed (knots)", "flow speed") == "kn"
    assert header_unit("u_a [m s^-1]", "flow speed") == "m/s"
    assert header_unit("carriage_ft_s", "flow speed") == "ft/s"
    assert header_unit("flow_speed", "flow speed") is None
    assert header_unit("flow_ms", "flow speed") is None  # milliseconds? says nothing
    assert header_unit("flow [kn]", "thrust") is None


# ----------------------------------------------------------------- 3. four-quadrant, sign reversed
@pytest.mark.parametrize("forward_only", [False, True])
def test_four_quadrant_warns_like_quadratic_when_the_flow_sign_is_reversed(flow_file, tmp_path,
                                                                            forward_only):
    """Water from ahead takes thrust away (k_a > 0, Healey et al. 1995); the map fitted to the
    negated column says the opposite (−∂T/∂u_a / |Ω| ≈ −0.033), as quadratic's k_a < 0 does."""
    df = pd.read_csv(flow_file)
    if forward_only:
        df = df[df["speed"] > 0]
    df.to_csv(tmp_path / "ok.csv", index=False)
    df.assign(flow_speed=-df["flow_speed"]).to_csv(tmp_path / "rev.csv", index=False)
    fq = ["--model", "four-quadrant", "--diameter", "0.076", "--speed-col", "speed",
          "--thrust-col", "thrust", "--json"]
    ok = _doc(_fit(tmp_path / "ok.csv", *fq, "--out-model", tmp_path / "ok.yaml"))
    assert not any("sign reversed" in w for w in ok["warnings"]), ok["warnings"]
    res = _fit(tmp_path / "rev.csv", *fq, "--out-model", tmp_path / "rev.yaml")
    rev = _doc(res)
    said = [w for w in rev["warnings"] if "sign reversed" in w]
    assert len(said) == 1 and "k_a of the fitted map" in said[0], rev["warnings"]
    quad = _doc(_fit(tmp_path / "rev.csv", *FLOW_ARGS, "--out-model", tmp_path / "q.yaml"))
    (q,) = [w for w in quad["warnings"] if "sign reversed" in w]
    tail = q.split(" < 0: ", 1)[1]  # the same words after the value
    assert said[0].split(" < 0: ", 1)[1] == tail
    assert "warning:" in _said(res) and "sign reversed" in _said(res)
