"""``uuvid simulate`` and ``uuvid vehicle``: fly missions, inspect vehicles, speed envelopes."""

from __future__ import annotations

import math
import warnings
from contextlib import contextmanager
from pathlib import Path

import typer
from rich.markup import escape

from uuvid.cli.options import inflow_option

vehicle_app = typer.Typer(
    no_args_is_help=True,
    help="Vehicles: info, speed envelope, static stability, station keeping (hold), "
         "identification from logs, input design.",
)


def _helpers():
    from uuvid.cli.common import _fail, _print_json, _table, err_console, out_console

    return _fail, _print_json, _table, err_console, out_console


@contextmanager
def _file_warnings(said: list[str], inputs: bool = False):
    """A vehicle file's warnings (:class:`VehicleFileWarning`: a wake above 0.5, a missing model)
    still on stderr, and their texts appended to ``said`` for ``--json``'s ``warnings``: they
    reached stderr only, and the document said none.  ``inputs``: the scenario's notes too
    (:class:`InputWarning`, e.g. a duration flown as whole steps)."""
    from uuvid.core.checks import InputWarning
    from uuvid.vehicle.definition import VehicleFileWarning

    kinds = (VehicleFileWarning, InputWarning) if inputs else VehicleFileWarning

    caught: list = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            yield said
    finally:
        for w in caught:  # said as before (the command line's `warning: …`), outside the catch
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)
            if issubclass(w.category, kinds) and str(w.message) not in said:
                said.append(str(w.message))


def _load_vehicle(name: str, need: str = "", inflow: str | None = None,
                  said: list[str] | None = None):
    """The vehicle ``name`` (preset or file), with ``--inflow`` over its file's key; ``need``:
    what the command does with its thrusters — a vehicle without any is then refused saying so."""
    from uuvid.thruster.modelfile import ModelFileError
    from uuvid.vehicle.definition import list_presets, load_vehicle

    _fail = _helpers()[0]
    try:
        with _file_warnings(said if said is not None else []):
            v = load_vehicle(name, inflow=inflow)
    except (ModelFileError, FileNotFoundError, KeyError) as e:
        msg = e.args[0] if isinstance(e, KeyError) and e.args else str(e)
        # the presets help where the name was not a vehicle file, not under a key's error
        _fail(f"{msg} (presets: {', '.join(list_presets())})" if "not a vehicle file" in msg
              and "preset" not in msg else msg)
    if need and len(v.layout) == 0:
        _fail(f"{name}: vehicle {v.name!r} has no thrusters, so {need}: add a thrusters list to "
              "its file")
    return v


def _fly(spec, base, out, json_out, label, where, inflow=None):
    from uuvid.cli.common import check_outputs
    from uuvid.core.progress import progress_task
    from uuvid.simulate.control.files import describe
    from uuvid.simulate.scenario import build
    from uuvid.simulate.vehicle_sim import fly_mission
    from uuvid.thruster.modelfile import ModelFileError

    _fail, _print_json, _table, err_console, out_console = _helpers()
    check_outputs(("--out", out, "folder"))  # before the flight, not after it
    try:
        # --inflow over the scenario's and file's key; out: its files counted before the flight
        with _file_warnings(said := [], inputs=True):
            vehicle, setup = build(spec, base, inflow, out)
    except (ModelFileError, FileNotFoundError, KeyError, ValueError) as e:
        text = f"{where}: {e}"
        if where == "command line":  # the scenario's keys as `uuvid simulate mission`'s options
            text = text.replace("command line: thruster_model: ", "--thruster-model ")
        _fail(text)
    err_console.print(f"controller: {describe(setup.controller)}")
    with progress_task(f"flying {label}", total=2) as task:
        try:
            result = fly_mission(setup)
        except ValueError as e:  # diverged: a result the scenario must change, not a traceback
            _fail(f"{where}: {e}")
        task.advance()
        if out:
            from uuvid.simulate.mission_report import write_mission_outputs

            write_mission_outputs(result, vehicle, out)
        task.advance()
    summary = result.metrics
    if json_out:
        keys = (
            "completed",
            "max_tracking_error_m",
            "rms_tracking_error_m",
            "max_thrust_N",
            "thrust_limit_N",
            "sim_time_s",
            "wall_time_s",
        )
        doc = {k: summary[k] for k in keys}
        doc.update({k: v for k, v in summary.items() if k not in keys})
        doc["warnings"] = said + list(doc.get("warnings", []))
        if out:
            doc["out"] = str(out)
        _print_json(doc)
        return
    out_console.print(
        _table(
            f"{summary['vehicle']}: {summary['mission']}",
            [{"quantity": k, "value": v} for k, v in summary.items()
             if k not in ("warnings", "mission_note") and not (k == "completed_reason" and not v)],
            ["quantity", "value"],
            "{:.4g}",
        )
    )
    if summary.get("mission_note"):
        err_console.print(f"note: {escape(summary['mission_note'])}")
    for w in summary.get("warnings", ()):
        err_console.print(f"[yellow]warning:[/] {escape(w)}")
    if out:
        err_console.print(f"report: {out / 'index.html'}", markup=False)


#: ``uuvid simulate mission`` options a scenario file sets itself (option name, the file's key)
_MISSION_ONLY = (("vehicle", "--vehicle", "vehicle"), ("speed", "--speed", "mission.speed"),
                 ("depth", "--depth", "mission.depth"), ("side", "--side", "mission.side"),
                 ("current", "--current", "current"),
                 ("thruster_model", "--thruster-model", "thruster_model"), ("dt", "--dt", "dt"))


def simulate(
    ctx: typer.Context,
    target: str = typer.Argument(..., help="A scenario file (YAML/TOML), or the word `mission`."),
    kind: str | None = typer.Argument(None, help="With `mission`: the built-in mission (square)."),
    vehicle: str = typer.Option("bluerov2", "--vehicle", help="mission: vehicle preset or file."),
    speed: float | None = typer.Option(
        None, "--speed", help="mission: cruising speed [m/s]; default 0.5, or 80 % of the vehicle's "
        "level-flight limit when that is lower (the summary says which)."),
    depth: float = typer.Option(2.0, "--depth", help="mission: depth [m]."),
    side: float = typer.Option(10.0, "--side", help="mission: side of the square [m]."),
    current: str = typer.Option("0,0,0", "--current", help="mission: water velocity N,E,D [m/s], the "
                                 "direction the water flows TO (0.3,0,0 flows north, i.e. comes "
                                 "from the south). Not hold's SPEED,DIR (where it comes FROM)."),
    thruster_model: str | None = typer.Option(
        None, "--thruster-model", help="mission: override the thrusters' model (file or preset: "
        "t200, laidani-a2212, t200-physical, ...)."
    ),
    dt: float = typer.Option(0.01, "--dt", help="mission: control and integration step [s]."),
    controller: str | None = typer.Option(
        None, "--controller", help="pid | lqr | FILE.py:FACTORY (your factory(vehicle, context) "
        "returning a Controller); overrides a scenario's."
    ),
    out: Path | None = typer.Option(None, "--out", help="Folder for time series, figures and index.html."),
    json_out: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
    inflow: str = inflow_option(),
):
    """Fly a vehicle: `uuvid simulate SCENARIO.yaml` or `uuvid simulate mission square --vehicle bluerov2`.

    Laidani et al.'s mission (square): dive 2 m, fly a 10 × 10 m square at 0.5 m/s (slower for a
    vehicle that cannot stay level at 0.5 m/s), surface.
    """
    from uuvid.simulate.control.files import ControllerFileError, parse_controller_arg
    from uuvid.simulate.scenario import load_scenario, scenario_from_dict
    from uuvid.thruster.modelfile import ModelFileError

    _fail = _helpers()[0]
    try:
        ctrl = parse_controller_arg(controller) if controller else None
    except ControllerFileError as e:
        _fail(str(e))
    if target == "mission":
        kind = kind or "square"
        if kind != "square":
            _fail(f"unknown mission {kind!r}; built-in: square (or write a scenario file)")
        try:
            cur = [float(x) for x in current.split(",")]
        except ValueError:
            cur = []
        if len(cur) != 3 or not all(map(math.isfinite, cur)):
            _fail(f"--current: expected N,E,D (m/s): three finite numbers, the water velocity "
                  f"north, east, down (where it flows to), e.g. 0.3,0,0; got {current!r}")
        try:
            spec = scenario_from_dict(
                {
                    "vehicle": vehicle,
                    "thruster_model": thruster_model,
                    "current": cur,
                    "dt": dt,
                    "mission": {"kind": "square", "depth": depth, "side": side,
                                **({"speed": speed} if speed is not None else {})},
                    **({"controller": ctrl} if ctrl else {}),
                },
                where="command line",
            )
        except ModelFileError as e:  # the scenario's key paths as this command's options
            text = str(e)
            for key, flag, value in (("mission.speed", "--speed", speed),
                                     ("mission.depth", "--depth", depth),
                                     ("mission.side", "--side", side), ("dt", "--dt", dt)):
                if f"command line: {key}:" in text:
                    text = text.replace(f"command line: {key}:", f"{flag} {value}:")
            _fail(text)
        _fly(spec, None, out, json_out, f"{kind} with {vehicle}", "command line", inflow)
        return
    if kind is not None:
        _fail(f"unexpected argument {kind!r} after the scenario file")
    given = [(flag, key) for name, flag, key in _MISSION_ONLY  # (typer vendors click: by name)
             if getattr(ctx.get_parameter_source(name), "name", None) == "COMMANDLINE"]
    if given:  # they were ignored: a flight in still water the user thought was in a current
        _fail(f"{', '.join(f for f, _ in given)}: only for `uuvid simulate mission`; the scenario "
              f"file {target} sets {', '.join(k for _, k in given)} itself (change "
              f"{'it' if len(given) == 1 else 'them'} there)")
    scenario = Path(target)
    if not scenario.exists():
        _fail(f"{scenario}: no such scenario file (or use `uuvid simulate mission square`)")
    try:
        spec = load_scenario(scenario)
        if ctrl:  # the command line's controller (its file relative to the working folder)
            ctrl["file"] = str(Path(ctrl["file"]).resolve()) if "file" in ctrl else None
            import warnings

            from uuvid.core.checks import InputWarning

            with warnings.catch_warnings():  # the file's values were checked (and said) above
                warnings.simplefilter("ignore", InputWarning)
                spec = scenario_from_dict({**spec.model_dump(exclude={"controller"}),
                                           "controller": {k: v for k, v in ctrl.items() if v}},
                                          where="--controller")
    except ModelFileError as e:
        _fail(str(e))
    _fly(spec, scenario.parent, out, json_out, spec.name, str(scenario), inflow)


@vehicle_app.command("info")
def vehicle_info(
    vehicle: str = typer.Argument(..., help="Vehicle preset or file."),
    json_out: bool = typer.Option(False, "--json", help="Print as JSON (units in the keys and "
                                  "in `units`)."),
):
    """Print a vehicle's parameters (SI, with units), thrusters, modes, sources and notes."""
    v = _load_vehicle(vehicle)
    if json_out:
        _helpers()[1](v.to_dict())
        return
    _helpers()[4].print(v.summary(), markup=False, highlight=False)


@vehicle_app.command("envelope")
def vehicle_envelope(
    vehicle: str = typer.Argument(..., help="Vehicle preset or file."),
    confirm: bool = typer.Option(True, "--confirm/--no-confirm", help="Confirm each speed by simulation."),
    json_out: bool = typer.Option(False, "--json", help="Print as JSON."),
    inflow: str = inflow_option(),
):
    """Maximum steady speed per DOF, analytic and confirmed by simulation (Laidani Table 4 kind).

    The analytic speed balances drag against the largest allocated force along the DOF; the
    simulation flies it at full command with the attitude held where the thrusters can hold it.
    Where they cannot, the static stability limit (`uuvid vehicle stability`) says why not."""
    from uuvid.analysis.envelope_check import confirm_envelope

    _fail, _print_json, _table, err_console, out_console = _helpers()
    v = _load_vehicle(vehicle, "it has no speed envelope", inflow, said := [])
    try:
        check = confirm_envelope(v, simulate=confirm, inflow=inflow)
    except ValueError as e:
        _fail(str(e))
    for w in check.warnings():  # on stderr: --json's stdout stays the document (its "warnings")
        err_console.print(f"[yellow]warning:[/] {escape(w)}", highlight=False, soft_wrap=True)
    if json_out:
        doc = check.to_dict()
        _print_json({**doc, "warnings": said + list(doc.get("warnings", []))})
        return
    with_inflow = check.inflow != "none"
    # the same columns, meaning the same, with and without inflow (inflow adds the bollard ones)
    cols = ["direction", "force", "speed", "allocator_speed"]
    cols += ["bollard_speed", "allocator_bollard_speed"] if with_inflow else []
    cols += ["simulated_speed", "relative_difference"] if confirm else []
    cols += ["limit"]
    heads = {"allocator_speed": "allocator speed", "simulated_speed": "simulated",
             "relative_difference": "simulated vs allocator", "bollard_speed": "speed (bollard)",
             "allocator_bollard_speed": "allocator speed (bollard)"}
    rows = [{heads.get(c, c): r[c] for c in cols} for r in check.table_rows(cols)]
    title = f"{v.name}: speed envelope" + (f", inflow {check.inflow}" if with_inflow else "")
    out_console.print(_table(title, rows, [heads.get(c, c) for c in cols], "{:.4g}"))
    legend = ("force, speed: the largest force any thrust combination gives along the direction "
              "and the steady speed it holds against the drag (speeds along the direction named; "
              "negative: full command moves the vehicle the other way); allocator speed: the same with the "
              "force the thrust allocator delivers (what a pilot gets, and what the simulation "
              "flies)")
    if with_inflow:
        legend += (f"; inflow {check.inflow}: each thruster's limit at its advance speed in that "
                   "steady state; (bollard): the same speeds with bollard thrust")
    if confirm:
        legend += ("; simulated: the steady speed of a full-command flight"
                   + (" that takes each thruster's limit at its advance speed at every control "
                      "step" if with_inflow else "") + ", its relative difference from the "
                   "allocator speed beside")
    out_console.print(legend + " (--json: keys force, speed, allocator_speed"
                      + (", bollard_speed, allocator_bollard_speed" if with_inflow else "")
                      + (", simulated_speed, relative_difference" if confirm else "") + ")",
                      highlight=False, soft_wrap=True, markup=False)
    if any(r["tumbling_full_command"] for r in check.rows):
        out_console.print("simulated_speed —: the vehicle cannot stay level at that speed; flown at "
                          "full command it tumbles (its speed only in --json, tumbling_full_command)",
                          highlight=False, soft_wrap=True)
    for r in check.rows:
        if r["confirmed"] is False:
            out_console.print(f"{r['direction']}: {r['note']}", highlight=False, soft_wrap=True, markup=False)
    for n in check.plain_notes():  # the envelope's notes; its warnings went to stderr above
        out_console.print(f"note: {n}", highlight=False, soft_wrap=True, markup=False)


@vehicle_app.command("stability")
def vehicle_stability(
    vehicle: str = typer.Argument(..., help="Vehicle preset or file."),
    max_tilt: float = typer.Option(20.0, "--max-tilt", help="Largest acceptable trim tilt [deg] "
                                   "(the same 20° as vehicle hold)."),
    json_out: bool = typer.Option(False, "--json", help="Print as JSON."),
    out: Path | None = typer.Option(None, "--out", help="Write stability.png and stability.json here."),
    inflow: str = inflow_option(),
):
    """Static stability in steady flight: trim roll/pitch against speed, and where it stops.

    The limit is the speed where the vehicle can no longer stay level: the righting moment BG·W
    against the thrust moment arms and the Munk moment of the added-mass difference."""
    from uuvid.analysis.envelope_check import envelope_warnings
    from uuvid.cli.common import check_outputs
    from uuvid.vehicle.envelope import speed_envelope
    from uuvid.vehicle.stability import static_stability

    _fail, _print_json, _table, err_console, out_console = _helpers()
    v = _load_vehicle(vehicle, "nothing holds its attitude", inflow, said := [])
    check_outputs(("--out", out, "folder"))  # before the work, not a traceback after it
    try:
        env = speed_envelope(v, inflow=inflow)  # the speeds scanned to, and their caveats
        res = static_stability(v, max_tilt_deg=max_tilt, envelope=env, inflow=inflow)
    except ValueError as e:
        from uuvid.cli.common import _fail_flagged

        _fail_flagged(e, {"max_tilt_deg": "--max-tilt"})
    doc = {**res.to_dict(), "inflow_source": "option" if inflow else "vehicle file"}
    doc["warnings"] = doc["warnings"] + envelope_warnings(env.notes)  # its speeds' caveats too
    for w in doc["warnings"]:  # on stderr: --json's stdout stays the document (its "warnings")
        err_console.print(f"[yellow]warning:[/] {escape(w)}", highlight=False, soft_wrap=True)
    doc["warnings"] = said + doc["warnings"]  # the file's, said on stderr as it loaded
    if out:
        from uuvid.core.atomic import atomic_dir, atomic_write_json

        with atomic_dir(out) as work:  # whole or not at all: Ctrl-C leaves no empty folder
            res.plot(work / "stability.png")
            atomic_write_json(work / "stability.json", doc)
    if json_out:
        _print_json(doc)
        return
    rows = res.rows()
    cols = list(dict.fromkeys(k for r in rows for k in r))
    if rows:
        out_console.print(_table(f"{v.name}: static stability (tilt limit {max_tilt:g}°)", rows, cols,
                                 f"{{:.{res.speed_digits()}g}}"))  # distinct speeds read distinct
    else:  # never an empty table: the notes below say why no direction was scanned
        out_console.print(f"{v.name}: no direction to scan for static stability (see the notes)",
                          highlight=False, soft_wrap=True, markup=False)
    out_console.print(res.summary(), highlight=False, soft_wrap=True, markup=False)
    if out:
        err_console.print(f"wrote {out / 'stability.png'}, {out / 'stability.json'}", markup=False)
