"""Station keeping: an LQR designed on the linearised vehicle against the PID DP, one compiled loop.

The plant is the 6-DOF model of :mod:`uuvid.vehicle.model` — the same compiled derivative
:func:`uuvid.vehicle.model.vehicle_rhs_into` the mission loop integrates — with ideal thrusters
(thrust = command, held over the control step ``dt``, clipped to each thruster's limits), RK4
with ``substeps`` per step and a constant NED current the controllers do not know.

Controllers (both at the control rate ``1/dt``):

* **PID DP** — :mod:`uuvid.simulate.control.blocks` exactly as the mission loop uses it (body-frame
  errors, conditional-integration anti-windup, attitude hold when available) followed by the
  vehicle's allocation (:func:`uuvid.vehicle.allocation.allocate_compiled`, uniform scaling).
* **LQR with integral action (LQI)** — ``f = f₀ − K [ξ; ∫e]`` on the 12-state deviation ``ξ`` of
  :mod:`uuvid.vehicle.linearize` (``f₀`` the trim thrust) and the integral of the position and
  yaw deviations ``e = [δn, δe, δd, α_z]``; ``K`` minimises ``∫ ξᵀQξ + δfᵀRδf`` for the
  augmented linear model (continuous algebraic Riccati equation; python-control's ``lqr`` gives
  the same ``K``).  The integrator stops while a thruster is clipped (anti-windup).

:func:`compare_station_keeping` flies both from the same disturbed start and scales ``R`` so the
LQR's peak thrust equals the PID's (bisection), then compares the RMS position error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from uuvid.core.result import Result, jsonable
from uuvid.simulate.control.lqr import (
    augment_integral,
    default_weights,
    deviation_into,
    lqi_step,
    lqr_gain,
)
from uuvid.simulate.control.pid import DPGains, attitude_hold, dp_control, dp_errors, quat_yaw
from uuvid.vehicle.allocation import allocate_compiled
from uuvid.vehicle.kinematics import normalise_state
from uuvid.vehicle.linearize import LinearModel, OperatingPoint, linearize
from uuvid.vehicle.model import vehicle_rhs_into

PID, LQR = 0, 1


# ---------------------------------------------------------------------------------------------
# Compiled plant step and loop
# ---------------------------------------------------------------------------------------------
@njit(cache=True)
def rk4_held(z, tau, vp, vc, h, nsub, dvc, k1, k2, k3, k4, zt):
    """Advance the 13-state ``z`` in place by ``nsub`` RK4 steps of ``h`` with ``τ`` held."""
    for _ in range(nsub):
        vehicle_rhs_into(z, tau, vp, vc, dvc, k1)
        for i in range(13):
            zt[i] = z[i] + 0.5 * h * k1[i]
        vehicle_rhs_into(zt, tau, vp, vc, dvc, k2)
        for i in range(13):
            zt[i] = z[i] + 0.5 * h * k2[i]
        vehicle_rhs_into(zt, tau, vp, vc, dvc, k3)
        for i in range(13):
            zt[i] = z[i] + h * k3[i]
        vehicle_rhs_into(zt, tau, vp, vc, dvc, k4)
        for i in range(13):
            z[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        normalise_state(z)


@njit(cache=True)
def thrust_to_tau(Bthr, f, tau):
    """``τ = B_thr f`` into ``tau`` (6)."""
    for r in range(6):
        s = 0.0
        for i in range(Bthr.shape[1]):
            s += Bthr[r, i] * f[i]
        tau[r] = s


def _read_only(a) -> np.ndarray:
    """A C-contiguous float copy that cannot be written: the LQI's ``K``, ``f₀`` and limits reach
    :func:`~uuvid.simulate.control.lqr.lqi_step` read-only from the mission loop too (a
    controller's parameters are frozen), so the one compiled signature serves both loops."""
    out = np.array(a, dtype=float, order="C")
    out.flags.writeable = False
    return out


@njit(cache=True)
def station_loop(z0, vp, vc, Bthr, lo, hi, kind, alloc, gains, K, x_ref, f0, dt, nsub, Z, F):
    """Hold ``x_ref`` (13) for ``Z.shape[0]`` steps with the PID (``kind`` 0: ``alloc``,
    ``gains``) or the LQI (``kind`` 1: ``K`` (n × 16), trim thrust ``f0``); writes the states
    ``Z`` at the start of each step and the thrusts ``F`` held over it."""
    nsteps = Z.shape[0]
    n = Bthr.shape[1]
    z = z0.copy()
    k1 = np.empty(13)
    k2 = np.empty(13)
    k3 = np.empty(13)
    k4 = np.empty(13)
    zt = np.empty(13)
    dvc = np.zeros(3)
    tau = np.zeros(6)
    f = np.zeros(n)
    e = np.zeros(4)
    edot = np.zeros(4)
    integ = np.zeros(4)
    integ_new = np.zeros(4)
    tau_des = np.zeros(6)
    xi = np.zeros(16)
    zero3 = np.zeros(3)
    ref_pos = x_ref[0:3]
    ref_yaw = quat_yaw(x_ref[3:7])
    for k in range(nsteps):
        if kind == 0:
            dp_errors(z[0:3], z[3:7], z[7:13], ref_pos, zero3, ref_yaw, 0.0, e, edot)
            dp_control(e, edot, integ, gains, dt, tau_des, integ_new)
            attitude_hold(z[3:7], z[7:13], gains, tau_des)
            for j in range(4):
                integ[j] = integ_new[j]
            allocate_compiled(alloc, tau_des, f)
        else:
            deviation_into(x_ref, z, xi)
            lqi_step(K, f0, lo, hi, xi, integ, dt, f)
        for i in range(n):
            f[i] = min(max(f[i], lo[i]), hi[i])
            F[k, i] = f[i]
        for i in range(13):
            Z[k, i] = z[i]
        thrust_to_tau(Bthr, f, tau)
        rk4_held(z, tau, vp, vc, dt / nsub, nsub, dvc, k1, k2, k3, k4, zt)


# ---------------------------------------------------------------------------------------------
# Python API
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class StationKeepingRun:
    """One controller holding station: time, 13-states, thrusts and the scores."""

    controller: str
    t: np.ndarray
    state: np.ndarray
    thrust: np.ndarray
    x_ref: np.ndarray

    @property
    def position_error(self) -> np.ndarray:
        return np.linalg.norm(self.state[:, 0:3] - self.x_ref[0:3], axis=1)

    @property
    def rms_error(self) -> float:
        return float(np.sqrt(np.mean(self.position_error**2)))

    @property
    def peak_thrust(self) -> float:
        return float(np.max(np.abs(self.thrust)))

    @property
    def final_error(self) -> float:
        return float(self.position_error[-1])

    def to_dict(self) -> dict:
        return {"controller": self.controller, "rms_position_error_m": self.rms_error,
                "peak_thrust_N": self.peak_thrust, "final_position_error_m": self.final_error,
                "max_position_error_m": float(np.max(self.position_error))}


@dataclass(frozen=True)
class StationKeepingComparison(Result):
    """PID DP against LQI on the same vehicle, disturbance and peak thrust."""

    vehicle: str
    pid: StationKeepingRun
    lqr: StationKeepingRun
    K: np.ndarray
    r_scale: float
    offset: np.ndarray
    current: np.ndarray
    linear_model: LinearModel = field(repr=False)

    @property
    def lqr_better(self) -> bool:
        return self.lqr.rms_error < self.pid.rms_error

    report_title = "Station keeping: PID DP vs LQI"

    def to_dict(self) -> dict:
        return jsonable({"vehicle": self.vehicle, "offset": self.offset.tolist(),
                         "current_ned_m_s": self.current.tolist(), "r_scale": self.r_scale,
                         "pid": self.pid.to_dict(), "lqr": self.lqr.to_dict(),
                         "lqr_smaller_rms_error": self.lqr_better})

    def summary(self) -> str:
        p, q = self.pid, self.lqr
        verdict = ("the LQR holds station with the smaller RMS error" if self.lqr_better
                   else "the PID holds station with the smaller RMS error (the LQR does NOT win)")
        return (f"{self.vehicle}: station keeping from offset {self.offset.tolist()} "
                f"(m, m, m, rad yaw) in a {self.current.tolist()} m/s current\n"
                f"  PID DP: RMS error {p.rms_error:.4f} m, peak thrust {p.peak_thrust:.2f} N, "
                f"final {p.final_error:.4f} m\n"
                f"  LQI   : RMS error {q.rms_error:.4f} m, peak thrust {q.peak_thrust:.2f} N, "
                f"final {q.final_error:.4f} m (R scaled by {self.r_scale:.3g})\n"
                f"  → {verdict}")

    def plot(self):
        from uuvid.core.plots import new_figure

        fig, ax = new_figure(2, 1, sharex=True)
        for run in (self.pid, self.lqr):
            ax[0].plot(run.t, run.position_error, label=run.controller)
            ax[1].plot(run.t, np.max(np.abs(run.thrust), axis=1), label=run.controller)
        ax[0].set_ylabel("position error (m)")
        ax[1].set_ylabel("max |thrust| (N)")
        ax[1].set_xlabel("time (s)")
        ax[0].legend()
        ax[0].set_title(f"{self.vehicle}: station keeping, PID DP vs LQI")
        return fig


def _vehicle(vehicle):
    if isinstance(vehicle, str):
        from uuvid.vehicle.definition import load_vehicle

        return load_vehicle(vehicle)
    return vehicle


def fly_station(vehicle, controller: str, *, x_ref, z0, current=(0.0, 0.0, 0.0), K=None, f0=None,
                gains: DPGains | None = None, duration: float = 30.0, dt: float = 0.01,
                substeps: int = 1) -> StationKeepingRun:
    """Fly one controller (``"pid"`` or ``"lqr"``) in :func:`station_loop`."""
    v = _vehicle(vehicle)
    if not (dt > 0 and substeps >= 1 and duration > dt):
        raise ValueError("need dt > 0, substeps >= 1 and duration > dt")
    n = v.layout.n
    nsteps = int(round(duration / dt))
    Z = np.empty((nsteps, 13))
    F = np.empty((nsteps, n))
    lim = v.layout.limits
    alloc = v.allocator().to_array("scale")  # uniform scaling, as this study was tuned with
    if gains is None:
        from uuvid.simulate.vehicle_sim import default_gains

        gains = default_gains(v)
    kind = {"pid": PID, "lqr": LQR}[controller]
    if kind == LQR and (K is None or f0 is None):
        raise ValueError("the LQR needs its gain K (n × 16) and trim thrust f0")
    Kc = _read_only(np.zeros((n, 16)) if K is None else K)
    f0c = _read_only(np.zeros(n) if f0 is None else f0)
    station_loop(np.asarray(z0, float), v.params.to_array(), np.asarray(current, float),
                 np.array(v.B, dtype=float, order="C"), _read_only(lim[:, 0]), _read_only(lim[:, 1]), kind,
                 alloc, gains.to_array(), Kc, np.asarray(x_ref, float), f0c, dt, int(substeps),
                 Z, F)
    if not np.all(np.isfinite(Z)):
        raise ValueError(f"{controller} station keeping diverged; try a smaller dt")
    return StationKeepingRun(controller, np.arange(nsteps) * dt, Z, F, np.asarray(x_ref, float))


def compare_station_keeping(vehicle="bluerov2", *, offset=(1.0, -0.5, 0.3, 0.3),
                            current=(0.15, 0.1, 0.0), duration: float = 40.0, dt: float = 0.01,
                            weights=None, match_peak: bool = True,
                            tol: float = 0.01) -> StationKeepingComparison:
    """LQI (linearised at hover) against the PID DP holding the origin.

    The vehicle starts at ``offset = [δn, δe, δd, δψ]`` (m, rad) from the station, at rest, in a
    constant NED ``current`` neither controller knows.  With ``match_peak`` the LQR's ``R`` is
    scaled (bisection on ``log ρ``) until its peak thrust equals the PID's within ``tol``
    (relative).  ``weights`` = ``(Q, R)`` for the 16-state augmented model (default
    :func:`default_weights`).
    """
    v = _vehicle(vehicle)
    lin = linearize(v, OperatingPoint.hover(v))
    x_ref = lin.x0
    off = np.asarray(offset, dtype=float)
    if off.shape != (4,):
        raise ValueError("offset must be [north, east, down, yaw] (m, m, m, rad)")
    z0 = x_ref.copy()
    z0[0:3] += off[0:3]
    z0[3:7] = [math.cos(off[3] / 2), 0.0, 0.0, math.sin(off[3] / 2)]
    Aa, Ba = augment_integral(lin)
    Q, R = weights if weights is not None else default_weights(lin)
    kw = dict(x_ref=x_ref, z0=z0, current=current, duration=duration, dt=dt)
    pid = fly_station(v, "pid", **kw)

    def run(rho):
        K = lqr_gain(Aa, Ba, Q, rho * R)
        return K, fly_station(v, "lqr", K=K, f0=lin.thrust0, **kw)

    rho = 1.0
    K, lqr = run(rho)
    if match_peak:
        target = pid.peak_thrust
        lo_r, hi_r = 1e-4, 1e4  # peak thrust falls as R grows
        for _ in range(60):
            if abs(lqr.peak_thrust - target) <= tol * target:
                break
            if lqr.peak_thrust > target:
                lo_r = rho
            else:
                hi_r = rho
            rho = math.sqrt(lo_r * hi_r)
            K, lqr = run(rho)
    return StationKeepingComparison(v.name, pid, lqr, K, rho, off, np.asarray(current, float),
                                    lin)
