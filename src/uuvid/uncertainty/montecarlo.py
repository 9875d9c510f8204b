"""Monte Carlo propagation of an identified model's covariance through the simulators.

**Model file** (``uuvid montecarlo MODEL.yaml``; format ``uuvid-uncertain-model/1``)::

    format: uuvid-uncertain-model/1
    name: bluerov2-identified
    kind: vehicle                  # vehicle | thruster_physical | thruster_chain
    base: {vehicle: bluerov2}      # thruster_physical: {physical_model: {...}};
                                   # thruster_chain: {chain: auv2-tunnel, preset_kwargs: {}}
    parameters:                    # names as in uuvid.uncertainty.params / targets
      - {name: added_mass[surge], estimate: 5.4, unit: kg, lower: 0}
      - {name: linear_damping[surge], estimate: 4.1, unit: N s/m, lower: 0}
    covariance: [[...], [...]]     # p × p, same order (or a sigma per parameter: independent)
    target: {...}                  # optional: what to simulate (default per kind, see below)
    requirement: {metric: max_tracking_error_m, below: 0.5}
    residual_sigma: 0.41           # optional: σ of one observation about the model (series unit)
    provenance: {...}              # how the numbers were obtained

A parameter's ``unit`` is that of its estimate, ``sigma``, bounds and covariance row: values in a
unit the parameter converts from (``g`` for a mass, ``cm/s`` for a current speed; the units of
sweep files, :data:`uuvid.uncertainty.params.UNITS_OF`) are converted to its SI unit when the model
is read, a unit that is not one of the parameter's is refused, and a parameter uuvid knows no unit
for keeps a ``unit`` it cannot convert as a label (one it can, ``%`` or ``deg``, becomes a fraction
or radians); reading a model written back reads the same numbers.  An estimate outside its own
``lower``/``upper`` is refused then too, before anything is drawn.

Also read: the ``summary.json`` of ``uuvid thruster fit --model physical`` (σ per parameter, and
the covariance if the file carries one; without it the parameters are taken as independent — a
warning says so) and a :meth:`uuvid.identify.fit.Fit.as_dict` document with a ``base``.

Built-in models: ``bluerov2-identified`` (drag and added mass of a simulated BlueROV2 identified
with the LS tools from synthetic pool experiments, :mod:`uuvid.uncertainty.identified`) and
``t200-physical`` (the physical model fitted to Blue Robotics' T200 sheets at 12 V and 16 V).

**Draws.**  Run ``r`` draws ``θ = θ̂ + A z``, ``z ~ N(0, I)`` from ``numpy.random.default_rng([seed,
r])`` with ``A Aᵀ = Σ`` (symmetric square root by eigendecomposition, so nearly singular
covariances — the T200 fit's K_e/K_Q correlation of 0.9999 — are fine).  Bounds (``lower``,
``upper``; physical ones such as η ≤ 1, m > 0, damping ≥ 0) are respected by one of:

``reject`` (default)
    redraw from the same run's stream until the draw is inside the bounds — exact sampling of the
    normal truncated to the box — at most ``max_draws`` times; a run that never gets an
    admissible draw is kept in the table with status ``rejected`` (never simulated, never
    silently dropped).  The table has ``draws`` (attempts) per run and the summary counts the
    rejected draws per parameter.
``truncate``
    one draw, clipped onto the bounds (``clipped`` names the parameters that were moved); this
    puts probability mass *on* the bound, which the model may or may not accept (a mass of
    exactly 0 is then an ``invalid`` run).
``ignore``
    no bounds; the model's own validation marks impossible runs ``invalid``.

**Results.**  The tidy table (one row per run: drawn parameters, metrics, status), prediction
bands of every per-run series (median and the central ``band`` interval, default 95 %, pointwise
over successful runs: the *confidence* band of the model; with ``residual_sigma`` also the
*prediction* band of a new measurement, each curve plus N(0, σ²) noise drawn from the seed),
quantiles of every metric, and the probability that the requirement holds
with a Wilson 95 % interval — over the simulated runs, and counting runs that could not be
simulated as failures.
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from uuvid.core.yamltypes import Num, Whole
from uuvid.uncertainty.sweep import Requirement, probability_summary, wilson  # noqa: F401
from uuvid.uncertainty.targets import (
    REJECTED,
    StudyBase,
    Target,
    ThrusterSteadyTarget,
    ThrusterStepTarget,
    VehicleMissionTarget,
    VelocityResponse,
    resolve_paths,
)

_CFG = ConfigDict(extra="forbid", allow_inf_nan=False)
MODEL_FORMAT = "uuvid-uncertain-model/1"
DATA = Path(__file__).resolve().parent / "data"
#: Where each built-in model file lives: the thruster model with the thruster models.
BUILTIN_FILES = {"bluerov2-identified": DATA / "bluerov2-identified.yaml",
                 "t200-physical": Path(__file__).resolve().parents[1] / "thruster" / "data"
                 / "t200-physical.yaml"}
BUILTIN_MODELS = ("bluerov2-identified", "t200-physical")


class ModelError(ValueError):
    """An invalid uncertain-model file; the message names the file and the key."""


#: the largest σ a parameter may carry: its square (the variance) stays far from overflow
MAX_SIGMA = 1e150


def _spelling(unit: str) -> str:
    return "".join(c for c in unit if c not in " ·*⋅.")


def parameter_unit(name: str, unit: str, where: str) -> tuple[float, str]:
    """``(factor, SI unit)`` of a parameter's ``unit``: values × factor are in the unit the model
    takes.  ``""``, the parameter's SI unit (``N s/m`` = ``N·s/m``) or a unit it converts from
    (:data:`uuvid.uncertainty.params.UNITS_OF`: ``g`` for kg, ``cm/s`` for m/s) are taken;
    another unit of a parameter whose SI unit is known is a ``ValueError`` naming ``where``.  A
    parameter whose dimension uuvid does not know keeps a ``unit`` it cannot convert (a thruster
    fit's ``V·s/rad``) as a label; one of :data:`~uuvid.uncertainty.params.UNITS` is converted to
    its dimension's SI unit (``%`` to a fraction, ``deg`` to rad): :func:`_unit_reached`."""
    from uuvid.uncertainty import params as PR

    si = PR.si_unit(name)
    if not unit or unit == "si" or (si and _spelling(unit) == _spelling(si)):
        return 1.0, si if unit == "si" else unit
    ok = PR.units_for(name)
    if si and (ok is None or unit not in ok):
        takes = f"{si}" + (f" (or {', '.join(u for u in ok if u != si)})" if ok and len(ok) > 1 else "")
        raise ValueError(f"{where}: unit {unit!r} is not a unit of {name}, which is in {si}; give "
                         f"the values in {takes}")
    if unit not in PR.UNITS:
        return 1.0, unit  # a label: its dimension is unknown to uuvid
    try:
        f = PR.unit_factor(name, unit)
    except ValueError as e:  # pragma: no cover - the checks above cover the known dimensions
        raise ValueError(f"{where}: {e}") from None
    return f, si or _unit_reached(unit, f)


def _unit_reached(unit: str, factor: float) -> str:
    """The unit values in ``unit`` are in once multiplied by its factor (:data:`UNITS`): the SI
    unit of its dimension (``deg`` → ``rad``, ``%`` → a fraction ``""``, ``ft/rad`` →
    ``m/rad``), so that converting the converted values again changes nothing."""
    from uuvid.uncertainty import params as PR

    if factor == 1.0:
        return unit
    dim = next((d for d, us in PR.UNITS_OF.items() if unit in us), None)
    if dim == "°":
        return "rad"
    if dim is not None:
        return dim
    return {"%": "", "ft/rad": "m/rad"}.get(unit, unit)


class UncertainParameter(BaseModel):
    model_config = _CFG
    name: str
    estimate: Num
    sigma: Num | None = Field(None, ge=0)
    unit: str = ""
    lower: Num | None = None
    upper: Num | None = None

    @model_validator(mode="after")
    def _bounds(self):
        if self.lower is not None and self.upper is not None and not self.lower < self.upper:
            raise ValueError(f"{self.name}: lower must be < upper")
        if self.sigma is not None and not (math.isfinite(self.sigma) and self.sigma <= MAX_SIGMA):
            raise ValueError(f"{self.name}: sigma {self.sigma:g} is beyond {MAX_SIGMA:g} (its "
                             "variance overflows): no distribution to draw from")
        return self

    @property
    def outside_bounds(self) -> bool:
        """The estimate itself lies outside ``[lower, upper]`` (draws around it mostly fail)."""
        return (self.lower is not None and self.estimate < self.lower
                or self.upper is not None and self.estimate > self.upper)


class UncertainModel(BaseModel):
    """An identified model: estimates, covariance and bounds (see the module docstring)."""

    model_config = _CFG
    format: Literal["uuvid-uncertain-model/1"] = MODEL_FORMAT
    name: str
    kind: Literal["vehicle", "thruster_physical", "thruster_chain"]
    description: str = ""
    base: dict[str, Any] = Field(default_factory=dict)
    parameters: list[UncertainParameter] = Field(min_length=1)
    covariance: list[list[Num]] | None = None
    target: Target | None = None
    requirement: Requirement | None = None
    residual_sigma: Num | None = Field(None, ge=0)
    provenance: dict[str, Any] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _units_and_bounds(self):
        """Values in another unit than the parameter's SI unit converted to it (estimate, σ,
        bounds, covariance; as sweep files, :func:`uuvid.uncertainty.params.unit_factor`); an
        estimate outside its own bounds refused before anything is drawn."""
        factors = []
        for i, q in enumerate(self.parameters):
            f, si = parameter_unit(q.name, q.unit, f"parameters[{i}] ({q.name})")
            factors.append(f)
            if f != 1.0 or si != q.unit:
                self.parameters[i] = q.model_copy(update={
                    "estimate": q.estimate * f, "sigma": None if q.sigma is None else q.sigma * f,
                    "lower": None if q.lower is None else q.lower * f,
                    "upper": None if q.upper is None else q.upper * f, "unit": si})
        if self.covariance is not None and any(f != 1.0 for f in factors):
            f = np.asarray(factors)
            C = np.asarray(self.covariance, dtype=float)
            if C.shape == (f.size, f.size):
                self.covariance = (C * np.outer(f, f)).tolist()
        for i, q in enumerate(self.parameters):
            if q.outside_bounds:
                lo = "-inf" if q.lower is None else f"{q.lower:g}"
                hi = "inf" if q.upper is None else f"{q.upper:g}"
                raise ValueError(f"parameters[{i}] ({q.name}): estimate {q.estimate:g} is outside "
                                 f"its bounds [{lo}, {hi}]{' ' + q.unit if q.unit else ''}: draws "
                                 "around it would be rejected or piled on the bound; correct the "
                                 "estimate or the bound (lower, upper)")
        return self

    @model_validator(mode="after")
    def _cov(self):
        p = len(self.parameters)
        names = [q.name for q in self.parameters]
        if len(set(names)) != p:
            raise ValueError("parameters: a name appears twice")
        if self.covariance is None:
            missing = [q.name for q in self.parameters if q.sigma is None]
            if missing:
                raise ValueError(f"no covariance and no sigma for {', '.join(missing)}")
            return self
        C = np.asarray(self.covariance, dtype=float)
        if C.shape != (p, p):
            raise ValueError(f"covariance must be {p}×{p} (one row per parameter), got {C.shape}")
        if not np.all(np.isfinite(C)):
            raise ValueError("covariance has non-finite entries")
        if not np.allclose(C, C.T, rtol=1e-8, atol=1e-14 * max(1.0, float(np.abs(C).max()))):
            raise ValueError("covariance must be symmetric")
        ev = np.linalg.eigvalsh(0.5 * (C + C.T))
        if ev.min() < -1e-8 * max(ev.max(), 1e-300):
            raise ValueError(f"covariance is not positive semi-definite (eigenvalue {ev.min():.3g})")
        for i, q in enumerate(self.parameters):
            if q.sigma is not None and not math.isclose(q.sigma, math.sqrt(max(C[i, i], 0)),
                                                        rel_tol=1e-3, abs_tol=1e-300):
                raise ValueError(f"{q.name}: sigma {q.sigma:g} disagrees with the covariance "
                                 f"diagonal ({math.sqrt(max(C[i, i], 0)):g})")
        return self

    @property
    def names(self) -> list[str]:
        return [q.name for q in self.parameters]

    @property
    def mean(self) -> np.ndarray:
        return np.array([q.estimate for q in self.parameters])

    @property
    def cov(self) -> np.ndarray:
        if self.covariance is not None:
            C = np.asarray(self.covariance, dtype=float)
            return 0.5 * (C + C.T)
        return np.diag([q.sigma**2 for q in self.parameters])

    @property
    def sigma(self) -> np.ndarray:
        return np.sqrt(np.clip(np.diag(self.cov), 0, None))

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo = np.array([-np.inf if q.lower is None else q.lower for q in self.parameters])
        hi = np.array([np.inf if q.upper is None else q.upper for q in self.parameters])
        return lo, hi

    def sqrt_cov(self) -> np.ndarray:
        """``A`` with ``A Aᵀ = Σ`` (symmetric square root; clips tiny negative eigenvalues)."""
        w, V = np.linalg.eigh(self.cov)
        return (V * np.sqrt(np.clip(w, 0, None))) @ V.T

    def default_target(self):
        if self.target is not None:
            return self.target
        if self.kind == "vehicle":
            from uuvid.simulate.scenario import ScenarioSpec

            sc = dict(self.base.get("scenario", {}))
            sc.setdefault("vehicle", self.base.get("vehicle", "bluerov2"))
            return VehicleMissionTarget(scenario=ScenarioSpec.model_validate(sc),
                                        velocity_response=VelocityResponse())
        if self.kind == "thruster_physical":
            return ThrusterSteadyTarget(physical_model=self.base["physical_model"],
                                        supply_voltages=self.base.get("supply_voltages",
                                                                      [12.0, 14.0, 16.0]))
        return ThrusterStepTarget(chain=self.base.get("chain", "auv2-tunnel"),
                                  preset_kwargs=self.base.get("preset_kwargs", {}),
                                  **({"signal": self.base["signal"]} if "signal" in self.base else {}))

    def default_requirement(self) -> Requirement | None:
        if self.requirement is not None:
            return self.requirement
        if self.kind == "vehicle":
            return Requirement(metric="max_tracking_error_m", below=0.5)
        return None


# ---------------------------------------------------------------------------------------------
# reading models
# ---------------------------------------------------------------------------------------------
def _loc(loc) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else ("." if out else "") + str(part)
    return out


def model_from_dict(raw: Any, where: str = "<model>", base_dir: Path | None = None) -> UncertainModel:
    """An :class:`UncertainModel` from a model document, a ``uuvid thruster fit`` summary or a
    ``Fit.as_dict()`` document with ``kind`` and ``base``."""
    if not isinstance(raw, dict):
        raise ModelError(f"{where}: expected a mapping")
    if "format" not in raw and isinstance(raw.get("parameters"), dict):
        raw = _from_fit_summary(raw, where)
    other = _other_file(raw, where)
    if other:
        raise ModelError(other)
    try:
        m = UncertainModel.model_validate(raw)
    except ValidationError as e:
        msgs = []
        for err in e.errors():
            loc = _loc(err["loc"])
            text = {"missing": "missing", "extra_forbidden": "unknown key"}.get(err["type"], err["msg"])
            if err["type"] == "value_error" and err.get("ctx", {}).get("error") is not None:
                text = str(err["ctx"]["error"])  # our own message, without "Value error, "
            msgs.append(f"{where}: {loc}: {text}" if loc else f"{where}: {text}")
        raise ModelError("\n".join(msgs)) from None
    if base_dir is not None:
        if m.target is not None:
            m = m.model_copy(update={"target": resolve_paths(m.target, base_dir)})
        b = dict(m.base)
        for key in ("vehicle", "chain"):
            v = b.get(key)
            if isinstance(v, str) and (base_dir / v).exists() and not Path(v).is_absolute():
                b[key] = str((base_dir / v).resolve())
        m = m.model_copy(update={"base": b})
    return m


#: What ``uuvid montecarlo`` reads (said when it is given another kind of uuvid file).
TAKES = ("montecarlo takes an uncertain-model file (format: uuvid-uncertain-model/1: kind, base, "
         "parameters with estimate and sigma or a covariance), the summary.json of `uuvid thruster "
         f"fit --model physical`, or a built-in model ({', '.join(BUILTIN_MODELS)})")


def _other_file(raw: dict, where: str) -> str | None:
    """The message for another kind of uuvid file (a thruster model, a vehicle, a scenario, a
    sweep), naming what it is and what Monte Carlo takes; ``None`` for a model document."""
    from uuvid.thruster.modelfile import KIND_KEYS

    fmt = raw.get("format")
    if isinstance(fmt, str) and fmt.startswith("uuvid-sweep/"):
        return f"{where}: this is a sweep file (format: {fmt}): run it with `uuvid sweep`; {TAKES}"
    if fmt is not None or "kind" in raw or "base" in raw:
        return None
    for kind, keys in KIND_KEYS.items():
        hit = [k for k in keys if k in raw]
        if not hit:
            continue
        if kind == "a thruster model file":
            chain = Path(where).name
            return (f"{where}: this is a thruster model file (uuvid thruster fit --out-model; it has "
                    f"{', '.join(hit)}): estimates without their uncertainty. {TAKES}. To propagate "
                    f"this model's uncertainty write an uncertain-model file: kind: thruster_chain, "
                    f"base: {{chain: {chain}}}, parameters: [{{name: 'blocks[0].<field>', estimate: "
                    f"..., sigma: ...}}] (σ from the fit's summary.json)")
        return f"{where}: this is {kind} (it has {', '.join(hit)}); {TAKES}"
    return None


def _from_fit_summary(raw: dict, where: str) -> dict:
    """``uuvid thruster fit`` summary (``--model physical``) or ``Fit.as_dict()`` → model dict."""
    params = raw["parameters"]
    names = list(params)
    if "physical_model" in raw:
        kind, base = "thruster_physical", {"physical_model": raw["physical_model"]}
        if raw.get("supply_voltage_V"):
            base["supply_voltages"] = sorted({12.0, 14.0, 16.0, float(raw["supply_voltage_V"])})
    elif "kind" in raw and "base" in raw:
        kind, base = raw["kind"], raw["base"]
    else:
        raise ModelError(f"{where}: a fit summary without 'physical_model' (or 'kind' and 'base'); "
                         "only physical thruster fits carry a model Monte Carlo can rebuild")
    cov = raw.get("covariance")
    loose = [n for n in names if params[n].get("sigma", 0.0) is None
             or (isinstance(params[n].get("sigma"), float) and not math.isfinite(params[n]["sigma"]))]
    if loose:
        raise ModelError(f"{where}: the fit does not determine {', '.join(loose)} (σ = ∞, null in "
                         "the JSON): no distribution to sample them from — refit with data that "
                         "separate them (a physical fit: the current column), or write a model "
                         "file with the parameters and σ you trust")
    plist = []
    for n in names:
        d = params[n]
        plist.append({"name": n, "estimate": d.get("estimate", d.get("value")),
                      "sigma": d.get("sigma"), "unit": d.get("unit", "") or "",
                      **_physical_bounds(n)})
    if cov is None:
        warnings.warn(f"{where}: no covariance in the fit summary — parameters taken as "
                      "independent (σ only); correlated estimates make the bands too wide or too "
                      "narrow", RuntimeWarning, stacklevel=3)
    return {"format": MODEL_FORMAT, "name": raw.get("name", Path(where).stem), "kind": kind,
            "base": base, "parameters": plist, "covariance": cov,
            "provenance": {"from": where, "fit_model": raw.get("model"),
                           "warnings": raw.get("warnings", [])}}


def _physical_bounds(name: str) -> dict:
    """Physical bounds of the physical-model parameters (positive constants, |β| < 1)."""
    if name.startswith("curvature"):
        return {"lower": -0.999, "upper": 0.999}
    if name in ("K_e", "R", "K_Q_fwd", "K_Q_rev", "K_T_fwd", "K_T_rev", "c_v", "T_c",
                "deadband_fwd", "deadband_rev"):
        return {"lower": 0.0}
    return {}


def _read_json(p: Path):
    try:
        return json.loads(p.read_text(encoding="utf-8"))
    except UnicodeDecodeError as e:
        raise ModelError(f"{p}: not UTF-8 text (byte offset {e.start}); save the file as UTF-8 "
                         "JSON") from None
    except json.JSONDecodeError as e:
        raise ModelError(f"{p}: line {e.lineno}, column {e.colno}: not valid JSON ({e.msg})") \
            from None
    except OSError as e:
        raise ModelError(f"{p}: cannot read the model file ({e.strerror or e})") from None


def load_model(path_or_name: str | Path) -> UncertainModel:
    """A model file (YAML/TOML/JSON) or a built-in name (:data:`BUILTIN_MODELS`)."""
    from uuvid.thruster.modelfile import read_model_text

    p = Path(path_or_name)
    if not p.exists():
        cand = BUILTIN_FILES.get(str(path_or_name), DATA / f"{path_or_name}.yaml")
        if not cand.exists():
            raise FileNotFoundError(f"{path_or_name}: no such model file, and not a built-in "
                                    f"model ({', '.join(BUILTIN_MODELS)})")
        p = cand
    raw = read_model_text(p) if p.suffix.lower() != ".json" else _read_json(p)
    return model_from_dict(raw, where=str(p), base_dir=p.resolve().parent)


def save_model(model: UncertainModel, path: str | Path) -> Path:
    import yaml

    from uuvid.core.atomic import atomic_write_text

    d = model.model_dump(mode="json", exclude_none=True)
    return atomic_write_text(path, yaml.safe_dump(d, sort_keys=False, width=100, allow_unicode=True))


# ---------------------------------------------------------------------------------------------
# drawing parameters
# ---------------------------------------------------------------------------------------------
class Sampler:
    """Per-run draws with bounds (see the module docstring)."""

    def __init__(self, model: UncertainModel, seed: int, policy: str = "reject",
                 max_draws: int = 100):
        if policy not in ("reject", "truncate", "ignore"):
            raise ValueError(f"bounds policy must be reject, truncate or ignore, got {policy!r}")
        self.model, self.seed, self.policy, self.max_draws = model, int(seed), policy, int(max_draws)
        self.mu = model.mean
        self.A = model.sqrt_cov()
        self.lo, self.hi = model.bounds()
        self.p = self.mu.size

    def draw(self, run: int) -> tuple[np.ndarray, int, str, np.ndarray]:
        """``(θ, draws used, status ("ok" or "rejected"), violations per parameter)``."""
        rng = np.random.default_rng([self.seed, int(run)])
        viol = np.zeros(self.p, dtype=np.int64)
        if self.policy == "ignore":
            return self.mu + self.A @ rng.standard_normal(self.p), 1, "ok", viol
        if self.policy == "truncate":
            x = self.mu + self.A @ rng.standard_normal(self.p)
            viol += (x < self.lo) | (x > self.hi)
            return np.clip(x, self.lo, self.hi), 1, "ok", viol
        for k in range(1, self.max_draws + 1):
            x = self.mu + self.A @ rng.standard_normal(self.p)
            bad = (x < self.lo) | (x > self.hi)
            if not bad.any():
                return x, k, "ok", viol
            viol += bad
        return x, self.max_draws, REJECTED, viol


# ---------------------------------------------------------------------------------------------
# the study
# ---------------------------------------------------------------------------------------------
class MonteCarloSpec(BaseModel):
    model_config = _CFG
    name: str = "montecarlo"
    model: UncertainModel
    runs: Whole = Field(1000, ge=1)
    seed: Whole = Field(0, ge=0)
    bounds: Literal["reject", "truncate", "ignore"] = "reject"
    max_draws: Whole = Field(100, ge=1, le=100000)
    target: Target | None = None
    requirement: Requirement | None = None
    band: Num = Field(0.95, gt=0, lt=1)
    chunk_size: Whole | None = Field(None, ge=1)
    retries: Whole = Field(2, ge=0, le=100)


class MonteCarloStudy(StudyBase):
    """A Monte Carlo as a study for :func:`uuvid.uncertainty.execute.run_study`."""

    kind = "montecarlo"

    def __init__(self, spec: MonteCarloSpec):
        m = spec.model
        spec = spec.model_copy(update={"target": spec.target or m.default_target(),
                                       "requirement": spec.requirement or m.default_requirement()})
        self.spec = spec
        self.name = spec.name
        self.n_runs = spec.runs
        self.retries = spec.retries
        self.sampler = Sampler(m, spec.seed, spec.bounds, spec.max_draws)
        self._plan = None

    @classmethod
    def from_payload(cls, payload: dict) -> MonteCarloStudy:
        return cls(MonteCarloSpec.model_validate(payload["spec"]))

    def parameter_names(self) -> list[str]:
        return list(self.spec.model.names)

    def check(self) -> None:
        plan = self.plan
        self.warnings = self.say_build_warnings()  # the vehicle file's, the duration's rounding
        req = self.spec.requirement
        if req is not None and req.metric not in plan.metric_names:
            from uuvid.uncertainty.params import ParameterNameError

            raise ParameterNameError(f"requirement: unknown metric {req.metric!r}; the target "
                                     f"gives {', '.join(plan.metric_names)}")


    def parameter_table(self, start: int, stop: int) -> pd.DataFrame:
        runs = np.arange(start, stop)
        X = np.empty((runs.size, self.sampler.p))
        draws = np.empty(runs.size, dtype=np.int64)
        status = np.empty(runs.size, dtype=object)
        viol = np.zeros((runs.size, self.sampler.p), dtype=np.int64)
        for j, r in enumerate(runs):
            X[j], draws[j], status[j], viol[j] = self.sampler.draw(int(r))
        cols: dict[str, Any] = {"run": runs}
        for i, n in enumerate(self.spec.model.names):
            cols[n] = X[:, i]
        cols["draws"] = draws
        cols["_status"] = status
        names = np.array(self.spec.model.names, dtype=object)
        cols["bound_violations"] = [";".join(f"{n}×{c}" for n, c in zip(names[v > 0], v[v > 0]))
                                    for v in viol]
        return pd.DataFrame(cols)

    def evaluate(self, start: int, stop: int):
        from uuvid.uncertainty.targets import ChunkResult

        table = self.parameter_table(start, stop)
        pre = table.pop("_status").to_numpy()
        live = np.flatnonzero(pre == "ok")
        names = self.spec.model.names
        plan = self.plan
        metrics = {m: np.full(len(table), np.nan) for m in plan.metric_names}
        status = pre.copy()
        outside = [q for q in self.spec.model.parameters if q.outside_bounds]
        why = "; ".join(f"{q.name}'s estimate {q.estimate:g} is itself outside "
                        f"[{q.lower if q.lower is not None else '-inf'}, "
                        f"{q.upper if q.upper is not None else 'inf'}]" for q in outside)
        message = np.where(pre == REJECTED, f"no admissible draw in {self.spec.max_draws} "
                           f"attempts (bounds{': ' + why if why else ''})", "").astype(object)
        series: dict[str, np.ndarray] = {}
        if live.size:
            ev = plan.evaluate({n: table[n].to_numpy()[live] for n in names}, live.size)
            for m in plan.metric_names:
                metrics[m][live] = ev.metrics[m]
            status[live] = ev.status
            message[live] = ev.message
            for k, v in ev.series.items():
                s = np.full((len(table), v.shape[1]), np.nan)
                s[live] = v
                series[k] = s
        else:
            from uuvid.uncertainty.targets import series_axes

            for k, ax in series_axes(plan).items():
                series[k] = np.full((len(table), ax.size), np.nan)
        for m in plan.metric_names:
            table[m] = metrics[m]
        req = self.spec.requirement
        if req is not None:
            table["requirement_met"] = req.met(metrics[req.metric]) & (status == "ok")
        table["status"] = status
        table["message"] = message
        return ChunkResult(start, stop, table, series)

    def series_axes(self) -> dict:
        from uuvid.uncertainty.targets import series_axes

        return series_axes(self.plan)

    def summarise(self, table: pd.DataFrame, series: dict) -> dict:
        sp = self.spec
        out: dict = {"target": self.plan.info(), "model": sp.model.name,
                     "model_kind": sp.model.kind, "seed": sp.seed,
                     "bounds_policy": sp.bounds, "parameters": sp.model.names}
        if getattr(self, "warnings", None):  # said on stderr by check: in the document too
            out["warnings"] = list(dict.fromkeys(self.warnings))
        if not len(table):
            return out
        ok = table["status"] == "ok"
        draws = table["draws"].to_numpy()
        viol: dict[str, int] = {}
        for s in table["bound_violations"].fillna(""):
            for part in filter(None, str(s).split(";")):
                n, c = part.rsplit("×", 1)
                viol[n] = viol.get(n, 0) + int(c)
        out["draws"] = {"total": int(draws.sum()), "rejected_draws": int(draws.sum() - len(table))
                        if sp.bounds == "reject" else 0,
                        "runs_with_rejections": int((draws > 1).sum()),
                        "runs_rejected": int((table["status"] == REJECTED).sum()),
                        "runs_clipped": int((table["bound_violations"].fillna("") != "").sum())
                        if sp.bounds == "truncate" else 0,
                        "violations_by_parameter": viol,
                        "acceptance_rate": float(len(table) / max(int(draws.sum()), 1))}
        q = (1 - sp.band) / 2
        out["metric_quantiles"] = {}
        for m in self.plan.metric_names:
            x = table.loc[ok, m].to_numpy(dtype=float)
            x = x[np.isfinite(x)]
            if x.size:
                out["metric_quantiles"][m] = {
                    "mean": float(x.mean()), "std": float(x.std(ddof=1)) if x.size > 1 else 0.0,
                    f"q{100 * q:g}": float(np.quantile(x, q)), "median": float(np.median(x)),
                    f"q{100 * (1 - q):g}": float(np.quantile(x, 1 - q))}
        if sp.requirement is not None:
            out["requirement"] = probability_summary(table, sp.requirement)
        out["bands"] = {k: band_summary(v[ok.to_numpy()], sp.band, sp.model.residual_sigma, sp.seed)
                        for k, v in series.items()}
        return out


def series_unit(name: str) -> str:
    if name.startswith("thrust@"):
        return "N"
    if name.startswith("velocity_"):
        return "rad/s" if name.split("_", 1)[1] in ("roll", "pitch", "yaw") else "m/s"
    return ""


def band_summary(Y: np.ndarray, band: float, residual_sigma: float | None = None,
                 seed: int = 0) -> dict:
    """Pointwise median and central ``band`` interval over the rows of ``Y`` (NaN rows ignored);
    with ``residual_sigma`` also the prediction interval of one new observation."""
    Y = np.asarray(Y, dtype=float)
    Y = Y[np.all(np.isfinite(Y), axis=1)] if Y.size else Y
    if not Y.size or Y.shape[0] == 0:
        return {"n": 0}
    q = (1 - band) / 2
    out = {"n": int(Y.shape[0]), "band": band,
           "lower": np.quantile(Y, q, axis=0).tolist(), "median": np.median(Y, axis=0).tolist(),
           "upper": np.quantile(Y, 1 - q, axis=0).tolist()}
    if residual_sigma:
        rng = np.random.default_rng([int(seed), 0x5EED])
        Yn = Y + residual_sigma * rng.standard_normal(Y.shape)
        out["residual_sigma"] = residual_sigma
        out["prediction_lower"] = np.quantile(Yn, q, axis=0).tolist()
        out["prediction_upper"] = np.quantile(Yn, 1 - q, axis=0).tolist()
    return out


# ---------------------------------------------------------------------------------------------
# running and reporting
# ---------------------------------------------------------------------------------------------
def run_montecarlo(model: UncertainModel | str | Path, runs: int = 1000, out: str | Path | None = None,
                   *, seed: int = 0, bounds: str = "reject", max_draws: int = 100, target=None,
                   requirement: Requirement | None = None, band: float = 0.95,
                   report: bool = True, name: str | None = None, chunk_size: int | None = None,
                   **kw):
    """Draw ``runs`` parameter sets from ``model`` and simulate them; ``kw`` go to
    :func:`~uuvid.uncertainty.execute.run_study` (``backend``, ``workers``, ``scheduler``, …)."""
    from uuvid.uncertainty.execute import run_study

    if not isinstance(model, UncertainModel):
        model = load_model(model)
    try:
        spec = MonteCarloSpec(name=name or f"{model.name}-mc", model=model, runs=runs, seed=seed,
                              bounds=bounds, max_draws=max_draws, target=target,
                              requirement=requirement, band=band, chunk_size=chunk_size)
    except ValidationError as e:  # one line naming the keyword (`runs=`, `seed=`, …)
        err = e.errors()[0]
        key = ".".join(str(x) for x in err["loc"])
        raise ValueError(f"`{key}=` {err.get('input')!r}: {err['msg']}") from None
    study = MonteCarloStudy(spec)
    study.check()
    res = run_study(study, out, **kw)
    if out is not None:
        res.out = Path(out)
        if report:
            res.info["figures"] = write_mc_report(res, study, Path(out))
            from uuvid.core.atomic import atomic_write_json

            atomic_write_json(Path(out) / "summary.json", res.info)
    return res


def write_mc_report(res, study: MonteCarloStudy, out: Path) -> list[str]:
    """Band plots, the requirement histogram, parameter table, ``bands.csv``, ``index.html``."""
    from uuvid.core.atomic import atomic_path
    from uuvid.core.html import Report
    from uuvid.core.plots import new_figure, save_figure

    sp = study.spec
    s = res.info
    table = res.table
    ok = (table["status"] == "ok").to_numpy()
    rep = Report(f"uuvid montecarlo — {sp.model.name}")
    rep.add_paragraph(
        f"{s['runs']} draws from the {sp.model.kind} model {sp.model.name!r} (seed {sp.seed}, "
        f"bounds: {sp.bounds}); {s['succeeded']} simulated successfully "
        f"({', '.join(f'{k}: {v}' for k, v in s['status_counts'].items())}); {s['backend']} "
        f"backend, {s['wall_time_s']:.3g} s ({s['runs_per_s']:.4g} runs/s)."
        + (" PARTIAL RESULT." if s.get("partial") else ""))
    if sp.model.description:
        rep.add_paragraph(sp.model.description)
    rep.add_table([{"parameter": q.name, "estimate": q.estimate, "sigma": float(sd), "unit": q.unit,
                    "lower": q.lower, "upper": q.upper}
                   for q, sd in zip(sp.model.parameters, sp.model.sigma)],
                  caption="Identified parameters (estimate, σ from the covariance, bounds)")
    files = []
    if "requirement" in s:
        r = s["requirement"]
        rep.add_heading("Requirement")
        rep.add_paragraph(
            f"P({r['requirement']}) = {r['probability']:.4f} (Wilson 95 % "
            f"[{r['wilson95'][0]:.4f}, {r['wilson95'][1]:.4f}]) over {r['runs_simulated']} simulated "
            f"runs; counting runs that could not be simulated as failures: "
            f"{r['probability_counting_unsimulated_as_failures']:.4f}.")
        req = sp.requirement
        x = table.loc[ok, req.metric].to_numpy(dtype=float)
        x = x[np.isfinite(x)]
        if x.size:
            fig, ax = new_figure(1, 1, figsize=(7, 4))
            ax.hist(x, bins=min(60, max(10, x.size // 20)), color="C0", alpha=0.8)
            for v in (req.below, req.above):
                if v is not None:
                    ax.axvline(v, color="C3", ls="--", label=f"requirement {v:g}")
            from uuvid.uncertainty.targets import metric_label

            ax.set_xlabel(metric_label(req.metric))
            ax.set_ylabel("runs")
            ax.legend()
            save_figure(fig, out / "requirement_hist.png")
            rep.add_figure(out / "requirement_hist.png", caption=f"Distribution of {req.metric}")
            files.append("requirement_hist.png")
    axes = res.axes or study.series_axes()
    band_rows = []
    for k, Y in res.series.items():
        b = s.get("bands", {}).get(k, {})
        if not b.get("n"):
            continue
        x = axes.get(k, np.arange(Y.shape[1]))
        lo, med, hi = (np.asarray(b[j]) for j in ("lower", "median", "upper"))
        fig, (ax, ax2) = new_figure(2, 1, sharex=True, figsize=(7, 6.5),
                                    gridspec_kw={"height_ratios": [2, 1]})
        good = Y[ok & np.all(np.isfinite(Y), axis=1)]
        for row in good[: min(30, len(good))]:
            ax.plot(x, row, color="0.6", lw=0.5, alpha=0.5)
        lab = f"{100 * sp.band:g} % band"
        if "prediction_lower" in b:
            pl_, pu_ = np.asarray(b["prediction_lower"]), np.asarray(b["prediction_upper"])
            plab = f"{100 * sp.band:g} % prediction (σ_residual {b['residual_sigma']:.3g})"
            ax.fill_between(x, pl_, pu_, color="C1", alpha=0.2, label=plab)
            ax2.fill_between(x, pl_ - med, pu_ - med, color="C1", alpha=0.2, label=plab)
        ax.fill_between(x, lo, hi, color="C0", alpha=0.3, label=lab)
        ax.plot(x, med, color="C0", lw=2, label="median")
        ax2.fill_between(x, lo - med, hi - med, color="C0", alpha=0.5, label=lab)
        ax2.axhline(0, color="C0", lw=1)
        unit = series_unit(k)
        ax.set_ylabel(f"{k} [{unit}]")
        ax2.set_ylabel(f"{k} − median [{unit}]")
        xl = ("command [" + str(sp.model.base.get("physical_model", {}).get("command_unit", "")) + "]"
              if k.startswith("thrust@") else "t [s]")
        ax2.set_xlabel(xl)
        ax.set_title(f"{k}: {b['n']} runs")
        ax.legend(fontsize=8)
        name = f"band_{k.replace('@', '_at_')}.png"
        save_figure(fig, out / name)
        rep.add_figure(out / name, caption=f"{k}: median and {100 * sp.band:g} % pointwise band of "
                                           "the model (grey: 30 individual runs); below, the bands "
                                           "relative to the median")
        files.append(name)
        pl = b.get("prediction_lower", [np.nan] * len(x))
        pu = b.get("prediction_upper", [np.nan] * len(x))
        for xi, a, m, c, d, e in zip(x, lo, med, hi, pl, pu):
            band_rows.append({"series": k, "x": float(xi), "lower": a, "median": m, "upper": c,
                              "prediction_lower": d, "prediction_upper": e})
    if band_rows:
        with atomic_path(out / "bands.csv") as tmp:
            pd.DataFrame(band_rows).to_csv(tmp, index=False)
    if s.get("metric_quantiles"):
        rep.add_table([{"metric": k, **v} for k, v in s["metric_quantiles"].items()],
                      caption="Metrics over successful runs")
    rep.add_json({k: v for k, v in s.items() if k not in ("spec", "bands")}, caption="Summary")
    rep.write(out)
    return files


__all__ = ["BUILTIN_MODELS", "ModelError", "MonteCarloSpec", "MonteCarloStudy", "Sampler",
           "UncertainModel", "UncertainParameter", "band_summary", "load_model", "model_from_dict",
           "probability_summary", "run_montecarlo", "save_model", "wilson", "write_mc_report"]
