"""Write identified 1-DOF parameters back into a vehicle definition file.

:func:`write_identified` takes a vehicle file (YAML/TOML) or a preset name and the parameters
identified per DOF (Caccia et al. 2000: drag, installation coefficients per thrust-mapping mode,
inertia) and writes a **new** vehicle YAML that :func:`uuvid.vehicle.definition.load_vehicle`
loads and ``uuvid simulate`` flies:

* ``hydrodynamics.linear_damping`` / ``quadratic_damping``: the diagonal entry of the DOF
  (6-value or 36-value form alike) ← ``linear`` / ``quadratic``;
* ``hydrodynamics.added_mass``: the diagonal entry ← ``mass − M_RB[i, i]`` (the identified total
  inertia along the DOF minus the rigid-body one about the origin).  A negative added mass is
  refused (:class:`WritebackError`): the identified inertia is below the rigid body's, which means
  the rigid-body numbers or the identification are wrong — the file is not written;
* ``modes.<mode>.eta_dof``: the DOF-level installation coefficients identified per mode
  (``yaw`` for both signs, ``yaw+``/``yaw-`` per sign) for modes the vehicle defines; the
  per-thruster ``installation`` coefficients (which the 6-DOF simulator applies) are left as they
  were — mapping DOF-level coefficients to thrusters is not unique;
* ``rigid_body.buoyancy`` ← ``W − disturbance`` for heave (the identified net weight, the
  weight kept), so the 6-DOF model sinks or floats as the dive did;
* ``one_dof.<key>``: the eq. 3 model (``mass``, ``linear``, ``quadratic``, ``eta_pos``,
  ``eta_neg``, ``disturbance``, ``mode``), created or updated; ``inflow_coefficient`` (``k_a`` of
  the linear inflow form, identified from a dive: :func:`uuvid.identify.vehicle.dive.identify_dive`)
  goes only there — the dive replay reads it; ``hydrodynamics`` then holds the hull's drag
  without the thrust loss;
* ``source.identified`` (a list of records: what was identified, from which log, when, with σ)
  when the schema has that key, else a sentence appended to ``source.notes``.

The new vehicle is named after its file (``mine.yaml`` → ``mine``; the base's name with
``-identified`` if the file has the base's name), so that replays and simulations do not call it
the base vehicle.  Relative thruster-model paths are rewritten relative to the new file
(absolute for a preset's thruster files, which live in the installed package) so the new file
finds them.
Comments of the original file are not kept (the file is re-serialised).  The result is validated
with the vehicle schema *before* anything is written; the write is atomic.
"""

from __future__ import annotations

import copy
import datetime as _dt
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from uuvid.core.atomic import atomic_write_text
from uuvid.thruster.modelfile import ModelFileError, read_model_text
from uuvid.vehicle.definition import (
    PRESET_DIR,
    VehicleFileError,
    list_presets,
    load_vehicle,
    preset_path,
    vehicle_from_dict,
)
from uuvid.vehicle.layout import dof_index
from uuvid.vehicle.model import DOF_NAMES

__all__ = ["WritebackError", "write_identified", "identified_yaml"]

#: keys accepted per DOF in ``identified``
KEYS = {"linear", "quadratic", "mass", "inertia", "eta", "disturbance", "mode", "key", "sigma",
        "log", "method", "notes", "inflow_coefficient"}


class WritebackError(ValueError):
    """The identified parameters cannot be written into the vehicle file (message says why)."""


def _source_path(vehicle) -> Path:
    p = Path(vehicle)
    if p.is_file():
        return p
    if isinstance(vehicle, str) and vehicle in list_presets():
        return preset_path(vehicle)
    raise WritebackError(f"{vehicle}: no such vehicle file and not a preset (presets: "
                         f"{', '.join(list_presets())})")


def _num(dof: str, name: str, v, *, positive: bool = False, nonneg: bool = False) -> float:
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise WritebackError(f"identified {dof}.{name}: expected a number, got {v!r}") from None
    if not math.isfinite(x):
        raise WritebackError(f"identified {dof}.{name}: not finite ({v!r})")
    if positive and x <= 0:
        raise WritebackError(f"identified {dof}.{name} = {x:.6g} must be > 0")
    if nonneg and x < 0:
        raise WritebackError(f"identified {dof}.{name} = {x:.6g} is negative: drag coefficients are "
                             "positive magnitudes; a negative estimate means the model or the data "
                             "are wrong (refit, e.g. without the insignificant term)")
    return x


def _etas(dof: str, eta) -> dict[str, tuple[float | None, float | None]]:
    """``{mode: value | [pos, neg] | {"+"/"pos": v, "-"/"neg": v}}`` → ``{mode: (pos, neg)}``."""
    if eta is None:
        return {}
    if not isinstance(eta, Mapping):
        raise WritebackError(f"identified {dof}.eta: expected {{mode: value}}, got {eta!r}")
    out: dict[str, tuple[float | None, float | None]] = {}
    for mode, v in eta.items():
        where = f"eta.{mode}"
        if isinstance(v, Mapping):
            unknown = set(v) - {"+", "-", "pos", "neg"}
            if unknown:
                raise WritebackError(f"identified {dof}.{where}: unknown keys {sorted(unknown)} "
                                     "(use '+'/'-' or pos/neg)")
            p = v.get("+", v.get("pos"))
            n = v.get("-", v.get("neg"))
        elif isinstance(v, (list, tuple)):
            if len(v) != 2:
                raise WritebackError(f"identified {dof}.{where}: expected [eta_pos, eta_neg]")
            p, n = v
        else:
            p = n = v
        out[str(mode)] = (None if p is None else _num(dof, where, p, positive=True),
                          None if n is None else _num(dof, where, n, positive=True))
    return out


def _diag_index(values: list, i: int, where: str) -> int:
    if len(values) == 6:
        return i
    if len(values) == 36:
        return 7 * i
    raise WritebackError(f"{where}: expected 6 or 36 values, got {len(values)}")


def _fmt(x: float) -> float:
    """A float rounded to 6 significant digits for a readable file (σ is far larger)."""
    return float(f"{x:.6g}")


def _describe(dof: str, d: Mapping, etas: Mapping, added: float | None) -> str:
    parts = []
    sig = d.get("sigma") or {}

    def pm(name, key):
        s = sig.get(key) if isinstance(sig, Mapping) else None
        v = d.get(key)
        if key == "mass" and v is None:
            v = d.get("inertia")
        if v is None:
            return None
        return f"{name} {float(v):.4g}" + (f" ± {float(s):.2g}" if s is not None and
                                           math.isfinite(float(s)) else "")

    for name, key in (("linear damping", "linear"), ("quadratic damping", "quadratic"),
                      ("inertia" if dof in ("roll", "pitch", "yaw") else "mass", "mass"),
                      ("disturbance", "disturbance"),
                      ("inflow coefficient", "inflow_coefficient")):
        s = pm(name, key)
        if s:
            parts.append(s)
    if added is not None:
        parts.append(f"added {'inertia' if dof in ('roll', 'pitch', 'yaw') else 'mass'} "
                     f"{added:.4g}")
    for mode, (p, n) in etas.items():
        if p is not None and n is not None and p == n:
            parts.append(f"η[{mode}] {p:.3g}")
        else:
            parts.append(f"η[{mode}] " + ", ".join(f"{s} {v:.3g}" for s, v in (("+", p), ("−", n))
                                                   if v is not None))
    return f"{dof}: " + "; ".join(parts)


def identified_yaml(vehicle_file_or_preset, identified: Mapping[str, Mapping[str, Any]], *,
                    out_dir: str | Path | None = None, log: str | None = None,
                    command: str | None = None, when: str | None = None) -> tuple[dict, list[str]]:
    """The new vehicle description (a dict ready for YAML) and notes on what was written.

    See :func:`write_identified`; ``out_dir`` is where the file will live (for relative thruster
    model paths).  Raises :class:`WritebackError`.
    """
    src = _source_path(vehicle_file_or_preset)
    try:
        base = load_vehicle(src)
        raw = copy.deepcopy(read_model_text(src))
    except (ModelFileError, FileNotFoundError, KeyError) as e:
        raise WritebackError(str(e)) from None
    if not isinstance(identified, Mapping) or not identified:
        raise WritebackError("nothing identified to write (identified is empty)")
    when = when or _dt.datetime.now(_dt.UTC).replace(microsecond=0).isoformat().replace("+00:00",
                                                                                          "Z")
    hyd = raw.setdefault("hydrodynamics", {})
    for k in ("added_mass", "linear_damping", "quadratic_damping"):
        hyd[k] = [float(v) for v in hyd[k]]
    M_RB = base.params.M_RB
    modes_raw = raw.get("modes") or {}
    one_dof = raw.get("one_dof") or {}
    raw["one_dof"] = one_dof
    notes: list[str] = []
    records: list[dict] = []
    for dof, d in identified.items():
        try:
            i = dof_index(dof)
        except ValueError as e:
            raise WritebackError(f"identified: {e}") from None
        dof = DOF_NAMES[i]
        if not isinstance(d, Mapping):
            raise WritebackError(f"identified {dof}: expected a mapping of parameters")
        unknown = sorted(set(d) - KEYS)
        if unknown:
            raise WritebackError(f"identified {dof}: unknown keys {unknown}; known: {sorted(KEYS)}")
        if d.get("mass") is not None and d.get("inertia") is not None:
            raise WritebackError(f"identified {dof}: give mass or inertia, not both")
        lin = d.get("linear")
        quad = d.get("quadratic")
        lin = None if lin is None else _num(dof, "linear", lin, nonneg=True)
        quad = None if quad is None else _num(dof, "quadratic", quad, nonneg=True)
        mass = d.get("mass", d.get("inertia"))
        mass = None if mass is None else _num(dof, "mass", mass, positive=True)
        dist = d.get("disturbance")
        dist = None if dist is None else _num(dof, "disturbance", dist)
        ka = d.get("inflow_coefficient")
        ka = None if ka is None else _num(dof, "inflow_coefficient", ka, nonneg=True)
        etas = _etas(dof, d.get("eta"))
        # ---------------------------------------------------------------- hydrodynamics
        for key, v in (("linear_damping", lin), ("quadratic_damping", quad)):
            if v is not None:
                hyd[key][_diag_index(hyd[key], i, f"hydrodynamics.{key}")] = _fmt(v)
        added = None
        if mass is not None:
            rigid = float(M_RB[i, i])
            added = mass - rigid
            if added < 0:
                what = "inertia" if i >= 3 else "mass"
                raise WritebackError(
                    f"identified {dof} {what} {mass:.6g} is below the rigid-body {what} "
                    f"{rigid:.6g} of {src.name} (rigid_body{'.inertia' if i >= 3 else '.mass'}): the "
                    f"added {what} would be {added:.4g} < 0.  Check the rigid-body numbers or the "
                    "identification (σ, window, drag); nothing was written")
            j = _diag_index(hyd["added_mass"], i, "hydrodynamics.added_mass")
            hyd["added_mass"][j] = _fmt(added)
        # ---------------------------------------------------------------- modes' DOF-level η
        not_vehicle_modes = []
        for mode, (p, n) in etas.items():
            if mode not in modes_raw:
                not_vehicle_modes.append(mode)
                continue
            ms = modes_raw[mode]
            if ms is None:
                ms = modes_raw[mode] = {}
            ed = dict(ms.get("eta_dof") or {})
            if dof in ed:  # split a both-signs entry before overwriting one sign
                both = ed.pop(dof)
                ed.setdefault(f"{dof}+", both)
                ed.setdefault(f"{dof}-", both)
            if p is not None:
                ed[f"{dof}+"] = _fmt(p)
            if n is not None:
                ed[f"{dof}-"] = _fmt(n)
            if f"{dof}+" in ed and f"{dof}-" in ed and ed[f"{dof}+"] == ed[f"{dof}-"]:
                ed[dof] = ed.pop(f"{dof}+")
                ed.pop(f"{dof}-")
            ms["eta_dof"] = ed
        if not_vehicle_modes:
            notes.append(f"{dof}: modes {not_vehicle_modes} are not thrust-mapping modes of "
                         f"{base.name} (have {sorted(modes_raw)}): their η are only in the "
                         "source.identified record")
        # ---------------------------------------------------------------- one_dof
        key = str(d.get("key") or dof)
        entry = dict(one_dof.get(key) or {})
        if entry and entry.get("dof") not in (None, dof):
            raise WritebackError(f"one_dof.{key} of {src.name} is a {entry.get('dof')} model; "
                                 f"choose another key for the identified {dof} model")
        entry["dof"] = dof
        DL, DQ = base.params.linear_damping, base.params.quadratic_damping
        if lin is not None:
            entry["linear"] = _fmt(lin)
        elif quad is not None and "linear" not in entry:
            entry["linear"] = 0.0
        else:
            entry.setdefault("linear", _fmt(float(DL[i, i])))
        if quad is not None:
            entry["quadratic"] = _fmt(quad)
        elif lin is not None and "quadratic" not in entry:
            entry["quadratic"] = 0.0
        else:
            entry.setdefault("quadratic", _fmt(float(DQ[i, i])))
        if mass is not None:
            entry["mass"] = _fmt(mass)
        elif "mass" not in entry:
            MA = np.asarray(base.params.added_mass)
            entry["mass"] = _fmt(float(M_RB[i, i] + (added if added is not None else MA[i, i])))
        mode = d.get("mode")
        if mode is not None:
            mode = str(mode)
            if mode in modes_raw:
                entry["mode"] = mode
            else:
                entry.pop("mode", None)
            p, n = etas.get(mode, (None, None))
            entry["eta_pos"] = _fmt(p) if p is not None else 1.0
            entry["eta_neg"] = _fmt(n) if n is not None else 1.0
        if dist is not None:
            entry["disturbance"] = _fmt(dist)
            if i == 2:  # heave: the net weight W − B, which the 6-DOF model takes from rigid_body
                rb = raw.setdefault("rigid_body", {})
                w_n = float(base.params.weight)
                b_old, b_new = float(base.params.buoyancy), w_n - dist
                if b_new <= 0:
                    raise WritebackError(
                        f"identified heave disturbance (net weight W − B) {dist:.6g} N is not "
                        f"below the weight {w_n:.6g} N of {src.name}: the buoyancy would be "
                        f"{b_new:.4g} N; nothing was written")
                rb.pop("displaced_volume", None)
                rb.pop("water_density", None)
                rb["buoyancy"] = _fmt(b_new)
                notes.append(f"heave: rigid_body.buoyancy {b_old:.5g} → {b_new:.5g} N (the "
                             f"identified net weight W − B = {dist:+.4g} N with the weight "
                             f"{w_n:.5g} N kept), so the 6-DOF model sinks or floats as the dive did")
        if ka is not None:
            entry["inflow_coefficient"] = _fmt(ka)
        desc = _describe(dof, d, etas, added)
        src_txt = f" from {d.get('log') or log}" if (d.get("log") or log) else ""
        entry["notes"] = (f"identified by uuvid{' (' + str(d['method']) + ')' if d.get('method') else ''}"
                          f"{src_txt} on {when}" + (f"; {d['notes']}" if d.get("notes") else ""))
        one_dof[key] = entry
        rec = {"dof": dof, "when": when, "log": d.get("log") or log, "method": d.get("method"),
               "command": command, "one_dof_key": key, "summary": desc}
        rec["values"] = {k: v for k, v in (("linear", lin), ("quadratic", quad), ("mass", mass),
                                            ("added_mass", added), ("disturbance", dist),
                                            ("inflow_coefficient", ka))
                         if v is not None}
        if etas:
            rec["eta"] = {m: {"pos": p, "neg": n} for m, (p, n) in etas.items()}
        if d.get("sigma"):
            rec["sigma"] = {k: float(v) for k, v in dict(d["sigma"]).items()
                            if v is not None and math.isfinite(float(v))}
        records.append({k: v for k, v in rec.items() if v is not None})
        notes.append(desc)
    # ---------------------------------------------------------------- provenance
    source = dict(raw.get("source") or {})
    sentence = ("Identified by uuvid on " + when + (f" from {log}" if log else "") + ": "
                + "; ".join(r["summary"] for r in records) + ".")
    from uuvid.vehicle.schema import SourceSchema

    if "identified" in SourceSchema.model_fields:
        prev = source.get("identified")
        prev = list(prev) if isinstance(prev, list) else ([prev] if prev else [])
        source["identified"] = prev + records
    else:
        source["notes"] = ((str(source["notes"]).rstrip() + "\n\n") if source.get("notes")
                           else "") + sentence
    raw["source"] = source
    # ---------------------------------------------------------------- thruster model paths
    from uuvid.thruster.resolve import is_preset

    target_dir = Path(out_dir).resolve() if out_dir is not None else Path.cwd()
    for t in raw.get("thrusters") or []:
        ref = t.get("model")
        if not isinstance(ref, str) or is_preset(ref) or Path(ref).is_absolute():
            continue
        p = (src.parent / ref).resolve()
        if p.is_file():
            if src.resolve().parent == PRESET_DIR.resolve():
                t["model"] = str(p)  # a preset's thruster file lives in the installed package
                continue
            try:
                t["model"] = os.path.relpath(p, target_dir)
            except ValueError:  # another drive (Windows)
                t["model"] = str(p)
    return raw, notes


def write_identified(vehicle_file_or_preset, identified: Mapping[str, Mapping[str, Any]],
                     out_path: str | Path, *, log: str | None = None, command: str | None = None,
                     when: str | None = None) -> Path:
    """Write ``vehicle_file_or_preset`` with the ``identified`` parameters to ``out_path`` (YAML).

    ``identified`` — per DOF (``"yaw"``, ``"surge"``, …)::

        {"yaw": {"linear": 28.6, "quadratic": 0.0,          # N·m·s/rad, N·m·s²/rad²
                 "mass": 84.0,                             # total inertia (or "inertia")
                 "eta": {"yaw_fl_rr": {"+": 1.0, "-": 0.68}, "horizontal_all": 0.62},
                 "mode": "yaw_fl_rr",                      # the one_dof model's mode
                 "disturbance": 0.0, "key": "yaw",         # one_dof entry (default: the DOF)
                 "sigma": {"linear": 1.3, ...}, "log": "pool.csv", "method": "steady"}}

    Every key is optional; what is given is written (see the module docstring).  Raises
    :class:`WritebackError` (a ``ValueError``) with a clear message — including for a negative
    added mass — and writes nothing then.  Returns the path written.
    """
    out = Path(out_path)
    if out.suffix.lower() not in (".yaml", ".yml"):
        raise WritebackError(f"{out}: the new vehicle file must end in .yaml or .yml")
    try:
        src = _source_path(vehicle_file_or_preset)
        if out.resolve() == src.resolve() or out.resolve().parent == PRESET_DIR.resolve():
            raise WritebackError(f"{out}: refusing to overwrite the source vehicle file or a preset; "
                                 "write a new file")
    except OSError as e:
        raise WritebackError(f"{out}: {e}") from None
    raw, _ = identified_yaml(vehicle_file_or_preset, identified, out_dir=out.resolve().parent,
                             log=log, command=command, when=when)
    # the new vehicle is named after its file: replays and simulations flying it no longer say
    # the base's name (a written bluerov2 looked like the preset); the base is in source
    base_name = str(raw.get("name") or src.stem)
    raw = {"name": out.stem if out.stem != base_name else f"{base_name}-identified",
           **{k: v for k, v in raw.items() if k != "name"}}
    try:
        vehicle_from_dict(raw, where=str(out), base_dir=out.resolve().parent, path=out.resolve())
    except VehicleFileError as e:
        raise WritebackError(f"the identified vehicle would be invalid: {e}") from None
    header = (f"# {raw.get('name', 'vehicle')}: written by uuvid from {src.name} with identified "
              "parameters (see source).\n# SI units; NED/FRD body axes; positive damping and "
              "added-mass magnitudes.\n")
    text = header + yaml.safe_dump(raw, sort_keys=False, allow_unicode=True, width=100)
    try:
        atomic_write_text(out, text)
    except OSError as e:
        raise WritebackError(f"{out}: cannot write the vehicle file ({e.strerror or e})") from None
    return out
