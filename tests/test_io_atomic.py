"""Tests for uuvid.core.atomic."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
import pytest

from uuvid.core.atomic import (
    atomic_path,
    atomic_write_bytes,
    atomic_write_json,
    atomic_write_text,
    to_jsonable,
)


def _leftovers(directory: Path, keep: set[str]) -> list[str]:
    return sorted(p.name for p in directory.iterdir() if p.name not in keep)


def test_write_text_creates_parents_and_roundtrips(tmp_path: Path) -> None:
    target = tmp_path / "a" / "b" / "note.txt"
    out = atomic_write_text(target, "héllo\nworld\n")
    assert out == target
    assert target.read_text(encoding="utf-8") == "héllo\nworld\n"
    assert _leftovers(target.parent, {"note.txt"}) == []


def test_write_bytes_overwrites(tmp_path: Path) -> None:
    target = tmp_path / "blob.bin"
    atomic_write_bytes(target, b"old")
    atomic_write_bytes(target, b"\x00new\xff")
    assert target.read_bytes() == b"\x00new\xff"
    assert _leftovers(tmp_path, {"blob.bin"}) == []


def test_failed_block_keeps_old_file_and_removes_temp(tmp_path: Path) -> None:
    target = tmp_path / "data.csv"
    target.write_text("old content\n")
    seen: list[Path] = []
    with pytest.raises(RuntimeError, match="boom"), atomic_path(target) as tmp:
        seen.append(tmp)
        assert tmp.parent == target.parent
        assert tmp != target
        tmp.write_text("partial new content")
        raise RuntimeError("boom")
    assert target.read_text() == "old content\n"
    assert not seen[0].exists()
    assert _leftovers(tmp_path, {"data.csv"}) == []


def test_failed_block_without_existing_target_leaves_nothing(tmp_path: Path) -> None:
    target = tmp_path / "sub" / "new.txt"
    with pytest.raises(ValueError), atomic_path(target) as tmp:
        tmp.write_text("x")
        raise ValueError
    assert not target.exists()
    assert list(target.parent.iterdir()) == []


def test_atomic_path_keeps_extension_for_format_inference(tmp_path: Path) -> None:
    target = tmp_path / "table.csv.gz"
    with atomic_path(target) as tmp:
        assert tmp.name.endswith("table.csv.gz")
        assert tmp.suffix == ".gz"
        tmp.write_bytes(b"payload")
    assert target.read_bytes() == b"payload"


def test_atomic_path_with_pandas_to_csv(tmp_path: Path) -> None:
    pd = pytest.importorskip("pandas")
    target = tmp_path / "frame.csv"
    df = pd.DataFrame({"t": [0.0, 0.1], "u": [1.0, 2.0]})
    with atomic_path(target) as tmp:
        df.to_csv(tmp, index=False)
    assert target.read_text().splitlines() == ["t,u", "0.0,1.0", "0.1,2.0"]
    assert _leftovers(tmp_path, {"frame.csv"}) == []


@pytest.mark.skipif(os.name != "posix", reason="POSIX permissions")
def test_new_file_gets_umask_mode_not_0600(tmp_path: Path) -> None:
    target = tmp_path / "perm.txt"
    atomic_write_text(target, "x")
    old = os.umask(0o022)
    os.umask(old)
    assert target.stat().st_mode & 0o777 == 0o666 & ~old


@pytest.mark.skipif(os.name != "posix", reason="POSIX permissions")
def test_existing_file_mode_is_preserved(tmp_path: Path) -> None:
    target = tmp_path / "script.sh"
    target.write_text("old")
    target.chmod(0o750)
    atomic_write_text(target, "new")
    assert target.stat().st_mode & 0o777 == 0o750


def test_to_jsonable_numpy_and_nan() -> None:
    obj = {
        "arr": np.array([[1.0, np.nan], [np.inf, 2.5]]),
        "ints": np.arange(3, dtype=np.int32),
        "f32": np.float32(0.5),
        "i64": np.int64(7),
        "b": np.bool_(True),
        "nan": float("nan"),
        "tuple": (1, np.float64(-np.inf)),
        "path": Path("x") / "y",
        3: "int key",
        "scalar_arr": np.array(4.0),
    }
    out = to_jsonable(obj)
    assert out == {
        "arr": [[1.0, None], [None, 2.5]],
        "ints": [0, 1, 2],
        "f32": 0.5,
        "i64": 7,
        "b": True,
        "nan": None,
        "tuple": [1, None],
        "path": str(Path("x") / "y"),
        "3": "int key",
        "scalar_arr": 4.0,
    }
    assert type(out["i64"]) is int
    assert type(out["f32"]) is float
    assert type(out["b"]) is bool
    json.dumps(out, allow_nan=False)  # strict JSON


def test_atomic_write_json_numpy_nan(tmp_path: Path) -> None:
    target = tmp_path / "out" / "result.json"
    atomic_write_json(target, {"x": np.linspace(0, 1, 3), "bad": np.float64("nan"), "n": 2})
    text = target.read_text()
    assert "NaN" not in text
    assert text.endswith("\n")
    assert "\n  " in text  # indent=2
    assert json.loads(text) == {"x": [0.0, 0.5, 1.0], "bad": None, "n": 2}


def test_atomic_write_json_rejects_unknown_types_and_keeps_old(tmp_path: Path) -> None:
    target = tmp_path / "r.json"
    atomic_write_json(target, [1, 2])
    with pytest.raises(TypeError):
        atomic_write_json(target, {"obj": object()})
    assert json.loads(target.read_text()) == [1, 2]
    assert _leftovers(tmp_path, {"r.json"}) == []


def test_to_jsonable_plain_values_untouched() -> None:
    assert to_jsonable(1.5) == 1.5
    assert to_jsonable(True) is True
    assert to_jsonable(None) is None
    assert to_jsonable("s") == "s"
    assert to_jsonable([1, [2.0, math.nan]]) == [1, [2.0, None]]


# --------------------------------------------------------------------------- whole folders
def _report(folder: Path, files: dict[str, str]) -> None:
    from uuvid.core.html import Report

    for name, text in files.items():
        (folder / name).write_text(text)
    Report("t").write(folder)


def test_atomic_dir_new_folder_appears_whole_or_not_at_all(tmp_path: Path) -> None:
    from uuvid.core.atomic import atomic_dir

    out = tmp_path / "rep"
    with pytest.raises(RuntimeError, match="interrupted"), atomic_dir(out) as work:
        _report(work, {"a.txt": "1"})
        raise RuntimeError("interrupted")
    assert not out.exists() and list(tmp_path.iterdir()) == []
    with atomic_dir(out) as work:
        assert work.parent == tmp_path and work.name.startswith(".tmp-")
        _report(work, {"a.txt": "1"})
    assert sorted(p.name for p in out.iterdir()) == ["a.txt", "index.html"]
    assert [p.name for p in tmp_path.iterdir()] == ["rep"]


def test_atomic_dir_replaces_a_report_folder_as_a_whole(tmp_path: Path) -> None:
    from uuvid.core.atomic import atomic_dir

    out = tmp_path / "rep"
    with atomic_dir(out) as work:
        _report(work, {"old.png": "old", "same.txt": "old"})
    with pytest.raises(KeyboardInterrupt), atomic_dir(out) as work:
        _report(work, {"same.txt": "new"})
        raise KeyboardInterrupt
    assert (out / "same.txt").read_text() == "old" and (out / "old.png").exists()
    with atomic_dir(out) as work:
        _report(work, {"same.txt": "new"})
    assert sorted(p.name for p in out.iterdir()) == ["index.html", "same.txt"]
    assert (out / "same.txt").read_text() == "new"
    assert [p.name for p in tmp_path.iterdir()] == ["rep"]


def test_atomic_dir_keeps_files_it_did_not_write(tmp_path: Path) -> None:
    """A folder that is not a uuvid report (no index.html of ours) keeps its other files."""
    from uuvid.core.atomic import atomic_dir

    (tmp_path / "notes.md").write_text("mine")
    (tmp_path / "index.html").write_text("<html>my site</html>")
    (tmp_path / "models").mkdir()
    (tmp_path / "models" / "mine.yaml").write_text("k: 1")
    with atomic_dir(tmp_path) as work:
        _report(work, {"a.txt": "1"})
        (work / "models").mkdir()
        (work / "models" / "new.yaml").write_text("k: 2")
    assert (tmp_path / "notes.md").read_text() == "mine"
    assert sorted(p.name for p in (tmp_path / "models").iterdir()) == ["mine.yaml", "new.yaml"]
    assert "uuvid" in (tmp_path / "index.html").read_text() and (tmp_path / "a.txt").exists()
    assert not [p for p in tmp_path.parent.iterdir() if p.name.startswith(".tmp-")]


@pytest.mark.slow
def test_interrupted_result_report_leaves_the_old_folder(tmp_path: Path, monkeypatch) -> None:
    """Result.report (every report command's path): a failure while plotting leaves the previous
    report folder as it was, and a first report that fails leaves no folder at all."""
    from uuvid.core.result import Result

    class DictSummaryResult(Result):
        report_title = "t"

        def __init__(self, doc):
            self.doc = doc

        def summary(self):
            return repr(self.doc)

        def to_dict(self):
            return self.doc

        def plot(self):
            from uuvid.core.plots import new_figure

            fig, ax = new_figure(1, 1)
            ax.plot([0, 1], [0, self.doc["a"]])
            return fig

    res = DictSummaryResult({"a": 1.0})
    out = tmp_path / "rep"
    index = res.report(out)
    assert index == out / "index.html" and index.is_file()
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    def boom(self):
        raise RuntimeError("killed while plotting")

    monkeypatch.setattr(DictSummaryResult, "plot", boom)
    with pytest.raises(RuntimeError, match="killed"):
        DictSummaryResult({"a": 2.0}).report(out)
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    with pytest.raises(RuntimeError, match="killed"):
        DictSummaryResult({"a": 2.0}).report(tmp_path / "fresh")
    assert not (tmp_path / "fresh").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


# ------------------------------------------------------------------------------ leftovers
def _dead_pid() -> int:
    import subprocess
    import sys

    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_sweep_removes_orphans_and_old_leftovers_only(tmp_path: Path) -> None:
    import time

    from uuvid.core.atomic import sweep_stale

    now = time.time()
    dead = _dead_pid()

    def make(name, age, folder=False):
        p = tmp_path / name
        if folder:
            p.mkdir()
            (p / "index.html").write_text("x")
        else:
            p.write_text("x")
        os.utime(p, (now - age, now - age))
        return p

    orphan = make(f".tmp-{dead}-0123abcd-fig.png", 120)
    orphan_dir = make(f".tmp-{dead}-89abcdef-rep", 120, folder=True)
    fresh_orphan = make(f".tmp-{dead}-00000000-new.png", 5)  # its owner may be another host's
    live = make(f".tmp-{os.getpid()}-11111111-fig.png", 3 * 24 * 3600 - 100)
    legacy_old = make(".tmp-22222222-data.csv", 2 * 24 * 3600)
    legacy_new = make(".tmp-33333333-data.csv", 600)
    mine = make("keep.png", 9 * 24 * 3600)
    foreign = make(".tmp-editor-swap", 9 * 24 * 3600)  # not a name uuvid makes
    removed = sweep_stale(tmp_path, now=now)
    assert sorted(removed) == sorted([orphan, orphan_dir, legacy_old, live])
    assert fresh_orphan.exists() and legacy_new.exists() and mine.exists() and foreign.exists()


def test_next_write_sweeps_its_directory(tmp_path: Path) -> None:
    import time

    import uuvid.core.atomic as atomic

    dead = _dead_pid()
    left = tmp_path / f".tmp-{dead}-0123abcd-fig.png"
    left.write_text("half a figure")
    old = time.time() - 300
    os.utime(left, (old, old))
    atomic_write_text(tmp_path / "note.txt", "x")
    assert not left.exists()
    assert atomic._OWNED.match(atomic._temp_name(tmp_path / "a.png"))


def test_atomic_dir_without_an_exchange_call(tmp_path: Path, monkeypatch) -> None:
    """Where the system has no atomic exchange, two renames replace the folder and nothing of
    the old report is left beside it."""
    import uuvid.core.atomic as atomic

    monkeypatch.setattr(atomic, "_exchange", lambda a, b: False)
    out = tmp_path / "rep"
    for text in ("old", "new"):
        with atomic.atomic_dir(out) as work:
            _report(work, {"x.txt": text})
    assert (out / "x.txt").read_text() == "new"
    assert [p.name for p in tmp_path.iterdir()] == ["rep"]


def test_atomic_dir_into_the_working_folder(tmp_path: Path, monkeypatch) -> None:
    """``--out .``: the working folder is filled in place (never swapped away from under the
    process), and written again the same way."""
    from uuvid.core.atomic import atomic_dir

    work_dir = tmp_path / "w"
    work_dir.mkdir()
    monkeypatch.chdir(work_dir)
    for text in ("old", "new"):
        with atomic_dir(".") as work:
            assert work.parent == tmp_path
            _report(work, {"x.txt": text})
    assert Path.cwd() == work_dir and (work_dir / "x.txt").read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["w"]


def test_check_writable_dir_creates_the_folder_and_names_a_file_in_the_way(tmp_path: Path) -> None:
    from uuvid.core.atomic import check_writable_dir

    d = check_writable_dir(tmp_path / "new" / "report")
    assert d.is_dir() and not list(d.iterdir())  # the probe file is gone
    (tmp_path / "afile").write_text("x")
    with pytest.raises(NotADirectoryError) as e:
        check_writable_dir(tmp_path / "afile" / "report")
    assert e.value.filename == str(tmp_path / "afile")


def test_sigterm_removes_the_half_written_file(tmp_path: Path) -> None:
    """`kill` (SIGTERM) ends a command like Ctrl-C: the temporary file of a write in progress is
    removed and the target left as it was (the default action left a 25 MB .tmp file)."""
    import subprocess
    import sys

    target = tmp_path / "response.csv"
    target.write_text("old\n")
    code = ("import os, signal\n"
            "from uuvid.cli.app import _on_terminate_clean_up\n"
            "from uuvid.core.atomic import atomic_path\n"
            "_on_terminate_clean_up()\n"
            f"with atomic_path({str(target)!r}) as tmp:\n"
            "    tmp.write_text('new, half written')\n"
            "    os.kill(os.getpid(), signal.SIGTERM)\n"
            "    import time; time.sleep(5)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert r.returncode == 128 + 15, r.stderr
    assert target.read_text() == "old\n"
    assert _leftovers(tmp_path, {"response.csv"}) == []
