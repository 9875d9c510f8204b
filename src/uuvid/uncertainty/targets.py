"""What a sweep or a Monte Carlo run simulates, and how one chunk of runs is evaluated.

Three targets, each a pydantic model (the ``target:`` block of a sweep file) and a *plan* that
evaluates a batch of parameter rows with the batched compiled simulators:

``thruster_step``
    A step (any signal) on a thruster chain: McLean's step metrics per run (peak output thrust,
    max true thrust, steady thrust and speed, time to peak, 63.2 % speed time constant, 36.8 %
    decay time constant, final thrust), SI.  All runs of a chunk go through one parallel compiled
    call (:mod:`uuvid.uncertainty._kernels`, the chain's own RK4).
``thruster_steady``
    The steady thrust-vs-command curve of a :class:`~uuvid.thruster.physical.PhysicalModel` at
    one or more supply voltages (series per run, for prediction bands), plus full-command thrust.
``vehicle_mission``
    A vehicle flying a mission (a scenario, :mod:`uuvid.simulate.scenario`) through
    ``uuvid.simulate.batch.run_batch_fast`` when it exists, else
    :func:`uuvid.simulate.vehicle_sim.run_batch`: max/RMS/final tracking error, max thrust, min
    allocation scale per run; optionally the 1-DOF velocity response (Caccia's eq. 3 with the run's
    inertia and drag) as a series per run, for a velocity band.

A plan never raises for a bad *value*: the run gets status ``invalid`` and a message naming the
parameter; a non-finite simulation gets ``diverged``.  Bad *names* raise
:class:`~uuvid.uncertainty.params.ParameterNameError` when the plan is built.
"""

from __future__ import annotations

import json
import math
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from uuvid.core.checks import memory_budget_bytes, physical_memory_bytes
from uuvid.core.yamltypes import Num, Whole
from uuvid.simulate.scenario import ScenarioSpec
from uuvid.thruster.blocks import ParameterError
from uuvid.uncertainty import params as PR

_CFG = ConfigDict(extra="forbid", allow_inf_nan=False)

OK, INVALID, DIVERGED, FAILED, REJECTED = "ok", "invalid", "diverged", "failed", "rejected"


# ---------------------------------------------------------------------------------------------
# target descriptions
# ---------------------------------------------------------------------------------------------
class ThrusterStepTarget(BaseModel):
    """A thruster chain under a step (or any signal); McLean's step metrics per run."""

    model_config = _CFG
    kind: Literal["thruster_step"] = "thruster_step"
    chain: str = "auv2-tunnel"
    preset_kwargs: dict[str, Any] = Field(default_factory=dict)
    #: default: the chain's own step, as ``thruster simulate`` takes (neutral → full forward µs
    #: for a PWM ESC, 0 → 24 V for a voltage input; :func:`uuvid.simulate.signals.default_step`)
    signal: dict[str, Any] | None = None
    t_end: Num = Field(1.333, gt=0)
    dt: Num = Field(1e-3, gt=0)
    substeps: Whole = Field(4, ge=1, le=1000)
    steady_window: Num = Field(0.1, gt=0, le=1)


class ThrusterSteadyTarget(BaseModel):
    """Steady thrust vs command of a physical thruster model at given supply voltages."""

    model_config = _CFG
    kind: Literal["thruster_steady"] = "thruster_steady"
    physical_model: dict[str, Any]
    supply_voltages: list[Num] = Field(default_factory=lambda: [16.0], min_length=1)
    commands: list[Num] | None = None  # default: 81 points from full reverse to full forward
    n_commands: Whole = Field(81, ge=3, le=5000)


class VelocityResponse(BaseModel):
    """1-DOF velocity step response (Caccia eq. 3) from each run's inertia and drag."""

    model_config = _CFG
    dof: Literal["surge", "sway", "heave", "roll", "pitch", "yaw"] = "surge"
    force: Num = 10.0
    t_end: Num = Field(5.0, gt=0)
    dt: Num = Field(0.02, gt=0)


class VehicleMissionTarget(BaseModel):
    """A vehicle scenario (vehicle, mission, controller, current) flown per run."""

    model_config = _CFG
    kind: Literal["vehicle_mission"] = "vehicle_mission"
    scenario: ScenarioSpec = Field(default_factory=ScenarioSpec)
    velocity_response: VelocityResponse | None = None
    simulator: Literal["auto", "fast", "reference"] = "auto"


Target = Annotated[ThrusterStepTarget | ThrusterSteadyTarget | VehicleMissionTarget,
                   Field(discriminator="kind")]


def resolve_paths(target, base: Path | None):
    """Make file references in a target absolute (workers may run elsewhere)."""
    if base is None:
        return target
    if isinstance(target, ThrusterStepTarget):
        from uuvid.thruster.presets import PRESETS

        if target.chain not in PRESETS and not Path(target.chain).is_absolute():
            return target.model_copy(update={"chain": str((base / target.chain).resolve())})
    if isinstance(target, VehicleMissionTarget):
        from uuvid.vehicle.definition import list_presets

        sc = target.scenario
        upd = {}
        if sc.vehicle not in list_presets() and not Path(sc.vehicle).is_absolute():
            upd["vehicle"] = str((base / sc.vehicle).resolve())
        if sc.thruster_model:
            from uuvid.thruster.resolve import is_preset

            if not is_preset(sc.thruster_model) and not Path(sc.thruster_model).is_absolute():
                upd["thruster_model"] = str((base / sc.thruster_model).resolve())
        if upd:
            return target.model_copy(update={"scenario": sc.model_copy(update=upd)})
    return target


#: SI unit of every metric a target gives (for labels)
METRIC_UNITS = {
    "peak_output_thrust": "N", "max_true_thrust": "N", "steady_thrust": "N", "steady_speed": "rad/s",
    "time_to_peak": "s", "time_constant_speed": "s", "time_constant_decay": "s", "final_thrust": "N",
    "max_tracking_error_m": "m", "rms_tracking_error_m": "m", "max_thrust_N": "N",
    "final_position_error_m": "m", "min_allocation_scale": "1",
}


def metric_unit(name: str) -> str:
    """SI unit of a metric (``""`` unknown), or of a parameter column (:func:`~uuvid.uncertainty.
    params.si_unit`) — what a table or label of a study's results prints beside it."""
    return (METRIC_UNITS.get(name)
            or ("N" if name.startswith(("max_thrust_", "min_thrust_")) else "")
            or PR.si_unit(name))


def metric_label(name: str) -> str:
    u = metric_unit(name)
    return f"{name} [{u}]" if u else name


# ---------------------------------------------------------------------------------------------
# evaluation result of one batch
# ---------------------------------------------------------------------------------------------
@dataclass
class Evaluation:
    """Metrics (name → (R,) array), status and message per run, series (name → (R, n))."""

    metrics: dict[str, np.ndarray]
    status: np.ndarray
    message: np.ndarray
    series: dict[str, np.ndarray] = field(default_factory=dict)


#: Most input samples (8 bytes each: 128 MB) a ``thruster_step`` plan holds at once — the input
#: of every run with its own signal, e.g. a swept voltage; a chunk whose runs would hold more is
#: evaluated in parts (a 2,500-run chunk of 2 M-sample runs held 40 GB).
MAX_INPUT_SAMPLES = 16_000_000


def _values_at(values: dict[str, np.ndarray], r: int) -> dict[str, Any]:
    return {k: (v[r].item() if hasattr(v[r], "item") else v[r]) for k, v in values.items()}


# ---------------------------------------------------------------------------------------------
# thruster step
# ---------------------------------------------------------------------------------------------
class ThrusterStepPlan:
    """Evaluates ``thruster_step`` runs; see the module docstring."""

    def __init__(self, target: ThrusterStepTarget, names: list[str]):
        import inspect

        from uuvid.simulate.signals import signal_from_spec
        from uuvid.thruster import presets
        from uuvid.thruster.chain import _n_samples
        from uuvid.thruster.modelfile import load_chain
        from uuvid.uncertainty._kernels import STEP_METRICS

        # the simulate command's RK4-step limit, and a run's input within what a chunk holds
        # (:data:`MAX_INPUT_SAMPLES`, 8 bytes a sample: a run keeps no channels), before the time
        # grid is allocated (a t_end of 1e9 s at 1 ms was a MemoryError of 7 TiB)
        n_t = _n_samples(target.t_end, target.dt, target.substeps,
                         names=("target.t_end", "target.dt", "target.substeps"),
                         max_samples=MAX_INPUT_SAMPLES, sample_bytes=8)
        self.target = target
        self.factory = presets.PRESETS.get(target.chain)
        if self.factory is None:
            path = Path(target.chain)
            if not path.is_file():
                raise PR.ParameterNameError(
                    f"chain {target.chain!r} is neither a thruster preset "
                    f"({', '.join(sorted(presets.PRESETS))}) nor a model file")
            fixed = load_chain(path)
            self.factory = lambda **kw: fixed
            if target.preset_kwargs:
                raise PR.ParameterNameError("preset_kwargs only apply to preset chains")
        kwargs = self._factory_kwargs(inspect)
        unknown = sorted(set(target.preset_kwargs) - set(kwargs or ()))
        if unknown:
            raise PR.ParameterNameError(
                f"target.preset_kwargs: unknown keyword(s) {', '.join(map(repr, unknown))} for the "
                f"preset {target.chain!r}; it takes {', '.join(sorted(kwargs or [])) or 'none'}")
        try:
            self.base = self.factory(**target.preset_kwargs)
        except ParameterError as e:
            raise ValueError(f"target.preset_kwargs{'.' + e.param if e.param else ''}: {e}") from None
        if target.signal is None:  # a 24 V step was a 24 µs command (full reverse) to an ESC
            from uuvid.simulate.signals import default_step

            d = default_step(self.base)
            self.signal_spec = {"kind": "step", "amplitude": d.amplitude, "t0": d.t0,
                                "baseline": d.baseline}
        else:
            self.signal_spec = dict(target.signal)
        self.base_signal = signal_from_spec(self.signal_spec)
        self.kind_of: dict[str, tuple[str, str]] = {}
        for n in names:
            if n.startswith("signal."):
                self.kind_of[n] = ("signal", n[len("signal."):])
            elif n in ("voltage", "command", "amplitude") and self.signal_spec.get("kind") == "step":
                if n != "amplitude" and self.base.input_kind != n:
                    raise PR.ParameterNameError(
                        f"{n!r}: the chain {self.base.name} is driven by {self.base.input_kind}")
                self.kind_of[n] = ("signal", "amplitude")
            elif PR.parse_block_name(n):
                i, path = PR.parse_block_name(n)
                if i >= len(self.base.blocks):
                    raise PR.ParameterNameError(f"{n}: the chain has {len(self.base.blocks)} blocks")
                PR.set_block_field(self.base.blocks[i], path, _current(self.base.blocks[i], path))
                self.kind_of[n] = ("block", n)
            elif n.startswith("preset.") or n in kwargs:
                key = n[len("preset."):] if n.startswith("preset.") else n
                if kwargs is not None and key not in kwargs:
                    takes = ", ".join(sorted(kwargs)) or "no keywords"
                    raise PR.ParameterNameError(f"{n}: the preset {target.chain!r} takes {takes}")
                self.kind_of[n] = ("preset", key)
            else:
                raise PR.ParameterNameError(
                    f"unknown thruster parameter {n!r}: use blocks[i].field, preset.<keyword> "
                    f"({', '.join(sorted(kwargs or []))}), signal.<field> or voltage/command")
        # channels the chain records (measured thrust? propeller speed?)
        probe = self.base.simulate(self.base_signal, 5 * target.dt, dt=target.dt, substeps=1)
        self.use_meas = "measured_thrust" in probe.channels
        self.use_speed = "prop_speed" in probe.channels
        self.t = np.arange(n_t) * target.dt
        start = self.t[-1] - target.steady_window * (self.t[-1] - self.t[0])
        self.k0 = int(np.flatnonzero(self.t >= start)[0])
        self.t_window = float(start)
        self.metric_names = list(STEP_METRICS)
        self._chains: dict = {}
        self._signals: dict = {}

    def input_warnings(self, values: dict[str, list]) -> list[str]:
        """What ``thruster simulate`` warns of the input (a command outside the pulse widths an
        ESC takes, a voltage no small thruster runs on), for the base signal and every swept
        signal value (``values``: parameter name → its values)."""
        from uuvid.simulate.signals import signal_from_spec
        from uuvid.thruster.blocks import ESC
        from uuvid.thruster.chain import command_range_warnings, voltage_range_warnings

        t = np.linspace(0.0, float(self.t[-1]), 1001)
        specs = [self.signal_spec]
        for n, vals in values.items():
            kind, key = self.kind_of.get(n, ("", ""))
            if kind == "signal":
                specs += [{**self.signal_spec, key: v} for v in vals]
        u = []
        for spec in specs:
            try:
                u.append(np.asarray(signal_from_spec(spec)(t), float))
            except Exception:  # noqa: BLE001 - the run says what is wrong with its signal
                continue
        if not u:
            return []
        u = np.concatenate(u)
        esc = next((b for b in self.base.blocks if isinstance(b, ESC)), None)
        out = voltage_range_warnings(u, self.base)
        if esc is not None:
            out += command_range_warnings(u, esc, self.base.channel_units().get("command", ""))
        return out

    def _factory_kwargs(self, inspect) -> set[str] | None:
        from uuvid.thruster import presets

        f = presets.PRESETS.get(self.target.chain)
        if f is None:
            return set()
        if f is presets.auv2_rig_chain or f is presets.auv2_tunnel_chain:
            f = presets.auv2_tunnel_thruster  # **thruster_kwargs
        return {p for p, v in inspect.signature(f).parameters.items()
                if v.kind in (v.POSITIONAL_OR_KEYWORD, v.KEYWORD_ONLY)}

    def chain_for(self, run_values: dict[str, Any]):
        pk = dict(self.target.preset_kwargs)
        bk = {}
        for n, v in run_values.items():
            kind, key = self.kind_of[n]
            if kind == "preset":
                pk[key] = v
            elif kind == "block":
                bk[key] = v
        ck = (tuple(sorted(pk.items(), key=lambda kv: kv[0])), tuple(sorted(bk.items())))
        got = self._chains.get(ck)
        if got is None:
            try:
                chain = self.factory(**pk)
                chain = PR.apply_block_values(chain, bk)
                got = (chain, chain.compile(), "")
            except (ParameterError, ValueError, TypeError) as e:
                got = (None, None, str(e))
            if len(self._chains) > 50000:
                self._chains.clear()
            self._chains[ck] = got
        return got

    def signal_for(self, run_values: dict[str, Any]):
        from uuvid.simulate.signals import signal_from_spec

        spec = dict(self.signal_spec)
        for n, v in run_values.items():
            kind, key = self.kind_of[n]
            if kind == "signal":
                spec[key] = v
        sk = tuple(sorted(spec.items()))
        got = self._signals.get(sk)
        if got is None:
            try:
                sig = signal_from_spec(spec)
                u = np.asarray(sig(self.t), dtype=float)
                got = (u, "" if np.all(np.isfinite(u)) else "input signal is not finite")
            except (ValueError, TypeError) as e:
                got = (None, f"signal: {e}")
            if len(self._signals) * self.t.size >= MAX_INPUT_SAMPLES:
                self._signals.clear()
            self._signals[sk] = got
        return got

    def evaluate(self, values: dict[str, np.ndarray], nrun: int) -> Evaluation:
        part = max(1, MAX_INPUT_SAMPLES // self.t.size)  # runs whose inputs fit at once
        if nrun <= part:
            return self._evaluate(values, nrun)
        parts = [self._evaluate({k: v[a:a + part] for k, v in values.items()}, min(part, nrun - a))
                 for a in range(0, nrun, part)]
        return Evaluation({m: np.concatenate([e.metrics[m] for e in parts]) for m in parts[0].metrics},
                          np.concatenate([e.status for e in parts]),
                          np.concatenate([e.message for e in parts]))

    def _evaluate(self, values: dict[str, np.ndarray], nrun: int) -> Evaluation:
        from uuvid.thruster.kernels import parallel_pays
        from uuvid.uncertainty import _kernels

        status = np.full(nrun, OK, dtype=object)
        message = np.full(nrun, "", dtype=object)
        OUT = np.full((nrun, _kernels.N_METRICS), np.nan)
        groups: dict = {}
        urows: dict = {}
        U_list: list = []
        for r in range(nrun):
            rv = _values_at(values, r)
            chain, comp, err = self.chain_for(rv)
            if chain is None:
                status[r], message[r] = INVALID, err
                continue
            u, serr = self.signal_for(rv)
            if serr:
                status[r], message[r] = INVALID, serr
                continue
            uk = id(u)
            if uk not in urows:
                urows[uk] = len(U_list)
                U_list.append(u)
            skey = (comp.kinds.tobytes(), comp.poff.tobytes(), comp.soff.tobytes(),
                    comp.exact.tobytes(), comp.outch.tobytes(), comp.in_ch)
            g = groups.setdefault(skey, {"comp": comp, "n": chain.n_states, "rows": [],
                                         "P": [], "u": []})
            g["rows"].append(r)
            g["P"].append(comp.params)
            g["u"].append(urows[uk])
        if U_list:
            U = np.ascontiguousarray(np.stack(U_list))
            tg = self.target
            for g in groups.values():
                c = g["comp"]
                rows = np.array(g["rows"])
                P = np.ascontiguousarray(np.stack(g["P"]))
                out = np.empty((rows.size, _kernels.N_METRICS))
                fin = np.empty(rows.size, dtype=np.bool_)
                steps = U.shape[1] * int(tg.substeps)
                run = (_kernels.step_metrics_batch if parallel_pays(rows.size, steps)
                       else _kernels.step_metrics_serial)
                run(c.kinds, c.poff, P, c.soff, c.outch, c.in_ch, c.exact,
                    np.zeros(g["n"]), U, np.asarray(g["u"], dtype=np.int64),
                    float(tg.dt), int(tg.substeps), self.t, self.k0, self.t_window,
                    self.use_meas, self.use_speed, out, fin)
                OUT[rows] = out
                bad = rows[~fin]
                status[bad] = DIVERGED
                message[bad] = (f"the state left the finite numbers (step dt/substeps = "
                                f"{tg.dt / tg.substeps:.3g} s too large?)")
        return Evaluation({n: OUT[:, j] for j, n in enumerate(self.metric_names)}, status, message)

    def info(self) -> dict:
        return {"chain": self.base.name, "signals": list(self.base.signal_kinds),
                "input": self.base_signal.describe(),
                "parameters_of_base": self.base.compile().params.size,
                "output_metric_of": "measured_thrust" if self.use_meas else "thrust",
                "simulator": ("uuvid.uncertainty._kernels.step_metrics_batch (chain RK4; "
                              "step_metrics_serial for small batches)")}


def _current(block, path: str):
    obj = block
    for part in path.split("."):
        if not hasattr(obj, part):
            names = sorted(f for f in getattr(obj, "__dataclass_fields__", {}))
            raise PR.ParameterNameError(f"{getattr(obj, 'TYPE', type(obj).__name__)} has no "
                                        f"parameter {part!r}; it has {', '.join(names)}")
        obj = getattr(obj, part)
    return obj


# ---------------------------------------------------------------------------------------------
# thruster steady (physical model)
# ---------------------------------------------------------------------------------------------
PHYSICAL_NAMES = {"K_e": "back_emf_constant", "R": "resistance", "K_Q_fwd": "kq_fwd",
                  "K_Q_rev": "kq_rev", "K_T_fwd": "kt_fwd", "K_T_rev": "kt_rev",
                  "curvature_fwd": "curvature_fwd", "curvature_rev": "curvature_rev",
                  "c_v": "viscous", "T_c": "coulomb", "full_fwd": "full_fwd", "full_rev": "full_rev",
                  "deadband_fwd": "edge_fwd", "deadband_rev": "edge_rev"}


class ThrusterSteadyPlan:
    def __init__(self, target: ThrusterSteadyTarget, names: list[str]):
        from dataclasses import fields

        from uuvid.thruster.physical import PhysicalModel

        self.target = target
        fnames = {f.name for f in fields(PhysicalModel)}
        unknown = sorted(set(target.physical_model) - fnames)
        if unknown:
            raise PR.ParameterNameError(
                f"base.physical_model: unknown key(s) {', '.join(map(repr, unknown))}; expected "
                f"the fields of a thruster physical fit: {', '.join(sorted(fnames))}")
        self.base = PhysicalModel(**target.physical_model)
        known = set(PHYSICAL_NAMES) | {f.name for f in fields(PhysicalModel)
                                       if f.name not in ("command_unit", "neutral")}
        PR.check_names(names, sorted(known), "thruster_steady")
        self.names = names
        b = self.base
        self.commands = (np.asarray(target.commands, float) if target.commands
                         else np.linspace(b.full_rev, b.full_fwd, target.n_commands))
        self.metric_names = []
        for v in target.supply_voltages:
            self.metric_names += [f"max_thrust_{v:g}V", f"min_thrust_{v:g}V"]

    def model_for(self, rv: dict[str, Any]):
        from uuvid.thruster.physical import PhysicalModel

        kw = dict(self.target.physical_model)
        for n, v in rv.items():
            f = PHYSICAL_NAMES.get(n, n)
            if n == "deadband_fwd":
                v = kw["neutral"] + float(v)
            elif n == "deadband_rev":
                v = kw["neutral"] - float(v)
            kw[f] = float(v)
        return PhysicalModel(**kw)

    def evaluate(self, values: dict[str, np.ndarray], nrun: int) -> Evaluation:
        status = np.full(nrun, OK, dtype=object)
        message = np.full(nrun, "", dtype=object)
        V = self.target.supply_voltages
        series = {f"thrust@{v:g}V": np.full((nrun, self.commands.size), np.nan) for v in V}
        metrics = {n: np.full(nrun, np.nan) for n in self.metric_names}
        for r in range(nrun):
            rv = _values_at(values, r)
            try:
                m = self.model_for(rv)
                for v in V:
                    th = m.thrust(self.commands, v)
                    if not np.all(np.isfinite(th)):
                        raise ValueError("non-finite thrust")
                    series[f"thrust@{v:g}V"][r] = th
                    ends = m.thrust(np.array([m.full_fwd, m.full_rev]), v)
                    metrics[f"max_thrust_{v:g}V"][r] = ends[0]
                    metrics[f"min_thrust_{v:g}V"][r] = ends[1]
            except (ParameterError, ValueError) as e:
                status[r], message[r] = INVALID, str(e)
                for s in series.values():
                    s[r] = np.nan
                for mm in metrics.values():
                    mm[r] = np.nan
        return Evaluation(metrics, status, message, series)

    def series_axes(self) -> dict[str, np.ndarray]:
        return {f"thrust@{v:g}V": self.commands for v in self.target.supply_voltages}

    def info(self) -> dict:
        return {"model": "physical thruster model (steady)", "supply_voltages": self.target.supply_voltages,
                "command_unit": self.base.command_unit, "simulator": "PhysicalModel.predict"}


# ---------------------------------------------------------------------------------------------
# vehicle mission
# ---------------------------------------------------------------------------------------------
MISSION_METRICS = ("max_tracking_error_m", "rms_tracking_error_m", "max_thrust_N",
                   "final_position_error_m", "min_allocation_scale")


def vehicle_simulator(kind: str = "auto"):
    """``(name, function)``: the fast batch runner if it exists (and ``kind`` allows it)."""
    if kind in ("auto", "fast"):
        try:
            from uuvid.simulate.batch import run_batch_fast  # the batched vehicle simulator

            return "uuvid.simulate.batch.run_batch_fast", run_batch_fast
        except ImportError:
            if kind == "fast":
                raise
    from uuvid.simulate.vehicle_sim import run_batch

    return "uuvid.simulate.vehicle_sim.run_batch", run_batch


class VehicleMissionPlan:
    def __init__(self, target: VehicleMissionTarget, names: list[str]):
        from uuvid.simulate.scenario import build
        from uuvid.simulate.vehicle_sim import step_count

        vr = target.velocity_response
        if vr is not None:  # a flight's limit, checked before the scenario's slow build
            n_vr = step_count(vr.t_end, vr.dt, name="target.velocity_response.t_end",
                              dt_name="target.velocity_response.dt")
        self.target = target
        for n in names:
            PR.parse_vehicle_name(n)
        self.names = names
        key = json.dumps(target.scenario.model_dump(mode="json"), sort_keys=True)
        if key not in _SETUPS:  # the thrusters' inverse tables take seconds: once per process
            if len(_SETUPS) > 4:
                _SETUPS.clear()
            with kept_warnings() as said:  # batches: summary rows
                built = build(target.scenario, time_series=False)
            _SETUPS[key] = (*built, said)
        self.vehicle, self.setup, said = _SETUPS[key]
        #: uuvid's warnings of the build (the vehicle file's, a duration rounded to whole steps):
        #: (category, text), said by the study's check and listed in its summary's "warnings"
        self.build_warnings = list(said)
        self.sim_name, self.sim = vehicle_simulator(target.simulator)
        self.metric_names = list(MISSION_METRICS)
        self.thruster_names = {n: n[len("thruster."):] for n in names if n.startswith("thruster.")}
        bank = self.setup.bank
        for n, bn in self.thruster_names.items():
            i, path = PR.parse_block_name(bn)
            if i >= len(bank.chains[0].blocks):
                raise PR.ParameterNameError(f"{n}: the thruster chain has "
                                            f"{len(bank.chains[0].blocks)} blocks")
            _current(bank.chains[0].blocks[i], path)
        self._tp: dict = {}
        vr = target.velocity_response
        if vr is not None:
            self.vr_t = np.arange(n_vr + 1) * vr.dt

    def _thruster_rows(self, values, nrun, msg):
        bank = self.setup.bank
        TP = np.ascontiguousarray(np.broadcast_to(bank.params, (nrun,) + bank.params.shape)).copy()
        if not self.thruster_names:
            return TP
        for r in range(nrun):
            if msg[r]:
                continue
            key = tuple(float(values[n][r]) for n in self.thruster_names)
            got = self._tp.get(key)
            if got is None:
                try:
                    rows = []
                    for ch in bank.chains:
                        c = PR.apply_block_values(ch, {bn: values[n][r] for n, bn in
                                                       self.thruster_names.items()}).compile()
                        if not (np.array_equal(c.poff, bank.poff) and np.array_equal(c.soff, bank.soff)):
                            raise ValueError("the thruster chain's structure changed (number of "
                                             "states/parameters); a vehicle batch needs one structure")
                        rows.append(c.params)
                    got = (np.stack(rows), "")
                except (ParameterError, ValueError) as e:
                    got = (None, str(e))
                self._tp[key] = got
            if got[0] is None:
                msg[r] = got[1]
            else:
                TP[r] = got[0]
        return TP

    def evaluate(self, values: dict[str, np.ndarray], nrun: int) -> Evaluation:
        s = self.setup
        vvals = {k: v for k, v in values.items() if not k.startswith("thruster.")}
        VP, VC, msg = PR.vehicle_rows(self.vehicle.params, vvals, nrun, current0=s.current)
        TP = self._thruster_rows(values, nrun, msg)
        status = np.where(msg == "", OK, INVALID).astype(object)
        ok = np.flatnonzero(status == OK)
        metrics = {n: np.full(nrun, np.nan) for n in self.metric_names}
        if ok.size:
            VC_ok = (np.ascontiguousarray(VC[ok]) if VC is not None
                     else np.ascontiguousarray(np.zeros((ok.size, 3)) + s.current))
            out = np.asarray(self.sim(s, np.ascontiguousarray(VP[ok]), np.ascontiguousarray(TP[ok]),
                                      VC_ok), dtype=float)
            for j, n in enumerate(self.metric_names):
                metrics[n][ok] = out[:, j]
            # only the metric columns: the fast runner's saturated_fraction is NaN (not a
            # divergence) for runs it flew again through the scalar loop
            div = ok[~np.all(np.isfinite(out[:, :len(self.metric_names)]), axis=1)]
            status[div] = DIVERGED
            msg[div] = "the simulation diverged (non-finite summary)"
        series = {}
        vr = self.target.velocity_response
        if vr is not None:
            from uuvid.uncertainty._kernels import one_dof_step_batch

            dof = PR.DOFS.index(vr.dof)
            m, k, kq = PR.one_dof_of_rows(VP, dof)
            Vt = np.full((nrun, self.vr_t.size), np.nan)
            if ok.size:
                tmp = np.empty((ok.size, self.vr_t.size))
                one_dof_step_batch(np.ascontiguousarray(m[ok]), np.ascontiguousarray(k[ok]),
                                   np.ascontiguousarray(kq[ok]), np.full(ok.size, vr.force),
                                   vr.dt, 4, tmp)
                Vt[ok] = tmp
            series[f"velocity_{vr.dof}"] = Vt
        return Evaluation(metrics, status, msg, series)

    def series_axes(self) -> dict[str, np.ndarray]:
        vr = self.target.velocity_response
        return {f"velocity_{vr.dof}": self.vr_t} if vr is not None else {}

    def info(self) -> dict:
        s = self.setup
        return {"vehicle": self.vehicle.name, "mission": s.mission.name, "steps": int(s.t.size),
                "dt": s.dt, "simulator": self.sim_name,
                "velocity_response": (self.target.velocity_response.model_dump()
                                      if self.target.velocity_response else None)}


@contextmanager
def kept_warnings():
    """Keep uuvid's own warnings raised in the block (a :class:`VehicleFileWarning`, an
    :class:`InputWarning` such as the duration-rounding note) as ``(category, text)`` in the list
    it yields, once each, instead of saying them: a plan is built once per process (workers too)
    and cached, so the study says them (:meth:`StudyBase.say_build_warnings`), once, and puts
    them in its summary.  Other packages' warnings are said as they come."""
    import warnings

    said: list[tuple[type, str]] = []
    caught: list = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            yield said
    finally:
        for w in caught:
            if w.category.__module__.split(".")[0] == "uuvid":
                if (w.category, str(w.message)) not in said:
                    said.append((w.category, str(w.message)))
            else:
                warnings.showwarning(w.message, w.category, w.filename, w.lineno)


# ---------------------------------------------------------------------------------------------
_PLANS: dict[str, object] = {}
_SETUPS: dict[str, tuple] = {}


def plan_for(target, names: list[str]):
    """The plan of ``target`` for parameter ``names``, cached per process (workers build it once)."""
    key = json.dumps([target.model_dump(mode="json"), list(names)], sort_keys=True)
    p = _PLANS.get(key)
    if p is None:
        cls = {"thruster_step": ThrusterStepPlan, "thruster_steady": ThrusterSteadyPlan,
               "vehicle_mission": VehicleMissionPlan}[target.kind]
        p = cls(target, list(names))
        if len(_PLANS) > 8:
            _PLANS.clear()
        _PLANS[key] = p
    return p


def series_axes(plan) -> dict[str, np.ndarray]:
    f = getattr(plan, "series_axes", None)
    return f() if f else {}


def nan_safe(x) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


@dataclass
class ChunkResult:
    """Rows ``start … stop-1`` of a study: the table (one row per run, with ``run``), per-run series
    aligned with the rows, the wall time and where it ran."""

    start: int
    stop: int
    table: pd.DataFrame  # noqa: F821 (annotation only)
    series: dict[str, np.ndarray] = field(default_factory=dict)
    wall_time: float = 0.0
    worker: str = ""


#: Bytes one number of a run (a column of its row, a point of its series) holds until the study
#: ends: the chunk tables and series are copied about three times (chunks, the concatenated
#: result, the summary); measured ≈ 6 kB a run for the T200 Monte Carlo's 263 numbers.
BYTES_PER_RUN_VALUE = 24
#: A value of a result row written as CSV text (a float with 17 significant digits and a comma).
CSV_BYTES_PER_VALUE = 24
#: Memory a local worker process takes (Python with NumPy, pandas and the compiled kernels).
WORKER_PROCESS_BYTES = 250e6


def check_workers(workers) -> int | None:
    """``workers`` (``None``: one per CPU) as an int >= 1 whose processes fit in
    :func:`memory_budget_bytes` (≈ :data:`WORKER_PROCESS_BYTES` each); ``ValueError`` naming
    ```workers=``` otherwise."""
    if workers is None:
        return None
    w = int(workers)
    if w < 1:
        raise ValueError(f"`workers=` {w}: expected a number of worker processes >= 1")
    budget = memory_budget_bytes()
    if w * WORKER_PROCESS_BYTES > budget:
        raise ValueError(
            f"`workers=` {w:,}: that many processes would take ≈ "
            f"{w * WORKER_PROCESS_BYTES / 1e9:.3g} GB (≈ {WORKER_PROCESS_BYTES / 1e6:g} MB each), "
            f"more than half this machine's {physical_memory_bytes() / 1e9:.3g} GB; give at most "
            f"{int(budget // WORKER_PROCESS_BYTES):,} (default: one per CPU)")
    return w


class StudyBase:
    """What every study (sweep, Monte Carlo) shares for :func:`uuvid.uncertainty.execute.run_study`:
    a serialisable payload, a lazily built plan over its parameter names, the chunk-size rule.
    Subclasses set ``kind`` and ``spec`` and say which names they vary (``parameter_names``)."""

    kind = ""

    def payload(self) -> dict:
        return {"kind": self.kind, "spec": self.spec.model_dump(mode="json")}

    def parameter_names(self) -> list[str]:  # pragma: no cover - overridden
        raise NotImplementedError

    @property
    def plan(self):
        if getattr(self, "_plan", None) is None:
            self._plan = plan_for(self.spec.target, self.parameter_names())
        return self._plan

    def say_build_warnings(self) -> list[str]:
        """Say (as warnings, on stderr at the command line) what building the plan warned of —
        the vehicle file's warnings, a duration that is not a whole number of steps — and return
        their texts, once each, for the summary's ``warnings`` (``--json``, ``summary.json``)."""
        import warnings

        for cat, text in getattr(self.plan, "build_warnings", ()):
            warnings.warn(text, cat, stacklevel=3)
        return [text for _cat, text in getattr(self.plan, "build_warnings", ())]

    def default_chunk_size(self, backend: str, workers: int) -> int:
        return default_chunk_size(self.n_runs, self.spec.chunk_size, self.spec.target.kind, backend,
                                  workers)

    def estimated_work_s(self) -> float:
        """Single-core seconds the whole study needs, roughly (for the backend choice)."""
        return self.n_runs * run_cost_s(self.spec.target)

    def _run_values(self) -> tuple[int, int]:
        """(series values, row values) of one run's results: its curves; its parameters,
        metrics and status."""
        series = sum(int(np.size(ax)) for ax in series_axes(self.plan).values())
        return series, len(self.parameter_names()) + len(self.plan.metric_names) + 4

    def run_bytes(self) -> int:
        """Memory one run's results hold until the study ends: its row and series, ×
        :data:`BYTES_PER_RUN_VALUE`."""
        return sum(self._run_values()) * BYTES_PER_RUN_VALUE

    #: How to spread a study too big for memory over several (the memory refusal's last words).
    split_advice = "split the study into several (other seeds) and pool their results"

    def size_text(self) -> str:
        """What sets the number of runs, and that number (the memory and disk refusals start
        with it): a Monte Carlo's ```runs=```; a sweep names its own keys."""
        return f"`runs=` {int(self.n_runs):,}"

    def size_advice(self, fit: int) -> str:
        """How to bring the study down to ``fit`` runs."""
        return f"give at most {fit:,} runs"

    def check_memory(self) -> None:
        """``ValueError`` before any run when the study's results would not fit in
        :func:`memory_budget_bytes` (they are held in memory to the end): it says how much they
        would take and how many runs fit."""
        per = self.run_bytes()
        need = float(self.n_runs) * per
        budget = memory_budget_bytes()
        if need > budget:
            raise ValueError(
                f"{self.size_text()}: the results would take ≈ {need / 1e9:.3g} GB of "
                f"memory (≈ {per / 1e3:.3g} kB a run, held to the end of the study), more than "
                f"half this machine's {physical_memory_bytes() / 1e9:.3g} GB; "
                f"{self.size_advice(int(budget // per))}, or {self.split_advice}")

    def disk_bytes(self) -> float:
        """Disk the study's ``out`` folder needs at its peak, bytes: every run's row as CSV text
        (≈ :data:`CSV_BYTES_PER_VALUE` a value) and its series as float64, twice — the chunk
        parts and the consolidated ``results.csv``/``series.npz`` coexist until the parts are
        removed at the end."""
        series, row = self._run_values()
        return 2.0 * float(self.n_runs) * (series * 8 + row * CSV_BYTES_PER_VALUE)

    def check_disk(self, out) -> None:
        """``OSError`` before any run when :meth:`disk_bytes` exceeds the free space where
        ``out`` is written (a study that fills the disk midway loses its consolidation)."""
        import shutil

        need = self.disk_bytes()
        p = Path(out).absolute()
        while not p.exists() and p != p.parent:
            p = p.parent
        free = shutil.disk_usage(p).free
        o = Path(out)  # a rerun into the same folder: its old results are removed first
        old = [o / "results.csv", o / "series.npz", *(o / "parts").glob("chunk-*")] \
            if o.is_dir() else []
        free += sum(f.stat().st_size for f in old if f.is_file())
        if need > free:
            per = need / max(float(self.n_runs), 1.0)
            raise OSError(
                f"{out}: {self.size_text()} would write ≈ {need / 1e9:.3g} GB (≈ "
                f"{per / 1e3:.3g} kB a run: the chunk parts and the consolidated results), and "
                f"{free / 1e9:.3g} GB are free there; {self.size_advice(int(free // per))}, "
                "fewer series, or another output folder")


#: Single-core cost of one integration step, s (orders measured on a 2-core machine: a thruster
#: chain RK4 substep, a 6-DOF vehicle step with its thrusters, one steady-map point).
STEP_COST_S = {"thruster_step": 1e-6, "vehicle_mission": 5e-6, "thruster_steady": 1e-6}


def run_cost_s(target) -> float:
    """Rough single-core seconds of one run of ``target``: steps × :data:`STEP_COST_S`."""
    if target.kind == "thruster_step":
        steps = (round(target.t_end / target.dt) + 1) * target.substeps
    elif target.kind == "vehicle_mission":
        sc = target.scenario
        duration = sc.duration or sc.mission.build().duration
        steps = duration / sc.dt * sc.substeps
    else:
        steps = (len(target.commands) if target.commands else target.n_commands) * \
            len(target.supply_voltages)
    return float(steps) * STEP_COST_S[target.kind]


def default_chunk_size(n_runs: int, chunk_size: int | None, target_kind: str, backend: str,
                       workers: int) -> int:
    """Runs per task: the whole study in-process (capped), else about four chunks per worker
    (vehicle missions in smaller chunks: each run is heavier)."""
    if chunk_size:
        return chunk_size
    vehicle = target_kind == "vehicle_mission"
    cap = 512 if vehicle else 2500
    if backend == "inprocess":
        return max(1, min(cap, n_runs))
    return int(min(cap, max(4 if vehicle else 16, math.ceil(n_runs / (4 * workers)))))
