"""A reversed motor in a dive table or bag: do the forces computed from the servo outputs push
the way the vehicle moves?

A table's ``pwm_<j>`` columns (or a bag's ``/mavros/rc/out``) carry no motor direction; the reader
assumes ArduSub's direction is already applied.  :func:`direction_check` tests that against the
measured heave and yaw accelerations: per thruster group (thrusters whose forces correlate beyond
:data:`DIRECTION_GROUP_CORR` share one coefficient) a least-squares fit of the acceleration on the
groups' forces, a constant and the drag terms, with autocorrelation-robust (Newey–West) σ.  An
output is named only when its coefficient is below −:data:`DIRECTION_Z` σ, at least
:data:`DIRECTION_SHARE` × the vehicle's ``1/(m + added mass)`` in size, and mirroring it lets one
shared coefficient explain :data:`DIRECTION_GAIN` more of the motion.  One motor reversed among
several driven together (one group) is found by mirroring each member alone, two by mirroring
each pair of grouped outputs.  A warning, not an error: it
is a statistical judgement (a snagged tether or a wrong vehicle file can push against the motion
too).  Called by :mod:`uuvid.io.dive_channels`.

A table's own force columns (``Z_N``, ``N_Nm``) go through the same fit
(:func:`force_sign_check`: each column one "thruster" of an identity ``B``), so a depth logged
positive up is said alike whether the forces were computed from the PWM or logged.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

#: DOF → (row of B, measured channel, force column, force unit, acceleration unit, inertia)
_DIRECTION_DOFS = {"heave": (2, "depth_m", "Z_N", "N", "m/s²", "m + Z_ẇ"),
                   "yaw": (5, "yaw_rad", "N_Nm", "N·m", "rad/s²", "I_z + N_ṙ")}
DIRECTION_GROUP_CORR = 0.95  # thrusters whose forces in a DOF correlate beyond ± this: one group
DIRECTION_Z = 4.0  # a thruster's coefficient must be this many σ (autocorrelation-robust) below 0
DIRECTION_SHARE = 0.1  # … and at least this × the vehicle's 1/(inertia + added) in size
DIRECTION_GAIN = 0.05  # … and mirroring its column must explain this much more of the motion
DIRECTION_RATIO = 2.0  # one of a group driven together: mirrored, this × the share explained
DIRECTION_MIN_S = 30.0  # armed, gap-free seconds the check needs
DIRECTION_MAX_GRID = 4_000_000  # grid points (≥ 0.125 s apart: ≥ 5.8 days); beyond, no check
DIRECTION_SURFACE_M = 0.3  # shallower than this the vehicle may be at the surface: left out

#: DOF → the question to ask when its measured channel opposes every force in it (the channel's
#: sign convention, before a motor or a force column)
SIGN_HINT = {"heave": "is depth_m positive up (a height, or depth with the wrong sign)? expected "
                      "metres, positive down",
             "yaw": "is yaw_rad counter-clockwise (ENU, east = 0)? expected the NED heading, "
                    "clockwise from north"}
#: the force columns of a table, and what their sign means (for :func:`force_sign_check`)
_FORCE_COLUMNS = ("X_N", "Y_N", "Z_N", "K_Nm", "M_Nm", "N_Nm")
_FORCE_SIGN = {"Z_N": "the body-frame force, z down (a positive Z_N pushes the vehicle deeper)",
               "N_Nm": "the body-frame moment about z down (a positive N_Nm turns the vehicle "
                       "clockwise seen from above)"}


def table_fix(keys) -> str:
    cols = " and ".join(f"pwm_{k}" for k in keys)
    return ("the motor direction (SERVOn_REVERSED / MOT_n_DIRECTION) is not applied in this "
            f"table: mirror {'that column' if len(keys) == 1 else 'those columns'} ({cols}) about "
            "1500 µs (pwm → 3000 − pwm)")


def bag_fix(directions: dict):
    def fix(keys) -> str:
        want = ", ".join(f"MOT_{k}_DIRECTION = {-int(round(directions[k])):d}" for k in keys)
        return ("the motor direction (SERVOn_REVERSED / MOT_n_DIRECTION) applied to the servo "
                f"outputs does not match the vehicle: pass --params with {want}")
    return fix


def _smoothing_kernels(sig: float, h: float):
    """Gaussian (σ ``sig``) smoothing, first- and second-derivative kernels on a step ``h``,
    scaled so that they are exact on a constant, a ramp and a parabola (``np.convolve``)."""
    m = int(np.ceil(4 * sig / h))
    u = np.arange(-m, m + 1) * h
    g = np.exp(-0.5 * (u / sig) ** 2)
    g /= g.sum()
    g1 = -u / sig ** 2 * g
    g1 /= -np.sum(g1 * u)
    g2 = (u ** 2 / sig ** 4 - 1 / sig ** 2) * g
    g2 -= g2.mean()
    g2 /= np.sum(g2 * u ** 2 / 2)
    return m, g, g1, g2


def _covered(grid, ts, sig: float) -> np.ndarray:
    """Grid points between two samples of ``ts`` no further apart than 5 of its median steps
    (at least ``sig``): not in a logging gap."""
    gap = max(5 * float(np.median(np.diff(ts))), sig)
    i = np.clip(np.searchsorted(ts, grid), 1, ts.size - 1)
    return (ts[i] - ts[i - 1]) <= gap


def _hac_var(U, rows, lags: int) -> np.ndarray:
    """Variance of ``Σ_t U[t, j]`` per column with serially correlated terms (Newey–West,
    Bartlett weights over ``lags`` grid steps); ``rows`` places the terms on the full grid so
    that lags never bridge a gap."""
    Z = np.zeros((rows.size, U.shape[1]))
    Z[rows] = U
    nf = 1 << int(np.ceil(np.log2(2 * rows.size)))
    f = np.fft.rfft(Z, nf, axis=0)
    ac = np.fft.irfft(f * np.conj(f), nf, axis=0)[:lags + 1]
    w = 1.0 - np.arange(lags + 1) / (lags + 1)
    return np.maximum(ac[0] + 2 * (w[1:, None] * ac[1:]).sum(axis=0), 0.0)


def _inverse_inertia(veh, dof: str) -> float | None:
    """The vehicle's ``1/(m + Z_ẇ)`` (heave) or ``1/(I_z + N_ṙ)`` (yaw), ``None`` without them."""
    try:
        p = veh.params
        ma = np.asarray(p.added_mass, float)
        if dof == "heave":
            val = float(p.mass) + abs(float(ma[2, 2]))
        else:
            inertia = np.asarray(p.inertia, float)
            val = float(inertia[2] if inertia.ndim == 1 else inertia[2, 2]) + abs(float(ma[5, 5]))
    except (AttributeError, IndexError, TypeError, ValueError):
        return None
    return 1.0 / val if np.isfinite(val) and val > 0 else None


def force_sign_check(chans: dict, veh, armed: list, name: str, warnings: list,
                     columns) -> list[str]:
    """:func:`direction_check` for a table's own force ``columns`` (among ``Z_N`` and ``N_Nm``;
    the others of ``X_N … N_Nm`` it has only tilt the heave force to the vertical): each column is
    one "thruster" of an identity ``B`` whose mirror is its negative, so a measured channel that
    opposes the logged force — a depth logged positive up, a heading counter-clockwise — is said
    with the same evidence and question as for forces computed from the PWM, the force column's
    own sign as the other suspect.  Returns the DOFs said so (``veh`` only gives the expected
    ``1/(inertia + added)``; ``None`` leaves it out)."""
    have = [c for c in _FORCE_COLUMNS if c in chans and chans[c][0].size >= 2]
    if not any(c in have for c in columns):
        return []
    t = np.unique(np.concatenate([chans[c][0] for c in have]))
    T = np.zeros((len(_FORCE_COLUMNS), t.size))
    for i, c in enumerate(_FORCE_COLUMNS):
        if c in have:
            T[i] = np.interp(t, *chans[c])
    # what direction_check reads of the reader's thrust per output (dive_channels._PwmThrust)
    pt = SimpleNamespace(keys=list(_FORCE_COLUMNS), t=t, T=T, mirrored=-T,
                         computed=[c for c in columns if c in have])

    def fix(keys):
        return "; ".join(f"otherwise {k} has the wrong sign: expected {_FORCE_SIGN.get(k, k)}"
                         for k in keys)

    return direction_check(chans, pt, veh, armed, name, warnings, fix, B=np.eye(6),
                           col=str, source="logged in", every=fix)


def direction_check(chans: dict, pt, veh, armed: list, name: str, warnings: list,
                    fix, *, B=None, col=None, source: str = "", every=None,
                    named: list | None = None) -> list[str]:
    """Warn about a servo output whose computed force pushes against the measured motion
    (``pt``: the reader's thrust per servo output, logged and mirrored, ``dive_channels._PwmThrust``;
    ``fix(keys)``: the sentence that says how to mend the named outputs in this kind of log).
    Returns the DOFs whose measured channel opposes every force in them (its sign convention is
    asked about, :data:`SIGN_HINT`).  ``B`` (default ``veh.B``), ``col(key)`` (the column of an
    output, default ``pwm_<key>``), ``source`` and ``every(keys)`` (the words for where the forces
    come from and for the other suspect when every one opposes the motion) let
    :func:`force_sign_check` run the same fit on a table's force columns.

    For heave (``depth_m``) and yaw (``yaw_rad``), where that DOF's force column was computed from
    the PWM, the measured acceleration — the second derivative of the Gaussian-smoothed depth or
    heading (σ = max(0.5 s, 2 sample steps of it and of the PWM)), so no noisy differencing —
    is fitted by least squares over the armed, gap-free samples deeper than
    :data:`DIRECTION_SURFACE_M` with each thruster's force in that DOF, smoothed alike (its ``B``
    entry × its thrust at the logged PWM; in heave turned to the vertical with the logged roll
    and pitch), plus a constant (buoyancy), the smoothed rate and its square (drag), and in yaw
    with a DVL the surge and sway accelerations and ``u·v`` (the couplings of the coupled
    model).  Thrusters whose forces correlate beyond ±:data:`DIRECTION_GROUP_CORR` (driven
    together, e.g. BlueROV2's vertical pair) get one coefficient, on their sum with each sign
    aligned to the first's: their forces cannot be told apart, but one whose force runs
    *against* its group's shows.

    Physically every coefficient is ``1/(inertia + added)`` > 0.  A thruster is reported as
    probably reversed when its coefficient (its group's, times its sign in the group) is below 0
    by more than :data:`DIRECTION_Z` σ (Newey–West over 10 s: the residuals are serially
    correlated), at least :data:`DIRECTION_SHARE` of the vehicle's ``1/(inertia + added)`` in
    size, *and* the fit with one shared coefficient (the physics) explains at least
    :data:`DIRECTION_GAIN` more of the acceleration with its column mirrored about 1500 µs than as
    logged (a negative shared coefficient explains nothing), that coefficient positive by
    :data:`DIRECTION_Z` σ.  When no coefficient is negative, a reversed motor may hide inside a
    group (its wrong sign only shrinks the group's coefficient): each member of a group is then
    mirrored alone (:func:`_hidden_in_group`) and one is named when that alone explains the motion
    several times better and no other mirror helps (else a pair, alike).  Every thruster of a
    DOF against the motion is reported as the measured channel's sign convention or all of them
    reversed.
    ``fix(keys)`` says what to do; ``named`` (a list) gets the key of each output named as
    probably reversed.  One pass of NumPy per DOF; it warns and never raises."""
    B = np.asarray(veh.B if B is None else B, float)
    keys = pt.keys
    col = col or (lambda k: f"pwm_{k}")
    opposed: list[str] = []
    if pt.t.size < 20 or B.shape[1] != len(keys):
        return opposed
    for dof, (_row, meas, force, funit, aunit, inertia) in _DIRECTION_DOFS.items():
        if force not in pt.computed or meas not in chans or chans[meas][0].size < 20:
            continue
        try:
            w = _direction_dof(chans, dof, pt, B, armed)
        except (np.linalg.LinAlgError, ValueError, FloatingPointError):
            w = None
        if w is None:
            continue
        k_exp = _inverse_inertia(veh, dof)
        exp = f"; the vehicle's 1/({inertia}) is {k_exp:.3g}" if k_exp is not None else ""

        def mates(i, w=w):
            return ", ".join(col(keys[j]) for j in w["group_of"][i] if j != i)

        flagged = [(i, c, s) for i, c, s in w["members"]
                   if c < 0 and -c >= DIRECTION_Z * s
                   and (k_exp is None or -c >= DIRECTION_SHARE * k_exp)]
        if not flagged:
            hidden = _hidden_in_group(w)
            if hidden is not None:
                bad, (k_fix, s_fix, r2_fix, r2_log) = hidden
                if len(bad) == 1:
                    i = bad[0]
                    who = (f"{col(keys[i])} is probably reversed: it is driven in step with "
                           f"{mates(i)}, so its {dof} force cannot show against the motion on its "
                           "own, but with it mirrored")
                    other = "any other output alone"
                else:
                    cols = " and ".join(col(keys[i]) for i in bad)
                    who = (f"{cols} are probably both reversed: each is driven in step with "
                           f"another thruster, so their {dof} forces cannot show against the motion "
                           "on their own, but with both mirrored")
                    other = "one of them alone or any other pair"
                warnings.append(
                    f"{name}: {who} the forces computed from the thrusters explain "
                    f"{r2_fix:.0%} of the {dof} acceleration measured from {meas} instead of "
                    f"{r2_log:.0%} as logged (one shared coefficient {k_fix:+.3g} ± {s_fix:.2g} "
                    f"{aunit} per {funit}{exp}); mirroring {other} does not help. "
                    f"{fix([keys[i] for i in bad])}")
                if named is not None:
                    named += [keys[i] for i in bad]
            continue

        def confirmed(bad, w=w):
            conf = w["confirm"](bad)
            return conf if (conf is not None and conf[0] >= DIRECTION_Z * conf[1]
                            and conf[2] - conf[3] >= DIRECTION_GAIN) else None

        bad = [i for i, _, _ in flagged]
        conf = confirmed(bad)
        if conf is None and len(flagged) > 1:  # the clearest one alone
            one = min(flagged, key=lambda f: f[1] / f[2])
            flagged, bad = [one], [one[0]]
            conf = confirmed(bad)
        if conf is None:
            odd = _odd_one_out(w, flagged)
            if odd is not None:
                i, c, s = odd
                warnings.append(
                    f"{name}: {col(keys[i])} is probably reversed: it is driven in step with "
                    f"{mates(i)} (their {dof} forces correlate at {w['corr'][i]:+.2f}), its {dof} "
                    f"force runs against all of theirs and against the {dof} acceleration "
                    f"measured from {meas}: coefficient {c:+.3g} ± {s:.2g} {aunit} per {funit}, "
                    f"physically positive{exp}. In this log the group always moves together, so "
                    f"mirroring it cannot be confirmed by the fit (it only rescales the group); "
                    f"no mixer drives one of its thrusters against all the others. "
                    f"{fix([keys[i]])}")
                if named is not None:
                    named.append(keys[i])
            continue
        k_fix, s_fix, r2_fix, r2_log = conf
        cols = [col(keys[i]) for i in bad]
        share = (f"as logged the {'computed forces explain' if not source else 'force explains'} "
                 f"{r2_log:.0%} of the {dof} acceleration, with {' and '.join(cols)} mirrored "
                 f"{r2_fix:.0%}")
        if len(bad) == len(w["live"]):  # every thruster of the DOF: the sign convention?
            c, s = w["shared"]
            whence = (f"{source} {', '.join(cols)}" if source else
                      f"computed from every thruster that gives one ({', '.join(cols)})")
            other = (every([keys[i] for i in bad]) if every is not None else
                     f"otherwise all these motors are reversed: {fix([keys[i] for i in bad])}")
            warnings.append(
                f"{name}: the {dof} acceleration measured from {meas} opposes the {dof} force "
                f"{whence}: coefficient {c:+.3g} ± {s:.2g} {aunit} per {funit}, physically "
                f"positive{exp}; {share}. {SIGN_HINT[dof]}; {other}")
            opposed.append(dof)
            continue
        for i, c, s in flagged:
            together = ""
            if len(w["group_of"][i]) > 1:
                together = (f" (driven in step with {mates(i)}: their {dof} forces "
                            f"correlate at {w['corr'][i]:+.2f}, so they share one coefficient "
                            "and this one's sign in it is tested)")
            warnings.append(
                f"{name}: {col(keys[i])} is probably reversed: its thruster's {dof} force opposes "
                f"the {dof} acceleration measured from {meas}{together}: coefficient {c:+.3g} ± "
                f"{s:.2g} {aunit} per {funit} (fitted with the other thrusters' forces, a "
                f"constant and drag), physically positive{exp}; {share}. {fix([keys[i]])}")
            if named is not None:
                named.append(keys[i])
    return opposed


def _odd_one_out(w, flagged) -> tuple | None:
    """The one flagged thruster of a group of three or more whose other members all push with
    the motion (coefficients positive): a mixer drives thrusters of one DOF together or in
    opposing pairs, never one against all the others, so it is the reversed one even when
    mirroring it cannot be confirmed (a group that always moves together: the mirror only
    rescales the group's coefficient)."""
    if len(flagged) != 1:
        return None
    i = flagged[0][0]
    grp = w["group_of"].get(i, [])
    if len(grp) < 3:
        return None
    coef = {j: c for j, c, _ in w["members"]}
    return flagged[0] if all(coef[j] > 0 for j in grp if j != i) else None


def _hidden_in_group(w) -> tuple[tuple, tuple] | None:
    """Reversed motors among thrusters driven together (:func:`direction_check`'s groups share one
    coefficient, so their sign cannot show on its own): ``(thrusters, confirm(...))`` when
    mirroring those outputs lets one shared coefficient explain at least :data:`DIRECTION_GAIN`
    more of the acceleration and :data:`DIRECTION_RATIO` × as much as logged, that coefficient
    positive by :data:`DIRECTION_Z` σ, and no other mirror of as many outputs gains
    :data:`DIRECTION_GAIN` (a wrong thrust model or timing moves every mirror alike).  Each member
    is mirrored alone first; when none qualifies, each pair of grouped outputs (two reversed motors
    of BlueROV2's four horizontal ones cancel each other's yaw force as logged, and the groups
    re-form around the wrong signs), and a pair must also explain :data:`DIRECTION_GAIN` more
    than its best single mirror."""
    grouped = [i for i in w["live"] if len(w["group_of"].get(i, ())) >= 2]

    def best(sets, floor):
        trials = []
        for bad in sets:
            conf = w["confirm"](list(bad))
            if conf is not None:
                trials.append((conf[2] - conf[3], bad, conf))
        if not trials:
            return None
        trials.sort(key=lambda t: -t[0])
        gain, bad, conf = trials[0]
        k_fix, s_fix, r2_fix, r2_log = conf
        if (gain >= DIRECTION_GAIN and r2_fix >= DIRECTION_RATIO * r2_log
                and k_fix >= DIRECTION_Z * s_fix and r2_fix - floor >= DIRECTION_GAIN
                and all(t[0] < DIRECTION_GAIN for t in trials[1:])):
            return bad, conf
        return None, max(t[2][2] for t in trials)

    one = best([(i,) for i in grouped], -1.0)
    if one is None or one[0] is not None:
        return one
    pairs = [(a, b) for k, a in enumerate(grouped) for b in grouped[k + 1:]]
    two = best(pairs, one[1]) if pairs else None
    return two if two is not None and two[0] is not None else None


def _direction_dof(chans: dict, dof: str, pt, B, armed):
    """The fit behind :func:`direction_check` for one DOF (``None`` when the log cannot inform
    it): ``members`` [(thruster, coefficient, σ)], ``live`` (thrusters with a force in the DOF),
    ``group_of``, ``corr`` (of each member with its group's other first member), ``shared`` (one
    coefficient for the forces as logged, σ) and ``confirm(mirrored)`` → (coefficient, σ, R²,
    R² as logged) of the one-coefficient fit with those thrusters' outputs mirrored."""
    row, meas = _DIRECTION_DOFS[dof][:2]
    tm, xm = chans[meas]
    tp = pt.t
    brow = B[row]
    scale = float(np.max(np.abs(brow)))
    if scale <= 0:
        return None
    act = np.flatnonzero(np.abs(brow) > 1e-6 * scale)
    sig = max(0.5, 2 * float(np.median(np.diff(tm))), 2 * float(np.median(np.diff(tp))))
    if not np.isfinite(sig) or sig > 5.0:
        return None
    h = sig / 4
    t0, t1 = max(tm[0], tp[0]), min(tm[-1], tp[-1])
    if t1 - t0 < DIRECTION_MIN_S + 8 * sig:
        return None
    if (t1 - t0) / h > DIRECTION_MAX_GRID:  # days between stamps: a clock problem the reader says
        return None
    grid = t0 + h * np.arange(int((t1 - t0) / h) + 1)
    m, g0, g1, g2 = _smoothing_kernels(sig, h)

    def have(c):
        return c in chans and chans[c][0].size >= 20

    ok = _covered(grid, tm, sig) & _covered(grid, tp, sig)
    tilt = dof == "heave" and have("roll_rad") and have("pitch_rad")
    uv = dof == "yaw" and have("u_mps") and have("v_mps")
    for c in (("roll_rad", "pitch_rad") if tilt else ()) + (("u_mps", "v_mps") if uv else ()):
        ok &= _covered(grid, chans[c][0], sig)
    if have("depth_m"):  # at the surface the water no longer holds the vehicle (|·|: a depth
        ok &= _covered(grid, chans["depth_m"][0], sig)  # logged positive up is said, not skipped)
        ok &= np.abs(np.interp(grid, *chans["depth_m"])) >= DIRECTION_SURFACE_M
    rows = np.convolve((~ok).astype(float), np.ones(2 * m + 1), "same") < 0.5
    rows[:m] = False
    rows[-m:] = False
    on = np.zeros(grid.size, bool)
    for a, b in armed:
        on |= (grid >= a) & (grid <= b)
    rows &= on
    n = int(rows.sum())
    if n * h < DIRECTION_MIN_S:
        return None

    def smooth(sig_, k=g0):
        return np.convolve(sig_, k, "same")[rows]

    x = np.interp(grid, tm, xm)
    y, rate = smooth(x, g2), smooth(x, g1)
    if tilt:  # the force along the vertical: row 3 of the body-to-NED rotation
        ph, th = (np.interp(grid, *chans[c]) for c in ("roll_rad", "pitch_rad"))
        factor = (-np.sin(th)[None] * B[0][:, None] + (np.sin(ph) * np.cos(th))[None]
                  * B[1][:, None] + (np.cos(ph) * np.cos(th))[None] * B[2][:, None])
    else:
        factor = np.broadcast_to(brow[:, None], (B.shape[1], grid.size))
    T = np.stack([np.interp(grid, tp, pt.T[i]) for i in range(B.shape[1])])
    Tm = np.stack([np.interp(grid, tp, pt.mirrored[i]) for i in act])
    C = np.stack([smooth(factor[i] * T[i]) for i in act])
    Cm = np.stack([smooth(factor[i] * Tm[j]) for j, i in enumerate(act)])
    nuis = [np.ones(n), rate, rate * np.abs(rate)]
    rest = [i for i in range(B.shape[1]) if i not in set(act.tolist())]
    if tilt and rest:  # the other thrusters' share of the vertical force when pitched or rolled
        nuis.append(smooth((factor[rest] * T[rest]).sum(axis=0)))
    if uv:  # the coupled horizontal model's surge/sway accelerations and the Munk moment u·v
        uu, vv = (np.interp(grid, *chans[c]) for c in ("u_mps", "v_mps"))
        nuis += [smooth(uu, g1), smooth(vv, g1), smooth(uu * vv)]
    nuis = np.column_stack([c for c in nuis if np.any(c != 0.0)])  # no tilt logged: no share
    lags = int(np.ceil(max(10.0, 5 * sig) / h))
    sd = C.std(axis=1)
    live = np.flatnonzero(sd > 1e-6 * max(float(sd.max()), 1e-300))
    if live.size == 0:
        return None
    R = np.corrcoef(C[live]) if live.size > 1 else np.ones((1, 1))
    groups, used = [], set()
    for a in range(live.size):  # greedy: a group is its first member and those that track it
        if a in used:
            continue
        grp = [(a, 1.0)]
        used.add(a)
        for b in range(a + 1, live.size):
            if b not in used and abs(R[a, b]) > DIRECTION_GROUP_CORR:
                grp.append((b, float(np.sign(R[a, b]))))
                used.add(b)
        groups.append(grp)
    G = np.stack([sum(s * C[live[a]] for a, s in grp) for grp in groups])
    syy = max(float(((y - y.mean()) ** 2).sum()), 1e-300)

    def fit(X):
        sc = np.abs(X).max(axis=0)
        sc[sc == 0] = 1.0
        Xs = X / sc
        XtX = Xs.T @ Xs
        if np.linalg.cond(XtX) > 1e12:
            return None
        inv = np.linalg.inv(XtX)
        beta = inv @ (Xs.T @ y)
        e = y - Xs @ beta
        var = _hac_var((Xs @ inv) * e[:, None], rows, lags)
        return beta / sc, np.sqrt(var) / sc, 1.0 - float(e @ e) / syy

    full = fit(np.column_stack([G.T, nuis]))
    if full is None:
        return None
    beta, sb, _ = full
    members, group_of, corr = [], {}, {}
    for gi, grp in enumerate(groups):
        ids = [int(act[live[a]]) for a, _ in grp]
        for a, s in grp:
            i = int(act[live[a]])
            members.append((i, s * beta[gi], sb[gi]))
            group_of[i] = ids
            other = grp[1][0] if a == grp[0][0] and len(grp) > 1 else grp[0][0]
            corr[i] = float(R[a, other])

    def one(F):  # one shared coefficient (the physics), the same other terms
        r = fit(np.column_stack([F, nuis]))
        return None if r is None else (r[0][0], r[1][0], r[2] if r[0][0] > 0 else 0.0)

    logged = one(C.sum(axis=0))

    def confirm(bad):
        idx = [int(np.flatnonzero(act == i)[0]) for i in bad]
        fixed = one(C.sum(axis=0) + sum(Cm[j] - C[j] for j in idx))
        if fixed is None or logged is None:
            return None
        return fixed[0], fixed[1], fixed[2], logged[2]

    return {"members": members, "live": [int(act[i]) for i in live], "group_of": group_of,
            "corr": corr, "confirm": confirm,
            "shared": (logged[0], logged[1]) if logged else (float("nan"), float("nan"))}
