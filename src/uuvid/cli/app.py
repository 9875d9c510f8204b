"""The ``uuvid`` command: demo, reproduce, thruster, bench.

Data goes to stdout (``--json`` prints exactly one JSON document); progress and messages go to
stderr.  Errors in user input exit with status 2 and a one-line message naming what is wrong.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import typer
from rich.table import Table

from uuvid.cli.helptext import TidyHelpGroup

app = typer.Typer(
    cls=TidyHelpGroup,
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


def _register_subcommands(command: str | None = None) -> None:
    """Add the commands that live in other modules: all of them, or only those the top-level
    ``command`` needs (the console entry point names it, so ``uuvid simulate`` does not import the
    identification code).  Idempotent."""
    if command is None or command not in _PARTS_FOR and command not in _LOCAL_COMMANDS:
        want = _ALL_PARTS  # help, no command or an unknown one: list everything
    else:
        want = _PARTS_FOR.get(command, ())
    for part in want:
        if part in _REGISTERED:
            continue
        _REGISTERED.add(part)
        if part == "vehicle":
            from uuvid.cli.vehicle_cmds import simulate, vehicle_app

            _app.command("simulate")(simulate)
            _app.add_typer(vehicle_app, name="vehicle")
        elif part == "thruster":
            from uuvid.cli.thruster_cmds import register as register_thruster

            register_thruster(thruster_app)
        elif part == "fit":
            from uuvid.cli.fit_cmd import register as register_fit

            register_fit(thruster_app)
        elif part == "replay":
            from uuvid.cli.replay_cmd import register as register_replay

            register_replay(thruster_app)
        elif part == "identify":
            from uuvid.cli.hold_cmd import register as register_hold
            from uuvid.cli.identify_cmds import register as register_identify
            from uuvid.cli.vehicle_cmds import vehicle_app

            _register_subcommands("simulate")  # the vehicle group first
            register_identify(vehicle_app, reproduce_app)
            register_hold(vehicle_app)
        elif part == "uncertainty":
            from uuvid.cli.uncertainty_cmds import register as register_uncertainty

            register_uncertainty(_app)
        elif part == "examples":
            from uuvid.cli.examples_cmd import register as register_examples

            register_examples(_app)
        else:
            from uuvid.cli.log_cmds import register as register_log

            register_log(_app)


_REGISTERED: set[str] = set()
_ALL_PARTS = ("vehicle", "thruster", "fit", "replay", "identify", "uncertainty", "examples", "log")
_PARTS_FOR = {"simulate": ("vehicle",), "vehicle": ("vehicle", "identify"),
              "thruster": ("thruster", "fit", "replay"), "reproduce": ("identify",),
              "sweep": ("uncertainty",), "montecarlo": ("uncertainty",),
              "examples": ("examples",), "log": ("log",)}
_LOCAL_COMMANDS = ("study", "demo", "bench")  # defined in this module: nothing else to import


from uuvid.cli.common import (  # noqa: E402,F401  (re-exported: the app's own commands use them)
    _fail,
    _load_model,
    _print_json,
    _table,
    err_console,
    out_console,
)


# ------------------------------------------------------------------------------------ reproduce
@reproduce_app.command("mclean1991")
def reproduce_mclean(
    json_out: bool = typer.Option(False, "--json", help="Print the results as one JSON document."),
    out: Path | None = typer.Option(None, "--out", help="Write plots, tables and index.html here."),
):
    """McLean (1991): Table I, App. A load matching, voltage pulsing."""
    from uuvid.core.progress import progress_task
    from uuvid.papers import mclean1991

    with progress_task("McLean 1991: Table I cases", total=11) as task:
        result = mclean1991.reproduce(out_dir=out, progress=task.advance)
    if json_out:
        _print_json(result)
        return
    _show_mclean(result)
    if out:
        err_console.print(f"report: {out / 'index.html'}", markup=False)


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
    out_console.print(result["pulsing"]["answer"], markup=False)
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
    from uuvid.core.progress import progress_task
    from uuvid.papers import thruster_loop_study as st

    if name != "thruster-loop":
        _fail(f"unknown study {name!r}; available: thruster-loop")
    try:
        bws = tuple(float(x) for x in bandwidths.split(","))
    except ValueError:
        _fail(f"--bandwidths: expected comma-separated numbers, got {bandwidths!r}")
    from uuvid.cli.common import check_outputs

    check_outputs(("--out", out, "folder"))  # before the study, not after 35 s of it
    try:
        with progress_task("thruster-loop study", total=6 * len(bws)) as task:
            result = st.run_study(bws, progress=task.advance)
    except ValueError as e:
        from uuvid.cli.common import _fail_flagged

        _fail_flagged(e, {"bandwidths": "--bandwidths"})
    if out:
        result.report(out)
    if json_out:
        _print_json(result)
    else:
        out_console.print(result["answer"], markup=False)


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


# ------------------------------------------------------------------------------------ demo
@app.command("demo")
def demo(
    out: Path = typer.Option(Path("uuvid-demo"), "--out", help="Report folder to write."),
    json_out: bool = typer.Option(False, "--json", help="Print all numbers as one JSON document."),
    quick: bool = typer.Option(False, "--quick", help="A shorter run: no thruster-loop study or LQI "
                               "flight; coarser hold polar, endurance and dynamics selection."),
    workers: int = typer.Option(None, "--workers", min=1, help="Processes the sections run in "
                                "(default: one per core, at most 3; 1: all in this process)."),
):
    """Everything uuvid can do, on built-in data: reproduces the papers and writes a report."""
    from uuvid.demo import run_demo

    result = run_demo(out, quick=quick, workers=workers)
    if json_out:
        _print_json(result)
        return
    _show_mclean(result["mclean1991"])
    _show_laidani(result["laidani"])
    from uuvid.demo import caccia_headline

    out_console.print(caccia_headline(result["caccia2000"]))
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


@app.callback(invoke_without_command=True)
def _root(
    version: bool = typer.Option(False, "--version", is_eager=True, help="Print the version and exit."),
):
    """Model, simulate and identify underwater vehicles and their thrusters."""
    if version:
        from uuvid import __version__

        sys.stdout.write(f"uuvid {__version__}\n")
        raise typer.Exit()


_app = app
del app  # served by __getattr__ below, complete: `from uuvid.cli.app import app` sees every command


def __getattr__(name: str):
    if name == "app":
        _register_subcommands()
        return _app
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _user_warning(message, category, filename, lineno, line=None) -> str:
    """uuvid's own warnings (a vehicle file, identifiability, the cache) as ``warning: …``: the
    message names the file and key; the Python source line behind it is noise to a user.  Other
    packages' warnings keep their location (a bug report needs it)."""
    if category.__module__.split(".")[0] == "uuvid":
        return f"warning: {message}\n"
    return _default_format(message, category, filename, lineno, line)


_default_format = None


def main() -> None:  # console-script entry point
    """Run the command line, importing only the command module the arguments name."""
    import re
    import warnings

    global _default_format
    if _default_format is None:
        _default_format = warnings.formatwarning
        warnings.formatwarning = _user_warning
    command = next((a for a in sys.argv[1:] if not a.startswith("-")), None)
    _register_subcommands(command)
    _on_terminate_clean_up()
    try:
        _app()
    except SystemExit as e:  # Ctrl-C as the command returned (outside the root group's invoke)
        if e.code == 130 and _after_ctrl_c(e):
            from uuvid.core.progress import say_interrupted

            say_interrupted()
        raise
    except OSError as e:  # the file system said no (a folder that is a file, no permission, full)
        if os.environ.get("UUVID_DEBUG"):
            raise
        # an atomic write's temporary file is named as the file it was to become
        name = re.sub(r"(^|[\\/])\.tmp-\d+-[0-9a-f]{8}-([^\\/]+)$", r"\1\2", str(e.filename or ""))
        where = f"{name}: " if name else ""
        what = e.strerror or str(e) or type(e).__name__
        if isinstance(e, (FileExistsError, NotADirectoryError)) and e.filename \
                and os.path.isfile(e.filename):
            what = "a file of that name is in the way (a folder, or a new name, was expected)"
        sys.stderr.write(f"error: {where}{what} ({type(e).__name__}); nothing more was written "
                         "(UUVID_DEBUG=1 shows where)\n")
        raise SystemExit(2) from None


def _after_ctrl_c(e: BaseException) -> bool:
    """Whether ``e`` ends a chain of exceptions that began with a KeyboardInterrupt (``raise …
    from None`` ends the chain: a command that said its own "interrupted: …")."""
    seen = set()
    while e is not None and id(e) not in seen:
        if isinstance(e, KeyboardInterrupt):
            return True
        seen.add(id(e))
        e = e.__cause__ if e.__cause__ is not None or e.__suppress_context__ else e.__context__
    return False


def _on_terminate_clean_up() -> None:
    """SIGTERM (``kill``, a job scheduler's stop) ends the command like Ctrl-C does: as an
    exception, so that half-written temporary files are removed on the way out (the default
    action ends the process at once and leaves them)."""
    import signal

    def stop(signum, frame):
        raise SystemExit(128 + signum)

    try:
        signal.signal(signal.SIGTERM, stop)
    except (ValueError, OSError):  # not the main thread, or no such signal here
        pass


if __name__ == "__main__":  # pragma: no cover
    main()
