"""Tests for the report helpers in uuvid.core (plots, HTML report, progress)."""

from __future__ import annotations

import base64
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from uuvid.core.html import Report
from uuvid.core.plots import new_figure, plot_time_series, save_figure
from uuvid.core.progress import progress, progress_disabled, progress_task

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


# ----------------------------------------------------------------------------- plots


def _series() -> tuple[np.ndarray, dict[str, np.ndarray]]:
    t = np.linspace(0.0, 2.0, 201)
    return t, {
        "u": np.sin(t),
        "u_ref": np.ones_like(t),
        "tau": np.cos(t),
        "rpm": np.column_stack([t, 2 * t]),
    }


def test_save_figure_writes_png(tmp_path: Path) -> None:
    fig, ax = new_figure()
    ax.plot([0, 1], [0, 1])
    out = save_figure(fig, tmp_path / "figs" / "line.png", dpi=50)
    assert out == tmp_path / "figs" / "line.png"
    assert out.read_bytes()[:8] == PNG_SIGNATURE
    assert [p.name for p in out.parent.iterdir()] == ["line.png"]


@pytest.mark.slow
def test_new_figure_axes_shape() -> None:
    _, axes = new_figure(2, 3, sharex=True)
    assert axes.shape == (2, 3)


@pytest.mark.slow
def test_plot_time_series_groups(tmp_path: Path) -> None:
    t, ch = _series()
    fig = plot_time_series(
        t,
        ch,
        title="step <test>",
        ylabel_by_channel={"u": "m/s", "u_ref": "m/s", "tau": "N"},
        axes_groups=[["u", "u_ref"], ["tau"], ["rpm"]],
    )
    axes = fig.get_axes()
    assert len(axes) == 3
    assert axes[0].get_ylabel() == "m/s"
    assert axes[1].get_ylabel() == "N"
    assert axes[2].get_ylabel() == "rpm"
    assert len(axes[0].get_lines()) == 2
    assert len(axes[2].get_lines()) == 2  # 2-D channel -> one line per column
    assert axes[0].get_shared_x_axes().joined(axes[0], axes[2])
    out = save_figure(fig, tmp_path / "ts.png", dpi=40)
    assert out.read_bytes()[:8] == PNG_SIGNATURE


def test_plot_time_series_default_one_axis_per_channel() -> None:
    t, ch = _series()
    fig = plot_time_series(t, {"u": ch["u"], "tau": ch["tau"]})
    assert len(fig.get_axes()) == 2


def test_plot_time_series_validates() -> None:
    t, ch = _series()
    with pytest.raises(KeyError):
        plot_time_series(t, ch, axes_groups=[["nope"]])
    with pytest.raises(ValueError):
        plot_time_series(t, {"bad": np.zeros(5)})


@pytest.mark.slow
def test_import_is_headless_and_leaves_backend_alone() -> None:
    code = (
        "import os; os.environ.pop('DISPLAY', None); os.environ.pop('WAYLAND_DISPLAY', None)\n"
        "import sys, uuvid, uuvid.core.plots as p, uuvid.core.html\n"
        "assert 'matplotlib.pyplot' not in sys.modules\n"
        "fig = p.plot_time_series([0, 1], {'a': [0, 1]})\n"
        "import io; b = io.BytesIO(); fig.savefig(b, format='png'); assert b.getvalue()[:4] == b'\\x89PNG'\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)


# ----------------------------------------------------------------------------- html


def test_report_html_self_contained(tmp_path: Path) -> None:
    fig, ax = new_figure(figsize=(2, 1.5))
    ax.plot([0, 1], [1, 0])
    png = save_figure(fig, tmp_path / "p.png", dpi=30)

    fig2, ax2 = new_figure(figsize=(2, 1.5))
    ax2.plot([0, 1], [0, 1])

    rep = Report("Fit <T200> & co")
    rep.add_heading("Section <1>")
    rep.add_paragraph('Tom & "Jerry" <script>alert(1)</script>')
    rep.add_table(
        [
            {"name": "K<t>", "value": 0.012345678, "n": np.int64(3)},
            {"name": "Kq", "value": np.float64("nan"), "extra": True},
        ],
        caption="estimates & stats",
    )
    rep.add_figure(png, caption="from <file>")
    rep.add_figure(fig2, caption="in memory")
    rep.add_json({"a": np.array([1.0, np.nan]), "s": "<x>"}, caption="raw")
    out = rep.write(tmp_path / "report")

    assert out == tmp_path / "report" / "index.html"
    html = out.read_text(encoding="utf-8")
    assert html.startswith("<!DOCTYPE html>")

    # text is escaped
    assert "<script>" not in html
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in html
    assert "Tom &amp; &quot;Jerry&quot;" in html
    assert "Fit &lt;T200&gt; &amp; co" in html
    assert "K&lt;t&gt;" in html
    assert "estimates &amp; stats" in html
    assert "&quot;&lt;x&gt;&quot;" in html

    # table formatting
    assert ">0.01235<" in html
    assert ">NaN<" in html
    assert ">3<" in html
    assert "<th>extra</th>" in html

    # JSON: NaN -> null
    assert "null" in html

    # images embedded as base64 PNG data URIs (the file one byte-identical)
    uris = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', html)
    assert len(uris) == 2
    assert base64.b64decode(uris[0]) == png.read_bytes()
    assert base64.b64decode(uris[1])[:8] == PNG_SIGNATURE

    # no external resources
    assert not re.search(r"https?://", html)
    assert "<link" not in html
    assert "<script" not in html


def test_report_table_columns_subset() -> None:
    html = Report("t").add_table([{"a": 1, "b": 2}], columns=["b"]).to_html()
    assert "<th>b</th>" in html and "<th>a</th>" not in html


# ----------------------------------------------------------------------------- progress


def test_progress_disabled_yields_all_items() -> None:
    items = list(range(10))
    assert list(progress(items, description="x", disable=True)) == items
    assert list(progress(iter(items), disable=True)) == items  # no len()


def test_progress_env_var_disables(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("UUVID_NO_PROGRESS", "1")
    assert progress_disabled(None)
    assert progress_disabled(False)  # env var is the global off switch
    assert list(progress(range(5))) == [0, 1, 2, 3, 4]


def test_progress_auto_disabled_when_stderr_not_tty(monkeypatch: pytest.MonkeyPatch) -> None:
    import io

    monkeypatch.delenv("UUVID_NO_PROGRESS", raising=False)
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    assert progress_disabled(None)
    assert not progress_disabled(False)


def test_progress_enabled_still_yields_all(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("UUVID_NO_PROGRESS", raising=False)
    assert list(progress(range(7), description="on", disable=False)) == list(range(7))


def test_progress_task_counts() -> None:
    with progress_task("work", total=3, disable=True) as task:
        for _ in range(3):
            task.advance()
        task.advance(2)
    assert task.completed == 5
    with progress(total=2, description="ctx", disable=False) as task2:
        task2.advance()
        task2.update(description="ctx2")
    assert task2.completed == 1


def test_stages_print_one_line_each_off_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    import io

    monkeypatch.delenv("UUVID_NO_PROGRESS", raising=False)
    err = io.StringIO()  # not a TTY, like CI or a pipe
    monkeypatch.setattr(sys, "stderr", err)
    with progress_task("job", total=3, stages=3) as task:
        for name in ("first", "second", "third"):
            task.stage(name)
            task.advance()
    lines = err.getvalue().splitlines()
    assert [ln.split(" (")[0] for ln in lines[:3]] == ["job: first", "job: second", "job: third"]
    assert "(2/3, " in lines[1] and lines[1].endswith(" s)")
    assert lines[3].startswith("job: done in ") and len(lines) == 4


def test_stages_silent_when_switched_off(monkeypatch: pytest.MonkeyPatch) -> None:
    import io

    err = io.StringIO()
    monkeypatch.setattr(sys, "stderr", err)
    monkeypatch.setenv("UUVID_NO_PROGRESS", "1")
    with progress_task("job", stages=1) as task:
        task.stage("first")
    monkeypatch.delenv("UUVID_NO_PROGRESS")
    with progress_task("job", stages=1, disable=True) as task:
        task.stage("first")
    assert err.getvalue() == ""


def test_stage_names_the_step_in_the_bar(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("UUVID_NO_PROGRESS", raising=False)
    with progress_task("job", total=2, disable=False, eta=False) as task:
        task.stage("fitting")
        desc = task._progress.tasks[0].description
        cols = [type(c).__name__ for c in task._progress.columns]
    assert desc == "job — fitting"
    assert "TimeRemainingColumn" not in cols


def test_interrupted_task_says_interrupted_not_failed(monkeypatch: pytest.MonkeyPatch) -> None:
    import io

    monkeypatch.delenv("UUVID_NO_PROGRESS", raising=False)
    err = io.StringIO()
    monkeypatch.setattr(sys, "stderr", err)
    with pytest.raises(KeyboardInterrupt), progress_task("job", stages=2) as task:
        task.stage("first")
        raise KeyboardInterrupt
    with pytest.raises(RuntimeError), progress_task("job", stages=2) as task:
        task.stage("first")
        raise RuntimeError("boom")
    lines = err.getvalue().splitlines()
    assert lines[1].startswith("job: interrupted after ") and "failed" not in lines[1]
    assert lines[3].startswith("job: failed after ")


def test_best_legend_is_searched_once_per_save_and_the_picture_is_unchanged(tmp_path, monkeypatch):
    """save_figure lets a loc="best" legend search its corner once (constrained layout placed
    it six times per save, each a search over every plotted vertex): same PNG bytes as a plain
    savefig, one search per legend."""
    from matplotlib.legend import Legend

    def make():
        rng = np.random.default_rng(1)
        fig, axes = new_figure(2, 1)
        t = np.linspace(0, 100, 2000)
        for ax in axes:
            for k in range(3):
                ax.plot(t, np.sin(t * (k + 1) / 7) + 0.1 * rng.normal(size=t.size),
                        label=f"channel {k} [m]")
            ax.set_xlabel("t [s]")
            ax.legend()
        return fig

    searches = []
    real = Legend._find_best_position

    def counted(self, *a):
        searches.append(self)
        return real(self, *a)

    monkeypatch.setattr(Legend, "_find_best_position", counted)
    make().savefig(tmp_path / "plain.png", dpi=110, format="png")
    plain = len(searches)
    searches.clear()
    save_figure(make(), tmp_path / "once.png")
    assert len(searches) == 2 < plain  # one per legend
    assert (tmp_path / "once.png").read_bytes() == (tmp_path / "plain.png").read_bytes()


def test_a_long_counted_task_off_a_terminal_says_how_far_it_is(monkeypatch: pytest.MonkeyPatch
                                                               ) -> None:
    """A million Monte Carlo runs in a pipe printed nothing for minutes: a counted task prints
    its count, elapsed and remaining time at most every LINE_EVERY_S, and its end."""
    import io

    from uuvid.core import progress as P

    monkeypatch.delenv("UUVID_NO_PROGRESS", raising=False)
    err = io.StringIO()
    monkeypatch.setattr(sys, "stderr", err)
    clock = iter(np.arange(0.0, 10000.0, 1.0))  # each call 1 s later
    monkeypatch.setattr(P.time, "perf_counter", lambda: float(next(clock)))
    with progress_task("montecarlo", total=200) as task:
        for _ in range(199):
            task.advance()
    lines = err.getvalue().splitlines()
    counts = [ln for ln in lines if " of 200 (" in ln]
    assert counts and counts[0].startswith("montecarlo: ") and "s left" in counts[0]
    assert len(counts) <= 199 * 3 / P.LINE_EVERY_S + 1  # every 30 s at most, not every advance
    assert lines[-1].startswith("montecarlo: done in ")


def test_a_task_with_after_s_draws_only_once_that_long_has_passed(monkeypatch) -> None:
    """``after_s``: a short task (a small log read) draws no bar; a long one draws it from the
    count so far (counted once, not twice)."""
    import io

    monkeypatch.delenv("UUVID_NO_PROGRESS", raising=False)
    out = io.StringIO()
    with progress_task("read", total=10, disable=False, after_s=3600.0, stream=out) as task:
        task.advance(4)
        assert task._progress is None
    assert out.getvalue() == ""
    with progress_task("read", total=10, disable=False, after_s=1e-9, stream=out) as task:
        task.advance(4)
        assert task._progress is not None
        assert task._progress.tasks[0].completed == 4
        task.advance(2)
        assert task._progress.tasks[0].completed == 6
    assert "read" in out.getvalue()


def test_a_bar_on_a_pinned_stream_leaves_sys_stdout_alone(monkeypatch) -> None:
    """A log reader captures sys.stdout/stderr while the bar (on the terminal's stderr) starts:
    rich's proxies, restored after the reader had restored its own, sent later prints into the
    reader's dead buffer."""
    import io

    monkeypatch.delenv("UUVID_NO_PROGRESS", raising=False)
    before_out, before_err = sys.stdout, sys.stderr
    with progress_task("read", total=10, disable=False, after_s=1e-9, stream=io.StringIO()) as task:
        sys.stdout, sys.stderr = io.StringIO(), io.StringIO()  # the reader's capture
        task.advance(5)
        sys.stdout, sys.stderr = before_out, before_err  # and its end
    assert sys.stdout is before_out and sys.stderr is before_err
