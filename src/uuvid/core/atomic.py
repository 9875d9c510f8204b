"""Atomic file output.

Every writer here builds the new content in a temporary file *in the same directory* as the
target, flushes and ``fsync``\\ s it, then ``os.replace``\\ s it onto the target.  A reader therefore
sees either the complete old file or the complete new file, never a partial one, and a failure
while writing leaves the old file untouched and no temporary file behind.

Parent directories are created as needed.

>>> from uuvid.core.atomic import atomic_path
>>> with atomic_path("out/fig.png") as tmp:   # doctest: +SKIP
...     fig.savefig(tmp)
...     # df.to_csv(tmp) works the same way

The temporary name keeps the target's full file name as its ending
(``.tmp-<pid>-<random>-fig.png``), so tools that infer the format from the extension (Matplotlib
``savefig``, pandas compression inference for ``.csv.gz``) behave as they would on the target.

**Folders** (:func:`atomic_dir`): a report folder is built whole in a temporary sibling folder and
then takes the old folder's place in one step (an atomic exchange on Linux), so an interrupted
report leaves the old folder intact, or nothing when there was none.

**Leftovers**: a process killed mid-write (SIGKILL, power loss) leaves its ``.tmp-*`` file or
folder behind.  The next write into that directory removes those whose owner process is gone
(the pid is in the name) and any older than :data:`STALE_AFTER_S` (:func:`sweep_stale`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as _dt
import enum
import errno
import json
import math
import os
import re
import secrets
import shutil
import sys
import tempfile
import time
from collections.abc import Iterator, Mapping
from pathlib import Path, PurePath
from typing import Any

__all__ = [
    "check_writable_dir",
    "check_writable_file",
    "atomic_dir",
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_json",
    "atomic_write_text",
    "sweep_stale",
    "to_jsonable",
]

_TMP_PREFIX = ".tmp-"
#: A ``.tmp-*`` leftover older than this (seconds) is removed whatever its owner (one day); one
#: whose owner process is gone goes after :data:`_ORPHAN_GRACE_S`.
STALE_AFTER_S = 24 * 3600.0
_ORPHAN_GRACE_S = 60.0
_OWNED = re.compile(r"^\.tmp-(\d+)-[0-9a-f]{8}-.")
_LEGACY = re.compile(r"^\.tmp-[0-9a-f]{8}-.")  # before the pid was in the name
_SWEPT: set[str] = set()


# --------------------------------------------------------------------------------------------
# low-level helpers
# --------------------------------------------------------------------------------------------


def check_writable_dir(path: str | os.PathLike[str], create: bool = True) -> Path:
    """Create the folder ``path`` if needed and check that a file can be written in it (a file is
    created and removed); raises :class:`OSError` (``NotADirectoryError`` when a parent is a
    file).  For commands that write several outputs: check them all before writing any, so a
    failure writes nothing.  ``create=False``: nothing is created — the nearest folder of
    ``path`` that exists is probed instead (the writers create the rest), so a run that then
    fails on its input leaves no empty folder behind."""
    d = Path(path)
    for parent in (d, *d.parents):
        if parent.exists():
            if not parent.is_dir():
                raise NotADirectoryError(errno.ENOTDIR, "a file, not a folder", str(parent))
            break
    if create:
        d.mkdir(parents=True, exist_ok=True)
    else:
        d = parent if parent.exists() else Path.cwd()
    try:
        fd, name = tempfile.mkstemp(prefix=".uuvid-check-", dir=d)
    except OSError as e:  # name the folder, not the probe file
        raise type(e)(e.errno, e.strerror, str(d)) from None
    os.close(fd)
    os.unlink(name)
    return d


def check_writable_file(path: str | os.PathLike[str], create: bool = True) -> Path:
    """Check that the file ``path`` can be written: not a folder, and its folder writable
    (:func:`check_writable_dir`; ``create``: as there); raises :class:`OSError`
    (``IsADirectoryError`` when ``path`` is a folder)."""
    p = Path(path)
    if p.is_dir():
        raise IsADirectoryError(errno.EISDIR, "a folder, not a file", str(p))
    check_writable_dir(p.parent, create=create)
    return p


def _create_temp(target: Path) -> Path:
    """Create (exclusively) an empty temporary file next to *target* and return its path.

    ``os.open(..., 0o666)`` lets the process umask decide the permissions, so the final file
    gets the same mode an ordinary ``open(path, "w")`` would have given it (``mkstemp`` would
    give 0600).
    """
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0)
    for _ in range(100):
        tmp = target.with_name(_temp_name(target))
        try:
            fd = os.open(tmp, flags, 0o666)
        except FileExistsError:
            continue
        os.close(fd)
        return tmp
    raise FileExistsError(f"could not create a temporary file next to {target}")


def _temp_name(target: Path) -> str:
    """``.tmp-<pid>-<8 hex>-<target name>``: the owner's pid lets :func:`sweep_stale` tell an
    orphan from a write in progress."""
    return f"{_TMP_PREFIX}{os.getpid()}-{secrets.token_hex(4)}-{target.name}"


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True  # exists (another user's) or cannot tell: keep it
    return True


def sweep_stale(directory: str | os.PathLike[str], *, max_age_s: float = STALE_AFTER_S,
                now: float | None = None) -> list[Path]:
    """Remove the ``.tmp-*`` files and folders in *directory* left by interrupted writes: those
    whose owner process (pid in the name) is gone and that are older than a minute, and any older
    than ``max_age_s``.  Only names of the form uuvid makes (``.tmp-<pid>-<8 hex>-<name>``, or
    the older ``.tmp-<8 hex>-<name>``) are considered.  Best effort (errors are ignored);
    returns what was removed."""
    d = Path(os.fspath(directory))
    now = time.time() if now is None else now
    removed = []
    try:
        entries = list(os.scandir(d))
    except OSError:
        return removed
    for e in entries:
        m = _OWNED.match(e.name)
        if m is None and not _LEGACY.match(e.name):
            continue  # not a name uuvid makes: never touched
        try:
            age = now - e.stat(follow_symlinks=False).st_mtime
        except OSError:
            continue
        orphan = m is not None and age > _ORPHAN_GRACE_S and not _pid_alive(int(m.group(1)))
        if not (orphan or age > max_age_s):
            continue
        p = Path(e.path)
        try:
            if e.is_dir(follow_symlinks=False):
                shutil.rmtree(p)
            else:
                p.unlink()
        except OSError:
            continue
        removed.append(p)
    return removed


def _sweep_once(directory: Path) -> None:
    """:func:`sweep_stale` a directory the first time this process writes into it."""
    key = os.fspath(directory)
    if key not in _SWEPT:
        _SWEPT.add(key)
        sweep_stale(directory)


def _fsync_file(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_BINARY", 0))
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_dir(directory: Path) -> None:
    """Best effort: make the rename itself durable (POSIX only)."""
    if os.name != "posix":
        return
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _copy_mode(src: Path, dst: Path) -> None:
    """Keep the permissions of an existing target (best effort)."""
    try:
        mode = os.stat(src).st_mode & 0o7777
        os.chmod(dst, mode)
    except OSError:
        pass


def _unlink_quietly(path: Path) -> None:
    with contextlib.suppress(OSError):
        os.unlink(path)


# --------------------------------------------------------------------------------------------
# public API
# --------------------------------------------------------------------------------------------


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path next to *path*; move it onto *path* only if the block succeeds.

    The temporary file already exists (empty) when the block starts; writers such as
    ``Figure.savefig`` or ``DataFrame.to_csv`` simply overwrite it.  On success the file is
    fsync'ed and atomically renamed onto *path*; on any exception it is removed and the
    exception propagates, leaving an existing *path* untouched.
    """
    target = Path(os.fspath(path))
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        _sweep_once(target.parent)
        tmp = _create_temp(target)
    except OSError as e:  # name the file asked for, not the hidden temporary one
        raise type(e)(e.errno, e.strerror, str(target)) from None
    try:
        yield tmp
        if not tmp.exists():
            raise FileNotFoundError(
                f"temporary file {tmp} disappeared before it could replace {target}"
            )
        _fsync_file(tmp)
        if target.exists():
            _copy_mode(target, tmp)
        os.replace(tmp, target)
    except BaseException:
        _unlink_quietly(tmp)
        raise
    _fsync_dir(target.parent)


#: ``index.html`` pages uuvid writes carry this tag; a folder whose index.html has it is a report
#: folder :func:`atomic_dir` may replace as a whole.
GENERATOR_TAG = '<meta name="generator" content="uuvid">'


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths in one step (Linux ``renameat2(RENAME_EXCHANGE)``); False when the
    system cannot."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    AT_FDCWD, RENAME_EXCHANGE = -100, 2
    rc = fn(AT_FDCWD, os.fsencode(a), AT_FDCWD, os.fsencode(b), RENAME_EXCHANGE)
    return rc == 0


def _is_report_folder(d: Path) -> bool:
    """Empty, or a folder whose ``index.html`` uuvid wrote (:data:`GENERATOR_TAG`)."""
    try:
        if not any(d.iterdir()):
            return True
        with open(d / "index.html", encoding="utf-8", errors="replace") as fh:
            return GENERATOR_TAG in fh.read(4096)
    except OSError:
        return False


#: The files a report wrote, recorded at the end of its ``index.html`` (:func:`_record_outputs`), so
#: the next report into that folder replaces those and keeps the rest (the user's notes).
_OUTPUTS = re.compile(r"<!-- uuvid-outputs: (\[.*?\]) -->", re.S)


def _files_under(d: Path) -> list[str]:
    """Relative POSIX paths of the files (and symbolic links) under ``d``, sorted."""
    out = []
    for root, dirs, files in os.walk(d):
        r = Path(root)
        out += [(r / f).relative_to(d).as_posix() for f in files]
        out += [(r / x).relative_to(d).as_posix() for x in dirs if (r / x).is_symlink()]
    return sorted(out)


def _record_outputs(d: Path) -> None:
    """Append the list of ``d``'s files to its ``index.html`` when uuvid wrote that page."""
    index = d / "index.html"
    try:
        with open(index, encoding="utf-8", errors="replace") as fh:
            if GENERATOR_TAG not in fh.read(4096):
                return
    except OSError:
        return
    names = json.dumps(_files_under(d), ensure_ascii=True).replace("--", "-\\u002d")
    with open(index, "a", encoding="utf-8") as fh:
        fh.write(f"\n<!-- uuvid-outputs: {names} -->\n")
        fh.flush()
        os.fsync(fh.fileno())


def _recorded_outputs(d: Path) -> set[str] | None:
    """The files the report in ``d`` wrote (:func:`_record_outputs`); ``None`` when its page
    does not say (a report of an earlier version)."""
    try:
        m = _OUTPUTS.findall((d / "index.html").read_text(encoding="utf-8", errors="replace"))
        return set(json.loads(m[-1])) if m else None
    except (OSError, ValueError):
        return None


def _carry_foreign(old: Path, new: Path) -> bool:
    """Link (or copy, where links are not possible) into ``new`` every file of the report folder
    ``old`` the report there did not write (:func:`_recorded_outputs`) and ``new`` does not hold,
    so they survive the exchange; ``False`` when ``old`` does not say what it wrote (nothing
    done: the caller merges instead of replacing)."""
    if not any(old.iterdir()):
        return True
    ours = _recorded_outputs(old)
    if ours is None:
        return False
    for rel in _files_under(old):
        if rel in ours or rel == "index.html":
            continue
        src, dst = old / rel, new / rel
        up = dst.parent
        while up != new:  # the new report writes a file where the user's file sits in a folder
            if up.is_symlink() or (up.exists() and not up.is_dir()):
                _clash(old / rel, f"the report now writes a file {up.relative_to(new)} where this "
                                  "file of yours sits in a folder of that name")
            up = up.parent
        if dst.is_dir() and not dst.is_symlink() and not (src.is_dir() and not src.is_symlink()):
            _clash(old / rel, "the report now writes a folder of that name")
        if dst.exists() or dst.is_symlink():  # the new report writes that name: its output
            continue
        dst.parent.mkdir(parents=True, exist_ok=True)
        try:
            os.link(src, dst, follow_symlinks=False)
        except OSError:
            shutil.copy2(src, dst, follow_symlinks=False)
    for root, dirs, _ in os.walk(old):  # the user's empty folders too
        for x in dirs:
            rel = (Path(root) / x).relative_to(old)
            if not (new / rel).exists() and not (Path(root) / x).is_symlink():
                (new / rel).mkdir(parents=True)
    return True


def _clash(path: Path, why: str) -> None:
    """A file of the user's in a report folder that the new report cannot keep beside its own
    outputs: ``FileExistsError`` naming it (the old folder is left as it was)."""
    raise FileExistsError(errno.EEXIST, f"{why}; move it out of the way and write the report again "
                          "(nothing was changed)", str(path))


def _unlisted(d: Path) -> bool:
    """``d`` holds a report that does not say which files it wrote (an earlier version's)."""
    return any(d.iterdir()) and _recorded_outputs(d) is None


def _merge_into(src: Path, dst: Path) -> None:
    """Move ``src``'s entries into the existing folder ``dst``, one atomic rename each, folders
    merged recursively (nothing of ``dst`` is removed but files of the same name), ``index.html``
    last; ``src`` is removed."""
    for p in sorted(src.iterdir(), key=lambda q: q.name == "index.html"):
        d = dst / p.name
        if p.is_dir() and not p.is_symlink() and d.is_dir() and not d.is_symlink():
            _merge_into(p, d)
        elif p.is_dir() and (d.is_dir() or d.is_symlink()):
            raise IsADirectoryError(f"cannot replace {d} by the folder {p.name}")
        else:
            os.replace(p, d)
    src.rmdir()


@contextlib.contextmanager
def atomic_dir(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield an empty temporary folder next to *path*; when the block succeeds it takes the
    place of *path* as a whole, and on any exception it is removed and *path* is left as it was.

    *path* absent: the folder is renamed into place.  *path* a report folder (empty, or its
    ``index.html`` written by uuvid): the two are exchanged atomically (Linux; elsewhere two
    renames a moment apart) and the old one removed — files of the old report the new one does
    not write go with it, while files the old report did not write (the user's notes, listed
    as not its own at the end of its ``index.html``) are linked into the new folder before the
    exchange and so kept.  *path* a folder holding other files (not a report of ours, or one
    of an earlier version that does not list its files): they are kept and the new entries
    moved in one by one, ``index.html`` last.  Nested use (a report inside a report folder)
    works: the inner folder is swapped inside the outer temporary one.
    """
    target = Path(os.path.abspath(os.fspath(path)))  # "." and ".." get a name and a parent
    if target == target.parent:
        raise ValueError(f"cannot write a report folder over the file-system root {target}")
    if target.exists() and not target.is_dir():
        # with its file name, so the command line says "a file of that name is in the way"
        raise NotADirectoryError(errno.ENOTDIR, "exists and is not a folder (a file of that name "
                                 "is in the way)", str(target))
    cwd = Path(os.path.abspath(os.getcwd()))
    merge = cwd == target or target in cwd.parents  # never swap the working folder away
    tmp = target.with_name(_temp_name(target))
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        _sweep_once(target.parent)
        tmp.mkdir()
    except OSError as e:  # name the folder asked for, not the hidden temporary one
        raise type(e)(e.errno, e.strerror, str(target)) from None
    try:
        yield tmp
        report_there = target.exists() and _is_report_folder(target)
        if not (report_there and (merge or _unlisted(target))):
            # merged over a report, its list would pass the old report's outputs for the user's
            _record_outputs(tmp)
        if report_there and not merge and not _carry_foreign(target, tmp):
            merge = True  # a report that does not list its files: merged, nothing removed
        _fsync_dir(tmp)
        if not target.exists():
            os.rename(tmp, target)
        elif not merge and _is_report_folder(target):
            if _exchange(tmp, target):
                shutil.rmtree(tmp, ignore_errors=True)  # now holds the old report
            else:
                old = target.with_name(_temp_name(target))
                os.rename(target, old)
                os.rename(tmp, target)
                shutil.rmtree(old, ignore_errors=True)
        else:
            _merge_into(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    _fsync_dir(target.parent)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> Path:
    """Atomically write *data* to *path*; returns the path."""
    target = Path(os.fspath(path))
    with atomic_path(target) as tmp:  # fsyncs the file before the rename
        tmp.write_bytes(data)
    return target


def atomic_write_text(
    path: str | os.PathLike[str],
    text: str,
    encoding: str = "utf-8",
    newline: str | None = None,
) -> Path:
    """Atomically write *text* to *path* (UTF-8 by default); returns the path.

    ``newline`` has the meaning of :func:`open`: ``None`` translates ``"\\n"`` to the platform
    line separator, ``""`` writes the text exactly as given.
    """
    target = Path(os.fspath(path))
    with atomic_path(target) as tmp, open(tmp, "w", encoding=encoding, newline=newline) as fh:
        fh.write(text)  # atomic_path fsyncs the file before the rename
    return target


def atomic_write_json(
    path: str | os.PathLike[str],
    obj: Any,
    indent: int | None = 2,
    sort_keys: bool = False,
) -> Path:
    """Atomically write *obj* as JSON (via :func:`to_jsonable`); returns the path.

    Numpy scalars/arrays become Python numbers/lists and non-finite floats become ``null``, so
    the output is strict JSON (``allow_nan=False``).  A trailing newline is added.
    """
    text = json.dumps(
        to_jsonable(obj),
        indent=indent,
        sort_keys=sort_keys,
        ensure_ascii=False,
        allow_nan=False,
        default=_json_default,
    )
    return atomic_write_text(path, text + "\n")


# --------------------------------------------------------------------------------------------
# JSON conversion
# --------------------------------------------------------------------------------------------


def _json_default(o: Any) -> Any:
    converted = to_jsonable(o)
    if converted is o:
        raise TypeError(f"Object of type {type(o).__name__} is not JSON serializable")
    return converted


def _float(x: float) -> float | None:
    return x if math.isfinite(x) else None


def to_jsonable(obj: Any) -> Any:
    """Return a structure made only of ``dict``/``list``/``str``/``int``/``float``/``bool``/``None``.

    * numpy arrays -> (nested) lists, numpy scalars -> Python scalars;
    * NaN and ±inf (Python or numpy floats) -> ``None`` (JSON ``null``);
    * mappings -> ``dict`` with ``str`` keys; tuples, lists, sets -> lists (sets sorted when
      possible, for reproducible output);
    * ``Path`` -> ``str``; ``datetime``/``date``/``time`` -> ISO 8601 strings;
      ``Enum`` -> its value; dataclasses -> dicts; objects with ``model_dump()`` (pydantic v2)
      -> their dump; pandas objects via ``to_dict``/``tolist``;
    * complex numbers -> ``{"real": ..., "imag": ...}``.

    Anything else is returned unchanged (``json.dumps`` will then reject it).
    """
    # Exact-type fast paths first (bool is an int subclass, keep it as bool).
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, int) and not _is_numpy(obj):
        return int(obj)
    if isinstance(obj, float) and not _is_numpy(obj):
        return _float(float(obj))
    if isinstance(obj, complex) and not _is_numpy(obj):
        return {"real": _float(obj.real), "imag": _float(obj.imag)}

    if _is_numpy(obj):
        import numpy as np

        if isinstance(obj, np.ndarray):
            if obj.dtype.kind in "biuU":  # already plain Python values after tolist()
                return obj.tolist()
            return to_jsonable(obj.tolist())  # floats (NaN), complex, datetimes, objects
        if isinstance(obj, np.generic):
            return to_jsonable(obj.item())

    if isinstance(obj, Mapping):
        return {_key(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, (set, frozenset)):
        items = [to_jsonable(v) for v in obj]
        try:
            return sorted(items)
        except TypeError:
            return items
    if isinstance(obj, PurePath):
        return str(obj)
    if isinstance(obj, (_dt.datetime, _dt.date, _dt.time)):
        return obj.isoformat()
    if isinstance(obj, _dt.timedelta):
        return obj.total_seconds()
    if isinstance(obj, enum.Enum):
        return to_jsonable(obj.value)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: to_jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, (bytes, bytearray)):
        return obj.decode("utf-8", errors="replace")

    model_dump = getattr(obj, "model_dump", None)
    if callable(model_dump) and not isinstance(obj, type):
        return to_jsonable(model_dump())
    module = type(obj).__module__ or ""
    if module.startswith("pandas"):
        if hasattr(obj, "isoformat"):  # Timestamp
            return obj.isoformat()
        to_dict = getattr(obj, "to_dict", None)
        if callable(to_dict):
            try:
                return to_jsonable(to_dict(orient="list"))  # DataFrame
            except TypeError:
                return to_jsonable(to_dict())  # Series
        tolist = getattr(obj, "tolist", None)
        if callable(tolist):
            return to_jsonable(tolist())
    return obj


def _is_numpy(obj: Any) -> bool:
    return (type(obj).__module__ or "").startswith("numpy")


def _key(k: Any) -> str:
    if isinstance(k, str):
        return k
    v = to_jsonable(k)
    if isinstance(v, str):
        return v
    if v is None or isinstance(v, bool):
        return json.dumps(v)
    return str(v)
