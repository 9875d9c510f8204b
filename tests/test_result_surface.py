"""Every result class has the same small surface (issue 12, item 2): ``summary()`` text,
``to_dict()`` that strict JSON accepts, ``plot()`` giving a Figure and ``report(folder)`` writing
``index.html`` and ``result.json``.

The classes are found, not listed: every module of the package is imported and every subclass
of :class:`uuvid.core.result.Result` must have a factory below that builds a real instance
from small synthetic data — a new result class without one fails ``test_every_result_class_has_a
_factory``, so none can skip the surface."""

from __future__ import annotations

import importlib
import json
import pkgutil
import warnings

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure
from test_log_identify import _write_csv as _csv

import uuvid
from uuvid.core.result import Result, SummaryDict

# modules that need optional extras (their import may fail without them)
_OPTIONAL = {"uuvid.simulate.gym_env"}


def _all_subclasses(cls) -> set[type]:
    out = set()
    for sub in cls.__subclasses__():
        out.add(sub)
        out |= _all_subclasses(sub)
    return out


def result_classes() -> set[type]:
    for m in pkgutil.walk_packages(uuvid.__path__, "uuvid."):
        if m.name.startswith("uuvid.cli") and m.name != "uuvid.cli":
            continue  # the shell: nothing there defines results
        try:
            importlib.import_module(m.name)
        except ImportError:
            if m.name in _OPTIONAL:
                continue
            raise
    # abstract bases (no summary of their own) are covered through their subclasses
    from uuvid.core.result import DictSummaryResult
    from uuvid.papers.reproduction import PaperReproduction

    # only the library's own classes: a test may define a Result subclass of its own (it lives until the
    # garbage collector takes it, so whether it is seen here would depend on the order tests ran in)
    return {c for c in _all_subclasses(Result)
            if c.__module__.startswith("uuvid.") and c not in (PaperReproduction, DictSummaryResult)}


def _name(cls) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


# ----------------------------------------------------------------------------------- shared data
def _quiet(fn, *a, **kw):
    from uuvid.identify.fit import IdentifiabilityWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdentifiabilityWarning)
        return fn(*a, **kw)


def _bench():
    from uuvid.io.bench import BenchData

    rng = np.random.default_rng(0)
    pwm = np.arange(1100.0, 1901.0, 10.0)
    w = np.where(np.abs(pwm - 1500) > 25, 0.6 * (pwm - 1500), 0.0)
    thrust = 3.5e-4 * w * np.abs(w) + rng.normal(0, 0.05, pwm.size)
    return BenchData(command=pwm, thrust=thrust, speed=w + rng.normal(0, 0.3, pwm.size),
                     source="synthetic")


def _yaw_log(tmp_path):
    from test_log_identify import _yaw_steps

    t, f, y = _yaw_steps()
    return _csv(tmp_path / "steps.csv", ["time", "torque", "heading"],
                [[f"{a:.3f}", b, c] for a, b, c in zip(t, f, y)])


def _sine_log(tmp_path):
    from test_log_identify import _jittery_sine

    return _csv(tmp_path / "sine.csv", ["time", "torque", "yaw"], _jittery_sine()[0])


def _two_state_records():
    from uuvid.identify.thruster.dynamic_select import reference_two_state_thruster, synthetic_experiments

    return synthetic_experiments(reference_two_state_thruster(), (2.0, 3.0), rate=100.0,
                                 duration=3.0, seed=5)


_DYN_COLS = {"time_col": "t", "command_col": "V", "command_unit": "volts", "speed_col": "w",
             "thrust_col": "T"}


def _two_state_files(tmp_path):
    out = []
    for e in _two_state_records():
        out.append(_csv(tmp_path / f"run{e.name}.csv", ["t", "V", "w", "T"],
                        [[f"{v:.9g}" for v in row] for row in zip(e.t, e.u, e.speed, e.thrust)]))
    return out


# ------------------------------------------------------------------------------------- factories
def f_fit(tmp_path):
    from uuvid.identify.fit import linear_lsq

    x = np.linspace(0, 1, 30)
    y = 2.0 + 3.0 * x + np.random.default_rng(0).normal(0, 0.05, x.size)
    return linear_lsq(np.column_stack([np.ones_like(x), x]), y, ["a", "b"])


def f_steady_fit(tmp_path):
    from uuvid.identify.thruster.steady import fit_polynomial

    return _quiet(fit_polynomial, _bench(), None, degrees=range(1, 4), k=3)


def f_degree_table(tmp_path):
    return f_steady_fit(tmp_path).info["tables"]["forward"]


def f_chain_fit(tmp_path):
    from uuvid.identify.thruster.dynamic import Run, fit_chain
    from uuvid.thruster.blocks import FirstOrderMotor
    from uuvid.thruster.chain import ThrusterChain

    t = np.arange(80) * 0.01
    y = 1 - np.exp(-t / 0.1) + np.random.default_rng(0).normal(0, 0.01, t.size)
    start = ThrusterChain((FirstOrderMotor(gain=1.0, time_constant=0.2),), input_kind="voltage")
    return _quiet(fit_chain, start, {0: ["time_constant"]}, [Run(t, np.ones_like(t), y,
                                                                 "prop_speed")])


def f_dynamics_fit(tmp_path):
    from uuvid.identify.thruster.dynamic_select import fit_dynamics

    return _quiet(fit_dynamics, [e for e in _two_state_records() if e.level == 2.0], "healey")


def f_selection(tmp_path):
    from uuvid.identify.thruster.dynamic_select import select_structure

    return _quiet(select_structure, _two_state_records(), ["first-order", "healey"])


def f_physical_fit(tmp_path):
    from test_physical_model import TRUTH, synthetic_sheets

    from uuvid.identify.thruster.physical import fit_physical

    return _quiet(fit_physical, synthetic_sheets(TRUTH))


def f_fit_outcome(tmp_path):
    from uuvid.identify.thruster.workflow import ReadOptions, run_fit

    b = _bench()
    p = _csv(tmp_path / "bench.csv", ["command", "speed", "thrust"],
             [[c, w, f] for c, w, f in zip(b.command, b.speed, b.thrust)])
    return _quiet(run_fit, [p], "quadratic",
                  ReadOptions(thrust_col="thrust", speed_col="speed"))


def f_replay(tmp_path):
    from uuvid.identify.thruster.dynamic_select import reference_two_state_thruster
    from uuvid.identify.thruster.workflow import ReadOptions, replay_files

    return replay_files(reference_two_state_thruster(), _two_state_files(tmp_path)[:1],
                        ReadOptions(**_DYN_COLS))


def f_steady_identification(tmp_path):
    from uuvid.identify.vehicle.procedures import identify_steady

    return _quiet(identify_steady, _yaw_log(tmp_path), dof="yaw", command_col="torque",
                  position_col="heading", settle=10, min_duration=10)


def f_inertia_identification(tmp_path):
    from uuvid.identify.vehicle.procedures import identify_inertia

    return _quiet(identify_inertia, _sine_log(tmp_path), dof="yaw", k=20.5, k_q=49.5,
                  command_col="torque", position_col="yaw")


def f_drag_fit(tmp_path):
    return f_steady_identification(tmp_path).fit


def f_inertia_fit(tmp_path):
    return f_inertia_identification(tmp_path).fit


def f_bootstrap(tmp_path):
    from uuvid.uncertainty.bootstrap import bootstrap_linear

    x = np.linspace(0, 1, 40)
    y = 1.0 + 2.0 * x + np.random.default_rng(0).normal(0, 0.1, x.size)
    return bootstrap_linear(np.column_stack([np.ones_like(x), x]), y, ["a", "b"], n_boot=50)


def f_study(tmp_path):
    from uuvid.uncertainty.execute import StudyResult

    table = pd.DataFrame({"run": [0, 1, 2, 3], "status": ["ok", "ok", "ok", "failed"],
                          "max_error_m": [0.1, 0.2, np.nan, np.nan], "message": ["", "", "", "x"]})
    return StudyResult(table, {}, {"succeeded": 3, "backend": "inprocess", "partial": False})


def f_mission(tmp_path):
    from uuvid.simulate.vehicle_sim import MissionResult

    n, t = 50, np.linspace(0, 4.9, 50)
    state = np.zeros((n, 13))
    state[:, 0], state[:, 3] = np.linspace(0, 1, n), 1.0
    ref = np.column_stack([np.linspace(0, 1.1, n), np.zeros(n), np.zeros(n)])
    thrust = np.tile([1.0, -1.0], (n, 1))
    return MissionResult(t, state, thrust, thrust, np.zeros((n, 6)), np.ones(n), ref, np.zeros(n),
                         ("t1", "t2"), np.array([[-40.0, 50.0]] * 2),
                         {"vehicle": "test", "mission": "line", "completed": True,
                          "max_tracking_error_m": 0.1, "real_time_factor": float("inf")})


def f_time_response(tmp_path):
    from uuvid.thruster.presets import laidani_chain

    return laidani_chain().simulate(1600.0, 0.3, dt=1e-3)


def f_sweep(tmp_path):
    from uuvid.thruster.presets import laidani_chain

    return laidani_chain().sweep(np.linspace(1100.0, 1900.0, 9), settle_time=0.25)


def _bluerov2():
    from uuvid.vehicle.definition import load_vehicle

    return load_vehicle("bluerov2")


def f_linear_model(tmp_path):
    from uuvid.vehicle.linearize import linearize

    return linearize("bluerov2")


def f_station_keeping(tmp_path):
    from uuvid.simulate.station_keeping import StationKeepingComparison, StationKeepingRun

    t = np.linspace(0, 2, 21)
    st = np.zeros((t.size, 13))
    st[:, 0] = np.exp(-t)
    runs = [StationKeepingRun(c, t, st * s, np.ones((t.size, 8)) * s, np.zeros(13))
            for c, s in (("PID DP", 1.0), ("LQI", 0.5))]
    return StationKeepingComparison("bluerov2", runs[0], runs[1], np.zeros((8, 12)), 1.0,
                                    np.array([1.0, 0, 0, 0]), np.zeros(3), f_linear_model(tmp_path))


def f_envelope(tmp_path):
    from uuvid.vehicle.envelope import speed_envelope

    return speed_envelope(_bluerov2())


def f_envelope_check(tmp_path):
    from uuvid.analysis.envelope_check import confirm_envelope

    return confirm_envelope(_bluerov2(), simulate=False)


def f_stability(tmp_path):
    return f_envelope_check(tmp_path).stability


def f_capability(tmp_path):
    from uuvid.analysis.hold import CapabilityResult

    deg = np.arange(0.0, 360.0, 45.0)
    return CapabilityResult("bluerov2", deg, 0.5 + 0.1 * np.cos(np.radians(deg)),
                            limiting=(("t1",),) * deg.size, limit=("thrust",) * deg.size)


def f_endurance(tmp_path):
    from uuvid.analysis.hold import EnduranceResult

    k = np.arange(5.0)
    return EnduranceResult("bluerov2", 0.3, 0.0, 600 * k, 1 - 0.2 * k, 16 - 0.5 * k, 10 + k,
                           50 - k, 2400.0, "battery empty")


def f_degree_selection(tmp_path):
    from uuvid.papers.laidani_identification import degree_selection

    return degree_selection(seed=0)


def f_laidani(tmp_path):
    from uuvid.papers import laidani

    return laidani.reproduce()


def f_mclean(tmp_path):
    from uuvid.papers import mclean1991

    return mclean1991.reproduce()


def f_mclean_identification(tmp_path):
    from uuvid.papers import mclean1991_identification

    return mclean1991_identification.reproduce()


def f_caccia(tmp_path):
    from uuvid.papers import caccia2000

    return caccia2000.reproduce(seed=0, fast=True)


def f_loop_study(tmp_path):
    from uuvid.papers import thruster_loop_study

    return thruster_loop_study.run_study(bandwidths=(2.0,))


def _synthetic_bin(tmp_path):
    pytest.importorskip("pymavlink")
    from test_ardusub import scenario, write_bin

    return write_bin(tmp_path / "dive.BIN", scenario(n=200))


def f_log_inspection(tmp_path):
    from uuvid.io.ardusub import inspect_log

    return inspect_log(_synthetic_bin(tmp_path))


def f_dive(tmp_path):
    from uuvid.io.ardusub import load_dive

    return load_dive(_synthetic_bin(tmp_path))


def _short_dive():
    from uuvid.simulate.dive_synth import synthetic_dive

    return synthetic_dive(150.0, seed=5, pwm_rate=10.0, surge=0.0)[0]


def f_dive_identification(tmp_path):
    from uuvid.identify.vehicle.dive import identify_dive

    return identify_dive(_short_dive(), "bluerov2", ["heave", "yaw"], t_end=110.0)


def f_dive_replay(tmp_path):
    from uuvid.simulate.dive_replay import replay_dive

    return replay_dive(_short_dive(), "bluerov2", ["heave", "yaw"])


#: class (module.qualname) → factory; ``slow`` ones run with --run-slow (CI)
FACTORIES = {
    "uuvid.identify.fit.Fit": f_fit,
    "uuvid.identify.thruster.steady.SteadyFit": f_steady_fit,
    "uuvid.identify.thruster.steady.DegreeTable": f_degree_table,
    "uuvid.identify.thruster.dynamic.ChainFit": f_chain_fit,
    "uuvid.identify.thruster.dynamic_select.DynamicsFit": f_dynamics_fit,
    "uuvid.identify.thruster.dynamic_select.Selection": f_selection,
    "uuvid.identify.thruster.physical.PhysicalFit": f_physical_fit,
    "uuvid.identify.thruster.workflow.FitOutcome": f_fit_outcome,
    "uuvid.identify.thruster.workflow.Replay": f_replay,
    "uuvid.identify.vehicle.procedures.SteadyIdentification": f_steady_identification,
    "uuvid.identify.vehicle.procedures.InertiaIdentification": f_inertia_identification,
    "uuvid.identify.vehicle.fit.DragFit": f_drag_fit,
    "uuvid.identify.vehicle.fit.InertiaFit": f_inertia_fit,
    "uuvid.uncertainty.bootstrap.BootstrapResult": f_bootstrap,
    "uuvid.uncertainty.execute.StudyResult": f_study,
    "uuvid.simulate.vehicle_sim.MissionResult": f_mission,
    "uuvid.core.response.TimeResponse": f_time_response,
    "uuvid.thruster.chain.SweepResult": f_sweep,
    "uuvid.simulate.station_keeping.StationKeepingComparison": f_station_keeping,
    "uuvid.analysis.envelope_check.EnvelopeCheck": f_envelope_check,
    "uuvid.vehicle.envelope.Envelope": f_envelope,
    "uuvid.vehicle.stability.StabilityResult": f_stability,
    "uuvid.analysis.hold.CapabilityResult": f_capability,
    "uuvid.analysis.hold.EnduranceResult": f_endurance,
    "uuvid.vehicle.linearize.LinearModel": f_linear_model,
    "uuvid.papers.laidani_identification.DegreeSelection": f_degree_selection,
    "uuvid.papers.laidani.LaidaniReproduction": f_laidani,
    "uuvid.papers.mclean1991.McLeanReproduction": f_mclean,
    "uuvid.papers.mclean1991_identification.McLeanIdentification": f_mclean_identification,
    "uuvid.papers.caccia2000.Reproduction": f_caccia,
    "uuvid.papers.thruster_loop_study.LoopStudy": f_loop_study,
    "uuvid.io.ardusub.inspect.LogInspection": f_log_inspection,
    "uuvid.io.ardusub.dive.DiveLog": f_dive,
    "uuvid.identify.vehicle.dive.DiveIdentification": f_dive_identification,
    "uuvid.simulate.dive_replay.DiveReplay": f_dive_replay,
}
SLOW = {"uuvid.identify.thruster.dynamic_select.Selection", "uuvid.papers.thruster_loop_study.LoopStudy",
        "uuvid.papers.laidani.LaidaniReproduction",
        "uuvid.papers.mclean1991.McLeanReproduction", "uuvid.papers.caccia2000.Reproduction",
        "uuvid.papers.mclean1991_identification.McLeanIdentification",
        # ≥ 0.4 s each on a warm machine (fits, dives, envelopes): CI only
        "uuvid.analysis.envelope_check.EnvelopeCheck",
        "uuvid.analysis.hold.EnduranceResult",
        "uuvid.core.response.TimeResponse",
        "uuvid.identify.thruster.dynamic_select.DynamicsFit",
        "uuvid.identify.thruster.physical.PhysicalFit",
        "uuvid.identify.thruster.steady.SteadyFit",
        "uuvid.identify.thruster.workflow.FitOutcome",
        "uuvid.identify.thruster.workflow.Replay",
        "uuvid.identify.vehicle.dive.DiveIdentification",
        "uuvid.identify.vehicle.fit.DragFit",
        "uuvid.identify.vehicle.fit.InertiaFit",
        "uuvid.identify.vehicle.procedures.InertiaIdentification",
        "uuvid.identify.vehicle.procedures.SteadyIdentification",
        "uuvid.io.ardusub.dive.DiveLog",
        "uuvid.papers.laidani_identification.DegreeSelection",
        "uuvid.simulate.dive_replay.DiveReplay",
        "uuvid.simulate.vehicle_sim.MissionResult",
        "uuvid.thruster.chain.SweepResult",
        "uuvid.vehicle.envelope.Envelope",
        "uuvid.vehicle.stability.StabilityResult",
}


def test_every_result_class_has_a_factory():
    found = {_name(c) for c in result_classes()}
    missing = sorted(found - set(FACTORIES))
    assert not missing, f"result classes without a factory in {__file__}: {missing}"
    stale = sorted(set(FACTORIES) - found)
    assert not stale, f"factories for classes that are not Result subclasses: {stale}"


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n in SLOW else n
                                  for n in FACTORIES])
@pytest.mark.slow
def test_the_surface(name, tmp_path):
    obj = FACTORIES[name](tmp_path)
    assert _name(type(obj)) == name
    text = obj.summary()
    assert isinstance(text, str) and text.strip()
    d = obj.to_dict()
    assert isinstance(d, dict) and d
    assert json.loads(json.dumps(d, allow_nan=False)) == d  # strict JSON, nothing lost
    assert json.loads(obj.to_json()) == d
    fig = obj.plot()
    assert isinstance(fig, Figure) and fig.axes
    index = obj.report(tmp_path / "report")
    assert index == tmp_path / "report" / "index.html" and index.is_file()
    assert json.loads((tmp_path / "report" / "result.json").read_text()) == d
    assert (tmp_path / "report" / "summary.txt").read_text().strip() == text.strip()
    assert obj._repr_html_().startswith("<pre>")


def test_old_summary_dicts_still_read_and_write():
    """``MissionResult.summary`` / ``StudyResult.summary`` were dicts: reading and writing keys
    goes to ``metrics`` / ``info``, calling gives the text."""
    m = f_mission(None)
    assert isinstance(m.summary, SummaryDict) and m.summary["completed"] is True
    m.summary["extra"] = 1
    assert m.metrics["extra"] == 1 and "completed" in m.summary()
    s = f_study(None)
    s.summary["files"] = ["results.csv"]
    assert s.info["files"] == ["results.csv"] and "4 runs" in s.summary()


def test_to_json_writes_a_file_atomically(tmp_path):
    p = f_fit(None).to_json(tmp_path / "fit.json")
    assert json.loads(p.read_text())["model"] == "linear"
    assert not list(tmp_path.glob(".tmp-*"))


def test_a_huge_percentile_error_is_written_in_three_digits():
    """A σ that only says 'not determined' printed as '2996043212469741568.0 %'."""
    from uuvid.identify.fit import _pct

    assert _pct(12.34) == "12.3" and _pct(2996043212469741568.0) == "3e+18"
    assert _pct(float("inf")) == "inf"
