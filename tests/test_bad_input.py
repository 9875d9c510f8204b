"""Bad input ends in a clear error, never a traceback, a silent NaN or an unbounded run (issue 18).

Each test feeds one class of bad input and fails on an uncaught exception (a traceback), on a
non-finite result passed off as valid, or when the input would run past a size/time budget
instead of being refused before anything is allocated."""

import math

import numpy as np
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app

runner = CliRunner()


def clean_error(res, *needles, code=(1, 2)):
    """A CLI run that failed as a user error: exit status 1/2, no traceback, message named."""
    assert res.exit_code in code, (res.exit_code, res.output, res.exception)
    assert isinstance(res.exception, SystemExit), repr(res.exception)
    assert "Traceback" not in res.output
    for n in needles:
        assert n in res.output, (n, res.output)


# ------------------------------------------------------------------------- result tables
def test_parameter_tables_show_a_missing_sigma_as_a_dash():
    from uuvid.cli.log_options import params_table
    from uuvid.identify.procedures import _params_text

    params = {"k": {"estimate": 1.5, "sigma": None, "unit": "N·s/m", "percentile_error": None,
                    "significant": False},
              "k_q": {"estimate": 2.0, "sigma": math.nan, "unit": "", "percentile_error": math.inf,
                      "significant": True}}
    text = _params_text("drag", params)
    assert "—" in text and "1.5" in text
    table = params_table("drag", params)
    assert table.row_count == 2


# ------------------------------------------------------------------------- model files
def test_non_utf8_model_file_names_file_and_line(tmp_path):
    from uuvid.io.modelfile import ModelFileError, load_chain

    p = tmp_path / "m.yaml"
    p.write_bytes(b"name: x\nblocks:\n  - type: first_order # \xff\xfe\n")
    with pytest.raises(ModelFileError, match=r"m\.yaml: line 3: not UTF-8"):
        load_chain(p)


@pytest.mark.parametrize("value", ["[quadratic]", "{a: 1}", "3"])
def test_block_type_that_is_not_a_name(tmp_path, value):
    from uuvid.io.modelfile import ModelFileError, load_chain

    p = tmp_path / "m.yaml"
    p.write_text(f"blocks:\n  - type: {value}\n")
    with pytest.raises(ModelFileError, match=r"blocks\[0\]\.type: expected a block type name"):
        load_chain(p)


BOMB = "".join(f"{a}: &{a} [{', '.join([f'*{p}'] * 9 if p else ['1'] * 9)}]\n"
               for p, a in zip([None, *"abcdefg"], "abcdefgh"))


def test_yaml_alias_bomb_is_refused_quickly(tmp_path):
    import time

    from uuvid.io.modelfile import ModelFileError
    from uuvid.simulate.scenario import load_scenario

    p = tmp_path / "s.yaml"
    p.write_text(BOMB + "current: [*h, *h, *h]\n")  # 9**8 * 3 ≈ 1.3e8 values once expanded
    t0 = time.perf_counter()
    with pytest.raises(ModelFileError, match="alias bomb"):
        load_scenario(p)
    assert time.perf_counter() - t0 < 5.0


def test_recursive_yaml_anchor_is_refused(tmp_path):
    from uuvid.io.modelfile import ModelFileError, read_model_text

    p = tmp_path / "v.yaml"
    p.write_text("x: &x [1, *x]\n")
    with pytest.raises(ModelFileError, match=r"x\[1\]: a YAML anchor refers to itself"):
        read_model_text(p)


def test_expanded_size_counts_shared_values_once_per_use():
    from uuvid.io.modelfile import check_expanded_size

    leaf = [1, 2, 3]  # 4 values
    assert check_expanded_size({"a": leaf, "b": [leaf, leaf]}, "w") == 1 + 4 + (1 + 8)


# ------------------------------------------------------------------------- vehicle parameters
@pytest.mark.parametrize("field, value", [("linear_damping", np.diag([1e308, 1, 1, 1, 1, 1])),
                                          ("mass", 1e308), ("added_mass", np.eye(6) * 1e200),
                                          ("inertia", [1e300, 1, 1])])
def test_absurd_vehicle_parameters_are_refused_by_name(field, value):
    from uuvid.thruster.blocks import ParameterError
    from uuvid.vehicle.model import VehicleParams

    kw = dict(mass=10.0, inertia=[0.1, 0.1, 0.1], r_g=np.zeros(3), r_b=[0, 0, -0.02],
              weight=98.0, buoyancy=99.0, added_mass=np.zeros(6), linear_damping=np.ones(6),
              quadratic_damping=np.ones(6))
    kw[field] = value
    with pytest.raises(ParameterError, match=f"VehicleParams.{field}") as e:
        VehicleParams(**kw)
    assert e.value.param == field


# ------------------------------------------------------------------------- scenarios
@pytest.mark.parametrize("text, needle", [
    ("duration: 0.001\n", "shorter than one step"),
    ("duration: 1.0e7\n", "shorten duration or raise dt"),
    ("mission: {kind: waypoints, waypoints: [[0, 0, 0, 0], [1.0e300, 0, 0, 0]]}\n",
     "duration not given"),
    ("mission: {kind: waypoints, waypoints: [[0, 0, 0, 0], [1.0e6, 0, 0, 0]]}\n",
     "shorten duration or raise dt"),
])
def test_scenario_durations_are_bounded_before_allocating(tmp_path, text, needle):
    p = tmp_path / "s.yaml"
    p.write_text(text)
    res = runner.invoke(app, ["simulate", str(p)])
    clean_error(res, "s.yaml", needle)


def test_step_count_budget():
    from uuvid.simulate.vehicle_sim import MAX_STEPS, step_count

    assert step_count(1.0, 0.01) == 100
    assert step_count(MAX_STEPS * 0.01, 0.01) == MAX_STEPS
    for T, dt in [(0.001, 0.01), (math.inf, 0.01), (math.nan, 0.01), (-1.0, 0.01),
                  (MAX_STEPS * 0.0101, 0.01), (1.0, 0.0), (1.0, math.nan)]:
        with pytest.raises(ValueError, match="t_end|dt"):
            step_count(T, dt)


def test_divergence_in_uuvid_simulate_is_an_error_not_a_traceback(tmp_path, monkeypatch):
    import uuvid.simulate.vehicle_sim as vs

    def diverge(setup):
        raise ValueError("the simulation diverged at t = 1.000 s; try a smaller dt or more substeps")

    monkeypatch.setattr(vs, "fly_mission", diverge)
    p = tmp_path / "s.yaml"
    p.write_text("duration: 1.0\n")
    clean_error(runner.invoke(app, ["simulate", str(p)]), "s.yaml", "diverged")


def test_controller_file_without_py_suffix(tmp_path):
    (tmp_path / "ctl.txt").write_text("def make_controller(vehicle, context):\n    return None\n")
    p = tmp_path / "s.yaml"
    p.write_text("controller: {kind: python, file: ctl.txt}\n")
    clean_error(runner.invoke(app, ["simulate", str(p)]), "ctl.txt", "rename it to ctl.py")


# ------------------------------------------------------------------------- sweeps
SWEEP = """name: t
target: {{kind: thruster_step, chain: auv2-tunnel, preset_kwargs: {kw}, signal: {{kind: step,
          amplitude: 24.0}}, t_end: 0.2}}
mode: grid
parameters:
  - {{name: voltage, values: [8, 16]}}
"""


@pytest.mark.parametrize("text, needle", [
    (SWEEP.format(kw="{foo: 1}"), "target.preset_kwargs: unknown keyword(s) 'foo'"),
    (SWEEP.format(kw="{tunnel_length: -1}"), "target.preset_kwargs.tunnel_length"),
    ("name: t\ntarget: {kind: thruster_steady, physical_model: {foo: 1}}\nmode: grid\n"
     "parameters:\n  - {name: R, values: [0.1, 0.2]}\n", "base.physical_model: unknown key(s) 'foo'"),
])
def test_sweep_with_unknown_or_bad_keywords(tmp_path, text, needle):
    p = tmp_path / "sw.yaml"
    p.write_text(text)
    res = runner.invoke(app, ["sweep", str(p), "--out", str(tmp_path / "out")])
    clean_error(res, "sw.yaml", needle)
