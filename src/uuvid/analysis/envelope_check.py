"""Confirm a vehicle's analytic speed envelope by simulation, flown as a pilot flies it.

Translational directions (surge, sway, heave): the driven DOF gets the full command (the
allocator's largest force along it) while a controller holds what the vehicle can hold — the
attitude DOFs it controls (roll, pitch, yaw at zero: PID on the angles) and the other
translational DOFs (PID on the NED position, e.g. depth in surge).  The hold has priority: its
thrust is allocated first and the driven DOF gets the largest multiple of its thrust direction
that still fits the limits (as ArduSub's motor mixing does).  The steady velocity of the full
6-DOF model (instantaneous thrust; the steady state does not depend on the thrusters' dynamics) is
compared with the analytic one, ``k_L v + k_Q v|v| = F`` (Caccia et al. 2000, eq. 3).

Roll and pitch that the thrusters cannot control are left to the righting moment; where the static
analysis (:func:`uuvid.vehicle.stability.static_stability`) says the vehicle cannot stay level
below the analytic speed, the direction is not confirmed and the row carries that limit, plus a
check of the analysis: the vehicle flown at 80 % of the limit speed (speed held) against the
analysis' trim angle at that speed.  Such a row has no simulated speed: the full-command flight
tumbles, and its (meaningless) velocity is kept only under ``tumbling_full_command``.

Rotational directions (yaw): the allocated torque is held open loop; roll and pitch rows have a
restoring moment and no steady rate (their maximum moment is reported).

A direction that full command makes no way in (``makes_way`` False: the allocator's speed along
it is ≤ 0, e.g. a positively buoyant vehicle with weak vertical thrusters rises at full dive
command) is still flown, but its ``limit`` and ``note`` say what it does ("cannot dive: rises at
0.40 m/s at full dive command") and :meth:`EnvelopeCheck.warnings` lists it.  The speeds keep
their sign (body axes, z down) in the rows; :meth:`EnvelopeCheck.table_rows` shows them along the
direction named (negative: the other way).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from uuvid.core.result import Result, jsonable
from uuvid.thruster.inflow import inflow_thrust_nb
from uuvid.vehicle.inflow import state_advance_speeds_nb
from uuvid.vehicle.kinematics import quat_to_rotmat
from uuvid.vehicle.layout import dof_index
from uuvid.vehicle.model import vehicle_rhs

ROW_KEYS = ("dof", "direction", "sign", "force", "speed", "allocator_force", "allocator_speed",
            "bollard_speed", "allocator_bollard_speed", "force_unit", "speed_unit",
            "simulated_speed", "relative_difference", "final_roll_deg", "final_pitch_deg",
            "method", "confirmed", "makes_way", "limit", "trim_check_speed", "trim_static_deg",
            "trim_simulated_deg", "tumbling_full_command", "note")
TOLERANCE = 0.05  # relative difference accepted as confirmation


def _tilt_words(tilt) -> str:
    """``up to 35° pitch`` / ``up to 12° roll, 40° pitch``: the tilts a flight reached, a roll or
    pitch that stayed level (under half a degree) left unsaid."""
    parts = [f"{a:.0f}° {n}" for a, n in zip(tilt, ("roll", "pitch")) if a >= 0.5]
    return "up to " + ", ".join(parts) if parts else "level"


@njit(cache=True)
def _rk4_held(x, tau, vp, dt):
    """One RK4 step of the 6-DOF model with ``τ`` held; the quaternion renormalised."""
    k1 = vehicle_rhs(x, tau, vp)
    k2 = vehicle_rhs(x + 0.5 * dt * k1, tau, vp)
    k3 = vehicle_rhs(x + 0.5 * dt * k2, tau, vp)
    k4 = vehicle_rhs(x + dt * k3, tau, vp)
    x = x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    n = math.sqrt(x[3] ** 2 + x[4] ** 2 + x[5] ** 2 + x[6] ** 2)
    for i in range(3, 7):
        x[i] /= n
    return x


@njit(cache=True)
def _settle(x0, tau, vp, dt, nsteps):
    x = x0.copy()
    for _ in range(nsteps):
        x = _rk4_held(x, tau, vp, dt)
    return x


@njit(cache=True)
def _hold_run(x0, vp, B, T, lo0, hi0, ctl, dof, sgn, mode, speed, gains, dt, nsteps, ntail,
              inflow, lim, en, ep, IPRM, IGEO):
    """Fly with the hold controller; ``mode`` 0: full command on ``dof`` (priority to the hold),
    1: NED speed ``sgn·speed`` held along ``dof`` too.  ``lo0``/``hi0``: delivered-thrust limits.
    Returns tail means ``[ν_dof, roll, pitch, command fraction]`` and tail max ``|roll|, |pitch|``
    (angles in rad).  The hold: PID on the NED position (per axis) rotated into body axes and
    PID on the Euler angles of the controlled attitude DOFs other than ``dof``; ``gains`` =
    ``[K_p(6), K_d(6), K_i(6)]``; thrust delivered instantly, ``τ = B t``.

    ``inflow``: the limits at each control step are the thrusts the full commands give at the
    thrusters' present advance speeds, ``η_i T_i(n_lim, u_a,i)`` (:func:`uuvid.thruster.inflow.
    inflow_thrust_nb` of the bollard limits ``lim``; ``IPRM``, ``IGEO``: the mission loop's map
    and geometry), the thrust allocated within them delivered — what the envelope with inflow
    assumes (:func:`uuvid.vehicle.envelope.speed_envelope`)."""
    n = T.shape[0]
    x = x0.copy()
    integ = np.zeros(6)
    phi = np.zeros(6)
    tu = np.zeros(n)
    th = np.zeros(n)
    t = np.zeros(n)
    tau = np.zeros(6)
    lo = lo0.copy()
    hi = hi0.copy()
    ua = np.zeros(n)
    still = np.zeros(3)
    for i in range(n):
        tu[i] = T[i, dof] * sgn
    sig_full = 1e300
    for i in range(n):
        if tu[i] > 0.0:
            sig_full = min(sig_full, hi[i] / tu[i])
        elif tu[i] < 0.0:
            sig_full = min(sig_full, lo[i] / tu[i])
    out = np.zeros(6)
    for step in range(nsteps):
        time = step * dt
        if inflow:
            state_advance_speeds_nb(x, still, IGEO, ua)
            sig_full = 1e300
            for i in range(n):
                lo[i] = en[i] * inflow_thrust_nb(lim[i, 0], ua[i], IPRM)
                hi[i] = ep[i] * inflow_thrust_nb(lim[i, 1], ua[i], IPRM)
                if tu[i] > 0.0:
                    sig_full = min(sig_full, hi[i] / tu[i])
                elif tu[i] < 0.0:
                    sig_full = min(sig_full, lo[i] / tu[i])
        q = x[3:7]
        R = quat_to_rotmat(q)
        ang = np.empty(3)
        ang[0] = math.atan2(R[2, 1], R[2, 2])
        ang[1] = -math.asin(max(-1.0, min(1.0, R[2, 0])))
        ang[2] = math.atan2(R[1, 0], R[0, 0])
        fned = np.zeros(3)
        for i in range(3):
            v = R[i, 0] * x[7] + R[i, 1] * x[8] + R[i, 2] * x[9]
            if i == dof and mode == 0:
                continue
            ref = sgn * speed * time if i == dof else 0.0
            vref = sgn * speed if i == dof else 0.0
            e = ref - x[i]
            fned[i] = gains[i] * e + gains[6 + i] * (vref - v) + gains[12 + i] * integ[i]
            integ[i] += e * dt
        for i in range(3):
            phi[i] = R[0, i] * fned[0] + R[1, i] * fned[1] + R[2, i] * fned[2]
        for k in range(3, 6):
            phi[k] = 0.0
            if ctl[k] and k != dof:
                e = -ang[k - 3]
                phi[k] = gains[k] * e - gains[6 + k] * x[7 + k] + gains[12 + k] * integ[k]
                integ[k] += e * dt
        if mode == 0:
            phi[dof] = 0.0
        for i in range(n):
            s = 0.0
            for j in range(6):
                s += T[i, j] * phi[j]
            th[i] = s
        sh = 1.0
        for i in range(n):
            if th[i] > hi[i]:
                sh = min(sh, hi[i] / th[i])
            elif th[i] < lo[i]:
                sh = min(sh, lo[i] / th[i])
        sig = 0.0
        if mode == 0 and sh >= 1.0:
            sig = sig_full
            for i in range(n):
                if tu[i] > 0.0:
                    sig = min(sig, (hi[i] - th[i]) / tu[i])
                elif tu[i] < 0.0:
                    sig = min(sig, (lo[i] - th[i]) / tu[i])
            sig = max(sig, 0.0)
        for i in range(n):
            t[i] = sh * th[i] + sig * tu[i]
        for j in range(6):
            s = 0.0
            for i in range(n):
                s += B[j, i] * t[i]
            tau[j] = s
        x = _rk4_held(x, tau, vp, dt)
        if step >= nsteps - ntail:
            out[0] += x[7 + dof] / ntail
            out[1] += ang[0] / ntail
            out[2] += ang[1] / ntail
            out[3] += (sig / sig_full if mode == 0 else sh) / ntail
            out[4] = max(out[4], abs(ang[0]))
            out[5] = max(out[5], abs(ang[1]))
    return out


def _gains(vehicle, translation_bandwidth: float = 1.0, attitude_bandwidth: float = 5.0):
    """PID gains placing a triple pole at −ω on each DOF's total inertia ``M_ii``."""
    M = np.diag(vehicle.params.mass_matrix)
    w = np.array([translation_bandwidth] * 3 + [attitude_bandwidth] * 3)
    return np.concatenate([3 * M * w**2, 3 * M * w, M * w**3])


def hold_flight(vehicle, dof, sign: int, speed: float | None = None, t_end: float = 90.0,
                dt: float = 0.01, tail: float = 15.0, inflow: str | None = "none") -> dict:
    """Fly along ``dof`` (sign ±) with the hold controller: at full command (``speed`` None) or
    holding the NED speed ``speed``; tail means of the velocity along ``dof`` and of roll/pitch.
    ``dof`` a translation, or yaw (5: full yaw command, position and roll/pitch held).
    ``inflow`` (``'none'``: bollard thrust; ``None``: the vehicle file's): the thrust limits at
    the thrusters' advance speeds, step by step (see :func:`_hold_run`)."""
    from uuvid.vehicle.inflow import loop_arrays

    d = dof_index(dof) if isinstance(dof, str) else int(dof)
    arrays = loop_arrays(vehicle, inflow)
    iprm, igeo = arrays if arrays is not None else (np.zeros(1), np.zeros((1, 7)))
    alloc = vehicle.allocator(compensate_eta=True)
    ep, en = alloc.eta
    lim = vehicle.layout.limits
    ctl = np.zeros(6, dtype=np.int64)
    ctl[list(alloc.controlled)] = 1
    x0 = np.zeros(13)
    x0[3] = 1.0
    nsteps = int(round(t_end / dt))
    out = _hold_run(x0, vehicle.params.to_array(), np.array(vehicle.B, dtype=float, order="C"),
                    np.ascontiguousarray(alloc.T), lim[:, 0] * en, lim[:, 1] * ep, ctl, d,
                    float(sign), 0 if speed is None else 1, 0.0 if speed is None else float(speed),
                    _gains(vehicle), dt, nsteps, int(round(tail / dt)), arrays is not None,
                    np.array(lim, dtype=float, order="C"), np.asarray(en, float),
                    np.asarray(ep, float), iprm, igeo)
    return {"speed": float(out[0]), "roll_deg": math.degrees(out[1]),
            "pitch_deg": math.degrees(out[2]), "command_fraction": min(1.0, float(out[3])),
            "max_abs_roll_deg": math.degrees(out[4]), "max_abs_pitch_deg": math.degrees(out[5]),
            "method": ("closed loop: full command, attitude and other DOFs held" if speed is None
                       else f"closed loop: speed {speed:.3g} m/s held, attitude and other DOFs held")}


def simulated_speed(vehicle, dof: int, force: float, t_end: float = 120.0, dt: float = 0.01,
                    full: bool = False):
    """Open loop: steady velocity along ``dof`` under the allocated generalised force ``force``
    (with ``full``: also the final roll and pitch in degrees)."""
    alloc = vehicle.allocator(compensate_eta=True)
    phi = np.zeros(6)
    phi[dof] = force
    res = alloc.allocate(phi, saturation="scale")
    tau = vehicle.B @ res.delivered
    x0 = np.zeros(13)
    x0[3] = 1.0
    x = _settle(x0, np.ascontiguousarray(tau), vehicle.params.to_array(), dt, int(t_end / dt))
    if full:
        from uuvid.vehicle.kinematics import quat_to_euler

        rpy = np.degrees(quat_to_euler(x[3:7]))
        return float(x[7 + dof]), float(rpy[0]), float(rpy[1])
    return float(x[7 + dof])


@dataclass(frozen=True)
class EnvelopeCheck(Result):
    """The envelope confirmed by simulation: one row per direction, always with every column of
    :data:`ROW_KEYS` (``None`` where a value does not apply).

    Row keys and the :class:`~uuvid.vehicle.envelope.EnvelopeRow` fields they come from:
    ``force``/``speed`` ← ``force``/``speed`` (the LP's largest force), ``allocator_force``/
    ``allocator_speed`` ← ``force_allocator``/``speed_allocator`` (what the allocator delivers:
    the speed the simulation checks).  With inflow on (``inflow`` ≠ ``'none'``) the rows also
    carry the same speeds with bollard thrust limits: ``bollard_speed`` ← ``speed_bollard``,
    ``allocator_bollard_speed`` ← ``speed_allocator_bollard`` (``None`` with inflow off)."""

    vehicle: str
    rows: tuple[dict, ...]
    stability: object = None  # uuvid.vehicle.stability.StabilityResult
    inflow: str = "none"
    notes: tuple[str, ...] = ()  # the envelope's (uuvid.vehicle.envelope.Envelope.notes)

    def __iter__(self):
        return iter(self.rows)

    def __getitem__(self, direction: str) -> dict:
        for r in self.rows:
            if r["direction"] == direction:
                return r
        raise KeyError(f"no envelope row {direction!r}; have {[r['direction'] for r in self.rows]}")

    def table_rows(self, columns=("direction", "speed", "allocator_speed", "simulated_speed",
                                  "relative_difference", "limit", "note"),
                   units: bool = True) -> list[dict]:
        """Rows for display: ``None`` as "—", speeds along the direction named (``sign ·
        speed``: positive where the vehicle moves the way the direction says, negative where full
        command moves it the other way — "diving −0.40 m/s" rises); with ``units`` the forces and
        speeds as text with the row's unit ("129.3 N", "4.70 rad/s": rows mix translation and
        rotation) and the relative difference in %."""
        out = []
        for r in self.rows:
            d = {}
            for c in columns:
                v = r.get(c)
                if v is None or (isinstance(v, float) and math.isnan(v)):
                    d[c] = "—"
                    continue
                if isinstance(v, float) and c.endswith("speed") and math.isinf(v) and units:
                    from uuvid.vehicle.envelope import UNBOUNDED_TEXT

                    d[c] = UNBOUNDED_TEXT  # no drag in the DOF: never "inf m/s"
                    continue
                if isinstance(v, float) and c.endswith("speed"):
                    v = r["sign"] * v + 0.0  # along the direction named (+ 0.0: no "-0")
                if units and isinstance(v, float):
                    if c.endswith("speed"):
                        v = f"{v:.4g} {r['speed_unit']}"
                    elif c.endswith("force"):
                        v = f"{v:.4g} {r['force_unit']}"
                    elif c == "relative_difference":
                        v = f"{v:.1%}"
                d[c] = v
            out.append(d)
        return out

    @property
    def all_confirmed(self) -> bool:
        return all(r["confirmed"] is not False for r in self.rows)

    def warnings(self) -> list[str]:
        """One line per direction that full command makes no way in ("diving: cannot dive: rises
        at 0.40 m/s at full dive command"), then the envelope's notes that put its speeds in
        doubt (:func:`envelope_warnings`: a fitted propeller map read outside its bench's advance
        angles)."""
        return [f"{r['direction']}: {r['limit']}" for r in self.rows if r["makes_way"] is False] \
            + envelope_warnings(self.notes)

    def plain_notes(self) -> list[str]:
        """The envelope's notes that are not warnings (said once: those are in :meth:`warnings`)."""
        warned = envelope_warnings(self.notes)
        return [n for n in self.notes if n not in warned]

    def summary(self) -> str:
        lines = [f"Speed envelope confirmed by simulation — {self.vehicle}"]
        for r in self.rows:
            lines.append(f"  {r['direction']:<26} {r['note']}")
        lines.extend(f"warning: {w}" for w in self.warnings())
        lines.extend(f"note: {n}" for n in self.plain_notes())
        return "\n".join(lines)

    report_title = "Speed envelope confirmed by simulation"

    def to_dict(self) -> dict:
        return jsonable({"vehicle": self.vehicle, "inflow": self.inflow,
                         "rows": [dict(r) for r in self.rows], "warnings": self.warnings(),
                         "notes": list(self.notes),
                         "stability": self.stability.to_dict() if self.stability is not None
                         else None})

    def plot(self):
        """Allocator (static) and simulated top speed per direction."""
        from uuvid.core.plots import new_figure

        fig, ax = new_figure(1, 1, figsize=(max(6.4, 0.9 * len(self.rows) + 2), 4))
        x = np.arange(len(self.rows))

        def col(key):  # along the direction named (negative: the other way)
            return np.array([r["sign"] * r[key] if r.get(key) is not None else np.nan
                             for r in self.rows], dtype=float)

        ax.bar(x - 0.2, col("allocator_speed"), 0.4, label="allocator (static)")
        ax.bar(x + 0.2, col("simulated_speed"), 0.4, label="simulated")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_xticks(x)
        ax.set_xticklabels([r["direction"] for r in self.rows], rotation=30, ha="right",
                           fontsize=8)
        ax.set_ylabel("top speed along the direction\n(m/s or rad/s, per row; < 0: the other way)")
        ax.set_title(f"{self.vehicle}: speed envelope", fontsize=10)
        ax.legend(fontsize=8)
        return fig


WARNING_NOTES = ("extrapolated:",)  # the envelope notes that put its speeds in doubt


def envelope_warnings(notes) -> list[str]:
    """The notes of an envelope (:attr:`uuvid.vehicle.envelope.Envelope.notes`) that are warnings,
    not explanations: its speeds rest on a fitted propeller map read outside the advance angles
    its bench covered ("extrapolated: …").  Every command that shows speeds from that envelope
    (``vehicle envelope``, ``vehicle stability``) says them on stderr and in ``--json``'s
    ``warnings``."""
    return [n for n in notes if n.startswith(WARNING_NOTES)]


def _row(r) -> dict:
    d = dict.fromkeys(ROW_KEYS)
    d.update({"dof": r.dof, "direction": r.direction, "sign": r.sign, "force": r.force,
              "allocator_force": r.force_allocator, "force_unit": r.force_unit,
              "speed_unit": r.speed_unit})
    d["speed"] = None if math.isnan(r.speed) else r.speed
    d["allocator_speed"] = None if math.isnan(r.speed_allocator) else r.speed_allocator
    return d


def _level_limit(case) -> str:
    return f"stability: level only to {case.limit_speed:.2f} m/s ({case.limit_dof})"


def confirm_envelope(vehicle, env=None, stability=None, tolerance: float = TOLERANCE,
                     simulate: bool = True, inflow: str | None = None) -> EnvelopeCheck:
    """Simulate every direction of the envelope (see the module text) and say which are
    confirmed within ``tolerance`` of the allocator's analytic speed, and why not
    (``simulate=False``: the analytic rows with the stability limits only).

    ``inflow`` (``None``: the vehicle file's, ``'none'``: bollard thrust): with inflow the rows
    carry the bollard-thrust speeds beside (``bollard_speed``, ``allocator_bollard_speed``: the
    latter is the one to compare with ``allocator_speed``) and the confirming flight
    (:func:`hold_flight`) takes each thruster's limit at its advance speed at every control step;
    the yaw rows fly full yaw command with position, roll and pitch held (bollard yaw rows: the
    allocated torque open loop, as before)."""
    from uuvid.vehicle.envelope import speed_envelope
    from uuvid.vehicle.stability import static_stability, trim_state

    env = speed_envelope(vehicle, inflow=inflow) if env is None else env
    stab = static_stability(vehicle, envelope=env, inflow=env.inflow) if stability is None \
        else stability
    with_inflow = env.inflow != "none"
    rows = []
    for r in env.rows:
        d = _row(r)
        if with_inflow:  # the same speeds with bollard thrust limits (EnvelopeCheck's keys)
            d["bollard_speed"] = None if math.isnan(r.speed_bollard) else r.speed_bollard
            d["allocator_bollard_speed"] = None if math.isnan(r.speed_allocator_bollard) else \
                r.speed_allocator_bollard
        k = dof_index(r.dof)
        ref = r.speed_allocator
        if k in (3, 4):
            d["method"] = "analytic"
            d["limit"] = f"moment {r.force_allocator:.3g} {r.force_unit}"
            d["note"] = ("restoring moment, no steady rate: the largest moment "
                         f"{r.force_allocator:.3g} {r.force_unit} is reported")
            rows.append(d)
            continue
        # full command moves the vehicle the other way (or not at all): say so, in the limit and
        # the note; never a "stays level to" built on the size of a speed of the wrong sign
        no_way = r.no_way()
        d["makes_way"] = not no_way
        if math.isinf(ref):  # no drag in this DOF: nothing bounds the speed, nothing to fly to
            from uuvid.vehicle.envelope import UNBOUNDED_TEXT

            d["confirmed"] = False
            d["limit"] = f"speed {UNBOUNDED_TEXT}"
            d["note"] = (f"{UNBOUNDED_TEXT}: the vehicle file gives {r.dof} neither linear nor "
                         f"quadratic damping, so {r.force_allocator:.4g} {r.force_unit} "
                         "accelerates it for ever; expected positive damping")
            rows.append(d)
            continue
        if r.force_allocator <= 0 or not math.isfinite(ref):
            d["confirmed"] = False
            d["note"] = "the allocator gives no force along this direction"
            if no_way:
                d["limit"] = no_way
                d["note"] = f"{no_way} ({d['note']})"
            rows.append(d)
            continue
        case = stab.get(r.direction) if k < 3 else None
        if not simulate:
            d["limit"] = no_way or (case.limit_text() if case is not None else "—")
            d["method"] = "analytic"
            d["note"] = f"{no_way}; not simulated" if no_way else "not simulated"
            if not no_way and case is not None and case.limited and \
                    case.limit_speed < r.along_allocator:
                d["confirmed"] = False
                d["limit"] = _level_limit(case)
                d["note"] = (f"cannot stay level above {case.limit_speed:.2f} m/s "
                             f"({case.limit_dof}: {case.limit_reason})")
            rows.append(d)
            continue
        if k < 3 or with_inflow:
            sim = hold_flight(vehicle, k, r.sign, inflow=env.inflow)
            d.update(simulated_speed=sim["speed"], final_roll_deg=sim["roll_deg"],
                     final_pitch_deg=sim["pitch_deg"], method=sim["method"])
            tilt = (sim["max_abs_roll_deg"], sim["max_abs_pitch_deg"])
        else:
            v, roll, pitch = simulated_speed(vehicle, k, r.sign * r.force_allocator, full=True)
            d.update(simulated_speed=v, final_roll_deg=roll, final_pitch_deg=pitch,
                     method="open loop (allocated torque held)")
        rel = abs(d["simulated_speed"] - ref) / abs(ref) if ref else math.nan
        d["relative_difference"] = rel
        d["confirmed"] = bool(rel <= tolerance)
        d["limit"] = case.limit_text() if case is not None else "—"
        if no_way:
            d["limit"] = no_way
            agree = ("" if math.isnan(rel) else f", within {rel:.1%} of the analysis"
                     if d["confirmed"] else f", {rel:.0%} off the analysis")
            d["note"] = (f"{no_way} (the simulation flies {d['simulated_speed']:+.3g} "
                         f"{r.speed_unit} in body axes{agree})")
        elif case is not None and case.limited and case.limit_speed < r.along_allocator:
            # the full-command flight tumbles: its speed is no check of the analytic one
            d["tumbling_full_command"] = {
                "speed": d["simulated_speed"], "relative_difference": rel,
                "final_roll_deg": d["final_roll_deg"], "final_pitch_deg": d["final_pitch_deg"],
                "max_abs_roll_deg": tilt[0], "max_abs_pitch_deg": tilt[1]}
            d.update(simulated_speed=None, relative_difference=None, final_roll_deg=None,
                     final_pitch_deg=None, confirmed=False)
            us = 0.8 * case.limit_speed
            st = trim_state(vehicle, k, r.sign, us)
            fl = hold_flight(vehicle, k, r.sign, speed=us, inflow=env.inflow)
            ang = case.limit_dof
            d["limit"] = _level_limit(case)
            d["trim_check_speed"] = us
            d["trim_static_deg"] = st["tilt_deg"][ang]
            d["trim_simulated_deg"] = fl[f"{ang}_deg"]
            d["note"] = (f"not confirmed: cannot stay level above {case.limit_speed:.2f} m/s "
                         f"({ang}: {case.limit_reason}; righting BG·W "
                         f"{case.righting[ang]:.3g} N·m/rad); at {us:.2f} m/s the static trim is "
                         f"{st['tilt_deg'][ang]:+.1f}° {ang}, the simulation flies "
                         f"{fl[f'{ang}_deg']:+.1f}°; at full command it "
                         f"{'tumbles' if max(tilt) > 60 else 'tilts'} ({_tilt_words(tilt)}), "
                         "so no steady speed is simulated")
        elif d["confirmed"]:
            d["note"] = f"confirmed within {rel:.1%}"
        else:
            d["note"] = (f"not confirmed: {rel:.0%} off, roll {d['final_roll_deg']:.0f}°, pitch "
                         f"{d['final_pitch_deg']:.0f}° (coupling the uncoupled analytic speed "
                         "ignores)")
        rows.append(d)
    return EnvelopeCheck(vehicle.name, tuple(rows), stab, env.inflow, tuple(env.notes))
