"""One BLAS thread for small dense problems.

A least-squares fit of a few parameters works on tall, thin matrices (a Jacobian of a few
columns): multithreaded BLAS/LAPACK only adds start-up and synchronisation to every SVD, and on
a machine whose cores are busy (two shared cores, a Dask worker, a Monte Carlo pool) its
threads wait for each other — ``uuvid thruster fit`` ran 3.5× slower with the default threads
than with one.  :func:`small_blas` limits the BLAS pools to one thread for the duration of a
block (threadpoolctl; the controller that finds the loaded libraries is built once per process,
so entering the block costs a few microseconds).
"""

from __future__ import annotations

import contextlib
import functools
import sys

#: Problems with at most this many unknowns are "small": one BLAS thread.
SMALL_PROBLEM_COLUMNS = 64
#: Matrices with at most this many entries never start BLAS threads (OpenBLAS runs a level-2/3
#: call on one thread below 2304 × 4 = 9216 entries): nothing to limit, and entering the limit
#: (~70 µs) would cost more than the solve.
TINY_PROBLEM_ENTRIES = 4096


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
