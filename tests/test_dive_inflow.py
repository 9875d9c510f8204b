"""The inflow coefficient identified jointly from a dive (issue 21, item 3).

Evidence: synthetic piloted dives flown by the project's 6-DOF model with thrust that falls with
the advance speed (the linear inflow form ``T_i = T_i,bollard − k_a |Ω_i| u_a,i``, Healey et al.
1995; ``synthetic_dive(..., inflow_coefficient=k_a)``), logged as ArduSub would log them — the
forces in the log are the *bollard* ones.  Identified with inflow on, ``k_a`` and the drag come
back within 3σ over a fixed range of seeds; with inflow off, the same data make the drag absorb
the loss beyond 3σ.  The optimiser never starts at the truth: its ``k_a`` starts are 0 and the
T200 preset's value, and the dives are flown with 1.4× the preset's value.
"""

import dataclasses
import functools

import numpy as np
import pytest
from typer.testing import CliRunner

from uuvid.cli.app import app
from uuvid.identify.vehicle.dive import PARAMS_INFLOW, identify_dive, inflow_warnings
from uuvid.io.ardusub.thrust import default_t200
from uuvid.io.dive_channels import DiveDataError, inflow_gain, read_dive_channels, rotor_speeds
from uuvid.simulate.dive_replay import WindowProblem, dive_windows, replay_dive
from uuvid.simulate.dive_synth import synthetic_dive
from uuvid.thruster.inflow import advance_speeds, t200_inflow
from uuvid.vehicle.definition import load_vehicle
from uuvid.vehicle.inflow import one_dof_inflow_matrix
from uuvid.vehicle.writeback import write_identified

runner = CliRunner()
KA_T200 = t200_inflow().inflow_coefficient
KA_TRUE = 1.4 * KA_T200  # not a start value of the fit
SEEDS = range(1, 7)  # every seed of the range counts (none picked)
DRAG = ("linear", "quadratic")


# ------------------------------------------------------------------------------------------------
# the physics: c(t) from the project's advance speeds
# ------------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_one_dof_force_with_inflow_equals_bollard_force_minus_ka_c_v():
    """Σ_i B_ji (T_i,bollard − k_a |Ω_i| u_a,i) with u_a from advance_speeds for a motion along
    DOF j alone equals F_j − k_a c_j v with c_j = Σ_i G_ji |Ω_i| — for every DOF, with wake."""
    veh = load_vehicle("bluerov2")
    B = np.asarray(veh.B)
    n = B.shape[1]
    rng = np.random.default_rng(3)
    wake = rng.uniform(0.0, 0.3, n)
    veh = dataclasses.replace(veh, wake=tuple(wake))
    G = one_dof_inflow_matrix(veh)
    P = np.array([t.position for t in veh.layout])
    A = np.array([t.axis for t in veh.layout])
    T_b = rng.uniform(-30, 40, n)
    omega = rng.uniform(50, 350, n)
    ka = 0.04
    for j in range(6):
        v = rng.uniform(-1, 1)
        nu = np.zeros(6)
        nu[j] = v
        ua = advance_speeds(nu, P, A, wake)
        direct = B[j] @ (T_b - ka * omega * ua)
        assert direct == pytest.approx(B[j] @ T_b - ka * (G[j] @ omega) * v, rel=1e-12,
                                       abs=1e-12)
    # the loss always opposes the motion: G = (1 − w) B² ≥ 0 (yaw: the lever arm squared)
    assert np.all(G >= 0)
    np.testing.assert_allclose(G, (1 - wake) * B ** 2, atol=1e-15)


@pytest.mark.slow
def test_rotor_speed_is_the_physical_models_and_gain_is_G_times_it():
    df, _ = synthetic_dive(40.0, seed=2, disarmed=2.0, pwm_rate=5.0)
    veh = load_vehicle("bluerov2")
    dc = read_dive_channels(df, veh)
    t, W, how = rotor_speeds(dc)
    assert "steady rotor speed" in how
    tm = default_t200()
    keys = sorted(dc.pwm, key=int)
    volts = np.interp(t, *dc.channels["battery_V"])
    T = np.stack([tm.thrust(dc.pwm[k][1], volts) for k in keys])
    pm_kt = np.where(T >= 0, 3.6656428689377826e-4, 2.905838942560228e-4)
    # T200 physical model: T = K_T Ω|Ω| per direction
    np.testing.assert_allclose(W, np.sqrt(np.abs(T) / pm_kt), rtol=1e-6, atol=1e-6)
    tg, c, _ = inflow_gain(dc, veh, "heave")
    np.testing.assert_allclose(c, one_dof_inflow_matrix(veh)[2] @ W)
    assert np.ptp(c) > 0  # it varies with the thrust: that is what separates k_a from drag


@pytest.mark.slow
def test_window_model_with_constant_c_is_a_linear_drag_k_plus_ka_c():
    df, _ = synthetic_dive(60.0, seed=4, disarmed=2.0, pwm_rate=5.0)
    dc = read_dive_channels(df, load_vehicle("bluerov2"))
    wins, _ = dive_windows(dc, "heave", 10.0)
    c0 = 250.0
    gain = (np.array([0.0, 1e3]), np.array([c0, c0]))
    prob = WindowProblem(dc, "heave", wins, gain=gain)
    m, k, kq, b, ka = 26.0, 8.0, 49.0, -2.0, 0.03
    y0, v0 = prob.y0_meas, prob.v0_meas
    with_ka = prob.predict(np.array([m, k, kq, b, ka]), y0, v0)
    folded = prob.predict(np.array([m, k + ka * c0, kq, b]), y0, v0)
    np.testing.assert_allclose(with_ka, folded, rtol=1e-12)
    assert np.max(np.abs(with_ka - prob.predict(np.array([m, k, kq, b]), y0, v0))) > 0.05
    with pytest.raises(ValueError, match="inflow gain"):
        WindowProblem(dc, "heave", wins).predict(np.array([m, k, kq, b, ka]), y0, v0)


@pytest.mark.slow
def test_synthetic_dive_default_unchanged_and_inflow_slows_it():
    a, truth = synthetic_dive(30.0, seed=5, disarmed=2.0)
    b, _ = synthetic_dive(30.0, seed=5, disarmed=2.0, inflow_coefficient=0.0)
    assert "inflow" not in truth["heave"]
    assert a.equals(b)
    c, t2 = synthetic_dive(30.0, seed=5, disarmed=2.0, inflow_coefficient=KA_TRUE)
    assert t2["heave"]["inflow"] == KA_TRUE
    # same PWM schedule start, different motion: the loss acts
    assert not np.allclose(a["depth_m"].dropna().to_numpy(), c["depth_m"].dropna().to_numpy())


def test_inflow_warnings_name_the_confusion_with_linear_drag():
    v = dict(zip(PARAMS_INFLOW, (26.0, 8.0, 49.0, -2.0, 0.03)))
    s = dict(zip(PARAMS_INFLOW, (0.3, 0.5, 2.0, 0.02, 0.003)))
    corr = np.eye(5)
    assert inflow_warnings(v, s, corr) == []
    corr[1, 4] = corr[4, 1] = -0.97
    w = inflow_warnings(v, s, corr)
    assert len(w) == 1 and "linear drag" in w[0] and "-0.97" in w[0]
    assert any("negative" in x for x in inflow_warnings({**v, "inflow": -0.01}, s, np.eye(5)))
    assert any("poorly determined" in x for x in inflow_warnings(v, {**s, "inflow": 0.02},
                                                                 np.eye(5)))


# ------------------------------------------------------------------------------------------------
# identification over seeds
# ------------------------------------------------------------------------------------------------
@functools.cache
def _run(seed: int):
    """z-scores ``(estimate − truth)/σ`` with inflow on and off, for heave and yaw."""
    df, truth = synthetic_dive(240.0, seed=seed, pwm_rate=10.0, surge=0.0,
                               inflow_coefficient=KA_TRUE)
    on = identify_dive(df, "bluerov2", ("heave", "yaw"), inflow=True)
    off = identify_dive(df, "bluerov2", ("heave", "yaw"), inflow=False)
    z_on, z_off = {}, {}
    for dof in ("heave", "yaw"):
        e, f = on.estimates[dof], off.estimates[dof]
        assert "inflow" in e.values and "inflow" not in f.values
        z_on[dof] = {k: (e.values[k] - truth[dof][k]) / e.sigma[k] for k in ("inflow",) + DRAG}
        z_off[dof] = {k: (f.values[k] - truth[dof][k]) / f.sigma[k] for k in DRAG}
        # the optimiser did not start at the truth
        assert not any(abs(ka - KA_TRUE) < 1e-9 for ka in (0.0, KA_T200))
    return z_on, z_off


@pytest.mark.slow
@pytest.mark.parametrize("seed", SEEDS)
def test_each_seed_identifies_ka_and_drag(seed):
    z_on, z_off = _run(seed)
    for dof in ("heave", "yaw"):
        # none far off (the 3σ coverage over the seeds is the aggregate test below)
        assert all(abs(z) < 5 for z in z_on[dof].values()), (dof, z_on[dof])


@pytest.mark.slow
def test_ka_and_drag_within_3_sigma_over_seeds_and_bollard_model_is_biased():
    z_on = [z for s in SEEDS for dof in ("heave", "yaw") for z in _run(s)[0][dof].values()]
    inside = np.mean(np.abs(z_on) <= 3.0)
    assert inside >= 0.9, (inside, z_on)
    # the bollard-thrust model on the same data books the loss as drag, beyond 3σ in every dive:
    # c(t) grows with the thrust, which grows with the speed, so the loss looks mostly like
    # *quadratic* drag (the linear drag stays within a few σ, slightly low)
    for s in SEEDS:
        for dof in ("heave", "yaw"):
            z = _run(s)[1][dof]
            assert z["quadratic"] > 3.0, (s, dof, z)


# ------------------------------------------------------------------------------------------------
# result surface, write-back, replay, defaults, CLI
# ------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def dive():
    return synthetic_dive(150.0, seed=8, pwm_rate=10.0, surge=0.0, inflow_coefficient=KA_TRUE)


@pytest.fixture(scope="module")
def result(dive):
    return identify_dive(dive[0], "bluerov2", "heave", t_end=120.0, inflow=True)


@pytest.mark.slow
def test_result_shows_ka_and_the_share_of_the_apparent_drag(result, tmp_path):
    e = result.estimates["heave"]
    d = result.to_dict()["dofs"]["heave"]
    assert d["correlation"]["params"] == list(PARAMS_INFLOW)
    assert len(d["correlation"]["matrix"]) == 5 and "inflow" in d["sigma"]
    s = d["inflow"]
    assert s["loss_as_drag"] == pytest.approx(e.values["inflow"] * s["c_mean"])
    assert s["apparent_linear"] == pytest.approx(e.values["linear"] + s["loss_as_drag"])
    assert 0 < s["loss_fraction"] < 1
    text = result.summary()
    assert "inflow coefficient k_a" in text and "of the apparent linear drag" in text
    assert result.report(tmp_path / "rep").is_file()


@pytest.mark.slow
def test_written_vehicle_carries_ka_and_its_replay_uses_it(result, dive, tmp_path):
    out = result.write_vehicle(tmp_path / "mine.yaml")
    v = load_vehicle(out)
    ka = result.estimates["heave"].values["inflow"]
    assert v.one_dof["heave"].inflow_coefficient == pytest.approx(ka, rel=1e-5)
    rep = replay_dive(dive[0], v, "heave", t_start=120.0)
    assert any("k_a" in n for n in rep.notes)
    held = result.estimates["heave"].held_out["identified"]["rms"]
    assert rep.channels["depth"]["rms"] == pytest.approx(held, rel=1e-3)
    # without k_a the same numbers replay worse: the loss is part of the model
    v0 = tmp_path / "no_ka.yaml"
    ident = result.identified()
    ident["heave"]["inflow_coefficient"] = 0.0
    write_identified("bluerov2", ident, v0)
    assert replay_dive(dive[0], v0, "heave", t_start=120.0).channels["depth"]["rms"] > held
    # a file carrying k_a turns the joint fit on by default
    r2 = identify_dive(dive[0], v, "heave", t_end=120.0)
    assert "inflow" in r2.estimates["heave"].values


@pytest.mark.slow
def test_default_off_for_presets_and_needs_pwm(dive):
    df = dive[0]
    r = identify_dive(df, "bluerov2", "heave", t_end=120.0)
    assert "inflow" not in r.estimates["heave"].values
    forces_only = df.drop(columns=[c for c in df.columns if c.startswith("pwm_")])
    with pytest.raises(DiveDataError, match="servo outputs"):
        identify_dive(forces_only, "bluerov2", "heave", inflow=True)


@pytest.mark.slow
def test_cli_inflow_option(dive, tmp_path):
    p = tmp_path / "dive.csv"
    dive[0].to_csv(p, index=False)
    res = runner.invoke(app, ["vehicle", "identify", "dive", str(p), "--vehicle", "bluerov2",
                              "--dof", "heave", "--inflow", "--json"])
    assert res.exit_code == 0, res.output
    assert '"inflow"' in res.output and "loss_fraction" in res.output
    res = runner.invoke(app, ["vehicle", "identify", "dive", "--help"])
    assert "--no-inflow" in res.output
