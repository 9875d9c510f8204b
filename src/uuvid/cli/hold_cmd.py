"""``uuvid vehicle hold``: can the vehicle hold station in this current, and for how long?"""

from __future__ import annotations

import math
from pathlib import Path

import typer

from uuvid.cli.options import inflow_option

#: the library's parameter names as this command's options (error messages)
HOLD_FLAGS = {"step_deg": "--step", "simulate_deg": "--simulate", "supply_voltage": "--voltage",
              "soc": "--battery", "inflow": "--inflow "}


def register(vehicle_app: typer.Typer) -> None:
    vehicle_app.command("hold")(vehicle_hold)


def _parse_current(text: str | None):
    if text is None:
        return None
    try:
        parts = [float(x) for x in text.split(",")]
    except ValueError:
        parts = []
    if len(parts) not in (1, 2) or not all(map(math.isfinite, parts)) or parts[0] < 0:
        from uuvid.cli.common import _fail

        _fail(f"--current: expected SPEED[,DIR] (finite numbers: a speed >= 0 in m/s, degrees "
              f"off the bow it comes from), got {text!r}")
    from uuvid.core.checks import current_speed, direction_deg

    try:
        current_speed("--current", parts[0])
        deg = direction_deg("--current direction", parts[1]) if len(parts) == 2 else 0.0
    except ValueError as e:
        from uuvid.cli.common import _fail

        _fail(str(e))
    return parts[0], deg


def vehicle_hold(
    vehicle: str = typer.Argument(..., help="Vehicle preset or file."),
    current: str = typer.Option(None, "--current", help="SPEED[,DIR]: current speed (m/s) and the "
                                "direction it comes FROM, degrees off the bow clockwise (0 = "
                                "head-on, 90 = from starboard; vehicle heading north). Not "
                                "simulate's N,E,D, which is where the water flows TO."),
    battery: float = typer.Option(None, "--battery", help="State of charge (0–1) of the vehicle "
                                  "file's battery: limits at its loaded voltage; with --current "
                                  "also the endurance from this charge."),
    voltage: float = typer.Option(None, "--voltage", help="Fixed supply voltage [V] for the "
                                  "limits (default: the vehicle file's own thrust limits)."),
    step: float = typer.Option(15.0, "--step", help="Angle step of the capability plot, deg."),
    simulate: str = typer.Option("", "--simulate", help="Angles (deg, comma-separated) to confirm "
                                 "by simulation, e.g. 0,90."),
    out: Path = typer.Option(None, "--out", help="Folder for capability.png (the requested "
                             "current marked), endurance.png, hold.json and index.html."),
    json_out: bool = typer.Option(False, "--json", help="Print as JSON."),
    inflow: str = inflow_option(),
):
    """Station-keeping capability (largest current held per direction, a polar "capability plot")
    and, with --current and --battery, the endurance on the battery."""
    from uuvid.analysis import hold
    from uuvid.cli.common import _fail, _fail_flagged, _print_json, out_console
    from uuvid.cli.vehicle_cmds import _load_vehicle
    from uuvid.vehicle.power import limits_at

    v = _load_vehicle(vehicle, "it cannot hold station", inflow, said := [])  # the file's warnings
    cur = _parse_current(current)
    if battery is not None:
        from uuvid.core.checks import state_of_charge

        try:
            state_of_charge("--battery", battery)
        except ValueError as e:
            _fail(str(e))
    if battery is not None and v.battery is None:
        _fail(f"{v.name} has no battery block in its vehicle file; use --voltage")
    if battery is not None:
        from uuvid.vehicle.power import check_battery_models

        try:
            check_battery_models(v)
        except ValueError as e:
            _fail(str(e))
    try:
        sim = tuple(float(x) for x in simulate.split(",") if x.strip())
    except ValueError:
        _fail(f"--simulate: expected comma-separated angles, got {simulate!r}")
    from uuvid.core.checks import direction_deg

    try:  # as --current's direction: 400 is said and taken as 40
        sim = tuple(direction_deg("--simulate", d) for d in sim)
    except ValueError as e:
        _fail(str(e))
    if sim and battery is not None:
        _fail("--simulate confirms at fixed limits: give --voltage instead of --battery")
    from uuvid.cli.common import check_outputs

    check_outputs(("--out", out, "folder"))  # before the polar is computed, not after
    # the direction of --current and --simulate is checked (and warned of) above, once: the
    # library's private paths take it as it is
    try:
        cap = hold._capability(v, step_deg=step, supply_voltage=voltage, soc=battery,
                               simulate_deg=sim, inflow=inflow)
    except ValueError as e:
        _fail_flagged(e, HOLD_FLAGS)
    doc = {"capability": cap.to_dict(), "inflow": cap.inflow,
           "inflow_source": "option" if inflow else "vehicle file"}
    endur = None
    if cur is not None:
        speed, deg = cur
        lim = None if voltage is None else limits_at(v, voltage)
        try:
            vmax = hold._max_current(v, deg, soc=battery, limits=lim, inflow=cap.inflow)[0]
        except ValueError as e:
            _fail_flagged(e, HOLD_FLAGS)
        doc["at_current"] = {"speed_m_s": speed, "from_deg": deg, "max_current_m_s": vmax,
                             "holds": bool(speed <= vmax), "margin": vmax / speed if speed else None}
        if battery is not None:
            endur = hold._endurance(v, speed, deg, soc0=battery)
            doc["endurance"] = endur.to_dict()
    if out is not None:
        hold.write_hold_report(out, cap, doc, cur, endur)
        doc["out"] = str(out)
    if voltage is None and battery is None:
        doc["limits_note"] = ("thrust limits: the vehicle file's own (default; --voltage V or "
                              "--battery SOC for the limits at a supply voltage)")
    doc["warnings"] = cap.warnings()
    if json_out:  # the vehicle file's warnings too (on stderr as it loaded)
        _print_json({**doc, "warnings": said + doc["warnings"]})
        return
    from uuvid.cli.common import err_console

    if "limits_note" in doc:
        err_console.print(f"note: {doc['limits_note']}", markup=False, highlight=False)
    for w in doc["warnings"]:
        err_console.print(f"warning: {w}", markup=False, highlight=False)
    out_console.print(cap.summary(), markup=False, highlight=False)
    if cur is not None:
        a = doc["at_current"]
        out_console.print(f"current {a['speed_m_s']:.2f} m/s from {a['from_deg']:.0f}°: "
                          f"{'holds' if a['holds'] else 'does NOT hold'} (largest "
                          f"{a['max_current_m_s']:.3f} m/s)", markup=False)
        if endur is not None:
            out_console.print(endur.summary(), markup=False, highlight=False)
    if out is not None:
        out_console.print(f"wrote {out}/capability.png" + (", endurance.png" if endur else "")
                          + f", hold.json and {out}/index.html", markup=False)

