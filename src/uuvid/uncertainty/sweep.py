"""Parameter sweeps: a grid (or list, or random sample) over named model parameters → a tidy table.

A sweep file (YAML/TOML; ``uuvid sweep SWEEP.yaml``)::

    name: mclean-sensitivity
    target:                            # what one run simulates (see uuvid.uncertainty.targets)
      kind: thruster_step              # thruster_step | thruster_steady | vehicle_mission
      chain: auv2-tunnel               # preset or model file
      signal: {kind: step, amplitude: 24.0}
      t_end: 1.333
    mode: grid                         # grid (cartesian product) | list | random
    parameters:                        # grid / random axes (names: uuvid.uncertainty.params)
      - {name: tunnel_length, unit: in, values: [5, 10.5, 20]}
      - {name: added_mass_coefficient, start: 0, stop: 1, num: 5}
      - {name: voltage, values: [8, 16, 24]}
    metrics: [peak_output_thrust, time_constant_speed, steady_thrust]   # default: all
    requirement: {metric: max_tracking_error_m, below: 0.5}            # optional
    plots:                             # optional; default: a heat map and line plots
      - {kind: heatmap, x: tunnel_length, y: added_mass_coefficient, metric: peak_output_thrust}
      - {kind: line, x: voltage, metric: steady_thrust, hue: tunnel_length}

``mode: list`` takes ``runs: [{name: value, ...}, ...]``; ``mode: random`` draws ``samples`` runs,
each axis uniform (``log: true``: log-uniform) between ``start`` and ``stop`` from the stream
``numpy.random.default_rng([seed, run])`` — the same values whatever the backend or chunking.

The result is a tidy table, one row per run: ``run``, the parameters (SI), the metrics, ``status``
(``ok``, ``invalid``, ``diverged``, ``failed``) and ``message``; plus heat maps / line plots.
Run it with :func:`run_sweep` (backends: :mod:`uuvid.uncertainty.execute`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from uuvid.core.yamltypes import Num, Whole, boolean_message
from uuvid.uncertainty import params as PR
from uuvid.uncertainty.targets import StudyBase, Target, metric_label, metric_unit, resolve_paths

_CFG = ConfigDict(extra="forbid", allow_inf_nan=False)
DATA = Path(__file__).resolve().parent / "data"
SWEEP_FORMAT = "uuvid-sweep/1"


class SweepError(ValueError):
    """An invalid sweep description; the message names the file and the key."""


class Axis(BaseModel):
    """One swept parameter: ``values`` (a list) or ``start``/``stop``/``num`` (linspace, or
    geometric with ``log``), plus optional extra ``include`` values; in ``unit`` (default SI)."""

    model_config = _CFG
    name: str
    values: list[Any] | None = None
    start: Num | None = None
    stop: Num | None = None
    num: Whole | None = Field(None, ge=1, le=100000)
    log: bool = False
    include: list[Num] = Field(default_factory=list)
    unit: str | None = None

    @model_validator(mode="after")
    def _one_form(self):
        if self.values is None and (self.start is None or self.stop is None):
            raise ValueError(f"parameter {self.name!r}: give values, or start and stop")
        if self.values is not None and (self.start is not None or self.stop is not None):
            raise ValueError(f"parameter {self.name!r}: give values or start/stop, not both")
        if self.values is not None and not self.values:
            raise ValueError(f"parameter {self.name!r}: values is empty")
        if self.log and self.start is not None and not (self.start > 0 and self.stop > 0):
            raise ValueError(f"parameter {self.name!r}: log spacing needs start, stop > 0")
        PR.unit_factor(self.name, self.unit)  # a unit of the parameter's dimension (not rpm for m/s)
        if self.start is not None:
            with np.errstate(all="ignore"):
                g = np.asarray(self.grid(), dtype=float)
            if not np.all(np.isfinite(g)):  # linspace(1e308, -1e308): stop - start overflows
                raise ValueError(f"parameter {self.name!r}: start {self.start:g} … stop "
                                 f"{self.stop:g} gives non-finite grid values (the range is "
                                 "beyond the floating-point numbers); give a narrower range")
        return self

    def grid(self) -> list[Any]:
        """The values in SI (list order; a start/stop grid is sorted with ``include`` merged)."""
        if self.values is not None:
            vals = list(self.values) + list(self.include)
        else:
            n = self.num or 11
            g = (np.geomspace(self.start, self.stop, n) if self.log
                 else np.linspace(self.start, self.stop, n))
            vals = sorted(set(float(v) for v in g) | set(float(v) for v in self.include))
        return [PR.to_si(v, self.unit, self.name) for v in vals]

    def sample(self, rng: np.random.Generator) -> float:
        if self.start is None:
            vals = self.grid()
            return vals[int(rng.integers(len(vals)))]
        if self.log:
            v = math.exp(rng.uniform(math.log(self.start), math.log(self.stop)))
        else:
            v = rng.uniform(self.start, self.stop)
        return PR.to_si(v, self.unit, self.name)


class Requirement(BaseModel):
    """``metric < below`` and/or ``metric > above``; each run is ``requirement_met`` or not."""

    model_config = _CFG
    metric: str
    below: Num | None = None
    above: Num | None = None

    @model_validator(mode="after")
    def _bound(self):
        if self.below is None and self.above is None:
            raise ValueError("requirement: give below and/or above")
        return self

    def describe(self) -> str:
        parts = []
        if self.above is not None:
            parts.append(f"{self.metric} > {self.above:g}")
        if self.below is not None:
            parts.append(f"{self.metric} < {self.below:g}")
        return " and ".join(parts)

    def met(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        ok = np.isfinite(x)
        if self.below is not None:
            ok &= x < self.below
        if self.above is not None:
            ok &= x > self.above
        return ok


class PlotSpec(BaseModel):
    model_config = _CFG
    kind: Literal["heatmap", "line"]
    x: str
    y: str | None = None  # heatmap
    hue: str | None = None  # line
    metric: str
    at: dict[str, Num] = Field(default_factory=dict)  # other parameters fixed at (SI)


class SweepSpec(BaseModel):
    """A sweep description (see the module docstring)."""

    model_config = _CFG
    format: Literal["uuvid-sweep/1"] | None = None
    name: str = "sweep"
    description: str = ""
    target: Target
    mode: Literal["grid", "list", "random"] = "grid"
    parameters: list[Axis] = Field(default_factory=list)
    runs: list[dict[str, Any]] | None = None
    samples: Whole | None = Field(None, ge=1)
    metrics: list[str] | None = None
    requirement: Requirement | None = None
    seed: Whole = 0
    chunk_size: Whole | None = Field(None, ge=1)
    retries: Whole = Field(2, ge=0, le=100)
    plots: list[PlotSpec] | None = None

    @model_validator(mode="after")
    def _mode(self):
        names = [a.name for a in self.parameters]
        if len(set(names)) != len(names):
            raise ValueError("parameters: a name appears twice")
        if self.mode == "list":
            if not self.runs:
                raise ValueError("mode list needs runs: [{name: value, ...}, ...]")
            if self.parameters:
                raise ValueError("mode list takes runs, not parameters")
            keys = set(self.runs[0])
            for i, r in enumerate(self.runs):
                if set(r) != keys:
                    raise ValueError(f"runs[{i}] sets {sorted(r)}; every run must set the same "
                                     f"parameters ({sorted(keys)})")
        else:
            if self.runs is not None:
                raise ValueError(f"runs is for mode list (mode is {self.mode})")
            if self.mode == "random" and not self.samples:
                raise ValueError("mode random needs samples: N")
            if self.mode == "grid" and self.samples:
                raise ValueError("samples is for mode random")
            if not self.parameters:  # an empty grid silently ran the baseline alone
                raise ValueError(f"mode {self.mode} needs parameters: [{{name: ..., values: [...]}} "
                                 "or {name: ..., start: ..., stop: ...}, ...] (none given)")
            if self.mode == "grid":  # (random draws between start and stop: num unused)
                for i, a in enumerate(self.parameters):
                    if a.num == 1 and a.start is not None and a.start != a.stop:
                        raise ValueError(f"parameters[{i}] ({a.name}): num 1 gives start {a.start:g} "
                                         f"alone (stop {a.stop:g} unused); give num >= 2, or "
                                         f"values: [{a.start:g}]")
            if self.mode == "random":
                for i, a in enumerate(self.parameters):
                    if a.start is not None and a.start > a.stop:
                        raise ValueError(f"parameters[{i}] ({a.name}): start {a.start:g} > stop "
                                         f"{a.stop:g}; a random axis draws between start and "
                                         "stop: give start <= stop")
        return self

    @property
    def names(self) -> list[str]:
        if self.mode == "list":
            return list(dict.fromkeys(k for r in self.runs for k in r))
        return [a.name for a in self.parameters]

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a.grid()) for a in self.parameters)

    @property
    def n_runs(self) -> int:
        if self.mode == "grid":
            return math.prod(self.shape)  # Python ints: np.prod wrapped past 2^63
        if self.mode == "list":
            return len(self.runs)
        return int(self.samples)


def _loc(loc) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else ("." if out else "") + str(part)
    return out


def sweep_from_dict(raw, where: str = "<sweep>", base: Path | None = None) -> SweepSpec:
    try:
        spec = SweepSpec.model_validate(raw if raw is not None else {})
    except ValidationError as e:
        msgs = []
        for err in e.errors():
            loc = _loc(err["loc"])
            text = {"missing": "missing", "extra_forbidden": "unknown key"}.get(
                err["type"], err["msg"].removeprefix("Value error, "))
            msgs.append(f"{where}: {loc}: {text}" if loc else f"{where}: {text}")
        raise SweepError("\n".join(msgs)) from None
    check_values(spec, where)
    return spec.model_copy(update={"target": resolve_paths(spec.target, base)})


def _given_values(spec: SweepSpec) -> list[tuple[str, str, list, str | None]]:
    """(where in the file, parameter name, values as given, unit) of every parameter."""
    if spec.mode == "list":
        return [(f"runs[{r}].{n}", n, [v], None) for r, run in enumerate(spec.runs)
                for n, v in run.items()]
    return [(f"parameters[{i}] ({a.name})", a.name,
             list(a.values) + list(a.include) if a.values is not None else [a.start, a.stop], a.unit)
            for i, a in enumerate(spec.parameters)]


def _expects_number(kind: str, name: str) -> bool:
    """Whether parameter ``name`` of a ``kind`` target takes numbers only (known without its
    plan; :meth:`SweepStudy.check` looks at the chain's block fields)."""
    if kind == "thruster_steady":
        return True
    if kind == "vehicle_mission":
        return not name.startswith("thruster.")
    return (name in ("voltage", "command", "amplitude") or PR.si_unit(name) != ""
            or (name.startswith("signal.") and name != "signal.kind"))


def _is_number(v) -> bool:
    if isinstance(v, bool):  # YAML's yes/on/true: pydantic and float() take it as 1.0
        return False
    if isinstance(v, (int, float)):
        return True
    if isinstance(v, str):
        try:
            float(v)
            return True
        except ValueError:
            return False
    return False


def _number_error(where: str, loc: str, name: str, vals: list) -> None:
    """``SweepError`` naming the file (``where``; none: the caller names it), the parameter and
    the first value that is not a number."""
    for v in vals:
        if not _is_number(v):
            u = PR.si_unit(name)
            what = boolean_message(v) if isinstance(v, bool) else f"value {v!r} is not a number"
            raise SweepError((f"{where}: " if where else "")
                             + f"{loc}: {what}; {name} takes numbers"
                             + (f" (in {u} unless the parameter gives a unit)" if u else ""))


def check_values(spec: SweepSpec, where: str = "<sweep>") -> None:
    """Refuse, when the file is read, a value no run could use: text for a numeric parameter
    (it failed every run of its chunk, the good ones too), a current faster than any sea's
    (:func:`uuvid.core.checks.current_speed`, the bound ``uuvid simulate`` applies)."""
    from uuvid.core.checks import current_speed

    kind = spec.target.kind
    for loc, name, vals, unit in _given_values(spec):
        if _expects_number(kind, name):
            _number_error(where, loc, name, vals)
        if kind == "vehicle_mission" and (name == "current_speed" or name.startswith("current[")):
            for v in vals:
                try:
                    si = PR.to_si(float(v), unit, name)
                    current_speed(f"{where}: {loc}: value {v!r}"
                                  + (f" {unit}" if unit else ""), abs(si))
                except ValueError as e:
                    raise SweepError(str(e)) from None


def builtin_sweeps() -> list[str]:
    return sorted(p.stem for p in DATA.glob("*.sweep.yaml"))


def load_sweep(path_or_name: str | Path) -> SweepSpec:
    """A sweep file (YAML/TOML) or a built-in sweep name (:func:`builtin_sweeps`)."""
    from uuvid.thruster.modelfile import read_model_text

    p = Path(path_or_name)
    if not p.exists():
        cand = DATA / f"{path_or_name}.sweep.yaml"
        if cand.exists():
            p = cand
        else:
            raise FileNotFoundError(f"{path_or_name}: no such sweep file, and not a built-in sweep "
                                    f"({', '.join(builtin_sweeps())})")
    return sweep_from_dict(read_model_text(p), where=str(p), base=p.resolve().parent)


# ---------------------------------------------------------------------------------------------
# the study
# ---------------------------------------------------------------------------------------------
class SweepStudy(StudyBase):
    """A sweep as a study for :func:`uuvid.uncertainty.execute.run_study`."""

    kind = "sweep"

    def __init__(self, spec: SweepSpec):
        self.spec = spec
        self.name = spec.name
        self.n_runs = spec.n_runs
        self.retries = spec.retries
        self._grids = [a.grid() for a in spec.parameters]
        self._plan = None

    @classmethod
    def from_payload(cls, payload: dict) -> SweepStudy:
        return cls(SweepSpec.model_validate(payload["spec"]))

    def parameter_names(self) -> list[str]:
        return list(self.spec.names)

    def check(self) -> None:
        """Build the plan once (raises on unknown parameter or metric names, and on text given
        for a numeric field of a chain block)."""
        plan = self.plan
        self.warnings = self.say_build_warnings()  # the vehicle file's, the duration's rounding
        kinds = getattr(plan, "kind_of", {})
        for loc, name, vals, _unit in _given_values(self.spec):
            if kinds.get(name, ("",))[0] == "block":
                i, path = PR.parse_block_name(name)
                from uuvid.uncertainty.targets import _current

                cur = _current(plan.base.blocks[i], path)
                if isinstance(cur, (int, float)) and not isinstance(cur, bool):
                    _number_error("", loc, name, vals)
        for m in (self.spec.metrics or []):
            if m not in plan.metric_names:
                raise PR.ParameterNameError(f"unknown metric {m!r}; the {self.spec.target.kind} "
                                            f"target gives {', '.join(plan.metric_names)}")
        if self.spec.requirement and self.spec.requirement.metric not in plan.metric_names:
            raise PR.ParameterNameError(f"requirement: unknown metric "
                                        f"{self.spec.requirement.metric!r}")
        if hasattr(plan, "input_warnings"):  # said before the runs, as thruster simulate does
            import warnings

            from uuvid.core.checks import InputWarning

            given = {}
            for _loc, name, vals, unit in _given_values(self.spec):
                given.setdefault(name, []).extend(PR.to_si(v, unit, name) for v in vals)
            for w in plan.input_warnings(given):
                warnings.warn(f"target.signal: {w}", InputWarning, stacklevel=2)
                self.warnings.append(f"target.signal: {w}")

    # the memory and disk refusals (StudyBase.check_memory/check_disk) name the sweep's own keys
    @property
    def split_advice(self) -> str:
        if self.spec.mode == "random":
            return "split the sweep into several (other seeds) and pool their results"
        return "split the sweep into several (part of a parameter's values each)"

    def size_text(self) -> str:
        sp = self.spec
        n = self.n_runs
        if sp.mode == "grid":
            axes = " × ".join(f"{a.name} {k:,}" for a, k in zip(sp.parameters, sp.shape))
            return f"the grid of parameters ({axes}) = {n:,} runs"
        if sp.mode == "random":
            return f"samples: {n:,}"
        return f"runs: {n:,} entries"

    def size_advice(self, fit: int) -> str:
        sp = self.spec
        if sp.mode == "grid":
            return (f"give at most {fit:,} runs: fewer values (values, or num of a start/stop "
                    "axis) in parameters")
        if sp.mode == "random":
            return f"give samples: {fit:,} or fewer"
        return f"give at most {fit:,} entries in runs"

    # ----------------------------------------------------------------- parameters of runs
    def parameter_table(self, start: int, stop: int) -> pd.DataFrame:
        runs = np.arange(start, stop)
        cols: dict[str, Any] = {"run": runs}
        sp = self.spec
        if sp.mode == "grid":
            if sp.parameters:
                idx = (np.unravel_index(runs, self.spec.shape) if runs.size
                       else [np.zeros(0, int)] * len(sp.parameters))
                for a, g, ix in zip(sp.parameters, self._grids, idx):
                    cols[a.name] = _column([g[i] for i in ix])
        elif sp.mode == "list":
            for n in sp.names:
                cols[n] = _column([sp.runs[r][n] for r in runs])
        else:
            rows = []
            for r in runs:
                rng = np.random.default_rng([int(sp.seed), int(r)])
                rows.append([a.sample(rng) for a in sp.parameters])
            for j, a in enumerate(sp.parameters):
                cols[a.name] = _column([row[j] for row in rows])
        return pd.DataFrame(cols)

    def evaluate(self, start: int, stop: int):
        from uuvid.uncertainty.targets import ChunkResult

        table = self.parameter_table(start, stop)
        values = {n: table[n].to_numpy() for n in self.spec.names}
        ev = self.plan.evaluate(values, len(table))
        keep = self.spec.metrics or self.plan.metric_names
        for m in keep:
            table[m] = ev.metrics[m]
        if self.spec.requirement:
            req = self.spec.requirement
            table["requirement_met"] = req.met(ev.metrics[req.metric]) & (ev.status == "ok")
        table["status"] = ev.status
        table["message"] = ev.message
        return ChunkResult(start, stop, table, ev.series)

    def series_axes(self) -> dict:
        from uuvid.uncertainty.targets import series_axes

        return series_axes(self.plan)

    def summarise(self, table: pd.DataFrame, series: dict) -> dict:
        ok = table[table["status"] == "ok"] if len(table) else table
        metrics = self.spec.metrics or [c for c in table.columns if c not in
                                        set(self.spec.names) | {"run", "status", "message",
                                                                "requirement_met"}]
        out: dict = {"target": self.plan.info(), "parameters": self.spec.names,
                     "grid_shape": list(self.spec.shape) if self.spec.mode == "grid" else None,
                     "metrics": {}}
        for m in metrics:
            if m in ok and len(ok):
                x = ok[m].to_numpy(dtype=float)
                x = x[np.isfinite(x)]
                if x.size:
                    out["metrics"][m] = {"min": float(x.min()), "max": float(x.max()),
                                         "mean": float(x.mean()), "unit": metric_unit(m)}
        if self.spec.requirement and len(table):
            out["requirement"] = probability_summary(table, self.spec.requirement)
        if getattr(self, "warnings", None):
            out["warnings"] = list(dict.fromkeys(self.warnings))
        return out


def _column(vals: list) -> np.ndarray:
    if vals and all(isinstance(v, (bool, np.bool_)) for v in vals):
        return np.array(vals, dtype=bool)
    try:
        return np.array(vals, dtype=float)
    except (TypeError, ValueError):
        return np.array(vals, dtype=object)


# ---------------------------------------------------------------------------------------------
# running and reporting
# ---------------------------------------------------------------------------------------------
def run_sweep(spec: SweepSpec | dict | str | Path, out: str | Path | None = None, *, report: bool = True,
              **kw):
    """Run a sweep (spec, a dict like a sweep file, file or built-in name); ``kw`` go to
    :func:`~uuvid.uncertainty.execute.run_study` (``backend``, ``workers``, ``scheduler``, …).
    With ``out``: results, summary, plots and ``index.html`` there."""
    from uuvid.uncertainty.execute import run_study

    if isinstance(spec, dict):  # a sweep file's contents
        spec = sweep_from_dict(spec)
    elif not isinstance(spec, SweepSpec):
        spec = load_sweep(spec)
    study = SweepStudy(spec)
    study.check()
    res = run_study(study, out, **kw)
    if out is not None:
        res.out = Path(out)
        if report:
            res.info["figures"] = write_sweep_report(res, spec, Path(out))
            from uuvid.core.atomic import atomic_write_json

            atomic_write_json(Path(out) / "summary.json", res.info)
    return res


def _fixed_mask(table: pd.DataFrame, spec: SweepSpec, free: list[str], at: dict) -> np.ndarray:
    """Rows where every parameter not in ``free`` sits at ``at`` (or at its grid value nearest the
    middle of its grid)."""
    mask = np.ones(len(table), dtype=bool)
    for a, g in zip(spec.parameters, [a.grid() for a in spec.parameters]):
        if a.name in free or len(g) == 1:
            continue
        if a.name in at:
            v = at[a.name]
        else:
            v = g[len(g) // 2] if not isinstance(g[0], (bool, str)) else g[0]
        col = table[a.name].to_numpy()
        if isinstance(v, (bool, str)):
            mask &= col == v
        else:
            mask &= np.isclose(col.astype(float), float(v), rtol=1e-9, atol=1e-12)
    return mask


def default_plots(spec: SweepSpec, metric_names: list[str]) -> list[PlotSpec]:
    if spec.plots is not None:
        return spec.plots
    if spec.mode != "grid":
        return []
    axes = [a.name for a, g in zip(spec.parameters, [a.grid() for a in spec.parameters])
            if len(g) > 1 and not isinstance(g[0], (bool, str))]
    metrics = (spec.metrics or metric_names)[:3]
    plots: list[PlotSpec] = []
    if len(axes) >= 2:
        for m in metrics:
            plots.append(PlotSpec(kind="heatmap", x=axes[0], y=axes[1], metric=m))
    for ax in axes[:4]:
        plots.append(PlotSpec(kind="line", x=ax, metric=metrics[0],
                              hue=next((a for a in axes if a != ax), None)))
    return plots


def write_sweep_report(res, spec: SweepSpec, out: Path) -> list[str]:
    """Heat maps and line plots (PNG), ``index.html``; returns the figure file names."""
    from uuvid.core.html import Report
    from uuvid.core.plots import new_figure, save_figure

    out.mkdir(parents=True, exist_ok=True)
    table = res.table
    ok = table[table["status"] == "ok"]
    units = {a.name: a.unit for a in spec.parameters if a.unit}

    def shown(name, v):
        u = units.get(name)
        return np.asarray(v, float) / PR.unit_factor(name, u) if u else np.asarray(v, float)

    def label(name):
        u = units.get(name) or PR.si_unit(name)  # values are SI unless the file gives a unit
        return f"{name} [{u}]" if u else name

    rep = Report(f"uuvid sweep — {spec.name}")
    s = res.info
    rep.add_paragraph(
        f"{s['runs']} runs ({', '.join(f'{k}: {v}' for k, v in s['status_counts'].items())}) on the "
        f"{s['backend']} backend in {s['wall_time_s']:.3g} s ({s['runs_per_s']:.4g} runs/s)."
        + (" PARTIAL RESULT." if s.get("partial") else ""))
    if spec.description:
        rep.add_paragraph(spec.description)
    metric_cols = [c for c in (spec.metrics or res.info.get("metrics", {}).keys())]
    files = []
    for k, p in enumerate(default_plots(spec, list(metric_cols))):
        if p.metric not in ok:
            continue
        if p.kind == "heatmap":
            sub = ok[_fixed_mask(ok, spec, [p.x, p.y], p.at)]
            if sub.empty:
                continue
            piv = sub.pivot_table(index=p.y, columns=p.x, values=p.metric, aggfunc="mean")
            fig, ax = new_figure(1, 1, figsize=(7, 5))
            xs, ys = shown(p.x, piv.columns.to_numpy()), shown(p.y, piv.index.to_numpy())
            im = ax.pcolormesh(_edges(xs), _edges(ys), piv.to_numpy(), shading="flat", cmap="viridis")
            fig.colorbar(im, ax=ax, label=metric_label(p.metric))
            ax.set_xlabel(label(p.x))
            ax.set_ylabel(label(p.y))
            ax.set_title(f"{p.metric}")
        else:
            free = [p.x] + ([p.hue] if p.hue else [])
            sub = ok[_fixed_mask(ok, spec, free, p.at)]
            if sub.empty:
                continue
            fig, ax = new_figure(1, 1, figsize=(7, 4.5))
            groups = sub.groupby(p.hue) if p.hue else [(None, sub)]
            for key, g in groups:
                g = g.sort_values(p.x)
                hu = units.get(p.hue) or PR.si_unit(p.hue) if p.hue else ""
                lab = None if key is None else (f"{p.hue} = {shown(p.hue, [key])[0]:.4g}"
                                                + (f" {hu}" if hu else ""))
                ax.plot(shown(p.x, g[p.x].to_numpy()), g[p.metric].to_numpy(), "o-", ms=3, label=lab)
            ax.set_xlabel(label(p.x))
            ax.set_ylabel(metric_label(p.metric))
            ax.set_title(f"{p.metric} vs {p.x}" + (f" per {p.hue}" if p.hue else ""))
            if p.hue:
                ax.legend(fontsize=7, ncol=2)
        fixed = [a.name for a in spec.parameters if a.name not in (p.x, p.y, p.hue)]
        cap = f"{p.kind}: {p.metric} vs {p.x}" + (f" and {p.y}" if p.y else "") + (
            f"; other parameters at mid-grid values ({', '.join(fixed)})" if fixed else "")
        name = f"{p.kind}_{k}_{p.metric}.png".replace("/", "_")
        save_figure(fig, out / name)
        rep.add_figure(out / name, caption=cap)
        files.append(name)
    head = table.head(50)
    rep.add_table(head.to_dict(orient="records"), caption=f"First {len(head)} of {len(table)} "
                  f"runs (all in results.csv)")
    if len(table) and (table["status"] != "ok").any():
        bad = table[table["status"] != "ok"].head(20)
        rep.add_table(bad.to_dict(orient="records"), caption="Runs that did not succeed (first 20)")
    rep.add_json({k: v for k, v in res.info.items() if k != "spec"}, caption="Summary")
    rep.write(out)
    return files


def _edges(c: np.ndarray) -> np.ndarray:
    c = np.asarray(c, dtype=float)
    if c.size == 1:
        return np.array([c[0] - 0.5, c[0] + 0.5])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])


def wilson(k: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion ``k/n`` (95 % by default)."""
    if n == 0:
        return (math.nan, math.nan)
    p = k / n
    den = 1 + z * z / n
    c = (p + z * z / (2 * n)) / den
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return (0.0 if k == 0 else max(0.0, c - h), 1.0 if k == n else min(1.0, c + h))


def probability_summary(table: pd.DataFrame, req: Requirement) -> dict:
    ok = table["status"] == "ok"
    met = table["requirement_met"].eq(True) & ok
    n_ok, k = int(ok.sum()), int(met.sum())
    n_all = len(table)
    lo, hi = wilson(k, n_ok)
    lo2, hi2 = wilson(k, n_all)
    return {"requirement": req.describe(), "runs_simulated": n_ok, "runs_met": k,
            "probability": k / n_ok if n_ok else math.nan, "wilson95": [lo, hi],
            "probability_counting_unsimulated_as_failures": k / n_all if n_all else math.nan,
            "wilson95_counting_unsimulated": [lo2, hi2]}


__all__ = ["Axis", "PlotSpec", "Requirement", "SweepError", "SweepSpec", "SweepStudy",
           "builtin_sweeps", "load_sweep", "run_sweep", "sweep_from_dict", "write_sweep_report"]
