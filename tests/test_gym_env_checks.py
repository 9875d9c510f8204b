"""Gymnasium environments: bad actions, options and call orders are refused with a named reason."""

import math
import re
import warnings

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

from gymnasium.error import ResetNeeded  # noqa: E402

from uuvid.simulate.gym_env import StationKeepingEnv, StationKeepingVectorEnv  # noqa: E402


def _env(**kw):
    env = StationKeepingEnv("bluerov2", **kw)
    env.reset(seed=0)
    return env


def test_nan_actions_are_refused_with_their_index():
    env = _env()
    with pytest.raises(ValueError, match=r"action contains NaN at index 0, 1, 2, 3 … \(6 in all\)"):
        env.step(np.full(6, np.nan))
    with pytest.raises(ValueError, match=r"action contains NaN at index 2$"):
        env.step(np.array([0, 0, np.nan, 0, 0, 0], np.float32))
    venv = StationKeepingVectorEnv("bluerov2", num_envs=3)
    venv.reset(seed=0)
    a = np.zeros((3, 6))
    a[1, 4] = np.nan
    with pytest.raises(ValueError, match=r"actions contains NaN at index \(1, 4\)"):
        venv.step(a)


def test_infinite_actions_are_clipped_to_the_bound():
    # documented: outside [−1, 1] (±inf too) clips, as many Gymnasium environments do
    for inf, bound in ((np.inf, 1.0), (-np.inf, -1.0)):
        o1, r1, *_ = _env().step(np.full(6, inf))
        o2, r2, *_ = _env().step(np.full(6, bound))
        np.testing.assert_array_equal(o1, o2)
        assert r1 == r2


def test_action_shapes_are_not_reshaped():
    env = _env()
    for bad in (np.zeros(5), np.zeros((1, 6)), np.zeros(7)):
        with pytest.raises(ValueError, match=re.escape(f"action shape {bad.shape}, expected (6,)")):
            env.step(bad)
    venv = StationKeepingVectorEnv("bluerov2", num_envs=4)
    venv.reset(seed=0)
    with pytest.raises(ValueError, match=r"actions shape \(6, 4\), expected \(4, 6\)"):
        venv.step(np.zeros((6, 4)))
    with pytest.raises(ValueError, match=r"actions shape \(24,\), expected \(4, 6\)"):
        venv.step(np.zeros(24))


def test_step_before_reset_asks_for_reset():
    with pytest.raises(ResetNeeded, match=r"call reset\(\) before step\(\)"):
        StationKeepingEnv("bluerov2").step(np.zeros(6))
    with pytest.raises(ResetNeeded, match=r"call reset\(\) before step\(\)"):
        StationKeepingVectorEnv("bluerov2", num_envs=2).step(np.zeros((2, 6)))


@pytest.mark.parametrize("kw, match", [
    (dict(current=(math.nan, 0, 0)), "current must be 3 finite numbers"),
    (dict(current=(0.1, 0)), "current must be 3 finite numbers"),
    (dict(weights=(math.nan, 1, 1, 1)), "weights must be 4 finite numbers >= 0"),
    (dict(weights=(-1, 1, 1, 1)), "weights must be 4 finite numbers >= 0"),
    (dict(weights=(1, 1, 1)), "weights must be 4 finite numbers >= 0"),
    (dict(offset_range=math.nan), "offset_range must be finite numbers >= 0"),
    (dict(offset_range=-1.0), "offset_range must be finite numbers >= 0"),
    (dict(max_distance=math.nan), "max_distance must be a number > 0"),
    (dict(max_distance=0.0), "max_distance must be a number > 0"),
    (dict(acceptance_radius=-1), "acceptance_radius must be a finite number >= 0"),
    (dict(acceptance_radius=math.inf), "acceptance_radius must be a finite number >= 0"),
    (dict(current_range=math.nan), "current_range must be a finite number >= 0"),
    (dict(max_steps=2.7), r"^max_steps = 2.7: expected .*, a whole number"),
    (dict(max_steps=0), r"^max_steps = 0: expected .* >= 1"),
    (dict(substeps=1.5), r"^substeps = 1.5: expected .*, a whole number"),
    (dict(dt="0.1"), "dt must be a finite number > 0"),
    (dict(dt=math.nan), "dt must be a finite number > 0"),
    (dict(dt=-0.1), "dt must be a finite number > 0"),
    (dict(dt=1e4), r"RK4 stability bound .*need dt <= 0\.1\d* s, or substeps >= "),
    (dict(dt=0.25, substeps=1), "RK4 stability bound"),  # bluerov2's yaw at full thrust: 0.05 s
])
def test_bad_options_are_named(kw, match):
    with pytest.raises(ValueError, match=match):
        StationKeepingEnv("bluerov2", **kw)


def test_a_step_just_past_the_estimated_bound_is_said_not_refused():
    """The bound is an estimate: a step past it but within twice it (e.g. a vehicle file whose
    identified yaw inertia puts the bound just under the default 0.05 s) warns; twice it is
    refused (above)."""
    from uuvid.core.checks import InputWarning

    with pytest.warns(InputWarning, match="RK4 stability bound"):
        StationKeepingEnv("bluerov2", dt=0.1, substeps=1)


def test_good_options_still_accepted():
    StationKeepingEnv("bluerov2", max_steps=3.0, max_distance=math.inf, acceptance_radius=0.0)
    StationKeepingEnv("bluerov2", dt=0.2, substeps=4)  # same RK4 step as the default
    StationKeepingEnv("romeo", dt=0.5, substeps=1)  # a big slow vehicle takes long steps
    with pytest.raises(ValueError, match=r"^num_envs = 2.5: expected .*, a whole number"):
        StationKeepingVectorEnv("bluerov2", num_envs=2.5)


def test_the_step_limit_is_where_the_plant_blows_up():
    # bluerov2's bound (≈ 0.05 s, its yaw at full thrust): a step twice as long diverges under
    # bang-bang actions; the accepted default (dt 0.1 s, 2 substeps) stays bounded
    from uuvid.simulate.gym_env import rk4_step_limit
    from uuvid.vehicle.definition import load_vehicle

    hmax, dof, _ = rk4_step_limit(load_vehicle("bluerov2"))
    assert 0.04 < hmax < 0.06 and dof == 5
    for dt, nsub, diverges in ((0.1, 2, False), (0.2, 2, True)):
        env = StationKeepingEnv("bluerov2", max_distance=math.inf, max_steps=10**6)
        env.reset(seed=0)
        env.cfg.dt, env.cfg.nsub = dt, nsub  # past the constructor's check
        rng = np.random.default_rng(0)
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a NaN state ends the episode; step on regardless
            for _ in range(200):
                obs, *_ = env.step(rng.choice([-1.0, 1.0], size=6))
        assert (not np.all(np.abs(obs[6:]) < 100)) == diverges


def test_reset_options_are_checked():
    env = StationKeepingEnv("bluerov2")
    env.reset(seed=0, options={})
    env.reset(seed=0, options=None)
    with pytest.raises(ValueError, match=r"unknown options \['junk'\]; accepted keys: none"):
        env.reset(options={"junk": 1})
    with pytest.raises(TypeError, match="options must be None or a dict"):
        env.reset(options=[1, 2])
    venv = StationKeepingVectorEnv("bluerov2", num_envs=2)
    with pytest.raises(ValueError, match=r"unknown options \['junk'\]"):
        venv.reset(options={"junk": 1})


@pytest.mark.parametrize("kw", [dict(max_distance=0.01), dict(max_steps=1)])
def test_stepping_after_the_episode_ended_warns_once(kw):
    env = _env(**kw)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _, _, term, trunc, _ = env.step(np.zeros(6))
    assert term or trunc
    with pytest.warns(UserWarning, match=r"after the episode ended .* call reset\(\)"):
        env.step(np.zeros(6))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env.step(np.zeros(6))  # once per episode
        env.reset(seed=1)
        env.step(np.zeros(6))


@pytest.mark.parametrize("kw", [dict(max_steps="100"), dict(substeps=None), dict(max_steps=True)])
def test_a_count_that_is_no_number_is_a_type_error_naming_it(kw):
    """The env's counts are checked by the library's one check (uuvid.core.checks.count), in its
    words (``max_steps = '100': expected …``), as a mission's are."""
    name = next(iter(kw))
    with pytest.raises(TypeError, match=rf"^{name} = .*: expected .*, got "):
        StationKeepingEnv("bluerov2", **kw)
