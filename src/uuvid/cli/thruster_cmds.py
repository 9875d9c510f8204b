"""``uuvid thruster show|simulate|export|predict``: inspect a thruster model, simulate it under
any input, export it to UUV Simulator, predict its steady output (e.g. at another supply voltage).
``fit`` and ``replay`` live in :mod:`uuvid.cli.fit_cmd` and :mod:`uuvid.cli.replay_cmd`."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import typer
from rich.markup import escape
from rich.table import Table

from uuvid.cli.common import (
    _fail,
    _fail_flagged,
    _flagged,
    _load_model,
    _print_json,
    _table,
    check_outputs,
    err_console,
    out_console,
)
from uuvid.cli.options import deprecated_out, renamed

#: ``thruster simulate --out`` warns before writing a time series bigger than this [bytes].
CSV_WARN_BYTES = 50e6


# ------------------------------------------------------------------------------------ thruster
def _parse_signal(spec: str):
    """``kind=step,amplitude=24,t0=0`` → a signal."""
    from uuvid.simulate.signals import signal_from_spec

    d: dict = {}
    for part in spec.split(","):
        if not part.strip():
            continue
        if "=" not in part:
            _fail(f"--signal: expected key=value, got {part!r} (e.g. kind=step,amplitude=24)")
        k, v = part.split("=", 1)
        k, v = k.strip(), v.strip()
        try:
            d[k] = float(v)
        except ValueError:
            d[k] = v
    try:
        return signal_from_spec(d)
    except (ValueError, TypeError) as e:
        _fail(f"--signal: {e}")


def thruster_show(model: str = typer.Argument(..., help="Model file (YAML/TOML) or preset name.")):
    """Print a thruster model's blocks and parameters."""
    chain = _load_model(model)
    t = Table(title=f"{chain.name}: {' → '.join(chain.signal_kinds)}")
    t.add_column("#")
    t.add_column("block")
    t.add_column("parameters")
    for i, b in enumerate(chain.blocks):
        d = b.to_dict()
        d.pop("type")
        t.add_row(str(i), b.TYPE, ", ".join(f"{k}={v}" for k, v in d.items()))
    out_console.print(t)
    if chain.inflow:
        sec = chain.inflow
        out_console.print(f"inflow ({sec['form']}: {sec.get('equation') or ''}; {sec.get('source') or ''})",
                          highlight=False, markup=False, soft_wrap=True)
        for name, p in sec["parameters"].items():
            sig = p.get("sigma")
            out_console.print(f"  {name} = {p['estimate']:.6g}"
                              + (f" ± {sig:.2g}" if sig is not None else "")
                              + (f" {p['unit']}" if p.get("unit") else ""),
                              highlight=False, markup=False)
        out_console.print("  (the blocks above are the bollard map; "
                          + ("a vehicle file flies this map with inflow: four-quadrant when a "
                             "thruster names this file as its propeller:)"
                             if sec.get("form") == "four-quadrant" else
                             "vehicle simulations do not read the linear form: fit "
                             "--model four-quadrant --diameter D for a map they fly)"),
                          highlight=False, markup=False)
    from uuvid.vehicle.propeller_note import model_propeller_note

    if (line := model_propeller_note(model)):
        out_console.print(line, highlight=False, markup=False, soft_wrap=True)


def thruster_simulate(
    model: str = typer.Argument(..., help="Model file (YAML/TOML) or preset name."),
    signal: str | None = typer.Option(
        None,
        "--signal",
        help="Input in the model's command unit (µs for a PWM ESC, V for a voltage input), e.g. "
        "kind=step,amplitude=24 | kind=sine,offset=1500,amplitude=400,period=2 "
        "| kind=square,low=0,high=24,period=1 | kind=sawtooth,... | kind=ramp,... | kind=sweep,... "
        "Default: a step to full forward command (1500 → 1900 µs for the T200, 0 → 24 for a "
        "voltage input), printed.",
    ),
    t_end: float = typer.Option(2.0, "--t-end", help="Simulated time [s]."),
    dt: float = typer.Option(1e-3, "--dt", help="Output sample time [s]."),
    substeps: int = typer.Option(4, "--substeps", help="RK4 steps per output sample."),
    out: Path | None = typer.Option(
        None, "--out", help="Folder for the time series (CSV), a plot and index.html."
    ),
    json_out: bool = typer.Option(False, "--json", help="Print step metrics as JSON."),
):
    """Simulate a thruster chain under an input signal; print response metrics.

    ``--signal kind=sampled,file=RUN.csv,time_col=t,command_col=V,...`` replays a logged command
    and compares with the logged speed/thrust (see ``uuvid thruster replay``)."""
    if signal is not None and "file=" in signal:
        from uuvid.cli.replay_cmd import replay_from_spec

        return replay_from_spec(model, signal, out, json_out)
    check_outputs(("--out", out, "folder"))  # a mistyped path is said
    chain = _load_model(model)
    from uuvid.simulate.signals import Constant, Step, default_step
    from uuvid.thruster.chain import command_range_warnings, signal_range_warnings

    sig = _parse_signal(signal) if signal is not None else default_step(chain)
    volt_warnings = signal_range_warnings(chain, sig, t_end)
    for w in volt_warnings:  # before the run: a wrong unit may make it diverge
        err_console.print(f"[yellow]warning:[/] {escape(w)}", highlight=False, soft_wrap=True)
    try:
        resp = chain.simulate(sig, t_end, dt=dt, substeps=substeps)
    except ValueError as e:
        _fail(str(e))
    is_step = isinstance(sig, (Step, Constant))  # step metrics (peak, τ) mean nothing for a square
    metrics = resp.metrics().as_dict(nan_as_none=True) if "thrust" in resp and is_step else {}
    summary = {"model": chain.name, "signal": sig.describe(), "t_end": t_end, "dt": dt, "metrics_SI": metrics}
    if not is_step:
        summary["metrics_note"] = ("step-response metrics apply to step inputs; this input is "
                                   + type(sig).__name__)
    from uuvid.core.metrics import STEP_METRIC_UNITS
    from uuvid.thruster.blocks import ESC

    esc = next((b for b in chain.blocks if isinstance(b, ESC)), None)
    units = chain.channel_units()
    summary["units"] = {"t_end": "s", "dt": "s", **{k: STEP_METRIC_UNITS.get(k, "") for k in metrics},
                        "channels": {k: units.get(k, "") for k in resp.channels}}
    if signal is None:
        summary["signal_note"] = (f"default input: step {sig.baseline:g} → {sig.amplitude:g} "
                                  f"{units['command']} at t = {sig.t0:g} s (--signal to change)")
        err_console.print(summary["signal_note"], highlight=False, markup=False, soft_wrap=True)
    if volt_warnings:
        summary.setdefault("warnings", []).extend(volt_warnings)
    if esc is not None:
        for w in command_range_warnings(resp["command"], esc, units["command"]):
            summary.setdefault("warnings", []).append(w)
            err_console.print(f"[yellow]warning:[/] {escape(w)}", highlight=False, soft_wrap=True)
    if out:
        from uuvid.core.atomic import atomic_dir, atomic_write_json
        from uuvid.core.html import Report
        from uuvid.core.plots import save_figure

        with atomic_dir(out) as work:  # whole or not at all: Ctrl-C leaves no empty folder
            size = resp.csv_bytes_estimate()
            rows = f"{len(resp.t):,} rows × {len(resp.channels) + 1} columns ≈ {size / 1e6:.3g} MB"
            summary["csv_size"] = rows
            big = size > CSV_WARN_BYTES
            err_console.print(("[yellow]warning:[/] " if big else "") + escape(
                f"writing {out / 'response.csv'}: {rows}"
                + (f" (over {CSV_WARN_BYTES / 1e6:g} MB: a larger --dt, the output sample time, "
                   "writes fewer rows; --substeps keeps the integration step)" if big else "")),
                highlight=False, soft_wrap=True)
            resp.to_csv(work / "response.csv")
            png = save_figure(resp.plot(title=chain.name), work / "response.png")
            atomic_write_json(work / "summary.json", summary)
            rep = Report(f"uuvid thruster simulate — {chain.name}")
            rep.add_json(summary, caption="Summary (SI)")
            rep.add_figure(png)
            rep.write(work)
        summary["out"] = str(out)
    if json_out:
        _print_json(summary)
    elif not metrics:
        err_console.print(summary.get("metrics_note", "no thrust output: no step metrics"), highlight=False,
                          markup=False)
        out_console.print(
            _table(f"{chain.name}: final values (SI)",
                   [{"channel": k, "final": float(resp[k][-1]), "unit": units.get(k, "")}
                    for k in resp.channels], ["channel", "final", "unit"], "{:.4g}"))
    else:
        out_console.print(
            _table(
                f"{chain.name} response (SI)",
                # a metric the response does not have (no overshoot: nothing decays) is said so,
                # not printed as "nan s"
                [{"metric": k, "value": v if v is not None else "— (none in this response)",
                  "unit": STEP_METRIC_UNITS.get(k, "") if v is not None else ""}
                 for k, v in metrics.items()],
                ["metric", "value", "unit"],
                "{:.4g}",
            )
        )
    if out and not json_out:
        err_console.print(f"wrote {out / 'response.csv'}, response.png, summary.json and "
                          f"{out / 'index.html'}", highlight=False, soft_wrap=True, markup=False)


def thruster_export(
    model: str = typer.Argument(..., help="Model file or preset name."),
    to: str = typer.Option("yaml", "--to", help="yaml | toml | uuv-simulator"),
    out: Path | None = typer.Option(None, "--out-file", help="File to write (default: stdout)."),
    old_out: Path | None = deprecated_out("--out-file"),
    thruster_id: int | None = typer.Option(None, "--thruster-id", help="uuv-simulator: <thrusterID> (0)."),
    table_points: int | None = typer.Option(
        None, "--table-points", help="uuv-simulator: points of a LinearInterp table (101)."
    ),
    command_range: str | None = typer.Option(
        None, "--command-range", help="uuv-simulator: LOW:HIGH input range over which a map "
        "without an exact conversion (e.g. a polynomial) is tabulated (default: the ESC's range)."
    ),
    supply_voltage: float | None = typer.Option(
        None, "--supply-voltage",
        help="Battery voltage [V] to export a model with an ESC at (a preset by its own voltage "
        "law, e.g. the T200's sheets); default: the model's own, printed.",
    ),
):
    """Write a model in our own format (YAML/TOML) or as a UUV Simulator thruster plugin snippet."""
    from uuvid.core.atomic import atomic_write_text
    from uuvid.io.export import ExportError, export_model
    from uuvid.thruster.resolve import export_supply

    out = renamed(out, "--out-file", old_out)
    check_outputs(("--out-file", out, "file"))  # before the work, as given
    chain = _load_model(model)
    try:
        chain, said = export_supply(model, chain, supply_voltage)
    except ValueError as e:
        _fail_flagged(e, {"supply_voltage": "--supply-voltage"})
    for line in said:  # notes and warnings (a supply outside the model's data), as written
        err_console.print(line, highlight=False, soft_wrap=True, markup=False)
    try:
        text, said = export_model(chain, to, thruster_id=thruster_id, table_points=table_points,
                                  command_range=command_range)
    except ExportError as e:
        _fail_flagged(e, {"thruster_id": "--thruster-id", "table_points": "--table-points",
                          "command_range": "--command-range", "to": "--to"})
    for line in said:
        err_console.print(_flagged(line, {"table_points": "--table-points",
                                          "command_range": "--command-range"}),
                          highlight=False, soft_wrap=True, markup=False)
    if out:
        atomic_write_text(out, text)
        err_console.print(f"wrote {out}", markup=False)
    else:
        sys.stdout.write(text)


#: Most inputs ``thruster predict`` evaluates: its table takes ≈ 1 kB of memory and ≈ 1 ms a row
#: (100,000 rows ≈ 100 MB and 100 s; the JSON is lighter but no more readable).
MAX_PREDICT_POINTS = 100_000


def _parse_range(spec: str, name: str):
    """``a:b:step`` (inclusive) or ``v1,v2,...`` → array of finite values, at most
    :data:`MAX_PREDICT_POINTS` of them (counted before the grid is allocated)."""
    import numpy as np

    try:
        if ":" in spec:
            parts = [float(x) for x in spec.split(":")]
            if (len(parts) != 3 or not all(map(math.isfinite, parts)) or parts[2] <= 0
                    or parts[1] < parts[0]):
                raise ValueError
            n = (parts[1] - parts[0]) / parts[2] + 1
            if n > MAX_PREDICT_POINTS:
                _fail(f"{name} {spec}: {n:.3g} inputs, more than the {MAX_PREDICT_POINTS:,} one "
                      f"prediction prints (≈ {n * 1e3 / 1e9:.3g} GB as a table, ≈ 1 kB a row); "
                      "give a larger step or a shorter range")
            n = int(round((parts[1] - parts[0]) / parts[2])) + 1
            return parts[0] + parts[2] * np.arange(n)
        x = np.array([float(x) for x in spec.split(",") if x.strip()])
        if x.size == 0 or not np.all(np.isfinite(x)):
            raise ValueError
        return x
    except ValueError:
        _fail(f"{name}: expected start:stop:step (finite numbers, stop >= start, step > 0) or a "
              f"comma list of finite numbers, got {spec!r}")


def thruster_predict(
    model: str = typer.Argument(..., help="Model file or preset name."),
    pwm: str | None = typer.Option(None, "--pwm", help="PWM commands [µs]: start:stop:step or a,b,c."),
    voltage: str | None = typer.Option(None, "--voltage", help="Motor voltages [V] (voltage-driven models)."),
    speed: str | None = typer.Option(None, "--speed", help="Propeller speeds [rad/s] (speed-driven maps)."),
    supply_voltage: float | None = typer.Option(
        None, "--supply-voltage",
        help="Battery voltage [V] for models with an ESC (default: the model's own, printed; "
        "t200 16 V, laidani-a2212 12 V).",
    ),
    json_out: bool = typer.Option(False, "--json", help="Print {input: [...], thrust_N: [...]} as JSON."),
):
    """Steady thrust of a model at given commands, voltages or speeds."""
    from uuvid.thruster.blocks import ESC
    from uuvid.thruster.chain import (
        ThrusterChain,
        command_range_warnings,
        monotonicity_warnings,
        zero_output_warnings,
    )
    from uuvid.thruster.resolve import (
        command_map_supply,
        is_command_map,
        supply_law,
        supply_used,
        supply_voltage_warnings,
    )

    chain = _load_model(model)
    given = [(k, v) for k, v in (("pwm_us", pwm), ("voltage_V", voltage), ("speed_rad_s", speed)) if v]
    if len(given) != 1:
        _fail("give exactly one of --pwm, --voltage, --speed")
    key, spec = given[0]
    x = _parse_range(spec, "--" + key.split("_")[0])
    blocks = list(chain.blocks)
    if supply_voltage is not None:
        from uuvid.core.checks import supply_voltage as check_supply

        try:
            supply_voltage = check_supply("supply_voltage", supply_voltage)
        except ValueError as e:
            _fail_flagged(e, {"supply_voltage": "--supply-voltage"})
        # a preset's own voltage law (the T200's speed is not ∝ V); its range is warned below
        law = supply_law(model, chain, quiet=True)
        if law is None and not is_command_map(chain):  # a command map is the same at any supply
            _fail(f"{chain.name} has no ESC block: --supply-voltage does not apply")
        if law is not None:
            blocks = list(law[0](supply_voltage).blocks)
    want = {"pwm_us": "command", "voltage_V": "voltage", "speed_rad_s": "speed"}[key]
    kinds = chain.signal_kinds
    if want not in kinds[:-1]:
        _fail(f"{chain.name} is driven by {kinds[0]}; it has no {want} input (signals: {' → '.join(kinds)})")
    start = kinds.index(want)
    sub = ThrusterChain(tuple(blocks[start:]), input_kind=want, name=chain.name)
    thrust = sub.steady_thrust(x)
    note = None
    if key == "pwm_us":  # --pwm feeds the model's command: named in the model's own unit
        unit = blocks[0].command_unit if isinstance(blocks[0], ESC) else None
        if unit == "volts" and blocks[0].neutral >= 500.0:  # the default of a file without a unit
            unit = "pwm_us"
            note = (f"{chain.name}'s ESC says command_unit volts (what a file without command_unit "
                    f"gets) but its neutral is {blocks[0].neutral:g}, a pulse width: read as µs; "
                    "add command_unit: pwm_us to the file")
        key = {"pwm_us": "pwm_us", "volts": "command_V", "duty": "duty"}.get(unit, "command")
        if key != "pwm_us":
            note = (f"--pwm gives {chain.name}'s command input, which is not a pulse width here ("
                    + (f"its {type(blocks[0]).__name__} takes {unit}" if unit else
                       f"its first block, {type(blocks[0]).__name__}, takes the command in the "
                       "unit of the data it was fitted on")
                    + f"): the column is {key}")
    # the output is named after what the chain produces (a speed-output model gives speeds)
    out_key = {"thrust": "thrust_N", "measured_thrust": "measured_thrust_N", "speed": "speed_rad_s",
               "voltage": "voltage_V"}.get(sub.output_kind, sub.output_kind)
    doc = {key: x.tolist(), out_key: thrust.tolist(), "model": chain.name}
    volts, source, _ = supply_used(model, chain, supply_voltage)
    supply_warnings = []
    if volts is None and start == 0 and is_command_map(chain):
        source, supply_warnings = command_map_supply(chain, supply_voltage)
        doc["supply_voltage_source"] = source
        err_console.print(f"supply voltage: {source}", highlight=False, soft_wrap=True, markup=False)
    elif volts is not None and start == 0:  # the supply matters only when the ESC is in the path
        doc["supply_voltage_V"] = volts
        doc["supply_voltage_source"] = source
        err_console.print(f"supply voltage: {source}", highlight=False, soft_wrap=True, markup=False)
        # one range check for presets and model files alike (the data's voltages)
        supply_warnings = supply_voltage_warnings(model, chain, volts)
    neutral = blocks[start].neutral if isinstance(blocks[start], ESC) else 0.0
    doc["warnings"] = zero_output_warnings(x, thrust, neutral) + monotonicity_warnings(
        x, thrust, neutral)
    if isinstance(blocks[start], ESC):
        doc["warnings"] += command_range_warnings(
            x, blocks[start], {"pwm_us": "µs", "command_V": "V"}.get(key, ""))
    if note:
        doc["warnings"].append(note)
    doc["warnings"] += supply_warnings
    for w in doc["warnings"]:
        err_console.print(f"[yellow]warning:[/] {escape(str(w))}", highlight=False, soft_wrap=True)
    if json_out:
        _print_json(doc)
    else:
        out_console.print(
            _table(
                f"{chain.name}: steady {sub.output_kind}"
                + (f" at {doc['supply_voltage_V']:g} V supply" if "supply_voltage_V" in doc else ""),
                [{key: float(a), out_key: float(b)} for a, b in zip(x, thrust)],
                [key, out_key],
                "{:.4g}",
            )
        )


def register(thruster_app: typer.Typer) -> None:
    thruster_app.command("show")(thruster_show)
    thruster_app.command("simulate")(thruster_simulate)
    thruster_app.command("export")(thruster_export)
    thruster_app.command("predict")(thruster_predict)
