"""One BLAS thread for small dense problems.

A least-squares fit of a few parameters works on tall, thin matrices (a Jacobian of a few
columns): multithreaded BLAS/LAPACK only adds start-up and synchronisation to every SVD, and on
a machine whose cores are busy (two shared cores, a Dask worker, a Monte Carlo pool) its
threads wait for each other — ``uuvid thruster fit`` ran 3.5× slower with the default threads
than with one.  :func:`small_blas` limits the BLAS pools to one thread for the duration of a
block (threadpoolctl; the controller that finds the loaded libraries is built once per process,
so entering the block costs a few microseconds).

:func:`usable_cpus` is the number of cores this process may run on — what a worker or thread
count is taken from: ``os.cpu_count()`` counts the machine's, not the ones the process is pinned
to (``taskset``, a batch scheduler) nor a container's CPU quota (cgroups), and a pool of one
worker per counted core then time-slices on a few.
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
import sys

#: Problems with at most this many unknowns are "small": one BLAS thread.
SMALL_PROBLEM_COLUMNS = 64
#: Matrices with at most this many entries never start BLAS threads (OpenBLAS runs a level-2/3
#: call on one thread below 2304 × 4 = 9216 entries): nothing to limit, and entering the limit
#: (~70 µs) would cost more than the solve.
TINY_PROBLEM_ENTRIES = 4096


#: cgroup v2: ``"<quota> <period>"`` in µs, or ``"max <period>"`` without a quota
CGROUP_V2_CPU_MAX = "/sys/fs/cgroup/cpu.max"
#: cgroup v1: the quota (``-1``: none) and the period, µs
CGROUP_V1_CFS_QUOTA = "/sys/fs/cgroup/cpu/cpu.cfs_quota_us"
CGROUP_V1_CFS_PERIOD = "/sys/fs/cgroup/cpu/cpu.cfs_period_us"


def _read_words(path) -> list[str]:
    try:
        with open(path, encoding="ascii") as fh:
            return fh.read().split()
    except (OSError, ValueError):
        return []


def _quota_cpus(quota: str, period: str) -> int | None:
    """``ceil(quota / period)``, or ``None`` when there is no quota (``max``, ``-1``, unreadable)."""
    try:
        q, p = float(quota), float(period)
    except ValueError:
        return None
    if not (math.isfinite(q) and math.isfinite(p)) or q <= 0 or p <= 0:
        return None
    return max(1, math.ceil(q / p))


def cgroup_cpu_limit(cpu_max=CGROUP_V2_CPU_MAX, cfs_quota=CGROUP_V1_CFS_QUOTA,
                     cfs_period=CGROUP_V1_CFS_PERIOD) -> int | None:
    """The cores a cgroup CPU quota allows (``ceil(quota / period)``), or ``None`` without one:
    cgroup v2's ``cpu.max`` (``"150000 100000"`` → 2, ``"max 100000"`` → none), else v1's
    ``cpu.cfs_quota_us`` / ``cpu.cfs_period_us`` (quota ``-1`` → none); the smaller when both
    set one.  A missing or unreadable file sets none.  The paths are parameters for the tests."""
    found = []
    v2 = _read_words(cpu_max)
    if v2:
        found.append(_quota_cpus(v2[0], v2[1] if len(v2) > 1 else "100000"))
    q, p = _read_words(cfs_quota), _read_words(cfs_period)
    if q and p:
        found.append(_quota_cpus(q[0], p[0]))
    found = [n for n in found if n is not None]
    return min(found) if found else None


def usable_cpus(cpu_max=CGROUP_V2_CPU_MAX, cfs_quota=CGROUP_V1_CFS_QUOTA,
                cfs_period=CGROUP_V1_CFS_PERIOD) -> int:
    """The cores this process may use, at least 1: the CPUs of its affinity mask
    (``os.sched_getaffinity``; ``os.cpu_count()`` where there is none), capped by a cgroup CPU
    quota (:func:`cgroup_cpu_limit`).  The count to size a pool of workers or threads by."""
    try:
        n = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # not on Linux
        n = os.cpu_count() or 1
    limit = cgroup_cpu_limit(cpu_max, cfs_quota, cfs_period)
    return max(1, min(n, limit) if limit is not None else n)


@functools.lru_cache(maxsize=2)
def _controller(scipy_loaded: bool):
    """The libraries loaded now (SciPy brings its own OpenBLAS: looked for again once it is)."""
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # threadpoolctl is a dependency; without it, leave the threads alone
        return None
    return ThreadpoolController()


@contextlib.contextmanager
def small_blas(columns: int = 0, threads: int = 1, entries: int | None = None):
    """Limit the BLAS thread pools to ``threads`` inside the block when the problem has at most
    :data:`SMALL_PROBLEM_COLUMNS` unknowns (``columns``); larger problems keep their threads, and
    a matrix of at most :data:`TINY_PROBLEM_ENTRIES` ``entries`` is left alone (BLAS runs it on
    one thread anyway)."""
    if entries is not None and entries <= TINY_PROBLEM_ENTRIES:
        yield
        return
    ctl = _controller("scipy.linalg" in sys.modules) if columns <= SMALL_PROBLEM_COLUMNS else None
    if ctl is None:
        yield
        return
    with ctl.limit(limits=threads, user_api="blas"):
        yield
