"""Plausibility checks for identification inputs and results: a sign or unit mistake that would
otherwise give a "valid" model (zero thrust, negative drag or inertia) is an error or a warning."""
from __future__ import annotations

import numpy as np

from uuvid.io.bench import BenchDataError

#: below this fraction of rows agreeing with the command's direction, the sign is reversed
_SIGN_AGREEMENT = 0.5


def check_bench_commands(data) -> None:
    """Raise :class:`BenchDataError` when the commands cannot be in the declared unit: PWM
    outside 800–2200 µs in most rows (e.g. duties −1…1 read as µs) or duties beyond ±1."""
    from uuvid.thruster.chain import PWM_PLAUSIBLE_US

    c = data.command[np.isfinite(data.command)]
    if not c.size:
        return
    src = f"{data.source}: " if data.source else ""
    rng = f"{c.min():g}…{c.max():g}"
    if data.command_unit == "pwm_us":
        lo, hi = PWM_PLAUSIBLE_US
        if np.mean((c >= lo) & (c <= hi)) < 0.5:
            hint = ("they look like duties: give --command-unit duty" if np.all(np.abs(c) <= 1.0)
                    else "give the command's unit: --command-unit duty or --command-unit volts")
            raise BenchDataError(f"{src}the commands hold {rng}, not pulse widths: command unit "
                                 f"pwm_us (the default) expects {lo:g}–{hi:g} µs; {hint}")
    elif data.command_unit == "duty" and np.any(np.abs(c) > 1.0 + 1e-9):
        hint = (" — they look like pulse widths: give --command-unit pwm_us"
                if np.mean((c >= 800) & (c <= 2200)) >= 0.5 else "")
        raise BenchDataError(f"{src}the commands hold {rng}: a duty is within −1…1{hint}")


def check_bench_signs(data, *, min_rows: int = 3) -> None:
    """Raise :class:`BenchDataError` when a bench file's commands cannot be in their unit
    (:func:`check_bench_commands`) or its thrust (or signed speed) has the opposite sign of the
    command direction in most measured rows (a reversed load cell or column): identification
    would otherwise return a model with zero or negative thrust."""
    check_bench_commands(data)
    d = data.direction
    for name, unit in (("thrust", "N"), ("speed", "rad/s")):
        y = getattr(data, name)
        if y is None:
            continue
        m = data.measured & (d != 0) & np.isfinite(y) & (y != 0)
        n = int(m.sum())
        if n < min_rows:
            continue
        agree = np.sign(y[m]) == d[m]
        if agree.mean() >= _SIGN_AGREEMENT:
            _check_direction_signs(data, name, unit, y, m, min_rows)
            continue
        cmd, val, src = _largest_row(data, y, m)
        raise BenchDataError(
            f"{src}{name} has the opposite sign of the command in {n - int(agree.sum())} of {n} "
            f"measured rows (e.g. command {cmd:g} {data.command_unit}, "
            f"{'above' if cmd > data.neutral else 'below'} neutral {data.neutral:g}, gives "
            f"{name} {val:+.4g} {unit}); expected: a command above neutral gives positive "
            f"{name} (forward). Fix: negate the {name} column (the load cell or sensor is "
            "mounted reversed), or give the right neutral command (--neutral)")


def _largest_row(data, y, rows):
    """The command and reading of the largest |reading| among ``rows`` (the example an error
    quotes) and the file's prefix for messages."""
    k = int(np.argmax(np.abs(y[rows])))
    src = f"{data.source}: " if data.source else ""
    return float(data.command[rows][k]), float(y[rows][k]), src


#: readings below this fraction of the file's largest |value| are left out of the per-direction
#: sign check (a dead band's noise may have either sign)
_SIGN_NOISE = 0.05


def _check_direction_signs(data, name: str, unit: str, y, m, min_rows: int) -> None:
    """One direction of the command with the other direction's sign in most of its clear rows
    (e.g. reverse thrust logged as a magnitude) is an error: the fit would give that direction a
    map through zero or one of the wrong sign."""
    d = data.direction
    big = m & (np.abs(y) > _SIGN_NOISE * np.max(np.abs(y[m])))
    for sgn, side in ((1, "above"), (-1, "below")):
        rows = big & (d == sgn)
        n = int(rows.sum())
        if n < min_rows:
            continue
        wrong = np.sign(y[rows]) != sgn
        if wrong.mean() < 1 - _SIGN_AGREEMENT:
            continue
        cmd, val, src = _largest_row(data, y, rows)
        raise BenchDataError(
            f"{src}{name} has the sign of the other direction in {int(wrong.sum())} of {n} rows "
            f"with the command {side} neutral {data.neutral:g} (e.g. command {cmd:g} "
            f"{data.command_unit} gives {name} {val:+.4g} {unit}); expected: "
            f"{'positive' if sgn > 0 else 'negative'} {name} there. Fix: a sensor that logs the "
            f"magnitude only needs its sign from the command (negate the {name} of those rows), "
            "or give the right neutral command (--neutral)")


# ------------------------------------------------------------------------------------------------
# vehicle identification: drag, inertia, rates for the unit given
# ------------------------------------------------------------------------------------------------
_SIGN_FIX = ("the command and the motion have opposite signs: check the sign of the position "
             "or heading channel (e.g. --field position=-MESSAGE.field) and of the command")


def drag_warnings(parameters: dict, dof: str) -> list[str]:
    """Negative drag coefficients (``k``, ``k_q`` in ``parameters``: name → {estimate, sigma})
    are physically implausible — a vehicle that speeds up by itself; one sentence each."""
    out = []
    names = {"k": "linear drag k", "k_q": "quadratic drag k_q"}
    for name, what in names.items():
        p = parameters.get(name)
        if not p or p.get("estimate") is None or not p["estimate"] < 0:
            continue
        est, sig = float(p["estimate"]), p.get("sigma")
        sig_txt = f" ± {float(sig):.3g}" if sig is not None and np.isfinite(sig) else ""
        strength = ("significantly below zero" if sig is not None and np.isfinite(sig)
                    and -est > 2 * float(sig) else "below zero")
        out.append(f"implausible {dof} {what} = {est:.4g}{sig_txt}, {strength}: drag must be "
                   f">= 0; {_SIGN_FIX}")
    return out


def inertia_warnings(mass: float, sigma: float | None, dof: str, unit: str) -> list[str]:
    """A non-positive inertia estimate is implausible (the model cannot be simulated)."""
    if mass is None or not np.isfinite(mass) or mass > 0:
        return []
    sig_txt = f" ± {sigma:.3g}" if sigma is not None and np.isfinite(sigma) else ""
    return [f"implausible {dof} inertia {mass:.4g}{sig_txt} {unit}: it must be > 0; "
            f"{_SIGN_FIX}, and that the drag given matches this DOF"]


#: faster than this is not an underwater vehicle's motion (a unit mistake)
MAX_PLAUSIBLE_RATE = {"angular": 2 * np.pi, "linear": 5.0}  # rad/s (one turn per second), m/s


def rate_warnings(t, x, dof: str, unit: str, defaulted: bool, angular: bool,
                  window: float = 0.5) -> list[str]:
    """Warn when the position's typical rate (90th percentile over ``window`` s) is implausible
    for the unit it was read in: e.g. a heading in degrees read as radians (57× too fast)."""
    t, x = np.asarray(t, float), np.asarray(x, float)
    ok = np.isfinite(t) & np.isfinite(x)
    t, x = t[ok], x[ok]
    if t.size < 4:
        return []
    if angular:  # a heading wrapping at ±π (a jump of about 2π) is not a fast turn
        o = np.argsort(t, kind="stable")
        t, d = t[o], np.diff(x[o])
        wrap = np.abs(np.abs(d) - 2 * np.pi) < 1.0
        d[wrap] -= np.sign(d[wrap]) * 2 * np.pi
        x = np.concatenate(([x[o][0]], x[o][0] + np.cumsum(d)))
    dt = np.diff(t)
    dt = dt[dt > 0]
    if not dt.size:
        return []
    k = max(1, int(round(window / float(np.median(dt)))))
    if t.size <= k:
        return []
    span = t[k:] - t[:-k]
    good = span > 0
    rates = np.abs(x[k:] - x[:-k])[good] / span[good]
    if not rates.size:
        return []
    r90 = float(np.percentile(rates, 90))
    limit = MAX_PLAUSIBLE_RATE["angular" if angular else "linear"]
    if r90 <= limit:
        return []
    si = "rad" if angular else "m"
    how = f"{unit}, the default" if defaulted else unit
    if angular:
        fix = ("is the angle in degrees? give --angle-unit deg" if unit == "rad" else
               "check --angle-unit")
        lim = f"{limit:.3g} rad/s (one turn per second)"
    else:
        fix = "is the position in cm or mm? give --position-unit"
        lim = f"{limit:g} m/s"
    return [f"implausible {dof} rates: the position (read in {how}) moves at {r90:.3g} {si}/s "
            f"or faster 10 % of the time, beyond {lim} for an underwater vehicle — {fix}"]


def fit_quality_warnings(nrmse, dof: str, limit: float = 0.5) -> list[str]:
    """The identified model's velocity NRMSE on its own log above ``limit``: the model does not
    describe the log (often a reversed command or heading channel)."""
    if nrmse is None or not np.isfinite(nrmse) or nrmse <= limit:
        return []
    return [f"implausible {dof} fit: the identified model does not reproduce the log's velocity "
            f"(NRMSE {100 * nrmse:.0f} % > {100 * limit:.0f} %); {_SIGN_FIX}, and the drag given"]
