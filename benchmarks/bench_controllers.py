"""Controller blocks in the mission loop: what a user controller costs against the built-in PID.

The BlueROV2 flies the 600 s square laps of ``bench_vehicle`` (dt = 0.01 s, 60,000 control steps)
with:

- ``builtin_pid``: the built-in PID DP (``fly``, the cached default kernel) — the reference;
- ``pid_block``: the same PID passed as a ``Controller`` (the loop compiled around it);
- ``user_pd_numba``: a PD written outside uuvid, ``@njit``-compiled;
- ``user_pd_python``: the same PD as a plain Python callable (``numba.objmode`` each step).

Each case reports its flight time (best of a few), the one-off compile time of its loop, and the
ratio to the built-in PID measured in the same process.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from numba import njit

from uuvid.simulate.control import Controller, pid
from uuvid.simulate.vehicle_sim import fly_mission, setup_mission
from uuvid.vehicle.definition import load_vehicle


def user_pd(t, eta, nu, ref_pos, ref_vel, ref_yaw, ref_rate, params, state, dt, tau_out):
    """Body-frame PD on position (params[0:2]) and yaw (params[2:4])."""
    q0, q1, q2, q3 = eta[3], eta[4], eta[5], eta[6]
    R = ((1 - 2 * (q2 * q2 + q3 * q3), 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)),
         (2 * (q1 * q2 + q0 * q3), 1 - 2 * (q1 * q1 + q3 * q3), 2 * (q2 * q3 - q0 * q1)),
         (2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1), 1 - 2 * (q1 * q1 + q2 * q2)))
    for j in range(6):
        tau_out[j] = 0.0
    for i in range(3):
        e = 0.0
        v = 0.0
        for k in range(3):
            e += R[k][i] * (ref_pos[k] - eta[k])
            v += R[k][i] * ref_vel[k]
        tau_out[i] = params[0] * e + params[1] * (v - nu[i])
    yaw = math.atan2(2 * (q0 * q3 + q1 * q2), 1 - 2 * (q2 * q2 + q3 * q3))
    tau_out[5] = (params[2] * ((ref_yaw - yaw + math.pi) % (2 * math.pi) - math.pi)
                  + params[3] * (ref_rate - nu[5]))


def _laps():
    import importlib.util

    spec = importlib.util.spec_from_file_location("uuvid_benchmarks_bench_vehicle_c",
                                                  Path(__file__).with_name("bench_vehicle.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)  # type: ignore[union-attr]
    return mod.laps_mission()


def _time(setup, repeats: int) -> tuple[float, float, dict]:
    r = fly_mission(setup)  # compiles (or loads) the loop on its first call
    compile_s = r.metrics["compile_time_s"]
    best = r.metrics["wall_time_s"]
    for _ in range(repeats - 1):
        r = fly_mission(setup)
        best = min(best, r.metrics["wall_time_s"])
    return best, compile_s, r.metrics


def controllers(sim_time: float = 600.0, repeats: int = 3) -> list[dict]:
    vehicle = load_vehicle("bluerov2")
    mission = _laps()
    base = setup_mission(vehicle, mission, t_end=sim_time)
    gains = [60.0, 80.0, 10.0, 8.0]
    setups = {
        "builtin_pid": (base, repeats),
        "pid_block": (setup_mission(vehicle, mission, t_end=sim_time, controller=pid(base.gains)),
                      repeats),
        "user_pd_numba": (setup_mission(vehicle, mission, t_end=sim_time, controller=Controller(
            njit(user_pd), gains, [], "PD (numba)")), repeats),
        "user_pd_python": (setup_mission(vehicle, mission, t_end=sim_time, controller=Controller(
            user_pd, gains, [], "PD (Python)")), 1),
    }
    times = {k: _time(s, n) for k, (s, n) in setups.items()}
    ref = times["builtin_pid"][0]
    steps = base.t.size
    out = []
    for k, (wall, comp, summ) in times.items():
        out.append({"case": f"bluerov2_{sim_time:g}s_{k}", "controller": summ["controller"],
                    "sim_time_s": sim_time, "time_s": wall, "compile_time_s": comp,
                    "steps_per_s": steps / wall, "real_time_factor": sim_time / wall,
                    "us_per_control_step": 1e6 * wall / steps,
                    "reference": "built-in PID DP loop (fly), same process",
                    "reference_time_s": ref, "ratio": wall / ref,
                    "max_tracking_error_m": summ["max_tracking_error_m"]})
    out[1]["within_10_percent_of_builtin"] = bool(out[1]["ratio"] <= 1.10)
    return out


def run_all() -> dict:
    return {"controllers": controllers()}


if __name__ == "__main__":
    print(json.dumps(run_all(), indent=2))
