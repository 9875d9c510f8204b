"""Simulation scenarios: a vehicle, a mission, a controller and the sea, in one validated file.

::

    vehicle: bluerov2                 # preset name or vehicle file
    mission:                          # Laidani et al.'s square, or your own waypoints
      kind: square                    # square | waypoints
      depth: 2.0
      side: 10.0
      speed: 0.5                      # omit: 0.5, or slower for a vehicle that tilts past 20°
      # waypoints: [[0, 0, 0, 0], [0, 0, 2, 0], ...]   (north, east, down [m], yaw [rad])
    thruster_model: null              # override every thruster's model (preset or file; with
                                      #   inflow, its propeller map too: t200, t200-physical, or
                                      #   a model file with a four-quadrant inflow section)
    inflow: null                      # none | four-quadrant: override the vehicle file's inflow
                                      #   key (null: the vehicle file's; --inflow overrides both)
    current: [0.0, 0.0, 0.0]          # NED, m/s; or one of
    #   {kind: constant, speed: 0.3, direction_deg: 90}          (flowing towards, 0 = north)
    #   {kind: timeseries, file: current.csv}                     (columns time, north, east[, down])
    #       (no other column, none twice; a series shorter than the flight is held, and warned of)
    # vertical currents (down) within ±1 m/s; depths (mission.depth, waypoints) to 11,000 m
    #   {kind: gauss_markov, mean: 0.3, mu: 0.05, sigma: 0.02, direction_deg: 0, seed: 1}
    allocation: priority              # priority | maxscale | scale | clip | none
    battery_soc: null                 # e.g. 0.8: fly on the vehicle file's battery from 80 % charge
    controller: {bandwidth: [1.5, 1.5, 1.5, 2.0]}      # PID DP: rad/s per surge, sway, heave, yaw
    #   {kp: [...], ki: [...], kd: [...]}      PID gains given (ki/kd need kp; not with bandwidth)
    #   {kind: lqr, weights: {position: 0.1, thrust: 10}}    LQI designed at hover (Bryson's rule)
    #   {kind: python, file: my_ctrl.py, factory: make_controller, options: {...}}
    #       (file relative to this one; make_controller(vehicle, context) returns a Controller,
    #        see uuvid.simulate.control.files)
    dt: 0.01
    substeps: 1
    duration: null                    # default: the mission's length

Errors name the file and the key path (``scenario.yaml: mission.speed: ...``).  A flight whose
time series and output files would take too much memory or disk is refused before it flies, a
large or long one said first (:func:`build`, :mod:`uuvid.simulate.footprint`).
"""

from __future__ import annotations

import reprlib
import typing
from dataclasses import replace
from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from uuvid.core.checks import direction_deg
from uuvid.core.yamltypes import Num, Whole, boolean_message
from uuvid.simulate.reference import (
    WaypointMission,
    cruise_speed,
    current_speed_bound,
    square_mission,
    waypoint_problem,
)
from uuvid.thruster.modelfile import ModelFileError, format_loc, other_kind, read_model_text

_CFG = ConfigDict(extra="forbid", allow_inf_nan=False)


class ScenarioError(ModelFileError):
    """A scenario file is invalid; the message names the file and the key path."""




#: no water is deeper (the Challenger Deep, ≈ 10 935 m): a deeper mission depth is a unit slip (mm,
#: cm) or a typo; vehicle files carry no depth rating to check a mission against
MAX_DEPTH_M = 11000.0
_DEEPER = (f"deeper than the deepest ocean (the Challenger Deep, about 10,935 m; at most "
           f"{MAX_DEPTH_M:,.0f} m): is it in cm or mm? expected metres, positive down")


class MissionSpec(BaseModel):
    model_config = _CFG
    kind: Literal["square", "waypoints"] = "square"
    depth: Num = Field(2.0, ge=0)
    side: Num = Field(10.0, gt=0)
    speed: Num | None = Field(None, gt=0)  # None: :func:`cruise_speed` for the vehicle
    vertical_speed: Num = Field(0.25, gt=0)
    yaw: Literal["path", "fixed"] = "path"
    hold: Num = Field(10.0, ge=0)
    waypoints: list[tuple[Num, Num, Num, Num]] | None = None

    @field_validator("waypoints", mode="before")
    @classmethod
    def _waypoints_rows_of_four(cls, v):
        """Rows of four: a flat list or rows of three were answered one pydantic line per number
        (``mission.waypoints[5]: Input should be a valid tuple``)."""
        if v is None:
            return v
        if not isinstance(v, (list, tuple)):
            raise ValueError(f"expected a list of waypoints [[north, east, down, yaw], ...] (m, m, "
                             f"m, rad); got {reprlib.repr(v)}")
        bad = [k for k, w in enumerate(v) if not isinstance(w, (list, tuple)) or len(w) != 4]
        if bad:
            k = bad[0]
            flat = " (a flat list: give one row per waypoint)" if not isinstance(
                v[k], (list, tuple, dict)) else ""
            more = f"; {len(bad) - 1} more rows like it" if len(bad) > 1 else ""
            raise ValueError(f"waypoint {k}: expected 4 numbers [north, east, down, yaw] (m, m, m, "
                             f"rad; down positive), got {reprlib.repr(v[k])}{flat}{more}")
        return v

    @field_validator("waypoints")
    @classmethod
    def _waypoints_in_water_and_radians(cls, v):
        """A waypoint above the surface (down < −0.5 m: NED, down positive) or a yaw beyond
        ±2π (degrees given) cannot be what the mission means."""
        for k, (_n, _e, d, yaw) in enumerate(v or []):
            why = waypoint_problem(k, d, yaw)
            if why:
                raise ValueError(why)
            if d > MAX_DEPTH_M:
                raise ValueError(f"waypoint {k} is at down = {d:g} m, {_DEEPER}")
        return v

    @field_validator("depth")
    @classmethod
    def _above_the_ocean_floor(cls, v):
        if v > MAX_DEPTH_M:
            raise ValueError(f"{v:g} m is {_DEEPER}")
        return v

    @model_validator(mode="after")
    def _keys_of_kind(self):
        """Keys of the other kind were ignored: waypoints under the default ``kind: square``
        flew the square (and said "completed"); a square's depth or side beside waypoints did
        nothing."""
        if self.kind == "square" and self.waypoints is not None:
            said = "" if "kind" in self.model_fields_set else " (the default)"
            raise ValueError(f"waypoints: given, but kind is 'square'{said}, which flies the "
                             "built-in square and would ignore them: add kind: waypoints")
        if self.kind == "waypoints":
            # by value, not model_fields_set: a sweep's worker re-checks a dump, which writes
            # every field (a square's default depth then read as given and refused every run)
            fields = type(self).model_fields
            extra = [k for k in ("depth", "side", "yaw") if getattr(self, k) != fields[k].default]
            if extra:
                raise ValueError(f"{', '.join(extra)}: only for kind square; a waypoint mission "
                                 "flies its waypoints (north, east, down [m], yaw [rad]) as given")
        return self

    def build(self, vehicle=None, current_speed: float = 0.0) -> WaypointMission:
        """The mission; without ``speed`` the cruising speed is :func:`cruise_speed` for
        ``vehicle`` in a current of ``current_speed`` (the nominal 0.5 m/s without a vehicle),
        and the mission's ``note`` says why."""
        speed, note = (self.speed, "") if self.speed is not None else cruise_speed(
            vehicle, self.kind == "square" and self.yaw == "path", current_speed)
        if self.kind == "square":
            m = square_mission(self.depth, self.side, speed, self.vertical_speed, self.yaw,
                               self.hold)
        else:
            if not self.waypoints or len(self.waypoints) < 2:
                raise ValueError("mission.waypoints: a waypoint mission needs at least two waypoints")
            m = WaypointMission(tuple(tuple(w) for w in self.waypoints), speed=speed,
                                vertical_speed=self.vertical_speed, hold=self.hold, name="waypoints")
        return replace(m, note=note) if note else m


class LqrWeightsSpec(BaseModel):
    """Bryson's rule of :func:`uuvid.simulate.control.lqr.default_weights`."""

    model_config = _CFG
    position: Num = Field(0.1, gt=0)
    yaw: Num = Field(0.1, gt=0)
    tilt: Num = Field(0.5, gt=0)
    speed: Num = Field(0.5, gt=0)
    rate: Num = Field(1.0, gt=0)
    integral: Num = Field(0.5, gt=0)
    thrust: Num = Field(10.0, gt=0)


_Pos = Annotated[Num, Field(gt=0)]
_NonNeg = Annotated[Num, Field(ge=0)]


DEFAULT_BANDWIDTH = (1.5, 1.5, 1.5, 2.0)  # rad/s: surge, sway, heave, yaw of the PID DP


class ControllerSpec(BaseModel):
    model_config = _CFG
    kind: Literal["pid", "lqr", "python"] = "pid"
    # rad/s; None: DEFAULT_BANDWIDTH (not written in, so a dump re-checks as the file it came from)
    bandwidth: tuple[_Pos, _Pos, _Pos, _Pos] | None = None
    kp: tuple[_NonNeg, _NonNeg, _NonNeg, _NonNeg] | None = None
    ki: tuple[_NonNeg, _NonNeg, _NonNeg, _NonNeg] | None = None
    kd: tuple[_NonNeg, _NonNeg, _NonNeg, _NonNeg] | None = None
    weights: LqrWeightsSpec | None = None  # lqr
    file: str | None = None  # python
    factory: str = "make_controller"  # python
    options: dict = Field(default_factory=dict)  # python: handed to the factory

    @model_validator(mode="after")
    def _keys_of_kind(self):
        # what the file gives, by value (not model_fields_set: a dump writes every field, so a
        # sweep's worker re-checking it would see a default bandwidth as given)
        given = {k for k in ("bandwidth", "kp", "ki", "kd") if getattr(self, k) is not None}
        gains = [k for k in ("bandwidth", "kp", "ki", "kd") if k in given]
        if self.kind == "lqr" and gains:  # the LQI flew unchanged: the gains did nothing
            raise ValueError(f"{', '.join(gains)}: only with kind: pid (or python, whose factory "
                             "gets them as context.gains); kind lqr flies the hover LQI from its "
                             "weights (Bryson: weights: {position, yaw, tilt, speed, ...})")
        if self.kp is None and (self.ki is not None or self.kd is not None):
            # without kp the gains are the bandwidth's: ki/kd were dropped, not flown
            raise ValueError(f"{', '.join(k for k in ('ki', 'kd') if k in given)}: given without "
                             "kp; ki/kd need kp (kp, ki, kd: four gains each, surge, sway, heave, "
                             "yaw) — without kp the gains come from bandwidth")
        if self.kp is not None and self.bandwidth is not None:
            raise ValueError("bandwidth and kp are exclusive: bandwidth derives the gains, kp "
                             "(with ki, kd) gives them; keep one")
        if self.kind != "lqr" and self.weights is not None:
            raise ValueError("weights: only for kind lqr")
        if self.kind == "python" and not self.file:
            raise ValueError("file: a python controller needs its file (and factory)")
        if self.kind != "python" and (self.file is not None or self.options):
            raise ValueError("file/options: only for kind python")
        return self


class ConstantCurrentSpec(BaseModel):
    model_config = _CFG
    kind: Literal["constant"]
    speed: Num = Field(ge=0)
    direction_deg: Num = 0.0
    down: Num = 0.0

    @field_validator("direction_deg")
    @classmethod
    def _degrees(cls, v):
        return direction_deg("current.direction_deg", v)

    @field_validator("down")
    @classmethod
    def _vertical(cls, v):
        from uuvid.simulate.currents import vertical_current

        return vertical_current("", v)  # the message's place: current: down:

    def build(self, base):
        from uuvid.simulate.currents import ConstantCurrent, ned

        return ConstantCurrent(tuple(float(x) for x in ned(self.speed, self.direction_deg,
                                                           self.down)))


class TimeSeriesCurrentSpec(BaseModel):
    model_config = _CFG
    kind: Literal["timeseries"]
    file: str

    def build(self, base):
        from uuvid.simulate.currents import TimeSeriesCurrent

        p = Path(self.file)
        if not p.is_absolute() and base is not None:
            p = base / p
        return TimeSeriesCurrent.from_csv(p)


class GaussMarkovCurrentSpec(BaseModel):
    model_config = _CFG
    kind: Literal["gauss_markov"]
    mean: Num = Field(0.3, ge=0)
    mu: Num = Field(0.05, gt=0)
    sigma: Num = Field(0.02, ge=0)
    min: Num = Field(0.0, ge=0)
    max: Num = Field(1.0, ge=0)
    direction_deg: Num = 0.0
    direction_sigma_deg: Num = Field(0.0, ge=0)
    direction_mu: Num = Field(0.05, gt=0)
    seed: Whole = 0

    @field_validator("direction_deg")
    @classmethod
    def _degrees(cls, v):
        return direction_deg("current.direction_deg", v)

    def build(self, base):
        from uuvid.simulate.currents import GaussMarkovCurrent

        # direction_deg checked (and warned of) by this spec's validator, naming the file's key
        return GaussMarkovCurrent._checked(**self.model_dump(exclude={"kind"}))


CurrentSpec = ConstantCurrentSpec | TimeSeriesCurrentSpec | GaussMarkovCurrentSpec


class ScenarioSpec(BaseModel):
    model_config = _CFG
    name: str = "scenario"
    vehicle: str = "bluerov2"
    mission: MissionSpec = MissionSpec()
    thruster_model: str | None = None
    inflow: Literal["none", "four-quadrant"] | None = None  # None: the vehicle file's key
    current: tuple[Num, Num, Num] | CurrentSpec = (0.0, 0.0, 0.0)
    allocation: Literal["priority", "maxscale", "scale", "clip", "none"] = "priority"
    battery_soc: Num | None = Field(None, gt=0, le=1)  # 0: an empty battery flies nothing
    controller: ControllerSpec = ControllerSpec()
    dt: Num = Field(0.01, gt=0, le=0.1)
    substeps: Whole = Field(1, ge=1, le=100)
    duration: Num | None = Field(None, gt=0)

    @field_validator("duration")
    @classmethod
    def _at_least_one_step(cls, v, info):
        """A duration below one step is refused when the file is read, whatever its size: the
        flight's step count took half a step or more as one (0.005 s at dt 0.01 flew 0.01 s)
        and refused less (1e-300 s); a duration above one step that is not a whole number of
        steps is rounded to one, said by :func:`build` (:func:`duration_note`)."""
        dt = info.data.get("dt")  # None: dt itself was refused (said)
        if v is not None and dt is not None and v / dt < 1 - _STEP_TOL:
            raise ValueError(f"{v:g} s is shorter than one step (dt = {dt:g} s); give a duration "
                             "of at least dt")
        return v

    @field_validator("current", mode="before")
    @classmethod
    def _ned_triple(cls, v):
        """A current is three numbers or a mapping of one kind; anything else was answered with
        pydantic's attempts at every member of the union (``current.tuple[float, float,
        float]: Input should be a valid tuple``, ``current.TimeSeriesCurrentSpec.file:
        missing`` for a constant current with a typo'd key)."""
        if isinstance(v, dict):
            kinds = {"constant": ConstantCurrentSpec, "timeseries": TimeSeriesCurrentSpec,
                     "gauss_markov": GaussMarkovCurrentSpec}
            spec = kinds.get(v.get("kind")) if isinstance(v.get("kind"), str) else None
            if spec is None:
                raise ValueError(f"kind: {'missing' if 'kind' not in v else repr(v['kind'])}; "
                                 f"expected one of {', '.join(kinds)} (or three numbers N,E,D "
                                 "in m/s, e.g. [0.3, 0, 0])")
            try:
                return spec.model_validate(v)
            except ValidationError as e:
                errs = e.errors()
                keys = (f" (a {v['kind']} current's keys: {', '.join(spec.model_fields)})"
                        if any(err["type"] == "extra_forbidden" for err in errs) else "")
                raise ValueError("; ".join(
                    f"{format_loc(err['loc'])}: "
                    + {"missing": "missing", "extra_forbidden": "unknown key"}.get(
                        err["type"], err["msg"].removeprefix("Value error, "))
                    for err in errs) + keys) from None
        if not isinstance(v, (list, tuple, BaseModel)):
            raise ValueError(f"expected N,E,D (m/s): a list of three numbers, the water velocity "
                             f"north, east, down (where it flows to), e.g. [0.3, 0, 0], or a "
                             f"mapping such as {{kind: constant, speed: 0.3, direction_deg: 90}}; "
                             f"got {reprlib.repr(v)}")
        if isinstance(v, (list, tuple)):
            for i, x in enumerate(v[:3]):  # else pydantic's union: every member's attempt
                if isinstance(x, bool):
                    raise ValueError(f"item {i} ({('north', 'east', 'down')[i]}, m/s): "
                                     + boolean_message(x))
            try:
                ok = len(v) == 3 and all(float(x) == float(x) for x in v)
            except (TypeError, ValueError):
                ok = False
            if not ok:
                raise ValueError(f"expected N,E,D (m/s): three numbers, the water velocity "
                                 f"north, east, down (where it flows to), e.g. [0.3, 0, 0]; got "
                                 f"{reprlib.repr(list(v))}")
            from uuvid.simulate.currents import vertical_current

            vertical_current("down", v[2])  # the horizontal speed is bounded at build
        return v


#: A duration within this fraction of a step of a whole number of steps is that number.
_STEP_TOL = 1e-9


def duration_note(duration: float, dt: float, steps: int) -> str | None:
    """The note for a ``duration`` that is not a whole number of steps of ``dt``: the flight
    takes ``steps`` (its step count, rounded) and flies ``steps·dt``; ``None`` when it is one."""
    n = duration / dt
    if abs(n - round(n)) <= _STEP_TOL * max(1.0, n):
        return None
    return (f"duration = {duration:g} s is not a whole number of steps (dt = {dt:g} s): the "
            f"flight takes {steps} step{'s' if steps != 1 else ''} and flies {steps * dt:g} s")


def _a_value(v) -> str:
    """``a list (1 item)``, ``the text 'square'``, ``the number 3``: a value as a message names
    it (the YAML kinds, not Python's class names)."""
    if isinstance(v, bool):
        return f"{str(v).lower()} (a yes/no value)"
    if isinstance(v, (int, float)):
        return f"the number {v!r}"
    if isinstance(v, str):
        return f"the text {reprlib.repr(v)}"
    if isinstance(v, (list, tuple)):
        return f"a list ({len(v)} item{'s' if len(v) != 1 else ''})"
    return f"a {type(v).__name__}"


def _not_a_mapping(err) -> str:
    """pydantic's ``Input should be a valid dictionary or instance of MissionSpec`` for a
    section given as something else: which keys it takes, and for a word that is one of its
    kinds (``mission: square``) how to write it."""
    spec = ScenarioSpec
    for part in err["loc"]:
        field = spec.model_fields.get(part) if isinstance(part, str) else None
        ann = field.annotation if field is not None else None
        models = [a for a in (ann, *typing.get_args(ann))  # LqrWeightsSpec | None
                  if isinstance(a, type) and issubclass(a, BaseModel)]
        spec = models[0] if models else spec
    key, v = format_loc(err["loc"]), err["input"]
    keys = ", ".join(f"{k}:" for k in list(spec.model_fields)[:4])
    kind = spec.model_fields.get("kind")
    hint = ""
    if kind is not None and isinstance(v, str) and v in getattr(kind.annotation, "__args__", ()):
        hint = f"; for that {key}, write {key}: {{kind: {v}}}"
    return f"expected a mapping of keys ({keys} …), got {_a_value(v)}{hint}"


def scenario_from_dict(raw, where: str = "<scenario>") -> ScenarioSpec:
    if raw is not None and not isinstance(raw, (dict, BaseModel)):  # pydantic: "ScenarioSpec"
        hint = (" — drop the leading '- ' (a YAML list item) and write its keys at the top level"
                if isinstance(raw, list) and raw and isinstance(raw[0], dict) else "")
        raise ScenarioError(f"{where}: a scenario file is a mapping of keys (vehicle:, mission:, "
                            f"duration:, …), got {_a_value(raw)}{hint}")
    try:
        return ScenarioSpec.model_validate(raw if raw is not None else {})
    except ValidationError as e:
        kind = other_kind(raw, "a scenario file")
        if kind:
            raise ScenarioError(f"{where}: not a scenario file: it looks like {kind}; a scenario "
                                f"file has {', '.join(ScenarioSpec.model_fields)} (all optional: "
                                "a vehicle flying its mission)") from None
        msgs = [f"{where}: {format_loc(err['loc'])}: "
                + (_not_a_mapping(err) if err["type"] == "model_type" else
                   {"missing": "missing", "extra_forbidden": "unknown key"}.get(
                       err["type"], err["msg"].removeprefix("Value error, ")))
                for err in e.errors()]
        raise ScenarioError("\n".join(msgs)) from None


def load_scenario(path: str | Path) -> ScenarioSpec:
    raw = read_model_text(path)
    if raw is None:  # an empty file: a scenario saved empty is a mistake, not "all defaults"
        raise ScenarioError(f"{path}: the file is empty; expected a mapping (vehicle, mission, "
                            "duration, …) — `uuvid simulate mission square` flies the defaults")
    return scenario_from_dict(raw, where=str(path))


def _inflow_of(spec: ScenarioSpec, inflow: str | None) -> tuple[str | None, str]:
    """The inflow override in force (``None``: the vehicle file's key) and where it comes from:
    ``inflow`` (the command line's ``--inflow``), else the scenario's ``inflow`` key, else the
    vehicle file."""
    if inflow is not None:
        return inflow, "option"
    if spec.inflow is not None:
        return spec.inflow, "scenario file"
    return None, "vehicle file"


def _thruster_model_propeller(spec: ScenarioSpec, base: Path | None, vehicle, source: str) -> str:
    """The preset or (absolute) model file whose four-quadrant map the scenario's
    ``thruster_model`` flies with inflow on: it replaces the vehicle's thrusters, propellers
    included.  A model without a map is an error saying where inflow was switched on."""
    from uuvid.thruster.resolve import is_preset
    from uuvid.vehicle.inflow import KNOWN_PROPELLERS, thruster_map

    ref = spec.thruster_model
    if not is_preset(ref):
        ref = str((Path(ref) if base is None or Path(ref).is_absolute() else base / ref).resolve())
    try:
        thruster_map(ref)
    except KeyError:
        off = {"option": "leave out --inflow four-quadrant",
               "scenario file": "set the scenario's inflow: none",
               "vehicle file": f"the vehicle file ({vehicle.name}) has inflow: {vehicle.inflow} — "
                               "set inflow: none in the scenario (--inflow none on the command "
                               "line)"}[source]
        raise ScenarioError(f"thruster_model (--thruster-model) {spec.thruster_model!r}: inflow "
                            f"{vehicle.inflow} flies the propeller map of the thruster model that "
                            f"replaces the vehicle's, and {spec.thruster_model!r} holds none "
                            f"(known: {KNOWN_PROPELLERS}); {off}, or give a thruster model with "
                            "a map") from None
    except (OSError, ModelFileError, ValueError) as e:
        raise ScenarioError(f"thruster_model: {e}") from None
    return ref


def _largest(model, key: str) -> float | None:
    """The ``le`` bound of a field (``dt``: 0.1 s), or ``None``."""
    return next((float(m.le) for m in model.model_fields[key].metadata
                 if getattr(m, "le", None) is not None), None)


def _model_ref(ref: str, base: Path | None) -> str:
    """``'../q.yaml' (model file /abs/q.yaml)`` for a model file (relative to ``base``, the
    scenario's folder), ``'t200' (preset)`` for a preset."""
    from uuvid.thruster.resolve import is_preset

    if is_preset(ref):
        return f"{ref!r} (preset)"
    p = Path(ref) if base is None or Path(ref).is_absolute() else base / ref
    return f"{ref!r} (model file {p.resolve()})"


def build(spec: ScenarioSpec, base: Path | None = None, inflow: str | None = None,
          out: str | Path | None = None, time_series: bool = True):
    """Vehicle, mission setup (see :func:`uuvid.simulate.vehicle_sim.setup_mission`).

    ``out``: the folder the flight's outputs will be written to
    (:func:`uuvid.simulate.mission_report.write_mission_outputs`), or ``None``.  A flight whose
    time series (and outputs) would take more memory than one flight may, or more disk than
    ``out`` has free, is refused here, before it flies; a large or long one is said with an
    :class:`~uuvid.core.checks.InputWarning` (:func:`uuvid.simulate.footprint.check_footprint`);
    ``time_series=False`` for a setup that flies batches (their runs keep summary rows only).

    ``inflow`` (the command line's ``--inflow``) overrides the scenario's ``inflow`` key, which
    overrides the vehicle file's (:func:`uuvid.vehicle.definition.load_vehicle`); the flight's
    metrics say which was in force and where it came from (``inflow``, ``inflow_source``).
    With inflow on, a ``thruster_model`` flies its own propeller map (t200, t200-physical, or a
    model file with a four-quadrant ``inflow`` section)."""
    from uuvid.simulate.control.files import (
        ControllerContext,
        ControllerFileError,
        make_controller,
    )
    from uuvid.simulate.control.pid import DPGains
    from uuvid.simulate.vehicle_sim import default_gains, setup_mission, step_count
    from uuvid.vehicle.definition import list_presets, load_vehicle

    vref = spec.vehicle
    if vref not in list_presets() and base is not None and not Path(vref).is_absolute():
        vref = str(base / vref)
    mode, source = _inflow_of(spec, inflow)
    vehicle = load_vehicle(vref, inflow=mode)
    if len(vehicle.layout) == 0:
        raise ScenarioError(f"vehicle {vehicle.name!r} has no thrusters: nothing can fly a mission "
                            "(add a thrusters list to its file)")
    chain = propeller = None
    if spec.thruster_model:
        from uuvid.thruster.resolve import resolve_chain

        try:
            chain = resolve_chain(spec.thruster_model, base)
        except FileNotFoundError as e:
            raise ScenarioError(f"thruster_model: {e}") from None
        if chain.input_kind == "speed":  # here, not in setup_mission: it named neither this key
            # nor the file, and blamed the vehicle file
            raise ScenarioError(
                f"thruster_model: {_model_ref(spec.thruster_model, base)} takes the propeller speed "
                "(rad/s) as its input, not a command, so a mission cannot drive the thrusters with "
                "it (a fit of thrust against propeller speed, e.g. a four-quadrant map fitted on a "
                "bench in a flow); give a command-driven model instead (e.g. t200, or a "
                "fit against the command), and to fly this file's four-quadrant map name it as "
                "each thruster's propeller: in the vehicle file (with inflow: four-quadrant)")
        if vehicle.inflow != "none":  # the replacing model's map, for the mission's speed too
            propeller = _thruster_model_propeller(spec, base, vehicle, source)
            vehicle = replace(vehicle, propellers=(propeller,) * len(vehicle.layout))
    c = spec.controller
    try:
        if c.kp is not None:
            g0 = default_gains(vehicle)
            gains = DPGains(c.kp, c.ki or (0.0,) * 4, c.kd or (0.0,) * 4, g0.tau_max, g0.i_limit)
        else:
            gains = default_gains(vehicle, omega=c.bandwidth or DEFAULT_BANDWIDTH)
    except ValueError as e:
        raise ScenarioError(f"{spec.name}: controller: {e}") from None
    cur = spec.current
    if hasattr(cur, "build"):
        try:
            cur = cur.build(base)
        except (ValueError, OSError) as e:
            raise ScenarioError(f"current: {e}") from None
    from uuvid.core.checks import current_speed

    try:
        mission = spec.mission.build(vehicle, current_speed("current", current_speed_bound(cur)))
    except ValueError as e:
        raise ScenarioError(str(e)) from None
    try:
        ctx = ControllerContext(spec.dt, gains, mission, dict(c.options))
        controller = make_controller(c.kind, vehicle, ctx, file=c.file, factory=c.factory,
                                     base=base, lqr_weights=c.weights.model_dump() if c.weights
                                     else None)
    except ControllerFileError as e:
        raise ScenarioError(f"{spec.name}: controller: {e}") from None
    try:
        steps = step_count(spec.duration if spec.duration is not None else mission.duration,
                           spec.dt, "duration", "dt")
    except ValueError as e:
        hint = ("" if spec.duration is not None else " (duration not given: the mission's "
                "length, from its waypoints or side and its speed; shorten the mission)")
        raise ScenarioError(f"{spec.name}: {e}{hint}") from None
    rounded = duration_note(spec.duration, spec.dt, steps) if spec.duration is not None else None
    if rounded:  # a note, as a current series shorter than the flight is (below): it flies
        import warnings

        from uuvid.core.checks import InputWarning

        warnings.warn(rounded, InputWarning, stacklevel=2)
    if hasattr(cur, "coverage_note"):  # a measured series shorter than the flight: held, said
        import warnings

        from uuvid.core.checks import InputWarning

        note = cur.coverage_note(spec.duration if spec.duration is not None else mission.duration)
        if note:
            warnings.warn(f"current: {note}", InputWarning, stacklevel=2)
    try:
        setup = setup_mission(vehicle, mission, dt=spec.dt, substeps=spec.substeps, gains=gains,
                              thruster_chain=chain, current=cur, t_end=spec.duration,
                              allocation=spec.allocation,
                              battery=True if spec.battery_soc is not None else None,
                              soc0=1.0 if spec.battery_soc is None else spec.battery_soc,
                              controller=controller, inflow=vehicle.inflow,
                              inflow_source=source, propeller=propeller)
    except ValueError as e:
        raise ScenarioError(f"{spec.name}: {e}") from None
    if not time_series:
        return vehicle, setup
    import warnings

    from uuvid.core.checks import InputWarning
    from uuvid.simulate.footprint import check_footprint

    try:  # rows × columns and the output files, not the step count alone
        said = check_footprint(setup, out, duration_name="duration" if spec.duration is not None
                               else "the mission's length",
                               max_dt=_largest(ScenarioSpec, "dt"))
    except ValueError as e:
        raise ScenarioError(str(e)) from None
    for w in said:
        warnings.warn(w, InputWarning, stacklevel=2)
    return vehicle, setup
