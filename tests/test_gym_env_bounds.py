"""The Gym environments refuse, in __init__, settings whose step() would run for minutes in a compiled
loop no interrupt stops, a copy count whose spaces do not fit in memory, and a vehicle argument of
another type (named, not an AttributeError)."""

from __future__ import annotations

import pytest

pytest.importorskip("gymnasium")

from uuvid.simulate import gym_env  # noqa: E402
from uuvid.simulate.gym_env import StationKeepingEnv, StationKeepingVectorEnv  # noqa: E402


def test_substeps_bounded():
    with pytest.raises(ValueError, match=r"^substeps = 1,000,000,000: expected .* of at most 10,000; "
                       "a step of dt/10,000 buys RK4 no accuracy"):
        StationKeepingEnv("bluerov2", substeps=10**9)


def test_dt_bounded_below():
    with pytest.raises(ValueError, match="dt must be at least"):
        StationKeepingEnv("bluerov2", dt=1e-9)
    StationKeepingEnv("bluerov2", dt=gym_env.MIN_DT, substeps=1)  # the smallest is taken


def test_num_envs_bounded_by_memory_before_allocating(monkeypatch):
    import uuvid.simulate.footprint as fp

    def no_batch(*a, **k):  # gymnasium's batch_space would allocate the bounds first
        raise AssertionError("batch_space called")

    monkeypatch.setattr(gym_env, "batch_space", no_batch)
    with pytest.raises(ValueError, match=r"num_envs = 1,000,000,000 copies .* at most"):
        StationKeepingVectorEnv("bluerov2", num_envs=10**9)
    monkeypatch.setattr(fp, "flight_memory_limit", lambda: 1e6)
    with pytest.raises(ValueError, match="num_envs"):
        StationKeepingVectorEnv("bluerov2", num_envs=1000)


def test_vector_env_of_valid_size_still_built():
    env = StationKeepingVectorEnv("bluerov2", num_envs=3)
    assert env.observation_space.shape[0] == 3


@pytest.mark.parametrize("bad", [None, 3.0, "chain"])
def test_vehicle_type_named(bad):
    if bad == "chain":
        from uuvid.vehicle.definition import load_vehicle

        bad = load_vehicle("bluerov2").thruster_chain(0)
    with pytest.raises(TypeError, match="vehicle: expected a preset name"):
        StationKeepingEnv(bad)
    with pytest.raises(TypeError, match="vehicle: expected a preset name"):
        StationKeepingVectorEnv(bad, num_envs=2)
