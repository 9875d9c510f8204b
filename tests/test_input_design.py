"""Input design for the inertia experiment (Caccia et al. 2000, §III-B): the D-optimal sine
frequency from the Fisher information, levels, robust choice, command series."""

import math

import numpy as np
import pytest

from uuvid.identify.vehicle.design import (
    d_efficiency,
    d_optimal_frequency,
    design_sine_experiment,
    fisher_information,
    linearised_drag,
    robust_frequency,
    sine_levels,
    time_constant,
)
from uuvid.vehicle.model import steady_speed


@pytest.mark.parametrize("a", [0.05, 0.305, 1.0, 7.0])
def test_numeric_fisher_optimum_is_a_over_sqrt3(a):
    w = d_optimal_frequency(a)  # numeric sensitivities, no closed form
    assert w == pytest.approx(a / math.sqrt(3), rel=1e-4)


@pytest.mark.parametrize("omega", [0.05, 0.2, 1.3])
def test_numeric_fisher_matches_closed_form(omega):
    Mn = fisher_information(omega, 0.3, 0.012, amplitude=4.0)
    Ma = fisher_information(omega, 0.3, 0.012, amplitude=4.0, method="analytic")
    assert np.allclose(Mn, Ma, rtol=1e-6, atol=1e-12 * np.abs(Ma).max())
    # det ∝ b² ω²/(a² + ω²)⁴
    assert np.linalg.det(Ma) == pytest.approx(
        4.0**4 / 4 * 0.012**2 * omega**2 / (0.3**2 + omega**2) ** 4, rel=1e-9)


def test_paper_design_frequencies():
    # yaw: I = 93.75 (box of 450 kg, 1.3 × 0.9 m), linear k = 28.6 → 0.176 rad/s
    assert 93.75 == pytest.approx(450 / 12 * (1.3**2 + 0.9**2))
    assert d_optimal_frequency(28.6 / 93.75) == pytest.approx(0.176, rel=0.02)
    # surge: m = 675 (450 + 50 %), k_L = 46.9 + 2·306.2·0.27 = 212.25 → 0.18 rad/s
    kl = linearised_drag(46.9, 306.2, 0.27)
    assert kl == pytest.approx(212.25, abs=0.01)
    assert d_optimal_frequency(kl / 675) == pytest.approx(0.18, rel=0.02)
    assert time_constant(675, kl) == pytest.approx(675 / 212.248)


def test_d_efficiency_and_robust_choice():
    a = 0.3
    assert d_efficiency(a / math.sqrt(3), a) == pytest.approx(1.0)
    assert d_efficiency(np.array([0.5, 2.0]) * a / math.sqrt(3), a).max() < 1.0
    r = robust_frequency(212.25, (495.0, 900.0))
    lo, hi = r["omega_opt_range"]
    assert lo < r["omega"] < hi
    e1, e2 = r["efficiency_at_ends"]
    assert e1 == pytest.approx(e2, abs=1e-3) and r["min_efficiency"] == pytest.approx(min(e1, e2))
    assert r["min_efficiency"] > 0.9


def test_sine_levels_no_reversal_and_speed_range():
    lv = sine_levels(46.9, 306.2, 0.27, speed_range=(0.1, 0.35), omega=0.24, mass=890.0)
    assert lv["offset"] == pytest.approx(46.9 * 0.27 + 306.2 * 0.27**2)
    assert steady_speed(46.9, 306.2, lv["offset"]) == pytest.approx(0.27)
    assert 0 < lv["amplitude"] < lv["offset"]
    assert lv["speed_min"] >= 0.1 - 1e-9 and lv["speed_max"] <= 0.35 + 1e-9
    assert lv["limited_by"] == "speed_range"
    qs = sine_levels(46.9, 306.2, 0.27, speed_range=(0.1, 0.35))
    assert qs["amplitude"] < lv["amplitude"]  # quasi-static is more conservative
    free = sine_levels(28.6, 0.0, -5 / 28.6)
    assert free["offset"] == pytest.approx(-5.0) and free["limited_by"] == "no_reversal"
    assert free["amplitude"] == pytest.approx(0.9 * 5.0)


def test_design_with_maneuvering_space_raises_frequency():
    d = design_sine_experiment(46.9, 306.2, mass=675.0, speed=0.27, mass_air=450.0,
                               speed_range=(0.1, 0.35), n_periods=2, max_distance=20.0,
                               dof="surge", force_limit=167.7)
    assert d.omega_opt == pytest.approx(0.1815, rel=1e-3)
    assert d.omega_numeric == pytest.approx(d.omega_opt, rel=1e-4)
    assert d.omega > d.omega_opt and d.messages
    assert d.distance == pytest.approx(20.0)
    assert 0.9 < d.efficiency < 1.0
    assert d.robust["omega_opt_range"][0] < d.robust["omega"] < d.robust["omega_opt_range"][1]
    c = d.command(0.1)
    assert c["sample_time"] == 0.1
    assert c["t"][1] - c["t"][0] == pytest.approx(0.1)
    assert c["t"][-1] == pytest.approx(d.duration, abs=0.1)
    assert c["force"].min() > 0  # never reverses
    assert d.signal().omega == pytest.approx(d.omega)
    assert d.as_dict()["period"] == pytest.approx(2 * math.pi / d.omega)


def test_thruster_commands_through_romeo_allocation():
    from uuvid.vehicle.definition import load_vehicle

    v = load_vehicle("romeo")
    d = design_sine_experiment(46.9, 306.2, mass=675.0, speed=0.27, n_periods=2, dof="surge")
    out = d.thruster_commands(v, "surge_front", voltage=(1.02, 1.09))
    th = out["thrust"]
    names = out["thrusters"]
    rear = [names.index("HRL"), names.index("HRR")]
    front = [names.index("HFL"), names.index("HFR")]
    assert np.all(th[rear] == 0.0) and np.all(th[front] > 0)
    assert np.allclose((v.B @ th)[0], d.command()["force"])
    assert np.allclose(1.02 * out["voltage"][front] ** 2, th[front])
    assert not out["saturated"]
    yd = design_sine_experiment(28.6, 0.0, mass=93.75, speed=-5 / 28.6, dof="yaw")
    yo = yd.thruster_commands(v, "yaw_fr_rl")
    assert np.allclose((v.B @ yo["thrust"])[5], yd.command()["force"])


def test_robust_design_choice():
    d = design_sine_experiment(28.6, 0.0, mass=93.75, speed=-5 / 28.6, mass_air=93.75,
                               choice="robust", dof="yaw")
    assert d.omega == pytest.approx(d.robust["omega"])
    assert d.omega < d.omega_opt  # added mass only makes τ_c longer


@pytest.mark.parametrize("kw, msg", [
    ({"mass": -1.0}, "mass"),
    ({"speed": 0.0}, "non-zero"),
    ({"force_limit": 10.0}, "force limit"),
    ({"amplitude": 40.0}, "reverse"),
    ({"choice": "best"}, "choice"),
    ({"max_distance": 1.0}, "settling"),
])
def test_design_bad_input(kw, msg):
    args = {"mass": 675.0, "speed": 0.27, "mass_air": 450.0}
    args.update(kw)
    with pytest.raises(ValueError, match=msg):
        design_sine_experiment(46.9, 306.2, **args)


def test_fisher_bad_input():
    with pytest.raises(ValueError, match="omega"):
        fisher_information(0.0, 1.0)
    with pytest.raises(ValueError, match="method"):
        fisher_information(1.0, 1.0, method="guess")
    with pytest.raises(ValueError, match="drag"):
        linearised_drag(-1.0, 0.0, 0.1)
    with pytest.raises(ValueError, match="mass_range"):
        robust_frequency(10.0, (5.0, 1.0))


@pytest.mark.parametrize("a", [0.05, 0.4, 3.0])
def test_vectorised_grid_is_the_one_frequency_fisher_information(a):
    """The grid of d_optimal_frequency evaluates every ω at once: the same log det M(ω) as
    fisher_information one ω at a time, and the same best grid point."""
    from uuvid.identify.vehicle.design import _logdet_grid

    omegas = np.exp(np.linspace(math.log(a / 100), math.log(a * 100), 97))
    grid = _logdet_grid(omegas, a, "numeric")
    one = []
    for w in omegas:
        s, ld = np.linalg.slogdet(fisher_information(w, a, 1.0))
        one.append(ld if s > 0 else -np.inf)
    one = np.array(one)
    fin = np.isfinite(one)
    assert np.array_equal(np.isfinite(grid), fin)
    assert np.allclose(grid[fin], one[fin], rtol=0, atol=1e-8)
    assert np.argmax(grid) == np.argmax(one)


@pytest.mark.parametrize("dof", ["pitch", "roll"])
def test_thruster_commands_refuse_a_dof_the_vehicle_cannot_produce(dof):
    """BlueROV2 allocates surge, sway, heave and yaw only: a pitch or roll command came out as
    all-zero thrusts (B·thrust = 0 while the designed moment runs 1 … 1.6 N·m), written silently."""
    from uuvid.vehicle.definition import load_vehicle

    v = load_vehicle("bluerov2")
    d = design_sine_experiment(2.0, 0.0, mass=0.16, mass_air=0.16, speed=0.5, dof=dof)
    with pytest.raises(ValueError, match=rf"(?s){dof}.*bluerov2|bluerov2.*{dof}"):
        d.thruster_commands(v, None)


def test_thruster_commands_reproduce_the_wrench_and_say_saturation():
    from uuvid.vehicle.definition import load_vehicle

    v = load_vehicle("bluerov2")
    d = design_sine_experiment(2.0, 0.0, mass=0.16, mass_air=0.16, speed=0.5, dof="yaw")
    out = d.thruster_commands(v, None)
    assert np.allclose((v.B @ out["thrust"])[5], d.command()["force"])
    assert out["mode"] == "default" and not out["saturated"] and not out["messages"]
    big = design_sine_experiment(2.0, 0.0, mass=0.16, mass_air=0.16, speed=0.5, dof="surge",
                                 amplitude=None, w=-300.0)
    sat = big.thruster_commands(v, None)
    assert sat["saturated"]
    assert any("limit" in m and "surge" in m for m in sat["messages"]), sat["messages"]
