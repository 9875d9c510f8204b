"""Gymnasium environment benchmark: the vectorised station-keeping environment against a plain
per-environment Python loop.

``gym_vector``: ``num_envs`` BlueROV2s (6 thrusters, dt = 0.1 s, 2 RK4 substeps) stepped through
the public Python API ``StationKeepingVectorEnv.step`` (one parallel compiled call per step).
The reference steps the same number of single ``StationKeepingEnv`` instances one after the other
in a Python loop (each step is itself compiled; the loop and the per-call overhead are Python's),
from the same initial states with the same actions; the largest state difference between the
two is reported (the same kernel: it must be 0).  Target (issue 12): ≥ 10⁵ vehicle-steps/s.
"""

from __future__ import annotations

import json
import time

import numpy as np


def gym_vector(num_envs: int = 1024, steps: int = 100, reference_envs: int = 64,
               reference_steps: int = 50, repeats: int = 3) -> dict:
    try:
        from uuvid.simulate.gym_env import StationKeepingEnv, StationKeepingVectorEnv
    except ImportError as e:
        nan = float("nan")
        return {"case": "gym_vector (skipped: gymnasium not installed)", "skipped": str(e),
                "time_s": nan, "reference_time_s": nan, "ratio": nan}
    venv = StationKeepingVectorEnv("bluerov2", num_envs=num_envs, max_steps=10**9)
    venv.reset(seed=0)
    rng = np.random.default_rng(1)
    acts = rng.uniform(-0.2, 0.2, size=(steps, num_envs, venv.cfg.n_act)).astype(np.float32)
    venv.step(acts[0])  # load the compiled code
    best = float("inf")
    for _ in range(repeats):
        venv.reset(seed=0)
        t0 = time.perf_counter()
        for k in range(steps):
            venv.step(acts[k])
        best = min(best, time.perf_counter() - t0)
    ours = num_envs * steps / best
    # reference: single environments in a Python loop, started where the vector copies start
    venv.reset(seed=0)
    start = venv.states[:reference_envs]
    envs = []
    for i in range(reference_envs):
        e = StationKeepingEnv("bluerov2", max_steps=10**9)
        e.reset(seed=0)
        e._z[:] = start[i]
        envs.append(e)
    envs[0].step(acts[0, 0])
    envs[0]._z[:] = start[0]
    t0 = time.perf_counter()
    for k in range(reference_steps):
        for i, e in enumerate(envs):
            e.step(acts[k, i])
    ref_wall = time.perf_counter() - t0
    ref = reference_envs * reference_steps / ref_wall
    for k in range(reference_steps):
        venv.step(acts[k])
    diff = float(np.max(np.abs(venv.states[:reference_envs] - np.array([e.state for e in envs]))))
    return {"case": f"bluerov2_station_keeping_x{num_envs}", "num_envs": num_envs,
            "steps": steps, "dt": venv.cfg.dt, "substeps": venv.cfg.nsub, "time_s": best,
            "vehicle_steps_per_s": ours, "target_vehicle_steps_per_s": 1e5,
            "meets_target": bool(ours >= 1e5),
            "reference": f"{reference_envs} single StationKeepingEnv stepped in a Python loop",
            "reference_vehicle_steps_per_s": ref, "reference_time_s": num_envs * steps / ref,
            "ratio": ours / ref, "reference_max_state_difference": diff}


def run_all() -> dict:
    return {"gym": [gym_vector()]}


if __name__ == "__main__":
    print(json.dumps(run_all(), indent=2))
