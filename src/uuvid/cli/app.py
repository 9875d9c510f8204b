"""The ``uuvid`` command: demo, reproduce, thruster, bench.

Data goes to stdout (``--json`` prints exactly one JSON document); progress and messages go to
stderr.  Errors in user input exit with status 2 and a one-line message naming what is wrong.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import typer
from rich.console import Console
from rich.table import Table

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="Model, simulate and identify underwater vehicles and their thrusters.",
)
reproduce_app = typer.Typer(no_args_is_help=True, help="Reproduce a paper's printed numbers.")
thruster_app = typer.Typer(
    no_args_is_help=True, help="Thruster models: show, simulate, predict, export, fit."
)
app.add_typer(reproduce_app, name="reproduce")
app.add_typer(thruster_app, name="thruster")


def _register_subcommands() -> None:
    from uuvid.cli.fit_cmd import register as register_fit
    from uuvid.cli.vehicle_cmds import simulate, vehicle_app

    app.command("simulate")(simulate)
    app.add_typer(vehicle_app, name="vehicle")
    register_fit(thruster_app)
    from uuvid.cli.identify_cmds import register as register_identify

    register_identify(vehicle_app, reproduce_app)
    from uuvid.cli.uncertainty_cmds import register as register_uncertainty

    register_uncertainty(app)
    from uuvid.cli.hold_cmd import register as register_hold

    register_hold(vehicle_app)


out_console = Console()
err_console = Console(stderr=True)


def _print_json(obj) -> None:
    from uuvid.io.atomic import to_jsonable

    sys.stdout.write(json.dumps(to_jsonable(obj), indent=2, allow_nan=False) + "\n")
    sys.stdout.flush()


def _fail(msg: str) -> None:
    err_console.print(f"[bold red]error:[/] {msg}", highlight=False, soft_wrap=True)
    raise typer.Exit(code=2)


def _table(title: str, rows: list[dict], columns: list[str], fmt: str = "{:.3g}") -> Table:
    t = Table(title=title)
    for c in columns:
        t.add_column(c)
    for r in rows:
        t.add_row(*[fmt.format(r[c]) if isinstance(r[c], float) else str(r[c]) for c in columns])
    return t


# ------------------------------------------------------------------------------------ reproduce
@reproduce_app.command("mclean1991")
def reproduce_mclean(
    json_out: bool = typer.Option(False, "--json", help="Print the results as one JSON document."),
    out: Path | None = typer.Option(None, "--out", help="Write plots, tables and index.html here."),
):
    """McLean (1991): Table I, App. A load matching, voltage pulsing."""
    from uuvid.papers import mclean1991
    from uuvid.report.progress import progress_task

    with progress_task("McLean 1991: Table I cases", total=11) as task:
        result = mclean1991.reproduce(out_dir=out, progress=task.advance)
    if json_out:
        _print_json(result)
        return
    _show_mclean(result)
    if out:
        err_console.print(f"report: {out / 'index.html'}")


def _show_mclean(result: dict) -> None:
    from uuvid.papers.mclean1991 import TABLE1_FIELDS

    t = Table(title="McLean 1991, Table I — ours [thesis]")
    t.add_column("case")
    for f in TABLE1_FIELDS:
        t.add_column(f)
    for r in result["table1"]:
        t.add_row(r["case"], *[f"{r[f]:.3g} [{r['thesis'][f]:g}]" for f in TABLE1_FIELDS])
    out_console.print(t)
    out_console.print(
        _table(
            "App. A — load matching",
            result["load_matching"],
            ["motor", "gear_ratio", "prop_rpm", "thrust_lbf"],
        )
    )
    out_console.print(result["pulsing"]["answer"])
    if "identified" in result:
        idn, ef = result["identified"], result["experiment_fit"]
        out_console.print(
            f"Identified from Table I: α_o−α_i = {idn['delta_alpha']:.3f} ± {idn['delta_alpha_sigma']:.3f}, "
            f"β_o−β_i = {idn['delta_beta']:.4f} ± {idn['delta_beta_sigma']:.4f}.  Experiment fit "
            f"(Tables II/III): {ef['mean_abs_rel_error']:.1%} mean error vs the thesis's "
            f"{ef['thesis_mean_abs_rel_error']:.1%}."
        )


@app.command("study")
def study(
    name: str = typer.Argument(
        "thruster-loop",
        help="thruster-loop: lagging vs leading thrusters in heading and depth loops (McLean's conjecture)",
    ),
    json_out: bool = typer.Option(False, "--json", help="Print the results as one JSON document."),
    out: Path | None = typer.Option(None, "--out", help="Write the figure, table and index.html here."),
    bandwidths: str = typer.Option("1,2,4,6", "--bandwidths", help="Controller bandwidths [rad/s]."),
):
    """Reproducible studies built on the models (today: thruster dynamics in DP loops)."""
    from uuvid.papers import thruster_loop_study as st
    from uuvid.report.progress import progress_task

    if name != "thruster-loop":
        _fail(f"unknown study {name!r}; available: thruster-loop")
    try:
        bws = tuple(float(x) for x in bandwidths.split(","))
    except ValueError:
        _fail(f"--bandwidths: expected comma-separated numbers, got {bandwidths!r}")
    with progress_task("thruster-loop study", total=6 * len(bws)) as task:
        result = st.run_study(bws, progress=task.advance)
    if out:
        st.write_outputs(result, out)
    if json_out:
        _print_json(result)
    else:
        out_console.print(result["answer"])


@reproduce_app.command("laidani")
def reproduce_laidani(
    json_out: bool = typer.Option(False, "--json", help="Print the results as one JSON document."),
    out: Path | None = typer.Option(None, "--out", help="Write plots (Fig. 10) and index.html here."),
):
    """Laidani et al.: PWM → ESC → A2212 → degree-5 polynomial."""
    from uuvid.papers import laidani

    result = laidani.reproduce(out_dir=out)
    if json_out:
        _print_json(result)
        return
    _show_laidani(result)


def _show_laidani(result: dict) -> None:
    paper = result["paper_values"]
    rows = [
        {
            "quantity": "full forward thrust [N]",
            "ours": result["full_forward_N"],
            "paper": paper["full_forward_N"],
        },
        {
            "quantity": "full reverse thrust [N]",
            "ours": result["full_reverse_N"],
            "paper": paper["full_reverse_N"],
        },
        {"quantity": "forward peak [N]", "ours": result["peak_forward_N"], "paper": paper["peak_forward_N"]},
        {
            "quantity": "dead zone width [µs]",
            "ours": result["dead_zone_width_us"],
            "paper": paper["dead_zone_width_us"],
        },
        {
            "quantity": "saturation onset [µs]",
            "ours": result["saturation_us"],
            "paper": paper["saturation_us"],
        },
    ]
    out_console.print(_table("Laidani et al. — ours vs paper", rows, ["quantity", "ours", "paper"], "{:.4g}"))


# ------------------------------------------------------------------------------------ thruster
def _load_model(model: str):
    from uuvid.io.modelfile import ModelFileError, load_chain
    from uuvid.thruster.presets import PRESETS, preset_chain

    if model in PRESETS:
        return preset_chain(model)
    p = Path(model)
    if not p.exists():
        _fail(f"{model}: no such model file, and not a preset (presets: {', '.join(sorted(PRESETS))})")
    try:
        return load_chain(p)
    except ModelFileError as e:
        _fail(str(e))


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


@thruster_app.command("show")
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


@thruster_app.command("simulate")
def thruster_simulate(
    model: str = typer.Argument(..., help="Model file (YAML/TOML) or preset name."),
    signal: str = typer.Option(
        "kind=step,amplitude=24",
        "--signal",
        help="Input, e.g. kind=step,amplitude=24 | kind=sine,offset=1500,amplitude=400,period=2 "
        "| kind=square,low=0,high=24,period=1 | kind=sawtooth,... | kind=ramp,... | kind=sweep,...",
    ),
    t_end: float = typer.Option(2.0, "--t-end", help="Simulated time [s]."),
    dt: float = typer.Option(1e-3, "--dt", help="Output sample time [s]."),
    substeps: int = typer.Option(4, "--substeps", help="RK4 steps per output sample."),
    out: Path | None = typer.Option(
        None, "--out", help="Write the time series (CSV), a plot and index.html."
    ),
    json_out: bool = typer.Option(False, "--json", help="Print step metrics as JSON."),
):
    """Simulate a thruster chain under an input signal; print response metrics."""
    chain = _load_model(model)
    sig = _parse_signal(signal)
    try:
        resp = chain.simulate(sig, t_end, dt=dt, substeps=substeps)
    except ValueError as e:
        _fail(str(e))
    metrics = resp.metrics().as_dict(nan_as_none=True) if "thrust" in resp else {}
    summary = {"model": chain.name, "signal": sig.describe(), "t_end": t_end, "dt": dt, "metrics_SI": metrics}
    if out:
        from uuvid.io.atomic import atomic_write_json
        from uuvid.report.html import Report
        from uuvid.report.plots import save_figure

        out.mkdir(parents=True, exist_ok=True)
        resp.to_csv(out / "response.csv")
        png = save_figure(resp.plot(title=chain.name), out / "response.png")
        atomic_write_json(out / "summary.json", summary)
        rep = Report(f"uuvid thruster simulate — {chain.name}")
        rep.add_json(summary, caption="Summary (SI)")
        rep.add_figure(png)
        rep.write(out)
        summary["out"] = str(out)
    if json_out:
        _print_json(summary)
    else:
        out_console.print(
            _table(
                f"{chain.name} response (SI)",
                [{"metric": k, "value": v if v is not None else float("nan")} for k, v in metrics.items()],
                ["metric", "value"],
                "{:.4g}",
            )
        )


@thruster_app.command("export")
def thruster_export(
    model: str = typer.Argument(..., help="Model file or preset name."),
    to: str = typer.Option("yaml", "--to", help="yaml | toml | uuv-simulator"),
    out: Path | None = typer.Option(None, "--out", help="File to write (default: stdout)."),
    thruster_id: int = typer.Option(0, "--thruster-id", help="uuv-simulator: <thrusterID>."),
    table_points: int = typer.Option(
        101, "--table-points", help="uuv-simulator: points of a LinearInterp table."
    ),
):
    """Write a model in our own format (YAML/TOML) or as a UUV Simulator thruster plugin snippet."""
    import yaml

    from uuvid.io.atomic import atomic_write_text
    from uuvid.io.export import ExportError, to_uuv_simulator
    from uuvid.io.modelfile import _to_toml, chain_to_dict

    chain = _load_model(model)
    if to == "uuv-simulator":
        try:
            text = to_uuv_simulator(chain, thruster_id=thruster_id, table_points=table_points)
        except ExportError as e:
            _fail(str(e))
    elif to in ("yaml", "toml"):
        d = chain_to_dict(chain)
        text = _to_toml(d) if to == "toml" else yaml.safe_dump(d, sort_keys=False)
    else:
        _fail(f"--to: expected yaml, toml or uuv-simulator, got {to!r}")
    if out:
        atomic_write_text(out, text)
        err_console.print(f"wrote {out}")
    else:
        sys.stdout.write(text)


def _parse_range(spec: str, name: str):
    """``a:b:step`` (inclusive) or ``v1,v2,...`` → array."""
    import numpy as np

    try:
        if ":" in spec:
            parts = [float(x) for x in spec.split(":")]
            if len(parts) != 3 or parts[2] <= 0 or parts[1] < parts[0]:
                raise ValueError
            n = int(round((parts[1] - parts[0]) / parts[2])) + 1
            return parts[0] + parts[2] * np.arange(n)
        return np.array([float(x) for x in spec.split(",") if x.strip()])
    except ValueError:
        _fail(f"{name}: expected start:stop:step (stop >= start, step > 0) or a comma list, got {spec!r}")


@thruster_app.command("predict")
def thruster_predict(
    model: str = typer.Argument(..., help="Model file or preset name."),
    pwm: str | None = typer.Option(None, "--pwm", help="PWM commands [µs]: start:stop:step or a,b,c."),
    voltage: str | None = typer.Option(None, "--voltage", help="Motor voltages [V] (voltage-driven models)."),
    speed: str | None = typer.Option(None, "--speed", help="Propeller speeds [rad/s] (speed-driven maps)."),
    supply_voltage: float | None = typer.Option(
        None, "--supply-voltage", help="Battery voltage [V] for models with an ESC."
    ),
    json_out: bool = typer.Option(False, "--json", help="Print {input: [...], thrust_N: [...]} as JSON."),
):
    """Steady thrust of a model at given commands, voltages or speeds."""
    from uuvid.thruster.blocks import ESC
    from uuvid.thruster.chain import ThrusterChain

    chain = _load_model(model)
    given = [(k, v) for k, v in (("pwm_us", pwm), ("voltage_V", voltage), ("speed_rad_s", speed)) if v]
    if len(given) != 1:
        _fail("give exactly one of --pwm, --voltage, --speed")
    key, spec = given[0]
    x = _parse_range(spec, "--" + key.split("_")[0])
    blocks = list(chain.blocks)
    if supply_voltage is not None:
        if supply_voltage <= 0:
            _fail(f"--supply-voltage must be positive, got {supply_voltage}")
        idx = [i for i, b in enumerate(blocks) if isinstance(b, ESC)]
        if not idx:
            _fail(f"{chain.name} has no ESC block: --supply-voltage does not apply")
        blocks[idx[0]] = blocks[idx[0]].with_supply(supply_voltage)
    want = {"pwm_us": "command", "voltage_V": "voltage", "speed_rad_s": "speed"}[key]
    kinds = chain.signal_kinds
    if want not in kinds[:-1]:
        _fail(f"{chain.name} is driven by {kinds[0]}; it has no {want} input (signals: {' → '.join(kinds)})")
    start = kinds.index(want)
    sub = ThrusterChain(tuple(blocks[start:]), input_kind=want, name=chain.name)
    thrust = sub.steady_thrust(x)
    # the output is named after what the chain produces (a speed-output model gives speeds)
    out_key = {"thrust": "thrust_N", "measured_thrust": "measured_thrust_N", "speed": "speed_rad_s",
               "voltage": "voltage_V"}.get(sub.output_kind, sub.output_kind)
    doc = {key: x.tolist(), out_key: thrust.tolist(), "model": chain.name}
    if supply_voltage is not None:
        doc["supply_voltage_V"] = supply_voltage
    if json_out:
        _print_json(doc)
    else:
        out_console.print(
            _table(
                f"{chain.name}: steady {sub.output_kind}",
                [{key: float(a), out_key: float(b)} for a, b in zip(x, thrust)],
                [key, out_key],
                "{:.4g}",
            )
        )


# ------------------------------------------------------------------------------------ demo
@app.command("demo")
def demo(
    out: Path = typer.Option(Path("uuvid-demo"), "--out", help="Report folder to write."),
    json_out: bool = typer.Option(False, "--json", help="Print all numbers as one JSON document."),
    quick: bool = typer.Option(False, "--quick", help="Skip the slow sections (the thruster-loop study)."),
):
    """Everything uuvid can do, on built-in data: reproduces the papers and writes a report."""
    from uuvid.cli.demo import run_demo

    result = run_demo(out, quick=quick)
    if json_out:
        _print_json(result)
        return
    _show_mclean(result["mclean1991"])
    _show_laidani(result["laidani"])
    out_console.print(f"\nReport: [bold]{out / 'index.html'}[/]  (numbers: {out / 'demo.json'})")


# ------------------------------------------------------------------------------------ bench
@app.command("bench")
def bench(json_out: bool = typer.Option(False, "--json", help="Print timings as JSON.")):
    """Time the compiled simulators against plain reference runs in the same process."""
    from uuvid.cli.bench import run_benchmarks

    result = run_benchmarks()
    if json_out:
        _print_json(result)
        return
    for group, cases in result.items():
        if isinstance(cases, list):
            out_console.print(
                _table(f"bench: {group}", cases, ["case", "time_s", "reference_time_s", "ratio"], "{:.4g}")
            )


_register_subcommands()


def main() -> None:  # console-script entry point
    app()


if __name__ == "__main__":  # pragma: no cover
    main()
