"""Servo outputs that never push: thrusters held in the dead band for a whole armed dive.

A dive identification fits ``(m + added) a = F − drag + (B − W)`` with ``F`` the force the
thrusters gave.  An output that never leaves the thruster model's dead band (1500 µs, neutral,
throughout) gives ``F = 0``: where no output of a DOF ever pushes there is nothing to scale mass,
drag and buoyancy by — they trade off exactly and the fit returns a number with σ = ∞ (every
``pwm_`` at 1500 µs while the depth moved 0–11 m gave "mass 183 ± inf").  Two checks:

* :func:`idle_output_check` (the dive reader): the outputs that stay in the dead band while armed
  are named in a warning — every output (no thrust in the log at all), or some while others are
  driven (a motor disabled or on another output, a column that is not its output; or a DOF the
  pilot never commanded);
* :func:`idle_force` (:func:`uuvid.identify.vehicle.dive.identify_dive`): a DOF whose force takes
  one value over the armed part fitted is refused with the outputs that give it, instead of
  reported as a model.
"""

from __future__ import annotations

import numpy as np

from uuvid.core.checks import arg

#: an output in the dead band for at least this long (s) while armed, and another driven beyond
#: it for as long, is worth naming (as :data:`uuvid.io.dive_channels.DEAD_OUTPUT_S`)
IDLE_MIN_S = 5.0
#: a force (N) or moment (N·m) whose armed samples span no more than this (or 10⁻⁶ of their
#: size) takes one value: no thrust to identify from
IDLE_FORCE_TOL = 1e-3
#: the DOFs a pilot commands (roll and pitch are held): rows of ``B``
_PILOTED = ((0, "surge"), (1, "sway"), (2, "heave"), (5, "yaw"))
_ROWS = {"X_N": 0, "Y_N": 1, "Z_N": 2, "K_Nm": 3, "M_Nm": 4, "N_Nm": 5}
_UNIT = {"X_N": "N", "Y_N": "N", "Z_N": "N", "K_Nm": "N·m", "M_Nm": "N·m", "N_Nm": "N·m"}


def _inside(t, intervals) -> np.ndarray:
    """Mask of the stamps ``t`` inside any of ``intervals`` ``[(t0, t1)]`` (ends included; the
    dive reader's too, :mod:`uuvid.io.dive_channels`)."""
    on = np.zeros(np.shape(t), bool)
    for a, b in intervals:
        on |= (t >= a) & (t <= b)
    return on


def _motor_order(pwm: dict) -> list:
    """The keys of ``pwm`` in motor order (``"10"`` after ``"9"``; the dive reader's too)."""
    return sorted(pwm, key=lambda k: int(k) if str(k).isdigit() else str(k))


def _cols(keys) -> str:
    return ", ".join(f"pwm_{k}" for k in keys)


def _and(words) -> str:
    words = list(words)
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def _held(vals) -> str:
    """``"at 1500 µs throughout"`` or ``"1496–1504 µs"``: what an idle output held."""
    lo, hi = float(np.min(vals)), float(np.max(vals))
    return f"at {lo:.6g} µs throughout" if lo == hi else f"{lo:.6g}–{hi:.6g} µs"


def _dead_band(regions) -> str:
    return f"the dead band {regions.edge_rev:.0f}–{regions.edge_fwd:.0f} µs of {regions.model}"


def _armed_idle(pwm: dict, armed: list, regions):
    """Per output (motor order): ``(armed pulse values, seconds armed, seconds driven)`` —
    driven: beyond the dead band; 0 µs (no pulse) is neither."""
    out = {}
    for k in _motor_order(pwm):
        t, v = pwm[k]
        if not t.size:
            continue
        dt = np.diff(t, append=t[-1])
        on = _inside(t, armed) & (v != 0)
        drive = on & ((v < regions.edge_rev) | (v > regions.edge_fwd))
        out[k] = (v[on], float(dt[on].sum()), float(dt[drive].sum()))
    return out


def idle_output_check(pwm: dict, armed: list, veh, name: str, warnings: list, regions,
                      skip=()) -> None:
    """Warn about servo outputs that never leave ``regions``' dead band while armed (at least
    20 samples, :data:`IDLE_MIN_S`): every output — the thrusters gave no thrust in this log, so
    there is no force to identify from — or some while others are driven beyond it for
    :data:`IDLE_MIN_S`.  An idle output that shares a piloted DOF (surge, sway, heave, yaw; its
    ``B`` entry and a driven one's both above 10 % of the DOF's largest) with a driven output is
    one the mixer would have driven too: its motor is disabled or on another output, or the
    column is not its output; DOFs that only idle outputs give are named as having no thrust in
    the log (expected only if the pilot never commanded them).  ``skip``:
    outputs already said (:func:`uuvid.io.dive_channels._check_neutral_outputs`)."""
    stats = _armed_idle(pwm, armed, regions)
    idle = [k for k, (v, on_s, drive_s) in stats.items()
            if v.size >= 20 and on_s >= IDLE_MIN_S and drive_s == 0.0]
    driven = [k for k, (_, _, drive_s) in stats.items() if drive_s >= IDLE_MIN_S]
    if not idle:
        return
    band = _dead_band(regions)
    if not driven:
        if len(idle) < len(stats):
            return  # the others barely driven or barely logged: nothing to compare with
        held = _held(np.concatenate([stats[k][0] for k in idle]))
        dur = max(stats[k][1] for k in idle)
        warnings.append(f"{name}: every servo output ({_cols(idle)}) stays within {band} "
                        f"({held}) for the {dur:.3g} s armed: the thrusters gave no thrust in "
                        "this log, so it holds no force to identify mass, drag or buoyancy from "
                        "(what moved the vehicle — a tether, a hand, the current — is not in it); "
                        "were these the thrusters' outputs, and was the vehicle driven?")
        return
    idle = [k for k in idle if k not in set(skip)]
    if not idle:
        return
    keys = list(stats)
    share, alone = {}, []
    if veh is not None and np.shape(veh.B)[1] == len(keys):
        F = np.asarray(veh.B, float)[[r for r, _ in _PILOTED]]
        scale = np.abs(F).max(axis=1, keepdims=True)
        F = np.abs(F / np.where(scale > 0, scale, 1.0)) > 0.1
        col = {k: i for i, k in enumerate(keys)}
        for k in idle:
            mates = [j for j in driven if np.any(F[:, col[k]] & F[:, col[j]])]
            if mates:
                both = np.any(F[:, [col[j] for j in mates]], axis=1) & F[:, col[k]]
                share[k] = (mates, [dof for d, (_, dof) in enumerate(_PILOTED) if both[d]])
        for d, (_, dof) in enumerate(_PILOTED):
            givers = [k for k in keys if F[d, col[k]]]
            if givers and all(k in idle for k in givers):
                alone.append(dof)
    held = _held(np.concatenate([stats[k][0] for k in idle]))
    dur = max(stats[k][1] for k in idle)
    one = len(idle) == 1
    text = (f"{name}: {_cols(idle)} never {'leaves' if one else 'leave'} {band} ({held}) in the "
            f"{dur:.3g} s armed while {_cols(driven)} {'is' if len(driven) == 1 else 'are'} "
            f"driven: {'its thruster gives' if one else 'their thrusters give'} no thrust in "
            "this log")
    if share:
        text += ("; " + "; ".join(f"pwm_{k} gives {_and(d)} with {_cols(m)}"
                                  for k, (m, d) in share.items())
                 + ", which are driven: the mixer would drive "
                 + ("it" if len(share) == 1 else "them") + " too — a motor disabled, unplugged "
                 "from the output logged or on another output (check SERVOn_FUNCTION), or a "
                 "column that is not its output? Taken as giving no thrust, the missing force "
                 "is fitted as the vehicle's own dynamics")
    if alone:
        dofs = _and(alone)
        text += (f"; no other thruster gives {dofs}, so {dofs} {'has' if len(alone) == 1 else 'have'}"
                 " no thrust to identify from in this log (expected only if the pilot never "
                 f"commanded {'it' if len(alone) == 1 else 'them'}; otherwise are those motors "
                 "disabled or on other outputs? check SERVOn_FUNCTION)")
    warnings.append(text)


def idle_force(dc, forces, B=None, regions=None, t_start=None, t_end=None, *,
               replay: bool = False) -> str | None:
    """Why the dive ``dc`` has no thrust to identify a DOF from — each of ``forces`` (force
    columns, e.g. ``["Z_N"]``) takes one value over the armed samples in ``[t_start, t_end]``
    (spanning no more than :data:`IDLE_FORCE_TOL` or 10⁻⁶ of its size) — or ``None``.  With the
    vehicle's ``B`` and the thruster model's dead band ``regions``, the outputs that give those
    forces are named with what they held when none of them left the dead band, or — the
    table's own force columns at one value while those outputs were driven beyond it — the
    contradiction is said (zero forces logged for a dive the PWM shows thrust in).  ``replay``:
    the text says what that means for a replay (the model coasting), not for a fit."""
    said = []
    for c in forces:
        if c not in dc.channels:
            return None
        t, v = dc.channels[c]
        sel = _inside(t, dc.armed)
        if t_start is not None:
            sel &= t >= t_start
        if t_end is not None:
            sel &= t <= t_end
        if np.count_nonzero(sel) < 2:
            return None
        x = v[sel]
        if float(np.ptp(x)) > max(IDLE_FORCE_TOL, 1e-6 * float(np.max(np.abs(x)))):
            return None
        lo, hi = float(np.min(x)), float(np.max(x))
        val = f"{lo:.3g}" if abs(hi - lo) < 5e-4 * max(abs(lo), 1.0) else f"{lo:.3g}…{hi:.3g}"
        said.append(f"{c} stays {val} {_UNIT.get(c, '')}".rstrip())
    if not said:
        return None
    text = f"{_and(said)} over the armed samples in {dc.span_text(t_start, t_end)}"
    keys = _motor_order(dc.pwm) if dc.pwm else []
    clash = ""  # the table's forces at one value while the PWM shows thrust
    if B is not None and regions is not None and keys and np.shape(B)[1] == len(keys):
        B = np.asarray(B, float)
        rows = [_ROWS[c] for c in forces if c in _ROWS]
        sub = np.abs(B[rows])
        givers = [k for i, k in enumerate(keys)
                  if np.any(sub[:, i] > 1e-6 * max(float(sub.max(initial=0.0)), 1e-300))]
        lo_t = -np.inf if t_start is None else t_start
        hi_t = np.inf if t_end is None else t_end
        span = [(max(a, lo_t), min(b, hi_t)) for a, b in dc.armed if max(a, lo_t) <= min(b, hi_t)]
        stats = _armed_idle({k: dc.pwm[k] for k in givers}, span, regions)
        if givers and all(stats.get(k, (None, 0.0, 1.0))[2] == 0.0 for k in givers):
            vals = [stats[k][0] for k in givers if k in stats and stats[k][0].size]
            held = f" ({_held(np.concatenate(vals))})" if vals else ""
            text += (f": {_cols(givers)}, every output that gives it, never "
                     f"{'leaves' if len(givers) == 1 else 'leave'} {_dead_band(regions)} while "
                     f"armed{held} — the thrusters sat at neutral")
        own = [c for c in forces if "computed from" not in str(dc.sources.get(c, ""))]
        driven = [k for k in givers if stats.get(k, (None, 0.0, 0.0))[2] >= 1.0]
        if own and driven:  # the table's forces say no thrust, its servo outputs say thrust
            s = sum(stats[k][2] for k in driven) / len(driven)
            clash = (f". Yet {_cols(driven)}, which give {_and(own)}, "
                     f"{'leaves' if len(driven) == 1 else 'leave'} {_dead_band(regions)} for "
                     f"{s:.3g} s{' on average' if len(driven) > 1 else ''} while armed: the "
                     f"thrusters were driven, so the force column{'s' if len(own) > 1 else ''} "
                     f"{_and(own)} contradict{'s' if len(own) == 1 else ''} the PWM (zeros "
                     "logged where thrust was given?): remove the force columns X_N … N_Nm to "
                     "have the thrust computed from the pwm_ columns")
    around = (f" (or {arg('t_start')}/{arg('t_end')} around such a part)" if t_start is not None
              or t_end is not None else "")
    if replay:
        return (text + ". A replay driven by no force shows the model coasting, not how it "
                "answers thrust: it tests neither its mass nor its drag; pass a dive in which the "
                f"thrusters drove it{around}{clash}")
    return (text + ". With no force to scale them by, the inertia (mass with added mass), drag "
            "and bias trade off exactly (σ = ∞): no model can be identified; pass a dive in which "
            f"the thrusters drove it{around}{clash}")
