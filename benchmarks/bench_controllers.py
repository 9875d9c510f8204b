"""Controller blocks in the mission loop: what a user controller costs against the built-in PID.

The BlueROV2 flies the 600 s square laps of ``bench_vehicle`` (dt = 0.01 s, 60,000 control steps)
with:

- ``builtin_pid``: the built-in PID DP (``fly``, the cached default kernel) — the reference;
- ``pid_block``: the same PID passed as a ``Controller`` (the loop compiled around it) — the
  acceptance line "PID as a user Controller vs built-in, single mission" (within 10 %);
- ``user_pd_numba``: a PD written outside uuvid, ``@njit``-compiled;
- ``user_pd_python``: the same PD as a plain Python callable (``numba.objmode`` each step);
- ``lqr_thrust_output``: the hover LQI, a controller that outputs per-thruster thrust.

Each case reports its flight time (best of a few), the one-off compile time of its loop, and the
ratio to the built-in PID measured in the same process.

Batch (:func:`batch_controllers`): 64 perturbed BlueROV2s fly the square through the SIMD kernel
with the built-in PID (the reference), with the PID as a user ``Controller`` called per lane in
the same kernel, and with that controller through the per-vehicle compiled loop
(``vehicle_sim.run_batch``, what user controllers flew before the kernel took them).
"""

from __future__ import annotations

import json
from pathlib import Path

from uuvid.simulate.control.blocks import Controller
from uuvid.simulate.control.lqr import lqr
from uuvid.simulate.control.pid import pid
from uuvid.simulate.vehicle_sim import fly_mission, setup_mission
from uuvid.vehicle.definition import load_vehicle


def user_pd():
    """A body-frame PD written outside uuvid: the example controller file
    (:func:`uuvid.simulate.control.files.write_example`), its ``body_pd`` (numba)."""
    import tempfile

    from uuvid.simulate.control.files import load_factory, write_example

    path = write_example(Path(tempfile.mkdtemp(prefix="uuvid-bench-")) / "bench_pd.py")
    return load_factory(path, "body_pd")


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
    gains = [60.0, 60.0, 60.0, 80.0, 80.0, 80.0, 10.0, 8.0]  # kp, kd (surge, sway, heave), yaw
    pd = user_pd()
    setups = {
        "builtin_pid": (base, repeats),
        "pid_block": (setup_mission(vehicle, mission, t_end=sim_time, controller=pid(base.gains)),
                      repeats),
        "user_pd_numba": (setup_mission(vehicle, mission, t_end=sim_time, controller=Controller(
            pd, gains, [], "PD (numba)")), repeats),
        "user_pd_python": (setup_mission(vehicle, mission, t_end=sim_time, controller=Controller(
            pd.py_func, gains, [], "PD (Python)")), 1),
        "lqr_thrust_output": (setup_mission(vehicle, mission, t_end=sim_time,
                                            controller=lqr(vehicle)), repeats),
    }
    labels = {"pid_block": "PID as a user Controller vs built-in, single mission"}
    times = {k: _time(s, n) for k, (s, n) in setups.items()}
    ref = times["builtin_pid"][0]
    steps = base.t.size
    out = []
    for k, (wall, comp, summ) in times.items():
        out.append({"case": labels.get(k, f"bluerov2_{sim_time:g}s_{k}"), "key": k,
                    "controller": summ["controller"],
                    "sim_time_s": sim_time, "time_s": wall, "compile_time_s": comp,
                    "steps_per_s": steps / wall, "real_time_factor": sim_time / wall,
                    "us_per_control_step": 1e6 * wall / steps,
                    "reference": "built-in PID DP loop (fly), same process",
                    "reference_time_s": ref, "ratio": wall / ref,
                    "max_tracking_error_m": summ["max_tracking_error_m"]})
    out[1]["within_10_percent_of_builtin"] = bool(out[1]["ratio"] <= 1.10)
    return out


def batch_controllers(runs: int = 64, repeats: int = 3) -> list[dict]:
    """The SIMD batch kernel with the PID built in, the PID as a user controller in the kernel,
    and that controller through the per-vehicle loop (ratios to the first, same process)."""
    import time

    import numpy as np

    from uuvid.simulate.batch import fast_path_reason, perturb_batch, run_batch_fast
    from uuvid.simulate.reference import square_mission
    from uuvid.simulate.vehicle_sim import run_batch

    vehicle = load_vehicle("bluerov2")
    base = setup_mission(vehicle, square_mission())
    user = setup_mission(vehicle, square_mission(), controller=pid(base.gains))
    VP, TP, VC = perturb_batch(base, np.random.default_rng(0), runs)
    cases = {
        "builtin_pid_simd": lambda: run_batch_fast(base, VP, TP, VC),
        "user_pid_simd": lambda: run_batch_fast(user, VP, TP, VC),
        "user_pid_per_vehicle_loop": lambda: run_batch(user, VP, TP, VC),
    }
    labels = {"user_pid_simd": "PID as a user Controller in the SIMD kernel vs built-in, batch",
              "user_pid_per_vehicle_loop": "PID as a user Controller, per-vehicle loop vs "
                                           "built-in SIMD, batch"}
    res = {}
    for k, f in cases.items():
        t0 = time.perf_counter()
        first = f()
        first_s = time.perf_counter() - t0
        best = min(_timed(f) for _ in range(repeats))
        res[k] = (best, first_s, first)
    ref = res["builtin_pid_simd"][0]
    steps = base.t.size
    out = []
    for k, (wall, first_s, o) in res.items():
        out.append({"case": labels.get(k, f"bluerov2_square_{runs}_runs_{k}"), "key": k,
                    "runs": runs, "time_s": wall, "first_call_s": first_s,
                    "vehicle_steps_per_s": runs * steps / wall,
                    "reference": "run_batch_fast with the built-in PID, same process",
                    "reference_time_s": ref, "ratio": wall / ref,
                    "max_rel_diff_vs_reference": float(np.max(
                        np.abs(o[:, :5] - res["builtin_pid_simd"][2][:, :5])
                        / np.maximum(np.abs(res["builtin_pid_simd"][2][:, :5]), 1e-300)))})
    out[1]["kernel"] = "simd" if fast_path_reason(user) is None else fast_path_reason(user)
    out[2]["simd_speedup_over_per_vehicle_loop"] = out[2]["time_s"] / out[1]["time_s"]
    return out


def _timed(f) -> float:
    import time

    t0 = time.perf_counter()
    f()
    return time.perf_counter() - t0


def run_all() -> dict:
    return {"controllers": controllers(), "controllers_batch": batch_controllers()}


if __name__ == "__main__":
    print(json.dumps(run_all(), indent=2))
