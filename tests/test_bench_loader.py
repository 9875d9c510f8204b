"""``uuvid bench`` loads benchmarks/ files as registered modules, so numba's on-disk cache of their
``cache=True`` functions works in the next process too (issue 20: ``No module named '<dynamic>'``
on every run after the first)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

TINY = '''from numba import njit


@njit(cache=True)
def twice(x):
    return 2.0 * x


def run_all():
    return {"tiny": twice(3.0)}
'''


@pytest.mark.slow
def test_benchmark_loader_runs_twice_with_numba_cache(tmp_path):
    bench = tmp_path / "benchmarks"
    bench.mkdir()
    (bench / "bench_thruster.py").write_text("")  # the folder's marker
    (bench / "bench_tiny.py").write_text(TINY)
    env = {**os.environ, "UUVID_BENCHMARKS": str(bench), "NUMBA_CACHE_DIR": str(tmp_path / "nb"),
           "PYTHONPATH": os.pathsep.join([str(Path(__file__).parents[1] / "src"),
                                          os.environ.get("PYTHONPATH", "")])}
    code = "from uuvid.cli.bench import _load; print(_load('bench_tiny').run_all())"
    for run in range(2):  # the second process loads the first one's cache
        res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                             text=True, timeout=120)
        assert res.returncode == 0, (run, res.stderr[-2000:])
        assert "{'tiny': 6.0}" in res.stdout
        if run == 0:
            assert list((tmp_path / "nb").rglob("*.nbi")), "nothing cached: the test proves nothing"


def test_benchmark_modules_are_registered_once(tmp_path, monkeypatch):
    from uuvid.cli.bench import _load

    (tmp_path / "bench_thruster.py").write_text("")
    (tmp_path / "bench_plain.py").write_text("X = object()\n")
    monkeypatch.setenv("UUVID_BENCHMARKS", str(tmp_path))
    m = _load("bench_plain")
    try:
        assert sys.modules["uuvid_benchmarks_bench_plain"] is m
        assert _load("bench_plain") is m and m.X is _load("bench_plain").X
    finally:
        sys.modules.pop("uuvid_benchmarks_bench_plain", None)
