"""Vehicle simulation benchmarks: the compiled mission loop against the practical limit.

``simulate``: the BlueROV2 (6 T200 thrusters with first-order dynamics, PID DP, dt = 0.01 s) flies
square laps for 600 s of simulated time.  The reference is the minimal numba RK4 kernel of the
same closed loop (``minimal_kernel.py``: what one would hand-write for this one configuration),
over the whole mission, in interleaved pairs; its trajectory is checked against ours (~1e-4 m).

``batch``: 1,000 BlueROV2s with perturbed parameters fly the square mission in parallel.
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from uuvid.simulate import vehicle_sim
from uuvid.simulate.reference import WaypointMission, square_mission
from uuvid.simulate.vehicle_sim import fly_mission, setup_mission
from uuvid.vehicle.definition import load_vehicle
from uuvid.vehicle.model import rotation_reference, vehicle_rhs_reference

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:  # the sibling modules, also when loaded by file (uuvid bench)
    sys.path.insert(0, _HERE)

import minimal_kernel  # noqa: E402
from _timing import interleaved  # noqa: E402


def laps_mission(laps: int = 4) -> WaypointMission:
    sq = square_mission(hold=0.0)
    wps = list(sq.waypoints[:2])
    for _ in range(laps):
        wps.extend(sq.waypoints[2:-2])
    wps.extend(sq.waypoints[-2:])
    return WaypointMission(tuple(wps), speed=0.5, vertical_speed=0.25, hold=600.0, name="square laps")


def numpy_reference(setup, steps: int) -> np.ndarray:
    """The same closed loop stepped in plain Python/NumPy (one step per loop iteration)."""
    s, b = setup, setup.bank
    params = s.vehicle.params
    gains = s.gains.to_array()
    kp, ki, kd, tmax, ilim = gains[0], gains[1], gains[2], gains[3], gains[4]
    T = s.alloc[3:3 + b.n * 6].reshape(b.n, 6)
    lo = s.alloc[3 + b.n * 6:3 + b.n * 7]
    hi = s.alloc[3 + b.n * 7:3 + b.n * 8]
    chain = b.chains[0]
    esc, motor, qmap = chain.blocks
    z = s.z0()
    x = z[:13].copy()
    w = np.zeros(b.n)  # motor speeds
    integ = np.zeros(4)
    ref_pos, ref_vel, ref_yaw, ref_rate = s.ref
    h = s.dt
    out = np.empty((steps, 13))
    for k in range(steps):
        out[k] = x
        q = x[3:7]
        R = rotation_reference(q)
        e = np.empty(4)
        ed = np.empty(4)
        e[:3] = R.T @ (ref_pos[k] - x[:3])
        ed[:3] = R.T @ ref_vel[k] - x[7:10]
        yaw = math.atan2(2 * (q[0] * q[3] + q[1] * q[2]), 1 - 2 * (q[2]**2 + q[3]**2))
        e[3] = (ref_yaw[k] - yaw + math.pi) % (2 * math.pi) - math.pi
        ed[3] = ref_rate[k] - x[12]
        u_un = kp * e + ki * integ + kd * ed
        sat = (np.abs(u_un) >= tmax) & (u_un * e > 0)
        integ = np.where(sat, integ, integ + e * h)
        lim = np.where(ki > 0, ilim / np.where(ki > 0, ki, 1.0), np.inf)
        integ = np.clip(integ, -lim, lim)
        u = np.clip(kp * e + ki * integ + kd * ed, -tmax, tmax)
        tau_des = np.zeros(6)
        tau_des[[0, 1, 2, 5]] = u
        f = T @ tau_des
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(f > hi, hi / f, np.where(f < lo, lo / f, 1.0))
        f = f * min(1.0, float(np.min(r)))
        cmd = np.array([np.interp(f[i], b.inv_thrust[i], b.inv_command[i]) for i in range(b.n)])
        target = motor.gain * esc.voltage(cmd)
        def thrust_at(tt, w=w, target=target):
            ws = target + (w - target) * math.exp(-tt / motor.time_constant)
            return qmap.thrust(ws)

        def rhs(xx, th):
            return vehicle_rhs_reference(xx, s.B @ th, params)

        k1 = rhs(x, thrust_at(0.0))
        k2 = rhs(x + 0.5 * h * k1, thrust_at(0.5 * h))
        k3 = rhs(x + 0.5 * h * k2, thrust_at(0.5 * h))
        k4 = rhs(x + h * k3, thrust_at(h))
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        x[3:7] /= np.linalg.norm(x[3:7])
        w = target + (w - target) * math.exp(-h / motor.time_constant)
    return out


def simulate(sim_time: float = 600.0, repeats: int = 15, budget_s: float = 40.0) -> dict:
    """``fly_mission``'s compiled loop against the minimal kernel (:mod:`minimal_kernel`) on the
    full 600 s mission, interleaved pairs.  Ours is the compiled loop called as ``fly_mission``
    calls it (the summary after it excluded), the kernel its one call; both write the states and
    thrusts of every step into preallocated arrays."""
    vehicle = load_vehicle("bluerov2")
    setup = setup_mission(vehicle, laps_mission(), t_end=sim_time)
    r = fly_mission(setup)  # load the compiled code
    Z, F = minimal_kernel.fly(setup)  # compile the kernel
    agree = float(np.max(np.abs(Z[:, :3] - r.state[:, :3])))
    # the same model: trajectories agree to ~1e-4 m (the kernel inverts the quadratic map in
    # closed form, uuvid reads its 401-point inverse table)
    assert agree < 3e-4, f"minimal kernel and fly_mission disagree by {agree:.3g} m"
    a = minimal_kernel.kernel_inputs(setup)
    ref_pos, ref_vel, ref_yaw, ref_rate = (np.ascontiguousarray(x) for x in setup.ref)
    z0 = setup.z0()

    # ours: the compiled loop exactly as fly_mission calls it (its summary afterwards excluded)
    s, b = setup, setup.bank
    N = setup.t.size
    Zo = np.empty((N, z0.size))
    Fo, FD = np.empty((N, b.n)), np.empty((N, b.n))
    TAU, SC = np.empty((N, 6)), np.empty(N)
    none3, none0 = np.zeros((0, 3)), np.zeros(0)  # no current series, ideal supply
    gains = s.gains.to_array()

    def ours():
        vehicle_sim.fly(z0, s.vp, s.B, s.alloc, s.eta_p, s.eta_n, s.dofs, b.kinds, b.poff,
                        b.params, b.soff, b.outch, b.in_ch, b.exact, b.inv_thrust, b.inv_command,
                        gains, ref_pos, ref_vel, ref_yaw, ref_rate, s.current, s.dt, s.substeps,
                        Zo, Fo, FD, TAU, SC, none3, none3, none0, np.zeros((0, 3 + b.n)))

    def kernel():
        minimal_kernel.fly_minimal(z0, a["Minv"], a["MRB"], a["MA"], a["DL"], a["DQ"], a["grav"],
                                   a["B"], a["T"], a["lo"], a["hi"], a["eta_p"], a["eta_n"], a["kq"],
                                   a["motor"], a["wlim"], a["gains"], ref_pos, ref_vel, ref_yaw,
                                   ref_rate, a["dt"], Z, F)

    t = interleaved(ours, kernel, repeats=repeats, budget_s=budget_s)
    assert np.array_equal(Zo, r.state)  # the loop timed is the one fly_mission flies
    steps = setup.t.size
    return {"case": "bluerov2_600s", "vehicle": "bluerov2", "thrusters": "6 x t200 (first-order)",
            "controller": "PID DP", "dt": setup.dt, "sim_time_s": sim_time, "steps": int(steps),
            **t, "steps_per_s": steps / t["time_s"], "real_time_factor": sim_time / t["time_s"],
            "reference": "minimal numba RK4 kernel of the same closed loop "
                         "(benchmarks/minimal_kernel.py), full mission, interleaved pairs",
            "target": "ours_over_reference <= 1.3 (cpu_ours_over_reference: the same on CPU time)",
            "reference_max_position_difference_m": agree,
            "tracking": {k: r.metrics[k] for k in ("max_tracking_error_m", "rms_tracking_error_m")}}


def batch(runs: int = 1000) -> dict:
    vehicle = load_vehicle("bluerov2")
    setup = setup_mission(vehicle, square_mission())
    rng = np.random.default_rng(0)
    try:
        from uuvid.simulate.batch import batch_throughput

        out = batch_throughput(setup, runs=runs)
        out["case"] = f"bluerov2_square_x{runs}"
        return out
    except ImportError:
        pass
    from uuvid.simulate.vehicle_sim import run_batch

    base = setup.vp
    VP = np.tile(base, (runs, 1))
    run_batch(setup, VP[:4])
    t0 = time.perf_counter()
    run_batch(setup, VP)
    wall = time.perf_counter() - t0
    del rng
    return {"case": f"bluerov2_square_x{runs}", "runs": runs, "steps": int(setup.t.size),
            "wall_s": wall, "vehicle_steps_per_s": runs * setup.t.size / wall}


def run_all() -> dict:
    return {"simulate": [simulate()], "batch": [batch()]}


if __name__ == "__main__":
    print(json.dumps(run_all(), indent=2))
