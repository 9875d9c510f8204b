"""A report written again into its folder replaces its own outputs only: files the user put there
(notes, a sub-folder) are kept, atomically (an interrupted report leaves the old folder whole), and
errors name the path the caller gave, in API terms."""

from __future__ import annotations

from pathlib import Path

import pytest


def _report(folder: Path, files: dict[str, str]) -> None:
    from uuvid.core.html import Report

    for name, text in files.items():
        (folder / name).write_text(text)
    Report("t").write(folder)


def test_second_report_keeps_the_users_files(tmp_path: Path) -> None:
    from uuvid.core.atomic import atomic_dir

    out = tmp_path / "rep"
    with atomic_dir(out) as work:
        _report(work, {"old.png": "old", "same.txt": "old"})
    (out / "my_notes.ipynb").write_text("{}")
    (out / "mine").mkdir()
    (out / "mine" / "data.csv").write_text("a,b")
    (out / "empty").mkdir()
    with pytest.raises(KeyboardInterrupt), atomic_dir(out) as work:
        _report(work, {"same.txt": "new"})
        raise KeyboardInterrupt
    assert (out / "same.txt").read_text() == "old" and (out / "my_notes.ipynb").exists()
    with atomic_dir(out) as work:
        _report(work, {"same.txt": "new"})
    assert sorted(p.name for p in out.iterdir()) == ["empty", "index.html", "mine", "my_notes.ipynb",
                                                      "same.txt"]  # old.png was the report's: gone
    assert (out / "my_notes.ipynb").read_text() == "{}"
    assert (out / "mine" / "data.csv").read_text() == "a,b"
    assert (out / "same.txt").read_text() == "new"
    with atomic_dir(out) as work:  # and again: the notes are still not the report's
        _report(work, {"same.txt": "newer"})
    assert (out / "my_notes.ipynb").read_text() == "{}"
    assert [p.name for p in tmp_path.iterdir()] == ["rep"]


def test_result_report_twice_keeps_a_notebook(tmp_path: Path) -> None:
    from uuvid.core.result import Result

    class R(Result):
        report_title = "t"

        def summary(self):
            return "a = 1"

        def to_dict(self):
            return {"a": 1.0}

        def plot(self):
            from uuvid.core.plots import new_figure

            fig, ax = new_figure(1, 1)
            ax.plot([0, 1], [0, 1])
            return fig

    r = R()
    out = tmp_path / "rep"
    r.report(out)
    (out / "my_notes.ipynb").write_text("{}")
    r.report(out)
    assert (out / "my_notes.ipynb").read_text() == "{}"


def test_report_errors_name_the_users_path(tmp_path: Path) -> None:
    from uuvid.core.atomic import atomic_dir, atomic_path

    f = tmp_path / "afile"
    f.write_text("")
    with pytest.raises(NotADirectoryError) as e, atomic_dir(f):
        pass
    assert "--out" not in str(e.value) and str(f) in str(e.value)
    if not Path("/proc/self").is_dir():
        pytest.skip("needs /proc, a folder no one may write in")
    for ctx, name in ((atomic_dir("/proc/uuvid-no-rep"), "/proc/uuvid-no-rep"),
                      (atomic_path("/proc/uuvid-x.png"), "/proc/uuvid-x.png")):
        with pytest.raises(OSError) as e, ctx:
            pass
        assert ".tmp-" not in str(e.value) and name in str(e.value)
