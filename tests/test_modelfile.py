"""Thruster model files (YAML/TOML): round trips, error key paths, UUV Simulator names, presets."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uuvid.simulate.signals import Sine, Step
from uuvid.thruster import presets
from uuvid.thruster.blocks import (
    ESC,
    BessaDynamics,
    DCMotor,
    DeadZoneMap,
    FirstOrder,
    FirstOrderMotor,
    LoadCell,
    PolynomialMap,
    QuadraticMap,
    TableMap,
    Yoerger,
    ZeroOrder,
)
from uuvid.thruster.chain import ThrusterChain
from uuvid.thruster.modelfile import (
    ModelFileError,
    chain_from_dict,
    chain_to_dict,
    load_chain,
    save_chain,
)

PRESET_RUNS = {
    "auv2-tunnel": (presets.auv2_rig_chain, Step(24.0), 0.5),
    "laidani-a2212": (presets.laidani_chain, Sine(offset=1500.0, amplitude=400.0, period=2.0), 1.0),
}


def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def assert_same_simulation(a: ThrusterChain, b: ThrusterChain, signal, t_end):
    ra, rb = a.simulate(signal, t_end), b.simulate(signal, t_end)
    assert ra.names == rb.names
    for name in ra.names:
        np.testing.assert_array_equal(ra[name], rb[name], err_msg=name)


# ---------------------------------------------------------------------------------- round trips
@pytest.mark.parametrize("suffix", [".yaml", ".toml"])
@pytest.mark.parametrize("preset", sorted(PRESET_RUNS))
def test_preset_round_trip_gives_equal_chain_and_identical_simulation(tmp_path, preset, suffix):
    make, signal, t_end = PRESET_RUNS[preset]
    chain = make()
    path = save_chain(chain, tmp_path / f"{preset}{suffix}")
    assert path.exists()
    back = load_chain(path)
    assert back == chain
    assert back.signal_kinds == chain.signal_kinds
    np.testing.assert_array_equal(back.compile().params, chain.compile().params)
    assert_same_simulation(chain, back, signal, t_end)


def test_toml_output_is_valid_toml_with_a_nested_motor_table(tmp_path):
    import tomllib

    path = save_chain(presets.auv2_rig_chain(), tmp_path / "rig.toml")
    data = tomllib.loads(path.read_text())
    assert data["input"] == "voltage"
    assert data["blocks"][0]["type"] == "tunnel_thruster"
    assert data["blocks"][0]["motor"]["resistance"] == 4.06
    assert data["blocks"][1]["type"] == "load_cell"


ALL_BLOCK_CHAINS = [
    ThrusterChain((ESC(a_fwd=0.5, b_fwd=-0.25, a_rev=0.75, b_rev=0.1, neutral=0.0,
                       deadzone_low=-0.5, deadzone_high=0.5, supply_voltage=24.0),
                   DCMotor(torque_coefficient=2e-6, torque_coefficient_rev=3e-6, gear_ratio=2.5,
                           coulomb_torque=0.01, inductance=1e-3, motor_viscous=1e-6),
                   QuadraticMap(k_pos=1e-4, k_neg=2e-4, torque_pos=1e-6, torque_neg=2e-6)),
                  input_kind="command", name="esc-dc-quad"),
    ThrusterChain((FirstOrder(0.1), TableMap([-5.0, 0.0, 2.0, 5.0], [-100.0, -10.0, 20.0, 120.0]),
                   LoadCell(natural_frequency=40.0, damping_ratio=0.3)), input_kind="command"),
    ThrusterChain((Yoerger(2.0, 3.0), DeadZoneMap(0.001, 0.002, -50.0, 25.0)),
                  input_kind="command"),
    ThrusterChain((BessaDynamics(jmsp=0.05, kv1=0.2, kv2=0.002, kt=0.5, rm=2.0),
                   PolynomialMap(forward=(1.0, 0.0), reverse=(2.0,))), input_kind="command"),
    ThrusterChain((ZeroOrder(), QuadraticMap.basic(0.0049)), input_kind="command"),
    ThrusterChain((DCMotor(torque_coefficient=2e-6),), input_kind="voltage"),
    ThrusterChain((FirstOrderMotor(), PolynomialMap(presets.LAIDANI_POLY_FORWARD,
                                                    presets.LAIDANI_POLY_REVERSE)),
                  input_kind="voltage"),
    ThrusterChain((presets.auv2_tunnel_thruster(coulomb=True, inductance=True),),
                  input_kind="voltage", name="tunnel-only"),
]


@pytest.mark.parametrize("suffix", [".yaml", ".yml", ".toml"])
@pytest.mark.parametrize("chain", ALL_BLOCK_CHAINS,
                         ids=lambda c: "-".join(b.TYPE for b in c.blocks))
def test_every_block_type_round_trips(tmp_path, chain, suffix):
    back = load_chain(save_chain(chain, tmp_path / f"model{suffix}"))
    assert back == chain


def test_infinite_esc_saturation_round_trips_as_absent(tmp_path):
    chain = ThrusterChain((ESC(supply_voltage=12.0),), input_kind="command")
    for suffix in (".yaml", ".toml"):
        path = save_chain(chain, tmp_path / f"esc{suffix}")
        assert "inf" not in path.read_text().lower()
        back = load_chain(path)
        assert back == chain
        assert math.isinf(back.blocks[0].saturation_high)


# ---------------------------------------------------------------------------------- errors
LAIDANI_YAML_HEAD = """\
name: test
input: command
blocks:
  - type: esc
    a_fwd: 0.0436
    b_fwd: -66.5
    a_rev: 0.0436
    b_rev: -64.4
    neutral: 1500
    deadzone_low: 1475
    deadzone_high: 1525
    supply_voltage: 12
"""


def test_unknown_key_names_file_and_key_path(tmp_path):
    p = write(tmp_path, "m.yaml", LAIDANI_YAML_HEAD + """\
  - type: first_order_motor
    gain: 131.3016
    time_constant: 0.01021
    tau: 0.01
""")
    with pytest.raises(ModelFileError) as exc:
        load_chain(p)
    msg = str(exc.value)
    assert str(p) in msg
    assert "blocks[1].tau" in msg and "unknown key" in msg


def test_unknown_top_level_key(tmp_path):
    p = write(tmp_path, "m.yaml", "nme: x\nblocks:\n  - type: zero_order\n")
    with pytest.raises(ModelFileError, match=r"nme: unknown key"):
        load_chain(p)


def test_missing_parameter_names_file_and_key_path(tmp_path):
    p = write(tmp_path, "m.yaml", LAIDANI_YAML_HEAD + """\
  - type: first_order_motor
    gain: 131.3016
""")
    with pytest.raises(ModelFileError) as exc:
        load_chain(p)
    msg = str(exc.value)
    assert str(p) in msg
    assert "blocks[1].time_constant" in msg and "missing parameter" in msg


def rig_blocks() -> list[dict]:
    """The McLean rig's blocks as model-file data (nested motor without a type)."""
    return chain_to_dict(presets.auv2_rig_chain())["blocks"]


def test_missing_nested_motor_parameter_names_the_nested_path():
    blocks = rig_blocks()
    del blocks[0]["motor"]["resistance"]
    data = {"name": "x", "input": "voltage", "blocks": blocks}
    with pytest.raises(ModelFileError, match=r"rig\.yaml: blocks\[0\]\.motor\.resistance: "
                                             r"missing parameter"):
        chain_from_dict(data, where="rig.yaml")


def test_unknown_block_type_names_file_and_key_path(tmp_path):
    p = write(tmp_path, "m.yaml", LAIDANI_YAML_HEAD + "  - type: Warp\n")
    with pytest.raises(ModelFileError) as exc:
        load_chain(p)
    msg = str(exc.value)
    assert str(p) in msg and "blocks[1].type" in msg and "'Warp'" in msg


def test_non_numeric_value_names_the_key_path(tmp_path):
    p = write(tmp_path, "m.toml", '[[blocks]]\ntype = "FirstOrder"\ntime_constant = "fast"\n')
    with pytest.raises(ModelFileError) as exc:
        load_chain(p)
    assert str(p) in str(exc.value) and "blocks[0].time_constant" in str(exc.value)


def test_physically_invalid_value_names_file_block_and_parameter(tmp_path):
    p = write(tmp_path, "m.yaml", LAIDANI_YAML_HEAD + """\
  - type: first_order_motor
    gain: 131.3016
    time_constant: -0.01
""")
    with pytest.raises(ModelFileError) as exc:
        load_chain(p)
    msg = str(exc.value)
    assert str(p) in msg and "blocks[1]" in msg and "time_constant" in msg
    assert isinstance(exc.value, ValueError)


def test_physically_invalid_value_gives_the_dotted_key_path(tmp_path):
    p = write(tmp_path, "m.yaml", LAIDANI_YAML_HEAD + """\
  - type: first_order_motor
    gain: 131.3016
    time_constant: -0.01
""")
    with pytest.raises(ModelFileError, match=r"m\.yaml: blocks\[1\]\.time_constant: "):
        load_chain(p)


def test_physically_invalid_nested_motor_value_gives_the_nested_key_path():
    blocks = rig_blocks()
    blocks[0]["motor"]["resistance"] = 0.0
    with pytest.raises(ModelFileError, match=r"rig\.yaml: blocks\[0\]\.motor\.resistance: "):
        chain_from_dict({"input": "voltage", "blocks": blocks}, where="rig.yaml")


@pytest.mark.parametrize(("block", "param"), [
    ("type: LinearInterp\n    input_values: [0, 2, 1]\n    output_values: [0, 1, 2]",
     "input_values"),
    ("type: LinearInterp\n    input_values: [0, 1, 2]\n    output_values: [0, 1]", "output_values"),
    (("type: deadzone\n    rotor_constant_l: 1\n    rotor_constant_r: 1\n    delta_l: 1\n"
      "    delta_r: 0"), "delta_l"),
    ("type: FirstOrder\n    time_constant: 0", "time_constant"),
])
def test_invalid_values_raise_model_file_error(tmp_path, block, param):
    p = write(tmp_path, "m.yaml", f"input: speed\nblocks:\n  - {block}\n")
    with pytest.raises(ModelFileError) as exc:
        load_chain(p)
    assert str(p) in str(exc.value) and "blocks[0]" in str(exc.value)
    assert param in str(exc.value)


def test_efficiency_above_one_in_a_tunnel_thruster():
    blocks = rig_blocks()
    blocks[0]["propeller_efficiency"] = 1.3
    with pytest.raises(ModelFileError, match=r"rig\.yaml: blocks\[0\]\.propeller_efficiency: "):
        chain_from_dict({"input": "voltage", "blocks": blocks}, where="rig.yaml")


def test_wiring_error_in_a_model_file_names_the_block(tmp_path):
    p = write(tmp_path, "m.yaml", "input: command\nblocks:\n  - type: load_cell\n"
                                  "    natural_frequency: 44\n    damping_ratio: 0.16\n")
    with pytest.raises(ModelFileError) as exc:
        load_chain(p)
    assert str(p) in str(exc.value) and "block 0" in str(exc.value)


def test_invalid_yaml_is_a_clear_model_file_error(tmp_path):
    p = write(tmp_path, "bad.yaml", "blocks: [\n  - type: FirstOrder\n")
    with pytest.raises(ModelFileError) as exc:
        load_chain(p)
    msg = str(exc.value)
    assert msg.startswith(str(p)) and "not valid YAML" in msg
    assert exc.value.__cause__ is None  # no yaml traceback chained in


def test_invalid_toml_is_a_clear_model_file_error(tmp_path):
    p = write(tmp_path, "bad.toml", "[[blocks]\ntype = 'FirstOrder'\n")
    with pytest.raises(ModelFileError, match="not valid TOML"):
        load_chain(p)


@pytest.mark.parametrize("text", ["", "- 1\n- 2\n", "just a string\n"])
def test_non_mapping_top_level(tmp_path, text):
    p = write(tmp_path, "m.yaml", text)
    with pytest.raises(ModelFileError, match="expected a mapping at the top level"):
        load_chain(p)


def test_missing_file(tmp_path):
    with pytest.raises(ModelFileError, match="cannot read model file"):
        load_chain(tmp_path / "nope.yaml")


# ---------------------------------------------------------------------------------- UUV names
def test_uuv_simulator_names_are_accepted_as_type(tmp_path):
    p = write(tmp_path, "uuv.yaml", """\
input: command
blocks:
  - type: FirstOrder
    time_constant: 0.5
  - type: LinearInterp
    input_values: [-5, 0, 2, 5]
    output_values: [-100, -10, 20, 120]
""")
    chain = load_chain(p)
    assert chain.blocks == (FirstOrder(0.5), TableMap([-5, 0, 2, 5], [-100, -10, 20, 120]))
    for text, expected in [
        ("type: Basic\n    k_pos: 0.0049\n    k_neg: 0.0049", QuadraticMap.basic(0.0049)),
        ("type: ZeroOrder", ZeroOrder()),
        ("type: Yoerger\n    alpha: 2\n    beta: 3", Yoerger(2.0, 3.0)),
        ("type: Bessa\n    jmsp: 0.05\n    kv1: 0.2\n    kv2: 0.002\n    kt: 0.5\n    rm: 2",
         BessaDynamics(jmsp=0.05, kv1=0.2, kv2=0.002, kt=0.5, rm=2.0)),
    ]:
        p = write(tmp_path, "one.yaml", f"input: command\nblocks:\n  - {text}\n")
        assert load_chain(p).blocks == (expected,)


def test_uuv_simulator_first_order_from_file_reaches_1_minus_1_over_e(tmp_path):
    p = write(tmp_path, "fo.toml", 'input = "command"\n[[blocks]]\ntype = "FirstOrder"\n'
                                   "time_constant = 0.5\n")
    r = load_chain(p).simulate(Step(1.0), 0.5)
    assert r["prop_speed"][-1] == pytest.approx(1.0 - math.exp(-1.0), abs=1e-9)


def test_uuv_simulator_basic_with_one_rotor_constant_is_symmetric(tmp_path):
    # UUV Simulator's Basic has one rotorConstant; k_neg left out must mean "same as k_pos"
    # (it used to default to 1.0: -2500 N instead of -12.25 N at x = -50)
    p = write(tmp_path, "basic.yaml", "input: speed\nblocks:\n  - type: Basic\n    k_pos: 0.0049\n")
    chain = load_chain(p)
    assert chain.blocks == (QuadraticMap.basic(0.0049),)
    np.testing.assert_allclose(chain.steady_thrust([50.0, -50.0]), [12.25, -12.25], rtol=1e-12)


# ---------------------------------------------------------------------------------- presets
def test_preset_laidani_loads(tmp_path):
    p = write(tmp_path, "p.yaml", "preset: laidani-a2212\n")
    assert load_chain(p) == presets.laidani_chain()
    p = write(tmp_path, "p.toml", 'preset = "auv2-tunnel"\n')
    assert load_chain(p) == presets.auv2_rig_chain()


def test_unknown_preset_and_extra_keys_with_preset(tmp_path):
    p = write(tmp_path, "p.yaml", "preset: nope\n")
    with pytest.raises(ModelFileError, match=r"preset: .*'nope'.*laidani-a2212"):
        load_chain(p)
    p = write(tmp_path, "p.yaml", "preset: laidani-a2212\nblocks: []\n")
    with pytest.raises(ModelFileError, match="no other keys"):
        load_chain(p)


def test_a_vehicle_or_scenario_file_given_as_a_model_says_it_is_not_one(tmp_path):
    """A vehicle file named as a thruster model listed 'blocks: missing parameter', then
    'rigid_body: unknown key', … for every key, and never said what was wrong."""
    from uuvid.thruster.modelfile import NotAModelFileError
    from uuvid.vehicle.definition import preset_path

    with pytest.raises(NotAModelFileError) as e:
        load_chain(preset_path("bluerov2"))
    said = str(e.value)
    assert said.startswith(f"{preset_path('bluerov2')}: not a thruster model file: it looks like "
                           "a vehicle file (it has rigid_body, hydrodynamics, thrusters)")
    assert "a thruster model file has blocks" in said and "preset: NAME" in said
    assert "unknown key" not in said and "\n" not in said
    sc = tmp_path / "sc.yaml"
    sc.write_text("vehicle: bluerov2\nmission: {kind: square, side: 4}\n")
    with pytest.raises(NotAModelFileError, match=r"sc\.yaml: not a thruster model file: it looks "
                                                 r"like a scenario file \(it has mission, vehicle\)"):
        load_chain(sc)
    # a model file with a mistake stays a model file: its keys are named as before
    bad = tmp_path / "m.yaml"
    bad.write_text("name: m\nblock: []\n")
    with pytest.raises(ModelFileError) as e:
        load_chain(bad)
    assert not isinstance(e.value, NotAModelFileError)
    assert "blocks: missing parameter" in str(e.value) and "block: unknown key" in str(e.value)
