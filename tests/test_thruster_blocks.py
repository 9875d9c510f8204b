"""Thruster blocks and chains against the papers and UUV Simulator's own test vectors.

* UUV Simulator ``ThrusterConversionFcn_TEST.cc`` (Basic, Bessa, LinearInterp) and ``Dynamics.cc``
  (FirstOrder, Yoerger, Bessa).
* Laidani et al.: ESC eq. (1), A2212 first-order motor eq. (3), degree-5 polynomial (Table 2);
  digest §B "check worked out from the paper".
* Caccia et al. 2000: ``T = c_V V|V|``, ROMEO c_V = 1.02 / 1.09 N/V² (digest §C.1).
* McLean 1991: DC motor eqs. 2.1–2.5, tunnel thruster eqs. 2.12–2.16, Table I (digest §A).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from uuvid.core import units as U
from uuvid.simulate.signals import Step
from uuvid.thruster import presets
from uuvid.thruster.blocks import (
    ESC,
    BessaDynamics,
    DCMotor,
    DeadZoneMap,
    FirstOrder,
    FirstOrderMotor,
    LoadCell,
    ParameterError,
    PolynomialMap,
    QuadraticMap,
    TableMap,
    TunnelThruster,
    Yoerger,
    ZeroOrder,
)
from uuvid.thruster.chain import ThrusterChain


def static(block, input_kind="speed") -> ThrusterChain:
    return ThrusterChain((block,), input_kind=input_kind)


# =============================================================================================
# UUV Simulator conversion functions (ThrusterConversionFcn_TEST.cc)
# =============================================================================================
def test_uuv_simulator_basic_conversion_c0049():
    chain = static(QuadraticMap.basic(0.0049))
    out = chain.steady_thrust([0.0, 50.0, -50.0])
    assert out[0] == 0.0
    assert out[1] == pytest.approx(50.0 * 50.0 * 0.0049, rel=1e-15)  # 12.25 N
    assert out[2] == pytest.approx(-50.0 * 50.0 * 0.0049, rel=1e-15)
    assert out[1] == pytest.approx(12.25) and out[2] == pytest.approx(-12.25)
    # the vectorised Python law is the kernel's law
    np.testing.assert_allclose(QuadraticMap.basic(0.0049).thrust([0.0, 50.0, -50.0]), out,
                               rtol=1e-15)


BESSA_CL, BESSA_CR, BESSA_DL, BESSA_DR = 0.001, 0.002, -50.0, 25.0


def test_uuv_simulator_bessa_conversion_outside_dead_zone():
    chain = static(DeadZoneMap(BESSA_CL, BESSA_CR, BESSA_DL, BESSA_DR))
    plus, minus = chain.steady_thrust([50.0, -50.0])
    assert plus == pytest.approx(BESSA_CR * (50.0 * 50.0 - BESSA_DR), rel=1e-14)  # 4.95 N
    assert minus == pytest.approx(BESSA_CL * (-50.0 * 50.0 - BESSA_DL), rel=1e-14)  # -2.45 N
    assert plus == pytest.approx(4.95) and minus == pytest.approx(-2.45)


def test_uuv_simulator_bessa_conversion_zero_inside_dead_zone():
    chain = static(DeadZoneMap(BESSA_CL, BESSA_CR, BESSA_DL, BESSA_DR))
    delta = 1e-6
    out = chain.steady_thrust([0.0, math.sqrt(BESSA_DR) - delta, -math.sqrt(-BESSA_DL) + delta])
    assert np.all(out == 0.0)


def test_uuv_simulator_bessa_conversion_dead_zone_is_on_x_abs_x():
    # ThrusterConversionFcn.cc compares basic = x|x| (not x) with delta_L, delta_R, so the map is
    # continuous at x = -sqrt(-delta_L), +sqrt(delta_R): x = 10 gives 0.002 (100 - 25) = 0.15 N
    dz = DeadZoneMap(BESSA_CL, BESSA_CR, BESSA_DL, BESSA_DR)
    chain = static(dz)
    x = np.array([10.0, -10.0, math.sqrt(BESSA_DR) + 1e-3, -math.sqrt(-BESSA_DL) - 1e-3, 24.999,
                  25.0])
    xx = x * np.abs(x)
    expected = np.where(xx <= BESSA_DL, BESSA_CL * (xx - BESSA_DL),
                        np.where(xx >= BESSA_DR, BESSA_CR * (xx - BESSA_DR), 0.0))
    np.testing.assert_allclose(chain.steady_thrust(x), expected, rtol=1e-12, atol=1e-15)
    assert chain.steady_thrust(10.0)[0] == pytest.approx(0.15)
    assert chain.steady_thrust(-10.0)[0] == pytest.approx(-0.05)
    np.testing.assert_allclose(dz.thrust(x), expected, rtol=1e-12, atol=1e-15)


def test_bessa_conversion_is_continuous_and_monotone():
    chain = static(DeadZoneMap(BESSA_CL, BESSA_CR, BESSA_DL, BESSA_DR))
    x = np.linspace(-60.0, 60.0, 24001)
    t = chain.steady_thrust(x)
    assert np.all(np.diff(t) >= 0.0)
    assert np.max(np.abs(np.diff(t))) < 2 * BESSA_CR * 60.0 * (x[1] - x[0]) * 1.01


LI_IN = [-5.0, 0.0, 2.0, 5.0]
LI_OUT = [-100.0, -10.0, 20.0, 120.0]


def test_uuv_simulator_linear_interp_exact_at_nodes():
    chain = static(TableMap(LI_IN, LI_OUT))
    assert np.array_equal(chain.steady_thrust(LI_IN), np.array(LI_OUT))


def test_uuv_simulator_linear_interp_holds_end_values():
    chain = static(TableMap(LI_IN, LI_OUT))
    out = chain.steady_thrust([-10.0, LI_IN[0] - 0.5, 10.0, LI_IN[-1] + 0.5])
    assert out.tolist() == [-100.0, -100.0, 120.0, 120.0]


def test_uuv_simulator_linear_interp_midpoints():
    chain = static(TableMap(LI_IN, LI_OUT))
    for i, alpha in enumerate((0.1, 0.5, 0.9)):
        x = alpha * LI_IN[i] + (1 - alpha) * LI_IN[i + 1]
        y = alpha * LI_OUT[i] + (1 - alpha) * LI_OUT[i + 1]
        assert chain.steady_thrust(x)[0] == pytest.approx(y, abs=1e-12)
    # kernel (binary search) and numpy.interp agree everywhere
    xs = np.linspace(-7.0, 7.0, 281)
    np.testing.assert_allclose(chain.steady_thrust(xs), TableMap(LI_IN, LI_OUT).thrust(xs),
                               rtol=0, atol=1e-12)


# =============================================================================================
# UUV Simulator dynamics (Dynamics.cc)
# =============================================================================================
def test_uuv_simulator_first_order_tau05_unit_step_reaches_1_minus_1_over_e():
    chain = ThrusterChain((FirstOrder(0.5),), input_kind="command")
    r = chain.simulate(Step(1.0), 1.0, dt=1e-3)
    assert r.t[500] == pytest.approx(0.5)
    assert r["prop_speed"][500] == pytest.approx(1.0 - math.exp(-1.0), abs=1e-9)
    # exact ZOH update: the whole trajectory is 1 - exp(-t/tau) to rounding
    np.testing.assert_allclose(r["prop_speed"], 1.0 - np.exp(-r.t / 0.5), rtol=0, atol=1e-12)


@pytest.mark.parametrize("substeps", [1, 4])
def test_uuv_simulator_first_order_exact_at_samples_with_coarse_dt(substeps):
    chain = ThrusterChain((FirstOrder(0.5),), input_kind="command")
    r = chain.simulate(Step(1.0), 2.0, dt=0.1, substeps=substeps)
    assert r["prop_speed"][5] == pytest.approx(1.0 - math.exp(-1.0), abs=1e-9)
    np.testing.assert_allclose(r["prop_speed"], 1.0 - np.exp(-r.t / 0.5), rtol=0, atol=1e-12)


def test_zero_order_dynamics_passes_the_command_through():
    chain = ThrusterChain((ZeroOrder(), QuadraticMap.basic(0.0049)), input_kind="command")
    assert chain.steady_thrust([50.0, -50.0]).tolist() == pytest.approx([12.25, -12.25])


YO_ALPHA, YO_BETA, ROTOR_C = 2.0, 3.0, 0.0049


def yoerger_chain():
    """UUV Simulator thruster: Yoerger dynamics + Basic conversion."""
    return ThrusterChain((Yoerger(YO_ALPHA, YO_BETA), QuadraticMap.basic(ROTOR_C)),
                         input_kind="command")


def test_yoerger_steady_state_is_algebraic():
    # x|x| = beta u / alpha  =>  T = c x|x| = c beta u / alpha
    u = np.array([1.0, 10.0, 50.0, -50.0])
    out = yoerger_chain().steady_thrust(u)
    np.testing.assert_allclose(out, ROTOR_C * YO_BETA * u / YO_ALPHA, rtol=1e-8)


@pytest.mark.parametrize("u", [1.0, 50.0, -50.0])
def test_yoerger_step_is_monotone_and_does_not_blow_up_in_100s(u):
    # UUV Simulator's Yoerger never updates prevTime, so its Euler step dt grows with time and
    # the state eventually explodes; ours must sit on the equilibrium after 100 s.
    chain = ThrusterChain((Yoerger(YO_ALPHA, YO_BETA),), input_kind="command")
    r = chain.simulate(u, 100.0, dt=0.01)
    x = r["prop_speed"]
    x_ss = math.copysign(math.sqrt(YO_BETA * abs(u) / YO_ALPHA), u)
    assert np.all(np.isfinite(x))
    assert x[-1] == pytest.approx(x_ss, rel=1e-12)
    s = np.sign(u)
    assert np.all(np.diff(s * x) >= -1e-12), "step response must be monotone"
    assert np.all(s * x <= abs(x_ss) * (1 + 1e-12)), "no overshoot"


BESSA = {"jmsp": 0.05, "kv1": 0.2, "kv2": 0.002, "kt": 0.5, "rm": 2.0}


def bessa_steady(u: float) -> float:
    """Root of Kv2 x|x| + Kv1 x = u Kt/Rm with the sign of u."""
    rhs = abs(u) * BESSA["kt"] / BESSA["rm"]
    a, b = BESSA["kv2"], BESSA["kv1"]
    x = (-b + math.sqrt(b * b + 4 * a * rhs)) / (2 * a)
    return math.copysign(x, u)


def test_bessa_dynamics_steady_state_is_algebraic():
    chain = ThrusterChain((BessaDynamics(**BESSA), QuadraticMap.basic(ROTOR_C)),
                          input_kind="command")
    u = np.array([10.0, 100.0, -100.0])
    expected = np.array([ROTOR_C * bessa_steady(v) * abs(bessa_steady(v)) for v in u])
    np.testing.assert_allclose(chain.steady_thrust(u), expected, rtol=1e-8)


@pytest.mark.parametrize("u", [100.0, -40.0])
def test_bessa_dynamics_step_is_monotone_and_does_not_blow_up_in_100s(u):
    chain = ThrusterChain((BessaDynamics(**BESSA),), input_kind="command")
    r = chain.simulate(u, 100.0, dt=0.01)
    x = r["prop_speed"]
    assert np.all(np.isfinite(x))
    assert x[-1] == pytest.approx(bessa_steady(u), rel=1e-12)
    s = np.sign(u)
    assert np.all(np.diff(s * x) >= -1e-12)


@pytest.mark.slow
def test_slow_yoerger_steady_thrust_is_the_equilibrium():
    # time constant 1/(2 alpha x_ss) = 5 s at u = 1, beyond the 3 s settling hint: the sweep must
    # keep going until the output is at rest (it used to return the value after 3 s)
    chain = ThrusterChain((Yoerger(0.1, 0.1), QuadraticMap.basic(1.0)), input_kind="command")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = chain.sweep([1.0, -2.0])
    assert res.not_converged == ()
    np.testing.assert_allclose(res.final, [1.0, -2.0], rtol=1e-8)
    np.testing.assert_allclose(chain.steady_thrust([1.0, -2.0]), [1.0, -2.0], rtol=1e-8)


@pytest.mark.slow
def test_sweep_does_not_warn_when_the_last_pass_reached_rest():
    chain = ThrusterChain((Yoerger(0.05, 0.05), QuadraticMap.basic(1.0)), input_kind="command")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = chain.sweep([1.0])
    assert res.not_converged == ()
    assert res.final[0] == pytest.approx(1.0, rel=1e-9)


# =============================================================================================
# Laidani et al.: ESC (eq. 1) and A2212 first-order motor (eq. 3)
# =============================================================================================
def test_esc_dead_zone_gives_zero_volts():
    esc = presets.laidani_esc()
    chain = static(esc, "command")
    cmd = np.array([1475.0, 1490.0, 1500.0, 1510.0, 1525.0])  # 1500 ± 25 µs
    assert np.all(chain.steady_thrust(cmd) == 0.0)
    assert np.all(esc.voltage(cmd) == 0.0)


def test_esc_saturation_clips_at_supply():
    esc = presets.laidani_esc()
    chain = static(esc, "command")
    out = chain.steady_thrust([1800.0, 1900.0, 2000.0, 1200.0, 1100.0, 1000.0])
    np.testing.assert_allclose(out, [12.0, 12.0, 12.0, -12.0, -12.0, -12.0], rtol=1e-12)


def test_esc_per_direction_slopes():
    esc = ESC(a_fwd=2.0, b_fwd=-2.0, a_rev=3.0, b_rev=3.0, neutral=0.0, deadzone_low=-1.0,
              deadzone_high=1.0, saturation_low=-10.0, saturation_high=5.0, supply_voltage=12.0)
    chain = static(esc, "command")
    cmd = np.array([3.0, -3.0, 2.0, -2.0, 0.5, 5.0, 10.0, -10.0])
    # fwd: 2c - 2; rev: 3c + 3; clip cmd to [-10, 5]; clip V to ±12
    expected = [4.0, -6.0, 2.0, -3.0, 0.0, 8.0, 8.0, -12.0]
    np.testing.assert_allclose(chain.steady_thrust(cmd), expected, rtol=1e-14)
    np.testing.assert_allclose(esc.voltage(cmd), expected, rtol=1e-14)


def test_esc_from_range_hits_supply_at_full_points_and_zero_at_dead_band_edges():
    esc = ESC.from_range(1500.0, 50.0, 1100.0, 1800.0, 12.0)
    v = esc.voltage([1100.0, 1475.0, 1525.0, 1800.0])
    np.testing.assert_allclose(v, [-12.0, 0.0, 0.0, 12.0], atol=1e-12)
    # asymmetric: the reverse slope is 12 V / 375 µs, the forward one 12 V / 275 µs
    assert esc.a_rev == pytest.approx(12.0 / 375.0)
    assert esc.a_fwd == pytest.approx(12.0 / 275.0)
    # continuous at the dead-band edges
    assert abs(esc.voltage(1525.0 + 1e-9)) < 1e-9 and abs(esc.voltage(1475.0 - 1e-9)) < 1e-9


def test_esc_with_supply_scales_the_voltage():
    esc = presets.laidani_esc()
    e24 = esc.with_supply(24.0)
    cmd = np.array([1000.0, 1200.0, 1300.0, 1500.0, 1600.0, 1800.0, 1900.0])
    np.testing.assert_allclose(e24.voltage(cmd), 2.0 * esc.voltage(cmd), rtol=1e-14, atol=1e-13)
    assert e24.supply_voltage == 24.0
    np.testing.assert_allclose(static(e24, "command").steady_thrust(cmd), 2.0 * esc.voltage(cmd),
                               rtol=1e-14, atol=1e-13)


@pytest.mark.parametrize(("full_low", "full_high"), [
    (1200.0, 1525.0),  # forward full point on the dead-band edge (was a ZeroDivisionError)
    (1200.0, 1510.0),  # ... inside the dead band
    (1475.0, 1800.0),  # reverse full point on the edge
    (1490.0, 1800.0),
])
def test_esc_from_range_rejects_full_points_in_the_dead_band(full_low, full_high):
    with pytest.raises(ParameterError, match="full-command points"):
        ESC.from_range(1500.0, 50.0, full_low, full_high, 12.0)


def test_laidani_a2212_steady_speed_is_km_times_v():
    chain = ThrusterChain((FirstOrderMotor(gain=presets.LAIDANI_KM,
                                           time_constant=presets.LAIDANI_TAU),),
                          input_kind="voltage")
    r = chain.simulate(12.0, 0.3)  # ~30 τ
    assert r["prop_speed"][-1] == pytest.approx(131.3016 * 12.0, rel=1e-10)  # 1575.6 rad/s
    assert r["prop_speed"][-1] == pytest.approx(1575.6, abs=0.05)
    # exact first-order response (ZOH, upstream static)
    np.testing.assert_allclose(r["motor_speed"],
                               1575.6192 * (1 - np.exp(-r.t / presets.LAIDANI_TAU)), rtol=1e-12)


def test_steady_thrust_of_a_speed_chain_is_the_chain_output():
    # a chain ending in a speed returns that speed at rest (it used to return NaN)
    chain = ThrusterChain((FirstOrderMotor(gain=131.3016, time_constant=0.01021),),
                          input_kind="voltage")
    assert chain.output_kind == "speed"
    np.testing.assert_allclose(chain.steady_thrust([12.0, -6.0, 0.0]),
                               [1575.6192, -787.8096, 0.0], rtol=1e-9, atol=1e-12)
    yo = ThrusterChain((Yoerger(YO_ALPHA, YO_BETA),), input_kind="command")
    assert yo.steady_thrust([2.0])[0] == pytest.approx(math.sqrt(YO_BETA * 2.0 / YO_ALPHA),
                                                      rel=1e-9)


def test_laidani_full_chain_steady_thrust_at_full_pwm():
    # PWM 1800 µs -> 12 V -> 1575.6 rad/s -> 12.0 N forward; 1200 µs -> -10.79 N (digest §B)
    fwd, rev, zero = presets.laidani_chain().steady_thrust([1800.0, 1200.0, 1500.0])
    assert fwd == pytest.approx(12.0, rel=0.01)
    assert rev == pytest.approx(-10.79, rel=0.01)
    assert zero == 0.0


# =============================================================================================
# Steady maps: Caccia c_V V|V|, Laidani polynomial (Table 2)
# =============================================================================================
def test_caccia_romeo_voltage_quadratic_cv():
    chain = ThrusterChain((QuadraticMap(k_pos=1.02, k_neg=1.09),), input_kind="voltage")
    assert chain.signal_kinds == ("voltage", "thrust")
    out = chain.steady_thrust([10.0, -10.0, 0.0])
    np.testing.assert_allclose(out, [102.0, -109.0, 0.0], rtol=1e-14)


LAIDANI_FULL_SPEED = 131.3016 * 12.0  # 1575.6 rad/s


def laidani_map_chain():
    return static(PolynomialMap(forward=presets.LAIDANI_POLY_FORWARD,
                                reverse=presets.LAIDANI_POLY_REVERSE))


def test_laidani_table2_forward_thrust_at_full_speed_is_12_N():
    assert laidani_map_chain().steady_thrust(LAIDANI_FULL_SPEED)[0] == pytest.approx(12.0, rel=0.01)


def test_laidani_table2_reverse_thrust_at_full_speed_is_10_79_N():
    t = laidani_map_chain().steady_thrust(-LAIDANI_FULL_SPEED)[0]
    assert t == pytest.approx(-10.79, rel=0.01)
    assert U.to_kgf(-t) == pytest.approx(1.1, rel=0.02)  # paper: 1.1 kgf reverse


def test_laidani_table2_forward_peaks_at_12_4_N_near_1400_rad_s():
    w = np.linspace(0.0, LAIDANI_FULL_SPEED, 3001)
    t = laidani_map_chain().steady_thrust(w)
    k = int(np.argmax(t))
    assert t[k] == pytest.approx(12.4, rel=0.01)
    assert 1300.0 < w[k] < 1500.0


def test_polynomial_map_kernel_matches_numpy_polyval():
    pm = PolynomialMap(forward=presets.LAIDANI_POLY_FORWARD, reverse=presets.LAIDANI_POLY_REVERSE)
    w = np.linspace(-LAIDANI_FULL_SPEED, LAIDANI_FULL_SPEED, 401)
    np.testing.assert_allclose(static(pm).steady_thrust(w), pm.thrust(w), rtol=1e-12, atol=1e-14)
    assert static(pm).steady_thrust(0.0)[0] == 0.0  # no constant term at rest


# =============================================================================================
# Parameter validation
# =============================================================================================
def test_parameter_error_is_a_value_error():
    assert issubclass(ParameterError, ValueError)


@pytest.mark.parametrize(("make", "names"), [
    (lambda: FirstOrder(-0.5), ["time_constant"]),
    (lambda: FirstOrder(float("nan")), ["time_constant"]),
    (lambda: FirstOrder(0.5).replace(time_constant=0.0), ["time_constant"]),
    (lambda: FirstOrderMotor(gain=131.3, time_constant=-0.01), ["time_constant"]),
    (lambda: DCMotor(resistance=0.0), ["resistance"]),
    (lambda: DCMotor(inductance=-1e-3), ["inductance"]),
    (lambda: DCMotor(coulomb_torque=-0.1), ["coulomb_torque"]),
    (lambda: TableMap([0.0, 2.0, 1.0], [0.0, 1.0, 2.0]), ["input_values"]),
    (lambda: TableMap([0.0, 1.0, 1.0], [0.0, 1.0, 2.0]), ["input_values"]),
    (lambda: TableMap([0.0, 1.0, 2.0], [0.0, 1.0]), ["input_values", "output_values"]),
    (lambda: TunnelThruster(propeller_efficiency=1.2), ["propeller_efficiency"]),
    (lambda: TunnelThruster(tunnel_length=0.0), ["tunnel_length"]),
    (lambda: DeadZoneMap(delta_l=1.0, delta_r=0.0), ["delta_l", "delta_r"]),
    (lambda: Yoerger(alpha=0.0, beta=1.0), ["alpha"]),
    (lambda: BessaDynamics(kv1=0.0, kv2=0.0), ["kv1", "kv2"]),
    (lambda: LoadCell(damping_ratio=-0.1), ["damping_ratio"]),
    (lambda: QuadraticMap(k_pos=-1.0), ["k_pos"]),
    (lambda: ESC(supply_voltage=0.0), ["supply_voltage"]),
    (lambda: PolynomialMap(forward=()), ["forward"]),
])
def test_invalid_parameters_raise_parameter_error_naming_the_parameter(make, names):
    with pytest.raises(ParameterError) as exc:
        make()
    for name in names:
        assert name in str(exc.value)
    if exc.value.param is not None:  # the key used for model-file paths
        assert exc.value.param in names


def test_chain_rejects_load_cell_on_a_command_input():
    with pytest.raises(ParameterError, match=r"block 0 \(load_cell\).*command"):
        ThrusterChain((LoadCell(),), input_kind="command")


def test_chain_rejects_esc_after_a_map():
    with pytest.raises(ParameterError, match=r"block 1 \(esc\) takes command.*block 0 "
                                             r"\(quadratic\) gives thrust"):
        ThrusterChain((QuadraticMap.basic(0.0049), ESC()), input_kind="speed")


def test_chain_rejects_empty_and_foreign_blocks():
    with pytest.raises(ParameterError, match="at least one block"):
        ThrusterChain(())
    with pytest.raises(ParameterError, match="block 1"):
        ThrusterChain((FirstOrder(0.1), "basic"), input_kind="command")


def test_chain_signal_kinds_follow_the_block_diagram():
    assert presets.laidani_chain().signal_kinds == ("command", "voltage", "speed", "thrust")
    assert presets.auv2_rig_chain().signal_kinds == ("voltage", "thrust", "measured_thrust")


# =============================================================================================
# McLean DC motor (eqs. 2.1–2.5)
# =============================================================================================
def test_dc_motor_coulomb_holds_the_shaft_when_k_t_v_over_r_is_below_t_c():
    m = DCMotor(coulomb_torque=0.05)
    v = 5.0
    assert m.torque_constant * v / m.resistance < m.coulomb_torque
    for motor in (m, m.replace(inductance=1e-3)):
        r = ThrusterChain((motor,), input_kind="voltage").simulate(v, 0.5)
        assert np.all(r["motor_speed"] == 0.0)
        assert np.all(r["prop_speed"] == 0.0)


def test_dc_motor_coulomb_starts_above_t_c_and_settles_on_the_algebraic_speed():
    m = DCMotor(coulomb_torque=0.05, motor_viscous=1e-5)
    v = 12.0
    assert m.torque_constant * v / m.resistance > m.coulomb_torque
    r = ThrusterChain((m,), input_kind="voltage").simulate(v, 0.5)
    kt, kg, R = m.torque_constant, m.back_emf_constant, m.resistance
    w_ss = (kt * v / R - m.coulomb_torque) / (kt * kg / R + m.motor_viscous)
    assert r["motor_speed"][1] > 0.0
    assert r["motor_speed"][-1] == pytest.approx(w_ss, rel=1e-9)


@pytest.mark.parametrize("substeps", [1, 4])
@pytest.mark.parametrize("v_after", [0.0, -5.0])
def test_dc_motor_coulomb_brings_the_shaft_to_rest_after_switch_off(substeps, v_after):
    # 557 rad/s, deceleration >= T_c/J = 13 000 rad/s²: at rest within ~0.05 s, then stuck, since
    # |K_T V/R| = 0.036 N·m < T_c.  (The shaft used to creep at a step-size dependent speed,
    # 0.55 rad/s at substeps = 4 and 2.3 rad/s at substeps = 1, RK4 stages straddling w = 0.)
    m = DCMotor(coulomb_torque=0.05, motor_viscous=1e-5)
    r = ThrusterChain((m,), input_kind="voltage").simulate(
        Step(v_after, t0=0.5, baseline=24.0), 1.0, substeps=substeps)
    w = r["motor_speed"]
    assert w[499] > 500.0
    assert np.all(w[r.t >= 0.6] == 0.0)


def test_mclean_tunnel_thruster_with_coulomb_stops_after_switch_off():
    tt = presets.auv2_tunnel_thruster(coulomb=True)
    r = ThrusterChain((tt,), input_kind="voltage").simulate(Step(0.0, t0=0.5, baseline=24.0), 1.5)
    assert r["prop_speed"][499] == pytest.approx(tt.steady_state(24.0)["prop_speed"], rel=0.02)
    assert np.all(r["motor_speed"][r.t >= 1.2] == 0.0)
    assert np.all(r["thrust"][r.t >= 1.2] == 0.0)


def test_dc_motor_steady_speed_matches_the_algebraic_solution():
    # K_T (V - K_G w)/R = (C_M + C_P/N^2) w + K_Q (w/N)^2 / N   (w = motor speed, w/N = prop)
    m = DCMotor(motor_viscous=2e-6, propeller_viscous=6e-6, gear_ratio=2.5,
                torque_coefficient=3e-6, propeller_inertia=2e-6)
    kt, kg, R, n = m.torque_constant, m.back_emf_constant, m.resistance, m.gear_ratio
    cv = m.motor_viscous + m.propeller_viscous / n**2
    for v in (24.0, -12.0):
        a = m.torque_coefficient / n**3
        b = kt * kg / R + cv
        w = (-b + math.sqrt(b * b + 4 * a * kt * abs(v) / R)) / (2 * a)
        w = math.copysign(w, v)
        r = ThrusterChain((m,), input_kind="voltage").simulate(v, 1.0)
        assert r["motor_speed"][-1] == pytest.approx(w, rel=1e-9)
        assert r["prop_speed"][-1] == pytest.approx(w / n, rel=1e-9)
        assert r["current"][-1] == pytest.approx((v - kg * w) / R, rel=1e-9)
        assert r["torque"][-1] == pytest.approx(m.torque_coefficient * (w / n) * abs(w / n),
                                                rel=1e-9)
        # torque balance at the motor shaft
        q_prop = m.torque_coefficient * (w / n) ** 2 / n * np.sign(w)
        residual = kt * (v - kg * w) / R - cv * w - q_prop
        assert abs(residual) < 1e-9 * kt * abs(v) / R


def test_dc_motor_reverse_torque_coefficient_sets_the_reverse_steady_speed():
    m = DCMotor(torque_coefficient=3e-6, torque_coefficient_rev=6e-6, gear_ratio=2.5)
    kt, kg, R, n = m.torque_constant, m.back_emf_constant, m.resistance, m.gear_ratio

    def speed(v, kq):
        a, b = kq / n**3, kt * kg / R
        return math.copysign((-b + math.sqrt(b * b + 4 * a * kt * abs(v) / R)) / (2 * a), v)

    chain = ThrusterChain((m,), input_kind="voltage")
    np.testing.assert_allclose(chain.steady_thrust([12.0, -12.0]),
                               [speed(12.0, 3e-6) / n, speed(-12.0, 6e-6) / n], rtol=1e-8)
    # None (the default) means "same as forward"
    sym = ThrusterChain((DCMotor(torque_coefficient=3e-6, gear_ratio=2.5),), input_kind="voltage")
    out = sym.steady_thrust([12.0, -12.0])
    assert out[1] == pytest.approx(-out[0], rel=1e-12)


def test_dc_motor_with_small_inductance_converges_to_the_l0_response():
    base = DCMotor(motor_viscous=2e-6, torque_coefficient=3e-6, gear_ratio=2.5)
    ref = ThrusterChain((base,), input_kind="voltage").simulate(24.0, 0.1, dt=1e-4, substeps=2)
    w0 = ref["motor_speed"]
    errors = []
    for tau_e in (8e-4, 2e-4, 5e-5):  # McLean's tau_e = 0.8 ms, then smaller
        m = base.replace(inductance=tau_e * base.resistance)
        assert m.n_states == 2
        r = ThrusterChain((m,), input_kind="voltage").simulate(24.0, 0.1, dt=1e-4, substeps=2)
        errors.append(np.abs(r["motor_speed"] - w0).max() / np.abs(w0).max())
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 0.01
    assert errors[1] / errors[2] > 3.0  # first order in tau_e
    # the current starts at 0 with inductance (McLean eq. 2.1) and at V/R without
    m = base.replace(inductance=8e-4 * base.resistance)
    r = ThrusterChain((m,), input_kind="voltage").simulate(24.0, 0.01, dt=1e-4)
    assert r["current"][0] == 0.0
    assert ref["current"][0] == pytest.approx(24.0 / base.resistance)


def test_dc_motor_stiff_inductance_is_not_silently_nan():
    base = DCMotor(motor_viscous=2e-6, torque_coefficient=3e-6, gear_ratio=2.5)
    try:
        stiff = ThrusterChain((base.replace(inductance=1e-7),), input_kind="voltage")
        r = stiff.simulate(12.0, 0.05)
    except ValueError as e:  # refusing the run is fine if it says why
        assert "inductance" in str(e) or "step" in str(e)
        return
    r0 = ThrusterChain((base,), input_kind="voltage").simulate(12.0, 0.05)
    assert np.all(np.isfinite(r["motor_speed"]))
    np.testing.assert_allclose(r["motor_speed"], r0["motor_speed"], rtol=1e-3, atol=1e-3)


# =============================================================================================
# McLean tunnel thruster (eqs. 2.12–2.16) and Table I
# =============================================================================================
@pytest.mark.parametrize(("kwargs", "volts"), [
    ({}, 24.0), ({}, 16.0), ({}, 8.0), ({}, -24.0), ({"coulomb": True}, 24.0),
    ({"tunnel_length": U.inch(20.0)}, 24.0), ({"effective_pitch": U.ft_per_rad(0.0270)}, 24.0),
])
def test_tunnel_thruster_steady_state_agrees_with_long_simulation(kwargs, volts):
    tt = presets.auv2_tunnel_thruster(**kwargs)
    ss = tt.steady_state(volts)
    r = ThrusterChain((tt,), input_kind="voltage").simulate(volts, 6.0)  # >= 25 time constants
    assert r["motor_speed"][-1] == pytest.approx(ss["motor_speed"], rel=1e-8)
    assert r["prop_speed"][-1] == pytest.approx(ss["prop_speed"], rel=1e-8)
    assert r["thrust"][-1] == pytest.approx(ss["thrust"], rel=1e-8)


def test_mclean_table1_baseline_steady_speed_925_rpm_and_thrust_0_50_lb():
    ss = presets.auv2_tunnel_thruster().steady_state(24.0)
    assert U.to_rpm(ss["prop_speed"]) == pytest.approx(925.0, rel=0.05)
    assert U.to_lbf(ss["thrust"]) == pytest.approx(0.50, rel=0.14)


def test_tunnel_thruster_with_coulomb_below_start_voltage_stays_at_rest():
    tt = presets.auv2_tunnel_thruster(coulomb=True)  # McLean: needs 4–5 V to start turning
    assert tt.steady_state(4.0) == {"motor_speed": 0.0, "prop_speed": 0.0, "thrust": 0.0}
    r = ThrusterChain((tt,), input_kind="voltage").simulate(4.0, 0.5)
    assert np.all(r["motor_speed"] == 0.0) and np.all(r["thrust"] == 0.0)


def test_mclean_table1_pe0_thrust_is_identically_zero():
    tt = presets.auv2_tunnel_thruster(effective_pitch=0.0)
    assert tt.effective_pitch == 0.0
    r = ThrusterChain((tt,), input_kind="voltage").simulate(Step(24.0), 1.0)
    assert np.all(r["thrust"] == 0.0)
    assert tt.steady_state(24.0)["thrust"] == 0.0
    # ... while the motor runs free: Table I's Pe = 0 row, 3000 rpm
    assert U.to_rpm(r["prop_speed"][-1]) == pytest.approx(3000.0, rel=0.05)


def test_mclean_max_true_thrust_is_fluid_mass_times_pe_times_initial_acceleration():
    tt = presets.auv2_tunnel_thruster()
    m, n, pe = tt.motor, tt.motor.gear_ratio, tt.effective_pitch
    # at t = 0+: w = 0, i = V/R, so J w_m' = K_T V / R with the water inertia reflected through N²
    j = m.motor_inertia + (m.propeller_inertia + tt.profile_factor * tt.fluid_mass * pe**2) / n**2
    wp_dot0 = m.torque_constant * 24.0 / m.resistance / j / n
    f_max = tt.fluid_mass * pe * wp_dot0
    r = ThrusterChain((tt,), input_kind="voltage").simulate(Step(24.0), 1.333)
    assert r["thrust"][0] == pytest.approx(f_max, rel=1e-12)
    assert r["thrust"].max() == r["thrust"][0]
    assert f_max == pytest.approx(U.lbf(3.78), rel=0.005)  # digest: 3.78 lb = 16.8 N
    assert f_max == pytest.approx(16.8, rel=0.005)
    assert U.to_lbf(f_max) == pytest.approx(3.80, rel=0.05)  # Table I baseline: 3.80 lb


def test_mclean_table1_baseline_peak_output_thrust_5_40_lb():
    r = presets.auv2_rig_chain().simulate(Step(24.0), 1.333)
    assert U.to_lbf(r["measured_thrust"].max()) == pytest.approx(5.40, rel=0.05)
