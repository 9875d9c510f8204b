"""Identification benchmarks: our fits against what a user writes with NumPy/SciPy alone.

Run standalone (``python benchmarks/bench_identification.py``) or through ``uuvid bench``.  Each
case times our implementation and a plain reference — what a user would write with scipy alone on
the same data and the same model — in the same process, and reports the ratio (reference time /
our time) and how far the two answers are apart.

Cases
    polynomial_fit_1e5
        Laidani's degree-5 per-direction polynomial with σ on 10⁵ bench samples.  Ours:
        :func:`uuvid.identify.thruster.steady.fit_polynomial` (scaled Vandermonde, linear LS, Caccia σ).
        Reference: ``np.linalg.lstsq`` on the Vandermonde matrix in the same scaled variable
        Ω/max Ω, σ from ``s²(VᵀV)⁻¹`` — the best a user writes for a linear model; interleaved.
    nonlinear_fit_20000_blas_one_thread
        A small nonlinear fit (5 parameters, 20,000 samples) through ``nonlinear_lsq`` (one BLAS
        thread) against the same ``least_squares`` call with the BLAS threads as loaded.
    mclean_fit_3steps
        McLean's tunnel thruster seen through the rig's load cell: α_o−α_i, β_o−β_i and K_a from
        three 1.5 s voltage steps (24, 16, 8 V) sampled at 1 kHz, synthetic from the thesis's
        parameters plus 0.2 N noise.  Ours: :func:`uuvid.identify.thruster.dynamic.fit_tunnel_thruster`.
        Reference 1 (``mclean_fit_3steps``): ``least_squares`` with defaults (2-point Jacobian,
        unit ``x_scale``) calling the public :meth:`ThrusterChain.simulate` per run and evaluation.
    mclean_fit_3steps_solve_ivp
        Reference 2: ``least_squares`` with the residual integrating each run with
        ``scipy.integrate.solve_ivp`` (LSODA) on the chain's public right-hand side
        (:meth:`ThrusterChain.rhs`) — no compiled time stepping at all.  It needs rtol 1e-8 and a
        finite-difference step of 1e-4 to converge (see :func:`_plain_mclean_solve_ivp`).
"""

from __future__ import annotations

import json
import math
import sys
import warnings
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import least_squares

from uuvid.identify.fit import IdentifiabilityWarning
from uuvid.identify.thruster.dynamic import Run, fit_tunnel_thruster
from uuvid.identify.thruster.steady import fit_polynomial
from uuvid.io.bench import BenchData
from uuvid.thruster.chain import ThrusterChain
from uuvid.thruster.presets import (
    LAIDANI_POLY_FORWARD,
    LAIDANI_POLY_REVERSE,
    auv2_rig_chain,
    auv2_tunnel_thruster,
    laidani_chain,
    mclean_load_cell,
)

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:  # the sibling module, also when loaded by file (uuvid bench)
    sys.path.insert(0, _HERE)
from _timing import interleaved  # noqa: E402


# ------------------------------------------------------------------------------------------------
# (a) polynomial on 10⁵ samples
# ------------------------------------------------------------------------------------------------
def _laidani_samples(n: int, seed: int = 0) -> BenchData:
    rng = np.random.default_rng(seed)
    chain = laidani_chain()
    pwm = rng.uniform(1000.0, 2000.0, n)
    omega = chain.blocks[1].gain * chain.blocks[0].voltage(pwm)
    t = np.where(omega > 0, np.polyval(LAIDANI_POLY_FORWARD, np.abs(omega)),
                 -np.polyval(LAIDANI_POLY_REVERSE, np.abs(omega)))
    t = np.where(omega == 0, 0.0, t) + rng.normal(0.0, 0.1, n)
    return BenchData(command=pwm, thrust=t, speed=omega, source="synthetic 1e5")


def _plain_polynomial(x: np.ndarray, y: np.ndarray, degree: int):
    """What a user writes with NumPy alone for a linear model: ``np.linalg.lstsq`` on the
    Vandermonde matrix in the scaled variable z = x/max x, σ from ``s² (VᵀV)⁻¹``."""
    s = float(x.max())
    V = np.vander(x / s, degree + 1)
    c, *_ = np.linalg.lstsq(V, y, rcond=None)
    r = y - V @ c
    s2 = float(r @ r) / (x.size - degree - 1)
    cov = s2 * np.linalg.inv(V.T @ V)
    D = np.array([s ** (-j) for j in range(degree, -1, -1)])
    return c * D, np.sqrt(np.diag(cov)) * D


def polynomial_fit(n: int = 100_000, degree: int = 5) -> dict:
    data = _laidani_samples(n)
    masks = {"forward": data.speed > 0, "reverse": data.speed < 0}
    out = {}

    def ours():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", IdentifiabilityWarning)
            out["ours"] = fit_polynomial(data, degree)

    def reference():
        out["ref"] = {d: _plain_polynomial(np.abs(data.speed[m]), np.abs(data.thrust[m]), degree)
                      for d, m in masks.items()}

    t = interleaved(ours, reference, repeats=9, budget_s=20.0)
    sf, ref = out["ours"], out["ref"]
    grid = np.linspace(0.0, 131.3016 * 12, 401)
    diff, sig = 0.0, 0.0
    for d in masks:
        c_ours = np.array([p.value for p in sf[d].parameters])
        s_ours = np.array([p.stderr for p in sf[d].parameters])
        c_ref, s_ref = ref[d]
        diff = max(diff, float(np.max(np.abs(np.polyval(c_ours, grid) - np.polyval(c_ref, grid)))))
        sig = max(sig, float(np.max(np.abs(s_ours / s_ref - 1.0))))
    e = math.log10(n)
    label = f"1e{round(e)}" if abs(e - round(e)) < 1e-12 else str(n)
    return {"case": f"polynomial_fit_{label}", **t,
            "reference": "np.linalg.lstsq on the scaled Vandermonde matrix per direction, "
                         "σ from s²(VᵀV)⁻¹ (ours also detects the regions, diagnoses "
                         "identifiability and selects nothing else), interleaved pairs",
            "max_abs_curve_difference_N": diff, "max_rel_sigma_difference": sig,
            "samples": n, "degree": degree}


# ------------------------------------------------------------------------------------------------
# (a') BLAS threads on a small nonlinear fit
# ------------------------------------------------------------------------------------------------
def blas_threads(n: int = 20000, repeats: int = 9) -> dict:
    """A steady thruster map with ESC curvature (5 parameters, ``n`` bench samples) fitted by
    :func:`uuvid.identify.fit.nonlinear_lsq` — which runs ``least_squares`` with one BLAS thread
    (:func:`uuvid.core.threads.small_blas`) — against the same ``least_squares`` call with the
    BLAS threads as loaded (what a user's plain call gets), interleaved pairs."""
    from uuvid.identify.fit import nonlinear_lsq

    rng = np.random.default_rng(1)
    pwm = rng.uniform(1100.0, 1900.0, n)
    true = np.array([0.04, 3.7e-4, 2.9e-4, -0.35, -0.37])

    def model(th, c):
        v = th[0] * (c - 1500.0)
        cur = np.where(v >= 0, th[3], th[4])
        v = v * (1.0 + cur * (np.abs(v) / 16.0 - 1.0))
        w = 23.47 * v
        return np.where(w >= 0, th[1], th[2]) * w * np.abs(w)

    y = model(true, pwm) + rng.normal(0.0, 0.2, n)
    x0 = np.array([0.035, 3e-4, 3e-4, -0.2, -0.2])

    def residual(th):
        return model(th, pwm) - y

    names = ("a", "k_pos", "k_neg", "c_fwd", "c_rev")
    got = {}

    def ours():
        got["ours"] = nonlinear_lsq(residual, x0, names, x_scale="jac", emit_warnings=False)

    def reference():
        got["ref"] = least_squares(residual, x0, x_scale="jac")

    t = interleaved(ours, reference, repeats=repeats, budget_s=20.0)
    from threadpoolctl import threadpool_info

    threads = max((d["num_threads"] for d in threadpool_info() if d["user_api"] == "blas"),
                  default=1)
    diff = float(np.max(np.abs(np.array([p.value for p in got["ours"].parameters])
                                - got["ref"].x) / np.abs(got["ref"].x)))
    return {"case": f"nonlinear_fit_{n}_blas_one_thread", **t,
            "reference": f"the same scipy least_squares with the BLAS pools as loaded "
                         f"({threads} threads), interleaved pairs",
            "blas_threads_default": threads, "max_rel_parameter_difference": diff}


# ------------------------------------------------------------------------------------------------
# (b) McLean tunnel thruster from three steps
# ------------------------------------------------------------------------------------------------
TRUE_MCLEAN = {"energy_correction": 3.0, "momentum_correction": 0.185,
               "added_mass_coefficient": 0.25}
START_MCLEAN = {"energy_correction": 2.0, "momentum_correction": 0.25,
                "added_mass_coefficient": 0.5}
NAMES = tuple(TRUE_MCLEAN)


def _mclean_runs(levels=(24.0, 16.0, 8.0), t_end: float = 1.5, dt: float = 1e-3,
                 noise: float = 0.2, seed: int = 16) -> list[Run]:
    rng = np.random.default_rng(seed)
    chain = auv2_rig_chain()
    t = np.arange(round(t_end / dt) + 1) * dt
    runs = []
    for v in levels:
        u = np.where(t >= 0.05, v, 0.0)
        y = chain.simulate(u, t[-1], dt=dt)["measured_thrust"] + rng.normal(0, noise, t.size)
        runs.append(Run(t, u, y, "measured_thrust", name=f"{v:g} V"))
    return runs


def _rig(theta) -> ThrusterChain:
    kw = dict(zip(NAMES, map(float, theta)))
    return ThrusterChain((auv2_tunnel_thruster(**kw), mclean_load_cell()), input_kind="voltage")


def _plain_mclean_simulate(runs):
    """least_squares with defaults; the residual calls the public ``ThrusterChain.simulate``."""
    def residual(theta):
        chain = _rig(theta)
        return np.concatenate([chain.simulate(r.u, r.t[-1], dt=r.t[1] - r.t[0])["measured_thrust"]
                               - r.y for r in runs])

    return least_squares(residual, [START_MCLEAN[k] for k in NAMES], bounds=(0.0, np.inf))


def _plain_mclean_solve_ivp(runs, rtol: float = 1e-8, atol: float = 1e-11,
                            diff_step: float | None = 1e-4):
    """least_squares (2-point Jacobian); the residual integrates every run with solve_ivp (LSODA).

    ``rtol``/``diff_step`` are what it takes to converge: with solve_ivp's default rtol 1e-6 and
    least_squares' default finite-difference step (√ε relative) the Jacobian sees the
    integrator's error control rather than the model and the fit stalls near its start."""
    lc_state = None

    def simulate(chain, r):
        nonlocal lc_state
        f = chain.rhs()
        if lc_state is None:
            lc_state = chain.blocks[0].n_states  # the load cell's position is the measurement
        t0 = float(r.t[np.flatnonzero(r.u != r.u[0])[0]])
        level = float(r.u[-1])
        sol = solve_ivp(lambda t, x: f(t, x, level if t >= t0 else 0.0), (0.0, float(r.t[-1])),
                        np.zeros(chain.n_states), method="LSODA", t_eval=r.t, rtol=rtol,
                        atol=atol, first_step=1e-4)
        return sol.y[lc_state]

    def residual(theta):
        chain = _rig(theta)
        return np.concatenate([simulate(chain, r) - r.y for r in runs])

    return least_squares(residual, [START_MCLEAN[k] for k in NAMES], bounds=(0.0, np.inf),
                         diff_step=diff_step)


def _ours_mclean(runs):
    start = auv2_tunnel_thruster(**START_MCLEAN)
    return fit_tunnel_thruster(runs, start, load_cell=mclean_load_cell(), emit_warnings=False)


def mclean_fit(repeat: int = 3) -> list[dict]:
    """Ours and each reference in interleaved pairs (``repeat`` pairs at most, within a time
    budget: the solve_ivp reference takes tens of seconds a fit)."""
    runs = _mclean_runs()
    _ours_mclean(runs[:1])  # compile / load the numba cache
    got = {}

    def ours_fit():
        got["ours"] = _ours_mclean(runs)

    ours_fit()
    cf = got["ours"]
    ours = np.array([cf.values[f"blocks[0].{k}"] for k in NAMES])
    sig = np.array([cf.stderrs[f"blocks[0].{k}"] for k in NAMES])
    truth = np.array([TRUE_MCLEAN[k] for k in NAMES])
    common = {"parameters": list(NAMES), "truth": truth.tolist(), "ours": ours.tolist(),
              "ours_sigma": sig.tolist(), "ours_nfev": cf.fit.extra.get("nfev"),
              "ours_max_error_in_sigma": float(np.max(np.abs(ours - truth) / sig)),
              "runs": "24, 16, 8 V steps, 1.5 s at 1 kHz, load cell, 0.2 N noise"}
    out = []
    for case, fn, label in (
            ("mclean_fit_3steps", _plain_mclean_simulate,
             "scipy least_squares defaults (2-point Jacobian), residual via "
             "ThrusterChain.simulate per run"),
            ("mclean_fit_3steps_solve_ivp", _plain_mclean_solve_ivp,
             "scipy least_squares (2-point Jacobian, diff_step 1e-4), residual via solve_ivp "
             "LSODA rtol=1e-8 atol=1e-11 on ThrusterChain.rhs per run (with rtol 1e-6 and the "
             "default step the fit stalls near its start)")):
        def reference(fn=fn):
            got["ref"] = fn(runs)

        t = interleaved(ours_fit, reference, repeats=repeat, budget_s=60.0, warmup=0)
        sol = got["ref"]
        out.append({"case": case, **t, "reference": label + ", interleaved pairs",
                    "reference_result": sol.x.tolist(), "reference_nfev": int(sol.nfev),
                    "max_rel_difference": float(np.max(np.abs(sol.x - ours) / np.abs(ours))),
                    "max_difference_in_sigma": float(np.max(np.abs(sol.x - ours) / sig)),
                    **common})
    return out


def run_all() -> dict:
    return {"identification": [polynomial_fit(), blas_threads(), *mclean_fit()]}


if __name__ == "__main__":
    print(json.dumps(run_all(), indent=2, allow_nan=False,
                     default=lambda o: None if isinstance(o, float) and not math.isfinite(o)
                     else str(o)))
