"""Plausibility checks for identification inputs and results: a sign or unit mistake that would
otherwise give a "valid" model (zero thrust, negative drag or inertia) is an error or a warning.

Bench files (``uuvid thruster fit``) are checked before they are fitted:

* commands outside their unit's range (:func:`check_bench_commands`);
* thrust or speed with the opposite sign of the command (:func:`check_bench_signs`);
* a unit the numbers cannot be in (:func:`check_bench_units`): a supply voltage above
  :data:`MAX_PLAUSIBLE_VOLTAGE` (mV), a current above :data:`MAX_PLAUSIBLE_CURRENT` (mA), or a
  still-water thrust above the momentum-theory bound of its electrical power (grams read as N);
* warnings where big thrusters make a hard limit wrong (:func:`bench_unit_warnings`): a thrust
  above :data:`MAX_PLAIN_THRUST` without electrical data to check it against, a speed above
  :data:`MAX_PLAUSIBLE_SPEED` (rpm read as rad/s).
"""
from __future__ import annotations

import numpy as np

from uuvid.core import units as U
from uuvid.core.checks import MAX_PLAUSIBLE_VOLTAGE as _MAX_SUPPLY_V
from uuvid.io.bench import REVERSAL_SIGMAS, SIGN_NOISE, BenchDataError, reversal_tolerance

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
    elif data.command_unit == "volts" and data.supply_voltage is not None:
        v = np.asarray(data.supply_voltage_array(), float)
        top = float(np.nanmax(v)) if v.size else np.nan
        if np.isfinite(top) and top > 0 and float(np.max(np.abs(c))) > 1.5 * top:
            hint = (" — they look like percent: give duties (−1…1, --command-unit duty)"
                    if float(np.max(np.abs(c))) <= 100.0 + 1e-9 else "")
            raise BenchDataError(f"{src}the commands hold {rng} V, beyond the {top:g} V supply: "
                                 f"a driver cannot apply more than its supply{hint}")


def check_bench_signs(data, *, min_rows: int = 3) -> None:
    """Raise :class:`BenchDataError` when a bench file's commands cannot be in their unit
    (:func:`check_bench_commands`), its readings cannot be in theirs (:func:`check_bench_units`)
    or its thrust (or signed speed) has the opposite sign of the
    command direction in most measured rows (a reversed load cell or column): identification
    would otherwise return a model with zero or negative thrust."""
    check_bench_commands(data)
    check_bench_units(data, min_rows=min_rows)
    d = data.direction
    for name, unit in (("thrust", "N"), ("speed", "rad/s"), ("current", "A")):
        y = getattr(data, name)
        if y is None:
            continue
        fin = np.isfinite(y)
        if fin.sum() >= min_rows and np.all(y[fin] == 0) and np.any(d[fin] != 0):
            src = f"{data.source}: " if data.source else ""
            raise BenchDataError(f"{src}{name} is 0 in every row while the command moves "
                                 f"({data.command[fin].min():g}…{data.command[fin].max():g} "
                                 f"{data.command_unit}): an empty column or the wrong one "
                                 f"(--{name}-col)?")
        if name == "current":  # unsigned (the supply's): only an empty column is checked
            continue
        m = data.measured & (d != 0) & np.isfinite(y) & (y != 0)
        n = int(m.sum())
        if n < min_rows:
            continue
        agree = np.sign(y[m]) == d[m]
        if agree.mean() >= _SIGN_AGREEMENT:
            _check_direction_signs(data, name, unit, y, m, min_rows)
            _check_single_reversals(data, name, unit, y, m)
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
#: sign check (a dead band's noise may have either sign); the rule of the check in a flow too
_SIGN_NOISE = SIGN_NOISE


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


#: a reading of the wrong sign must be this many times the row-to-row scatter to be a reversal
_REVERSAL_SIGMAS = REVERSAL_SIGMAS


def _check_single_reversals(data, name: str, unit: str, y, m) -> None:
    """A row whose reading has the other direction's sign, clear of the dead band's noise
    (beyond :data:`_SIGN_NOISE` of the file's largest |reading| and :data:`_REVERSAL_SIGMAS` ×
    the readings' row-to-row scatter: :func:`uuvid.io.bench.reversal_tolerance`), in still
    water: a thruster does not push backwards at a forward command — a sign slip in that row (or
    a row of another test).  Left unchecked, a table fit flattened it away and a polynomial bent
    around it.  In a flow a propeller can (a forward command against a strong inflow from ahead),
    so rows with a flow speed are not checked here (:func:`uuvid.io.bench.read_bench` checks those
    with the water at rest or from behind, by the same rule), nor time series (a step's transient
    keeps the old sign)."""
    if data.time is not None:  # a time series: after a command step the thrust keeps its old
        return  # sign for a few tenths of a second (the thruster's lag), which is no reversal
    d = data.direction
    still = np.ones(y.shape, bool)
    if data.flow_speed is not None:
        still = np.abs(np.nan_to_num(data.flow_speed, nan=np.inf)) <= _STILL_WATER
    # clear of the file's largest reading and of the readings' own scatter (the rule of the
    # check in a flow, bench.reversal_tolerance)
    big = m & still & (np.abs(y) > reversal_tolerance(y, data.command, m, m & still))
    wrong = np.flatnonzero(big & (np.sign(y) != d))
    if not wrong.size:
        return
    i = int(wrong[np.argmax(np.abs(y[wrong]))])
    src = f"{data.source}: " if data.source else ""
    more = f" (and {wrong.size - 1} more such row(s))" if wrong.size > 1 else ""
    raise BenchDataError(
        f"{src}{name} reverses at row {i + 1} of the data{more}: command {data.command[i]:g} "
        f"{data.command_unit} ({'above' if d[i] > 0 else 'below'} neutral {data.neutral:g}) gives "
        f"{name} {y[i]:+.4g} {unit}, while the other rows on that side give "
        f"{'positive' if d[i] > 0 else 'negative'} {name}; a thruster in still water does not "
        f"push against its command: fix the sign of that row (or leave it out)")


# ------------------------------------------------------------------------------------------------
# bench readings in their unit: volts, amperes, newtons, rad/s
# ------------------------------------------------------------------------------------------------
#: a median supply voltage above this [V] is in millivolts (no bench thruster runs on 1 kV)
MAX_PLAUSIBLE_VOLTAGE = _MAX_SUPPLY_V
#: a supply current above this [A] is in milliamperes
MAX_PLAUSIBLE_CURRENT = 1000.0
#: water density of the momentum bound [kg/m³]: sea water, the denser water (the looser bound);
#: the project has no shared density constant (``uuvid.thruster.inflow.RHO_FRESH`` is 1000)
BOUND_WATER_DENSITY = 1025.0
#: actuator-disk area of the momentum bound [m²] (D ≈ 1.13 m: beyond any bench thruster)
BOUND_DISK_AREA = 1.0
#: the bound is tested on the rows above this fraction of the file's largest electrical power
BOUND_POWER_FRACTION = 0.25
#: without electrical data, a larger |thrust| [N] is questioned (a warning: big thrusters exist)
MAX_PLAIN_THRUST = 2000.0
#: more than this fraction of a file's rows censored (below the detection limit) is a unit slip
MAX_CENSORED_FRACTION = 0.5
#: a larger |speed| [rad/s] (≈ 14 300 rpm) looks like rpm read as rad/s (a warning)
MAX_PLAUSIBLE_SPEED = 1500.0
#: |flow_speed| below this [m/s] is still water (a bollard row)
_STILL_WATER = 1e-9


def momentum_thrust_bound(power, area: float = BOUND_DISK_AREA,
                          rho: float = BOUND_WATER_DENSITY):
    """The largest thrust [N] an ideal actuator disk of ``area`` [m²] can give in still water
    with ``power`` [W] (momentum theory: ``P = T^{3/2} / √(2ρA)``, so ``T ≤ (2ρAP²)^{1/3}``).
    The shaft power is at most the electrical power, so ``V·I`` bounds a bollard thrust."""
    return np.cbrt(2.0 * rho * area * np.square(np.asarray(power, dtype=float)))


def _prefix(data) -> str:
    return f"{data.source}: " if data.source else ""


def _near(values, target) -> int:
    """The index of the value nearest ``target`` (the example row a message quotes)."""
    return int(np.argmin(np.abs(np.asarray(values, dtype=float) - target)))


def _power_rows(data, min_rows: int = 3):
    """``(P, rows)``: the electrical power |V·I| [W] per sample and the rows the momentum bound
    is tested on (measured, still water, finite, above :data:`BOUND_POWER_FRACTION` of the
    largest such power), or ``None`` when the file has no thrust, current or voltage, or fewer
    than ``min_rows`` such rows."""
    if data.thrust is None or data.current is None or data.supply_voltage is None:
        return None
    p = np.abs(data.supply_voltage_array() * data.current)
    rows = data.measured & np.isfinite(p) & np.isfinite(data.thrust) & (p > 0)
    if data.flow_speed is not None:
        rows &= np.abs(data.flow_speed) < _STILL_WATER
    if int(rows.sum()) < min_rows:
        return None
    rows &= p >= BOUND_POWER_FRACTION * float(np.max(p[rows]))
    if int(rows.sum()) < min_rows:
        return None
    return p, rows


def thrust_power_ratios(data, min_rows: int = 3):
    """``|thrust| / momentum_thrust_bound(V·I)`` on the rows :func:`check_bench_units` tests
    (``None`` without thrust, current and voltage): a real thruster stays well below 1."""
    pr = _power_rows(data, min_rows)
    if pr is None:
        return None
    p, rows = pr
    return np.abs(data.thrust[rows]) / momentum_thrust_bound(p[rows])


def check_bench_units(data, *, min_rows: int = 3) -> None:
    """Raise :class:`BenchDataError` when a bench file's readings cannot be in their unit:

    * the supply voltage (column or scalar) has a median above :data:`MAX_PLAUSIBLE_VOLTAGE`
      — millivolts read as V;
    * the current reaches :data:`MAX_PLAUSIBLE_CURRENT` — milliamperes read as A;
    * with thrust, current and voltage: on the measured still-water rows above
      :data:`BOUND_POWER_FRACTION` of the largest electrical power, the median of
      ``|thrust| / (2ρAP²)^{1/3}`` (:func:`momentum_thrust_bound`, a 1 m² disk in sea water,
      ``P = V·I``) is above 1 — no propeller gives that thrust at that power: e.g. grams read
      as N (a T200 sits near 0.08, its grams read as N near 8).
    """
    src = _prefix(data)
    sv = data.supply_voltage
    if sv is not None:
        if np.ndim(sv) == 0:
            if float(sv) > MAX_PLAUSIBLE_VOLTAGE:
                raise BenchDataError(
                    f"{src}the supply voltage given (--supply-voltage {float(sv):g}) is above "
                    f"{MAX_PLAUSIBLE_VOLTAGE:g} V, beyond any bench thruster: it looks like "
                    f"millivolts (mV). Fix: give it in volts: --supply-voltage "
                    f"{float(sv) / 1000:g}")
        else:
            v = np.asarray(sv, dtype=float)
            ok = np.flatnonzero(np.isfinite(v))
            med = float(np.median(v[ok])) if ok.size else float("nan")
            if med > MAX_PLAUSIBLE_VOLTAGE:
                k = int(ok[_near(v[ok], med)])
                raise BenchDataError(
                    f"{src}the supply voltage column (--voltage-col, read in V) has a median of "
                    f"{med:g} V (e.g. data row {k + 1}: {v[k]:g}), above "
                    f"{MAX_PLAUSIBLE_VOLTAGE:g} V, beyond any bench thruster: it looks like "
                    f"millivolts (mV), {v[k] / 1000:g} V. Fix: divide the voltage column by "
                    "1000 or write the unit in its header ('voltage [mV]'), or give --supply-voltage "
                "in V")
    if data.current is not None:
        a = np.abs(data.current)
        ok = np.flatnonzero(np.isfinite(a))
        if ok.size and float(np.max(a[ok])) > MAX_PLAUSIBLE_CURRENT:
            k = int(ok[np.argmax(a[ok])])
            raise BenchDataError(
                f"{src}the supply current column (--current-col, read in A) reaches "
                f"{a[k]:g} A (data row {k + 1}: {data.current[k]:g}), above "
                f"{MAX_PLAUSIBLE_CURRENT:g} A, beyond any bench thruster: it looks like "
                f"milliamperes (mA), {data.current[k] / 1000:g} A. Fix: divide the current "
                "column by 1000, or write the unit in its header ('current [mA]')")
    pr = _power_rows(data, min_rows)
    if pr is None:
        return
    p, rows = pr
    idx = np.flatnonzero(rows)
    t = data.thrust[idx]
    bound = momentum_thrust_bound(p[idx])
    ratio = np.abs(t) / bound
    med = float(np.median(ratio))
    if med <= 1.0:
        return
    j = _near(ratio, med)
    k = int(idx[j])
    volts = data.supply_voltage_array()[k]
    in_g = med * U.G0 / 1000.0  # the ratio were the numbers gram-force
    if in_g <= 1.0:
        hint = (f"it looks like grams (gram-force) read as N (in grams the median ratio would be "
                f"{in_g:.2g}): give --thrust-unit g")
        if med / U.KGF <= 1.0:
            hint += (f" (or, if the column is in N and --thrust-unit kgf was given, which "
                     f"multiplies it by 9.81, the ratio would be {med / U.KGF:.2g}: give "
                     "--thrust-unit N)")
    else:
        hint = ("even in grams it would exceed the bound: check the thrust column and its unit "
                "(--thrust-unit N | kgf | lbf | ozf | g), and that current and voltage are in A and V")
    raise BenchDataError(
        f"{src}the thrust is too large for its electrical power: e.g. data row {k + 1} has "
        f"thrust {t[j]:+.4g} N at {p[k]:.4g} W ({volts:.4g} V × {data.current[k]:.4g} A), while "
        f"momentum theory lets even a {BOUND_DISK_AREA:g} m² disk (D ≈ "
        f"{2 * np.sqrt(BOUND_DISK_AREA / np.pi):.2f} m) in still water give at most "
        f"(2ρAP²)^(1/3) = {bound[j]:.4g} N at that power; the median of |thrust| / bound is "
        f"{med:.3g} over the {idx.size} still-water rows above "
        f"{100 * BOUND_POWER_FRACTION:.0f} % of the largest power (a real thruster stays well "
        f"below 1, a T200 at about 0.08). The thrust cannot be in N: {hint}")


def bench_unit_warnings(data) -> list[str]:
    """Readings that are probably in the wrong unit, where big thrusters make an error wrong:
    a |thrust| above :data:`MAX_PLAIN_THRUST` when :func:`check_bench_units` has no electrical
    power to test it against, and a |speed| above :data:`MAX_PLAUSIBLE_SPEED` (rpm read as
    rad/s); one sentence each."""
    src = _prefix(data)
    out = []

    def largest(y):
        """``(row, |value|)`` of the largest finite measured |reading|."""
        a = np.where(data.measured & np.isfinite(y), np.abs(y), -np.inf)
        k = int(np.argmax(a))
        return k, a[k]

    if data.thrust is not None and _power_rows(data) is None:
        k, big = largest(data.thrust)
        if big > MAX_PLAIN_THRUST:
            out.append(
                f"{src}implausible thrust: |thrust| reaches {big:.4g} N (data row {k + 1}: "
                f"{data.thrust[k]:+.4g} N), above {MAX_PLAIN_THRUST:g} N for a bench thruster, "
                "and without current and voltage columns it cannot be checked against the "
                "electrical power — check the thrust unit (grams read as N?): give "
                "--thrust-unit g, kgf or lbf for a column in that unit")
    if data.speed is not None:
        k, big = largest(data.speed)
        if big > MAX_PLAUSIBLE_SPEED:
            out.append(
                f"{src}implausible propeller speed: |speed| reaches {big:.4g} rad/s "
                f"({big / U.RPM:.4g} rpm; data row {k + 1}: {data.speed[k]:+.4g} rad/s), "
                f"above {MAX_PLAUSIBLE_SPEED:g} rad/s (≈ {MAX_PLAUSIBLE_SPEED / U.RPM:.0f} rpm) "
                "— the speed looks like rpm; give --speed-unit rpm")
    if data.censored is not None and data.censored.size >= 5:
        frac = float(np.mean(data.censored))
        if frac > MAX_CENSORED_FRACTION:
            lim = (f" (below {data.censor_speed:g} rad/s)" if data.censor_speed is not None
                   else "")
            out.append(
                f"{src}{int(data.censored.sum())} of {data.censored.size} rows ({frac:.0%}) are "
                f"censored{lim} and left out of the fit: a sheet zeroes only the readings below "
                "its detection limit, around neutral — is the speed column in another unit "
                "(rad/s where rpm is expected: --speed-unit)?")
    return out


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


#: a vehicle log sampled coarser than this (median step, s) cannot show its motion settle: the
#: time column is probably in ms or µs (a 10 Hz log in ms is 100 "s" a sample)
MAX_LOG_STEP_S = 5.0


def time_step_warnings(t, unit: str = "s") -> list[str]:
    """Warn when a log's samples are more than :data:`MAX_LOG_STEP_S` apart (median): a time in ms
    read as seconds made every drag coefficient ×1000 with nothing said (the velocities ÷1000)."""
    t = np.asarray(t, float)
    d = np.diff(t[np.isfinite(t)])
    d = d[d > 0]
    if d.size < 2 or float(np.median(d)) <= MAX_LOG_STEP_S:
        return []
    step, span = float(np.median(d)), float(d.sum())
    fix = ("is the time column in ms (--time-unit ms) or µs (us)?" if unit == "s" else
           f"is the time column in a smaller unit than {unit} (--time-unit)?")
    return [f"samples {step:.4g} s apart (median) over {span / 3600:.3g} h, with time read in "
            f"{unit}: a vehicle log samples its motion several times a second, and every "
            f"velocity, drag and inertia follows the time unit — {fix}"]


def fit_quality_warnings(nrmse, dof: str, limit: float = 0.5) -> list[str]:
    """The identified model's velocity NRMSE on its own log above ``limit``: the model does not
    describe the log (often a reversed command or heading channel)."""
    if nrmse is None or not np.isfinite(nrmse) or nrmse <= limit:
        return []
    return [f"implausible {dof} fit: the identified model does not reproduce the log's velocity "
            f"(NRMSE {100 * nrmse:.0f} % > {100 * limit:.0f} %); {_SIGN_FIX}, and the drag given"]
