"""Thruster benchmarks: compiled chain simulation against ``scipy.integrate.solve_ivp``.

Run standalone (``python benchmarks/bench_thruster.py``) or through ``uuvid bench``.  Each case
times our implementation and a plain reference on the same model in the same process and reports
the ratio (reference time / our time).
"""

from __future__ import annotations

import json
import time

import numpy as np
from scipy.integrate import solve_ivp

from uuvid.thruster.presets import auv2_rig_chain, laidani_chain


def _best_of(fn, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def mclean_step(duration: float = 10.0, dt: float = 1e-3, substeps: int = 1, repeat: int = 3) -> dict:
    """A 10 s, 24 V step of the McLean rig chain: compiled RK4 (h = dt/substeps) vs solve_ivp
    (LSODA, rtol 1e-8); the agreement is measured on every sample of the first second (the
    transient) and every 100th after."""
    chain = auv2_rig_chain()
    chain.simulate(24.0, 0.01, dt=dt, substeps=substeps)  # compile / load the numba cache
    ours = _best_of(lambda: chain.simulate(24.0, duration, dt=dt, substeps=substeps), repeat)
    f = chain.rhs()
    t_eval = np.arange(int(round(duration / dt)) + 1) * dt

    def reference():
        return solve_ivp(
            lambda t, x: f(t, x, 24.0),
            (0.0, duration),
            np.zeros(chain.n_states),
            method="LSODA",
            rtol=1e-8,
            atol=1e-10,
            t_eval=t_eval,
        )

    ref = _best_of(reference, 1)
    a = chain.simulate(24.0, duration, dt=dt, substeps=substeps)["thrust"]
    sol = reference()
    n1 = int(round(1.0 / dt))
    idx = np.concatenate([np.arange(min(n1, a.size)), np.arange(n1, a.size, 100)])
    b = np.array([chain.evaluate(sol.y[:, k], 24.0)[1]["thrust"] for k in idx])
    err = float(np.max(np.abs(a[idx] - b)) / np.max(np.abs(a)))
    return {
        "case": "mclean_step_10s",
        "time_s": ours,
        "reference": "solve_ivp LSODA rtol=1e-8",
        "step_s": dt / substeps,
        "reference_time_s": ref,
        "ratio": ref / ours,
        "max_rel_difference": err,
        "samples": int(t_eval.size),
    }


def pwm_sweep(
    points: int = 10_000, reference_points: int = 40, settle: float = 0.25, dt: float = 1e-3
) -> dict:
    """Steady thrust at 10⁴ PWM levels of the Laidani chain, each simulated to rest.

    Ours: every level in one parallel compiled call.  Reference: solve_ivp per level, timed on
    ``reference_points`` levels and scaled to all of them (stated in the output).
    """
    chain = laidani_chain()
    pwm = np.linspace(1000.0, 2000.0, points)
    chain.sweep(pwm[:4], settle_time=settle, dt=dt)
    ours = _best_of(lambda: chain.sweep(pwm, settle_time=settle, dt=dt), 3)
    f = chain.rhs()
    sub = pwm[:: max(1, points // reference_points)][:reference_points]

    def reference():
        out = []
        for u in sub:
            sol = solve_ivp(
                lambda t, x, u=u: f(t, x, u),
                (0.0, settle),
                np.zeros(chain.n_states),
                method="LSODA",
                rtol=1e-8,
                atol=1e-10,
            )
            out.append(chain.evaluate(sol.y[:, -1], u)[1]["thrust"])
        return out

    t0 = time.perf_counter()
    ref_vals = reference()
    ref = (time.perf_counter() - t0) * points / sub.size
    ours_vals = chain.sweep(sub, settle_time=settle, dt=dt).final
    err = float(np.max(np.abs(np.array(ref_vals) - ours_vals)))
    return {
        "case": "pwm_sweep_1e4",
        "time_s": ours,
        "reference": "solve_ivp LSODA per level",
        "reference_time_s": ref,
        "reference_points_timed": int(sub.size),
        "ratio": ref / ours,
        "max_abs_difference_N": err,
        "points": points,
    }


def run_all() -> dict:
    return {"thruster": [mclean_step(), pwm_sweep()]}


if __name__ == "__main__":
    print(json.dumps(run_all(), indent=2))
