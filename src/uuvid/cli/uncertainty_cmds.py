"""``uuvid sweep`` and ``uuvid montecarlo``: design sweeps and uncertainty propagation at scale.

::

    uuvid sweep SWEEP.yaml --out DIR [--backend auto|inprocess|processes|dask] [--workers N]
                [--scheduler tcp://host:port] [--chunk-size N] [--retries N] [--json]
    uuvid montecarlo MODEL --runs N [--seed S] [--out DIR] [--bounds reject|truncate|ignore]
                [--requirement "max_tracking_error_m<0.5"] [--backend ...] [--json]

``SWEEP`` is a sweep file (:mod:`uuvid.uncertainty.sweep`) or a built-in sweep
(``mclean-sensitivity``); ``MODEL`` an uncertain-model file (:mod:`uuvid.uncertainty.montecarlo`),
the ``summary.json`` of ``uuvid thruster fit --model physical``, or a built-in model
(``bluerov2-identified``, ``t200-physical``).  The backend defaults to ``auto``: Dask when
``--scheduler`` (or ``UUVID_DASK_SCHEDULER``) names a scheduler, else in-process (its compiled
batch already uses every core; see :func:`uuvid.uncertainty.execute.choose_backend`); the summary
says which ran and why.  ``--json`` prints one JSON
summary on stdout; progress goes to stderr.  Bad input exits with status 2; Ctrl-C leaves the
partial result in ``--out`` (``summary.json`` says ``"partial": true``) and exits with 130.

:func:`register` adds the two commands to the ``uuvid`` app; the small showcases ``uuvid demo``
calls live in :mod:`uuvid.uncertainty.showcase`.
"""

from __future__ import annotations

import math
from pathlib import Path

import typer

from uuvid.uncertainty.showcase import public_summary

__all__ = ["montecarlo_cmd", "register", "sweep_cmd"]


def _helpers():
    from uuvid.cli.common import _fail, _print_json, _table, err_console, out_console

    return _fail, _print_json, _table, err_console, out_console


def _user_errors() -> tuple:
    from uuvid.thruster.modelfile import ModelFileError
    from uuvid.uncertainty.montecarlo import ModelError
    from uuvid.uncertainty.params import ParameterNameError
    from uuvid.uncertainty.sweep import SweepError

    return (SweepError, ModelError, ModelFileError, ParameterNameError, FileNotFoundError,
            KeyError, ValueError)


def _show(summary: dict, title: str) -> None:
    _fail, _print_json, _table, err_console, out_console = _helpers()
    rows = [{"quantity": "runs", "value": str(summary["runs"])},
            {"quantity": "succeeded", "value": str(summary["succeeded"])},
            {"quantity": "status", "value": ", ".join(f"{k}: {v}" for k, v in
                                                      summary["status_counts"].items())},
            {"quantity": "backend", "value": f"{summary['backend']} ({summary.get('workers', 1)} "
                                             "workers)"},
            {"quantity": "backend chosen because", "value": summary.get("backend_reason", "")},
            {"quantity": "wall time [s]", "value": f"{summary['wall_time_s']:.3g}"},
            {"quantity": "runs per second [1/s]", "value": f"{summary['runs_per_s']:.4g}"}]
    if summary.get("failed_chunks"):
        rows.append({"quantity": "failed chunks", "value": "; ".join(
            f"{c['start']}–{c['stop'] - 1}: {c['error']}" for c in summary["failed_chunks"])})
    req = summary.get("requirement")
    if req:
        rows.append({"quantity": f"P({req['requirement']})",
                     "value": f"{req['probability']:.4f}  (95 % [{req['wilson95'][0]:.4f}, "
                              f"{req['wilson95'][1]:.4f}], {req['runs_simulated']} runs)"})
    d = summary.get("draws")
    if d:
        rows.append({"quantity": "draws", "value": f"{d['total']} ({d['rejected_draws']} rejected by "
                                                   f"bounds, {d['runs_rejected']} runs without an "
                                                   "admissible draw)"})
    from uuvid.uncertainty.targets import metric_label

    for m, v in (summary.get("metrics") or {}).items():
        rows.append({"quantity": metric_label(m), "value": f"{v['min']:.4g} … {v['max']:.4g}"})
    for m, v in (summary.get("metric_quantiles") or {}).items():
        qs = [k for k in v if k.startswith("q")]
        rows.append({"quantity": metric_label(m), "value": f"median {v['median']:.4g}, "
                                                           f"[{v[qs[0]]:.4g}, {v[qs[-1]]:.4g}]"})
    out_console.print(_table(title, rows, ["quantity", "value"]))


#: The study functions' keywords (named ```name=``` in their errors) → these commands' options.
STUDY_FLAGS = {"runs": "--runs", "seed": "--seed", "max_draws": "--max-draws", "band": "--band",
               "workers": "--workers", "chunk_size": "--chunk-size", "retries": "--retries"}


def _run(fn, out: Path | None, json_out: bool, title: str, where: str = ""):
    _fail, _print_json, _table, err_console, out_console = _helpers()
    try:
        res = fn()
    except KeyboardInterrupt:
        err_console.print(f"interrupted: partial result in {out}" if out else "interrupted", markup=False)
        raise typer.Exit(code=130) from None
    except ImportError as e:
        _fail(str(e))
    except _user_errors() as e:  # the file's name first, unless the message starts with it
        from uuvid.cli.common import _flagged

        text = _flagged(e.args[0] if isinstance(e, KeyError) and e.args else str(e), STUDY_FLAGS)
        _fail(text if not where or text.startswith(where) or text.startswith("--")
              else f"{where}: {text}")
    summary = dict(res.info)
    if out is not None:
        summary["out"] = str(out)
    if json_out:
        _print_json(public_summary(summary))
    else:
        _show(summary, title)
        if out is not None:
            err_console.print(f"report: {out / 'index.html'}  (table: {out / 'results.csv'})", markup=False)
    _outcome(res, summary, where)
    return res


def _outcome(res, summary: dict, where: str) -> None:
    """Say how many runs did not succeed and why (the first message of each status); exit 1
    when none succeeded (a study whose every run failed is not a result)."""
    _fail, _print_json, _table, err_console, out_console = _helpers()
    n, ok = int(summary.get("runs", 0)), int(summary.get("succeeded", 0))
    if not n or ok == n:
        return
    counts = ", ".join(f"{k}: {v}" for k, v in summary["status_counts"].items() if k != "ok")
    why = []
    table = getattr(res, "table", None)
    if table is not None and "status" in table and "message" in table:
        bad = table[table["status"] != "ok"]
        for st, g in bad.groupby("status", sort=False):
            row = g.iloc[0]
            why.append(f"{st}, e.g. run {row['run']}: {row['message']}")
    text = (f"{n - ok} of {n} runs did not succeed ({counts})" + ("; " if why else "")
            + "; ".join(why) + (f"; see {summary['out']}/results.csv" if summary.get("out") else ""))
    if ok == 0:
        _fail(f"{where + ': ' if where else ''}none of the runs succeeded: {text}", code=1)
    from rich.markup import escape

    err_console.print(f"[yellow]warning:[/] {escape(text)}", highlight=False, soft_wrap=True)


def sweep_cmd(
    sweep: str = typer.Argument(..., help="Sweep file (YAML/TOML) or built-in sweep "
                                          "(mclean-sensitivity)."),
    out: Path = typer.Option(..., "--out", help="Folder for results.csv, summary.json, plots, "
                                                "index.html."),
    backend: str | None = typer.Option(None, "--backend",
                                       help="auto (default) | inprocess | processes | dask."),
    workers: int | None = typer.Option(None, "--workers", help="Worker processes (default: CPUs)."),
    scheduler: str | None = typer.Option(None, "--scheduler",
                                         help="Dask scheduler tcp://host:port (or set "
                                              "UUVID_DASK_SCHEDULER)."),
    chunk_size: int | None = typer.Option(None, "--chunk-size", help="Runs per task."),
    retries: int | None = typer.Option(None, "--retries", help="Retries of a failed chunk."),
    json_out: bool = typer.Option(False, "--json", help="Print the summary as one JSON document."),
):
    """Run a parameter sweep (grid/list/random) of thruster or vehicle simulations."""
    _fail = _helpers()[0]
    from uuvid.uncertainty.sweep import load_sweep, run_sweep

    if workers is not None and workers < 1:
        _fail(f"--workers must be >= 1, got {workers}")
    if chunk_size is not None and chunk_size < 1:
        _fail(f"--chunk-size must be >= 1, got {chunk_size}")
    try:
        spec = load_sweep(sweep)
    except _user_errors() as e:
        _fail(str(e))
    _run(lambda: run_sweep(spec, out, backend=backend, workers=workers, scheduler=scheduler,
                           chunk_size=chunk_size, retries=retries),
         out, json_out, f"sweep {spec.name}: {spec.n_runs} runs", sweep)


def _parse_requirement(text: str):
    import re

    from uuvid.uncertainty.sweep import Requirement

    m = re.fullmatch(r"\s*([A-Za-z0-9_@.\[\]]+)\s*([<>])\s*([-+0-9.eE]+)\s*", text)
    if not m:
        raise ValueError(f"--requirement: expected METRIC<VALUE or METRIC>VALUE, got {text!r}")
    key = "below" if m.group(2) == "<" else "above"
    value = float(m.group(3))
    if not math.isfinite(value):
        raise ValueError(f"--requirement: the bound must be a finite number, got {text!r}")
    return Requirement(metric=m.group(1), **{key: value})


def montecarlo_cmd(
    model: str = typer.Argument(..., help="Uncertain-model file, a `uuvid thruster fit` "
                                          "summary.json, or bluerov2-identified | t200-physical."),
    runs: int = typer.Option(1000, "--runs", help="Number of draws."),
    seed: int = typer.Option(0, "--seed", help="Seed (run r draws from default_rng([seed, r]))."),
    out: Path | None = typer.Option(None, "--out", help="Folder for results, bands, plots, "
                                                        "index.html."),
    bounds: str = typer.Option("reject", "--bounds", help="reject (redraw) | truncate (clip) | "
                                                          "ignore."),
    max_draws: int = typer.Option(100, "--max-draws", help="reject: draws per run before giving up."),
    requirement: str | None = typer.Option(None, "--requirement",
                                           help='e.g. "max_tracking_error_m<0.5" (vehicle default).'),
    band: float = typer.Option(0.95, "--band", help="Central probability of the prediction bands "
                                                     "(0–1, 0.95 = 95 %)."),
    backend: str | None = typer.Option(None, "--backend",
                                       help="auto (default) | inprocess | processes | dask."),
    workers: int | None = typer.Option(None, "--workers", help="Worker processes (default: CPUs)."),
    scheduler: str | None = typer.Option(None, "--scheduler", help="Dask scheduler tcp://host:port."),
    chunk_size: int | None = typer.Option(None, "--chunk-size", help="Runs per task."),
    retries: int | None = typer.Option(None, "--retries", help="Retries of a failed chunk."),
    json_out: bool = typer.Option(False, "--json", help="Print the summary as one JSON document."),
):
    """Propagate an identified model's covariance: prediction bands and requirement probability."""
    _fail = _helpers()[0]
    from uuvid.uncertainty.montecarlo import load_model, run_montecarlo

    if runs < 1:
        _fail(f"--runs must be >= 1, got {runs}")
    if not 0 < band < 1:
        _fail(f"--band must lie in (0, 1), got {band}")
    if bounds not in ("reject", "truncate", "ignore"):
        _fail(f"--bounds: expected reject, truncate or ignore, got {bounds!r}")
    try:
        m = load_model(model)
        req = _parse_requirement(requirement) if requirement else None
    except _user_errors() as e:
        _fail(str(e))
    _run(lambda: run_montecarlo(m, runs, out, seed=seed, bounds=bounds, max_draws=max_draws,
                                requirement=req, band=band, backend=backend, workers=workers,
                                scheduler=scheduler, chunk_size=chunk_size, retries=retries),
         out, json_out, f"Monte Carlo {m.name}: {runs} draws", model)


def register(app: typer.Typer) -> None:
    """Add ``sweep`` and ``montecarlo`` to the ``uuvid`` app."""
    app.command("sweep")(sweep_cmd)
    app.command("montecarlo")(montecarlo_cmd)


# ---------------------------------------------------------------------------------------------
# demo pieces (called by ``uuvid demo``)
# ---------------------------------------------------------------------------------------------
