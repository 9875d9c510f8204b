"""Thruster-dynamics benchmarks: Healey's two-state thruster, simulated and identified.

Run standalone (``python benchmarks/bench_dynamics.py``) or through ``uuvid bench``.

Cases
    healey_simulate_6s_1kHz
        The driver + two-state chain of :func:`reference_two_state_thruster` under a bench-shaped
        6 s command at 1 kHz.  Ours: the compiled chain RK4 (:meth:`ThrusterChain.simulate`, one
        RK4 step per sample).  Reference: ``scipy.integrate.solve_ivp`` (RK45, rtol 1e-6, max
        step 1 ms) on the chain's public right-hand side with the command held per sample.
    healey_joint_fit_2runs
        Dead bands, dynamics and thrust map from the ±2 V records (speed and thrust, 1 kHz).
        Ours: :func:`uuvid.identify.thruster.dynamic_select.fit_dynamics` (noise estimated and reweighted,
        each record simulated once for both channels).  Reference: ``least_squares`` with its
        defaults on a residual that calls :meth:`ThrusterChain.simulate` per record and channel,
        weighted by the *true* noise (which a user would not know), same start values.
"""

from __future__ import annotations

import json
import time

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import least_squares

from uuvid.identify.thruster.dynamic import parse_free, set_parameter
from uuvid.identify.thruster.dynamic_select import (
    Structure,
    _guess,
    _template,
    fit_dynamics,
    reference_two_state_thruster,
    synthetic_experiments,
)

NOISE = (1.0, 0.15)


def _timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def simulate_case(repeat: int = 5) -> dict:
    chain = reference_two_state_thruster()
    e = synthetic_experiments(chain, (3.0,), both_directions=False, noise=(0.0, 0.0))[0]
    dt = float(e.t[1] - e.t[0])
    chain.simulate(e.u, e.t[-1], dt=dt, substeps=1)  # compile / load the cache
    runs = [_timed(lambda: chain.simulate(e.u, e.t[-1], dt=dt, substeps=1)) for _ in range(repeat)]
    ours_t, r = min(runs, key=lambda x: x[0])
    f = chain.rhs()

    def held(t, x):
        k = min(int(t / dt + 1e-9), e.u.size - 1)
        return f(t, x, e.u[k])

    t0 = time.perf_counter()
    sol = solve_ivp(held, (0.0, e.t[-1]), np.zeros(chain.n_states), t_eval=e.t, rtol=1e-6,
                    max_step=dt)
    ref_t = time.perf_counter() - t0
    return {"case": "healey_simulate_6s_1kHz", "time_s": ours_t, "reference_time_s": ref_t,
            "ratio": ref_t / ours_t, "reference": "solve_ivp RK45 rtol 1e-6, max_step 1 ms",
            "max_speed_difference_rad_s": float(np.max(np.abs(sol.y[0] - r["prop_speed"])))}


def fit_case() -> dict:
    recs = [e for e in synthetic_experiments(reference_two_state_thruster(), (2.0,), seed=7)]
    ours_t, f = _timed(lambda: fit_dynamics(recs, "healey"))
    chain, free, bounds, _, _ = _template(Structure("healey"), _guess(recs, 0.0), True, 0.0, np.inf)
    fps = parse_free(chain, free)
    x0 = np.array([p.value_in(chain) for p in fps])
    dt = float(recs[0].t[1] - recs[0].t[0])

    def residual(theta):
        c = set_parameter(chain, list(zip(fps, theta)))
        out = []
        for e in recs:
            for ch, y, s in (("prop_speed", e.speed, NOISE[0]), ("thrust", e.thrust, NOISE[1])):
                out.append((c.simulate(e.u, e.t[-1], dt=dt, substeps=1)[ch] - y) / s)
        return np.concatenate(out)

    lo = np.zeros_like(x0)
    t0 = time.perf_counter()
    sol = least_squares(residual, x0, bounds=(lo, np.full_like(x0, np.inf)))
    ref_t = time.perf_counter() - t0
    ours = np.array([f.fit.values[p.name] for p in fps])
    return {"case": "healey_joint_fit_2runs", "time_s": ours_t, "reference_time_s": ref_t,
            "ratio": ref_t / ours_t, "reference": "least_squares defaults, ThrusterChain.simulate "
            "per record and channel, true noise weights", "ours_nfev": f.fit.extra.get("nfev"),
            "reference_nfev": int(sol.nfev),
            "max_rel_difference": float(np.max(np.abs(sol.x - ours) / np.abs(ours)))}


def run_all() -> dict:
    return {"dynamics": [simulate_case(), fit_case()]}


if __name__ == "__main__":
    print(json.dumps(run_all(), indent=2))
