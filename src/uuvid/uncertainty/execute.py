"""Running a study (a sweep or a Monte Carlo) in chunks: in-process, local processes or Dask.

One description, three backends that give the same table for the same seed:

``inprocess``
    Chunks run one after another in this process; each chunk is one call of the batched compiled
    simulator, parallel over its runs (numba threads).
``processes``
    Chunks go to a :class:`concurrent.futures.ProcessPoolExecutor` (``spawn`` workers, one numba
    thread each unless told otherwise); a progress bar on stderr.
``dask``
    Chunks go to a Dask distributed cluster (``--scheduler tcp://host:port``, the environment
    variable ``UUVID_DASK_SCHEDULER``, or a ``distributed.Client`` passed in); without an address
    a ``LocalCluster`` is started for the run.  Needs the ``dist`` extra
    (``pip install "uuvid[dist]"``, i.e. ``dask[distributed]``); workers must have ``uuvid``
    installed.

``auto`` (the default) picks one by :func:`choose_backend`'s rule: Dask when a scheduler or a
client is given; otherwise in-process, because one machine's cores are already all busy inside
each in-process chunk — local processes only add their start-up (spawn, import, loading the
compiled kernels: ≈ :data:`PROCESS_STARTUP_S` each) and the pickling of results (the bench
measured them at 0.37× and 0.07× the in-process speed).  Processes are chosen only when the
in-process batch is held to fewer threads than there are cores *and* the study's estimated work
gives every worker at least :data:`PROCESS_PAYOFF` times its start-up.  The choice and its reason
are in the summary (``backend``, ``backend_reason``).

Tasks are chunks of runs (``chunk_size``), never single runs.  A chunk is described by plain data
(the study's JSON payload and a run range), so workers rebuild the study themselves (once per
process, cached) and every run's parameters come from the study and the run index alone — grid
position, or the random stream ``default_rng([seed, run])`` — never from the chunking or the
worker.  Results stream back as they complete (``as_completed``), each row carrying its ``run``
index; the final table is sorted by run.

Failures: a chunk that raises is resubmitted up to ``retries`` times; after that its runs are put
in the table with status ``failed`` and the error, and the chunk is listed in
``summary["failed_chunks"]`` — never dropped.  The summary counts the runs that succeeded.

On disk (``out``): every completed chunk is written atomically to ``parts/`` and ``summary.json``
is rewritten with ``"partial": true`` after each chunk; at the end ``results.csv`` (one row per run)
and ``series.npz`` (per-run curves, if any) are written and the summary says
``"partial": false``.  Ctrl-C (KeyboardInterrupt) stops submitting, cancels what is queued, writes
the consolidated partial result (``results.csv`` with the runs done so far, ``"partial": true``,
``"interrupted": true``) and re-raises.  :func:`read_result` reads either form.  Before any run
the study's results must fit: in memory (they are held to the end) and on the disk of ``out``
(the parts and the consolidated files side by side at the end, ≈ twice the results) — a refusal
says how many runs fit.
"""

from __future__ import annotations

import importlib
import json
import math
import os
import socket
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from uuvid.core.result import DictSummaryResult, jsonable
from uuvid.core.threads import usable_cpus
from uuvid.uncertainty.targets import ChunkResult  # noqa: F401  (re-exported)

BACKENDS = ("inprocess", "processes", "dask")
#: Start-up of one local worker process, s (spawn, import uuvid, load the compiled kernels; the
#: order measured on a 2-core machine with warm caches).
PROCESS_STARTUP_S = 2.0
#: Most retries of a failed chunk (a chunk that fails a hundred times will not succeed).
MAX_RETRIES = 100
#: Processes pay when each worker gets at least this many times its start-up in work.
PROCESS_PAYOFF = 20.0
ENV_SCHEDULER = "UUVID_DASK_SCHEDULER"
RESULT_FORMAT = "uuvid-study-result/1"


# ---------------------------------------------------------------------------------------------
# the unit of work
# ---------------------------------------------------------------------------------------------
#: Study kinds a payload may name → the class that rebuilds it (imported by name in workers).
STUDY_KINDS = {"sweep": "uuvid.uncertainty.sweep:SweepStudy",
               "montecarlo": "uuvid.uncertainty.montecarlo:MonteCarloStudy"}

_STUDIES: dict[str, object] = {}


def study_from_payload(payload: dict):
    """Rebuild a study from its JSON payload (cached per process)."""
    key = json.dumps(payload, sort_keys=True)
    st = _STUDIES.get(key)
    if st is None:
        kind = payload.get("kind")
        if kind not in STUDY_KINDS:
            raise ValueError(f"unknown study kind {kind!r}")
        # by name: the studies call this executor, so it must not import them (no import circle)
        module, _, cls = STUDY_KINDS[kind].partition(":")
        st = getattr(importlib.import_module(module), cls).from_payload(payload)
        if len(_STUDIES) > 8:
            _STUDIES.clear()
        _STUDIES[key] = st
    return st


def evaluate_chunk(payload: dict, start: int, stop: int, attempt: int = 0,
                   threads: int | None = None) -> ChunkResult:
    """Evaluate runs ``start … stop-1`` of the study described by ``payload`` (any backend)."""
    if threads:
        import numba

        numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
    t0 = time.perf_counter()
    study = study_from_payload(payload)
    res = study.evaluate(int(start), int(stop))
    res.wall_time = time.perf_counter() - t0
    res.worker = f"{socket.gethostname()}:{os.getpid()}"
    return res


def _init_worker(threads: int | None) -> None:
    os.environ["UUVID_NO_PROGRESS"] = "1"
    if threads:
        import numba

        numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))


# ---------------------------------------------------------------------------------------------
# result on disk
# ---------------------------------------------------------------------------------------------
@dataclass
class StudyResult(DictSummaryResult):
    """The tidy table (one row per run), per-run series, the run ``info`` (what
    ``summary.json`` holds: counts, backend, requirement…) and the output folder.

    ``summary()`` is the text of the common result surface; ``summary["key"]`` still reads
    ``info`` (the field was called ``summary`` before)."""

    table: pd.DataFrame
    series: dict[str, np.ndarray]
    info: dict
    out: Path | None = None
    axes: dict[str, np.ndarray] = field(default_factory=dict)

    report_title = "Study"
    summary_field = "info"

    def _summary_text(self) -> str:
        i = self.info
        counts = i.get("status_counts") or (self.table["status"].value_counts().to_dict()
                                            if "status" in self.table else {})
        lines = [f"{len(self.table)} runs" + (" (partial)" if self.partial else "")
                 + (f", backend {i['backend']}" if i.get("backend") else "")
                 + (f", {i['wall_time_s']:.3g} s" if i.get("wall_time_s") is not None else ""),
                 "  status: " + ", ".join(f"{k} {v}" for k, v in counts.items())]
        from uuvid.uncertainty.targets import metric_label

        num = self._numeric()
        for c in list(num.columns)[:12]:
            x = num[c].to_numpy(dtype=float)
            x = x[np.isfinite(x)]
            if x.size:
                lines.append(f"  {metric_label(c):<32} median {np.median(x):.4g}  "
                             f"[{x.min():.4g}, {x.max():.4g}]")
        req = i.get("requirement")
        if isinstance(req, dict) and "probability" in req:
            lines.append(f"  requirement met with probability {req['probability']:.3g}")
        if self.out is not None:
            lines.append(f"  folder: {self.out}")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """The run info and the table (one record per run; the series stay in ``series``)."""
        return jsonable({"info": {k: v for k, v in self.info.items() if k != "spec"},
                         "table": self.table.to_dict(orient="records"),
                         "out": str(self.out) if self.out is not None else None})

    def plot(self, columns=None):
        """Histograms of the numeric result columns of the successful runs (up to 6)."""
        from uuvid.core.plots import new_figure

        num = self._numeric()
        cols = list(columns or num.columns)[:6] or ["run"]
        fig, ax = new_figure(1, len(cols), squeeze=False, figsize=(3.6 * len(cols), 3.2))
        for a, c in zip(ax[0], cols):
            x = num[c].to_numpy(dtype=float) if c in num else np.zeros(0)
            a.hist(x[np.isfinite(x)], bins=20)
            a.set_xlabel(_unit_label(c))
            a.set_ylabel("runs [count]")
        fig.suptitle(f"Distribution over the successful runs ({len(num)} of {len(self.table)})")
        return fig

    def _numeric(self) -> pd.DataFrame:
        t = self.ok if "status" in self.table else self.table
        return t.select_dtypes("number").drop(columns=["run"], errors="ignore")

    @property
    def partial(self) -> bool:
        return bool(self.info.get("partial"))

    @property
    def ok(self) -> pd.DataFrame:
        return self.table[self.table["status"] == "ok"]


class _Writer:
    """Writes parts and the summary atomically as chunks complete; consolidates at the end."""

    def __init__(self, out: Path | None, base_summary: dict):
        self.out = Path(out) if out is not None else None
        self.base = dict(base_summary)
        self.parts: list[str] = []
        if self.out is not None:
            self.out.mkdir(parents=True, exist_ok=True)
            (self.out / "parts").mkdir(exist_ok=True)
            for old in (self.out / "parts").glob("chunk-*"):
                old.unlink()
            for name in ("results.csv", "series.npz"):
                p = self.out / name
                if p.exists():
                    p.unlink()

    def chunk(self, res: ChunkResult, progress: dict) -> None:
        if self.out is None:
            return
        from uuvid.core.atomic import atomic_path

        stem = f"chunk-{res.start:09d}"
        with atomic_path(self.out / "parts" / f"{stem}.csv") as tmp:
            res.table.to_csv(tmp, index=False)
        self.parts.append(f"parts/{stem}.csv")
        if res.series:
            with atomic_path(self.out / "parts" / f"{stem}.npz") as tmp:
                with open(tmp, "wb") as fh:
                    np.savez(fh, run=res.table["run"].to_numpy(), **res.series)
            self.parts.append(f"parts/{stem}.npz")
        self.summary({**progress, "partial": True,
                      "parts": sorted(p for p in self.parts if p.endswith(".csv"))})

    def summary(self, extra: dict) -> None:
        if self.out is None:
            return
        from uuvid.core.atomic import atomic_write_json

        atomic_write_json(self.out / "summary.json", {**self.base, **extra})

    def final(self, result: StudyResult) -> None:
        if self.out is None:
            return
        from uuvid.core.atomic import atomic_path

        with atomic_path(self.out / "results.csv") as tmp:
            result.table.to_csv(tmp, index=False)
        files = ["results.csv"]
        if result.series:
            with atomic_path(self.out / "series.npz") as tmp:
                with open(tmp, "wb") as fh:
                    np.savez(fh, run=result.table["run"].to_numpy(), **result.series,
                             **{f"axis:{k}": v for k, v in result.axes.items()})
            files.append("series.npz")
        result.info["files"] = files
        self.summary(result.info)
        if not result.partial:
            for p in self.parts:
                try:
                    (self.out / p).unlink()
                except OSError:
                    pass
            try:
                (self.out / "parts").rmdir()
            except OSError:
                pass


def read_result(out: str | Path) -> StudyResult:
    """Read a study folder: the final result, or — for an interrupted or still running study —
    whatever parts are there (``summary["partial"]`` says which)."""
    out = Path(out)
    summary = json.loads((out / "summary.json").read_text())
    series: dict[str, np.ndarray] = {}
    axes: dict[str, np.ndarray] = {}
    if (out / "results.csv").exists() and "files" in summary:
        table = pd.read_csv(out / "results.csv", keep_default_na=True)
        if (out / "series.npz").exists():
            with np.load(out / "series.npz") as z:
                for k in z.files:
                    if k.startswith("axis:"):
                        axes[k[5:]] = z[k]
                    elif k != "run":
                        series[k] = z[k]
    else:
        parts = sorted((out / "parts").glob("chunk-*.csv")) if (out / "parts").is_dir() else []
        frames = [pd.read_csv(p) for p in parts]
        table = (pd.concat(frames, ignore_index=True).sort_values("run").reset_index(drop=True)
                 if frames else pd.DataFrame({"run": []}))
        npz = sorted((out / "parts").glob("chunk-*.npz")) if (out / "parts").is_dir() else []
        if npz:
            runs, acc = [], {}
            for p in npz:
                with np.load(p) as z:
                    runs.append(z["run"])
                    for k in z.files:
                        if k != "run":
                            acc.setdefault(k, []).append(z[k])
            order = np.argsort(np.concatenate(runs), kind="stable")
            series = {k: np.concatenate(v)[order] for k, v in acc.items()}
    if "message" in table:
        table["message"] = table["message"].astype(object).fillna("")
    return StudyResult(table, series, summary, out, axes)


# ---------------------------------------------------------------------------------------------
# the runner
# ---------------------------------------------------------------------------------------------
def chunk_ranges(n: int, size: int) -> list[tuple[int, int]]:
    size = max(1, int(size))
    return [(a, min(n, a + size)) for a in range(0, n, size)]


def default_workers() -> int:
    """The cores this process may use (its CPU affinity and a container's quota, not the
    machine's count: :func:`uuvid.core.threads.usable_cpus`)."""
    return usable_cpus()


@dataclass(frozen=True)
class BackendChoice:
    """The backend a study runs on, the Dask scheduler address (if any) and why."""

    backend: str
    scheduler: str | None
    reason: str


def _inprocess_threads(threads: int | None) -> int:
    if threads:
        return int(threads)
    import numba

    return int(numba.config.NUMBA_NUM_THREADS)


def choose_backend(backend: str | None = None, scheduler: str | None = None, *, client=None,
                   study=None, workers: int | None = None,
                   threads: int | None = None) -> BackendChoice:
    """Which backend runs a study, and why (the rule is in the module docstring).

    An explicit ``backend`` other than ``auto`` is used as asked.  ``auto``/``None``: Dask when a
    client, a ``scheduler`` or ``UUVID_DASK_SCHEDULER`` is given; else in-process when its
    compiled batch runs on every core (numba threads ≥ CPUs, the default); else local processes
    if ``study.estimated_work_s()`` spread over the workers is at least ``PROCESS_PAYOFF`` ×
    ``PROCESS_STARTUP_S`` per worker, in-process otherwise."""
    sched = scheduler or os.environ.get(ENV_SCHEDULER) or None
    if backend not in (None, "auto"):
        if backend not in BACKENDS:
            raise ValueError(f"backend must be one of auto, {', '.join(BACKENDS)}, got {backend!r}")
        return BackendChoice(backend, sched, "asked for")
    if client is not None:
        return BackendChoice("dask", sched, "auto: a Dask client was given")
    if sched:
        return BackendChoice("dask", sched, f"auto: a Dask scheduler was given ({sched})")
    cores = default_workers()
    nthreads = _inprocess_threads(threads)
    if nthreads >= cores:
        return BackendChoice("inprocess", None, (
            f"auto: one machine, and each in-process chunk already runs its runs in parallel on "
            f"all {cores} cores (numba threads); local processes would only add ≈"
            f"{PROCESS_STARTUP_S:g} s start-up each"))
    workers = int(workers) if workers else cores
    work = study.estimated_work_s() if study is not None and hasattr(study, "estimated_work_s") \
        else None
    need = PROCESS_PAYOFF * PROCESS_STARTUP_S
    if work is not None and work / workers >= need:
        return BackendChoice("processes", None, (
            f"auto: in-process runs on {nthreads} of {cores} cores and the estimated work "
            f"({work:.3g} s) gives each of {workers} workers ≥ {need:g} s "
            f"({PROCESS_PAYOFF:g}× its start-up)"))
    est = "unknown" if work is None else f"{work:.3g} s"
    return BackendChoice("inprocess", None, (
        f"auto: in-process runs on {nthreads} of {cores} cores, but the estimated work ({est}) "
        f"does not give each of {workers} workers {need:g} s ({PROCESS_PAYOFF:g}× its start-up)"))


def resolve_backend(backend: str | None, scheduler: str | None) -> tuple[str, str | None]:
    """``(backend, scheduler address)`` by :func:`choose_backend` (without a study)."""
    c = choose_backend(backend, scheduler)
    return c.backend, c.scheduler


def run_study(study, out: str | Path | None = None, *, backend: str | None = None,
              workers: int | None = None, scheduler: str | None = None, client=None,
              chunk_size: int | None = None, retries: int | None = None,
              threads_per_task: int | None = None, progress: bool | None = None,
              chunk_fn: Callable | None = None, on_chunk: Callable | None = None) -> StudyResult:
    """Run every run of ``study`` and return (and write, with ``out``) the tidy result.

    ``backend``: ``auto`` (``None``), ``inprocess``, ``processes`` or ``dask``
    (:func:`choose_backend`; the summary says which ran and why).
    ``chunk_fn`` replaces :func:`evaluate_chunk` (same signature; must be picklable for the
    process and Dask backends) — a hook for tests and instrumentation.  ``on_chunk(result,
    done_runs)`` is called in this process after every completed chunk.
    """
    from uuvid.uncertainty.targets import check_workers

    workers = check_workers(workers)
    if chunk_size is not None and int(chunk_size) < 1:
        raise ValueError(f"`chunk_size=` {chunk_size}: expected runs per task >= 1")
    if retries is not None and not 0 <= int(retries) <= MAX_RETRIES:
        raise ValueError(f"`retries=` {retries}: expected retries of a failed chunk within "
                         f"0..{MAX_RETRIES}")
    if hasattr(study, "check_memory"):
        study.check_memory()
    if out is not None and hasattr(study, "check_disk"):
        study.check_disk(out)
    choice = choose_backend(backend, scheduler, client=client, study=study, workers=workers,
                            threads=threads_per_task)
    backend, sched = choice.backend, choice.scheduler
    n = int(study.n_runs)
    workers = int(workers) if workers else default_workers()
    if chunk_size is None:
        chunk_size = study.default_chunk_size(backend, workers)
    retries = study.retries if retries is None else int(retries)
    if retries < 0:
        raise ValueError("retries must be >= 0")
    chunks = chunk_ranges(n, chunk_size)
    payload = study.payload()
    fn = chunk_fn or evaluate_chunk
    base = {"format": RESULT_FORMAT, "study": study.kind, "name": study.name, "runs": n,
            "backend": backend, "backend_reason": choice.reason, "scheduler": sched,
            "workers": workers if backend != "inprocess" else 1,
            "chunk_size": int(chunk_size), "chunks": len(chunks), "retries": retries,
            "spec": payload["spec"]}
    writer = _Writer(out, base)
    writer.summary({"partial": True, "done_runs": 0, "started": time.time()})
    results: dict[int, ChunkResult] = {}
    failed: dict[int, dict] = {}
    t0 = time.perf_counter()
    done_runs = 0
    interrupted = False

    from uuvid.core.progress import progress_task

    bar_disable = None if progress is None else (not progress)

    def completed(res: ChunkResult, bar) -> None:
        nonlocal done_runs
        results[res.start] = res
        done_runs += res.stop - res.start
        bar.advance(res.stop - res.start)
        writer.chunk(res, {"done_runs": done_runs, "failed_chunks": list(failed.values()),
                           "elapsed_s": time.perf_counter() - t0})
        if on_chunk is not None:
            on_chunk(res, done_runs)

    def failure(a: int, b: int, attempts: int, err: BaseException | str) -> None:
        text = err if isinstance(err, str) else "".join(
            traceback.format_exception_only(type(err), err)).strip()
        failed[a] = {"start": a, "stop": b, "attempts": attempts, "error": text}

    runner = {"inprocess": _run_inprocess, "processes": _run_processes, "dask": _run_dask}[backend]
    with progress_task(f"{study.kind} {study.name}", total=n, disable=bar_disable) as bar:
        try:
            info = runner(fn, payload, chunks, retries, workers, threads_per_task, sched, client,
                          lambda res: completed(res, bar), failure)
        except KeyboardInterrupt:
            interrupted = True
            info = {}
    wall = time.perf_counter() - t0
    result = _assemble(study, results, failed, chunks, base, wall, interrupted, info)
    writer.final(result)
    if interrupted:
        raise KeyboardInterrupt(f"{study.kind} {study.name} interrupted after {done_runs} of {n} "
                                f"runs; partial result in {out}" if out else "")
    return result


def _assemble(study, results, failed, chunks, base, wall, interrupted, info) -> StudyResult:
    frames = [results[a].table for a in sorted(results)]
    for _, f in sorted(failed.items()):
        t = study.parameter_table(f["start"], f["stop"])
        t = t.drop(columns=[c for c in t.columns if c.startswith("_")])
        t["status"] = "failed"
        t["message"] = (f"chunk {f['start']}–{f['stop'] - 1} failed after {f['attempts']} "
                        f"attempt(s): {f['error']}")
        frames.append(t)
    table = (pd.concat(frames, ignore_index=True) if frames else study.parameter_table(0, 0))
    table = table.sort_values("run", kind="stable").reset_index(drop=True)
    if "message" in table:
        table["message"] = table["message"].fillna("")
    # series aligned to the table (NaN rows for failed chunks)
    series: dict[str, np.ndarray] = {}
    axes: dict[str, np.ndarray] = {}
    names = set()
    for r in results.values():
        names |= set(r.series)
    if names:
        axes = study.series_axes()
        idx = {int(run): i for i, run in enumerate(table["run"].to_numpy())}
        for nm in sorted(names):
            width = next(r.series[nm].shape[1] for r in results.values() if nm in r.series)
            arr = np.full((len(table), width), np.nan)
            for r in results.values():
                if nm in r.series:
                    rows = [idx[int(x)] for x in r.table["run"].to_numpy()]
                    arr[rows] = r.series[nm]
            series[nm] = arr
    counts = {str(k): int(v) for k, v in table["status"].value_counts().items()} if len(table) else {}
    n_done = len(table)
    n = base["runs"]
    summary = dict(base)
    summary.update({
        "partial": bool(interrupted or n_done < n),
        "interrupted": bool(interrupted),
        "runs_in_table": n_done,
        "succeeded": int(counts.get("ok", 0)),
        "status_counts": counts,
        "failed_chunks": [failed[a] for a in sorted(failed)],
        "wall_time_s": wall,
        "runs_per_s": (n_done / wall) if wall > 0 else math.inf,
        "chunk_wall_time_s": float(sum(r.wall_time for r in results.values())),
        "workers_used": sorted({r.worker for r in results.values()}),
    })
    summary.update(info or {})
    summary.update(study.summarise(table, series))
    return StudyResult(table, series, summary, None, axes)


# ---------------------------------------------------------------------------------------------
# backends
# ---------------------------------------------------------------------------------------------
def _run_inprocess(fn, payload, chunks, retries, workers, threads, sched, client, completed,
                   failure) -> dict:
    if threads:
        import numba

        numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
    for a, b in chunks:
        for attempt in range(retries + 1):
            try:
                res = fn(payload, a, b, attempt, None)
            except KeyboardInterrupt:
                raise
            except Exception as e:  # noqa: BLE001 — reported, retried
                if attempt == retries:
                    failure(a, b, attempt + 1, e)
                continue
            completed(res)
            break
    return {}


def _run_processes(fn, payload, chunks, retries, workers, threads, sched, client, completed,
                   failure) -> dict:
    import multiprocessing as mp
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    workers = max(1, min(workers, len(chunks) or 1))
    per = threads or max(1, default_workers() // workers)
    ctx = mp.get_context("spawn")

    def new_pool():
        return ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_init_worker,
                                   initargs=(per,))

    pool = new_pool()
    attempts = {a: 0 for a, _ in chunks}
    pending: dict = {}
    restarts = 0

    def submit(a, b):
        pending[pool.submit(fn, payload, a, b, attempts[a], per)] = (a, b)

    try:
        for a, b in chunks:
            submit(a, b)
        while pending:
            done, _ = wait(list(pending), return_when=FIRST_COMPLETED)
            broken = False
            again = []
            for f in done:
                a, b = pending.pop(f)
                try:
                    res = f.result()
                except Exception as e:  # noqa: BLE001 — reported, retried
                    broken = broken or isinstance(e, BrokenProcessPool)
                    attempts[a] += 1
                    if attempts[a] > retries:
                        failure(a, b, attempts[a], f"worker process died: {e}"
                                if isinstance(e, BrokenProcessPool) else e)
                    else:
                        again.append((a, b))
                    continue
                completed(res)
            if broken:
                # every other future of a broken pool fails too: new pool, resubmit them
                again += list(pending.values())
                pending.clear()
                pool.shutdown(wait=False, cancel_futures=True)
                pool = new_pool()
                restarts += 1
            for a, b in again:
                submit(a, b)
    except KeyboardInterrupt:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown(wait=True)
    return {"threads_per_worker": per, "pool_restarts": restarts}


def _dask_client(sched: str | None, client, workers: int):
    try:
        from distributed import Client, LocalCluster
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("the dask backend needs the optional 'dist' extra: "
                          'pip install "uuvid[dist]" (dask[distributed])') from e
    if client is not None:
        return client, None
    if sched:
        return Client(sched), None
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                           dashboard_address=None)
    return Client(cluster), cluster


def _run_dask(fn, payload, chunks, retries, workers, threads, sched, client, completed,
              failure) -> dict:
    from distributed import as_completed

    cl, cluster = _dask_client(sched, client, workers)
    own = client is None
    per = threads or 1
    futures = []
    try:
        pl = cl.scatter([payload], broadcast=True)[0]  # one future for the whole description
        attempts = {a: 0 for a, _ in chunks}
        token = f"{os.getpid()}-{time.time_ns()}"
        meta: dict = {}

        def submit(a, b):
            f = cl.submit(fn, pl, a, b, attempts[a], per, pure=False, retries=0,
                          key=f"uuvid-chunk-{token}-{a}-{attempts[a]}")
            meta[f.key] = (a, b)
            futures.append(f)
            return f

        ac = as_completed([submit(a, b) for a, b in chunks])
        for f in ac:
            a, b = meta[f.key]
            if f.status == "finished":
                completed(f.result())
            else:
                try:
                    err = f.exception()
                except Exception as e:  # noqa: BLE001 — cancelled/lost futures
                    err = e
                attempts[a] += 1
                if attempts[a] > retries:
                    failure(a, b, attempts[a], err if isinstance(err, BaseException) else str(err))
                else:
                    ac.add(submit(a, b))
            f.release()
        info = {"dask_scheduler": cl.scheduler.address if cl.scheduler else sched,
                "dask_workers": len(cl.scheduler_info().get("workers", {})),
                "threads_per_task": per}
    except KeyboardInterrupt:
        try:
            cl.cancel(futures)
        finally:
            if own:
                cl.close()
                if cluster is not None:
                    cluster.close()
        raise
    if own:
        cl.close()
        if cluster is not None:
            cluster.close()
    return info


def _unit_label(column: str) -> str:
    """A result column with its unit: ``max_error_m [m]``; ``[SI]`` when the name says none."""
    from uuvid.uncertainty.targets import metric_unit

    u = metric_unit(column) or {"_m": "m", "_s": "s", "_N": "N", "_V": "V", "_A": "A"}.get(
        column[column.rfind("_"):] if "_" in column else "", "")
    return f"{column} [{u or 'SI'}]"
