"""Performance envelope: maximum steady speed per DOF and direction (Laidani et al., Table 4 kind).

For a DOF ξ and a direction (±) the steady state of the uncoupled model (Caccia et al. 2000,
eq. 3, with η φ the force the thrusters deliver) is

    k_L ξ + k_Q ξ|ξ| = F_max + ν,       ν = W − B in heave (z down), 0 otherwise

where ``F_max`` is the largest generalised force the thrusters can produce along ±ξ while every
*other controlled* DOF stays at zero (uncontrolled DOFs, e.g. the pitch of a 6-thruster
BlueROV2, are left free).  Two values of ``F_max`` are given:

* ``lp`` — the true maximum, a linear programme over the delivered thrusts
  ``d_i ∈ [η₋ᵢ min_i, η₊ᵢ max_i]`` (scipy HiGHS), with the mode's constraints applied to the
  delivered thrusts;
* ``allocator`` — what the vehicle's allocator gives (pseudo-inverse direction, η-compensated so
  the delivered force points along ±ξ, uniformly scaled until the first thruster saturates): the
  number a DP controller using it will see.

The speeds keep their sign (body axes, z down).  In heave ``ν`` can outweigh the thrust: a
positively buoyant vehicle whose vertical thrusters push less than its buoyancy rises at full dive
command.  Such a row does not make way in its direction (:attr:`EnvelopeRow.along` ≤ 0, the speed
along the direction named); :meth:`EnvelopeRow.no_way` says so ("cannot dive: rises at 0.40 m/s
at full dive command").

The drag coefficients are the diagonal of ``D_L``, ``D_Q`` (off-diagonal coupling ignored);
roll and pitch have restoring moments and no steady rate, so only their force is reported.
Confirmation by 6-DOF simulation is a separate step.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from uuvid.core.result import Result
from uuvid.vehicle.allocation import apply_eta, dead_thrusters
from uuvid.vehicle.layout import dof_index
from uuvid.vehicle.model import DOF_NAMES, steady_speed

DIRECTIONS = {
    0: ("forward", "backward"),
    1: ("starboard", "port"),
    2: ("diving", "climbing"),
    3: ("roll +", "roll -"),
    4: ("nose up", "nose down"),
    5: ("yaw + (clockwise)", "yaw - (counter-clockwise)"),
}
UNITS = {0: ("N", "m/s"), 1: ("N", "m/s"), 2: ("N", "m/s"), 3: ("N·m", "rad/s"),
         4: ("N·m", "rad/s"), 5: ("N·m", "rad/s")}
#: per direction: what making way in it is, what the vehicle does instead when it moves the other
#: way, and the command's name (:func:`no_way_text`)
MOTION = {
    "forward": ("go forward", "goes backward", "forward"),
    "backward": ("go backward", "goes forward", "backward"),
    "starboard": ("move to starboard", "moves to port", "starboard"),
    "port": ("move to port", "moves to starboard", "port"),
    "diving": ("dive", "rises", "dive"),
    "climbing": ("climb", "sinks", "climb"),
    "yaw + (clockwise)": ("turn clockwise", "turns counter-clockwise", "clockwise yaw"),
    "yaw - (counter-clockwise)": ("turn counter-clockwise", "turns clockwise", "counter-clockwise yaw"),
}
#: speed (m/s or rad/s) along a direction below which full command is said to make no way
WAY_TOL = 1e-9


def no_way_text(direction: str, along: float, unit: str) -> str:
    """The sentence for a direction in which full command makes no way, ``along`` (≤ 0) the
    steady speed along the direction named: "cannot dive: rises at 0.40 m/s at full dive
    command" (a positively buoyant vehicle whose vertical thrusters are weaker than its buoyancy),
    "cannot go forward: does not move at full forward command"."""
    can, other, cmd = MOTION.get(direction, (f"go {direction}", "moves the other way", direction))
    if along < -WAY_TOL:
        a = f"{-along:.2f}" if -along >= 0.005 else f"{-along:.1g}"
        return f"cannot {can}: {other} at {a} {unit} at full {cmd} command"
    return f"cannot {can}: does not move at full {cmd} command"


def max_force_lp(B, lower, upper, dof: int, sign: float, controlled: Sequence[int],
                 eta_pos=None, eta_neg=None, constraints=None) -> float:
    """Largest ``sign · (B d)[dof]`` over delivered thrusts ``d`` within ``[η₋ lower, η₊ upper]``
    with ``(B d)[j] = 0`` for the other controlled DOFs ``j`` and ``C d = 0``."""
    from scipy.optimize import linprog

    B = np.asarray(B, dtype=float)
    n = B.shape[1]
    ep = np.ones(n) if eta_pos is None else np.asarray(eta_pos, float)
    en = np.ones(n) if eta_neg is None else np.asarray(eta_neg, float)
    lo = np.asarray(lower, float) * en
    hi = np.asarray(upper, float) * ep
    others = [j for j in controlled if j != dof]
    rows = [B[others]] if others else []
    if constraints is not None and np.size(constraints):
        rows.append(np.atleast_2d(constraints))
    A_eq = np.vstack(rows) if rows else None
    b_eq = np.zeros(A_eq.shape[0]) if A_eq is not None else None
    bounds = [(None if not math.isfinite(a) else a, None if not math.isfinite(b) else b)
              for a, b in zip(lo, hi)]
    res = linprog(-sign * B[dof], A_eq=A_eq, b_eq=b_eq, bounds=bounds, method="highs")
    if res.status == 3:
        return math.inf
    if res.status != 0:
        return 0.0
    return max(0.0, float(-res.fun))


@dataclass(frozen=True)
class EnvelopeRow:
    dof: str
    direction: str
    sign: int
    force: float  # LP maximum, N or N·m
    speed: float  # steady speed with the LP force, signed in body axes (z down); nan for roll/pitch
    force_allocator: float
    speed_allocator: float
    force_unit: str
    speed_unit: str
    speed_bollard: float = math.nan  # the same speed with bollard thrust limits (inflow off)
    speed_allocator_bollard: float = math.nan

    @property
    def along(self) -> float:
        """``speed`` along the direction named (``sign · speed``): negative where full command
        moves the vehicle the other way (e.g. a positively buoyant vehicle at full dive command
        with vertical thrusters weaker than its buoyancy rises)."""
        return self.sign * self.speed

    @property
    def along_allocator(self) -> float:
        """``speed_allocator`` along the direction named (see :attr:`along`)."""
        return self.sign * self.speed_allocator

    @property
    def makes_way(self) -> bool | None:
        """Whether full command (the allocator's force, what a pilot gets) moves the vehicle the
        way the direction names; ``None`` for roll and pitch (no steady rate)."""
        if math.isnan(self.speed_allocator):
            return None
        return bool(self.along_allocator > WAY_TOL)

    def no_way(self) -> str:
        """"" where the vehicle makes way; else what it does at full command ("cannot dive: rises
        at 0.40 m/s at full dive command"), and the LP's speed where that one would make way."""
        if self.makes_way is not False:
            return ""
        text = no_way_text(self.direction, self.along_allocator, self.speed_unit)
        if self.along > WAY_TOL:
            can = MOTION.get(self.direction, (f"go {self.direction}",))[0]
            text += (f" (the largest force any thrust combination gives, {self.force:.3g} "
                     f"{self.force_unit}, would {can} at {self.along:.2f} {self.speed_unit})")
        return text


@dataclass(frozen=True)
class Envelope(Result):
    """Maximum steady speeds per DOF and direction, with the forces behind them."""

    vehicle: str
    rows: tuple[EnvelopeRow, ...]
    mode: str | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)
    inflow: str = "none"

    def __getitem__(self, direction: str) -> EnvelopeRow:
        for r in self.rows:
            if r.direction == direction or f"{r.dof} {'+' if r.sign > 0 else '-'}" == direction:
                return r
        raise KeyError(f"no envelope row {direction!r}; have {[r.direction for r in self.rows]}")

    def as_dict(self) -> dict:
        d = {"vehicle": self.vehicle, "mode": self.mode,
             "rows": [{**r.__dict__, "makes_way": r.makes_way, "no_way": r.no_way()}
                      for r in self.rows], "notes": list(self.notes)}
        if self.inflow != "none":
            d["inflow"] = self.inflow
        else:  # inflow off: the rows as before issue 21
            for r in d["rows"]:
                r.pop("speed_bollard")
                r.pop("speed_allocator_bollard")
        return d

    report_title = "Performance envelope"

    def to_dict(self) -> dict:
        return self.as_dict()

    def plot(self):
        """Largest force and steady speed per direction (LP and allocator)."""
        from uuvid.core.plots import new_figure

        fig, ax = new_figure(1, 2, figsize=(12, 4))
        x = np.arange(len(self.rows))
        labels = [r.direction for r in self.rows]
        ax[0].bar(x - 0.2, [abs(r.force) for r in self.rows], 0.4, label="LP maximum")
        ax[0].bar(x + 0.2, [abs(r.force_allocator) for r in self.rows], 0.4, label="allocator")
        ax[0].set_ylabel("force [N] / moment [N·m]")
        ax[1].bar(x - 0.2, [r.along for r in self.rows], 0.4, label="LP maximum")
        ax[1].bar(x + 0.2, [r.along_allocator for r in self.rows], 0.4, label="allocator")
        ax[1].axhline(0.0, color="k", lw=0.6)
        ax[1].set_ylabel("steady speed along the direction [m/s] / [rad/s]\n(< 0: the other way)")
        for a in ax:
            a.set_xticks(x)
            a.set_xticklabels(labels, rotation=30, ha="right", fontsize=7)
            a.legend(fontsize=8)
        fig.suptitle(f"{self.vehicle}: performance envelope", fontsize=11)
        return fig

    def summary(self) -> str:
        title = f"Performance envelope — {self.vehicle}" + (
            f" (mode {self.mode})" if self.mode else "")
        lines = [title, (f"{'DOF':<6} {'direction':<26} {'max force':>12} {'steady speed':>14}"
                         f" {'allocator force':>16} {'allocator speed':>16}")]
        for r in self.rows:
            # along the direction named: negative where full command moves the vehicle the other way
            sp = "—" if math.isnan(r.speed) else UNBOUNDED_TEXT if math.isinf(r.speed) else \
                f"{r.along:.3g} {r.speed_unit}"
            spa = "—" if math.isnan(r.speed_allocator) else UNBOUNDED_TEXT \
                if math.isinf(r.speed_allocator) else f"{r.along_allocator:.3g} {r.speed_unit}"
            lines.append(f"{r.dof:<6} {r.direction:<26} {r.force:>8.4g} {r.force_unit:<3} "
                         f"{sp:>14} {r.force_allocator:>10.4g} {r.force_unit:<5} {spa:>16}"
                         + ("" if self.inflow == "none" or math.isnan(r.speed_bollard) else
                            f"   (bollard thrust: {r.sign * r.speed_bollard:.3g} {r.speed_unit})"))
        lines.append("speeds along the direction named (negative: full command moves the vehicle "
                     "the other way)")
        lines.extend(f"warning: {r.direction}: {r.no_way()}" for r in self.rows if r.no_way())
        lines.extend(f"note: {n}" for n in self.notes)
        return "\n".join(lines)


def one_way_thrusters(lim) -> list[int]:
    """Thrusters limited to one direction (``[0, max]`` or ``[min, 0]``, not ``[0, 0]``): the
    allocator's least-effort direction ``T φ`` may need them the other way, so uniform scaling
    gives nothing there while the bounded allocation (missions' ``priority``) finds another mix."""
    lim = np.asarray(lim, float)
    side = np.flatnonzero((lim[:, 0] == 0.0) | (lim[:, 1] == 0.0))
    return [int(i) for i in np.setdiff1d(side, dead_thrusters(lim))]  # (dead: no way at all)


def _forces(alloc, B, lim, d, sign, controlled, ep, en, C) -> tuple[float, float]:
    """``(LP maximum, allocator force)`` along ``sign·e_d`` with thrust limits ``lim`` (n, 2)."""
    F = max_force_lp(B, lim[:, 0], lim[:, 1], d, sign, controlled, ep, en, C)
    e = np.zeros(B.shape[0])
    e[d] = sign
    tau = alloc.nominal(e)
    with np.errstate(divide="ignore", invalid="ignore"):  # Allocator.max_along at these limits
        r = np.where(tau > 0, lim[:, 1] / tau, np.where(tau < 0, lim[:, 0] / tau, np.inf))
    s = float(np.min(r)) if r.size else math.inf
    if one_way_thrusters(lim):  # T φ may need a thruster the way it cannot push (s = 0): what
        # the bounded allocation missions fly (priority) delivers along the direction instead
        import dataclasses

        same = np.array_equal(np.asarray(alloc.limits, float), np.asarray(lim, float))
        al = alloc if same else dataclasses.replace(alloc, limits=lim)
        return F, float(al.reach(e))
    if not np.any(tau):  # the allocator does not act on this DOF
        Fa = 0.0
    elif math.isfinite(s):
        Fa = max(0.0, float(sign * (B @ apply_eta(s * tau, ep, en))[d]))
    else:
        Fa = math.inf
    return F, Fa


def _no_drag_speed(force: float) -> float:
    """The steady speed without drag: unbounded the way the force pushes (±inf; 0 without
    force) — signed, so a direction is not said to go "the other way at inf m/s"."""
    return math.copysign(math.inf, force) if force != 0.0 else 0.0


#: How an unbounded speed (no drag in the DOF) is shown, never "inf m/s".
UNBOUNDED_TEXT = "unbounded (no drag)"


def speed_envelope(vehicle, modes=None, dofs: Sequence | None = None,
                   inflow: str | None = None) -> Envelope:
    """Envelope of a :class:`~uuvid.vehicle.definition.Vehicle` (default: its allocation DOFs
    and default modes).

    ``inflow``: ``None`` → the vehicle file's ``inflow`` key; ``'none'`` → bollard limits (the
    envelope as before issue 21); ``'four-quadrant'`` → each thruster's limit at the advance speed
    of the steady state itself (:mod:`uuvid.vehicle.inflow`), the speed the fixed point
    ``k_L v + k_Q v|v| = F_max(v)``; the bollard speeds are kept beside (``speed_bollard``)."""
    from uuvid.vehicle.inflow import inflow_limits, steady_speed_with_inflow

    alloc = vehicle.allocator(modes, compensate_eta=True)
    mode = alloc.mode
    B = vehicle.B
    lim = vehicle.layout.limits
    ep, en = alloc.eta
    controlled = alloc.controlled
    C = mode.constraint_rows(B) if mode is not None else None
    p = vehicle.params
    kL = np.diag(p.linear_damping)
    kQ = np.diag(p.quadratic_damping)
    inf_lim = inflow_limits(vehicle, inflow)
    wanted = controlled if dofs is None else tuple(dof_index(d) for d in dofs)
    rows = []
    beyond: list[str] = []  # limits read outside a fitted propeller map's advance angles
    for d in wanted:
        for sign in (1, -1):
            F, Fa = _forces(alloc, B, lim, d, sign, controlled, ep, en, C)
            if d in (3, 4):
                v = va = math.nan
            else:
                bias = p.net_weight if d == 2 else 0.0
                v = steady_speed(kL[d], kQ[d], sign * F + bias) if (kL[d] or kQ[d]) else \
                    _no_drag_speed(sign * F + bias)
                va = steady_speed(kL[d], kQ[d], sign * Fa + bias) if (kL[d] or kQ[d]) else \
                    _no_drag_speed(sign * Fa + bias)
            vb, vab = v, va
            if inf_lim is not None and d not in (3, 4) and (kL[d] or kQ[d]):
                def forces_at(s, d=d, sign=sign):
                    nu = np.zeros(6)
                    nu[d] = s
                    return _forces(alloc, B, inf_lim.limits_at(nu), d, sign, controlled, ep, en, C)

                def speed_of(force, d=d, bias=bias):
                    return steady_speed(kL[d], kQ[d], force + bias)

                v = steady_speed_with_inflow(lambda f, s=sign: speed_of(s * f),
                                             lambda s: forces_at(s)[0], vb)
                va = steady_speed_with_inflow(lambda f, s=sign: speed_of(s * f),
                                              lambda s: forces_at(s)[1], vab)
                F, Fa = forces_at(v)[0], forces_at(va)[1]
                if math.isfinite(v):
                    nu = np.zeros(6)
                    nu[d] = v
                    for i, b in inf_lim.extrapolated(nu):
                        beyond.append(f"{DOF_NAMES[d]} {DIRECTIONS[d][0 if sign > 0 else 1]}: "
                                      f"{vehicle.layout[i].name} at β = {b:.0f}°")
            rows.append(EnvelopeRow(DOF_NAMES[d], DIRECTIONS[d][0 if sign > 0 else 1], sign,
                                    F, v, Fa, va, *UNITS[d], vb, vab))
    notes = [(f"drag: diagonal of D_L and D_Q; heave includes W - B = {p.net_weight:+.3g} N; "
              "roll/pitch: restoring, no steady rate")]
    if inf_lim is not None:
        notes.append(f"inflow {inf_lim.model}: thrust limits at the advance speed of each steady "
                     "state (propeller map " + inf_lim.maps[0].name + ", full-command shaft speed "
                     "held; wake " + ", ".join(f"{w:g}" for w in sorted(set(inf_lim.wake))) +
                     "); bollard-thrust speeds beside (speed_bollard)")
        from uuvid.vehicle.propeller_note import propeller_map_note

        notes.append(propeller_map_note(inf_lim.maps, inf_lim.wake))
    if beyond:
        notes.append("extrapolated: the fitted propeller map (" + inf_lim.maps[0].ranges_text()
                     + ") is read outside its advance angles — " + "; ".join(beyond)
                     + " — those speeds rest on the series beyond the bench's data")
    if (one := one_way_thrusters(lim)):
        notes.append("allocator: thrusters limited to one direction ("
                     + ", ".join(vehicle.layout[i].name for i in one) + "): the allocator column "
                     "is what the bounded allocation (priority, as missions fly) delivers; uniform "
                     "scaling of the least-effort thrusts (allocation scale) can give less, or "
                     "nothing in a direction that needs them the other way")
    free_run = [DOF_NAMES[d] for d in wanted if d not in (3, 4) and not (kL[d] or kQ[d])]
    if free_run:
        notes.append(f"no drag in {', '.join(free_run)} (linear and quadratic damping 0): the "
                     f"steady speed there is {UNBOUNDED_TEXT} — give the vehicle's damping")
    unc = [DOF_NAMES[i] for i in range(6) if i not in controlled]
    if unc:
        notes.append(f"not controlled (left free): {', '.join(unc)}")
    if 3 not in controlled or 4 not in controlled:
        notes.append("these speeds balance drag and thrust only: with roll/pitch left to the "
                     "righting moment the vehicle may tilt past 20° well below them — the level-"
                     "flight limits: uuvid.vehicle.stability.static_stability (`uuvid vehicle "
                     "stability`)")
    return Envelope(vehicle.name, tuple(rows), mode.name if mode is not None else None,
                    tuple(notes), inf_lim.model if inf_lim is not None else "none")
