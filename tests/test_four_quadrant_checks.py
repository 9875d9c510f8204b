"""Four-quadrant fit checks (fix 43): a diameter off by 10× is said, a map squeezed by it still
reports extrapolation, and a still-water bench's refusal names its reason.

The bench is the package's own example in a flow (``uuvid examples thruster-flow``: a T200-like
thruster, D = 0.076 m, five water speeds 0–0.8 m/s, both shaft directions)."""

import json

import pandas as pd
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.examples import write_example
from uuvid.identify.thruster.inflow import BOLLARD_KT_RANGE, fit_four_quadrant
from uuvid.identify.thruster.workflow import ReadOptions, run_fit
from uuvid.io.bench import BenchDataError, read_bench
from uuvid.thruster.inflow import FourQuadrantMap, wageningen_b4_70

runner = CliRunner()
FQ = ["--model", "four-quadrant", "--speed-col", "speed", "--thrust-col", "thrust", "--json"]
SAID = "is the diameter in m? (a diameter off by 10× scales K_T by 10⁴)"


@pytest.fixture(scope="module")
def flow_file(tmp_path_factory):
    return write_example("thruster-flow", tmp_path_factory.mktemp("flow"))[0]


def _fq(flow_file, d):
    return run_fit([flow_file], "four-quadrant", ReadOptions(thrust_col="thrust", speed_col="speed"),
                   diameter=d)


# ------------------------------------------------------------------ 1. implausible bollard K_T
def test_the_wageningen_scale_lies_inside_the_plausible_range():
    lo, hi = BOLLARD_KT_RANGE
    fq = wageningen_b4_70()
    assert lo < fq.bollard_kt(1) < hi and lo < -fq.bollard_kt(-1) < hi


@pytest.mark.parametrize("d, implied", [(10.0, "1.45e-09"), (0.0076, "4.63e+03")])
def test_a_diameter_off_by_ten_is_said_with_the_implied_kt(flow_file, d, implied):
    out = _fq(flow_file, d)
    said = [w for w in out.warnings if SAID in w]
    assert len(said) == 1, out.warnings
    assert f"ahead {implied}" in said[0] and f"D = {d:g} m" in said[0]
    # the diameter a typical K_T would mean is the right one to ~5 %
    suggested = float(said[0].split("would mean D ≈ ")[1].split(" m")[0])
    assert abs(suggested / 0.076 - 1) < 0.05


def test_the_right_diameter_is_silent(flow_file):
    out = _fq(flow_file, 0.076)
    assert not any("diameter in m" in w for w in out.warnings), out.warnings


def test_the_cli_shows_the_warning_on_stderr_and_in_json(flow_file, tmp_path):
    res = runner.invoke(app, ["thruster", "fit", str(flow_file), *FQ, "--diameter", "10",
                              "--out-model", str(tmp_path / "fq.yaml")])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout[res.stdout.index("{"):])
    assert any(SAID in w for w in doc["warnings"]), doc["warnings"]
    assert SAID in " ".join(res.stderr.split())


# ------------------------------------------------------------------ 2. coverage of a narrow map
def _squeezed(lo_hi):
    z = (0.0, 0.0)
    return FourQuadrantMap("m", 10.0, (0.3, 0.1), (0.0, -0.5), z, z, beta_ranges_deg=lo_hi)


def test_a_narrow_fitted_interval_does_not_cover_water_from_behind():
    """D = 10 m squeezes the bench's 0–14° into 0–0.109°: a fixed 1° tolerance counted β = −0.5°
    (water from behind, never on the bench) and −179.5° as covered."""
    fq = _squeezed(((0.0, 0.109), (179.891, 180.0)))
    assert fq.covers(0.0) and fq.covers(0.05) and fq.covers(180.0) and fq.covers(-180.0)
    assert not fq.covers(-0.5) and not fq.covers(-179.5) and not fq.covers(0.5)
    assert "[0.00°, 0.11°]" in fq.ranges_text()


def test_usual_intervals_keep_the_one_degree_tolerance():
    fq = _squeezed(((0.0, 14.07), (165.93, 180.0)))
    assert fq.covers(-0.9) and fq.covers(14.9) and fq.covers(165.0) and fq.covers(-179.5)
    assert not fq.covers(-1.5) and not fq.covers(16.0)
    assert fq.ranges_text() == "[0°, 14°] and [166°, 180°]"
    assert _squeezed(((0.0, 14.0),)).covers(-2.0, tol=3.0)  # an explicit tolerance still holds
    assert _squeezed(((180.0, 180.0),)).covers(-180.0)  # a point interval, through rounding


def test_the_fit_with_the_right_diameter_covers_what_it_did(flow_file):
    fq = _fq(flow_file, 0.076).chain.inflow
    from uuvid.thruster.inflow import map_from_section

    m = map_from_section(fq)
    for b in (-0.99, 0.0, 7.0, 14.9, 165.1, 180.0, -179.0):
        assert m.covers(b) == m.covers(b, tol=1.0) is True
    for b in (-8.0, -172.0, 30.0, 90.0):
        assert m.covers(b) == m.covers(b, tol=1.0) is False


@pytest.mark.slow
def test_envelope_says_extrapolated_whatever_the_diameter(flow_file, tmp_path):
    import sys
    from pathlib import Path

    import yaml

    from uuvid.thruster.modelfile import save_chain

    sys.path.insert(0, str(Path(__file__).parent))
    from test_vehicle_inflow import _preset_raw

    for d in (0.076, 10.0):
        save_chain(_fq(flow_file, d).chain, tmp_path / f"fq_{d:g}.yaml")
        raw = _preset_raw("bluerov2")
        raw["inflow"] = "four-quadrant"
        for t in raw["thrusters"]:
            t["propeller"] = f"fq_{d:g}.yaml"
        (tmp_path / f"v_{d:g}.yaml").write_text(yaml.safe_dump(raw))
        res = runner.invoke(app, ["vehicle", "envelope", str(tmp_path / f"v_{d:g}.yaml"),
                                  "--no-confirm", "--json"])
        assert res.exit_code == 0, res.output
        doc = json.loads(res.stdout)
        assert any(w.startswith("extrapolated: the fitted propeller map") for w in doc["warnings"]), \
            (d, doc["warnings"])


# ------------------------------------------------------------------ 3. a still-water bench
def test_a_still_water_bench_four_quadrant_refuses_and_points_to_quadratic(flow_file, tmp_path):
    """quadratic fits the bollard map with a warning (its K_T needs no water speed); the
    four-quadrant map is C_T* over β = atan2(u_a, 0.7πnD), and still water gives β = 0°/180° only:
    no map to fit, so it refuses — and says why and what fits instead."""
    df = pd.read_csv(flow_file).assign(flow_speed=0.0)
    df.to_csv(tmp_path / "still.csv", index=False)
    opts = ReadOptions(thrust_col="thrust", speed_col="speed")
    with pytest.raises(BenchDataError) as e:
        run_fit([tmp_path / "still.csv"], "four-quadrant", opts, diameter=0.076)
    msg = " ".join(str(e.value).split())
    assert "flow_speed is 0 in every row" in msg and "--model quadratic" in msg and "β" in msg
    q = run_fit([tmp_path / "still.csv"], "quadratic", opts)
    assert any("not identifiable from bollard data" in w for w in q.warnings)
    assert q.chain.inflow is None or q.chain.inflow.get("form") != "four-quadrant"
    with pytest.raises(BenchDataError, match="--model quadratic"):  # the function says it too
        fit_four_quadrant(read_bench(tmp_path / "still.csv", command_col="command", thrust_col="thrust",
                                     speed_col="speed"), 0.076)
