"""Gymnasium environments: API conformance, single = vector, autoreset, reward and sign conventions."""

import warnings

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

from gymnasium.utils.env_checker import check_env  # noqa: E402

from uuvid.simulate.gym_env import StationKeepingEnv, StationKeepingVectorEnv  # noqa: E402


@pytest.mark.parametrize("kw", [dict(vehicle="bluerov2"),
                                dict(vehicle="romeo", action="force", current_range=0.2,
                                     waypoints=[[0, 0, 0, 0], [3, 1, 1, 1.0]])])
def test_check_env_passes(kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # unbounded Box and 'no spec' notes are not failures
        check_env(StationKeepingEnv(**kw))


def test_vector_env_steps_the_same_kernel_as_the_single_env():
    N = 5
    venv = StationKeepingVectorEnv("bluerov2", num_envs=N, current=(0.1, -0.05, 0.0))
    obs, _ = venv.reset(seed=3)
    assert venv.observation_space.shape == (N, 12) and venv.action_space.shape == (N, 6)
    assert obs.shape == (N, 12) and obs.dtype == np.float32
    singles = []
    for i in range(N):
        e = StationKeepingEnv("bluerov2", current=(0.1, -0.05, 0.0))
        e.reset(seed=0)
        e._z[:] = venv.states[i]
        singles.append(e)
    rng = np.random.default_rng(0)
    for _ in range(20):
        a = rng.uniform(-1, 1, size=(N, 6)).astype(np.float32)
        vo, vr, _, _, _ = venv.step(a)
        for i, e in enumerate(singles):
            so, sr, _, _, _ = e.step(a[i])
            np.testing.assert_array_equal(vo[i], so)
            assert vr[i] == sr
    np.testing.assert_array_equal(venv.states, np.array([e.state for e in singles]))


def test_vector_env_next_step_autoreset():
    venv = StationKeepingVectorEnv("bluerov2", num_envs=3, max_steps=4)
    venv.reset(seed=1)
    a = np.zeros((3, 6), np.float32)
    for k in range(4):
        obs, rew, term, trunc, _ = venv.step(a)
        assert trunc.all() == (k == 3) and not term.any()
    obs, rew, term, trunc, _ = venv.step(a)  # the reset step: new start, no reward, not done
    assert np.all(rew == 0) and not term.any() and not trunc.any()
    assert np.all(np.abs(venv.states[:, 7:]) == 0)  # at rest again
    obs2, *_ = venv.step(a)
    assert not np.array_equal(obs, obs2)


def test_reward_is_the_documented_cost():
    env = StationKeepingEnv("bluerov2", weights=(1.0, 0.5, 0.1, 0.05))
    env.reset(seed=2)
    a = np.array([0.3, -0.2, 0.1, 0.0, 0.5, -0.5], np.float32)
    obs, rew, *_ = env.step(a)
    o = obs.astype(float)
    cost = (np.linalg.norm(o[0:3]) + 0.5 * np.linalg.norm(o[3:6]) + 0.1 * np.linalg.norm(o[6:12])
            + 0.05 * np.mean(a.astype(float) ** 2))
    assert rew == pytest.approx(-cost * env.cfg.dt, rel=1e-5)


def test_thrust_actions_use_the_asymmetric_limits():
    # a = +1 / −1 on the two vertical thrusters (they push down, +z) from rest: after one short
    # step the heave acceleration is (B f + restoring)/(m + Z_ẇ) with f = f_max or f_min
    from uuvid.vehicle.model import vehicle_rhs_reference

    for sign, col in ((1.0, 1), (-1.0, 0)):
        env = StationKeepingEnv("bluerov2", dt=1e-4, substeps=1, offset_range=0.0)
        env.reset(seed=0)
        x0 = env.state
        a = np.zeros(6, np.float32)
        a[4:] = sign
        env.step(a)
        f = np.zeros(6)
        f[4:] = env.cfg.vehicle.layout.limits[4:, col]
        expected = vehicle_rhs_reference(x0, env.cfg.vehicle.B @ f, env.cfg.vehicle.params)[9]
        assert (env.state[9] - x0[9]) / 1e-4 == pytest.approx(expected, rel=1e-3)


def test_a_pd_policy_on_the_observation_holds_station():
    # the observation's body-frame error and the force actions share sign conventions: a PD
    # law on them brings the vehicle from a 2 m offset to the station
    env = StationKeepingEnv("bluerov2", action="force", offset_range=(2.0, 2.0, 1.0, 0.5))
    obs, _ = env.reset(seed=4)
    e0 = np.linalg.norm(obs[:3])
    for _ in range(300):
        e, att, nu = obs[:3], obs[3:6], obs[6:]
        a = np.clip([1.0 * e[0] - 2 * nu[0], 1.0 * e[1] - 2 * nu[1], 1.0 * e[2] - 2 * nu[2],
                     2.0 * att[2] - 2 * nu[5]], -1, 1)
        obs, r, term, trunc, _ = env.step(a.astype(np.float32))
        assert not term
    assert e0 > 1.0 and np.linalg.norm(obs[:3]) < 0.1 * e0


def test_waypoints_advance():
    env = StationKeepingEnv("bluerov2", action="force", offset_range=0.0, acceptance_radius=0.3,
                            waypoints=[[0, 0, 0, 0], [1.0, 0, 0, 0]])
    obs, info = env.reset(seed=0)
    obs, _, _, _, info = env.step(np.zeros(4, np.float32))
    assert info["waypoint"] == 1 and obs[0] == pytest.approx(1.0, abs=0.05)


def test_bad_vehicle_options_are_named():
    with pytest.raises(ValueError, match="action must be"):
        StationKeepingEnv("bluerov2", action="rpm")
    with pytest.raises(TypeError, match="unknown options"):
        StationKeepingEnv("bluerov2", dtt=0.1)
    with pytest.raises(ValueError, match="waypoints"):
        StationKeepingEnv("bluerov2", waypoints=[[0, 0, 0]])
