"""``uuvid thruster replay``: drive a model with logged commands, compare with the logged response.

::

    uuvid thruster replay MODEL RUN.csv... --time-col t --command-col V --command-unit volts \
        [--speed-col w] [--thrust-col T] [--out DIR] [--json]

``uuvid thruster simulate MODEL --signal kind=sampled,file=RUN.csv,time_col=t,command_col=V,...``
does the same (keys: ``file``, ``time_col``, ``command_col``, ``speed_col``, ``thrust_col``,
``command_unit``, ``speed_unit``, ``thrust_unit``, ``neutral``).
"""

from __future__ import annotations

from pathlib import Path

import typer

from uuvid.identify.thruster.workflow import FitError, ReadOptions, replay_files

SPEC_KEYS = {"file", "time_col", "command_col", "speed_col", "thrust_col", "command_unit",
             "speed_unit", "thrust_unit", "neutral", "kind"}


def _run(model: str, files: list[Path], opts: ReadOptions, out: Path | None, json_out: bool):
    from uuvid.cli.common import _fail, _load_model, _print_json, err_console, out_console
    from uuvid.io.bench import BenchDataError

    chain = _load_model(model)
    try:
        rep = replay_files(chain, files, opts)
    except (BenchDataError, FitError, ValueError) as e:
        _fail(str(e))
    doc = rep.to_dict()
    if out is not None:
        try:
            doc["report"] = str(rep.report(out))
        except OSError as e:
            _fail(f"--out {out}: cannot write ({e.strerror or e})")
    if json_out:
        _print_json(doc)
        return
    out_console.print(rep.summary(), highlight=False, markup=False, soft_wrap=True)
    if out is not None:
        err_console.print(f"wrote {out / 'index.html'}", markup=False)


def replay_from_spec(model: str, spec: str, out: Path | None, json_out: bool) -> None:
    """``kind=sampled,file=RUN.csv,time_col=...`` (the ``thruster simulate --signal`` form)."""
    from uuvid.cli.common import _fail

    d = {}
    for part in spec.split(","):
        if part.strip():
            k, _, v = part.partition("=")
            d[k.strip()] = v.strip()
    bad = sorted(set(d) - SPEC_KEYS)
    if bad:
        _fail(f"--signal: unknown key {bad[0]!r} with file=; keys: {', '.join(sorted(SPEC_KEYS))}")
    if d.get("kind", "sampled") != "sampled":
        _fail("--signal: file= goes with kind=sampled")
    try:
        neutral = float(d["neutral"]) if "neutral" in d else None
    except ValueError:
        _fail(f"--signal: neutral must be a number, got {d['neutral']!r}")
    opts = ReadOptions(command_col=d.get("command_col", "command"), time_col=d.get("time_col", "time"),
                       speed_col=d.get("speed_col"), thrust_col=d.get("thrust_col"),
                       command_unit=d.get("command_unit", "volts"),
                       speed_unit=d.get("speed_unit"),
                       thrust_unit=d.get("thrust_unit"), neutral=neutral)
    _run(model, [Path(d["file"])], opts, out, json_out)


def thruster_replay(
    model: str = typer.Argument(..., help="Model file (YAML/TOML) or preset name."),
    data: list[Path] = typer.Argument(..., help="Logged runs (CSV/Parquet), one record each."),
    time_col: str = typer.Option("time", "--time-col", help="Time column [s]."),
    command_col: str = typer.Option("command", "--command-col", help="Command column."),
    command_unit: str = typer.Option("volts", "--command-unit", help="pwm_us | duty | volts."),
    speed_col: str | None = typer.Option(None, "--speed-col", help="Shaft speed column."),
    speed_unit: str | None = typer.Option(
        None, "--speed-unit", help="rad/s | rpm | rev/s (default: the column header's, else rad/s)."),
    thrust_col: str | None = typer.Option(None, "--thrust-col", help="Thrust column."),
    thrust_unit: str | None = typer.Option(
        None, "--thrust-unit", help="N | kgf | lbf | ozf | g (default: the column header's, else N)."),
    neutral: float | None = typer.Option(None, "--neutral",
                                         help="Neutral command (default 1500 µs, or 0)."),
    out: Path | None = typer.Option(None, "--out",
                                    help="Folder: predicted CSVs, plot, summary.json, index.html."),
    json_out: bool = typer.Option(False, "--json", help="Print the NRMSE table as JSON."),
):
    """Replay logged commands through a model; print predicted-vs-measured NRMSE per channel."""
    opts = ReadOptions(command_col=command_col, time_col=time_col, speed_col=speed_col,
                       thrust_col=thrust_col, command_unit=command_unit, speed_unit=speed_unit,
                       thrust_unit=thrust_unit, neutral=neutral)
    _run(model, data, opts, out, json_out)


def register(thruster_app: typer.Typer) -> None:
    thruster_app.command("replay")(thruster_replay)
