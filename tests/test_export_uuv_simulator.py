"""Export to UUV Simulator's thruster plugin (dynamics + conversion) and back."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.io.export import ExportError, from_uuv_simulator, to_uuv_simulator
from uuvid.thruster.blocks import (
    BessaDynamics,
    DeadZoneMap,
    FirstOrder,
    QuadraticMap,
    TableMap,
    TunnelThruster,
    Yoerger,
    ZeroOrder,
)
from uuvid.thruster.chain import ThrusterChain
from uuvid.thruster.presets import auv2_rig_chain, laidani_chain

runner = CliRunner()


@pytest.mark.parametrize("dyn", [ZeroOrder(), FirstOrder(0.05), Yoerger(0.5, 0.7),
                                 BessaDynamics(0.05, 0.1, 0.02, 0.1, 1.0)])
@pytest.mark.parametrize("conv", [QuadraticMap.basic(0.0049), DeadZoneMap(0.001, 0.002, -50, 25),
                                  TableMap((-5, 0, 2, 5), (-100, -10, 20, 120))])
def test_uuv_native_chains_round_trip_exactly(dyn, conv):
    chain = ThrusterChain((dyn, conv), input_kind="command")
    xml = to_uuv_simulator(chain)
    assert "exact" in xml.splitlines()[0]
    assert from_uuv_simulator(xml).blocks == chain.blocks


def test_uuv_element_names():
    xml = to_uuv_simulator(ThrusterChain((Yoerger(0.5, 0.7), DeadZoneMap(0.001, 0.002, -50, 25)),
                                         input_kind="command"))
    for tag in ("<type>Yoerger</type>", "<alpha>0.5</alpha>", "<beta>0.7</beta>", "<type>Bessa</type>",
                "<rotorConstantL>", "<rotorConstantR>", "<deltaL>", "<deltaR>",
                'filename="libuuv_thruster_ros_plugin.so"'):
        assert tag in xml


def test_laidani_chain_exports_with_exact_steady_map():
    chain = laidani_chain()
    xml = to_uuv_simulator(chain, table_points=251)
    assert "approximate" in xml.splitlines()[0]
    back = from_uuv_simulator(xml)  # the plugin takes command − 1500; read back, the command
    pwm = np.linspace(1000, 2000, 401)
    assert np.max(np.abs(back.steady_thrust(pwm) - chain.steady_thrust(pwm))) < 0.1
    # the plugin's own view (no header): the table on command − 1500
    bare = from_uuv_simulator(xml[xml.index("<plugin"):])
    assert np.max(np.abs(bare.steady_thrust(pwm - 1500) - chain.steady_thrust(pwm))) < 0.1
    # dynamics close: a slow sine through both
    r1 = chain.simulate(lambda t: 1500 + 400 * np.sin(t), 4.0)
    r2 = back.simulate(lambda t: 1500 + 400 * np.sin(t), 4.0)
    assert np.max(np.abs(r1["thrust"] - r2["thrust"])) < 0.3


def test_chain_with_two_dynamic_blocks_is_refused():
    with pytest.raises(ExportError, match="dynamic blocks"):
        to_uuv_simulator(auv2_rig_chain())


def test_tunnel_thruster_has_no_uuv_dynamics():
    chain = ThrusterChain((auv2_rig_chain().blocks[0],), input_kind="voltage")
    assert isinstance(chain.blocks[0], TunnelThruster)
    with pytest.raises(ExportError, match="no UUV Simulator dynamics"):
        to_uuv_simulator(chain)


@pytest.mark.slow
def test_cli_export_and_predict(tmp_path):
    runner = CliRunner()
    out = tmp_path / "t.xml"
    res = runner.invoke(app, ["thruster", "export", "laidani-a2212", "--to", "uuv-simulator", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "<dynamics>" in out.read_text()
    res = runner.invoke(app, ["thruster", "predict", "laidani-a2212", "--pwm", "1100:1900:4", "--json"])
    assert res.exit_code == 0, res.output
    import json

    doc = json.loads(res.stdout)
    assert len(doc["pwm_us"]) == 201 and len(doc["thrust_N"]) == 201
    assert doc["thrust_N"][100] == 0.0  # 1500 µs: neutral
    res = runner.invoke(app, ["thruster", "predict", "laidani-a2212", "--pwm", "1900:1100:4"])
    assert res.exit_code == 2
    res = runner.invoke(app, ["thruster", "predict", "auv2-tunnel", "--pwm", "1500"])
    assert res.exit_code == 2 and "no command input" in res.output


def test_predict_warns_about_implausible_pwm():
    """A pulse width no servo output carries (a wrong unit) is warned, the ESC's saturation is not."""
    runner = CliRunner()
    res = runner.invoke(app, ["thruster", "predict", "t200", "--pwm", "1500,2500", "--json"])
    assert res.exit_code == 0, res.output
    assert any("check the unit" in w for w in json.loads(res.stdout)["warnings"])
    res = runner.invoke(app, ["thruster", "predict", "laidani-a2212", "--pwm", "1100:1900:100",
                              "--json"])
    assert not any("check the unit" in w for w in json.loads(res.stdout)["warnings"])


# ------------------------------------------------------------------ quadratic and polynomial fits
def test_asymmetric_quadratic_exports_exactly_as_bessa_with_zero_delta():
    chain = ThrusterChain((QuadraticMap(k_pos=3.7e-4, k_neg=2.9e-4),), input_kind="speed")
    xml = to_uuv_simulator(chain)
    head = xml.splitlines()[0]
    assert "exact" in head and "deltaL = deltaR = 0" in head and "the speed" in head
    back = from_uuv_simulator(xml)
    assert back.blocks[1] == DeadZoneMap(2.9e-4, 3.7e-4, 0.0, 0.0)
    w = np.linspace(-400, 400, 81)
    np.testing.assert_allclose(back.steady_thrust(w), chain.steady_thrust(w), rtol=1e-12, atol=0)


def test_first_order_motor_gain_folds_into_a_quadratic_conversion_exactly():
    from uuvid.thruster.blocks import FirstOrderMotor

    chain = ThrusterChain((FirstOrderMotor(gain=20.0, time_constant=0.1),
                           QuadraticMap(k_pos=3.7e-4, k_neg=2.9e-4)), input_kind="voltage")
    xml = to_uuv_simulator(chain)
    assert "exact" in xml.splitlines()[0] and "K_m²" in xml.splitlines()[0]
    back = from_uuv_simulator(xml)
    v = np.linspace(-16, 16, 33)
    np.testing.assert_allclose(back.steady_thrust(v), chain.steady_thrust(v), rtol=1e-12)
    r1 = chain.simulate(lambda t: 12 * np.sin(3 * t), 2.0)
    r2 = back.simulate(lambda t: 12 * np.sin(3 * t), 2.0)
    np.testing.assert_allclose(r2["thrust"], r1["thrust"], rtol=1e-9, atol=1e-9)


@pytest.mark.slow
def test_cli_exports_quadratic_and_polynomial_maps(tmp_path):
    from uuvid.thruster.blocks import PolynomialMap
    from uuvid.thruster.modelfile import save_chain

    runner = CliRunner()
    q = save_chain(ThrusterChain((QuadraticMap(k_pos=3.7e-4, k_neg=2.9e-4),), "speed", "q"),
                   tmp_path / "q.yaml")
    res = runner.invoke(app, ["thruster", "export", str(q), "--to", "uuv-simulator"])
    assert res.exit_code == 0, res.output
    assert "<type>Bessa</type>" in res.stdout
    poly = ThrusterChain((PolynomialMap(forward=(1e-7, 3e-4, 0.0, 0.0),
                                        reverse=(2e-4, 0.0, 0.0)),), "speed", "p")
    p = save_chain(poly, tmp_path / "p.yaml")
    res = runner.invoke(app, ["thruster", "export", str(p), "--to", "uuv-simulator"])
    assert res.exit_code == 2 and "--command-range LOW:HIGH" in res.output
    res = runner.invoke(app, ["thruster", "export", str(p), "--to", "uuv-simulator",
                              "--command-range", "-300:300", "--table-points", "61"])
    assert res.exit_code == 0, res.output
    back = from_uuv_simulator(res.stdout)
    x = np.array(back.blocks[1].input_values)
    assert x[0] == -300 and x[-1] == 300 and x.size == 61
    np.testing.assert_allclose(back.blocks[1].output_values, poly.steady_thrust(x), rtol=1e-9)
    res = runner.invoke(app, ["thruster", "export", str(p), "--to", "uuv-simulator",
                              "--command-range", "300:-300"])
    assert res.exit_code == 2 and "LOW < HIGH" in res.output


@pytest.mark.realdata
def test_t200_quadratic_fit_exports_from_the_cli(shared_data, tmp_path):
    runner = CliRunner()
    sheet = shared_data / "t200-bluerobotics-2019" / "T200_16V.csv"
    model = tmp_path / "q.yaml"
    res = runner.invoke(app, ["thruster", "fit", str(sheet), "--format", "t200", "--model",
                              "quadratic", "--out-model", str(model)])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["thruster", "export", str(model), "--to", "uuv-simulator"])
    assert res.exit_code == 0, res.output
    back = from_uuv_simulator(res.stdout)
    from uuvid.thruster.modelfile import load_chain

    w = np.linspace(-380, 380, 39)
    np.testing.assert_allclose(back.steady_thrust(w), load_chain(model).steady_thrust(w),
                               rtol=1e-12)


def test_a_driver_offset_becomes_the_plugin_commands_zero():
    """A dynamic model fitted on PWM (driver with offset 1500 µs → first-order motor → map)
    was exported with the raw µs as the plugin command: the plugin's state starts at 0, i.e.
    full reverse, so a vehicle at neutral pushed −5 N for 0.1 s.  The table's input is now
    command − 1500 (its zero the rest command), as for an ESC's neutral."""
    from uuvid.thruster.blocks import Driver, FirstOrderMotor

    chain = ThrusterChain((Driver(deadband_fwd=0.06, offset=1500.0),
                           FirstOrderMotor(gain=0.4, time_constant=0.05),
                           QuadraticMap(k_pos=3.6e-4, k_neg=3.6e-4)), input_kind="command")
    xml = to_uuv_simulator(chain, command_range=(1200.0, 1800.0))
    assert "plugin command = command − 1500" in xml.splitlines()[0]
    back = from_uuv_simulator(xml)
    table = next(b for b in back.blocks if isinstance(b, TableMap))
    x, y = np.array(table.input_values), np.array(table.output_values)
    assert x[0] == pytest.approx(-300.0) and x[-1] == pytest.approx(300.0)
    assert np.interp(0.0, x, y) == pytest.approx(0.0, abs=1e-9)  # at rest: no thrust
    assert np.interp(250.0, x, y) == pytest.approx(float(chain.steady_thrust(np.array([1750.0]))[0]),
                                                   rel=1e-3)
    # read back, the chain takes the command again (a driver takes the 1500 off)
    assert isinstance(back.blocks[0], Driver) and back.blocks[0].offset == 1500.0
    np.testing.assert_allclose(back.steady_thrust(np.array([1500.0, 1750.0])),
                               chain.steady_thrust(np.array([1500.0, 1750.0])), rtol=1e-3, atol=1e-9)


def test_an_inflow_section_left_out_of_the_export_is_said(tmp_path):
    """UUV Simulator's plugin has no water speed: a model fitted in a flow was exported as
    "exact" with its inflow coefficients dropped silently."""
    import dataclasses

    chain = dataclasses.replace(ThrusterChain((QuadraticMap.basic(3.6e-4),), input_kind="speed"),
                                inflow={"form": "linear", "parameters": {"k_a": {"estimate": 0.03}}})
    head = to_uuv_simulator(chain).splitlines()[0]
    assert "exact at bollard" in head and "inflow section" in head and "not exported" in head
    assert "inflow" not in to_uuv_simulator(ThrusterChain((QuadraticMap.basic(3.6e-4),),
                                                          input_kind="speed")).splitlines()[0]


def test_the_cli_reads_back_its_own_uuv_simulator_export(tmp_path):
    """``thruster show x.xml`` said "expected a mapping at the top level, got str": the export
    could not be read back where a model is expected; a file that is no plugin names itself."""
    xml = tmp_path / "lai.xml"
    assert runner.invoke(app, ["thruster", "export", "laidani-a2212", "--to", "uuv-simulator",
                               "--out-file", str(xml)]).exit_code == 0
    res = runner.invoke(app, ["thruster", "show", str(xml)])
    assert res.exit_code == 0 and "lai" in res.output, res.output
    bad = tmp_path / "bad.xml"
    bad.write_text("<plugin><dyn")
    res = runner.invoke(app, ["thruster", "show", str(bad)])
    assert res.exit_code == 2 and "not a UUV Simulator thruster plugin" in " ".join(res.output.split())


@pytest.mark.parametrize("suffix", [".xacro", ".urdf", ".sdf", ".XML"])
def test_a_plugin_export_saved_as_xacro_urdf_or_sdf_reads_back(tmp_path, suffix):
    """``thruster export … --to uuv-simulator --out-file a2212.xacro`` then ``thruster predict
    a2212.xacro`` said "not valid YAML": only ``.xml`` was read as the plugin's XML, yet UUV
    Simulator's thruster snippets live in .xacro (and .urdf/.sdf) files."""
    f = tmp_path / f"a2212{suffix}"
    res = runner.invoke(app, ["thruster", "export", "laidani-a2212", "--to", "uuv-simulator",
                              "--out-file", str(f)])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["thruster", "predict", str(f), "--pwm", "1100:1900:200", "--json"])
    assert res.exit_code == 0, res.output
    got = json.loads(res.stdout)["thrust_N"]
    want = laidani_chain().steady_thrust(np.arange(1100.0, 1901.0, 200.0))
    np.testing.assert_allclose(got, want, atol=0.1)
    bad = tmp_path / f"bad{suffix}"
    bad.write_text("<robot><dyn")
    res = runner.invoke(app, ["thruster", "show", str(bad)])
    assert res.exit_code == 2 and "not a UUV Simulator thruster plugin" in " ".join(res.output.split())


def test_a_plugin_inside_a_xacro_macro_reads_back():
    """A plugin snippet pasted into a xacro macro (text after ``</plugin>``) reads as the plugin."""
    xml = to_uuv_simulator(laidani_chain())
    wrapped = ('<robot xmlns:xacro="http://www.ros.org/wiki/xacro">\n<xacro:macro name="t">\n'
               + xml[xml.index("<plugin"):] + "</xacro:macro>\n</robot>\n")
    back = from_uuv_simulator(wrapped)
    assert back.steady_thrust(np.array([400.0])) == pytest.approx(
        from_uuv_simulator(xml[xml.index("<plugin"):]).steady_thrust(np.array([400.0])))


@pytest.mark.parametrize("name", ["t200", "laidani-a2212"])
def test_the_table_holds_the_models_corners_exactly(name):
    """The T200 table spanned [900, 2100] µs at 12 µs spacing: its saturation corners at 1100 and
    1900 µs fell between points, and the plugin read back −39.95/51.29 N for the model's
    −40.28/51.74 N.  The ESC's corners (saturation, dead-zone edges, where the voltage reaches the
    supply) are now points of the table, and the table keeps the points asked for."""
    from uuvid.thruster.blocks import ESC
    from uuvid.thruster.presets import preset_chain

    chain = preset_chain(name)
    esc = chain.blocks[0]
    assert isinstance(esc, ESC)
    corners = np.array([esc.saturation_low, esc.deadzone_low, esc.deadzone_high,
                        esc.saturation_high])
    for n in (101, 37):
        xml = to_uuv_simulator(chain, table_points=n)
        back = from_uuv_simulator(xml)
        np.testing.assert_allclose(back.steady_thrust(corners), chain.steady_thrust(corners),
                                   rtol=1e-9, atol=1e-9)
        table = next(b for b in back.blocks if isinstance(b, TableMap))
        assert len(table.input_values) == n
        assert f"tabulated at {n} points" in xml.splitlines()[0]
    if name == "t200":
        back = from_uuv_simulator(to_uuv_simulator(chain))
        assert back.steady_thrust(np.array([1100.0, 1900.0])) == pytest.approx([-40.28, 51.74],
                                                                                abs=0.01)


def test_export_options_with_no_effect_are_refused_or_said(tmp_path):
    """``--command-range`` and ``--table-points`` were ignored silently with ``--to yaml/toml``
    and when the conversion is exact (Basic/Bessa): the first is refused naming the options, the
    second is said in a note."""
    from uuvid.thruster.modelfile import save_chain

    for to in ("yaml", "toml"):
        for opt in (["--table-points", "51"], ["--command-range", "1200:1800"],
                    ["--thruster-id", "2"]):
            res = runner.invoke(app, ["thruster", "export", "t200", "--to", to, *opt])
            text = " ".join(res.output.split())
            assert res.exit_code == 2, (to, opt, res.output)
            assert opt[0] in text and "uuv-simulator" in text, text
    q = save_chain(ThrusterChain((FirstOrder(0.05), QuadraticMap.basic(3.6e-4)), "command", "q"),
                   tmp_path / "q.yaml")
    res = runner.invoke(app, ["thruster", "export", str(q), "--to", "uuv-simulator",
                              "--table-points", "51", "--command-range", "-300:300"])
    assert res.exit_code == 0, res.output
    text = " ".join(res.stderr.split())
    assert "--table-points" in text and "--command-range" in text and "no effect" in text, text
    assert "<type>Basic</type>" in res.stdout
    res = runner.invoke(app, ["thruster", "export", str(q), "--to", "uuv-simulator"])
    assert res.exit_code == 0 and "no effect" not in res.output
