"""numba's on-disk cache keyed on all of uuvid's compiled code, not on one file.

numba stamps a ``cache=True`` function with its own source file only: a change in a compiled
function it calls from another module (``vehicle_sim._fly_loop`` → ``control.dp_control``) goes
unnoticed and the stale machine code keeps running.  :func:`install` (called by ``uuvid``'s
``__init__``, stdlib only, numba not imported) makes uuvid's functions carry, besides numba's stamp
of their file, a digest of every uuvid module that uses numba: editing any of them recompiles what
depends on it.  Other packages' functions are left to numba's own locators.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import os
import sys

_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # the uuvid package
_TARGET = "numba.core.caching"


@functools.lru_cache(maxsize=1)
def numba_sources_digest() -> str:
    """SHA-256 (16 hex) of the path and bytes of every ``.py`` file of the package that mentions
    numba (the code the compiled functions can reach)."""
    h = hashlib.sha256()
    for dirpath, dirnames, filenames in os.walk(_ROOT):
        dirnames[:] = sorted(d for d in dirnames if d != "__pycache__")
        for f in sorted(filenames):
            if not f.endswith(".py"):
                continue
            p = os.path.join(dirpath, f)
            with open(p, "rb") as fh:
                data = fh.read()
            if b"numba" in data:
                h.update(os.path.relpath(p, _ROOT).encode())
                h.update(b"\x00")
                h.update(data)
    return h.hexdigest()[:16]


#: Cache folders found writable in this process (numba checks by writing a temporary file, for
#: every ``cache=True`` function it decorates: once per folder is enough).
_WRITABLE: set[str] = set()


@functools.cache
def _ours(py_file: str) -> bool:
    try:
        return os.path.commonpath([os.path.abspath(py_file), _ROOT]) == _ROOT
    except ValueError:
        return False


def _patch(caching) -> None:
    """Put uuvid-only subclasses of numba's locators (``NUMBA_CACHE_DIR``, in-tree, user-wide, in
    numba's order) first; they check a cache folder is writable once per process, not once per
    function (≈ 0.1–0.3 ms each, ~130 functions on a mission's import path)."""
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    if impl is None or getattr(impl, "_uuvid_patched", False):
        return

    def make(base):
        class Locator(base):
            @classmethod
            def from_function(cls, py_func, py_file):
                if not _ours(py_file):
                    return None
                return super().from_function(py_func, py_file)

            def get_source_stamp(self):
                return (super().get_source_stamp(), numba_sources_digest())

            def ensure_cache_path(self):
                path = self.get_cache_path()
                if path not in _WRITABLE:
                    super().ensure_cache_path()
                    _WRITABLE.add(path)

        Locator.__name__ = f"Uuvid{base.__name__}"
        return Locator

    bases = [getattr(caching, n, None)
             for n in ("UserProvidedCacheLocator", "InTreeCacheLocator", "UserWideCacheLocator")]
    if any(b is None for b in bases):
        return
    impl._locator_classes = [make(b) for b in bases] + list(impl._locator_classes)
    impl._uuvid_patched = True


class _Finder:
    """Patches ``numba.core.caching`` the moment it is imported (numba is not imported here)."""

    def find_spec(self, name, path=None, target=None):
        if name != _TARGET:
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            return spec
        run = spec.loader.exec_module

        def exec_module(module):
            run(module)
            try:
                _patch(module)
            except Exception:  # numba's internals changed: its own caching stays as it was
                pass

        spec.loader.exec_module = exec_module
        return spec


def install() -> None:
    """Key uuvid's numba caches on :func:`numba_sources_digest` (idempotent)."""
    if _TARGET in sys.modules:
        try:
            _patch(sys.modules[_TARGET])
        except Exception:
            pass
        return
    if not any(isinstance(f, _Finder) for f in sys.meta_path):
        sys.meta_path.insert(0, _Finder())
