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


@pytest.mark.parametrize("case", ["file_then_folder", "folder_then_file"])
def test_a_users_file_the_new_report_would_overwrite_is_an_error_naming_it(tmp_path: Path, case) -> None:
    """The user's file ``userfile`` and a new report writing ``userfile/x.png`` (the file was
    dropped without a word), or the user's ``figs/mine.txt`` and a report writing a file ``figs``
    (an error naming the hidden temporary folder): an error naming the user's file, the old
    folder as it was."""
    from uuvid.core.atomic import atomic_dir

    out = tmp_path / "rep"
    with atomic_dir(out) as work:
        _report(work, {"a.txt": "old"})
    if case == "file_then_folder":
        (out / "userfile").write_text("mine")
        mine, writes = out / "userfile", {"userfile/x.png": "new"}
    else:
        (out / "figs").mkdir()
        (out / "figs" / "mine.txt").write_text("mine")
        mine, writes = out / "figs" / "mine.txt", {"figs": "new"}
    with pytest.raises(FileExistsError) as e, atomic_dir(out) as work:
        for name, text in writes.items():
            (work / name).parent.mkdir(parents=True, exist_ok=True)
            (work / name).write_text(text)
        _report(work, {})
    assert e.value.filename == str(mine) and ".tmp-" not in str(e.value)
    assert mine.read_text() == "mine" and (out / "a.txt").read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["rep"]


def test_a_report_merged_over_an_unlisted_one_lists_nothing(tmp_path: Path) -> None:
    """Over a report of an earlier version (no list of its outputs) the new one is merged; had it
    listed only its own files, the old report's leftovers would pass for the user's for ever."""
    import re

    from uuvid.core.atomic import atomic_dir

    out = tmp_path / "rep"
    with atomic_dir(out) as work:
        _report(work, {"old.png": "old"})
    page = out / "index.html"
    page.write_text(re.sub(r"<!-- uuvid-outputs: .*? -->", "", page.read_text(), flags=re.S))
    with atomic_dir(out) as work:
        _report(work, {"new.png": "new"})
    assert (out / "old.png").exists()  # merged: nothing removed
    assert "uuvid-outputs" not in page.read_text()
    with atomic_dir(out) as work:  # still unlisted: merged again, never the old outputs kept as 'user' files
        _report(work, {"new.png": "newer"})
    assert (out / "new.png").read_text() == "newer"
