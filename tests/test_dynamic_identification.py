"""Dynamic identification (uuvid.identify.thruster.dynamic): synthetic records from known parameters, white
noise added, parameters recovered within 3σ with small σ; several runs at once; bad input."""

import json
import math

import numpy as np
import pytest

from uuvid.identify.fit import IdentifiabilityWarning
from uuvid.identify.thruster import dynamic as D
from uuvid.thruster import presets as P
from uuvid.thruster.blocks import BessaDynamics, FirstOrder, FirstOrderMotor, QuadraticMap, Yoerger
from uuvid.thruster.chain import ThrusterChain


def _step_run(chain, level, t_end, dt, channel, noise, rng, t0=0.05, substeps=4, name=""):
    t = np.arange(round(t_end / dt) + 1) * dt
    u = np.where(t >= t0, level, 0.0)
    r = chain.simulate(u, t[-1], dt=dt, substeps=substeps)
    return D.Run(t, u, r[channel] + rng.normal(0.0, noise, t.size), channel, name=name)


def _within_3_sigma(fit, truth: dict, max_rel_sigma: float):
    for name, true in truth.items():
        p = fit[name]
        assert abs(p.value - true) <= 3 * p.stderr, (name, p.value, true, p.stderr)
        assert p.stderr / abs(true) < max_rel_sigma, (name, p.stderr, true)


# ------------------------------------------------------------------------------------------------
# models
# ------------------------------------------------------------------------------------------------
def test_first_order_motor_laidani_a2212():
    """Laidani eq. 3: Ω/V = 131.3/(1 + 0.01021 s), a 6 V step sampled at 1 kHz, 5 rad/s noise."""
    rng = np.random.default_rng(10)
    truth = ThrusterChain((FirstOrderMotor(gain=131.3016, time_constant=0.01021),),
                          input_kind="voltage")
    run = _step_run(truth, 6.0, 0.1, 1e-3, "prop_speed", 5.0, rng, t0=0.02)
    fit = D.fit_first_order([run])  # start values from the record itself
    _within_3_sigma(fit, {"blocks[0].gain": 131.3016, "blocks[0].time_constant": 0.01021}, 0.01)
    assert fit.chain.blocks[0].time_constant == fit["blocks[0].time_constant"].value
    assert fit.fit.extra["runs"][0]["rmse"] == pytest.approx(5.0, rel=0.2)


def test_first_order_gain_for_a_thrust_record_and_a_sweep_input():
    """gain × FirstOrder on an arbitrary (chirp) input: the channel name of the run does not matter."""
    rng = np.random.default_rng(11)
    truth = ThrusterChain((FirstOrderMotor(gain=2.5, time_constant=0.2),), input_kind="voltage")
    t = np.arange(2001) * 2e-3
    u = 10 * np.sin(2 * np.pi * (0.2 + 1.0 * t) * t)
    y = truth.simulate(u, t[-1], dt=2e-3)["prop_speed"] + rng.normal(0, 0.2, t.size)
    fit = D.fit_first_order(D.Run(t, u, y, channel="thrust"), gain=1.0, time_constant=0.05)
    _within_3_sigma(fit, {"blocks[0].gain": 2.5, "blocks[0].time_constant": 0.2}, 0.01)


def test_yoerger_two_runs_both_directions():
    """ẋ = βu − αx|x| from two steps of opposite sign sharing α = 0.02, β = 5."""
    rng = np.random.default_rng(12)
    truth = ThrusterChain((Yoerger(alpha=0.02, beta=5.0),), input_kind="command")
    runs = [_step_run(truth, lvl, 3.0, 5e-3, "prop_speed", 0.5, rng, t0=0.1) for lvl in (10, -6)]
    fit = D.fit_yoerger(runs)
    _within_3_sigma(fit, {"blocks[0].alpha": 0.02, "blocks[0].beta": 5.0}, 0.01)
    assert [r["name"] for r in fit.fit.extra["runs"]] == ["run0", "run1"]


@pytest.mark.slow
def test_bessa_identifiable_combinations():
    """Only K_t/(R_m J_msp), K_v1/J_msp, K_v2/J_msp are identifiable; K_t, R_m fixed at truth."""
    rng = np.random.default_rng(13)
    truth = ThrusterChain((BessaDynamics(jmsp=0.002, kv1=0.001, kv2=1e-5, kt=0.1, rm=1.0),),
                          input_kind="command")
    runs = [_step_run(truth, lvl, 2.0, 5e-3, "prop_speed", 1.0, rng, t0=0.1) for lvl in (12, 6)]
    fit = D.fit_bessa(runs, kt=0.1, rm=1.0, jmsp=0.001, kv1=0.002, kv2=2e-5)
    _within_3_sigma(fit, {"blocks[0].jmsp": 0.002, "blocks[0].kv1": 0.001,
                          "blocks[0].kv2": 1e-5}, 0.02)
    ident = fit.fit.extra["identifiable"]
    for name, true in (("Kt/(Rm Jmsp)", 50.0), ("Kv1/Jmsp", 0.5), ("Kv2/Jmsp", 0.005)):
        e = ident[name]
        assert abs(e["estimate"] - true) <= 3 * e["sigma"], (name, e, true)
    assert fit.fit.extra["fixed"] == {"kt": 0.1, "rm": 1.0}


def test_bessa_refuses_unidentifiable_free_set():
    t = np.arange(100) * 0.01
    run = D.Run(t, np.ones_like(t), np.linspace(0, 1, 100), "prop_speed")
    with pytest.raises(ValueError, match="not separately identifiable"):
        D.fit_bessa([run], free=("jmsp", "kt", "kv1"))


@pytest.fixture(scope="module")
def dc_truth():
    return P.pittman_9514().replace(torque_coefficient=2e-6, coulomb_torque=0.01)


def _dc_runs(motor, channels, seed):
    rng = np.random.default_rng(seed)
    chain = ThrusterChain((motor,), input_kind="voltage")
    runs = []
    for v in (12.0, 24.0):
        t = np.arange(601) * 1e-3
        u = np.where(t >= 0.05, v, 0.0)
        r = chain.simulate(u, t[-1], dt=1e-3)
        for ch, s in channels.items():
            runs.append(D.Run(t, u, r[ch] + rng.normal(0, s, t.size), ch, name=f"{v:g}V-{ch}"))
    return runs


@pytest.mark.slow
def test_dc_motor_from_speed_alone(dc_truth):
    """Speed alone: K (=K_T=K_G), J_M, K_Q, T_c, with R and the viscous friction fixed."""
    start = dc_truth.replace(torque_constant=0.025, back_emf_constant=0.025, motor_inertia=5e-6,
                             torque_coefficient=1e-6, coulomb_torque=0.005)
    fit = D.fit_dc_motor(_dc_runs(dc_truth, {"prop_speed": 1.0}, 14), start)
    k = "blocks[0].torque_constant=back_emf_constant"
    assert fit.fit.names == [k, "blocks[0].motor_inertia", "blocks[0].torque_coefficient",
                             "blocks[0].coulomb_torque"]
    _within_3_sigma(fit, {k: dc_truth.torque_constant, "blocks[0].motor_inertia":
                          dc_truth.motor_inertia, "blocks[0].torque_coefficient": 2e-6,
                          "blocks[0].coulomb_torque": 0.01}, 0.05)
    m = fit.chain.blocks[0]
    assert m.torque_constant == m.back_emf_constant  # tied
    assert fit["blocks[0].motor_inertia"].unit == "kg·m²"


def test_dc_motor_with_current_separates_r(dc_truth):
    start = dc_truth.replace(torque_constant=0.025, back_emf_constant=0.025, motor_inertia=5e-6,
                             resistance=3.0, torque_coefficient=1e-6, coulomb_torque=0.005,
                             motor_viscous=0.0)  # viscous 0 → not freed (collinear with T_c, K_Q)
    fit = D.fit_dc_motor(_dc_runs(dc_truth.replace(motor_viscous=0.0),
                                  {"prop_speed": 1.0, "current": 0.01}, 15), start)
    assert "blocks[0].resistance" in fit
    _within_3_sigma(fit, {"blocks[0].resistance": 4.06,
                          "blocks[0].torque_constant=back_emf_constant": dc_truth.torque_constant,
                          "blocks[0].motor_inertia": dc_truth.motor_inertia}, 0.01)
    assert fit.fit.extra["normalized"]  # speed and current runs are scaled to weigh alike


@pytest.fixture(scope="module")
def rig_runs():
    """McLean's rig (tunnel thruster + load cell) at 24 and 16 V, measured thrust, 0.2 N noise."""
    rng = np.random.default_rng(16)
    chain = P.auv2_rig_chain()
    return [_step_run(chain, v, 1.5, 1e-3, "measured_thrust", 0.2, rng, name=f"{v:g} V")
            for v in (24.0, 16.0)]


@pytest.mark.slow
def test_mclean_tunnel_thruster_through_the_load_cell(rig_runs):
    start = P.auv2_tunnel_thruster(energy_correction=2.0, momentum_correction=0.25,
                                   added_mass_coefficient=0.5)
    fit = D.fit_tunnel_thruster(rig_runs, start, load_cell=P.mclean_load_cell())
    _within_3_sigma(fit, {"blocks[0].energy_correction": 3.0,
                          "blocks[0].momentum_correction": 0.185,
                          "blocks[0].added_mass_coefficient": 0.25}, 0.06)
    json.dumps(fit.as_dict())  # the fitted chain is stored JSON-able in extra


@pytest.mark.slow
def test_mclean_tunnel_thruster_at_75_hz_with_load_cell_damping():
    """The thesis's sampling rate: each 13.3 ms interval is integrated in RK4 substeps."""
    rng = np.random.default_rng(17)
    chain = P.auv2_rig_chain()
    runs = [_step_run(chain, v, 1.5, 1 / 75, "measured_thrust", 0.1, rng, substeps=27)
            for v in (24.0, 16.0)]
    start = P.auv2_tunnel_thruster(momentum_correction=0.2,  # Δα fixed at its true 3.0
                                   added_mass_coefficient=0.4)
    lc = P.mclean_load_cell().replace(damping_ratio=0.25)
    fit = D.fit_tunnel_thruster(runs, start, load_cell=lc,
                                free=["momentum_correction", "added_mass_coefficient",
                                      "load_cell.damping_ratio"], max_step=5e-4)
    _within_3_sigma(fit, {"blocks[0].momentum_correction": 0.185,
                          "blocks[0].added_mass_coefficient": 0.25,
                          "blocks[1].damping_ratio": 14.1 / (2 * math.sqrt(1935))}, 0.1)


# ------------------------------------------------------------------------------------------------
# the generic core
# ------------------------------------------------------------------------------------------------
def _first_order_step(seed: int, samples: int):
    """A 100 rad/s step into first order (τ 0.08 s) + quadratic map (k 0.004): thrust and speed
    records with noise, and a template started away from the truth (τ 0.2 s, k 0.01)."""
    rng = np.random.default_rng(seed)
    truth = ThrusterChain((FirstOrder(time_constant=0.08), QuadraticMap(k_pos=0.004)),
                          input_kind="speed")
    t = np.arange(samples) * 2e-3
    u = np.where(t >= 0.1, 100.0, 0.0)
    r = truth.simulate(u, t[-1], dt=2e-3)
    runs = [D.Run(t, u, r["thrust"] + rng.normal(0, 0.2, t.size), "thrust"),
            D.Run(t, u, r["prop_speed"] + rng.normal(0, 1.0, t.size), "speed")]
    template = ThrusterChain((FirstOrder(time_constant=0.2), QuadraticMap(k_pos=0.01)),
                             input_kind="speed")
    return runs, template


def test_fit_chain_paths_x0_bounds_and_predict():
    """First order on a thrust demand + quadratic map; parameters by path; thrust and speed runs
    of one experiment fitted together."""
    runs, template = _first_order_step(18, 501)
    fit = D.fit_chain(template, ["blocks[0].time_constant", ("blocks[1].k_pos", "blocks[1].k_neg")],
                      runs, x0={"time_constant": 0.05}, bounds={"time_constant": (0.01, 1.0)})
    assert fit.fit.names == ["blocks[0].time_constant", "blocks[1].k_pos=k_neg"]
    _within_3_sigma(fit, {"blocks[0].time_constant": 0.08, "blocks[1].k_pos=k_neg": 0.004}, 0.01)
    assert fit.chain.blocks[1].k_neg == fit.chain.blocks[1].k_pos
    assert fit.predict(0) == pytest.approx(fit.response(0)["thrust"])
    assert np.sqrt(np.mean((fit.predict(1) - runs[1].y) ** 2)) == pytest.approx(1.0, rel=0.2)


def test_free_as_block_index_mapping_and_set_parameter():
    chain = P.auv2_rig_chain()
    fps = D.parse_free(chain, {0: ["momentum_correction", "motor.coulomb_torque"],
                               1: ["damping_ratio"]})
    assert [f.name for f in fps] == ["blocks[0].momentum_correction",
                                     "blocks[0].motor.coulomb_torque", "blocks[1].damping_ratio"]
    c2 = D.set_parameter(chain, {"blocks[0].motor.coulomb_torque": 0.02})
    assert c2.blocks[0].motor.coulomb_torque == 0.02 and chain.blocks[0].motor.coulomb_torque == 0


# ------------------------------------------------------------------------------------------------
# bad input
# ------------------------------------------------------------------------------------------------
@pytest.fixture
def fo_chain():
    return ThrusterChain((FirstOrderMotor(gain=1.0, time_constant=0.1),), input_kind="voltage")


def _good():
    t = np.arange(50) * 0.01
    return t, np.ones(50), 1 - np.exp(-t / 0.1)


@pytest.mark.parametrize("mutate, message", [
    (lambda t, u, y: (t, u[:-1], y), "same length"),
    (lambda t, u, y: (t[::-1], u, y), "strictly increasing"),
    (lambda t, u, y: (t, u, np.where(np.arange(50) == 7, np.nan, y)), r"y\[7\] is not finite"),
    (lambda t, u, y: (t[:2], u[:2], y[:2]), "at least 3 samples"),
    (lambda t, u, y: (np.concatenate([t[:10], t[10:] + 0.004]), u, y), "not uniformly sampled"),
])
def test_bad_runs_are_rejected_with_a_clear_message(fo_chain, mutate, message):
    t, u, y = mutate(*_good())
    with pytest.raises(ValueError, match=message):
        D.fit_chain(fo_chain, {0: ["time_constant"]}, [D.Run(t, u, y, "prop_speed")])


def test_non_uniform_time_can_be_resampled(fo_chain):
    t = np.sort(np.concatenate([np.arange(0, 1, 0.01), [0.005]]))
    y = 1 - np.exp(-t / 0.1)
    fit = D.fit_chain(fo_chain, {0: ["time_constant"]},
                      [D.Run(t, np.ones_like(t), y, "prop_speed")], x0=[0.2], resample=True)
    assert fit.fit.extra["runs"][0]["resampled"]
    assert fit["blocks[0].time_constant"].value == pytest.approx(0.1, rel=0.05)


def test_more_samples_than_parameters_required():
    t = np.arange(3) * 0.01
    run = D.Run(t, np.ones(3), np.zeros(3), "prop_speed")
    with pytest.raises(ValueError, match="too few samples: 3 in all runs for 3"):
        D.validate_runs([run], n_params=3)
    motor = ThrusterChain((P.pittman_9514(),), input_kind="voltage")
    with pytest.raises(ValueError, match="too few samples"):
        D.fit_chain(motor, {0: ["resistance", "motor_inertia", "motor_viscous"]}, [run])


@pytest.mark.parametrize("kwargs, message", [
    ({"free": {0: ["nonsense"]}}, "no parameter 'nonsense'"),
    ({"free": ["time_constant"]}, "must look like"),
    ({"free": {3: ["gain"]}}, "1 block"),
    ({"free": {0: ["time_constant"]}, "bounds": {"gain": (0, 1)}}, "not a free parameter"),
    ({"free": {0: ["time_constant"]}, "x0": [5.0], "bounds": {"time_constant": (0.01, 1)}},
     "outside its bounds"),
])
def test_bad_parameter_specs(fo_chain, kwargs, message):
    t, u, y = _good()
    with pytest.raises(ValueError, match=message):
        D.fit_chain(fo_chain, runs=[D.Run(t, u, y, "prop_speed")], **kwargs)


def test_unknown_or_missing_channel(fo_chain):
    t, u, y = _good()
    with pytest.raises(ValueError, match="unknown channel"):
        D.fit_chain(fo_chain, {0: ["time_constant"]}, [D.Run(t, u, y, "rpm")])
    with pytest.raises(ValueError, match="does not produce channel 'measured_thrust'"):
        D.fit_chain(fo_chain, {0: ["time_constant"]}, [D.Run(t, u, y, "measured_thrust")])


def test_coulomb_friction_started_at_zero_stays_non_negative(rig_runs):
    """A friction starting at 0 gets a lower bound of 0 (the block rejects negative values); the
    truth has none, and the fit says it is not significant."""
    with pytest.warns(IdentifiabilityWarning, match="coulomb_torque: percentile error"):
        fit = D.fit_tunnel_thruster(rig_runs, P.auv2_tunnel_thruster(),
                                    load_cell=P.mclean_load_cell(),
                                    free=["momentum_correction", "motor.coulomb_torque"],
                                    scale=[0.1, 0.01])
    tc = fit["blocks[0].motor.coulomb_torque"]
    assert tc.value >= 0 and tc.value < 3 * tc.stderr + 1e-4  # the truth has none
    assert fit["blocks[0].momentum_correction"].value == pytest.approx(0.185, rel=0.02)


def test_threaded_jacobian_columns_give_the_serial_fit_bit_for_bit(monkeypatch):
    """fit_chain evaluates the finite-difference columns in threads and reuses the residual
    least_squares just computed: the fit is the one-thread fit, number for number."""
    runs, template = _first_order_step(5, 401)
    runs = runs[:1]  # thrust only
    free = ["blocks[0].time_constant", "blocks[1].k_pos"]
    calls = []
    real = D._fd_jacobian

    def spy(*a, **k):
        calls.append(a[-1] if len(a) > 6 else k.get("workers", 1))
        return real(*a, **k)

    monkeypatch.setattr(D, "_fd_jacobian", spy)
    monkeypatch.setattr(D, "usable_cpus", lambda: 2)
    threaded = D.fit_chain(template, free, runs)
    monkeypatch.setattr(D, "usable_cpus", lambda: 1)
    serial = D.fit_chain(template, free, runs)
    assert set(calls) == {1, 2}
    assert threaded.fit.values == serial.fit.values
    assert np.array_equal(threaded.fit.covariance, serial.fit.covariance)
    assert threaded.fit.extra["nfev"] == serial.fit.extra["nfev"]


def _between_samples_step(dt, K=40.0, tau=0.05, ts=0.2437):
    """Exact first-order speed after a 2 V step at ``ts`` (between samples), sampled every dt."""
    t = np.arange(round(1.0 / dt) + 1) * dt
    return D.Run(t, np.where(t >= ts, 2.0, 0.0),
                 np.where(t >= ts, 2 * K * (1 - np.exp(-(t - ts) / tau)), 0.0), "prop_speed")


def test_a_time_constant_sampled_coarsely_is_said():
    """The command is held between samples: a step between two of them is placed at one, and τ
    fitted on exact data drifted with the logging rate (0.050 s at 1 kHz, 0.047 at 100 Hz —
    27σ off — 0.025 at 10 Hz) without a word.  Under 10 samples per τ it is said, with the
    bias bound; a τ shorter than the step is said unresolvable."""
    fine = D.fit_first_order([_between_samples_step(1e-3)], emit_warnings=False).fit
    assert fine["blocks[0].time_constant"].value == pytest.approx(0.05, rel=0.01)
    assert not any("sample step" in w for w in fine.warnings)
    with pytest.warns(IdentifiabilityWarning, match=r"time_constant = 0\.04\d* s spans only 4\.\d* "
                                                   r"sample steps of 0\.01 s.*up to 0\.005 s"):
        coarse = D.fit_first_order([_between_samples_step(0.01)]).fit
    tau = coarse["blocks[0].time_constant"]
    assert abs(tau.value - 0.05) > 3 * tau.stderr  # the bias the warning is about: beyond σ
    slow = D.fit_first_order([_between_samples_step(0.1)], emit_warnings=False).fit
    assert any("shorter than the sample step 0.1 s" in w for w in slow.warnings), slow.warnings


def test_a_current_column_a_dynamic_fit_does_not_use_is_said(tmp_path):
    """``--current-col`` with ``--model first-order``/``dc-motor`` was read and ignored: the
    written resistance was a start value, never marked as one."""
    import warnings as _w

    from uuvid.identify.thruster.workflow import ReadOptions, run_fit

    r = _between_samples_step(1e-3)
    rows = ["t,V,w,I"] + [f"{a:.17g},{b:.17g},{c:.17g},{0.1 + 0.05 * b:.17g}"
                          for a, b, c in zip(r.t, r.u, r.y)]
    (tmp_path / "step.csv").write_text("\n".join(rows) + "\n")
    opts = dict(time_col="t", command_col="V", command_unit="volts", speed_col="w")
    with _w.catch_warnings():
        _w.simplefilter("ignore")
        out = run_fit([tmp_path / "step.csv"], "first-order", ReadOptions(**opts, current_col="I"))
        plain = run_fit([tmp_path / "step.csv"], "first-order", ReadOptions(**opts))
    assert any("the current column (--current-col) is read but not used by --model first-order"
               in w for w in out.warnings), out.warnings
    assert not any("current column" in w for w in plain.warnings)


def test_resample_reaches_the_speed_and_thrust_fits(tmp_path):
    """``--resample`` was ignored by the dynamic fits that take thrust too (the structured path):
    the error on a jittered record said "pass --resample" with it passed."""
    import warnings as _w

    from uuvid.identify.thruster.workflow import ReadOptions, run_fit

    r = _between_samples_step(2e-3)
    t = r.t + np.random.default_rng(1).uniform(-2e-4, 2e-4, r.t.size)  # a jittered logger clock
    rows = ["t,V,w,T"] + [f"{a:.17g},{b:.17g},{c:.17g},{3.6e-4 * c * abs(c):.17g}"
                          for a, b, c in zip(t, r.u, r.y)]
    (tmp_path / "jit.csv").write_text("\n".join(rows) + "\n")
    opts = ReadOptions(time_col="t", command_col="V", command_unit="volts", speed_col="w",
                       thrust_col="T")
    with _w.catch_warnings():
        _w.simplefilter("ignore")
        with pytest.raises(ValueError, match="not uniformly sampled.*--resample"):
            run_fit([tmp_path / "jit.csv"], "first-order", opts)
        out = run_fit([tmp_path / "jit.csv"], "first-order", opts, resample=True)
    tau = next(v for k, v in out.parameters().items() if k.endswith("time_constant"))
    assert tau["estimate"] == pytest.approx(0.05, rel=0.05)
