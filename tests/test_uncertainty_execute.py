"""Execution backends: the same study in-process, over local processes and on a local Dask
cluster gives the same table; failed chunks are retried then reported; Ctrl-C leaves a readable
partial result marked partial."""

import json

import numpy as np
import pandas as pd
import pytest

from uuvid.uncertainty.execute import evaluate_chunk, read_result, resolve_backend, run_study
from uuvid.uncertainty.montecarlo import MonteCarloSpec, MonteCarloStudy, load_model
from uuvid.uncertainty.sweep import SweepSpec, SweepStudy

SWEEP = {"name": "exec-test",
         "target": {"kind": "thruster_step", "t_end": 0.4, "substeps": 1},
         "parameters": [{"name": "tunnel_length", "unit": "in", "values": [5, 10.5, 20]},
                        {"name": "voltage", "values": [8, 16, 24]},
                        {"name": "added_mass_coefficient", "values": [0.25, 1.0]}]}


def study():
    return SweepStudy(SweepSpec.model_validate(SWEEP))


# chunk functions for the failure tests: module level so that spawned workers can import them
def flaky_once(payload, start, stop, attempt=0, threads=None):
    """Fails the first attempt of the chunk holding run 5, then works."""
    if start <= 5 < stop and attempt == 0:
        raise RuntimeError("injected worker failure")
    return evaluate_chunk(payload, start, stop, attempt, threads)


def always_fails_on_run_5(payload, start, stop, attempt=0, threads=None):
    if start <= 5 < stop:
        raise RuntimeError(f"injected permanent failure (attempt {attempt})")
    return evaluate_chunk(payload, start, stop, attempt, threads)


def dies_once(payload, start, stop, attempt=0, threads=None):
    """The worker process running the chunk holding run 5 dies (first attempt)."""
    if start <= 5 < stop and attempt == 0:
        import os

        os._exit(3)
    return evaluate_chunk(payload, start, stop, attempt, threads)


class Interrupt:
    """Raises KeyboardInterrupt (as Ctrl-C would) when the third chunk starts."""

    def __init__(self):
        self.calls = 0

    def __call__(self, payload, start, stop, attempt=0, threads=None):
        self.calls += 1
        if self.calls == 3:
            raise KeyboardInterrupt
        return evaluate_chunk(payload, start, stop, attempt, threads)


# ------------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_inprocess_result_and_files(tmp_path):
    res = run_study(study(), tmp_path, backend="inprocess", chunk_size=5, progress=False)
    t = res.table
    assert t["run"].tolist() == list(range(18)) and t["status"].eq("ok").all()
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["partial"] is False and s["succeeded"] == 18 and s["runs"] == 18 and s["chunks"] == 4
    assert s["files"] == ["results.csv"] and not (tmp_path / "parts").exists()
    back = read_result(tmp_path)
    assert not back.partial
    pd.testing.assert_frame_equal(back.table, t, check_dtype=False)


@pytest.mark.slow
def test_chunking_does_not_change_results():
    a = run_study(study(), None, backend="inprocess", chunk_size=18, progress=False).table
    b = run_study(study(), None, backend="inprocess", chunk_size=4, progress=False).table
    pd.testing.assert_frame_equal(a, b)


@pytest.mark.slow
def test_processes_backend_identical_and_retries(tmp_path):
    ref = run_study(study(), None, backend="inprocess", progress=False).table
    res = run_study(study(), tmp_path, backend="processes", workers=2, chunk_size=4,
                    chunk_fn=flaky_once, progress=False)
    pd.testing.assert_frame_equal(res.table, ref)
    assert res.info["succeeded"] == 18 and res.info["failed_chunks"] == []
    assert len(res.info["workers_used"]) >= 1


@pytest.mark.slow
def test_a_dying_worker_process_is_replaced_and_its_chunk_retried():
    ref = run_study(study(), None, backend="inprocess", progress=False).table
    res = run_study(study(), None, backend="processes", workers=2, chunk_size=4,
                    chunk_fn=dies_once, progress=False)
    pd.testing.assert_frame_equal(res.table, ref)
    assert res.info["pool_restarts"] >= 1 and res.info["failed_chunks"] == []


def test_failed_chunk_is_retried_then_reported_never_dropped(tmp_path):
    res = run_study(study(), tmp_path, backend="inprocess", chunk_size=4, retries=2,
                    chunk_fn=always_fails_on_run_5, progress=False)
    t = res.table
    assert len(t) == 18 and t["run"].tolist() == list(range(18))
    failed = t[t["status"] == "failed"]
    assert failed["run"].tolist() == [4, 5, 6, 7]
    assert "after 3 attempt(s)" in failed["message"].iloc[0]
    assert "injected permanent failure (attempt 2)" in failed["message"].iloc[0]
    assert failed["tunnel_length"].notna().all()  # the runs keep their parameters
    assert failed["peak_output_thrust"].isna().all()
    s = res.info
    assert s["succeeded"] == 14 and s["status_counts"] == {"ok": 14, "failed": 4}
    assert s["failed_chunks"] == [{"start": 4, "stop": 8, "attempts": 3,
                                   "error": "RuntimeError: injected permanent failure (attempt 2)"}]
    assert json.loads((tmp_path / "summary.json").read_text())["succeeded"] == 14


def test_worker_flakiness_is_absorbed_by_a_retry():
    res = run_study(study(), None, backend="inprocess", chunk_size=4, chunk_fn=flaky_once,
                    progress=False)
    assert res.info["succeeded"] == 18 and not res.info["failed_chunks"]


def test_interrupt_leaves_readable_partial_result(tmp_path):
    with pytest.raises(KeyboardInterrupt):
        run_study(study(), tmp_path, backend="inprocess", chunk_size=4, chunk_fn=Interrupt(),
                  progress=False)
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["partial"] is True and s["interrupted"] is True
    assert s["runs"] == 18 and s["runs_in_table"] == 8 and s["succeeded"] == 8
    part = read_result(tmp_path)
    assert part.partial
    assert part.table["run"].tolist() == list(range(8))
    assert part.table["status"].eq("ok").all()
    assert np.isfinite(part.table["peak_output_thrust"]).all()


@pytest.mark.slow
def test_interrupt_in_the_main_process_with_workers(tmp_path):
    """Ctrl-C while the process pool works: queued chunks cancelled, parts on disk, partial."""
    def stop_after_two(res, done):
        if done >= 8:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_study(study(), tmp_path, backend="processes", workers=2, chunk_size=4,
                  on_chunk=stop_after_two, progress=False)
    part = read_result(tmp_path)
    assert part.partial and part.info["interrupted"]
    assert 8 <= len(part.table) < 18
    assert part.table["status"].eq("ok").all()


def test_partial_parts_are_readable_before_the_end(tmp_path):
    """While a study runs, summary.json says partial and the parts hold the finished runs."""
    seen = {}

    def peek(res, done):
        if done == 8:
            seen["result"] = read_result(tmp_path)

    run_study(study(), tmp_path, backend="inprocess", chunk_size=4, on_chunk=peek, progress=False)
    r = seen["result"]
    assert r.partial and r.info["done_runs"] == 8 and r.table["run"].tolist() == list(range(8))


def test_backend_resolution(monkeypatch):
    monkeypatch.delenv("UUVID_DASK_SCHEDULER", raising=False)
    assert resolve_backend(None, None) == ("inprocess", None)  # auto on one machine
    assert resolve_backend(None, "tcp://h:1") == ("dask", "tcp://h:1")
    monkeypatch.setenv("UUVID_DASK_SCHEDULER", "tcp://env:2")
    assert resolve_backend(None, None) == ("dask", "tcp://env:2")
    assert resolve_backend("inprocess", None) == ("inprocess", "tcp://env:2")
    with pytest.raises(ValueError, match="backend must be one of"):
        resolve_backend("threads", None)


# ------------------------------------------------------------------------------------------------
@pytest.mark.slow  # starts a local dask cluster (≈ 5 s)
def test_bluerov2_montecarlo_identical_on_a_local_dask_cluster(tmp_path):
    """The BlueROV2 square mission with the identified covariance: in-process batch and a local
    Dask cluster (2 worker processes) give identical tables for the same seed."""
    distributed = pytest.importorskip("distributed")
    spec = MonteCarloSpec(name="rov-dask", model=load_model("bluerov2-identified"), runs=200,
                          seed=11)
    a = run_study(MonteCarloStudy(spec), None, backend="inprocess", progress=False)
    assert a.info["succeeded"] == 200
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        b = run_study(MonteCarloStudy(spec), tmp_path, client=client, chunk_size=25,
                      progress=False)
        # a failing worker on the cluster: retried, reported
        c = run_study(SweepStudy(SweepSpec.model_validate(SWEEP)), None, client=client,
                      chunk_size=4, retries=1, chunk_fn=_dask_fail, progress=False)
    assert b.info["backend"] == "dask" and b.info["dask_workers"] == 2
    assert len(b.info["workers_used"]) == 2
    pd.testing.assert_frame_equal(a.table, b.table)
    for k in a.series:
        assert np.array_equal(a.series[k], b.series[k], equal_nan=True)
    assert c.info["status_counts"] == {"ok": 14, "failed": 4}
    assert c.info["failed_chunks"][0]["attempts"] == 2


def _dask_fail(payload, start, stop, attempt=0, threads=None):
    if start <= 5 < stop:
        raise RuntimeError("injected failure on a dask worker")
    from uuvid.uncertainty.execute import evaluate_chunk as ev

    return ev(payload, start, stop, attempt, threads)


@pytest.fixture(autouse=True, scope="module")
def _pickle_test_functions_by_value():
    """Dask workers do not have tests/ on their path: ship this module's functions by value."""
    try:
        import sys

        import cloudpickle

        cloudpickle.register_pickle_by_value(sys.modules[__name__])
    except (ImportError, ValueError):
        pass
    yield


class _Work:
    """A stand-in study: only what the backend choice reads."""

    def __init__(self, seconds):
        self.seconds = seconds

    def estimated_work_s(self):
        return self.seconds


def test_auto_backend_rule(monkeypatch):
    from uuvid.uncertainty import execute as ex

    monkeypatch.delenv("UUVID_DASK_SCHEDULER", raising=False)
    monkeypatch.setattr(ex, "default_workers", lambda: 4)
    # in-process batches on every core: processes could only add start-up
    c = ex.choose_backend(None, study=_Work(1e6), threads=4)
    assert c.backend == "inprocess" and "all 4 cores" in c.reason
    assert ex.choose_backend("auto", study=_Work(1e6), threads=8).backend == "inprocess"
    # in-process held to one thread: processes when each worker gets PAYOFF × its start-up
    need = ex.PROCESS_PAYOFF * ex.PROCESS_STARTUP_S
    big = ex.choose_backend(None, study=_Work(4 * need * 1.01), threads=1)
    assert big.backend == "processes" and "1 of 4 cores" in big.reason
    small = ex.choose_backend(None, study=_Work(4 * need * 0.99), threads=1)
    assert small.backend == "inprocess" and "does not give" in small.reason
    assert ex.choose_backend(None, study=None, threads=1).backend == "inprocess"  # unknown work
    # a scheduler or a client means Dask; an explicit backend is obeyed
    assert ex.choose_backend(None, "tcp://h:1").backend == "dask"
    assert ex.choose_backend(None, client=object()).reason.startswith("auto: a Dask client")
    assert ex.choose_backend("processes", study=_Work(0.0)).reason == "asked for"


def test_summary_says_which_backend_ran_and_why(monkeypatch):
    monkeypatch.delenv("UUVID_DASK_SCHEDULER", raising=False)
    res = run_study(study(), None, chunk_size=4, progress=False)
    assert res.info["backend"] == "inprocess"
    assert res.info["backend_reason"].startswith("auto: ")
    assert study().estimated_work_s() > 0


def test_a_study_that_would_fill_the_disk_is_refused_before_any_run(tmp_path, monkeypatch):
    """A million-run study wrote until the disk was full, then lost its consolidation: the disk it
    needs (parts and results together) is checked against the free space first, and the refusal
    says how many runs would fit."""
    import shutil
    from collections import namedtuple

    s = study()
    need = s.disk_bytes()
    usage = namedtuple("usage", "total used free")
    calls = []

    def chunk(payload, start, stop, attempt=0, threads=None):
        calls.append(start)
        return evaluate_chunk(payload, start, stop, attempt, threads)

    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(10 * need, 9 * need, 0.5 * need))
    with pytest.raises(OSError, match=r"would write ≈ .* GB .*are free there; give at most 9 runs"):
        run_study(s, tmp_path / "out", backend="inprocess", chunk_size=5, progress=False,
                  chunk_fn=chunk)
    assert not calls and not (tmp_path / "out").exists()
    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(10 * need, 8 * need, 2 * need))
    run_study(s, tmp_path / "out", backend="inprocess", chunk_size=5, progress=False)


@pytest.mark.slow
def test_the_disk_estimate_bounds_what_a_study_writes(tmp_path):
    """The estimate covers the peak (the chunk parts and the consolidated results side by side)
    and is not a wild over-estimate (within 4× of it)."""
    s = study()
    seen = []

    def peak(res, done):
        seen.append(sum(p.stat().st_size for p in (tmp_path / "parts").glob("*")))

    run_study(s, tmp_path, backend="inprocess", chunk_size=5, progress=False, on_chunk=peak)
    final = sum((tmp_path / f).stat().st_size for f in ("results.csv",) if (tmp_path / f).exists())
    final += sum(p.stat().st_size for p in tmp_path.glob("series.npz"))
    written = max(seen) + final
    assert written <= s.disk_bytes() <= 4 * written, (written, s.disk_bytes())
