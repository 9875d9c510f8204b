"""Static stability in steady flight: can the vehicle stay level at speed?

A vehicle whose thrusters cannot produce roll or pitch moments (the 6-thruster BlueROV2) is held
level only by its righting moment.  In steady straight flight at speed ``U`` (NED velocity
``U e_d`` along the driven DOF, heading and every *controlled* DOF held by the thrusters) the
steady 6-DOF model (Fossen 2011, §§4.1, 6.3–6.4; ``ν̇ = 0``, ``ω = 0``) asks for the generalised
force

    τ_req(θ, U) = C_RB(ν)ν + C_A(ν)ν + D(ν)ν + g(q),      ν₁ = R(q)ᵀ U e_d

The allocator delivers ``τ_req`` on the controlled rows; its thrust ``τ_thr = B η(T τ_req)`` also
has components on the free rows (the moment arms of the thrusters producing the force).  The
free attitude angles settle where the free rows balance, ``(τ_thr − τ_req)_free = 0``.
For pitch in surge, with small angles, drag acting at the origin and thrust at height ``z_T``::

    z_T X(U)  +  (A₃₃ − A₁₁) U² θ  −  (W z_G − B z_B) θ  = 0
    θ* ≈ z_T X(U) / (BG·W − (A₃₃ − A₁₁) U²)

(``BG·W = W z_G − B z_B`` the righting moment per radian; ``A₃₃ − A₁₁ = X_u̇ − Z_ẇ`` the Munk
moment of the added-mass difference, ``M = (A₃₃ − A₁₁) u w`` with ``w = U sin θ``; roll in sway
likewise with ``A₃₃ − A₂₂``).  The vehicle can no longer stay level at the first speed where the
trim tilt exceeds ``max_tilt_deg``, where the static stiffness ``∂(τ_thr − τ_req)/∂θ`` stops being
restoring, or where no equilibrium exists.  The analysis solves the full nonlinear balance (not
only the small-angle form, which is reported alongside) by continuation in ``U``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from uuvid.core.result import Result
from uuvid.vehicle.allocation import apply_eta
from uuvid.vehicle.hydrodynamics import added_mass_coriolis, damping_force, restoring_forces
from uuvid.vehicle.kinematics import euler_to_rotmat
from uuvid.vehicle.model import DOF_NAMES, MAX_TILT_DEG  # noqa: F401  (the level limit)
from uuvid.vehicle.rigid_body import rigid_body_coriolis

ATTITUDE = (3, 4)  # roll, pitch: the DOFs with a righting moment
SPEED_DIGITS = 3  # significant digits of a speed in the text, more where distinct speeds need them


def speed_digits(values, least: int = SPEED_DIGITS, most: int = 6) -> int:
    """Significant digits that print distinct speeds distinctly: at least ``least`` (0.384 and
    0.377 m/s were both "0.38"), more while two speeds that differ (beyond rounding noise, 1e-9
    relative) still print alike, at most ``most``."""
    vals = sorted({float(v) for v in values if math.isfinite(v)})
    for n in range(least, most):
        seen: dict[str, float] = {}
        if all(math.isclose(seen.setdefault(f"{v:.{n}g}", v), v, rel_tol=1e-9, abs_tol=1e-12)
               for v in vals):
            return n
    return most


class _Balance:
    """Residual ``(τ_thr − τ_req)`` on the free rows for one driven DOF and direction."""

    def __init__(self, vehicle, dof: int, sign: int, modes=None, inflow=None):
        self.p = vehicle.params
        self.inflow = inflow  # uuvid.vehicle.inflow.InflowLimits, or None (bollard limits)
        self.alloc = vehicle.allocator(modes, compensate_eta=True)
        self.B = vehicle.B
        self.ep, self.en = self.alloc.eta
        ctl = set(self.alloc.controlled)
        self.dof, self.sign = dof, sign
        self.free_att = [k for k in ATTITUDE if k not in ctl]
        self.free_trans = [j for j in range(3) if j not in ctl and j != dof]
        self.free = self.free_att + self.free_trans
        self.lo, self.hi = vehicle.layout.limits[:, 0], vehicle.layout.limits[:, 1]

    def nu(self, z, U):
        ang = np.zeros(3)
        for i, k in enumerate(self.free_att):
            ang[k - 3] = z[i]
        R = euler_to_rotmat(ang[0], ang[1], 0.0)
        V = np.zeros(3)
        V[self.dof] = self.sign * U
        nu = np.zeros(6)
        nu[:3] = R.T @ V
        for i, j in enumerate(self.free_trans):
            nu[j] += z[len(self.free_att) + i]
        return nu, R

    def parts(self, z, U):
        """``(τ_req, τ_thr, thrust fraction)`` at unknowns ``z`` and speed ``U``."""
        p = self.p
        nu, R = self.nu(z, U)
        req = (rigid_body_coriolis(p.M_RB, nu) @ nu + added_mass_coriolis(p.M_A, nu) @ nu
               + damping_force(p.linear_damping, p.quadratic_damping, nu)
               + restoring_forces(p.weight, p.buoyancy, p.r_g, p.r_b, R))
        t = self.alloc.nominal(req)
        thr = self.B @ apply_eta(t, self.ep, self.en)
        lo, hi = self.lo, self.hi
        if self.inflow is not None:  # limits at the advance speed of this steady state
            lim = self.inflow.limits_at(nu)
            lo, hi = lim[:, 0], lim[:, 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            frac = np.where(t >= 0, t / hi, t / lo)
        return req, thr, float(np.nanmax(frac, initial=0.0))

    def residual(self, z, U):
        req, thr, _ = self.parts(z, U)
        return (thr - req)[self.free]

    def jacobian(self, z, U, h=1e-6):
        n = len(z)
        J = np.empty((n, n))
        for i in range(n):
            e = np.zeros(n)
            e[i] = h
            J[:, i] = (self.residual(z + e, U) - self.residual(z - e, U)) / (2 * h)
        return J

    def munk_stiffness(self, U, h=1e-6):
        """``∂M_Munk/∂angle`` at level (N·m/rad per free angle; > 0 turns the vehicle further)."""
        out = []
        for i, k in enumerate(self.free_att):
            def m(a, i=i, k=k):
                z = np.zeros(len(self.free))
                z[i] = a
                nu, _ = self.nu(z, U)
                return -(added_mass_coriolis(self.p.M_A, nu) @ nu)[k]
            out.append((m(h) - m(-h)) / (2 * h))
        return out


def trim_state(vehicle, dof, sign: int, speed: float, guess=None, modes=None) -> dict:
    """Steady trim at ``speed`` along ``dof`` (sign ±): free roll/pitch angles (deg), body
    velocity, thrust fraction, static stiffness and whether the balance was found."""

    from uuvid.vehicle.layout import dof_index

    d = dof_index(dof) if isinstance(dof, str) else int(dof)
    bal = _Balance(vehicle, d, int(sign), modes)
    return _solve(bal, float(speed), np.zeros(len(bal.free)) if guess is None else guess)


def _newton(bal: _Balance, U: float, z0, iters: int = 60):
    """Damped Newton on the free-row balance; converged when the residual is below 1e-9 of the
    largest force or moment in play."""
    z = np.array(z0, dtype=float)
    r = bal.residual(z, U)
    scale = max(1.0, float(np.abs(bal.parts(z, U)[0]).max()))
    for _ in range(iters):
        if np.abs(r).max() < 1e-9 * scale:
            return z, bool(np.all(np.abs(z[:len(bal.free_att)]) < math.pi / 2))
        try:
            step = np.linalg.solve(bal.jacobian(z, U), r)
        except np.linalg.LinAlgError:
            return z, False
        t, n0 = 1.0, np.abs(r).max()
        while t > 1e-4:
            zt = z - t * step
            rt = bal.residual(zt, U)
            if np.abs(rt).max() < n0:
                break
            t *= 0.5
        else:
            return z, False
        z, r = zt, rt
    return z, False


def _solve(bal: _Balance, U: float, z0) -> dict:
    z0 = np.asarray(z0, dtype=float)
    if not bal.free:
        z, ok = z0, True
    else:
        z, ok = _newton(bal, U, z0)
    na = len(bal.free_att)
    stiff = []
    stable = True
    if na and ok:
        J = bal.jacobian(z, U)
        stiff = list(np.diag(J)[:na])
        stable = bool(np.all(np.linalg.eigvals(J).real < 0))
    _, _, frac = bal.parts(z, U)
    nu, _ = bal.nu(z, U)
    return {"ok": ok, "stable": stable, "z": z,
            "tilt_deg": {DOF_NAMES[k]: math.degrees(z[i]) for i, k in enumerate(bal.free_att)},
            "stiffness": {DOF_NAMES[k]: s for k, s in zip(bal.free_att, stiff)},
            "body_velocity": nu[:3].tolist(), "thrust_fraction": frac}


@dataclass(frozen=True)
class StabilityCase:
    """Trim against speed for one direction (arrays over ``speeds``)."""

    dof: str
    direction: str
    sign: int
    free: tuple[str, ...]  # attitude DOFs left to the righting moment
    speeds: np.ndarray  # m/s
    tilt_deg: dict  # free DOF → trim angle (deg), nan beyond the last equilibrium
    tilt_small_deg: dict  # free DOF → small-angle estimate −J₀⁻¹ r₀ (deg)
    righting: dict  # free DOF → BG·W, N·m/rad (restoring)
    thrust_moment: dict  # free DOF → moment of the thrust at level, N·m
    munk_stiffness: dict  # free DOF → ∂M_Munk/∂angle at level, N·m/rad (destabilising if > 0)
    thrust_fraction: np.ndarray  # largest |thrust|/limit needed for the trim
    max_speed: float  # the envelope's analytic speed along this direction (< 0: the other way)
    limit_speed: float  # first speed where the vehicle cannot stay level (inf: none ≤ max)
    limit_dof: str | None
    limit_reason: str
    no_way: str = ""  # full command makes no way in this direction: what it does instead

    @property
    def limited(self) -> bool:
        return math.isfinite(self.limit_speed)

    @property
    def makes_way(self) -> bool:
        """Whether full command moves the vehicle the way the direction names (if not, only the
        trim at rest is scanned and :meth:`limit_text` says what it does instead)."""
        return not self.no_way

    def limit_text(self, digits: int = SPEED_DIGITS) -> str:
        """What limits the flight in this direction, speeds to ``digits`` significant digits."""
        if self.no_way:
            return self.no_way
        if not self.free:
            return "attitude held by thrusters"
        if not self.limited:
            return f"stays level to {self.max_speed:.{digits}g} m/s"
        return f"stability {self.limit_speed:.{digits}g} m/s ({self.limit_dof})"

    def to_dict(self) -> dict:
        d = {k: getattr(self, k) for k in ("dof", "direction", "sign", "max_speed", "limit_speed",
                                           "limit_dof", "limit_reason", "makes_way")}
        d["free"] = list(self.free)
        d["limit"] = self.limit_text()
        d["speeds"] = self.speeds.tolist()
        d["thrust_fraction"] = self.thrust_fraction.tolist()
        for nm in ("tilt_deg", "tilt_small_deg", "thrust_moment", "munk_stiffness"):
            d[nm] = {k: np.asarray(v).tolist() for k, v in getattr(self, nm).items()}
        d["righting"] = dict(self.righting)
        return d


@dataclass(frozen=True)
class StabilityResult(Result):
    """Static stability of a vehicle in steady flight along each translational direction."""

    vehicle: str
    cases: tuple[StabilityCase, ...]
    max_tilt_deg: float
    notes: tuple[str, ...] = field(default_factory=tuple)
    inflow: str = "none"  # the inflow model the envelope speeds and thrust fractions took

    def __getitem__(self, direction: str) -> StabilityCase:
        for c in self.cases:
            if direction in (c.direction, f"{c.dof} {'+' if c.sign > 0 else '-'}"):
                return c
        raise KeyError(f"no stability case {direction!r}; have {[c.direction for c in self.cases]}")

    def get(self, direction: str) -> StabilityCase | None:
        try:
            return self[direction]
        except KeyError:
            return None

    def warnings(self) -> list[str]:
        """One line per direction that full command makes no way in ("diving: cannot dive: rises
        at 0.40 m/s at full dive command")."""
        return [f"{c.direction}: {c.no_way}" for c in self.cases if c.no_way]

    def _summary_index(self, c: StabilityCase) -> int:
        """The speed sample the summary shows a case's trim at: 4/5 of its level range."""
        fin = [i for i in range(len(c.speeds)) if c.free and np.isfinite(c.tilt_deg[c.free[0]][i])]
        return fin[len(fin) * 4 // 5] if fin else 0

    def speed_digits(self) -> int:
        """Significant digits for the speeds the table and summary print (:func:`speed_digits`
        over every limit, top speed and trim speed shown), so that distinct ones read distinct."""
        vals = [x for c in self.cases for x in (c.max_speed, c.limit_speed)]
        vals += [c.speeds[self._summary_index(c)] for c in self.cases if c.free]
        return speed_digits(vals)

    def rows(self) -> list[dict]:
        out = []
        n = self.speed_digits()
        for c in self.cases:
            r = {"direction": c.direction, "free": ", ".join(c.free) or "—",
                 "max_speed_m_s": c.max_speed, "limit": c.limit_text(n), "reason": c.limit_reason}
            for k in c.free:
                r[f"righting_{k}_Nm_per_rad"] = c.righting[k]
            out.append(r)
        return out

    def summary(self) -> str:
        lines = [f"Static stability in steady flight — {self.vehicle} (tilt limit "
                 f"{self.max_tilt_deg:g}°)"]
        n = self.speed_digits()
        for c in self.cases:
            line = f"  {c.direction:<10} {c.limit_text(n)}"
            if c.limited:
                line += f": {c.limit_reason}"
            i = self._summary_index(c)
            for k in c.free:
                line += (f"; {k}: BG·W {c.righting[k]:.3g} N·m/rad, at {c.speeds[i]:.{n}g} m/s thrust "
                         f"moment {c.thrust_moment[k][i]:+.3g} N·m, Munk {c.munk_stiffness[k][i]:+.3g} "
                         f"N·m/rad, trim {c.tilt_deg[k][i]:+.1f}°")
            lines.append(line)
        lines.extend(f"  note: {n}" for n in self.notes)
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"vehicle": self.vehicle, "max_tilt_deg": self.max_tilt_deg, "inflow": self.inflow,
                "cases": [c.to_dict() for c in self.cases], "notes": list(self.notes),
                "warnings": self.warnings()}

    def plot(self, path=None):
        """Trim angle against speed per direction (lines: nonlinear, dotted: small-angle)."""
        import itertools

        from uuvid.core.plots import new_figure, save_figure

        fig, ax = new_figure(1, 1, figsize=(8, 4.5))
        colors = itertools.cycle(f"C{i}" for i in range(10))
        styles = {"roll": "-", "pitch": "-."}
        limits: dict[str, tuple[float, list[str]]] = {}  # the limit as printed → (speed, directions)
        n = self.speed_digits()
        for c in self.cases:
            for k in c.free:
                tilt = np.asarray(c.tilt_deg[k], float)
                if not np.any(np.abs(tilt[np.isfinite(tilt)]) > 0.05):
                    continue  # this angle stays level in this direction: nothing to show
                col = next(colors)
                ax.plot(c.speeds, tilt, styles.get(k, "-"), color=col, label=f"{c.direction}: {k}")
                # the small-angle estimate up to the limit (it diverges where trim is lost)
                upto = c.limit_speed if c.limited else np.inf
                small = np.where(np.asarray(c.speeds) <= upto, c.tilt_small_deg[k], np.nan)
                ax.plot(c.speeds, small, ":", color=col, lw=0.9)
                if c.limited:
                    limits.setdefault(f"{c.limit_speed:.{n}g}", (float(c.limit_speed), []))[1].append(
                        c.direction)
        for txt, (v, dirs) in limits.items():
            ax.axvline(v, color="k", ls=":", lw=0.8)
            ax.annotate(f"{'/'.join(dirs)} limit {txt} m/s", (v, -1.45 * self.max_tilt_deg),
                        rotation=90, fontsize=7, xytext=(3, 0), textcoords="offset points",
                        va="bottom")
        for s in (-1, 1):
            ax.axhline(s * self.max_tilt_deg, color="grey", lw=0.6)
        ax.set_ylim(-1.5 * self.max_tilt_deg, 1.5 * self.max_tilt_deg)
        ax.set_xlabel("speed [m/s]")
        ax.set_ylabel("trim angle [deg]")
        ax.set_title(f"{self.vehicle}: trim in steady flight (dotted: small-angle; grey: tilt limit)")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, ncol=2)
        return save_figure(fig, path) if path is not None else fig


def _scan(bal: _Balance, max_speed: float, n: int, max_tilt: float):
    """Trim over ``n`` speeds up to ``max_speed`` by continuation; the limit by bisection."""
    speeds = np.linspace(0.0, max_speed, n)

    def good(s):
        return s["ok"] and s["stable"] and all(abs(a) <= max_tilt for a in s["tilt_deg"].values())

    sols, z, last = [], np.zeros(len(bal.free)), None
    for U in speeds:
        s = _solve(bal, float(U), z)
        if not good(s):
            break
        z, last = s["z"], (float(U), s)
        sols.append((float(U), s))
    sols += [(float(U), None) for U in speeds[len(sols):]]
    if len(sols) and sols[-1][1] is not None:
        return speeds, sols, math.inf, None, ""
    if last is None:  # not even level at rest (e.g. no righting moment)
        s0 = _solve(bal, 0.0, z)
        return speeds, sols, 0.0, next(iter(s0["tilt_deg"]), None), (
            "no static equilibrium at rest" if not s0["ok"] else "unstable at rest")
    lo, zlo = last[0], last[1]["z"]
    hi = float(speeds[len([x for x in sols if x[1] is not None])])
    while hi - lo > 1e-4 * max(1.0, max_speed):
        mid = 0.5 * (lo + hi)
        sm = _solve(bal, mid, zlo)
        if good(sm):
            lo, zlo = mid, sm["z"]
        else:
            hi = mid
    ok_s, bad = _solve(bal, lo, zlo), _solve(bal, hi, zlo)
    tilt = ok_s["tilt_deg"]
    dof = max(tilt, key=lambda k: abs(tilt[k])) if tilt else None
    if not bad["ok"]:
        reason = "no static equilibrium: the righting moment cannot balance the moments at speed"
    elif not bad["stable"]:
        reason = "statically unstable: the Munk moment outgrows the righting moment"
        st = ok_s["stiffness"]
        dof = max(st, key=lambda k: st[k]) if st else dof
    else:
        reason = f"trim tilt beyond {max_tilt:g}°"
    return speeds, sols, lo, dof, reason


def static_stability(vehicle, max_tilt_deg: float = MAX_TILT_DEG, n_speeds: int = 41, modes=None,
                     envelope=None, inflow: str | None = None) -> StabilityResult:
    """Trim angle against speed and the speed where the vehicle can no longer stay level, for
    every controlled translational direction up to its envelope speed (see the module text).
    A direction that full command makes no way in (the envelope's speed along it ≤ 0: e.g. a
    positively buoyant vehicle whose vertical thrusters cannot out-push its buoyancy rises at full
    dive command) gets only its trim at rest, ``max_speed`` ≤ 0 and ``no_way`` saying what it does
    instead — never a "stays level to" a speed it cannot reach.

    ``inflow`` (``None``: the vehicle file's; ``'none'``: bollard): the envelope speed scanned to
    and the thrust fraction use each thruster's limit at the advance speed of the trim state
    (:mod:`uuvid.vehicle.inflow`); the trim itself does not depend on the limits."""

    from uuvid.vehicle.envelope import WAY_TOL, no_way_text, speed_envelope
    from uuvid.vehicle.inflow import inflow_limits
    from uuvid.vehicle.layout import dof_index

    if not (math.isfinite(max_tilt_deg) and 0 < max_tilt_deg < 90):
        raise ValueError(f"max_tilt_deg = {max_tilt_deg:g}°: expected a tilt angle between 0 and "
                         f"90° (default {MAX_TILT_DEG:g}°)")
    env = speed_envelope(vehicle, modes, inflow=inflow) if envelope is None else envelope
    il = inflow_limits(vehicle, inflow)
    p = vehicle.params
    bgw = {"roll": p.weight * p.r_g[2] - p.buoyancy * p.r_b[2],
           "pitch": p.weight * p.r_g[2] - p.buoyancy * p.r_b[2]}
    cases = []
    unbounded = []
    for r in env.rows:
        d = dof_index(r.dof)
        if d <= 2 and math.isinf(r.speed):
            unbounded.append(r.direction)
        if d > 2 or not math.isfinite(r.speed):
            continue
        # the speed along the direction named: a vehicle that full command moves the other way
        # (positively buoyant, weak vertical thrusters: it rises at full dive command) has no
        # speed to scan in this direction, only its trim at rest
        vmax = max(r.along, r.along_allocator)
        no_way = "" if vmax > WAY_TOL else r.no_way() or no_way_text(r.direction, vmax, r.speed_unit)
        bal = _Balance(vehicle, d, r.sign, modes, il)
        speeds, sols, limit, ldof, reason = _scan(bal, max(vmax, 0.0), 1 if no_way else n_speeds,
                                                  max_tilt_deg)
        free = tuple(DOF_NAMES[k] for k in bal.free_att)
        tilt = {k: np.full(len(speeds), np.nan) for k in free}
        small = {k: np.full(len(speeds), np.nan) for k in free}
        tm = {k: np.zeros(len(speeds)) for k in free}
        mk = {k: np.zeros(len(speeds)) for k in free}
        frac = np.full(len(speeds), np.nan)
        for i, (U, s) in enumerate(sols):
            z0 = np.zeros(len(bal.free))
            req, thr, f0 = bal.parts(z0, U)
            munk = bal.munk_stiffness(U)
            if bal.free:
                J0 = bal.jacobian(z0, U)
                zs = -np.linalg.lstsq(J0, bal.residual(z0, U), rcond=None)[0]
            for j, k in enumerate(bal.free_att):
                nm = DOF_NAMES[k]
                tm[nm][i] = thr[k]
                mk[nm][i] = munk[j]
                small[nm][i] = math.degrees(zs[j])
                if s is not None:
                    tilt[nm][i] = s["tilt_deg"][nm]
            frac[i] = s["thrust_fraction"] if s is not None else f0
        cases.append(StabilityCase(r.dof, r.direction, r.sign, free, speeds, tilt, small,
                                   {k: bgw[k] for k in free}, tm, mk, frac, vmax, limit,
                                   ldof, reason, no_way))
    notes = [f"steady straight flight along each direction at heading 0; controlled DOFs "
             f"(translations and held attitude) take what the balance needs; free: roll/pitch "
             f"angles settle on the righting moment BG·W = W z_G − B z_B = "
             f"{bgw['pitch']:.3g} N·m/rad"]
    if unbounded:  # said, not an empty table: the file gives no drag in these DOFs
        notes.append(f"no stability case for {', '.join(unbounded)}: no drag there (linear and "
                     "quadratic damping 0 in the vehicle file), so the steady speed is unbounded "
                     "and there is no speed range to scan — give the vehicle's damping")
    if il is not None:
        notes.append(f"inflow {il.model}: envelope speeds and thrust fractions with each "
                     "thruster's limit at its advance speed (the trim angles do not depend on it)")
        from uuvid.vehicle.propeller_note import propeller_map_note

        notes.append(propeller_map_note(il.maps, il.wake))
    return StabilityResult(vehicle.name, tuple(cases), float(max_tilt_deg), tuple(notes),
                           "none" if il is None else il.model)
