"""On-disk cache of computed arrays (steady thruster tables), next to the compiled batch kernels.

Location: ``$UUVID_KERNEL_CACHE/<sub>`` when that variable is set, else
``$XDG_CACHE_HOME/uuvid/<sub>`` (default ``~/.cache/uuvid/<sub>``); the batch kernels live in
``$UUVID_KERNEL_CACHE`` itself (``~/.cache/uuvid/batch_kernels``).  Entries are ``.npy`` files
named by a hash the caller computes from everything the result depends on — always including
:func:`code_version` (the package version and a hash of every source and data file of the
installed package), so a changed or reinstalled uuvid never reads an older entry; they are written
atomically (:mod:`uuvid.core.atomic`), so a reader sees a whole entry or none.  A cache that cannot
be read or written never fails the caller: the value is recomputed and one warning says why.
"""

from __future__ import annotations

import functools
import hashlib
import io
import os
import warnings
from pathlib import Path

import numpy as np

_WARNED: set[str] = set()


class CacheWarning(RuntimeWarning):
    """The on-disk cache could not be used; the result was computed instead."""


def warn_once(message: str) -> None:
    """Warn about a cache problem once per process and kind of problem."""
    kind = message.split(":", 1)[0]
    if kind not in _WARNED:
        _WARNED.add(kind)
        warnings.warn(message, CacheWarning, stacklevel=3)


def cache_root() -> Path:
    """The folder the batch kernels use (``$UUVID_KERNEL_CACHE`` or ``~/.cache/uuvid``)."""
    d = os.environ.get("UUVID_KERNEL_CACHE")
    if d:
        return Path(d)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "uuvid"


def cache_dir(sub: str) -> Path:
    """``cache_root()/sub`` (not created here)."""
    return cache_root() / sub


def digest(*parts) -> str:
    """SHA-256 of the parts (bytes, arrays or anything with a stable ``repr``), hex, 32 chars."""
    h = hashlib.sha256()
    for p in parts:
        if isinstance(p, np.ndarray):
            a = np.ascontiguousarray(p)
            h.update(f"{a.dtype.str}{a.shape}".encode())
            h.update(a.tobytes())
        elif isinstance(p, bytes):
            h.update(p)
        else:
            h.update(repr(p).encode())
        h.update(b"\x00")
    return h.hexdigest()[:32]


def file_digest(*paths) -> str:
    """Digest of source files' bytes (the code a cached result came from)."""
    h = hashlib.sha256()
    for p in paths:
        with open(p, "rb") as fh:
            h.update(fh.read())
    return h.hexdigest()[:16]


def source_digest(root) -> str:
    """SHA-256 (16 hex) of the relative path and bytes of every ``.py``/``.yaml``/``.json``/
    ``.csv`` file under ``root`` (``__pycache__`` left out)."""
    root = Path(root)
    h = hashlib.sha256()
    files = sorted(p for ext in ("py", "yaml", "yml", "json", "csv") for p in root.rglob(f"*.{ext}")
                   if "__pycache__" not in p.parts)
    for p in files:
        h.update(p.relative_to(root).as_posix().encode())
        h.update(b"\x00")
        h.update(p.read_bytes())
        h.update(b"\x00")
    return h.hexdigest()[:16]


@functools.lru_cache(maxsize=1)
def code_version() -> str:
    """``<uuvid version>+<source digest>`` of the installed package (:func:`source_digest`).
    Every disk-cache key includes it: any change to the code or its shipped data is a new key."""
    import uuvid

    return f"{uuvid.__version__}+{source_digest(Path(uuvid.__file__).resolve().parent)}"


def compiled_code_version() -> str:
    """``<uuvid version>+<digest of the modules that use numba>``
    (:func:`uuvid.core.numba_cache.numba_sources_digest`): the key of generated, compiled modules
    (mission loops, batch kernels), which can reach only that code.  An edit elsewhere (the CLI,
    a report, the docs) keeps their machine code instead of compiling them again (10–40 s each)."""
    import uuvid
    from uuvid.core.numba_cache import numba_sources_digest

    return f"{uuvid.__version__}+{numba_sources_digest()}"


@functools.lru_cache(maxsize=16)
def tree_stamp(*subpackages: str) -> str:
    """Digest of the package version and the relative path, size and modification time of every
    ``.py``/``.yaml``/``.json``/``.csv`` file in the given subpackages of uuvid (``""``: the top
    ``__init__``): a cheap stamp (no file is read, as Python's own bytecode cache does it) for
    results that depend only on those layers' code — imports only run downhill, so a result of
    layer ``k`` depends on layers ``0..k`` alone.  Taken once per process, as
    :func:`code_version` (the code a process runs is the code it imported)."""
    import uuvid

    root = Path(uuvid.__file__).resolve().parent
    parts = [uuvid.__version__]
    for sub in subpackages:
        base = root / sub if sub else root
        for dirpath, dirnames, filenames in os.walk(base):
            dirnames[:] = sorted(d for d in dirnames if d != "__pycache__") if sub else []
            for f in sorted(filenames):
                if f.rsplit(".", 1)[-1] in ("py", "yaml", "yml", "json", "csv"):
                    st = os.stat(os.path.join(dirpath, f))
                    parts.append(f"{os.path.relpath(os.path.join(dirpath, f), root)}:"
                                 f"{st.st_size}:{st.st_mtime_ns}")
    return digest(*parts)


def load_object(sub: str, key: str):
    """The object pickled under ``key`` in ``cache_dir(sub)`` by :func:`store_object`, or
    ``None`` (no entry, or one that cannot be read: it is overwritten by the next store).  The
    cache folder is the user's own, as numba's cache of compiled functions (also pickles) is."""
    import pickle

    path = cache_dir(sub) / f"{key}.pkl"
    if not path.is_file():
        return None
    try:
        with open(path, "rb") as fh:
            return pickle.load(fh)
    except Exception as e:  # noqa: BLE001 - any unreadable entry is recomputed
        warn_once(f"unreadable cache entry: {path} ({type(e).__name__}: {e}); recomputing")
        return None


def store_object(sub: str, key: str, obj) -> None:
    """Pickle ``obj`` under ``key`` atomically; an unwritable cache only warns (once)."""
    import pickle

    path = cache_dir(sub) / f"{key}.pkl"
    try:
        from uuvid.core.atomic import atomic_write_bytes

        atomic_write_bytes(path, pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL))
    except (OSError, pickle.PicklingError, TypeError, AttributeError) as e:
        warn_once(f"unwritable cache: {path.parent} ({e}); results are computed each time "
                  "(set UUVID_KERNEL_CACHE to a writable folder)")


def load_array(sub: str, key: str, shape: tuple[int, ...] | None = None) -> np.ndarray | None:
    """The array stored under ``key`` in ``cache_dir(sub)``, or ``None`` when there is none.  An
    entry that cannot be read, or has the wrong shape or non-finite values, counts as none (and
    is overwritten by the next :func:`store_array`)."""
    path = cache_dir(sub) / f"{key}.npy"
    if not path.is_file():
        return None
    try:
        with open(path, "rb") as fh:
            arr = np.load(fh, allow_pickle=False)
    except (OSError, ValueError, EOFError) as e:
        warn_once(f"unreadable cache entry: {path} ({e}); recomputing")
        return None
    if (shape is not None and arr.shape != shape) or not np.all(np.isfinite(arr)):
        warn_once(f"corrupt cache entry: {path} (shape {arr.shape} or non-finite values); "
                  "recomputing")
        return None
    return arr


def store_array(sub: str, key: str, arr: np.ndarray) -> None:
    """Store ``arr`` under ``key`` atomically; an unwritable cache only warns (once)."""
    path = cache_dir(sub) / f"{key}.npy"
    try:
        from uuvid.core.atomic import atomic_write_bytes

        buf = io.BytesIO()
        np.save(buf, np.asarray(arr), allow_pickle=False)
        atomic_write_bytes(path, buf.getvalue())
    except OSError as e:
        warn_once(f"unwritable cache: {path.parent} ({e}); results are computed each time "
                  "(set UUVID_KERNEL_CACHE to a writable folder)")
