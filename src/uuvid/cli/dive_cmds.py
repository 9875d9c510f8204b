"""``uuvid vehicle identify dive`` and ``uuvid vehicle replay``: a model from a whole piloted dive,
and how well a model predicts a dive.

::

    uuvid vehicle identify dive LOG --vehicle V [--dof heave|yaw|surge|sway|horizontal|all]
          [--t-start S] [--t-end S] [--horizon S] [--no-dead-band-weights] [--params FILE]
          [--topic ROLE=TOPIC[:FIELD] ...]
          [--out-vehicle OUT.yaml] [--report DIR] [--json]
    uuvid vehicle replay LOG --vehicle V [--dof ...] [--t-start S] [--t-end S] [--horizon S]
          [--params FILE] [--topic ROLE=TOPIC[:FIELD] ...] [--out DIR] [--json]

The work is done by :func:`uuvid.identify.vehicle.dive.identify_dive` and
:func:`uuvid.simulate.dive_replay.replay_dive`; this module parses options and prints.
"""

from __future__ import annotations

from pathlib import Path

import typer

LOG_ARG = typer.Argument(..., help="ArduSub .tlog/.BIN; a ROS 1 .bag or ROS 2 bag directory "
                                   "(ArduSub + mavros topics); or CSV/Parquet with t_s, the "
                                   "measured channels (depth_m for heave, yaw_rad for yaw, u_mps "
                                   "and v_mps (DVL) for surge and sway; horizontal needs u_mps, "
                                   "v_mps and yaw_rad), the body-frame force X_N, Y_N, Z_N [N] "
                                   "and moment K_Nm, M_Nm, N_Nm [N·m] (x forward, y starboard, z "
                                   "down) or the servo outputs pwm_1 … pwm_n [µs] (--inflow needs "
                                   "them) with battery_V [V] (without it: the nominal 16 V); "
                                   "optional armed, mode.")
PARAMS = typer.Option(None, "--params", help="ArduSub parameter file (QGroundControl / Mission "
                                             "Planner / BlueOS) for what the log lacks: a ROS bag "
                                             "has none, so SERVOn_FUNCTION and MOT_n_DIRECTION "
                                             "(reversed motors) come from here; a CSV/Parquet "
                                             "table's pwm_<n> columns (motor n) take its "
                                             "MOT_n_DIRECTION.")
TOPIC = typer.Option(None, "--topic", metavar="ROLE=TOPIC:FIELD",
                     help="ROS bags: ROLE=TOPIC:FIELD, or ROLE=TOPIC for the topic's usual "
                          "field, overriding a default mavros topic; roles "
                          "pwm, attitude, yaw, depth, altitude, pressure, battery, armed, mode, "
                          "velocity, u, v (e.g. depth=/bar30/depth:data). A topic two publish on "
                          "(a second IMU) keeps the one with the most messages; ROLE=TOPIC@SOURCE "
                          "picks another by its node or header frame_id. Repeatable.")
VEHICLE = typer.Option(..., "--vehicle", help="Base vehicle: preset or vehicle file (its thruster "
                                              "geometry turns servo outputs into forces).")
DOF = typer.Option("all", "--dof", help="heave, yaw, surge, sway, horizontal (surge, sway and yaw "
                                        "coupled; needs u_mps, v_mps, yaw_rad), a comma list, or "
                                        "all (every DOF the log has a measured channel for).")
T_START = typer.Option(None, "--t-start", help="Use the log from this time [s].")
T_END = typer.Option(None, "--t-end", help="Use the log up to this time [s] (identify dive: "
                                           "and score the identified model on the rest, held "
                                           "out).")
HORIZON = typer.Option(None, "--horizon", help="Window length [s] (default heave 10, yaw 4, "
                                               "surge, sway and horizontal 5).")
JSON = typer.Option(False, "--json", help="Print one JSON document.")


def _dofs(text: str):
    parts = [p.strip() for p in text.split(",") if p.strip()]
    return "all" if parts == ["all"] else parts


def _errors():
    from uuvid.io.logs import LogDataError
    from uuvid.thruster.modelfile import ModelFileError
    from uuvid.vehicle.writeback import WritebackError

    return (LogDataError, ModelFileError, WritebackError, FileNotFoundError, KeyError, ImportError)


def identify_dive_cmd(
    log: Path = LOG_ARG,
    vehicle: str = VEHICLE,
    dof: str = DOF,
    t_start: float | None = T_START,
    t_end: float | None = T_END,
    horizon: float | None = HORIZON,
    params: Path | None = PARAMS,
    topic: list[str] | None = TOPIC,
    out_vehicle: Path | None = typer.Option(None, "--out-vehicle",
                                            help="Write the base vehicle with the identified "
                                                 "values and their provenance (YAML)."),
    report: Path | None = typer.Option(None, "--report", help="Folder for the report."),
    dead_band_weights: bool = typer.Option(True, "--dead-band-weights/--no-dead-band-weights",
                                           help="Down-weight residuals whose force comes from "
                                                "thrusters at the dead band's edge (needs "
                                                "logged PWM)."),
    inflow: bool | None = typer.Option(None, "--inflow/--no-inflow",
                                       help="Fit the inflow coefficient k_a jointly: the thrust "
                                            "lost to the advance speed, F − k_a c(t) v (needs "
                                            "logged PWM). Default: on when the vehicle file has "
                                            "inflow other than none."),
    json_out: bool = JSON,
):
    """Identify per-DOF models (mass with added mass, drag, net buoyancy) from every armed sample
    of a piloted dive, closed-loop modes included; --dof horizontal identifies surge, sway and
    yaw jointly with the coupled model where a DVL logs u and v."""
    from uuvid.cli.common import _fail, check_outputs
    from uuvid.identify.vehicle.dive import identify_dive

    if out_vehicle is not None and out_vehicle.suffix.lower() not in (".yaml", ".yml"):
        _fail(f"--out-vehicle {out_vehicle}: the new vehicle file must end in .yaml or .yml")
    # before the fit: a --report that is a file failed after --out-vehicle had been written
    check_outputs(("--out-vehicle", out_vehicle, "file"), ("--report", report, "folder"))

    def write(res, doc):
        if out_vehicle is not None:
            doc["out_vehicle"] = str(res.write_vehicle(out_vehicle))
        if report is not None:
            doc["report"] = str(res.report(report))

    _run(lambda: identify_dive(log, vehicle, _dofs(dof), t_start=t_start, t_end=t_end,
                               horizon=horizon, params=params, topics=topic,
                               dead_band_weighting=dead_band_weights, inflow=inflow),
         write, json_out, lambda e: f"cannot write: {e.strerror or e} ({e.filename})")


def replay_dive_cmd(
    log: Path = LOG_ARG,
    vehicle: str = VEHICLE,
    dof: str = DOF,
    t_start: float | None = T_START,
    t_end: float | None = T_END,
    horizon: float | None = HORIZON,
    params: Path | None = PARAMS,
    topic: list[str] | None = TOPIC,
    out: Path | None = typer.Option(None, "--out", help="Folder for predicted-vs-measured plots "
                                                        "and result.json."),
    json_out: bool = JSON,
):
    """Drive the vehicle's model with the logged thruster forces (at the logged voltage),
    restarting every --horizon s from the measured state; compare depth, heading, velocities."""
    from uuvid.cli.common import check_outputs
    from uuvid.simulate.dive_replay import replay_dive

    check_outputs(("--out", out, "folder"))

    def write(res, doc):
        if out is not None:
            doc["report"] = str(res.report(out))

    _run(lambda: replay_dive(log, vehicle, _dofs(dof), t_start=t_start, t_end=t_end,
                             horizon=horizon, params=params, topics=topic), write, json_out,
         lambda e: f"--out {out}: cannot write ({e.strerror or e})")


def _run(compute, write, json_out: bool, write_error) -> None:
    """The shell both dive commands share: compute the result, write its files (``write(res,
    doc)`` records their paths in ``doc``), then print the JSON or the summary and what was
    written; bad input and unwritable outputs end in one line, not a traceback."""
    from uuvid.cli.common import _fail, _print_json, err_console, out_console
    from uuvid.core.checks import as_options

    try:
        with as_options():  # the library's messages name --t-end, not t_end
            res = compute()
        doc = res.to_dict()
    except _errors() as e:
        _fail(str(e).strip("'\""))
    try:
        with as_options():
            write(res, doc)
    except KeyboardInterrupt:  # a file already in place is not one the user thinks was not made
        for k in ("out_vehicle", "report"):
            if k in doc:
                err_console.print(f"wrote {doc[k]} before the interrupt", highlight=False,
                                  markup=False)
        raise
    except (*_errors(), OSError) as e:  # the result first, then why nothing (more) was written
        if not json_out:
            out_console.print(res.summary(), highlight=False, markup=False, soft_wrap=True)
        done = [str(doc[k]) for k in ("out_vehicle", "report") if k in doc]
        text = (write_error(e) if isinstance(e, OSError) and not isinstance(e, _errors())
                else str(e).strip("'\""))
        _fail(text + (f"; {' and '.join(done)} had been written before" if done else
                      "" if "nothing was written" in text else "; nothing was written"))
    if json_out:
        _print_json(doc)
    else:
        out_console.print(res.summary(), highlight=False, markup=False, soft_wrap=True)
        for k in ("out_vehicle", "report"):
            if k in doc:
                err_console.print(f"wrote {doc[k]}", highlight=False, markup=False)
    failed = _not_finite(res)
    if failed:  # printed for the record, but no model: the exit status says so
        _fail(f"{', '.join(failed)}: the identified parameters are not finite — no model was "
              "identified for " + ("it" if len(failed) == 1 else "them") + " (see the warnings)",
              code=1)


def _not_finite(res) -> list:
    """The DOFs of an identification result whose values are not all finite."""
    import math

    out = []
    for dof, e in (getattr(res, "estimates", None) or {}).items():
        vals = getattr(e, "values", {}) or {}
        if any(isinstance(v, (int, float)) and not math.isfinite(v) for v in vals.values()):
            out.append(str(dof))
    return out


def register(vehicle_app: typer.Typer, identify_app: typer.Typer) -> None:
    """Add ``vehicle identify dive`` and ``vehicle replay``."""
    identify_app.command("dive")(identify_dive_cmd)
    vehicle_app.command("replay")(replay_dive_cmd)
