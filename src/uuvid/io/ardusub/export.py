"""Writing a :class:`~uuvid.io.ardusub.dive.DiveLog`: the table (CSV + JSON sidecar, or
Parquet with the provenance in its metadata), atomically; and its overview figure."""

from __future__ import annotations

import contextlib
import json
from pathlib import Path

import numpy as np

from uuvid.core.atomic import atomic_path, atomic_write_json, to_jsonable
from uuvid.io.ardusub.sources import GAP_FACTOR
from uuvid.io.logs import LogDataError


def shared_log_dir() -> Path | None:
    """The real ArduSub logs (``shared/data/ardusub-bluerov2``): ``$UUVID_SHARED_DATA`` or
    ``shared/data`` beside the checkout / the working directory; ``None`` when absent."""
    import os

    here = Path(__file__).resolve()
    bases = [Path(os.environ["UUVID_SHARED_DATA"])] if os.environ.get("UUVID_SHARED_DATA") else []
    bases += [b / "shared" / "data" for b in (here.parents[4].parent, Path.cwd().parent,
                                              Path.cwd())]
    for b in bases:
        d = b / "ardusub-bluerov2"
        if d.is_dir():
            return d
    return None


def _meta(dive) -> dict:
    return {"format": "uuvid-dive/1", **dive.to_dict()}


EXPORT_TYPES = (".csv", ".parquet")


def check_export_path(out) -> Path:
    """The export path, after checking its type (before any log is read)."""
    out = Path(out)
    if out.suffix.lower() not in EXPORT_TYPES:
        raise LogDataError(f"{out.name}: unknown export type {out.suffix!r}; expected .csv or "
                           ".parquet")
    if out.suffix.lower() == ".parquet":
        _pyarrow(out)
    return out


def _pyarrow(out: Path):
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError as e:
        raise ImportError(f"{out.name}: writing Parquet needs pyarrow, which is not installed: "
                          "pip install 'uuvid[logs]' (or write .csv: the same table, with its "
                          "provenance in <file>.csv.json)") from e
    return pa, pq


def sidecar_path(out) -> Path | None:
    """Where the provenance of an export goes: ``<out>.json`` beside a CSV; ``None`` for Parquet
    (provenance in the file's metadata)."""
    out = Path(out)
    return out.with_name(out.name + ".json") if out.suffix.lower() == ".csv" else None


def export_dive(dive, out, plot=None) -> Path:
    """``out`` ending in ``.csv`` (sidecar ``<out>.json``) or ``.parquet``; returns the path.
    ``plot``: also the overview figure there, in the same all-or-none write: it is drawn into a
    temporary file first and takes its name only after the table did, so an interrupted or
    failed export leaves no figure without its table."""
    out = check_export_path(out)
    with contextlib.ExitStack() as figure:
        if plot is not None:
            plot_dive(dive, figure.enter_context(atomic_path(plot)))
        return _write_table(dive, out)


def _write_table(dive, out: Path) -> Path:
    suf = out.suffix.lower()
    tb = dive.table.copy()
    num = tb.select_dtypes("float").columns
    tb[num] = tb[num] + 0.0  # -0.0 written as 0
    if suf == ".csv":
        # the provenance is written while the table is still a temporary file: if it cannot
        # be, neither replaces anything (an earlier export of the same name stays whole)
        with atomic_path(out) as tmp:
            tb.to_csv(tmp, index=False, float_format="%.9g")
            atomic_write_json(sidecar_path(out), _meta(dive))
        return out
    pa, pq = _pyarrow(out)
    t = pa.Table.from_pandas(tb, preserve_index=False)
    md = dict(t.schema.metadata or {})
    md[b"uuvid"] = json.dumps(to_jsonable(_meta(dive)), allow_nan=False).encode()
    t = t.replace_schema_metadata(md)
    with atomic_path(out) as tmp:
        pq.write_table(t, tmp)
    return out


_MODE_COLOURS = {"MANUAL": None, "STABILIZE": "#9ecae1", "ALT_HOLD": "#a1d99b",
                 "POSHOLD": "#fdae6b", "SURFACE": "#bcbddc", "ACRO": "#fdd0a2"}
_OTHER_MODE_COLOURS = ("#fbb4ae", "#ccebc5", "#decbe4", "#fed9a6", "#e5d8bd", "#b3cde3")


def _mode_colours(modes) -> dict:
    """A fill colour per closed-loop mode seen (MANUAL: None, unshaded)."""
    out, extra = {}, iter(_OTHER_MODE_COLOURS * 4)
    for m in sorted({s["mode"] for s in modes}):
        out[m] = _MODE_COLOURS[m] if m in _MODE_COLOURS else next(extra, "#dddddd")
    return out


def plot_dive(dive, path=None):
    """Depth, attitude, thrusts and generalized forces against time; each mode but MANUAL
    shaded in its colour (a legend entry per mode), disarmed stretches hatched grey."""
    from matplotlib.patches import Patch

    from uuvid.core.plots import new_figure, save_figure
    from uuvid.io.ardusub.frames import MOMENT_FACTOR_UNIT

    tb = dive.table
    t = tb["t_s"].to_numpy(float)
    fig, ax = new_figure(4, 1, sharex=True, figsize=(10, 10))
    ax[0].plot(t, tb["depth_m"], "k")
    ax[0].invert_yaxis()
    ax[0].set_ylabel("depth [m]")
    ax[0].set_title(f"{dive.path.name}: depth from {dive.depth_source['source']}")
    for c in ("roll_rad", "pitch_rad", "yaw_rad"):
        ax[1].plot(t, np.degrees(tb[c]), label=c.split("_")[0])
    ax[1].set_ylabel("attitude [deg]")
    ax[1].legend(loc="upper right", fontsize="small")
    def finite(c):  # servo outputs logged slower than the rows are empty between samples
        v = tb[c].to_numpy(float)
        keep = np.isfinite(v)
        if keep.all():
            return t, v
        # a line between the samples, broken across a gap in them
        tk, vk = t[keep], v[keep]
        if tk.size > 2:
            step = float(np.median(np.diff(tk)))
            cut = np.flatnonzero(np.diff(tk) > GAP_FACTOR * step) + 1  # the reader's gap
            tk, vk = np.insert(tk, cut, np.nan), np.insert(vk, cut, np.nan)
        return tk, vk

    for m in dive.motors:
        ax[2].plot(*finite(f"thrust_{m}_N"), lw=0.8, label=f"motor {m}")
    ax[2].set_ylabel("thrust [N]")
    ax[2].legend(loc="upper right", fontsize="x-small", ncol=4)
    for c in ("X_N", "Y_N", "Z_N"):
        ax[3].plot(*finite(c), label=c)
    ax3b = ax[3].twinx()
    for c, ls in (("K_Nm", ":"), ("M_Nm", "-."), ("N_Nm", "--")):
        ax3b.plot(*finite(c), ls, lw=0.8, label=c)
    ax[3].set_ylabel("force [N]")
    ax3b.set_ylabel("moment [N·m]" if dive.vehicle else
                    "moment [" + MOMENT_FACTOR_UNIT.replace(" (", "]\n(", 1), fontsize="small")
    ax[3].legend(loc="upper left", fontsize="small")
    ax3b.legend(loc="upper right", fontsize="small")
    ax[3].set_xlabel("t [s]")
    colours = _mode_colours(dive.modes)
    hatch = {"facecolor": "none", "edgecolor": "0.65", "hatch": "//", "lw": 0, "zorder": 0.5}
    for s in dive.modes:
        for a in ax:
            if colours[s["mode"]]:
                a.axvspan(s["start_s"], s["end_s"], color=colours[s["mode"]], alpha=0.45, lw=0,
                          zorder=0)
            if s["armed"] is False:
                a.axvspan(s["start_s"], s["end_s"], **hatch)
    handles = [Patch(facecolor=c or "white", alpha=0.45 if c else 1.0, edgecolor="0.3" if not c
                     else "none", label=m + (" (unshaded)" if not c else ""))
               for m, c in colours.items()]
    if any(s["armed"] is False for s in dive.modes):
        handles.append(Patch(label="disarmed", **{k: v for k, v in hatch.items()
                                                  if k not in ("lw", "zorder")}))
    if handles:
        fig.legend(handles=handles, loc="outside upper center", ncol=len(handles),
                   fontsize="small", frameon=False)
    if path is not None:
        save_figure(fig, path)
    return fig
