"""Headless plotting helpers.

Figures are built with Matplotlib's object-oriented API (:class:`matplotlib.figure.Figure`
with an Agg canvas attached) and are never registered with :mod:`matplotlib.pyplot`.  This
renders without a display (no ``DISPLAY``, CI, servers), never opens a window, and does not
touch the global backend: importing :mod:`uuvid` leaves a user's own pyplot / interactive
backend exactly as it was (calling ``matplotlib.use("Agg")`` at import time would silently
switch it).  It also means figures need no ``plt.close`` bookkeeping: they are ordinary
objects, freed when no longer referenced.
"""

from __future__ import annotations

import os
import re
import sys
import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from uuvid.core.atomic import atomic_path

__all__ = ["figure_problems", "new_figure", "plot_time_series", "save_figure"]

# keyword arguments of Figure.subplots(); everything else goes to Figure()
_SUBPLOTS_KW = {
    "sharex",
    "sharey",
    "squeeze",
    "width_ratios",
    "height_ratios",
    "subplot_kw",
    "gridspec_kw",
}


def new_figure(nrows: int = 1, ncols: int = 1, **kw: Any) -> tuple[Figure, Any]:
    """Create a headless figure and its axes, like ``plt.subplots`` but without pyplot.

    Keyword arguments of ``Figure.subplots`` (``sharex``, ``sharey``, ``squeeze``,
    ``width_ratios``, ``height_ratios``, ``subplot_kw``, ``gridspec_kw``) are passed to it;
    the rest (``figsize``, ``dpi``, ``layout``, ...) to :class:`~matplotlib.figure.Figure`.
    Defaults: ``layout="constrained"`` and a figure size that grows with the grid.

    Returns ``(fig, axes)`` with ``axes`` squeezed as by ``plt.subplots`` (a single Axes for
    1x1, a 1-D array for one row/column, else 2-D) unless ``squeeze=False``.
    """
    if nrows < 1 or ncols < 1:
        raise ValueError(f"nrows and ncols must be >= 1, got {nrows}x{ncols}")
    sub_kw = {k: kw.pop(k) for k in list(kw) if k in _SUBPLOTS_KW}
    kw.setdefault("figsize", (max(6.4, 4.0 * ncols), 1.2 + 2.4 * nrows))
    kw.setdefault("layout", "constrained")
    fig = Figure(**kw)
    FigureCanvasAgg(fig)  # attach a raster canvas explicitly: independent of any backend
    axes = fig.subplots(nrows, ncols, **sub_kw)
    return fig, axes


def save_figure(
    fig: Figure, path: str | os.PathLike[str], dpi: float = 110, **savefig_kw: Any
) -> Path:
    """Save *fig* atomically to *path* (format from the suffix, PNG if none) and close it.

    Parent directories are created.  Extra keyword arguments go to ``Figure.savefig``.
    Returns the path.
    """
    target = Path(os.fspath(path))
    fmt = savefig_kw.pop("format", None) or (target.suffix[1:].lower() or "png")
    try:
        _best_legend_once(fig)
        with atomic_path(target) as tmp:
            fig.savefig(tmp, dpi=dpi, format=fmt, **savefig_kw)
    finally:
        _close(fig)
    return target


def _best_legend_once(fig: Figure) -> None:
    """Let each ``loc="best"`` legend of *fig* search for its place once per save.

    Matplotlib searches every candidate corner against every plotted vertex each time the legend
    is placed — and constrained layout places it in each of its passes before the final draw, so a
    figure with a few thousand points spent half its save time there.  The first search picks the
    corner; later placements put the legend in that corner of the (re-laid-out) axes.  Only
    Matplotlib's private placement helpers change behaviour, so anything unexpected leaves the
    legend alone."""
    from matplotlib.transforms import Bbox

    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is None or getattr(leg, "_loc", None) != 0 or "_find_best_position" in vars(leg):
            continue
        search = getattr(leg, "_find_best_position", None)
        anchored = getattr(leg, "_get_anchored_bbox", None)
        codes = getattr(leg, "codes", None)
        if search is None or anchored is None or not codes:
            continue

        chosen: list = []  # the corner the first search picked, per legend

        def once(width, height, renderer, _leg=leg, _search=search, _anchored=anchored,
                 _chosen=chosen):
            box = Bbox.from_bounds(0, 0, width, height)
            if _chosen:
                return _anchored(_chosen[0], box, _leg.get_bbox_to_anchor(), renderer)
            lb = _search(width, height, renderer)
            for idx in range(1, len(_leg.codes)):
                if tuple(_anchored(idx, box, _leg.get_bbox_to_anchor(), renderer)) == tuple(lb):
                    _chosen.append(idx)
                    break
            return lb

        leg._find_best_position = once


def _close(fig: Figure) -> None:
    """Release *fig*: unregister it from pyplot if pyplot manages it (no-op otherwise)."""
    plt = sys.modules.get("matplotlib.pyplot")
    if plt is not None:
        plt.close(fig)


_UNIT = re.compile(r"^(?P<name>.*?)\s*\[(?P<unit>[^\[\]]*)\]$")


def _axis_label(labels: Sequence[str], width: int = 24) -> str:
    """One y label for the channels of a subplot, short enough for its height: channels sharing a
    unit give ``a, b [unit]``; the text wraps at about *width* characters."""
    parts = [_UNIT.match(lab) for lab in labels]
    if len(labels) > 1 and all(parts) and len({m.group("unit") for m in parts}) == 1:
        text = ", ".join(m.group("name") for m in parts) + f" [{parts[0].group('unit')}]"
    else:
        text = " / ".join(labels)
    return textwrap.fill(text, width, break_long_words=False, break_on_hyphens=False)


def plot_time_series(
    t: Sequence[float] | np.ndarray,
    channels: Mapping[str, Sequence[float] | np.ndarray],
    title: str | None = None,
    ylabel_by_channel: Mapping[str, str] | None = None,
    axes_groups: Sequence[Sequence[str]] | None = None,
    *,
    xlabel: str = "t [s]",
    figsize: tuple[float, float] | None = None,
) -> Figure:
    """Draw named channels against time on stacked subplots sharing the time axis.

    Parameters
    ----------
    t:
        Time samples, shape ``(n,)``.
    channels:
        ``name -> values``; values of shape ``(n,)``, or ``(n, k)`` for ``k`` lines labelled
        ``name[0] .. name[k-1]``.
    title:
        Figure title.
    ylabel_by_channel:
        ``name -> y-axis label`` (units).  A subplot's label is the distinct labels of its
        channels joined with " / "; with no label given, a lone channel's name is used.
    axes_groups:
        Channel names per subplot, top to bottom, e.g. ``[["u", "u_ref"], ["tau"]]``.  Default:
        one subplot per channel in the mapping's order.

    Returns the :class:`~matplotlib.figure.Figure` (save it with :func:`save_figure`).
    """
    tt = np.asarray(t, dtype=float).ravel()
    n = tt.size
    if not channels:
        raise ValueError("no channels to plot")
    if axes_groups is None:
        groups = [[name] for name in channels]
    else:
        groups = [list(g) for g in axes_groups]
        if not groups or any(not g for g in groups):
            raise ValueError("axes_groups must be a non-empty list of non-empty lists")
        unknown = [name for g in groups for name in g if name not in channels]
        if unknown:
            raise KeyError(f"axes_groups name unknown channels: {unknown}")
    labels = dict(ylabel_by_channel or {})

    data: dict[str, np.ndarray] = {}
    for name in {name for g in groups for name in g}:
        y = np.asarray(channels[name], dtype=float)
        if y.ndim == 0 or y.ndim > 2 or y.shape[0] != n:
            raise ValueError(
                f"channel {name!r} has shape {y.shape}; expected ({n},) or ({n}, k) to match t"
            )
        data[name] = y

    fig_kw: dict[str, Any] = {}
    if figsize is not None:
        fig_kw["figsize"] = figsize
    else:
        fig_kw["figsize"] = (8.0, 1.0 + 2.1 * len(groups))
    fig, axes = new_figure(len(groups), 1, sharex=True, squeeze=False, **fig_kw)
    axes = axes[:, 0]

    for ax, group in zip(axes, groups):
        for name in group:
            y = data[name]
            if y.ndim == 1:
                ax.plot(tt, y, label=name, linewidth=1.0)
            else:
                for j in range(y.shape[1]):
                    ax.plot(tt, y[:, j], label=f"{name}[{j}]", linewidth=1.0)
        units = list(dict.fromkeys(labels[name] for name in group if name in labels))
        if units:
            ax.set_ylabel(_axis_label(units))
        elif len(group) == 1:
            ax.set_ylabel(group[0])
        # a fixed location: loc="best" is very slow on long series
        ax.legend(loc="upper right", fontsize="small")
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel(xlabel)
    fig.align_ylabels(axes)
    if n > 1 and np.isfinite(tt[[0, -1]]).all() and tt[0] != tt[-1]:
        axes[-1].set_xlim(tt[0], tt[-1])
    if title:
        fig.suptitle(title)
    return fig


_HAS_UNIT = re.compile(r"[\[(][^\[\]()]+[\])]")


def figure_problems(fig: Figure) -> list[str]:
    """What a reader of *fig* would miss: a title (the figure's or an axes'), and on every axes
    that shows data an x and a y label naming a unit in brackets or parentheses (``[m/s]``,
    ``(N)``, ``[-]``); a shared axis may carry its label on a sibling.  A polar axes names its
    radial unit in its title.  Empty when nothing is missing."""
    out = []
    sup = fig._suptitle.get_text() if getattr(fig, "_suptitle", None) is not None else ""
    data_axes = [ax for ax in fig.axes if not hasattr(ax, "_colorbar") and (
        ax.lines or ax.collections or ax.images or ax.patches or ax.containers)]
    if not sup.strip() and not any(ax.get_title().strip() for ax in fig.axes):
        out.append("no title")
    for i, ax in enumerate(data_axes):
        where = f"axes {i}" + (f" ({ax.get_title()!r})" if ax.get_title() else "")
        if ax.name == "polar":
            if not (_HAS_UNIT.search(ax.get_title()) or _HAS_UNIT.search(sup)):
                out.append(f"{where}: polar plot without its radial unit in the title")
            continue
        for axis, get, shared in (("x", "get_xlabel", ax.get_shared_x_axes()),
                                  ("y", "get_ylabel", ax.get_shared_y_axes())):
            if _categorical(ax.xaxis if axis == "x" else ax.yaxis):
                continue  # named categories (directions, message types) carry no unit
            labels = [getattr(a, get)() for a in [ax, *shared.get_siblings(ax)]]
            twins = [a for a in fig.axes if a is not ax and a.bbox.bounds == ax.bbox.bounds]
            if axis == "x":
                labels += [a.get_xlabel() for a in twins]
            label = next((lab for lab in labels if lab.strip()), "")
            if not label:
                out.append(f"{where}: no {axis} label")
            elif not _HAS_UNIT.search(label):
                out.append(f"{where}: {axis} label {label!r} names no unit")
    return out


def _categorical(axis) -> bool:
    """An axis of named categories: string data, or tick labels set to words."""
    conv = axis.get_converter() if hasattr(axis, "get_converter") else getattr(axis, "converter", None)
    if type(conv).__name__ == "StrCategoryConverter":
        return True
    texts = [t.get_text() for t in axis.get_ticklabels()]
    return any(re.search(r"[A-Za-z]", t) for t in texts)
