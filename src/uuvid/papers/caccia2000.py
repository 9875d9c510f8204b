"""Caccia, Indiveri & Veruggio (2000) — ROMEO's identification procedure, end to end, in simulation.

The paper identifies ROMEO's drag, thruster installation coefficients and inertia from on-board
sensors only.  Here ROMEO's **published estimates are the truth of a simulated vehicle**, the
vehicle is flown through the paper's experiments with the paper's sensors, and the whole procedure
is run on the simulated logs:

1. constant-thrust segments are found in the command log
   (:func:`~uuvid.identify.vehicle.segments.find_segments`);
2. each segment's velocity is a robust LS line fit to the position/heading/depth, with sonar
   multipath outliers and missing samples flagged (:func:`~uuvid.identify.vehicle.segments.segment_velocity`);
3. ``0 = −kξ − k_qξ|ξ| + η_μφ + w`` is stacked over segments and mapping modes (one mode with
   η = 1) and solved by LS with σ, percentile errors, the 51.02 % test and automatic model
   reduction (:func:`~uuvid.identify.vehicle.fit.fit_drag`); heave with ballast as in eq. 20;
4. the inertia comes from the sine experiments by the integrated regression (eqs. 15–19,
   :func:`~uuvid.identify.vehicle.fit.fit_inertia`), with the 4th-order Savitzky–Golay velocity;
5. the identified 1-DOF models are validated on other logs (NRMSE) and the phase lags of the sine
   experiments are measured and compared with ``atan(ω m/k_L)``;
6. the input design of §III-B (:mod:`uuvid.identify.vehicle.design`) is recomputed: D-optimal frequency
   verified numerically from the Fisher information, and full experiment designs.

**Simulation** (what is 6-DOF and what is not): every experiment is simulated with the full
**6-DOF** model (:func:`uuvid.vehicle.model.vehicle_rhs_into`, RK4, 0.05 s, ROMEO preset: rigid
body, added mass, Coriolis, damping, restoring forces with CB 0.1 m above CG) driven through the
thrust **allocation** of the paper's mapping mode (``load_vehicle("romeo").allocator(mode)``),
with the **installation coefficients applied per thruster** (delivered = η(sign τ)·τ) so that the
DOF-level coefficient equals the table's truth.  The 6-DOF damping of the identified DOF is set to
the table's truth (forward and backward surge drag differ in the paper: each run moves in one
direction only, so simulating it with that direction's coefficients is exact for an asymmetric
drag); the other DOFs keep the preset's values.  The couplings are small in these manoeuvres
(``coupling`` in the result: peak sway, roll, pitch) — which is the paper's argument for the
uncoupled model.  Only the *identified* model and the validation predictions are 1-DOF (eq. 3).

**Sensors** (the paper's rates): surge position by a 3.33 Hz echo-sounder (σ 2 cm, 1.5 % multipath
echoes of +0.5 … 2.5 m, 2 % missing samples plus occasional bursts of 5–30 missing samples);
heading by a 10 Hz compass (σ 0.3°, wrapped to [0°, 360°), 0.5 % missing, 0.2 % spikes of
5–20°); depth at 10 Hz (σ 1 cm, 0.5 % missing).  Commands at 10 Hz.

**What sets the σ's** (the paper does not say; chosen so that σ comes out of the paper's order):
the nominal force φ is computed from the thrust-tunnel model, so the force actually delivered
scatters around it — modelled as a per-segment relative thrust error (σ_T 1 % surge, 1.5 % yaw,
3 % heave), a per-segment disturbance force (σ_d 0.6 N, 0.2 N·m, 0.8 N) and a coloured
(Ornstein–Uhlenbeck, 2 s) disturbance inside every run (2 N, 0.6 N·m, 3 N: tether, pool
circulation, propeller wash); the plankton sled's runs get all surge noise × 1.6 (the paper's
plankton-sled σ_η is 0.024 against 0.014).  Mostly additive noise keeps the residuals
homoscedastic, so the paper's classical σ²(HᵀH)⁻¹ is honest (with a multiplicative thrust error it
under-covers the η's, which rest on the largest forces).  The numbers of segments follow what the
paper shows (heave: five runs, one per ballast, each with three down and three up steps, Fig. 4;
yaw: a staircase of 20 torques giving −20 … +20 °/s, Fig. 11, and 20 more within ±10 °/s; surge:
one pool crossing per level, 7 levels × 3 mapping modes per direction, speeds 0.05 … 0.35 m/s, the
settle time growing to 4 τ_c at the slow levels).  See :data:`EXPERIMENTS` and :data:`NOISE`.

**Inertia σ**: the residual of the integrated regression is an integrated disturbance (a random
walk), so the classical σ is 2–5× too small; the reported σ is the Newey–West (HAC) σ with a
bandwidth of a quarter sine period — over 30 seeds it matches the spread of the estimates — plus
the drag covariance propagated exactly (θ̂ is linear in k, k_q).  The estimate carries the
errors-in-variables correction for the Savitzky–Golay velocity noise (the plain LS value is
``m_uncorrected``), and rows whose filter window spans filled sonar gaps are left out (as the
paper's Fig. 14 uses a subset).  Measured phase lags include the half-sample delay of the 10 Hz
zero-order-hold command (``design.zoh_delay_deg``, ≈ 0.7°).

**Seed dependence** (:func:`seed_study` computes it): the estimates scatter from seed to seed, so
the **acceptance** (:func:`_acceptance`) is one statement with a known error rate: a joint bound
at family-wise level :data:`ACCEPTANCE_ALPHA` = 1 % over all its K ≈ 76 checks (Bonferroni, each
at 1 %/K): every |estimate − truth|/σ within the two-sided Student-t quantile of its σ's degrees
of freedom (≈ 5σ at the 15–16 residual degrees of freedom of the drag fits), every σ within a
factor :data:`SIGMA_ORDER_FACTOR` = 3 of the paper's widened by the χ² sampling spread of σ at
those degrees of freedom, and the low-speed quadratic (truth 0) not significant at the same
level.  A correct implementation fails it on at most 1 % of seeds (seeds 0–99: one failure, the
surge mass of seed 73 at 5.6σ against a bound of 5.0σ); a simulated drag 1.5× the
truth it is judged against fails on every seed (``test_caccia2000``).  The old rule — every one
of ~38 estimates within 3σ, every σ within a factor 3, the 5 % quadratic test — failed a correct
procedure on 8 of seeds 0–19 by chance.  The 3σ coverage (≈ 99 % of the estimates: single
parameters land at 3–4σ now and then with t-distributed errors) and the paper's own 51.02 %
reduction of the low-speed quadratic (a 5 % test: it keeps the absent term on ~7 % of seeds) are
reported, not required.

**Choices where the paper is not one consistent truth**: the low-speed yaw estimates (23.8 + 30.8|r|,
67 % error on the quadratic; linear 28.6) and the full-range ones (20.5 + 49.5|r|) are not one drag
curve, so the low-speed experiments (|r| ≤ 10 °/s) fly a vehicle whose truth is the paper's final
low-speed **linear** model (k = 28.6, η_hull = 0.68, η_hull-prop = 0.62; k_q = 0): fitting
linear + quadratic to it must find the quadratic insignificant and reduce to linear, as the paper
did.  The yaw inertia experiment uses that vehicle too (the paper linearises there).  Mean
disturbances w are estimated (eq. 8) with truth 0.  The heave mass (not identified) is the
preset's 1050 kg.  In the drag fits the velocity uncertainty (errors in variables) is ignored,
as in the paper.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numba import njit

from uuvid.identify.vehicle.design import (
    d_optimal_frequency,
    design_sine_experiment,
    fisher_information,
    linearised_drag,
)
from uuvid.identify.vehicle.fit import (
    DragFit,
    SteadyPoint,
    fit_drag,
    fit_inertia,
    phase_lag,
    predicted_phase_lag,
    steady_points_from_log,
    validate_one_dof,
)
from uuvid.identify.vehicle.segments import clean_series, savgol_velocity, summarise_rejections
from uuvid.papers.reproduction import PaperReproduction
from uuvid.vehicle.kinematics import normalise_state
from uuvid.vehicle.model import (
    OneDofModel,
    VehicleParams,
    make_state,
    steady_speed,
    vehicle_rhs_into,
)

CITATION = ("Caccia, M.; Indiveri, G.; Veruggio, G. (2000). Modeling and identification of "
            "open-frame variable configuration unmanned underwater vehicles. IEEE J. Oceanic "
            "Eng. 25(2), 227-240.")

# ---------------------------------------------------------------------------------------------
# the paper's numbers (Tables II–IV, §IV-D); (estimate, σ)
# ---------------------------------------------------------------------------------------------
PAPER: dict[str, dict[str, tuple[float, float]]] = {
    "heave": {"k": (44.7, 8.8), "k_q": (430.3, 20.8), "W": (-13.5, 1.3), "dW": (7.1, 0.4),
              "eta": (0.56, 0.023)},
    "yaw_linear_quadratic": {"k": (20.5, 2.6), "k_q": (49.5, 7.2), "eta_hull": (0.60, 0.03),
                             "eta_hull_prop": (0.60, 0.025)},
    "yaw_low_speed": {"k": (23.8, 3.5), "k_q": (30.8, 20.7), "eta_hull": (0.67, 0.048),
                      "eta_hull_prop": (0.61, 0.036)},
    "yaw_linear": {"k": (28.6, 1.3), "eta_hull": (0.68, 0.049), "eta_hull_prop": (0.62, 0.036)},
    "surge_forward_standard": {"k": (46.9, 4.9), "k_q": (306.2, 15.9), "eta_hull": (0.73, 0.014),
                               "eta_hull_prop": (0.73, 0.014)},
    "surge_backward_standard": {"k": (57.9, 5.4), "k_q": (331.4, 18.9), "eta_hull": (0.89, 0.016),
                                "eta_hull_prop": (0.80, 0.015)},
    # OCR prints σ 0.004 for η_hull-prop; its 3.6 % percentile error says 0.024
    "surge_forward_plankton": {"k": (33.0, 8.7), "k_q": (326.6, 27.7), "eta_hull": (0.72, 0.024),
                               "eta_hull_prop": (0.67, 0.024)},
    "surge_backward_plankton": {"k": (48.4, 8.3), "k_q": (324.7, 28.1), "eta_hull": (0.84, 0.023),
                                "eta_hull_prop": (0.63, 0.023)},
    "yaw_inertia": {"I": (84.0, 5.0)},
    "surge_mass": {"m": (890.0, 56.0)},
}
TABLE_KEYS = tuple(PAPER)
#: phase lags: (period s, inertia, k_L, the paper's predicted °, measured °)
PAPER_PHASE = {"yaw": (24.0, 84.0, 28.6, 37.5, 39.0), "surge": (26.0, 890.0, 212.25, 45.0, 37.0)}
#: design priors of §IV-D: yaw I = 93.75 (box of 450 kg, 1.3 × 0.9 m), k = 28.6 → ω = 0.176;
#: surge m = 675 (450 + 50 %), k = 46.9, k_q = 306.2 at ξ* = 0.27 m/s (k_L = 212.25) → 0.18.
DESIGN_PRIORS = {"yaw": {"mass": 93.75, "k": 28.6, "k_q": 0.0, "speed": -5.0 / 28.6,
                         "mass_air": 93.75, "paper_omega": 0.176},
                 "surge": {"mass": 675.0, "k": 46.9, "k_q": 306.2, "speed": 0.27,
                           "mass_air": 450.0, "paper_omega": 0.18}}

# ---------------------------------------------------------------------------------------------
# the simulated truth
# ---------------------------------------------------------------------------------------------
#: Truth per drag table: drag of the DOF, installation coefficients, mean disturbance (w or W/ΔW).
TRUTH: dict[str, dict[str, float]] = {
    "heave": {"k": 44.7, "k_q": 430.3, "W": -13.5, "dW": 7.1, "eta": 0.56},
    "yaw_linear_quadratic": {"k": 20.5, "k_q": 49.5, "eta_hull": 0.60, "eta_hull_prop": 0.60,
                             "w": 0.0},
    "yaw_low_speed": {"k": 28.6, "k_q": 0.0, "eta_hull": 0.68, "eta_hull_prop": 0.62, "w": 0.0},
    "yaw_linear": {"k": 28.6, "eta_hull": 0.68, "eta_hull_prop": 0.62, "w": 0.0},
    **{k: {**{n: v[0] for n, v in PAPER[k].items()}, "w": 0.0}
       for k in ("surge_forward_standard", "surge_backward_standard", "surge_forward_plankton",
                 "surge_backward_plankton")},
    "yaw_inertia": {"I": 84.0},
    "surge_mass": {"m": 890.0},
}
SURGE_MASS = 890.0
#: covariance of the inertia regression: the integrated regression's residuals are strongly
#: autocorrelated, so the classical σ²(HᵀH)⁻¹ is over-optimistic (2–3× too small: the spread of
#: m over seeds matches the Newey–West σ); both are reported.
INERTIA_COV = "HAC"
INERTIA_NOTE = ("σ = sqrt(σ_regression² + σ_from_drag²): the Newey–West (HAC, bandwidth 1/4 "
                "period) σ of the integrated regression (the classical σ²(HᵀH)⁻¹, sigma_classical,"
                " is 2–5 times too small: its residual is an integrated disturbance) plus the drag "
                "covariance propagated exactly (θ̂ is linear in k, k_q).  The estimate carries "
                "the errors-in-variables correction for the Savitzky–Golay velocity noise "
                "(m_uncorrected is the plain LS value, as in the paper)")

#: Sensor and disturbance models (see the module docstring).
NOISE = {
    "control_dt": 0.1, "substeps": 2,
    "sonar_dt": 0.3, "sonar_sigma": 0.02, "sonar_multipath_p": 0.015,
    "sonar_multipath_range": (0.5, 2.5), "sonar_missing_p": 0.02, "sonar_burst_p": 0.3,
    "sonar_burst_len": (5, 30),
    "compass_dt": 0.1, "compass_sigma_deg": 0.3, "compass_missing_p": 0.005,
    "compass_spike_p": 0.002, "compass_spike_deg": (5.0, 20.0),
    "depth_dt": 0.1, "depth_sigma": 0.01, "depth_missing_p": 0.005,
    # per-segment relative thrust error and additive disturbance, per DOF
    "thrust_rel_sigma": {"surge": 0.01, "yaw": 0.015, "heave": 0.03},
    "disturbance_sigma": {"surge": 0.6, "yaw": 0.2, "heave": 0.8},
    # coloured (Ornstein–Uhlenbeck) disturbance force inside every run: σ and correlation time
    "ou_sigma": {"surge": 2.0, "yaw": 0.6, "heave": 3.0},
    "ou_tau": 2.0,
    # the paper's plankton-sled fits scatter more (σ_η 0.024 vs 0.014): all surge noise × this
    "plankton_factor": 1.6,
}


@dataclass(frozen=True)
class SteadyDesign:
    """Steady experiments of one DOF: nominal levels per (mode, sign), repetitions, timing."""

    levels: dict
    repeats: int
    settle: float
    window: float


#: Experiment plan.  Levels are nominal generalized forces (N or N·m) per mapping mode.
EXPERIMENTS = {
    # heave: five runs (ballast 0…4 diver weights), each: down/up steps (Fig. 4)
    "heave": SteadyDesign({"vertical_all_heave_only": (20.0, -40.0, 45.0, -75.0, 75.0, -110.0)},
                          repeats=1, settle=35.0, window=30.0),
    # yaw, full range −20…+20 °/s: FL-RR mode both signs (η = 1 / η_hull), horizontal all
    "yaw_full": SteadyDesign({"yaw_fl_rr": (1.5, 3.5, 6.0, 9.0, 12.5, -2.5, -6.0, -10.0, -15.0,
                                            -20.0),
                              "horizontal_all": (2.5, 6.0, 10.0, 15.0, 20.0, -2.5, -6.0, -10.0,
                                                 -15.0, -20.0)},
                             repeats=1, settle=12.0, window=20.0),
    # yaw, |r| ≤ 10 °/s on the linear low-speed vehicle
    "yaw_low": SteadyDesign({"yaw_fl_rr": (1.0, 2.0, 3.0, 4.0, 5.0, -1.5, -3.0, -4.5, -6.0, -7.3),
                             "horizontal_all": (1.6, 3.2, 4.8, 6.4, 8.0, -1.6, -3.2, -4.8, -6.4,
                                                -8.0)},
                            repeats=1, settle=12.0, window=20.0),
    # surge: one pool crossing per level; open-water mode levels, η modes scaled by 1/η nominal
    # (speeds ≈ 0.05 … 0.35 m/s; the settle time grows to 4 τ_c at the slow levels)
    "surge": SteadyDesign({"open": (3.0, 8.0, 14.0, 22.0, 31.0, 42.0, 54.0)}, repeats=1,
                          settle=20.0, window=20.0),
}


# ---------------------------------------------------------------------------------------------
# 6-DOF simulation
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def _integrate(p, x0, tau, dt, nsub):
    """RK4 of the 6-DOF model under a piecewise-constant generalized force (one row per step)."""
    n = tau.shape[0]
    X = np.empty((n + 1, 13))
    x = x0.copy()
    for j in range(13):  # rows element by element: a row assignment compiles numba's
        X[0, j] = x[j]  # shape-mismatch message (≈ 2 s per process)
    h = dt / nsub
    vc = p[189:192].copy()
    dvc = np.zeros(3)
    k1 = np.empty(13)
    k2 = np.empty(13)
    k3 = np.empty(13)
    k4 = np.empty(13)
    xt = np.empty(13)
    for i in range(n):
        u = tau[i]
        for _ in range(nsub):
            vehicle_rhs_into(x, u, p, vc, dvc, k1)
            for j in range(13):
                xt[j] = x[j] + 0.5 * h * k1[j]
            vehicle_rhs_into(xt, u, p, vc, dvc, k2)
            for j in range(13):
                xt[j] = x[j] + 0.5 * h * k2[j]
            vehicle_rhs_into(xt, u, p, vc, dvc, k3)
            for j in range(13):
                xt[j] = x[j] + h * k3[j]
            vehicle_rhs_into(xt, u, p, vc, dvc, k4)
            for j in range(13):
                x[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
        normalise_state(x)
        for j in range(13):
            X[i + 1, j] = x[j]
    return X


def _yaw_of(X):
    q0, q1, q2, q3 = X[:, 3], X[:, 4], X[:, 5], X[:, 6]
    return np.arctan2(2 * (q0 * q3 + q1 * q2), 1 - 2 * (q2**2 + q3**2))


def _euler(X):
    q0, q1, q2, q3 = X[:, 3], X[:, 4], X[:, 5], X[:, 6]
    roll = np.arctan2(2 * (q0 * q1 + q2 * q3), 1 - 2 * (q1**2 + q2**2))
    pitch = np.arcsin(np.clip(2 * (q0 * q2 - q3 * q1), -1, 1))
    return roll, pitch


_DOF = {"surge": 0, "heave": 2, "yaw": 5}
_H = ("HFL", "HFR", "HRL", "HRR")


def _eta_arrays(vehicle, mode: str, truth: dict, dof: str, backward: dict | None = None):
    """Per-thruster (η₊, η₋) in ``mode`` so that the DOF-level coefficient is the table's truth.

    Thruster order of the preset: HFL, HFR, HRL, HRR, VFL, VFR, VRL, VRR.  Surge: ``truth`` is the
    forward table, ``backward`` the backward one; yaw: FL-RR/FR-RL modes are open water in their
    own direction and ``eta_hull`` in the other, horizontal-all is ``eta_hull_prop`` both ways.
    """
    n = vehicle.layout.n
    ep, en = np.ones(n), np.ones(n)
    if dof == "heave":
        en[4:8] = truth["eta"]
    elif dof == "yaw":
        if mode == "yaw_fl_rr":  # FL, RR: +thrust = clockwise (open water), −thrust η_hull
            en[[0, 3]] = truth["eta_hull"]
        elif mode == "yaw_fr_rl":  # FR, RL: +thrust = counter-clockwise (open water)
            en[[1, 2]] = truth["eta_hull"]
        elif mode == "horizontal_all":
            ep[:4] = en[:4] = truth["eta_hull_prop"]
    elif dof == "surge":
        fw, bw = truth, backward if backward is not None else truth
        if mode == "surge_front":  # front pair: + forward (open water), − backward η_hull⁻
            en[[0, 1]] = bw["eta_hull"]
        elif mode == "surge_rear":  # rear pair: − pushes forward (η_hull⁺), + backward open water
            en[[2, 3]] = fw["eta_hull"]
        elif mode == "horizontal_all":  # forward: front +, rear −; backward: front −, rear +
            ep[[0, 1]] = fw["eta_hull_prop"]
            en[[2, 3]] = fw["eta_hull_prop"]
            en[[0, 1]] = bw["eta_hull_prop"]
            ep[[2, 3]] = bw["eta_hull_prop"]
    return ep, en


def _params_for(base: VehicleParams, dof: str, k: float, k_q: float,
                net_weight: float | None = None, inertia_total: float | None = None) -> VehicleParams:
    i = _DOF[dof]
    DL = np.array(np.diag(base.linear_damping))
    DQ = np.array(np.diag(base.quadratic_damping))
    DL[i], DQ[i] = k, k_q
    kw = {"linear_damping": DL, "quadratic_damping": DQ}
    if net_weight is not None:
        kw["buoyancy"] = base.weight - net_weight
    if dof == "surge" and inertia_total is not None:
        MA = np.array(np.diag(base.added_mass))
        MA[0] = inertia_total - base.mass
        kw["added_mass"] = MA
    return replace(base, **kw)


class _Sim:
    """Flies the ROMEO preset through command schedules and records the paper's sensors."""

    def __init__(self, rng: np.random.Generator, noise_factor: float = 1.0):
        from uuvid.vehicle.definition import load_vehicle

        self.vehicle = load_vehicle("romeo")
        self.rng = rng
        self.dt = NOISE["control_dt"]
        self.noise_factor = noise_factor
        self._T = {}

    def T(self, mode):
        if mode not in self._T:
            self._T[mode] = self.vehicle.allocator(mode).T
        return self._T[mode]

    def run(self, params: VehicleParams, dof: str, force: np.ndarray, modes: list[str],
            seg_id: np.ndarray, eta: dict, x0=None) -> dict:
        """Simulate one log: ``force`` (N samples, the DOF's nominal generalized force), one mode
        label per sample, segment ids for the per-segment thrust error and disturbance."""
        rng = self.rng
        n = force.size
        i = _DOF[dof]
        nseg = int(seg_id.max()) + 1
        nf = self.noise_factor
        eps = rng.normal(0.0, nf * NOISE["thrust_rel_sigma"][dof], nseg)
        dist = rng.normal(0.0, nf * NOISE["disturbance_sigma"][dof], nseg)
        B = self.vehicle.B
        lim = self.vehicle.layout.limits
        tau = np.zeros((n, 6))
        for m in dict.fromkeys(modes):
            sel = np.array([mm == m for mm in modes])
            phi = np.zeros((6, int(sel.sum())))
            phi[i] = force[sel]
            th = self.T(m) @ phi
            if np.any(th > lim[:, 1:2] + 1e-9) or np.any(th < lim[:, 0:1] - 1e-9):
                raise RuntimeError(f"thrust limits exceeded in mode {m}")
            ep, en = eta[m]
            deliv = np.where(th >= 0, ep[:, None], en[:, None]) * th
            deliv = deliv * (1.0 + eps[seg_id[sel]])[None, :]
            tau[sel] = (B @ deliv).T
        tau[:, i] += dist[seg_id] * (force != 0)
        # Ornstein–Uhlenbeck disturbance (exact discretisation)
        a = math.exp(-self.dt / NOISE["ou_tau"])
        sd = nf * NOISE["ou_sigma"][dof]
        e = rng.normal(0.0, sd * math.sqrt(1 - a * a), n)
        ou = np.empty(n)
        ou[0] = rng.normal(0.0, sd)
        for j in range(1, n):
            ou[j] = a * ou[j - 1] + e[j]
        tau[:, i] += ou
        x0 = make_state() if x0 is None else x0
        X = _integrate(params.to_array(), np.asarray(x0, float), tau, self.dt, NOISE["substeps"])
        t = np.arange(n + 1) * self.dt
        return {"t": t, "X": X, "tau": tau, "force": np.append(force, force[-1]),
                "modes": list(modes) + [modes[-1]], "eps": eps, "dist": dist}

    # --------------------------------------------------------------------- sensors
    def sonar(self, t, x, bursts: list[tuple[float, float]] | None = None,
              multipath_at: list[float] | None = None):
        rng = self.rng
        step = int(round(NOISE["sonar_dt"] / self.dt))
        ts, xs = t[::step], x[::step].copy()
        y = xs + rng.normal(0.0, NOISE["sonar_sigma"], xs.size)
        lo, hi = NOISE["sonar_multipath_range"]
        mp = rng.random(xs.size) < NOISE["sonar_multipath_p"]
        if multipath_at is not None:
            mp[:] = False
            for tm in multipath_at:
                mp[int(np.argmin(np.abs(ts - tm)))] = True
        y[mp] += rng.uniform(lo, hi, int(mp.sum())) * rng.choice([-1.0, 1.0], int(mp.sum()))
        miss = rng.random(xs.size) < NOISE["sonar_missing_p"]
        if bursts is None:
            if rng.random() < NOISE["sonar_burst_p"]:
                a, b = NOISE["sonar_burst_len"]
                ln = int(rng.integers(a, b + 1))
                s0 = int(rng.integers(0, max(xs.size - ln, 1)))
                miss[s0:s0 + ln] = True
        else:
            for a, b in bursts:
                miss[(ts >= a) & (ts <= b)] = True
        y[miss] = np.nan
        return ts, y, {"multipath": np.flatnonzero(mp), "missing": np.flatnonzero(miss)}

    def compass(self, t, yaw):
        rng = self.rng
        step = int(round(NOISE["compass_dt"] / self.dt))
        ts, ps = t[::step], np.degrees(yaw[::step])
        y = ps + rng.normal(0.0, NOISE["compass_sigma_deg"], ps.size)
        sp = rng.random(ps.size) < NOISE["compass_spike_p"]
        lo, hi = NOISE["compass_spike_deg"]
        y[sp] += rng.uniform(lo, hi, int(sp.sum())) * rng.choice([-1.0, 1.0], int(sp.sum()))
        y = np.mod(y, 360.0)
        miss = rng.random(ps.size) < NOISE["compass_missing_p"]
        y[miss] = np.nan
        return ts, y, {"spikes": np.flatnonzero(sp), "missing": np.flatnonzero(miss)}

    def depth(self, t, z):
        rng = self.rng
        step = int(round(NOISE["depth_dt"] / self.dt))
        ts, zs = t[::step], z[::step]
        y = zs + rng.normal(0.0, NOISE["depth_sigma"], zs.size)
        miss = rng.random(zs.size) < NOISE["depth_missing_p"]
        y[miss] = np.nan
        return ts, y, {"missing": np.flatnonzero(miss)}


def _schedule(items: list[tuple[float, str, float]], dt: float, lead: float = 0.0):
    """(level, mode, duration) → force samples, mode labels, segment ids (lead-in at zero)."""
    force, modes, seg = [], [], []
    if lead > 0:
        n0 = int(round(lead / dt))
        m0 = items[0][1]
        force.append(np.zeros(n0))
        modes += [m0] * n0
        seg.append(np.zeros(n0, dtype=int))
    for j, (lvl, mode, dur) in enumerate(items):
        n = int(round(dur / dt))
        force.append(np.full(n, float(lvl)))
        modes += [mode] * n
        seg.append(np.full(n, j, dtype=int))
    return np.concatenate(force), modes, np.concatenate(seg)


def _coupling(X, dof: str) -> dict:
    roll, pitch = _euler(X)
    out = {"max_abs_sway_m_s": float(np.max(np.abs(X[:, 8]))),
           "max_abs_roll_deg": float(np.degrees(np.max(np.abs(roll)))),
           "max_abs_pitch_deg": float(np.degrees(np.max(np.abs(pitch))))}
    if dof != "yaw":
        out["max_abs_yaw_rate_deg_s"] = float(np.degrees(np.max(np.abs(X[:, 12]))))
    if dof != "heave":
        out["max_abs_heave_m_s"] = float(np.max(np.abs(X[:, 9])))
    return out


def _merge_coupling(a: dict, b: dict) -> dict:
    return {k: max(a.get(k, 0.0), b.get(k, 0.0)) for k in set(a) | set(b)}


# ---------------------------------------------------------------------------------------------
# experiments
# ---------------------------------------------------------------------------------------------
def _heave(sim: _Sim, fast: bool):
    truth = TRUTH["heave"]
    base = sim.vehicle.params
    eta = {"vertical_all_heave_only": _eta_arrays(sim.vehicle, "vertical_all_heave_only", truth,
                                                  "heave")}
    d = EXPERIMENTS["heave"]
    pts, vels, logs, coup = [], [], [], {}
    for run in range(5):
        W = truth["W"] + run * truth["dW"]
        p = _params_for(base, "heave", truth["k"], truth["k_q"], net_weight=W)
        items = [(lv, "vertical_all_heave_only", d.settle + d.window)
                 for lv in d.levels["vertical_all_heave_only"]] * d.repeats
        f, modes, seg = _schedule(items, sim.dt, lead=5.0)
        r = sim.run(p, "heave", f, modes, seg, eta)
        ts, y, info = sim.depth(r["t"], r["X"][:, 2])
        pp, vv = steady_points_from_log(
            r["t"], r["force"], ts, y, mode=r["modes"], min_duration=d.window * 0.8,
            settle=d.settle, eta_map={"vertical_all_heave_only+": None,
                                      "vertical_all_heave_only-": "eta"},
            ballast=float(run), run=run)
        pts += pp
        vels += vv
        logs.append({"run": run, "t": r["t"], "force": r["force"], "ts": ts, "y": y,
                     "true_velocity": r["X"][:, 9], "sensor": info})
        coup = _merge_coupling(coup, _coupling(r["X"], "heave"))
    fit = fit_drag(pts, disturbance="W", ballast="dW", dof="heave", model="heave, eq. 20")
    # Fig. 6: the same data with η = 1 assumed everywhere
    naive = fit_drag([replace(q, eta=None) for q in pts], disturbance="W", ballast="dW",
                     dof="heave", model="heave, η = 1 assumed")
    return fit, naive, pts, vels, logs, coup


def _yaw_steady(sim: _Sim, truth: dict, design: SteadyDesign, rng_key: str):
    base = sim.vehicle.params
    p = _params_for(base, "yaw", truth["k"], truth["k_q"])
    eta = {m: _eta_arrays(sim.vehicle, m, truth, "yaw") for m in design.levels}
    items = []
    for _ in range(design.repeats):
        for m, lv in design.levels.items():
            items += [(x, m, design.settle + design.window) for x in lv]
    f, modes, seg = _schedule(items, sim.dt, lead=5.0)
    r = sim.run(p, "yaw", f, modes, seg, eta)
    ts, y, info = sim.compass(r["t"], _yaw_of(r["X"]))
    pts, vels = steady_points_from_log(
        r["t"], r["force"], ts, np.radians(y), mode=r["modes"], min_duration=design.window * 0.8,
        settle=design.settle, angle=True,
        eta_map={"yaw_fl_rr+": None, "yaw_fl_rr-": "eta_hull", "horizontal_all": "eta_hull_prop"})
    log = {"t": r["t"], "force": r["force"], "ts": ts, "y": y, "true_velocity": r["X"][:, 12],
           "sensor": info, "name": rng_key}
    return pts, vels, log, _coupling(r["X"], "yaw")


_SURGE_TABLES = {"standard": ("surge_forward_standard", "surge_backward_standard"),
                 "plankton": ("surge_forward_plankton", "surge_backward_plankton")}


def _surge_steady(sim: _Sim, sled: str):
    fkey, bkey = _SURGE_TABLES[sled]
    tf, tb = TRUTH[fkey], TRUTH[bkey]
    base = sim.vehicle.params
    d = EXPERIMENTS["surge"]
    out = {}
    coup: dict = {}
    for direction, key, truth in (("forward", fkey, tf), ("backward", bkey, tb)):
        sgn = 1.0 if direction == "forward" else -1.0
        p = _params_for(base, "surge", truth["k"], truth["k_q"], inertia_total=SURGE_MASS)
        open_mode = "surge_front" if direction == "forward" else "surge_rear"
        hull_mode = "surge_rear" if direction == "forward" else "surge_front"
        modes_eta = {open_mode: 1.0, hull_mode: truth["eta_hull"],
                     "horizontal_all": truth["eta_hull_prop"]}
        eta_map = {f"{open_mode}{'+' if sgn > 0 else '-'}": None,
                   f"{hull_mode}{'+' if sgn > 0 else '-'}": "eta_hull",
                   f"horizontal_all{'+' if sgn > 0 else '-'}": "eta_hull_prop"}
        eta = {m: _eta_arrays(sim.vehicle, m, tf, "surge", backward=tb) for m in modes_eta}
        pts, vels, logs = [], [], []
        for rep in range(d.repeats):
            for m, e_nom in modes_eta.items():
                for lv in d.levels["open"]:
                    # the experimenter scales the nominal force by a rough η guess (0.8) so that
                    # every mode spans the same speeds; the regression does not use that guess
                    level = sgn * lv / (1.0 if e_nom == 1.0 else 0.8)
                    v_exp = abs(float(steady_speed(truth["k"], truth["k_q"], e_nom * abs(level))))
                    settle = max(d.settle, 4.0 * SURGE_MASS / linearised_drag(truth["k"],
                                                                               truth["k_q"], v_exp))
                    f, modes, seg = _schedule([(level, m, settle + d.window)], sim.dt, lead=2.0)
                    r = sim.run(p, "surge", f, modes, seg, eta)
                    ts, y, info = sim.sonar(r["t"], r["X"][:, 0])
                    pp, vv = steady_points_from_log(
                        r["t"], r["force"], ts, y, mode=r["modes"], min_duration=d.window * 0.8,
                        settle=settle, eta_map=eta_map, velocity_sign=int(sgn),
                        run=f"{direction}-{m}-{rep}")
                    pts += pp
                    vels += vv
                    logs.append({"t": r["t"], "force": r["force"], "ts": ts, "y": y, "mode": m,
                                 "true_velocity": r["X"][:, 7], "sensor": info})
                    coup = _merge_coupling(coup, _coupling(r["X"], "surge"))
        out[key] = (fit_drag(pts, dof="surge", model=key), pts, vels, logs)
    return out, coup


def _sine_experiment(sim: _Sim, dof: str, params: VehicleParams, mode: str, eta, offset: float,
                     amplitude: float, period: float, duration: float, *, bursts=None,
                     multipath_at=None):
    n = int(round(duration / sim.dt))
    t = np.arange(n) * sim.dt
    f = offset + amplitude * np.sin(2 * np.pi * t / period)
    seg = np.zeros(n, dtype=int)
    r = sim.run(params, dof, f, [mode] * n, seg, {mode: eta})
    if dof == "yaw":
        ts, y, info = sim.compass(r["t"], _yaw_of(r["X"]))
        y = np.radians(y)
        true_v = r["X"][:, 12]
    else:
        ts, y, info = sim.sonar(r["t"], r["X"][:, 0], bursts=bursts, multipath_at=multipath_at)
        true_v = r["X"][:, 7]
    return {"t": r["t"], "force": r["force"], "ts": ts, "y": y, "true_velocity": true_v,
            "sensor": info, "coupling": _coupling(r["X"], dof)}


def _hac_lags(period: float, dt: float) -> int:
    """Newey–West bandwidth for the integrated regression: a quarter of the sine period.

    The residual is an integrated disturbance; the default ``4(n/100)^(2/9)`` rule under-covers by
    ~2× here.  Over 30 seeds a quarter period gave σ ≈ the spread of the estimates (surge 31 vs
    35 kg, yaw 6.9 vs 6.2 kg·m²) with the least variable σ among 0.15 … 0.6 periods."""
    return int(round(0.25 * period / dt))


def _hac_dof(n: int, lags: int) -> float:
    """Effective degrees of freedom of a Newey–West (Bartlett) variance from ``n`` samples with
    bandwidth ``lags``: its relative variance is ≈ (4/3)·lags/n (Andrews 1991), that of χ²_ν/ν
    is 2/ν, so ν ≈ 1.5 n / lags (≈ 30 for the yaw sine, ≈ 20 for the surge one)."""
    return 1.5 * n / max(int(lags), 1)


def _measured_velocity(ts, y, window: int, angle: bool):
    cs = clean_series(ts, y, angle=angle, window=window)
    return cs.t, savgol_velocity(cs.t, cs.x, order=4, window=window), cs


def _param_rows(table: str, fit, names: dict[str, str] | None = None,
                dof: float | None = None) -> dict:
    """``{name: {estimate, sigma, truth, paper, paper_sigma, dof, ...}}`` for one table; ``dof``:
    the degrees of freedom of σ (default the fit's residual ones, n − p)."""
    names = names or {}
    dof = float(fit.dof if dof is None else dof)
    rows = {}
    for p in fit.parameters:
        key = names.get(p.name, p.name)
        paper = PAPER.get(table, {}).get(key)
        truth = TRUTH.get(table, {}).get(key, math.nan)
        z = abs(p.value - truth) / p.stderr if p.stderr > 0 else math.inf
        rows[key] = {"estimate": p.value, "sigma": p.stderr, "truth": truth,
                     "paper": paper[0] if paper else None,
                     "paper_sigma": paper[1] if paper else None,
                     "percentile_error": p.percentile_error, "significant": p.significant,
                     "z": z, "within_3sigma": bool(z <= 3.0), "dof": dof,
                     "sigma_ratio": (p.stderr / paper[1]) if paper else None}
    return rows


def _drag_table(table: str, fit: DragFit, vels, simulation: str, use_full: bool = False) -> dict:
    f = fit.full if use_full else fit.fit
    out = {"parameters": _param_rows(table, f), "n_segments": len(fit.points),
           "n_parameters": len(f.parameters), "sigma2": f.sigma2,
           "rejections": summarise_rejections(vels), "simulation": simulation,
           "quadratic_significant": fit.quadratic_significant,
           "reduced_to": fit.reduced_to, "messages": list(fit.messages), "notes": list(fit.notes),
           "cov_type": f.extra.get("cov_type")}
    out["velocity_relative_error_max"] = float(max(
        (v.relative_error for v in vels if v.velocity != 0), default=math.nan))
    return out


class Reproduction(PaperReproduction):
    """The JSON-able result (a ``dict``) plus ``artifacts`` (fits, logs) for the plots, with
    the common result surface (``summary()``, ``plot()``, ``report(folder)``…)."""

    report_title = "Caccia, Indiveri & Veruggio (2000) — ROMEO identification, reproduced"

    def summary(self) -> str:
        acc = self.get("acceptance", {})
        lines = [f"{self.get('paper', CITATION)}",
                 f"acceptance ({ACCEPTANCE_RULE}): " + ("PASSED" if acc.get("passed") else "FAILED")]
        lines += [f"  failure: {f}" for f in acc.get("failures", [])]
        for table in TABLE_KEYS:
            if table not in self:
                continue
            lines.append(f"{table}" + (f" (reduced to {self[table]['reduced_to']})"
                                       if self[table].get("reduced_to") else ""))
            for n, r in self[table]["parameters"].items():
                lines.append(f"  {n:<10} {r['estimate']:>11.4g} ± {r['sigma']:<9.3g} truth "
                             f"{r['truth']:<10.4g} |est − truth|/σ {r['z']:.2f}")
        return "\n".join(lines)

    def plot(self):
        """|estimate − truth| / σ per identified parameter (3σ marked; the acceptance's joint
        bound per parameter is in ``acceptance["bounds"]``)."""
        from uuvid.core.plots import new_figure

        names, z = [], []
        for table in TABLE_KEYS:
            for n, r in self.get(table, {}).get("parameters", {}).items():
                names.append(f"{table}.{n}")
                z.append(r["z"] if r["z"] is not None else np.nan)
        fig, ax = new_figure(1, 1, figsize=(max(7, 0.28 * len(names) + 2), 4.2))
        ax.bar(range(len(z)), z)
        ax.axhline(3.0, color="r", ls="--", lw=1, label="3σ (the acceptance's joint bound is ≈ 4.4–5σ)")
        ax.set_xticks(range(len(names)))
        ax.set_xticklabels(names, rotation=90, fontsize=6)
        ax.set_ylabel("|estimate − truth| / σ [-]")
        ax.set_title("Identified back from simulation: distance to the truth", fontsize=10)
        ax.legend(fontsize=8)
        return fig

    def _write_outputs(self, folder: Path) -> Path | None:
        return write_outputs(self, folder) if self.artifacts else None


#: Family-wise error rate of the acceptance: a correct implementation fails it on at most this
#: fraction of seeds (Bonferroni over all its checks; :func:`_acceptance`).
ACCEPTANCE_ALPHA = 0.01
#: The simulation's noise is designed so that the σ its estimates truly have lies within this
#: factor of the paper's σ (a modelling claim, see "What sets the σ's"); the σ a seed gives
#: scatters around that true σ as its sampling distribution says.
SIGMA_ORDER_FACTOR = 3.0


def acceptance_bounds(dof: float, n_checks: int, alpha: float = ACCEPTANCE_ALPHA) -> dict:
    """The bounds of one of ``n_checks`` checks on an estimate whose σ has ``dof`` degrees of
    freedom, each at level ``alpha / n_checks`` (Bonferroni: the family fails with probability
    ≤ ``alpha``): ``z``, the two-sided Student-t quantile that |estimate − truth|/σ stays below;
    ``sigma_ratio``, the interval σ/σ_paper stays in when the true σ is within
    :data:`SIGMA_ORDER_FACTOR` of the paper's (σ̂²/σ² ~ χ²_ν/ν, two-sided)."""
    from scipy import stats

    a = alpha / n_checks
    nu = max(float(dof), 1.0)
    lo, hi = (math.sqrt(stats.chi2.ppf(q, nu) / nu) for q in (a / 2, 1 - a / 2))
    return {"z": float(stats.t.ppf(1 - a / 2, nu)),
            "sigma_ratio": (lo / SIGMA_ORDER_FACTOR, hi * SIGMA_ORDER_FACTOR)}


def _acceptance(result: dict) -> dict:
    """The acceptance: one statement that holds for a correct implementation with probability
    ≥ 1 − :data:`ACCEPTANCE_ALPHA` (99 %) over seeds.  Its K checks, each at level α/K
    (Bonferroni), so that all of them pass jointly with probability ≥ 1 − α:

    * every estimate: |estimate − truth|/σ ≤ the two-sided t quantile of its σ's degrees of
      freedom (n − p for the drag fits; ≈ 1.5 n/lags for the HAC σ of the inertia);
    * every σ with a paper σ: σ/σ_paper within the sampling interval of σ (χ²_ν/ν) widened by
      :data:`SIGMA_ORDER_FACTOR` (the noise model claims the true σ is of the paper's order);
    * the low-speed quadratic (truth 0) not significant at the same level α/K: |k_q|/σ ≤ the
      same t quantile.  The paper's own reduction rule (percentile error > 51.02 %, a 5 % test)
      still decides ``reduced_to``; at 5 % it keeps a truly absent term on ~7 % of seeds, so it
      is reported, not required.

    The old rule (3σ for each of ~38 estimates, σ within a factor 3, the 5 % test) failed a
    correct procedure on about half the seeds."""
    checks = []  # (table, name, row)
    for table in TABLE_KEYS:
        for name, row in result[table]["parameters"].items():
            checks.append((table, name, row))
    n_sigma = sum(1 for _, _, row in checks if row["paper_sigma"])
    n_checks = len(checks) + n_sigma + 1
    fails, ratios, bounds = [], {}, {}
    for table, name, row in checks:
        b = acceptance_bounds(row["dof"], n_checks)
        key = f"{table}.{name}"
        bounds[key] = {"z": b["z"], "dof": row["dof"]}
        if not row["z"] <= b["z"]:
            fails.append(f"{key}: |estimate − truth| = {row['z']:.2f} σ > {b['z']:.2f} σ "
                         f"(the joint {1 - ACCEPTANCE_ALPHA:.0%} bound, {row['dof']:.0f} dof)")
        if row["paper_sigma"]:
            r = row["sigma"] / row["paper_sigma"]
            ratios[key] = r
            lo, hi = b["sigma_ratio"]
            bounds[key]["sigma_ratio"] = [lo, hi]
            if not lo <= r <= hi:
                fails.append(f"{key}: σ {row['sigma']:.3g} vs paper {row['paper_sigma']:.3g} "
                             f"(ratio {r:.2f}) outside {lo:.2f} … {hi:.2f} (a factor "
                             f"{SIGMA_ORDER_FACTOR:g} and the sampling spread of σ at "
                             f"{row['dof']:.0f} dof)")
    kq = result["yaw_low_speed"]["parameters"]["k_q"]
    b = acceptance_bounds(kq["dof"], n_checks)
    t_kq = abs(kq["estimate"]) / kq["sigma"] if kq["sigma"] > 0 else math.inf
    if not t_kq <= b["z"]:
        fails.append(f"yaw_low_speed: the quadratic term (truth 0) is significant at the joint "
                     f"level: |k_q|/σ = {t_kq:.2f} > {b['z']:.2f}")
    return {"passed": not fails, "failures": fails, "sigma_ratio": ratios,
            "alpha": ACCEPTANCE_ALPHA, "n_checks": n_checks, "bounds": bounds,
            "rule": ACCEPTANCE_RULE}


#: The acceptance in one line (summary, report, CLI).
ACCEPTANCE_RULE = (f"joint {1 - ACCEPTANCE_ALPHA:.0%} bound over all checks (Bonferroni): every "
                   "|estimate − truth|/σ within its t quantile, every σ within a factor "
                   f"{SIGMA_ORDER_FACTOR:g} of the paper's widened by its sampling spread, the "
                   "low-speed quadratic not significant at that level")


# ---------------------------------------------------------------------------------------------
# the reproduction
# ---------------------------------------------------------------------------------------------
def reproduce(seed: int = 0, fast: bool = False, out_dir: str | Path | None = None) -> Reproduction:
    """Simulate ROMEO's experiments with the paper's numbers as truth and identify everything back.

    Returns a :class:`Reproduction` (a JSON-able dict): one entry per table of the paper
    (``heave``, ``yaw_linear_quadratic``, ``yaw_low_speed``, ``yaw_linear``,
    ``surge_forward_standard``, ``surge_backward_standard``, ``surge_forward_plankton``,
    ``surge_backward_plankton``, ``yaw_inertia``, ``surge_mass``), each with
    ``parameters[name] = {estimate, sigma, truth, paper, paper_sigma, percentile_error, …}``, plus
    ``design``, ``validation``, ``coupling``, ``acceptance``, ``experiments`` (the plan and the
    noise models) and ``runtime_s``.  ``fast=True`` skips the two validation logs (Figs. 13, 15;
    ``validation`` is then empty); the identification is identical.  Deterministic for a given
    ``seed``.  ``out_dir``: also :func:`write_outputs` there.
    """
    t_start = time.perf_counter()
    ss = np.random.SeedSequence(seed)
    streams = [np.random.default_rng(s) for s in ss.spawn(8)]
    result = Reproduction()
    art: dict = {}
    coupling: dict = {}

    # ---------------------------------------------------------------- heave (Table II)
    sim = _Sim(streams[0])
    hfit, hnaive, hpts, hvels, hlogs, coupling["heave"] = _heave(sim, fast)
    result["heave"] = _drag_table("heave", hfit, hvels,
                                  "6-DOF, vertical all / heave only mode, 5 ballasts")
    art["heave"] = {"fit": hfit, "naive": hnaive, "points": hpts, "logs": hlogs}

    # ---------------------------------------------------------------- yaw (Table III)
    sim_y = _Sim(streams[1])
    ypts, yvels, ylog, coupling["yaw_full"] = _yaw_steady(sim_y, TRUTH["yaw_linear_quadratic"],
                                                          EXPERIMENTS["yaw_full"], "yaw_full")
    yfit = fit_drag(ypts, dof="yaw", model="yaw, linear + quadratic")
    result["yaw_linear_quadratic"] = _drag_table("yaw_linear_quadratic", yfit, yvels,
                                                 "6-DOF, yaw FL-RR and horizontal-all modes")
    sim_l = _Sim(streams[2])
    lpts, lvels, llog, coupling["yaw_low"] = _yaw_steady(sim_l, TRUTH["yaw_low_speed"],
                                                         EXPERIMENTS["yaw_low"], "yaw_low")
    lfit = fit_drag(lpts, dof="yaw", model="yaw, |r| < 10 °/s")
    result["yaw_low_speed"] = _drag_table("yaw_low_speed", lfit, lvels,
                                          "6-DOF, |r| ≤ 10 °/s, linear-truth vehicle",
                                          use_full=True)
    # the paper's lower section: the linear model fitted to the same data (identical to the reduced
    # fit when the reduction dropped k_q, as it should)
    linfit = fit_drag(lpts, quadratic=False, dof="yaw", model="yaw, linear, |r| < 10 °/s")
    result["yaw_linear"] = _drag_table("yaw_linear", linfit, lvels,
                                       "6-DOF, |r| ≤ 10 °/s, linear model (= the reduced fit)")
    result["yaw_linear"]["reduced_to"] = lfit.reduced_to
    art["yaw"] = {"full": (yfit, ypts, ylog), "low": (lfit, lpts, llog)}

    # ---------------------------------------------------------------- surge (Table IV)
    art["surge"] = {}
    for i, sled in enumerate(("standard", "plankton")):
        sim_s = _Sim(streams[3 + i], NOISE["plankton_factor"] if sled == "plankton" else 1.0)
        res, coupling[f"surge_{sled}"] = _surge_steady(sim_s, sled)
        for key, (fit, pts, vels, logs) in res.items():
            result[key] = _drag_table(key, fit, vels, f"6-DOF, surge front / rear / horizontal-all "
                                      f"modes, {sled} sled")
            art["surge"][key] = (fit, pts, logs)

    # ---------------------------------------------------------------- inertia (sine experiments)
    sim_i = _Sim(streams[5])
    yl = TRUTH["yaw_linear"]
    p_yaw = _params_for(sim_i.vehicle.params, "yaw", yl["k"], 0.0)
    eta_fr = _eta_arrays(sim_i.vehicle, "yaw_fr_rl", yl, "yaw")
    period_y = PAPER_PHASE["yaw"][0]
    yexp = _sine_experiment(sim_i, "yaw", p_yaw, "yaw_fr_rl", eta_fr, -5.0, 4.0, period_y, 130.0)
    k_yaw = linfit.k
    ykw = {"k": k_yaw, "k_q": 0.0, "eta": 1.0, "window": 41, "angle": True,
           "drag_cov": linfit.drag_covariance(), "velocity_noise_correction": True,
           "hac_lags": _hac_lags(period_y, NOISE["compass_dt"])}
    yin = fit_inertia(yexp["ts"], yexp["y"], yexp["force"], t_phi=yexp["t"], cov_type=INERTIA_COV,
                      **ykw)
    yin_c = fit_inertia(yexp["ts"], yexp["y"], yexp["force"], t_phi=yexp["t"],
                        **{**ykw, "drag_cov": None, "hac_lags": None})
    result["yaw_inertia"] = {
        "parameters": {"I": _param_rows("yaw_inertia", yin.fit, {"m": "I"},
                                        dof=_hac_dof(yin.fit.n_samples, ykw["hac_lags"]))["I"]},
        "sigma_classical": yin_c.fit["m"].stderr, "cov_type": INERTIA_COV,
        "sigma_regression": yin.fit.extra["sigma_ls"]["m"],
        "m_uncorrected": yin.fit.extra["m_uncorrected"],
        "sigma_from_drag": yin.fit.extra["sigma_drag"]["m"],
        "simulation": "6-DOF, yaw FR-RL mode (open water for negative torque), −5 + 4 sin(2πt/24) "
                      "N·m, 130 s, 10 Hz compass, 41-point 4th-order Savitzky–Golay",
        "drag_used": {"k": k_yaw, "k_q": 0.0}, "window": 41, "cleaning": yin.cleaning,
        "notes": list(yin.notes) + [INERTIA_NOTE]}
    sf = TRUTH["surge_forward_standard"]
    p_surge = _params_for(sim_i.vehicle.params, "surge", sf["k"], sf["k_q"], inertia_total=SURGE_MASS)
    eta_sf = _eta_arrays(sim_i.vehicle, "surge_front", sf, "surge",
                         backward=TRUTH["surge_backward_standard"])
    period_s = PAPER_PHASE["surge"][0]
    sexp = _sine_experiment(sim_i, "surge", p_surge, "surge_front", eta_sf, 35.0, 25.0, period_s,
                            90.0, bursts=[(70.0, 74.0), (77.0, 80.0)], multipath_at=[41.0, 47.5])
    fs = art["surge"]["surge_forward_standard"][0]
    skw = {"k": fs.k, "k_q": fs.k_q, "eta": 1.0, "window": 21, "drag_cov": fs.drag_covariance(),
           "velocity_noise_correction": True, "hac_lags": _hac_lags(period_s, NOISE["sonar_dt"])}
    sin_ = fit_inertia(sexp["ts"], sexp["y"], sexp["force"], t_phi=sexp["t"], cov_type=INERTIA_COV,
                       **skw)
    sin_c = fit_inertia(sexp["ts"], sexp["y"], sexp["force"], t_phi=sexp["t"],
                        **{**skw, "drag_cov": None, "hac_lags": None})
    result["surge_mass"] = {
        "parameters": {"m": _param_rows("surge_mass", sin_.fit,
                                        dof=_hac_dof(sin_.fit.n_samples, skw["hac_lags"]))["m"]},
        "sigma_classical": sin_c.fit["m"].stderr, "cov_type": INERTIA_COV,
        "sigma_regression": sin_.fit.extra["sigma_ls"]["m"],
        "m_uncorrected": sin_.fit.extra["m_uncorrected"],
        "sigma_from_drag": sin_.fit.extra["sigma_drag"]["m"],
        "simulation": "6-DOF, surge front mode (open water), 35 + 25 sin(2πt/26) N, 90 s, 3.33 Hz "
                      "sonar with two multipath echoes and two sets of missing samples (70–80 s), "
                      "21-point 4th-order Savitzky–Golay",
        "drag_used": {"k": fs.k, "k_q": fs.k_q}, "window": 21, "cleaning": sin_.cleaning,
        "notes": list(sin_.notes) + [INERTIA_NOTE]}
    coupling["inertia_yaw"] = yexp["coupling"]
    coupling["inertia_surge"] = sexp["coupling"]
    art["inertia"] = {"yaw": (yin, yexp), "surge": (sin_, sexp)}

    # ---------------------------------------------------------------- phase lags
    wy, ws = 2 * math.pi / period_y, 2 * math.pi / period_s
    ty_v, vy, _ = _measured_velocity(yexp["ts"], yexp["y"], 41, True)
    ts_v, vs, _ = _measured_velocity(sexp["ts"], sexp["y"], 21, False)
    fy = np.interp(ty_v, yexp["t"], yexp["force"])
    fsv = np.interp(ts_v, sexp["t"], sexp["force"])
    lag_y = phase_lag(ty_v, fy, vy, wy, t_start=30.0, t_end=ty_v[-1] - 3.0)
    lag_s = phase_lag(ts_v, fsv, vs, ws, t_start=20.0, t_end=ts_v[-1] - 3.0)
    lag_y_true = phase_lag(yexp["t"], yexp["force"], yexp["true_velocity"], wy, t_start=30.0)
    lag_s_true = phase_lag(sexp["t"], sexp["force"], sexp["true_velocity"], ws, t_start=20.0)

    # ---------------------------------------------------------------- design (§III-B, §IV-D)
    dy, ds = DESIGN_PRIORS["yaw"], DESIGN_PRIORS["surge"]
    kl_s = linearised_drag(ds["k"], ds["k_q"], ds["speed"])
    a_y, a_s = dy["k"] / dy["mass"], kl_s / ds["mass"]
    design = {
        "omega_opt_yaw": d_optimal_frequency(a_y),
        "omega_opt_surge": d_optimal_frequency(a_s),
        "omega_opt_yaw_analytic": a_y / math.sqrt(3),
        "omega_opt_surge_analytic": a_s / math.sqrt(3),
        "omega_opt_paper": {"yaw": dy["paper_omega"], "surge": ds["paper_omega"]},
        "k_L_surge": kl_s,
        "fisher_check": {
            "yaw_numeric_over_analytic": d_optimal_frequency(a_y) / (a_y / math.sqrt(3)),
            "surge_numeric_over_analytic": d_optimal_frequency(a_s) / (a_s / math.sqrt(3)),
            "det_numeric_vs_analytic_rel": float(abs(
                np.linalg.det(fisher_information(a_y / math.sqrt(3), a_y, 1.0))
                / np.linalg.det(fisher_information(a_y / math.sqrt(3), a_y, 1.0, method="analytic"))
                - 1.0))},
        "phase_lag_yaw_deg": predicted_phase_lag(wy, PAPER_PHASE["yaw"][1], PAPER_PHASE["yaw"][2]),
        "phase_lag_surge_deg": predicted_phase_lag(ws, PAPER_PHASE["surge"][1],
                                                   PAPER_PHASE["surge"][2]),
        "phase_lag_yaw_measured_deg": lag_y["lag_deg"],
        "phase_lag_surge_measured_deg": lag_s["lag_deg"],
        # the 10 Hz zero-order-hold command adds half a sample of delay to the measured lags
        "zoh_delay_deg": {"yaw": math.degrees(wy * NOISE["control_dt"] / 2),
                          "surge": math.degrees(ws * NOISE["control_dt"] / 2)},
        "phase_lag_yaw_true_velocity_deg": lag_y_true["lag_deg"],
        "phase_lag_surge_true_velocity_deg": lag_s_true["lag_deg"],
        "phase_lag_paper": {"yaw": {"predicted": PAPER_PHASE["yaw"][3],
                                    "measured": PAPER_PHASE["yaw"][4]},
                            "surge": {"predicted": PAPER_PHASE["surge"][3],
                                      "measured": PAPER_PHASE["surge"][4]}},
        "phase_lag_identified_deg": {
            "yaw": predicted_phase_lag(wy, yin.mass, linfit.k),
            "surge": predicted_phase_lag(ws, sin_.mass, linearised_drag(fs.k, fs.k_q, 0.27))},
    }
    yd = design_sine_experiment(dy["k"], 0.0, mass=dy["mass"], speed=dy["speed"],
                                mass_air=dy["mass_air"], n_periods=4, dof="yaw",
                                force_limit=2 * 0.6008 * 102.0)
    sd = design_sine_experiment(ds["k"], ds["k_q"], mass=ds["mass"], speed=ds["speed"],
                                mass_air=ds["mass_air"], speed_range=(0.1, 0.35), n_periods=2,
                                max_distance=20.0, dof="surge", force_limit=2 * 0.8222 * 102.0)
    design["yaw_experiment"] = yd.as_dict()
    design["surge_experiment"] = sd.as_dict()
    cmd = sd.thruster_commands(sim_i.vehicle, "surge_front", voltage=(1.02, 1.09))
    design["surge_experiment"]["command_samples"] = int(cmd["t"].size)
    design["surge_experiment"]["peak_thrust_N"] = float(np.max(np.abs(cmd["thrust"])))
    design["surge_experiment"]["peak_voltage_V"] = float(np.max(np.abs(cmd["voltage"])))
    result["design"] = design

    # ---------------------------------------------------------------- validation (Figs. 13, 15)
    validation = {}
    if not fast:
        sim_v = _Sim(streams[6])
        # yaw: two sines with offsets of opposite sign in FR-RL mode (η_hull for +torque)
        n = int(round(120.0 / sim_v.dt))
        tv = np.arange(n) * sim_v.dt
        fv = np.where(tv < 60.0, 5.0, -5.0) + 3.0 * np.sin(2 * np.pi * tv / 20.0)
        r = sim_v.run(p_yaw, "yaw", fv, ["yaw_fr_rl"] * n, np.zeros(n, dtype=int),
                      {"yaw_fr_rl": eta_fr})
        tsv, yv, _ = sim_v.compass(r["t"], _yaw_of(r["X"]))
        tgv, vmeas, _ = _measured_velocity(tsv, np.radians(yv), 41, True)
        mdl = OneDofModel(yin.mass, max(linfit.k, 1e-9), 0.0, linfit.eta("eta_hull"), 1.0, linfit.w,
                          "yaw")
        val = validate_one_dof(mdl, tgv, r["force"], vmeas, t_phi=r["t"])
        truev = np.interp(tgv, r["t"], r["X"][:, 12])
        validation["yaw"] = {"nrmse": val["nrmse"],
                             "nrmse_vs_true": float(np.sqrt(np.mean((val["predicted"] - truev) ** 2))
                                                    / np.ptp(truev)),
                             "model": {"I": mdl.mass, "k": mdl.linear, "eta_pos": mdl.eta_pos,
                                       "eta_neg": mdl.eta_neg}}
        art["validation_yaw"] = (tgv, vmeas, val["predicted"], r["t"], r["force"])
        # surge: steps and a sine in surge-front mode
        n = int(round(100.0 / sim_v.dt))
        tv = np.arange(n) * sim_v.dt
        fv = np.where(tv < 30, 20.0, np.where(tv < 60, 45.0, 30.0 + 15.0 * np.sin(
            2 * np.pi * (tv - 60) / 20.0)))
        r = sim_v.run(p_surge, "surge", fv, ["surge_front"] * n, np.zeros(n, dtype=int),
                      {"surge_front": eta_sf})
        tsv, yv, _ = sim_v.sonar(r["t"], r["X"][:, 0])
        tgv, vmeas, _ = _measured_velocity(tsv, yv, 21, False)
        mdl = OneDofModel(sin_.mass, fs.k, fs.k_q, 1.0, fs.eta("eta_hull"), fs.w, "surge")
        val = validate_one_dof(mdl, tgv, r["force"], vmeas, t_phi=r["t"], xi0=0.0)
        truev = np.interp(tgv, r["t"], r["X"][:, 7])
        validation["surge"] = {"nrmse": val["nrmse"],
                               "nrmse_vs_true": float(np.sqrt(np.mean((val["predicted"] - truev)
                                                                      ** 2)) / np.ptp(truev)),
                               "model": {"m": mdl.mass, "k": mdl.linear, "k_q": mdl.quadratic}}
        art["validation_surge"] = (tgv, vmeas, val["predicted"], r["t"], r["force"])
    result["validation"] = validation
    result["coupling"] = coupling
    result["acceptance"] = _acceptance(result)
    result["paper"] = CITATION
    result["seed"] = seed
    result["fast"] = fast
    result["experiments"] = {
        "heave": {"runs": 5, "levels_per_run": len(EXPERIMENTS["heave"].levels[
            "vertical_all_heave_only"]) * EXPERIMENTS["heave"].repeats,
                  "settle_s": EXPERIMENTS["heave"].settle, "window_s": EXPERIMENTS["heave"].window},
        "yaw_full": {"segments": sum(len(v) for v in EXPERIMENTS["yaw_full"].levels.values())
                     * EXPERIMENTS["yaw_full"].repeats},
        "yaw_low": {"segments": sum(len(v) for v in EXPERIMENTS["yaw_low"].levels.values())
                    * EXPERIMENTS["yaw_low"].repeats},
        "surge": {"runs_per_direction": 3 * len(EXPERIMENTS["surge"].levels["open"])
                  * EXPERIMENTS["surge"].repeats},
        "noise": {k: v for k, v in NOISE.items()},
    }
    result["runtime_s"] = time.perf_counter() - t_start
    result.artifacts = art
    if out_dir is not None:
        result.report(out_dir)
    return result


# ---------------------------------------------------------------------------------------------
# outputs
# ---------------------------------------------------------------------------------------------
_LABEL = {None: "open water (η = 1)", "eta": "η (pulling up)", "eta_hull": "η_hull",
          "eta_hull_prop": "η_hull-prop"}


def _plot_drag(ax, fit: DragFit, pts: list[SteadyPoint], title: str, scale: float = 1.0,
               unit: str = "m/s", by_ballast: bool = False):
    groups: dict = {}
    for p in pts:
        key = (p.ballast if by_ballast else p.eta)
        groups.setdefault(key, []).append(p)
    for j, (key, g) in enumerate(groups.items()):
        f = np.array([q.force for q in g])
        v = np.array([q.velocity for q in g]) * scale
        e = np.array([q.velocity_stderr for q in g]) * scale
        lab = f"ballast {int(key)}" if by_ballast else _LABEL.get(key, str(key))
        ax.errorbar(f, v, yerr=2 * e, fmt="o", ms=4, color=f"C{j}", capsize=2, label=lab)
        for sgn in (1, -1):
            fs = np.array([q.force for q in g if np.sign(q.force) == sgn])
            if fs.size == 0:
                continue
            ff = np.linspace(0, fs.max() if sgn > 0 else fs.min(), 100)
            etas = {q.eta for q in g if np.sign(q.force) == sgn}
            ballast = g[0].ballast
            for et in etas:
                try:
                    vv = fit.steady_speed(ff, et, ballast=ballast)
                except ValueError:
                    continue
                ax.plot(ff, np.asarray(vv) * scale, color=f"C{j}", lw=1)
    ax.axhline(0, color="0.7", lw=0.5)
    ax.axvline(0, color="0.7", lw=0.5)
    ax.set_xlabel("nominal applied torque φ [N·m]" if unit == "°/s" else "nominal applied force φ [N]")
    ax.set_ylabel(f"LS steady velocity [{unit}] (±2σ)")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=7)


def _buoyancy(fit: DragFit, n: int):
    W, dW = fit.fit["W"], fit.fit["dW"]
    names = fit.fit.names
    C = fit.fit.covariance
    iw, idw = names.index("W"), names.index("dW")
    est = np.array([W.value + i * dW.value for i in range(n)])
    sig = np.array([math.sqrt(max(C[iw, iw] + i * i * C[idw, idw] + 2 * i * C[iw, idw], 0.0))
                    for i in range(n)])
    return est, sig


def write_outputs(result: Reproduction, out_dir: str | Path) -> Path:
    """Plots (Figs. 5, 6 and the other tables' velocity-vs-thrust fits, inertia experiments,
    measured vs predicted velocity), ``caccia2000.json`` and ``index.html``."""
    from uuvid.core.atomic import atomic_write_json
    from uuvid.core.html import Report
    from uuvid.core.plots import new_figure, save_figure

    art = getattr(result, "artifacts", None)
    if not art:
        raise ValueError("write_outputs needs the object returned by reproduce() (with artifacts)")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rep = Report("Caccia, Indiveri & Veruggio (2000) — ROMEO identification, reproduced in "
                 "simulation")
    rep.add_paragraph(__doc__.split("\n\n")[1])
    acc = result["acceptance"]
    rep.add_paragraph(f"Acceptance ({ACCEPTANCE_RULE}): {'PASSED' if acc['passed'] else 'FAILED'}"
                      + ("" if acc["passed"] else "\n" + "\n".join(acc["failures"])))
    for table in TABLE_KEYS:
        rows = [{"parameter": k, "estimate": r["estimate"], "σ": r["sigma"], "truth": r["truth"],
                 "paper": r["paper"], "paper σ": r["paper_sigma"],
                 "percentile error %": r["percentile_error"],
                 "|est − truth|/σ": r["z"]} for k, r in result[table]["parameters"].items()]
        cap = table + (f" — reduced to {result[table]['reduced_to']}"
                       if result[table].get("reduced_to") else "")
        rep.add_table(rows, caption=cap)
    # Fig. 5: heave velocity vs thrust per ballast
    h = art["heave"]
    fig, ax = new_figure(1, 2, figsize=(12, 4.5))
    _plot_drag(ax[0], h["fit"], h["points"], "Heave (cf. Fig. 5): LS velocity vs nominal thrust, "
               "five ballasts", by_ballast=True)
    est, sig = _buoyancy(h["fit"], 5)
    est0, sig0 = _buoyancy(h["naive"], 5)
    truth = [TRUTH["heave"]["W"] + i * TRUTH["heave"]["dW"] for i in range(5)]
    x = np.arange(5)
    ax[1].errorbar(x - 0.08, est, yerr=2 * sig, fmt="o", capsize=3, label="identified η")
    ax[1].errorbar(x + 0.08, est0, yerr=2 * sig0, fmt="s", capsize=3, label="η = 1 (unitary)")
    ax[1].plot(x, truth, "k_", ms=20, label="truth")
    ax[1].set_xlabel("experiment (added diver weights)")
    ax[1].set_ylabel("W + n ΔW [N] (+ = sinks), ±2σ")
    ax[1].set_title("Buoyancy estimate with and without installation coefficient (cf. Fig. 6)",
                    fontsize=10)
    ax[1].legend(fontsize=8)
    rep.add_figure(save_figure(fig, out / "caccia2000_fig5_fig6_heave.png"),
                   caption="Heave: steady velocities with fitted curves (left) and the net "
                           "weight per experiment with identified vs unitary η (right)")
    # yaw and surge drag plots
    fig, ax = new_figure(2, 3, figsize=(15, 8.5))
    yfit, ypts, _ = art["yaw"]["full"]
    lfit, lpts, _ = art["yaw"]["low"]
    _plot_drag(ax[0, 0], yfit, ypts, "Yaw, linear + quadratic", scale=180 / math.pi, unit="°/s")
    _plot_drag(ax[0, 1], lfit, lpts, f"Yaw, |r| ≤ 10 °/s (reduced to {lfit.reduced_to})",
               scale=180 / math.pi, unit="°/s")
    for a_, key in zip((ax[0, 2], ax[1, 0], ax[1, 1], ax[1, 2]),
                       ("surge_forward_standard", "surge_backward_standard",
                        "surge_forward_plankton", "surge_backward_plankton")):
        fit, pts, _ = art["surge"][key]
        _plot_drag(a_, fit, pts, key.replace("_", " "))
    rep.add_figure(save_figure(fig, out / "caccia2000_drag_fits.png"),
                   caption="Velocity vs nominal force per mapping mode, with the identified "
                           "steady-state curves (Tables III, IV)")
    # inertia experiments
    fig, ax = new_figure(3, 2, figsize=(13, 8.5), sharex="col")
    for j, (key, unit, sc) in enumerate((("yaw", "°/s", 180 / math.pi), ("surge", "m/s", 1.0))):
        inf, ex = art["inertia"][key]
        ax[0, j].plot(ex["t"], ex["force"])
        ax[0, j].set_ylabel("nominal torque [N·m]" if key == "yaw" else "nominal force [N]")
        ax[0, j].set_title(f"{key} inertia experiment (cf. Figs. 12, 14)", fontsize=10)
        ax[1, j].plot(ex["ts"], ex["y"] * (sc if key == "yaw" else 1.0), ".", ms=2,
                      label="measured")
        ax[1, j].set_ylabel("heading [°]" if key == "yaw" else "position [m]")
        ax[2, j].plot(inf.t_raw, inf.velocity_raw * sc, "--", color="0.6", lw=0.8,
                      label="Savitzky–Golay, whole batch")
        ax[2, j].plot(inf.t, inf.velocity * sc, ".", ms=2, color="C0",
                      label="rows used by the regression")
        ax[2, j].plot(ex["t"], ex["true_velocity"] * sc, lw=0.8, color="C1", label="true")
        ax[2, j].set_ylabel(f"velocity [{unit}]")
        ax[2, j].set_xlabel("t [s]")
        ax[2, j].legend(fontsize=8)
    rep.add_figure(save_figure(fig, out / "caccia2000_inertia.png"),
                   caption="Sine experiments: input, raw sensor, Savitzky–Golay velocity (dashed: "
                           "whole batch; dots: rows used by the integrated regression — rows whose "
                           "filter window spans filled gaps are left out, cf. Fig. 14)")
    if "validation_yaw" in art:
        fig, ax = new_figure(2, 2, figsize=(13, 6), sharex="col")
        for j, (key, sc, unit) in enumerate((("validation_yaw", 180 / math.pi, "°/s"),
                                             ("validation_surge", 1.0, "m/s"))):
            tg, vm, vp, tf, ff = art[key]
            ax[0, j].plot(tf, ff)
            ax[0, j].set_ylabel("nominal torque [N·m]" if key == "validation_yaw"
                                else "nominal force [N]")
            ax[1, j].plot(tg, vm * sc, label="measured (S–G)")
            ax[1, j].plot(tg, vp * sc, label="predicted (identified 1-DOF model)")
            ax[1, j].set_ylabel(f"velocity [{unit}]")
            ax[1, j].set_xlabel("t [s]")
            ax[1, j].legend(fontsize=8)
            nm = key.split("_")[1]
            ax[0, j].set_title(f"{nm} validation, NRMSE {result['validation'][nm]['nrmse']:.3f} "
                               f"(cf. Figs. 13, 15)", fontsize=10)
        rep.add_figure(save_figure(fig, out / "caccia2000_validation.png"),
                       caption="Measured vs predicted velocity on validation logs")
    d = result["design"]
    rep.add_table([
        {"quantity": "ω_opt yaw [rad/s] (I = 93.75, k = 28.6)", "numeric Fisher": d["omega_opt_yaw"],
         "1/(√3 τ_c)": d["omega_opt_yaw_analytic"], "paper": d["omega_opt_paper"]["yaw"]},
        {"quantity": "ω_opt surge [rad/s] (m = 675, k_L = 212.25)",
         "numeric Fisher": d["omega_opt_surge"], "1/(√3 τ_c)": d["omega_opt_surge_analytic"],
         "paper": d["omega_opt_paper"]["surge"]},
        {"quantity": "phase lag yaw [°] (24 s, I = 84)", "numeric Fisher": d["phase_lag_yaw_measured_deg"],
         "1/(√3 τ_c)": d["phase_lag_yaw_deg"], "paper": "37.5 predicted / 39 measured"},
        {"quantity": "phase lag surge [°] (26 s, m = 890)",
         "numeric Fisher": d["phase_lag_surge_measured_deg"], "1/(√3 τ_c)": d["phase_lag_surge_deg"],
         "paper": "45 predicted / 37 measured"},
    ], caption="Input design and phase lags (for the lags: 'numeric' column = measured in the "
               "simulated sine experiment, next column = atan(ω m/k_L))")
    rep.add_json({k: v for k, v in result.items() if k in ("design", "validation", "coupling",
                                                           "experiments", "acceptance")},
                 caption="design, validation, coupling check, experiment plan, acceptance")
    atomic_write_json(out / "caccia2000.json", dict(result))
    return rep.write(out)


# ---------------------------------------------------------------------------------------------
# the procedure judged over many seeds
# ---------------------------------------------------------------------------------------------
#: Seeds :func:`seed_study` runs by default (one seed proves little: the acceptance is judged
#: over these).
STUDY_SEEDS = tuple(range(16))


def seed_study(seeds=STUDY_SEEDS, fast: bool = True) -> dict:
    """:func:`reproduce` for each seed and what the procedure achieves across them: the 3σ
    coverage (fraction of estimates within 3σ of the truth) overall and per parameter, the
    fraction of σ within a factor 3 of the paper's, the seeds whose low-speed quadratic came out
    significant, the acceptance pass rate and each failing seed's reasons, and the measured
    phase lags (less the command's half-sample delay) against
    those predicted from the *identified* inertia and drag (mean and largest difference, °).
    About 9 s per seed."""
    seeds = [int(s) for s in seeds]
    if len(seeds) < 1:
        raise ValueError("seed_study needs at least one seed")
    hits: dict[str, list[bool]] = {}
    ratios: list[float] = []
    low_speed_quadratic_kept = []
    passed, failures = [], {}
    lag_diff = {"yaw": [], "surge": []}
    for s in seeds:
        r = reproduce(seed=s, fast=fast)
        for table in TABLE_KEYS:
            for name, row in r[table]["parameters"].items():
                hits.setdefault(f"{table}.{name}", []).append(bool(row["within_3sigma"]))
        ratios += list(r["acceptance"]["sigma_ratio"].values())
        if r["yaw_low_speed"]["quadratic_significant"]:
            low_speed_quadratic_kept.append(s)
        if r["acceptance"]["passed"]:
            passed.append(s)
        else:
            failures[str(s)] = list(r["acceptance"]["failures"])
        d = r["design"]
        for dof in lag_diff:
            lag_diff[dof].append(d[f"phase_lag_{dof}_measured_deg"] - d["zoh_delay_deg"][dof]
                                 - d["phase_lag_identified_deg"][dof])
    n_est = sum(len(v) for v in hits.values())
    n_in = sum(sum(v) for v in hits.values())
    return {
        "seeds": seeds,
        "n_seeds": len(seeds),
        "coverage_3sigma": n_in / n_est,
        "estimates": n_est,
        "within_3sigma": n_in,
        "coverage_by_parameter": {k: sum(v) / len(v) for k, v in hits.items()},
        "sigma_within_factor3_of_paper": float(np.mean([1 / 3 <= q <= 3 for q in ratios])),
        "low_speed_quadratic_kept_seeds": low_speed_quadratic_kept,
        "passed_seeds": passed,
        "pass_rate": len(passed) / len(seeds),
        "failures": failures,
        "phase_lag_minus_identified_deg": {
            k: {"mean": float(np.mean(v)), "max_abs": float(np.max(np.abs(v)))}
            for k, v in lag_diff.items()},
        "acceptance_alpha": ACCEPTANCE_ALPHA,
        "note": "coverage of honest σ: ≈ 99.7 % for normal errors, a little less with the t "
                "distribution of 13–16 residual degrees of freedom; the acceptance is a joint "
                f"bound that a correct procedure fails on at most {ACCEPTANCE_ALPHA:.0%} of seeds "
                f"({ACCEPTANCE_RULE})",
    }
