"""Caccia, Indiveri & Veruggio (2000) identification on a vehicle's own logs, as library calls.

* :func:`identify_steady` — drag and installation coefficients from constant-command segments
  (§III-A: 0 = −kξ − k_q ξ|ξ| + η_μ φ + w per segment, stacked over segments and mapping modes).
* :func:`identify_inertia` — inertia from a sine experiment by the integrated regression
  (eqs. 15–19), with the drag from :func:`identify_steady` (or a vehicle file).

Both take a log path (with the :class:`~uuvid.identify.vehicle.logs.LogSpec` fields as keywords),
a ``LogSpec`` or a ready :class:`~uuvid.identify.vehicle.logs.LogData`, and return a result with
``summary()``, ``to_dict()`` (the JSON document of ``uuvid vehicle identify … --json``),
``report(folder)`` and ``plot()``::

    from uuvid.identify.vehicle.procedures import identify_steady, identify_inertia
    yaw = identify_steady("pool.csv", dof="yaw", command_col="torque",
                          position_col="heading", angle_unit="deg", open_water=["+"])
    print(yaw.summary())
    inertia = identify_inertia("sine.csv", dof="yaw", drag=yaw, command_col="torque",
                               position_col="heading", angle_unit="deg")
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from uuvid.core.checks import time_window
from uuvid.core.result import Result, jsonable
from uuvid.identify.plausibility import drag_warnings, fit_quality_warnings, inertia_warnings
from uuvid.identify.vehicle.logs import ANGULAR, LogData, LogSpec, read_vehicle_log

__all__ = ["identify_steady", "identify_inertia", "SteadyIdentification",
           "InertiaIdentification", "run_steady", "run_inertia", "InertiaOptions", "load_drag",
           "detect_omega", "parse_eta_map", "build_eta_map", "uniform_position",
           "steady_document", "inertia_document", "write_back"]


def _msg(e: BaseException) -> str:
    if isinstance(e, KeyError) and e.args:
        return str(e.args[0])
    return str(e)


# =============================================================================================
# installation-coefficient map
# =============================================================================================
def _eta_name(mode: str, sign: str | None = None) -> str:
    import re

    base = re.sub(r"\W+", "_", mode).strip("_")
    parts = ["eta"] + ([base] if base else []) + ([] if sign is None else
                                                  ["pos" if sign == "+" else "neg"])
    return "_".join(parts)


def parse_eta_map(text: str) -> dict[str, str | None]:
    """``"front+=1,front-=eta_hull,all=eta_hull_prop"`` → ``{"front+": None, ...}`` (1/open/none
    = open water, η fixed to 1)."""
    import re

    out: dict[str, str | None] = {}
    for part in text.split(","):
        if not part.strip():
            continue
        if "=" not in part:
            raise ValueError(f"--eta-map: expected MODE[+|-]=NAME, got {part.strip()!r}")
        k, v = (s.strip() for s in part.split("=", 1))
        if not k:
            raise ValueError(f"--eta-map: empty mode in {part.strip()!r}")
        if v.lower() in ("1", "1.0", "open", "none", "open_water", "open-water"):
            out[k] = None
        elif re.fullmatch(r"[A-Za-z_]\w*", v):
            out[k] = v
        else:
            raise ValueError(f"--eta-map: {v!r} is not a coefficient name (letters, digits, _) "
                             "nor 1/open (open water)")
    if not out:
        raise ValueError("--eta-map is empty")
    return out


def build_eta_map(seen: dict[str, set[str]], eta_map: str | None, open_water: list[str] | None,
                  per_sign: bool, has_mode_col: bool) -> tuple[dict[str, str | None], list[str]]:
    """η map for the (mode → signs of φ) seen in the segments; returns (map, notes)."""
    notes: list[str] = []
    if eta_map:
        m = parse_eta_map(eta_map)
        known = set(seen) | {f"{k}{s}" for k, ss in seen.items() for s in ss}
        extra = sorted(k for k in m if k not in known)
        if extra:
            notes.append(f"--eta-map entries {extra} match no segment of the log")
        return m, notes
    if open_water:
        opens = set()
        for o in open_water:
            for part in o.split(","):
                if part.strip():
                    opens.add(part.strip())
        for o in sorted(opens):
            base = o[:-1] if o[-1:] in "+-" and o[:-1] in seen else o
            if base not in seen:
                raise ValueError(f"--open-water-mode {o!r}: no steady segment in that mode; modes "
                                 f"in the log's segments: {sorted(seen) or '(none)'}")
        out: dict[str, str | None] = {}
        for mode, signs in seen.items():
            split = per_sign or any(f"{mode}{s}" in opens for s in "+-")
            for s in sorted(signs):
                if mode in opens or f"{mode}{s}" in opens:
                    out[f"{mode}{s}"] = None
                else:
                    out[f"{mode}{s}"] = _eta_name(mode, s if split else None)
        return out, notes
    if not has_mode_col or set(seen) == {""}:
        notes.append("no mode column: every segment taken as open water (η = 1); give --mode-col "
                     "and --open-water-mode to identify installation coefficients")
        return {"": None}, notes
    raise ValueError(f"the log has thrust-mapping modes {sorted(seen)}: say which works in open "
                     "water (η = 1) with --open-water-mode MODE (or MODE+ / MODE- for one sign of "
                     "the force), or give --eta-map MODE=NAME,...")




# =============================================================================================
# steady identification
# =============================================================================================
_SEP = "\x1f"


def run_steady(data: LogData, dof: str, *, settle: float, min_duration: float, tol: float,
               rel_tol: float, threshold: float, eta_map: str | None,
               open_water: list[str] | None, per_sign: bool, direction: str, quadratic: bool,
               cov_type: str, hac_lags: int | None, reduce: bool, has_mode_col: bool) -> dict:
    """Segments → robust velocities → η map → :func:`fit_drag`; everything for JSON/report."""
    from uuvid.identify.vehicle.fit import SteadyPoint, eta_label, fit_drag
    from uuvid.identify.vehicle.segments import find_segments, segment_velocity, summarise_rejections

    angle = dof in ANGULAR
    n = data.t_cmd.size
    modes = data.modes if data.modes is not None else [""] * n
    if data.ballast is not None:
        labels = [f"{m}{_SEP}{b!r}" for m, b in zip(modes, data.ballast.tolist())]
    else:
        labels = list(modes)
    cmd = data.command
    if data.closed_loop is not None:  # closed-loop stretches end constant-command intervals
        cmd = np.where(data.closed_loop, np.nan, cmd)
    segs = find_segments(data.t_cmd, cmd, min_duration=min_duration, settle=settle,
                         tol=tol, rel_tol=rel_tol, mode=labels)
    if not segs:
        raise ValueError(no_segment_message(data, cmd, settle=settle, min_duration=min_duration))
    sign_keep = {"both": 0, "positive": 1, "negative": -1}[direction]
    fitted, skipped = [], []
    for s in segs:
        mode, _, b = (s.mode or "").partition(_SEP)
        ballast = float(b) if b else 0.0
        try:
            sv = segment_velocity(data.t_pos, data.position, s.t0, s.t1, angle=angle,
                                  angle_unit="rad", threshold=threshold)
        except ValueError as e:
            skipped.append({"segment": s.index, "mode": mode, "level": s.level, "t0": s.t0,
                            "t1": s.t1, "reason": str(e)})
            continue
        if sign_keep and np.sign(sv.velocity) != sign_keep:
            skipped.append({"segment": s.index, "mode": mode, "level": s.level, "t0": s.t0,
                            "t1": s.t1, "reason": f"velocity {sv.velocity:.4g} is not {direction} "
                                                  "(--direction)"})
            continue
        fitted.append((s, mode, ballast, sv))
    if not fitted:
        raise ValueError("no steady segment left to fit: " + "; ".join(
            f"segment {k['segment']}: {k['reason']}" for k in skipped[:5]))
    seen: dict[str, set[str]] = {}
    for s, mode, _, _ in fitted:
        seen.setdefault(mode, set()).add("+" if s.level >= 0 else "-")
    emap, notes = build_eta_map(seen, eta_map, open_water, per_sign, has_mode_col)
    pts, vels, seg_rows, rejected = [], [], [], []
    for s, mode, ballast, sv in fitted:
        try:
            et = eta_label(emap, mode, s.level)
        except KeyError as e:
            raise ValueError(f"--eta-map: {_msg(e)}") from None
        pts.append(SteadyPoint(sv.velocity, s.level, et, sv.stderr, ballast, mode, 0, s.t0, s.t1))
        vels.append(sv)
        seg_rows.append({"segment": s.index, "mode": mode, "ballast": ballast, "level": s.level,
                         "t0": s.t0, "t1": s.t1, "eta": et, "velocity": sv.velocity,
                         "velocity_stderr": sv.stderr, "relative_error": sv.relative_error,
                         "n_total": sv.n_total, "n_used": sv.n_used, "n_missing": sv.n_missing,
                         "n_outliers": sv.n_outliers, "settled": sv.settled,
                         "messages": list(sv.messages)})
        for r in sv.rejected:
            rejected.append({"segment": s.index, **r.as_dict()})
    ballast = "dW" if data.ballast is not None else None
    disturbance = "W" if dof == "heave" else "w"
    fit = fit_drag(pts, quadratic=quadratic, disturbance=disturbance, ballast=ballast,
                   cov_type=cov_type, hac_lags=hac_lags, reduce=reduce, dof=dof,
                   model=f"{dof} steady drag ({data.info.get('source')})")
    naive = None
    if dof == "heave" and fit.eta_names:
        try:
            naive = fit_drag([replace(p, eta=None) for p in pts], quadratic=quadratic,
                             disturbance=disturbance, ballast=ballast, cov_type=cov_type,
                             hac_lags=hac_lags, reduce=reduce, dof=dof,
                             model="heave, η = 1 assumed")
        except ValueError:
            naive = None
    unsettled = [r["segment"] for r in seg_rows if not r["settled"]]
    if unsettled:
        notes.append(f"segments {unsettled} had not settled (significant acceleration): their "
                     "velocities are biased; lengthen `settle=`")
    rej = summarise_rejections(vels)
    # samples dropped at reading (NaN position / command) inside the fitted segments
    for key, tt in (("missing", data.t_position_missing), ("missing_command", data.t_command_missing)):
        k = 0 if tt is None else int(sum(np.count_nonzero((tt >= s.t0) & (tt <= s.t1))
                                         for s, _, _, _ in fitted))
        rej[key] = rej.get(key, 0) + k
        if key == "missing":
            rej["samples"] += k
    return {"fit": fit, "naive": naive, "points": pts, "velocities": vels, "segments": seg_rows,
            "skipped": skipped, "rejected": rejected, "eta_map": emap, "notes": notes,
            "rejections": rej, "seen": seen}


def no_segment_message(data: LogData, cmd: np.ndarray, *, settle: float,
                       min_duration: float) -> str:
    """Why no constant-command segment was found, and the remedy that fits: samples excluded as
    closed loop (not MANUAL, or disarmed) and what is left; a command that never changes; or
    stretches shorter than ``settle + min_duration``.  Library parameter names in backticks
    (the CLI maps them to its flags)."""
    src = data.info.get("source")
    n = int(cmd.size)
    span = float(data.t_cmd[-1] - data.t_cmd[0]) if n > 1 else 0.0
    head = (f"no constant-command segment of at least {min_duration:g} s after {settle:g} s of "
            f"settling in {src}")
    usable = np.isfinite(cmd)
    excl = int(n - np.count_nonzero(usable))
    lv = np.unique(np.round(cmd[usable], 6))
    dt = float(np.median(np.diff(data.t_cmd))) if n > 1 else 0.0
    # longest usable stretch
    edges = np.flatnonzero(np.diff(np.concatenate(([0], usable.astype(int), [0]))))
    longest = max(((data.t_cmd[b - 1] - data.t_cmd[a]) for a, b in zip(edges[::2], edges[1::2])),
                  default=0.0)
    parts = []
    if excl:
        why = data.info.get("closed_loop_why")
        parts.append(f"{excl} of {n} command samples ({excl * dt:.4g} s) excluded as not open "
                     "loop (only MANUAL and armed stretches are used"
                     + (f": {why}" if why else "") + ")")
        if not usable.any():
            armed = data.info.get("armed_s")
            return (f"{head}: {parts[0]}; nothing is left — the vehicle was never armed in MANUAL "
                    + (f"(armed {armed:.4g} s of {span:.4g} s in any mode) " if armed is not None
                       else "")
                    + "so the thrusters were never driven open loop; steady identification needs "
                    "constant-command driving in MANUAL, armed (or `open_loop_only=False` if the "
                    "command was open loop in another mode)")
        parts.append(f"left: {int(usable.sum())} samples, longest stretch {longest:.4g} s, "
                     f"{lv.size} distinct command values")
    else:
        parts.append(f"{lv.size} distinct command values over {span:.4g} s")
    if lv.size <= 1:
        armed = data.info.get("armed_s")
        val = f" ({lv[0]:.4g})" if lv.size else ""
        remedy = (f"the command never changes{' in what is left' if excl else ''}{val}: the "
                  "thrusters were idle or at neutral"
                  + (f" (armed {armed:.4g} s of {span:.4g} s)" if armed is not None else "")
                  + "; nothing in this log excites the DOF — use a log where it was driven")
    elif longest < settle + min_duration:
        remedy = (f"the longest usable stretch ({longest:.4g} s) is shorter than `settle=` + "
                  f"`min_duration=` ({settle + min_duration:g} s): lower them")
    else:
        remedy = ("the command is not constant long enough within `rel_tol=`: lower "
                  "`min_duration=`/`settle=` or raise `rel_tol=`")
    return f"{head} ({'; '.join(parts)}); {remedy}"


def _mode_etas(fit, emap: dict, seen: dict[str, set[str]]) -> dict[str, dict]:
    from uuvid.identify.vehicle.fit import eta_label

    out = {}
    for mode, signs in seen.items():
        d = {}
        for s in sorted(signs):
            name = eta_label(emap, mode, 1.0 if s == "+" else -1.0)
            d["pos" if s == "+" else "neg"] = fit.eta(name)
            d[("pos" if s == "+" else "neg") + "_name"] = name
        out[mode] = d
    return out


def _param_table(f) -> dict:
    return {p.name: {"estimate": p.value, "sigma": p.stderr, "unit": p.unit,
                     "percentile_error": p.percentile_error, "significant": p.significant}
            for p in f.parameters}


def _buoyancy(fit, counts) -> list[dict]:
    f = fit.fit
    if "W" not in f.names:
        return []
    C = f.covariance
    iw = f.names.index("W")
    idw = f.names.index("dW") if "dW" in f.names else None
    rows = []
    for n in counts:
        est = f["W"].value + (n * f["dW"].value if idw is not None else 0.0)
        var = C[iw, iw]
        if idw is not None:
            var += n * n * C[idw, idw] + 2 * n * C[iw, idw]
        rows.append({"ballast": n, "estimate": est, "sigma": math.sqrt(max(var, 0.0))})
    return rows


def steady_document(res: dict, dof: str, log: Path, data: LogData) -> dict:
    fit = res["fit"]
    f = fit.fit
    etas = _mode_etas(fit, res["eta_map"], res["seen"])
    opens = sorted({m + k for m, d in etas.items() for k, s in (("+", "pos"), ("-", "neg"))
                    if d.get(f"{s}_name", "x") is None})
    doc = {
        "command": "vehicle identify steady", "log": str(log), "dof": dof,
        "format": data.info.get("format"),
        "units": {"velocity": "rad/s" if dof in ANGULAR else "m/s",
                  "force": "N·m" if dof in ANGULAR else "N"},
        "parameters": _param_table(f),
        "quadratic_significant": fit.quadratic_significant,
        "linear_significant": fit.linear_significant,
        "reduced_to": fit.reduced_to, "dropped": list(fit.dropped),
        "full_parameters": _param_table(fit.full),
        "cov_type": f.extra.get("cov_type"), "sigma2": f.sigma2, "n_points": len(fit.points),
        "messages": list(fit.messages), "notes": list(fit.notes) + res["notes"],
        "eta_map": {k: v for k, v in res["eta_map"].items()},
        "model": {"dof": dof, "k": fit.k, "k_q": fit.k_q, "disturbance": fit.w,
                  "disturbance_name": fit.disturbance, "ballast": fit.ballast,
                  "drag_covariance": fit.drag_covariance().tolist(),
                  "eta": {m: {"pos": d.get("pos"), "neg": d.get("neg")} for m, d in etas.items()},
                  "open_water": opens},
        "segments": res["segments"], "skipped_segments": res["skipped"],
        "rejected": res["rejected"], "rejections": res["rejections"],
        "log_info": data.info,
    }
    if dof == "heave":
        counts = sorted({p.ballast for p in fit.points})
        doc["buoyancy"] = {"with_eta": _buoyancy(fit, counts),
                           "eta_unitary": _buoyancy(res["naive"], counts) if res["naive"] else []}
    return doc


def steady_identified(doc: dict, dof: str, log: Path, key: str | None, mode: str | None) -> dict:
    m = doc["model"]
    p = doc["parameters"]
    lin = m["k"] if "k" in p else 0.0
    quad = m["k_q"] if "k_q" in p else 0.0
    etas = {mo: {s: v for s, v in (("+", d["pos"]), ("-", d["neg"])) if v is not None}
            for mo, d in m["eta"].items() if mo}
    if mode is None:
        full = [mo for mo, d in m["eta"].items() if mo and all(
            (f"{mo}{s}" in m["open_water"]) for s, k in (("+", "pos"), ("-", "neg"))
            if d.get(k) is not None)]
        mode = full[0] if full else next((o[:-1] for o in m["open_water"] if o[:-1]), None)
    sigma = {"linear": p.get("k", {}).get("sigma"), "quadratic": p.get("k_q", {}).get("sigma")}
    d = {"linear": lin, "quadratic": quad, "eta": etas, "disturbance": m["disturbance"],
         "sigma": {k: v for k, v in sigma.items() if v is not None}, "log": str(log),
         "method": "steady segments, Caccia et al. 2000 §III-A"
                   + (f"; reduced to {doc['reduced_to']}" if doc["reduced_to"] else "")}
    if mode:
        d["mode"] = mode
    if key:
        d["key"] = key
    return {dof: d}



# =============================================================================================
# inertia
# =============================================================================================
def load_drag(source: str, dof: str, key: str | None = None, mode: str | None = None) -> dict:
    """Drag (k, k_q, covariance, disturbance, η) for the inertia regression from the JSON of
    ``identify steady --json`` or a vehicle file/preset (its ``one_dof`` model of the DOF)."""
    p = Path(source)
    if p.suffix.lower() == ".json":
        if not p.is_file():
            raise ValueError(f"--drag {p}: no such file")
        if p.stat().st_size == 0:  # e.g. `> steady.json` from a command that failed
            raise ValueError(f"--drag {p}: the file is empty — the command that should have "
                             "written it failed or wrote nothing (use its --report DIR: "
                             "DIR/summary.json)")
        try:
            doc = json.loads(p.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
            raise ValueError(f"--drag {p}: not a readable JSON file ({e})") from None
        m = doc.get("model", doc) if isinstance(doc, dict) else None
        if not isinstance(m, dict) or "k" not in m:
            raise ValueError(f"--drag {p}: expected the JSON of `uuvid vehicle identify steady "
                             "--json` (a 'model' with k, k_q) or {\"k\": ..., \"k_q\": ...}")
        if m.get("dof") not in (None, dof):
            raise ValueError(f"--drag {p}: a {m['dof']} model, but --dof is {dof}")
        try:
            k, kq = float(m["k"]), float(m.get("k_q", 0.0) or 0.0)
        except (TypeError, ValueError):
            raise ValueError(f"--drag {p}: k and k_q must be numbers") from None
        cov = m.get("drag_covariance")
        said = []
        if m.get("k_q") is None:  # a linear drag file: the quadratic term is not "0 measured"
            said.append(f"--drag {p.name}: k_q not given: 0 assumed (linear drag k = {k:.4g} "
                        "only); give \"k_q\" (the JSON of `identify steady --json` has it) — "
                        "the inertia follows the drag it is given")
        etas = m.get("eta") or {}
        ep = en = 1.0
        if mode is not None:
            if mode not in etas:
                raise ValueError(f"--mode {mode!r}: not a mode of {p.name} (modes: "
                                 f"{sorted(etas) or '(none)'})")
            ep = etas[mode].get("pos") or 1.0
            en = etas[mode].get("neg") or 1.0
        return {"k": k, "k_q": kq, "cov": cov, "w": float(m.get("disturbance", 0.0) or 0.0),
                "eta": (float(ep), float(en)), "source": str(p), "key": None, "warnings": said}
    from uuvid.vehicle.definition import load_vehicle

    try:
        v = load_vehicle(source)
    except (ValueError, FileNotFoundError, KeyError) as e:
        raise ValueError(f"--drag: {_msg(e)} (give the JSON of `identify steady --json` or a "
                         "vehicle file)") from None
    cands = {n: od for n, od in v.one_dof.items() if od.dof == dof}
    notes = []
    if key is not None:
        if key not in v.one_dof:
            raise ValueError(f"--one-dof {key!r}: {v.name} has no such one_dof model (have "
                             f"{sorted(v.one_dof)})")
        od = v.one_dof[key]
        if od.dof != dof:
            raise ValueError(f"--one-dof {key!r} is a {od.dof} model, but --dof is {dof}")
    elif len(cands) == 1:
        key, od = next(iter(cands.items()))
    elif len(cands) > 1:
        raise ValueError(f"{v.name} has several {dof} models in one_dof ({', '.join(cands)}): "
                         "pick one with --one-dof")
    else:
        from uuvid.vehicle.layout import dof_index

        i = dof_index(dof)
        od = None
        k, kq = float(v.params.linear_damping[i, i]), float(v.params.quadratic_damping[i, i])
        notes.append(f"{v.name} has no one_dof {dof} model: drag from hydrodynamics "
                     f"(k = {k:.4g}, k_q = {kq:.4g}), η = 1")
    if od is not None:
        k, kq = od.linear, od.quadratic
        ep, en = od.eta_pos, od.eta_neg
    else:
        ep = en = 1.0
    if mode is not None:
        if mode not in v.modes:
            raise ValueError(f"--mode {mode!r}: {v.name} has no such mode "
                             f"(modes: {', '.join(sorted(v.modes))})")
        ed = v.modes[mode].eta_dof
        ep = float(ed.get(f"{dof}+", ed.get(dof, 1.0)))
        en = float(ed.get(f"{dof}-", ed.get(dof, 1.0)))
    return {"k": float(k), "k_q": float(kq), "cov": None,
            "w": float(od.disturbance) if od is not None else 0.0, "eta": (float(ep), float(en)),
            "source": str(source), "key": key, "notes": notes}


def detect_omega(t, u) -> tuple[float | None, float]:
    """Frequency [rad/s] and amplitude of the dominant sine in ``u(t)`` (FFT peak refined by a
    least-squares sine fit), or ``None`` for the frequency when one sine explains less than 3/4
    of the command's variance or fewer than two periods are recorded (not a sine experiment)."""
    from scipy.optimize import minimize_scalar

    t = np.asarray(t, float)
    u = np.asarray(u, float)
    if t.size < 16:
        return None, 0.0
    dt = float(np.median(np.diff(t)))
    if not dt > 0:
        return None, 0.0
    _check_grid(t, dt, "command", relative=True)
    grid = np.arange(t[0], t[-1], dt)
    idx = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, t.size - 1)
    ug = u[idx]
    ug = ug - np.polyval(np.polyfit(grid - grid[0], ug, 1), grid - grid[0])
    if np.ptp(ug) <= 1e-9 * max(1.0, float(np.max(np.abs(u)))):
        return None, 0.0
    F = np.abs(np.fft.rfft(ug * np.hanning(ug.size)))
    fr = np.fft.rfftfreq(ug.size, dt)
    i = int(np.argmax(F[1:])) + 1
    lo, hi = 2 * math.pi * fr[max(i - 1, 1)], 2 * math.pi * fr[min(i + 1, fr.size - 1)]
    tt = grid - grid[0]

    def sine_fit(w):
        H = np.column_stack([np.sin(w * tt), np.cos(w * tt), np.ones_like(tt), tt])
        c, *_ = np.linalg.lstsq(H, ug, rcond=None)
        return float(np.sum((ug - H @ c) ** 2)), math.hypot(c[0], c[1])

    r = minimize_scalar(lambda w: sine_fit(w)[0], bounds=(lo, hi), method="bounded",
                        options={"xatol": 1e-9})
    w = float(r.x)
    rss, a = sine_fit(w)
    tss = float(np.sum((ug - ug.mean()) ** 2))
    # not a sine experiment: one sine explains less than 3/4 of the command's variance, or fewer
    # than two periods were recorded
    if tss <= 0 or rss > 0.25 * tss or 2 * math.pi / w > 0.5 * (grid[-1] - grid[0]):
        return None, a
    return w, a


@dataclass
class InertiaOptions:
    window: int | None = None
    order: int = 4
    cov_type: str = "HAC"
    hac_lags: int | None = None
    omega: float | None = None
    t_start: float | None = None
    t_end: float | None = None
    clean: bool = True
    eiv: bool = False
    max_filled: int = 2


def run_inertia(data: LogData, dof: str, drag: dict, opt: InertiaOptions) -> dict:
    from uuvid.identify.vehicle.fit import (
        fit_inertia,
        phase_lag,
        predicted_phase_lag,
        validate_one_dof,
    )
    from uuvid.vehicle.model import OneDofModel

    angle = dof in ANGULAR
    window = opt.window if opt.window is not None else (41 if angle else 21)
    if window % 2 == 0 or window <= opt.order:
        raise ValueError(f"--window must be an odd number of points > --order ({opt.order}), got "
                         f"{window}")
    if int(opt.max_filled) < 0:
        raise ValueError(f"--max-filled {opt.max_filled}: expected a count of samples >= 0")
    if opt.hac_lags is not None and int(opt.hac_lags) < 0:
        raise ValueError(f"--hac-lags {opt.hac_lags}: expected a bandwidth of >= 0 points")
    omega, amp = (opt.omega, math.nan) if opt.omega else detect_omega(data.t_cmd, data.command)
    dt_pos = float(np.median(np.diff(data.t_pos)))
    if opt.omega and opt.omega * dt_pos > math.pi:
        raise ValueError(f"--omega {opt.omega:g} rad/s is above the Nyquist frequency "
                         f"π/Δt = {math.pi / dt_pos:.4g} rad/s of the position samples (Δt = "
                         f"{dt_pos:.4g} s): the log cannot hold that sine; expected the sine's "
                         "frequency in rad/s (2π / period)")
    hac = opt.hac_lags
    notes = []
    if opt.cov_type == "HAC" and hac is None and omega:
        hac = max(1, int(round(0.25 * (2 * math.pi / omega) / dt_pos)))
        notes.append(f"HAC bandwidth {hac} points = a quarter of the {2 * math.pi / omega:.4g} s "
                     "sine period")
    cov = drag.get("cov")
    fit = fit_inertia(data.t_pos, data.position, data.command, t_phi=data.t_cmd, k=drag["k"],
                      k_q=drag["k_q"], eta=drag["eta"], order=opt.order, window=window,
                      t_start=opt.t_start, t_end=opt.t_end, clean=opt.clean, angle=angle,
                      angle_unit="rad", cov_type=opt.cov_type, hac_lags=hac,
                      drag_cov=cov, velocity_noise_correction=opt.eiv,
                      max_filled=opt.max_filled)
    m = fit.mass
    if opt.cov_type == "HAC" and hac is not None and hac >= np.size(fit.t):
        notes.append(f"HAC bandwidth {hac:,} points is not shorter than the {np.size(fit.t)} "
                     "regression rows: every pair of residuals is weighted, so σ is no HAC "
                     "estimate; give a smaller --hac-lags (default a quarter of the sine period)")
    out = {"fit": fit, "window": window, "hac_lags": hac, "omega": omega, "notes": notes}
    # phase lag of the velocity behind the sine input vs atan(ω m / k_L)
    tr, vr = fit.t_raw, fit.velocity_raw
    j = np.clip(np.searchsorted(data.t_cmd, tr, side="right") - 1, 0, data.t_cmd.size - 1)
    u_r = data.command[j]
    lag = None
    if omega:
        try:
            pl = phase_lag(tr, u_r, vr, omega, t_start=float(fit.t[0]), t_end=float(fit.t[-1]))
            kL = drag["k"] + 2 * drag["k_q"] * float(np.mean(np.abs(fit.velocity)))
            dt_cmd = float(np.median(np.diff(data.t_cmd)))
            lag = {"omega": omega, "period": 2 * math.pi / omega, "input_amplitude": amp,
                   "measured_deg": pl["lag_deg"], "time_lag_s": pl["time_lag_s"], "k_L": kL,
                   "predicted_deg": predicted_phase_lag(omega, m, kL) if m > 0 and kL > 0
                   else None,
                   "zoh_delay_deg": math.degrees(omega * dt_cmd / 2),
                   "note": "measured from the Savitzky–Golay velocity; includes the half-sample "
                           "delay of a zero-order-hold command (zoh_delay_deg)"}
        except ValueError as e:
            notes.append(f"phase lag not measured: {e}")
    else:
        notes.append("the command is not a sine (no dominant frequency): no phase lag; give "
                     "--omega")
    out["phase_lag"] = lag
    model = None
    if m > 0 and (drag["k"] > 0 or drag["k_q"] > 0):
        model = OneDofModel(m, max(drag["k"], 0.0), max(drag["k_q"], 0.0), drag["eta"][0],
                            drag["eta"][1], drag.get("w", 0.0), dof)
        sel = (tr >= fit.t[0]) & (tr <= fit.t[-1])
        val = validate_one_dof(model, tr[sel], data.command, vr[sel], t_phi=data.t_cmd)
        out["fit_nrmse"] = val["nrmse"]
        out["predicted"] = (tr[sel], val["predicted"], vr[sel])
    else:
        notes.append("non-positive inertia or drag: the model cannot be simulated")
    out["model"] = model
    return out


def _validate_log(model, data: LogData, dof: str, window: int) -> dict:
    from uuvid.identify.vehicle.fit import validate_one_dof
    from uuvid.identify.vehicle.segments import clean_series, savgol_velocity

    angle = dof in ANGULAR
    cs = clean_series(data.t_pos, data.position, angle=angle, angle_unit="rad", window=window)
    v = savgol_velocity(cs.t, cs.x, order=4, window=window)
    val = validate_one_dof(model, cs.t, data.command, v, t_phi=data.t_cmd)
    return {"nrmse": val["nrmse"], "rmse": val["rmse"], "cleaning": cs.summary(),
            "series": (cs.t, val["predicted"], v)}


def inertia_document(res: dict, dof: str, log: Path, drag: dict, data: LogData) -> dict:
    fit = res["fit"]
    f = fit.fit
    pars = _param_table(f)
    for n, r in pars.items():
        if "sigma_ls" in f.extra:
            r["sigma_regression"] = f.extra["sigma_ls"].get(n)
            r["sigma_from_drag"] = f.extra["sigma_drag"].get(n)
    doc = {"command": "vehicle identify inertia", "log": str(log), "dof": dof,
           "parameters": pars,
           "mass": {"estimate": fit.mass, "sigma": fit.mass_stderr,
                    "unit": "kg·m²" if dof in ANGULAR else "kg",
                    "m_uncorrected": f.extra.get("m_uncorrected")},
           "drag": {"k": drag["k"], "k_q": drag["k_q"], "disturbance": drag.get("w", 0.0),
                    "eta_pos": drag["eta"][0], "eta_neg": drag["eta"][1],
                    "source": drag["source"], "one_dof_key": drag.get("key"),
                    "covariance_propagated": drag.get("cov") is not None},
           "window": res["window"], "order": fit.order, "cov_type": f.extra.get("cov_type"),
           "hac_lags": res["hac_lags"], "n_rows": int(fit.t.size),
           "rows_excluded": f.extra.get("rows_excluded"), "cleaning": fit.cleaning,
           "phase_lag": res["phase_lag"], "fit_nrmse": res.get("fit_nrmse"),
           "notes": [n.replace("(give drag_cov)", "(give --drag with the JSON of identify steady)")
                     for n in fit.notes] + res["notes"] + list(drag.get("notes") or []),
           "log_info": data.info}
    return doc




# =============================================================================================
# a uniform position grid for the inertia regression
# =============================================================================================
MAX_GRID = 2_000_000
"""Most points of a uniform grid an identification builds (the budget checked before
allocating it)."""


def _check_grid(t: np.ndarray, step: float, what: str, *, relative: bool,
                option: str | None = None) -> int:
    """The size of a uniform ``step`` grid over ``t``, refused (``ValueError``) past
    :data:`MAX_GRID` points or, with ``relative``, past 10× the samples (a clock jump or a time
    column in the wrong unit: the grid would fill the gap)."""
    span = float(t[-1] - t[0])
    n = math.floor(span / step + 1e-9) + 1 if math.isfinite(span) else math.inf
    if relative and n > 10 * t.size + 16:
        d = np.diff(t)
        i = int(np.argmax(d))
        raise ValueError(
            f"{what} time stamps: the largest gap is {d[i]:.6g} s (after t = {t[i]:.6g} s, sample "
            f"{i + 1}) for a median step of {step:.4g} s; {t.size} samples span {span:.6g} s: "
            "a clock jump or a time column in the wrong unit (check --time-unit); cut the log "
            "with --t-start/--t-end around the experiment")
    if n > MAX_GRID:
        raise ValueError(
            f"{what}: a uniform {step:.4g} s grid over {span:.6g} s is {n:.3g} points, more than "
            f"{MAX_GRID:,}; " + (f"give a larger {option} step" if option else
                                 "cut the log with --t-start/--t-end"))
    return int(n)


def uniform_position(t, x, *, resample="auto", angle: bool = False,
                     jitter_tol: float = 0.01) -> tuple[np.ndarray, np.ndarray, str | None]:
    """The position on a uniform grid for the Savitzky–Golay derivative of the inertia fit.

    ``resample="auto"``: samples already within ``jitter_tol`` of a step of the grid
    ``t₀ + k·dt`` (``dt`` the median spacing) are kept; otherwise (an autopilot's 10 Hz attitude
    drifts off any grid) the record is interpolated onto the grid, a heading unwrapped
    first, by a cubic spline through the samples (linear interpolation would flatten the
    curvature the Savitzky–Golay derivative needs), grid points farther than 1.5 dt from any
    sample left missing (the cleaning fills them)
    — with a note saying so.  ``"off"``: keep the samples as they are; a number: resample onto
    that step [s].  Returns (t, x, note or None)."""
    t = np.asarray(t, float)
    x = np.asarray(x, float)
    if resample in (None, "off", False):
        return t, x, None
    if t.size < 3:
        return t, x, None
    d = np.diff(t)
    step = float(np.median(d))
    if isinstance(resample, str):
        if resample != "auto":
            raise ValueError(f"resample {resample!r}: expected auto, off or a step in seconds")
        _check_grid(t, step, "position", relative=True)
        k = np.rint((t - t[0]) / step)
        off = np.abs(t - (t[0] + k * step))
        if np.max(off) <= jitter_tol * step and np.unique(k).size == k.size:
            return t, x, None
        why = (f"position samples (median step {step:.4g} s) drift off a uniform grid (largest "
               f"offset {100 * np.max(off) / step:.0f} % of a step, steps {d.min():.4g}…"
               f"{d.max():.4g} s)")
    else:
        step = float(resample)
        if not (math.isfinite(step) and step > 0):
            raise ValueError(f"resample step must be > 0 s, got {resample!r}")
        why = "resampling asked for"
    if angle:
        from uuvid.identify.vehicle.segments import robust_unwrap

        x = robust_unwrap(t, x, "rad")
    n = _check_grid(t, step, "position", relative=isinstance(resample, str),
                    option=None if isinstance(resample, str) else "--resample")
    grid = t[0] + step * np.arange(n)
    from scipy.interpolate import CubicSpline

    ok = np.isfinite(x)
    xg = CubicSpline(t[ok], x[ok])(grid) if ok.sum() >= 4 else np.interp(grid, t[ok], x[ok])
    j = np.clip(np.searchsorted(t, grid), 1, t.size - 1)
    gap = np.minimum(np.abs(grid - t[j - 1]), np.abs(t[j] - grid))
    xg[gap > 1.5 * step] = np.nan
    note = (f"{why}: interpolated (cubic spline) onto a uniform {step:.4g} s grid ({n} points"
            + (f", {int(np.sum(gap > 1.5 * step))} in gaps left missing" if np.any(
                gap > 1.5 * step) else "") + ")" + ("; heading unwrapped first" if angle else "")
            + "; resample='off' (--resample off) to refuse instead")
    if np.std(d) > 0.5 * step:
        note += f"; the spacing is irregular (σ {np.std(d):.3g} s): check the log"
    return grid, xg, note


# =============================================================================================
# write-back into a vehicle file
# =============================================================================================
def write_back(vehicle: str, out_vehicle, identified: dict, log, command: str) -> str:
    """Write ``identified`` into a copy of ``vehicle`` at ``out_vehicle`` (see
    :func:`uuvid.vehicle.writeback.write_identified`); raises ``ValueError`` when refused."""
    from uuvid.vehicle.writeback import WritebackError, write_identified

    try:
        return str(write_identified(vehicle, identified, Path(out_vehicle), log=str(log),
                                    command=command))
    except WritebackError as e:
        raise ValueError(f"--write-vehicle: {e}") from None


# =============================================================================================
# results and the public entry points
# =============================================================================================
def _params_text(title: str, params: dict) -> str:
    lines = [title, f"  {'parameter':<16}{'estimate':>12}{'σ':>11}  {'% error':>8}  significant"]
    for n, r in params.items():
        lines.append(f"  {n:<16}{_cell(r['estimate'], '>12.5g')}{_cell(r['sigma'], '>11.3g')}  "
                     f"{_cell(r['percentile_error'], '>8.1f')}  "
                     f"{'yes' if r['significant'] else 'no'}  {r.get('unit') or ''}")
    return "\n".join(lines)


def _cell(x, fmt: str) -> str:
    """A number for the text table; "—" where the fit gave none (None, NaN, inf)."""
    width = int("".join(c for c in fmt.split(".")[0] if c.isdigit()) or 0)
    if x is None or not math.isfinite(x):
        return "—".rjust(width)
    return format(x, fmt)


@dataclass
class SteadyIdentification(Result):
    """Drag and installation coefficients of one DOF from a log (Caccia et al. 2000, §III-A).

    ``fit`` is the :class:`~uuvid.identify.vehicle.fit.DragFit`; ``result`` everything the
    procedure found (segments, skipped segments, rejected samples, η map); ``document`` the JSON
    of ``uuvid vehicle identify steady --json``."""

    dof: str
    log: str
    data: LogData
    result: dict
    document: dict

    @property
    def fit(self):
        return self.result["fit"]

    @property
    def notes(self) -> list[str]:
        return list(self.document["messages"]) + list(self.result["notes"])

    @property
    def warnings(self) -> list[str]:
        return list(self.document.get("warnings") or [])

    def summary(self) -> str:
        f = self.fit
        r = self.result["rejections"]
        out = [_params_text(f"{self.dof} drag from {Path(self.log).name}: {len(f.points)} steady "
                            "segments" + (f", reduced to {f.reduced_to}" if f.reduced_to else ""),
                            self.document["parameters"]),
               f"samples: {r['used']}/{r['samples']} used, {r['missing']} missing, "
               f"{r['outliers']} outliers rejected; {len(self.result['skipped'])} segments left "
               "out"]
        out += [f"warning: {w}" for w in self.warnings] + [f"note: {m}" for m in self.notes]
        return "\n".join(out)

    report_title = "Steady drag identification"

    def to_dict(self) -> dict:
        return jsonable(self.document)

    def _report_into(self, folder) -> Path:
        """Plots, tables, fit report, summary.json, summary.txt, result.json and index.html in
        ``folder`` (:meth:`report` writes the folder as a whole); returns the index."""
        from uuvid.identify.vehicle.reports import write_steady_report

        index = write_steady_report(self.result, self.document, self.data, self.dof, Path(folder))
        self.write_basics(folder)
        return index

    def plot(self):
        from uuvid.identify.vehicle.reports import steady_figure

        return steady_figure(self.result, self.document, self.data, self.dof)[0]

    def identified(self, key: str | None = None, mode: str | None = None) -> dict:
        """``{dof: {...}}`` for :func:`write_back` (the ``one_dof`` entry of a vehicle file)."""
        return steady_identified(self.document, self.dof, self.log, key, mode)

    def write_vehicle(self, vehicle: str, out, key: str | None = None,
                      mode: str | None = None) -> str:
        return write_back(vehicle, out, self.identified(key, mode), self.log,
                          "uuvid vehicle identify steady")


def _as_data(log, dof: str | None, read: dict) -> tuple[LogData, str, str]:
    if isinstance(log, LogData):
        if dof is None:
            raise ValueError("give dof= with a LogData")
        if read:
            raise ValueError(f"reading options {sorted(read)} apply to a log file, not to LogData")
        return log, dof, str(log.info.get("path") or log.info.get("source", "log"))
    if isinstance(log, LogSpec):
        spec = replace(log, **({"dof": dof} if dof else {}), **read)
    else:
        if dof is None:
            raise ValueError("give dof= (the degree of freedom the log excites)")
        spec = LogSpec(Path(log), dof, **read)
    return read_vehicle_log(spec), spec.dof, str(spec.path)


def _check_steady_options(settle, min_duration, tol, rel_tol, threshold) -> None:
    """The numbers of :func:`identify_steady`, before the log is read: ``ValueError`` naming the
    parameter (```name=```, spelled as an option by the command line)."""
    checks = (("settle", settle, lambda v: v >= 0, "a settling time >= 0 s"),
              ("min_duration", min_duration, lambda v: v > 0, "a duration > 0 s"),
              ("tol", tol, lambda v: v >= 0, "an absolute tolerance >= 0 (the command's unit)"),
              ("rel_tol", rel_tol, lambda v: v >= 0, "a relative tolerance >= 0 (0.02 = 2 %)"),
              ("threshold", threshold, lambda v: v > 0,
               "an outlier threshold > 0 (robust σ; 3.5 by default)"))
    for name, v, ok, what in checks:
        v = float(v)
        if not (math.isfinite(v) and ok(v)):
            raise ValueError(f"`{name}=` {v:g}: expected {what}")


def eta_warnings(parameters: dict, dof: str) -> list[str]:
    """A negative installation coefficient η (``eta_*`` in ``parameters``: name → {estimate,
    sigma}) is a thruster pushing backwards: a sign or unit slip (a heading in radians read as
    degrees, a reversed command), not a coefficient that is merely "not significant"."""
    out = []
    for name, p in parameters.items():
        if not name.startswith("eta_") or not p or p.get("estimate") is None:
            continue
        est, sig = float(p["estimate"]), p.get("sigma")
        if not est < 0:
            continue
        sig_txt = f" ± {float(sig):.3g}" if sig is not None and np.isfinite(sig) else ""
        out.append(f"implausible {dof} installation coefficient {name} = {est:.4g}{sig_txt} < 0: "
                   "that mode's thrust would push the vehicle backwards (η is the fraction of "
                   "the nominal thrust that acts, 0 < η ≲ 1) — check the sign of the command and "
                   "of the position/heading channel, its unit (--angle-unit, --position-unit) "
                   "and the mode mapping (--eta-map, --open-water-mode)")
    return out


def identify_steady(log, dof: str | None = None, *, settle: float = 10.0,
                    min_duration: float = 10.0, tol: float = 0.0, rel_tol: float = 0.02,
                    threshold: float = 3.5, eta_map: str | None = None,
                    open_water: list[str] | str | None = None, per_sign: bool = False,
                    direction: str = "both", quadratic: bool = True, cov_type: str = "classical",
                    hac_lags: int | None = None, reduce: bool = True,
                    **read) -> SteadyIdentification:
    """Drag (k, k_q), disturbance and installation coefficients η of one DOF from a log's
    constant-command segments (Caccia, Indiveri & Veruggio 2000, §III-A).

    ``log``: a path (``read`` are :class:`LogSpec` fields: ``command_col="-2*thrust"``,
    ``topics=[...]``, ``fields=[...]``, ``vehicle=``, ``on_duplicate=``, ``time=``,
    ``t_start=``…), a :class:`LogSpec` or :class:`LogData`.  ``eta_map`` / ``open_water`` say
    which mapping mode works in open water (η = 1) — see :func:`build_eta_map`."""
    _check_steady_options(settle, min_duration, tol, rel_tol, threshold)
    data, dof, name = _as_data(log, dof, read)
    if eta_map and open_water:
        raise ValueError("give eta_map (--eta-map) or open_water (--open-water-mode), not both")
    if data.ballast is not None and dof != "heave":
        raise ValueError("a ballast channel (added weights, eq. 20) applies to the heave DOF")
    if isinstance(open_water, str):
        open_water = [open_water]
    try:
        res = run_steady(data, dof, settle=settle, min_duration=min_duration, tol=tol,
                         rel_tol=rel_tol, threshold=threshold, eta_map=eta_map,
                         open_water=list(open_water or []), per_sign=per_sign,
                         direction=direction, quadratic=quadratic, cov_type=cov_type,
                         hac_lags=hac_lags, reduce=reduce, has_mode_col=data.modes is not None)
    except KeyError as e:
        raise ValueError(_msg(e)) from None
    res["notes"] = data.notes + res["notes"]
    doc = steady_document(res, dof, name, data)
    doc["warnings"] = (data.warnings + drag_warnings(doc["parameters"], dof)
                       + eta_warnings(doc["parameters"], dof))
    return SteadyIdentification(dof, name, data, res, doc)


@dataclass
class InertiaIdentification(Result):
    """Inertia of one DOF from a sine experiment (Caccia et al. 2000, eqs. 15–19).

    ``fit`` is the :class:`~uuvid.identify.vehicle.fit.InertiaFit`, ``model`` the identified
    :class:`~uuvid.vehicle.model.OneDofModel` (``None`` when it cannot be simulated),
    ``document`` the JSON of ``uuvid vehicle identify inertia --json``."""

    dof: str
    log: str
    data: LogData
    drag: dict
    result: dict
    document: dict
    validation: dict | None = None

    @property
    def fit(self):
        return self.result["fit"]

    @property
    def model(self):
        return self.result.get("model")

    @property
    def mass(self) -> float:
        return float(self.fit.mass)

    def summary(self) -> str:
        doc = self.document
        out = [_params_text(f"{self.dof} inertia from {Path(self.log).name} ({doc['n_rows']} "
                            f"rows, {doc['cov_type']} σ)", doc["parameters"])]
        pl = doc["phase_lag"]
        if pl:
            pred = f"{pl['predicted_deg']:.1f}°" if pl["predicted_deg"] is not None else "n/a"
            out.append(f"phase lag at ω = {pl['omega']:.4g} rad/s: measured "
                       f"{pl['measured_deg']:.1f}° (incl. {pl['zoh_delay_deg']:.1f}° ZOH), "
                       f"atan(ω m/k_L) = {pred}")
        if doc.get("fit_nrmse") is not None:
            out.append(f"NRMSE of the identified model on this log: {doc['fit_nrmse']:.3f}"
                       + (f"; on {Path(doc['validation']['log']).name}: "
                          f"{doc['validation']['nrmse']:.3f}" if doc.get("validation") else ""))
        out += [f"warning: {w}" for w in doc.get("warnings") or []]
        out += [f"note: {m}" for m in doc["notes"]]
        return "\n".join(out)

    report_title = "Inertia identification"

    def to_dict(self) -> dict:
        return jsonable(self.document)

    def _report_into(self, folder) -> Path:
        """Plots, tables, fit report, summary.json, summary.txt, result.json and index.html in
        ``folder`` (:meth:`report` writes the folder as a whole); returns the index."""
        from uuvid.identify.vehicle.reports import write_inertia_report

        index = write_inertia_report(self.result, self.document, self.data, self.dof,
                                     Path(folder), self.validation)
        self.write_basics(folder)
        return index

    def plot(self):
        from uuvid.identify.vehicle.reports import inertia_figure

        return inertia_figure(self.result, self.document, self.data, self.dof)

    def identified(self, key: str | None = None, mode: str | None = None) -> dict:
        d = self.dof
        ident = {d: {"mass": self.fit.mass, "linear": self.drag["k"],
                     "quadratic": self.drag["k_q"], "sigma": {"mass": self.fit.mass_stderr},
                     "log": self.log,
                     "method": "sine experiment, integrated regression, Caccia et al. 2000 "
                               "eqs. 15–19",
                     "key": key or self.drag.get("key") or d}}
        if mode is not None:
            ident[d]["mode"] = mode
            ident[d]["eta"] = {mode: {"+": self.drag["eta"][0], "-": self.drag["eta"][1]}}
        return ident

    def write_vehicle(self, vehicle: str, out, key: str | None = None,
                      mode: str | None = None) -> str:
        return write_back(vehicle, out, self.identified(key, mode), self.log,
                          "uuvid vehicle identify inertia")


def _drag(drag, dof: str, k, k_q, eta, mode, one_dof) -> dict:
    if drag is None and k is None:
        raise ValueError("give the drag: --drag STEADY.json|VEHICLE, or --k (and --kq)")
    if drag is not None and (k is not None or k_q is not None):
        raise ValueError("give --drag or --k/--kq, not both")
    if isinstance(drag, SteadyIdentification):
        m = drag.document["model"]
        if drag.dof != dof:
            raise ValueError(f"drag: a {drag.dof} identification, but the DOF is {dof}")
        ep = en = 1.0
        if mode is not None:
            if mode not in m["eta"]:
                raise ValueError(f"--mode {mode!r}: not a mode of the steady identification "
                                 f"(modes: {sorted(m['eta'])})")
            ep, en = m["eta"][mode].get("pos") or 1.0, m["eta"][mode].get("neg") or 1.0
        dr = {"k": float(m["k"]), "k_q": float(m["k_q"]), "cov": m["drag_covariance"],
              "w": float(m["disturbance"] or 0.0), "eta": (float(ep), float(en)),
              "source": f"steady identification of {Path(drag.log).name}", "key": None}
    elif drag is not None:
        dr = load_drag(str(drag), dof, one_dof, mode)
    else:
        if not (math.isfinite(k) and k >= 0) or (k_q is not None and not (math.isfinite(k_q)
                                                                            and k_q >= 0)):
            raise ValueError("--k and --kq must be finite and >= 0")
        if mode is not None:
            raise ValueError("--mode needs --drag (where the mode's η comes from); give --eta "
                             "instead")
        dr = {"k": float(k), "k_q": float(k_q or 0.0), "cov": None, "w": 0.0, "eta": (1.0, 1.0),
              "source": "command line", "key": None}
    if eta is not None:
        ev = [float(x) for x in (eta.split(",") if isinstance(eta, str) else np.atleast_1d(eta))]
        if len(ev) == 1:
            ev = ev * 2
        if len(ev) != 2 or not all(math.isfinite(x) and x > 0 for x in ev):
            raise ValueError(f"--eta: expected η or η₊,η₋ (positive), got {eta!r}")
        dr["eta"] = (ev[0], ev[1])
    if dr["k"] < 0 or dr["k_q"] < 0:
        raise ValueError(f"the drag from {dr['source']} is negative (k = {dr['k']:.4g}, k_q = "
                         f"{dr['k_q']:.4g}): implausible, drag must be >= 0 — the steady log's "
                         "command and motion have opposite signs; fix the sign of its position/"
                         "heading or command channel and identify the drag again")
    if dr["k"] <= 0 and dr["k_q"] <= 0:
        raise ValueError(f"the drag from {dr['source']} is zero (k = {dr['k']}, k_q = "
                         f"{dr['k_q']})")
    return dr


#: a drag force this many times the largest command over most of a record is not this vehicle's
DRAG_DOMINANCE = 100.0


def drag_dominance_warnings(fit, data: LogData, drag: dict, dof: str) -> list[str]:
    """The drag given, k·|ξ̇| + k_q·ξ̇², on the record's own velocities, exceeding the largest
    |η·command| by :data:`DRAG_DOMINANCE` or more (90th percentile): the drag cannot be this
    vehicle's (another DOF's, another unit, a typo) and the inertia only scales with it — said
    instead of the "opposite signs" diagnosis a bad fit gets otherwise."""
    v = np.asarray(fit.velocity, float)
    v = np.abs(v[np.isfinite(v)])
    c = np.asarray(data.command, float)
    c = c[np.isfinite(c)]
    if not v.size or not c.size:
        return []
    u = float(np.max(np.abs(c))) * max(1.0, *drag["eta"])
    f = float(np.percentile(drag["k"] * v + drag["k_q"] * v * v, 90))
    if u <= 0 or f < DRAG_DOMINANCE * u:
        return []
    unit = "N·m" if dof in ANGULAR else "N"
    return [f"implausible drag for this record: k = {drag['k']:.4g}, k_q = {drag['k_q']:.4g} "
            f"(from {drag['source']}) give a drag force of {f:.3g} {unit} or more 10 % of the "
            f"time at the record's velocities, {f / u:.3g}× the largest command ({u:.3g} {unit}): "
            "a drag that dominates the command by orders of magnitude is not this vehicle's "
            "(another DOF's or unit's drag, a typo) — the inertia only scales with it; check "
            "--drag / --k / --kq"]


def identify_inertia(log, dof: str | None = None, *, drag=None, k: float | None = None,
                     k_q: float | None = None, eta=None, mode: str | None = None,
                     one_dof: str | None = None, window: int | None = None, order: int = 4,
                     cov_type: str = "HAC", hac_lags: int | None = None,
                     omega: float | None = None, clean: bool = True, eiv: bool = False,
                     max_filled: int = 2, resample="auto", validation_log=None,
                     **read) -> InertiaIdentification:
    """Inertia of one DOF from a sine experiment by the integrated regression (Caccia et al.
    2000, eqs. 15–19): m ξ(t) − m ξ₀ − b t = Φ(t) − k x(t) − k_q ∫ξ|ξ|dt.

    ``drag``: a :class:`SteadyIdentification`, the JSON of ``identify steady --json`` or a
    vehicle file/preset (its ``one_dof`` model); or ``k`` (and ``k_q``).  ``resample``: see
    :func:`uniform_position` (``"auto"`` puts a jittery position record on a uniform grid, with
    a note).  ``t_start``/``t_end`` (in ``read``) bound the regression; the whole record feeds
    the velocity filter.  ``validation_log``: another log read the same way, on which the
    identified model's velocity NRMSE is reported."""
    t_start, t_end = read.pop("t_start", None), read.pop("t_end", None)
    if isinstance(log, LogSpec):
        t_start = log.t_start if t_start is None else t_start
        t_end = log.t_end if t_end is None else t_end
        log = replace(log, t_start=None, t_end=None)
    time_window(t_start, t_end)
    if omega is not None and not (math.isfinite(omega) and omega > 0):
        raise ValueError(f"--omega must be > 0 rad/s, got {omega}")
    d0 = dof or (log.dof if isinstance(log, LogSpec) else None)
    if d0 is None and not isinstance(log, LogData):
        raise ValueError("give dof= (the degree of freedom the log excites)")
    dr = _drag(drag, d0 or dof, k, k_q, eta, mode, one_dof) if d0 else None
    data, dof, name = _as_data(log, dof, read)
    if dr is None:
        dr = _drag(drag, dof, k, k_q, eta, mode, one_dof)
    tg, xg, note = uniform_position(data.t_pos, data.position, resample=resample,
                                    angle=dof in ANGULAR)
    notes = list(data.notes)
    if note:
        notes.append(note)
        data = replace(data, t_pos=tg, position=xg,
                       info={**data.info, "resampled": note, "position_samples": int(tg.size)})
    opt = InertiaOptions(window, order, cov_type, hac_lags, omega, t_start, t_end, clean, eiv,
                         max_filled)
    try:
        res = run_inertia(data, dof, dr, opt)
    except np.linalg.LinAlgError as e:
        raise ValueError(f"the regression is singular: {e}") from None
    res["notes"] = notes + res["notes"]
    doc = inertia_document(res, dof, name, dr, data)
    dominant = drag_dominance_warnings(res["fit"], data, dr, dof)
    doc["warnings"] = data.warnings + list(dr.get("warnings") or []) + dominant
    if not dominant:  # else their "opposite signs" diagnosis is wrong: the drag is
        doc["warnings"] += (inertia_warnings(res["fit"].mass, res["fit"].mass_stderr, dof,
                                             doc["mass"]["unit"])
                            + fit_quality_warnings(res.get("fit_nrmse"), dof))
    validation = None
    if validation_log is not None:
        if res["model"] is None:
            raise ValueError("--validation-log: the identified model cannot be simulated "
                             "(non-positive inertia or drag)")
        vspec = (replace(log, path=Path(validation_log)) if isinstance(log, LogSpec)
                 else LogSpec(Path(validation_log), dof, **read))
        vdata = read_vehicle_log(vspec)
        tv, xv, _ = uniform_position(vdata.t_pos, vdata.position, resample=resample,
                                     angle=dof in ANGULAR)
        vdata = replace(vdata, t_pos=tv, position=xv)
        try:
            validation = _validate_log(res["model"], vdata, dof, res["window"])
        except ValueError as e:
            raise ValueError(f"--validation-log {validation_log}: {e}") from None
        doc["validation"] = {"log": str(validation_log), "nrmse": validation["nrmse"],
                             "rmse": validation["rmse"], "cleaning": validation["cleaning"]}
    return InertiaIdentification(dof, name, data, dr, res, doc, validation)
