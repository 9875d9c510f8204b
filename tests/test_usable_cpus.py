"""Worker and thread counts come from the cores this process may use — its CPU affinity and a
container's cgroup quota — not from ``os.cpu_count()``, the machine's (a 64-core host with a
2-CPU container quota started 64 workers that time-sliced on two).  The cgroup files are given
as temporary files."""

from __future__ import annotations

import os

import pytest

from uuvid.core import threads as T


@pytest.fixture
def eight_cores(monkeypatch):
    """A process allowed on 8 of a 64-core machine's CPUs."""
    monkeypatch.setattr(T.os, "sched_getaffinity", lambda pid: set(range(8)), raising=False)
    monkeypatch.setattr(T.os, "cpu_count", lambda: 64)


def _files(tmp_path, v2=None, quota=None, period=None):
    paths = {"cpu_max": tmp_path / "cpu.max", "cfs_quota": tmp_path / "cpu.cfs_quota_us",
             "cfs_period": tmp_path / "cpu.cfs_period_us"}
    for key, text in (("cpu_max", v2), ("cfs_quota", quota), ("cfs_period", period)):
        if text is not None:
            paths[key].write_text(text + "\n")
    return {k: str(v) for k, v in paths.items()}


@pytest.mark.parametrize("v2, quota, period, expected", [
    ("150000 100000", None, None, 2),  # 1.5 CPUs of quota: two cores busy part of the time
    ("200000 100000", None, None, 2),
    ("50000 100000", None, None, 1),
    ("2000000 100000", None, None, 8),  # a quota above the affinity: the affinity
    ("max 100000", None, None, 8),  # no quota
    (None, None, None, 8),  # no cgroup files
    ("garbage", None, None, 8),  # unreadable content
    (None, "150000", "100000", 2),  # cgroup v1
    (None, "-1", "100000", 8),  # v1 without a quota
    (None, "300000", None, 8),  # v1 without its period: no quota known
    ("max 100000", "300000", "100000", 3),
])
def test_usable_cpus_is_the_affinity_capped_by_a_cgroup_quota(tmp_path, eight_cores, v2, quota,
                                                               period, expected):
    assert T.usable_cpus(**_files(tmp_path, v2, quota, period)) == expected


def test_an_unreadable_cgroup_file_is_no_quota(tmp_path, eight_cores):
    d = tmp_path / "cpu.max"
    d.mkdir()  # reading a directory: IsADirectoryError
    assert T.cgroup_cpu_limit(cpu_max=d, cfs_quota=tmp_path / "no", cfs_period=tmp_path / "no") is None
    assert T.usable_cpus(cpu_max=d, cfs_quota=tmp_path / "no", cfs_period=tmp_path / "no") == 8


def test_without_an_affinity_call_the_cpu_count_is_used(tmp_path, monkeypatch):
    monkeypatch.delattr(T.os, "sched_getaffinity", raising=False)
    monkeypatch.setattr(T.os, "cpu_count", lambda: None)  # undeterminable: 1
    assert T.usable_cpus(**_files(tmp_path)) == 1
    monkeypatch.setattr(T.os, "cpu_count", lambda: 6)
    assert T.usable_cpus(**_files(tmp_path)) == 6
    assert T.usable_cpus(**_files(tmp_path, "200000 100000")) == 2


def test_the_real_count_is_within_the_machine_and_the_pools_use_it(monkeypatch):
    n = T.usable_cpus()
    assert 1 <= n <= (os.cpu_count() or 1)
    if hasattr(os, "sched_getaffinity"):
        assert n <= len(os.sched_getaffinity(0))
    # the worker counts follow it, not os.cpu_count()
    from uuvid.uncertainty import execute as ex

    monkeypatch.setattr(T.os, "cpu_count", lambda: 64)
    monkeypatch.setattr(ex, "usable_cpus", lambda: 3)
    assert ex.default_workers() == 3
    from uuvid.demo import MAX_WORKERS, _workers

    assert _workers(None) == min(3, MAX_WORKERS)


def test_uuvid_bench_reports_the_machines_cores_and_the_usable_ones(monkeypatch):
    from types import SimpleNamespace

    from uuvid.cli import bench

    monkeypatch.setattr(bench, "_load", lambda name: SimpleNamespace(run_all=dict))
    monkeypatch.setattr(T.os, "cpu_count", lambda: 64)
    monkeypatch.setattr(T, "cgroup_cpu_limit", lambda *a: 2)
    machine = bench.run_benchmarks()["machine"]
    assert machine["cpus"] == 64 and machine["usable_cpus"] == 2
