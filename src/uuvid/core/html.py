"""Self-contained HTML reports.

A :class:`Report` is an ordered list of blocks (headings, paragraphs, tables, figures, JSON)
rendered to a single HTML file: styles are inline and images are embedded as base64 ``data:``
URIs, so the page loads no external resource and can be mailed or archived as one file.
All user text is escaped with :func:`html.escape`.

Example::

    rep = Report("Thruster T200 identification")
    rep.add_heading("Fit").add_table([{"param": "Kt", "value": 0.0123}], caption="estimates")
    rep.add_figure(fig, caption="step response")      # Matplotlib Figure or image path
    rep.write("out")                                   # -> out/index.html
"""

from __future__ import annotations

import base64
import html
import io
import json
import math
import numbers
import os
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from uuvid.core.atomic import GENERATOR_TAG, atomic_write_text, to_jsonable

__all__ = ["Report"]

_CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;
  max-width:1100px;margin:2em auto;padding:0 1em;color:#222;line-height:1.45}
h1{border-bottom:2px solid #ccc;padding-bottom:.2em}
h2{margin-top:1.6em;border-bottom:1px solid #e3e3e3}
table{border-collapse:collapse;margin:1em 0;font-size:.92em;max-width:100%}
th,td{border:1px solid #ccc;padding:.25em .6em;text-align:left;vertical-align:top;
  overflow-wrap:anywhere}
th{background:#f2f2f2}
td.num{text-align:right;font-variant-numeric:tabular-nums;font-family:ui-monospace,monospace}
tr:nth-child(even) td{background:#fafafa}
caption,figcaption{font-style:italic;color:#555;padding:.3em 0;text-align:left}
figure{margin:1.2em 0}
figure img{max-width:100%;height:auto;border:1px solid #eee}
.tw{max-width:100%}
a{color:#0b5cad}
pre{background:#f6f8fa;border:1px solid #e3e3e3;padding:.8em;overflow:auto;font-size:.88em}
"""

_MIME_BY_SUFFIX = {
    ".png": "image/png",
    ".jpg": "image/jpeg",
    ".jpeg": "image/jpeg",
    ".gif": "image/gif",
    ".svg": "image/svg+xml",
    ".webp": "image/webp",
}
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _esc(text: Any) -> str:
    return html.escape(str(text), quote=True)


class Report:
    """Builder for a single self-contained HTML page.

    Every ``add_*`` method returns the report itself, so calls can be chained.
    """

    def __init__(self, title: str) -> None:
        self.title = str(title)
        self._blocks: list[str] = []

    # ---------------------------------------------------------------- blocks

    def add_heading(self, text: str, level: int = 2) -> Report:
        """Add a section heading (``<h2>`` by default; *level* 1..6)."""
        level = min(max(int(level), 1), 6)
        self._blocks.append(f"<h{level}>{_esc(text)}</h{level}>")
        return self

    def add_paragraph(self, text: str) -> Report:
        """Add a paragraph of plain text (escaped; blank lines start new paragraphs)."""
        parts = [p.strip() for p in str(text).split("\n\n")]
        for part in parts:
            if part:
                self._blocks.append("<p>" + _esc(part).replace("\n", "<br>\n") + "</p>")
        return self

    def add_links(self, text: str, links: Mapping[str, str] | Iterable[str]) -> Report:
        """Add a paragraph *text* followed by links, e.g. ``add_links("Full page:",
        ["mission/index.html"])``; *links* maps label → href or lists hrefs (their own labels).
        Hrefs are kept relative to the page, so a report folder can be moved or mailed whole."""
        items = links.items() if isinstance(links, Mapping) else ((h, h) for h in links)
        anchors = ", ".join(f'<a href="{_esc(_relative_href(h))}">{_esc(label)}</a>'
                            for label, h in items)
        self._blocks.append(f"<p>{_esc(text)} {anchors}</p>")
        return self

    def add_table(
        self,
        rows: Iterable[Mapping[str, Any]],
        columns: Sequence[str] | None = None,
        caption: str | None = None,
        float_fmt: str = "{:.4g}",
    ) -> Report:
        """Add a table of *rows* (one dict per row).

        *columns* selects and orders the columns; by default all keys in order of first
        appearance.  Missing cells and ``None`` are blank; floats (Python or numpy) are formatted
        with *float_fmt*; numeric cells are right-aligned.  Cells wrap; a table still wider than
        the page (:data:`MAX_TABLE_PX`, :func:`column_min_px`) is split into several, each
        repeating the first column, so no column hides behind a scroll bar.
        """
        rows = list(rows)
        if columns is None:
            columns = list(dict.fromkeys(k for row in rows for k in row))
        columns = list(columns)
        cells = [[_format_cell(row.get(c), float_fmt) for c in columns] for row in rows]
        groups = _split_columns(columns, cells)
        for g, cols in enumerate(groups):
            cap = caption
            if len(groups) > 1:  # too wide for the page: split, the first column repeated
                part = f"part {g + 1} of {len(groups)}, split to fit the page"
                cap = f"{caption} ({part})" if caption else part.capitalize()
            self._blocks.append(_table_html(columns, cells, cols, cap))
        return self

    def add_figure(
        self,
        fig_or_path: Any,
        caption: str | None = None,
        dpi: float = 110,
        alt: str | None = None,
    ) -> Report:
        """Embed an image as a base64 ``data:`` URI.

        *fig_or_path* is a Matplotlib Figure (rendered to PNG in memory at *dpi*), a path to an
        image file (PNG, JPEG, GIF, SVG, WebP, chosen by suffix), or raw PNG bytes.  The figure
        is not closed: the caller still owns it.
        """
        data, mime = _image_bytes(fig_or_path, dpi)
        uri = f"data:{mime};base64," + base64.b64encode(data).decode("ascii")
        alt_text = alt if alt is not None else (caption or "figure")
        out = ["<figure>", f'<img src="{uri}" alt="{_esc(alt_text)}">']
        if caption:
            out.append(f"<figcaption>{_esc(caption)}</figcaption>")
        out.append("</figure>")
        self._blocks.append("\n".join(out))
        return self

    def add_json(self, obj: Any, caption: str | None = None) -> Report:
        """Add *obj* as pretty-printed JSON in a ``<pre>`` block (numpy/NaN handled)."""
        text = json.dumps(to_jsonable(obj), indent=2, ensure_ascii=False, default=str)
        out = []
        if caption:
            out.append(f'<p class="caption"><em>{_esc(caption)}</em></p>')
        out.append(f"<pre>{_esc(text)}</pre>")
        self._blocks.append("\n".join(out))
        return self

    def add_preformatted(self, text: str, caption: str | None = None) -> Report:
        """Add preformatted text (a fit report, a log) in a ``<pre>`` block."""
        if caption:
            self._blocks.append(f'<p class="caption"><em>{_esc(caption)}</em></p>')
        self._blocks.append(f"<pre>{_esc(text)}</pre>")
        return self

    def extend(self, other: Report) -> Report:
        """Append the blocks of *other* (a section built apart, e.g. in another process); its
        title is not added."""
        self._blocks.extend(other._blocks)
        return self

    # ---------------------------------------------------------------- output

    def to_html(self) -> str:
        """Return the full HTML document as a string."""
        body = "\n".join(self._blocks)
        return (
            "<!DOCTYPE html>\n"
            '<html lang="en">\n<head>\n<meta charset="utf-8">\n'
            f"{GENERATOR_TAG}\n"
            '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
            f"<title>{_esc(self.title)}</title>\n"
            f"<style>{_CSS}</style>\n</head>\n<body>\n"
            f"<h1>{_esc(self.title)}</h1>\n{body}\n</body>\n</html>\n"
        )

    def write(self, dir: str | os.PathLike[str], filename: str = "index.html") -> Path:
        """Write the page atomically to ``dir/filename`` (creating *dir*); returns the path."""
        return atomic_write_text(Path(os.fspath(dir)) / filename, self.to_html())

    def __len__(self) -> int:
        return len(self._blocks)


# -------------------------------------------------------------------- helpers

#: Widest table [px] the page holds (1100 px body less its padding): wider ones are split.
MAX_TABLE_PX = 1060
#: Estimated width of one character of a table cell [px] (.92em of 16 px, bold headers included)
#: and of a cell's padding and border.
CHAR_PX, CELL_PAD_PX = 9.0, 19.0
#: A text cell's word longer than this wraps anywhere (``overflow-wrap:anywhere``); numbers never.
LONG_WORD = 24


def column_min_px(header: str, cells: Iterable[tuple[str, bool]]) -> float:
    """Narrowest a column can be: its longest unbreakable piece (headers break at spaces and
    after underscores, text at spaces, long words anywhere; numbers do not break)."""
    words = [len(w) for w in re.split(r"(?<=_)|\s+", header) if w] or [0]  # "speed_" stays whole
    longest = max(words)
    for text, numeric in cells:
        if numeric:
            longest = max(longest, len(text))
        else:
            longest = max([longest, *(min(len(w), LONG_WORD) for w in text.split())])
    return longest * CHAR_PX + CELL_PAD_PX


def _split_columns(columns: list[str], cells: list[list[tuple[str, bool]]]) -> list[list[int]]:
    """Column indices per table: one table when it fits :data:`MAX_TABLE_PX`, else consecutive
    groups that do, each starting with the first (key) column."""
    w = [column_min_px(c, (row[i] for row in cells)) for i, c in enumerate(columns)]
    if sum(w) <= MAX_TABLE_PX or len(columns) < 3:
        return [list(range(len(columns)))]
    groups, cur, width = [], [0], w[0]
    for i in range(1, len(columns)):
        if width + w[i] > MAX_TABLE_PX and len(cur) > 1:
            groups.append(cur)
            cur, width = [0], w[0]
        cur.append(i)
        width += w[i]
    groups.append(cur)
    return groups


def _table_html(columns, cells, cols: list[int], caption: str | None) -> str:
    out = ['<div class="tw"><table>']  # fits the page: wraps (and is split) rather than scrolls
    if caption:
        out.append(f"<caption>{_esc(caption)}</caption>")
    header = "".join(f"<th>{_esc(columns[i]).replace('_', '_<wbr>')}</th>" for i in cols)
    out.append(f"<thead><tr>{header}</tr></thead>")
    out.append("<tbody>")
    for row in cells:
        tds = []
        for i in cols:
            text, numeric = row[i]
            cls = ' class="num"' if numeric else ""
            tds.append(f"<td{cls}>{_esc(text)}</td>")
        out.append("<tr>" + "".join(tds) + "</tr>")
    out.append("</tbody></table></div>")
    return "\n".join(out)


def _relative_href(href: str | os.PathLike[str]) -> str:
    """A link inside the report folder: forward slashes, no scheme, no absolute path."""
    h = Path(os.fspath(href)).as_posix() if not isinstance(href, str) else href.replace("\\", "/")
    if ":" in h.split("/", 1)[0] or h.startswith("/"):
        raise ValueError(f"report links are relative to the page, got {href!r}")
    return h


def _format_cell(value: Any, float_fmt: str) -> tuple[str, bool]:
    """Return (text, is_numeric) for one table cell."""
    if value is None:
        return "", False
    if isinstance(value, (str, bytes)):
        return (value.decode("utf-8", "replace") if isinstance(value, bytes) else value), False
    # numpy scalars -> Python scalars (np.bool_ is not a numbers.Number)
    item = getattr(value, "item", None)
    if callable(item) and (type(value).__module__ or "").startswith("numpy"):
        try:
            value = item()
        except (ValueError, TypeError):
            pass
    if isinstance(value, bool):
        return str(value), False
    if isinstance(value, numbers.Integral):
        return str(int(value)), True
    if isinstance(value, numbers.Real):
        v = float(value)
        if math.isnan(v):
            return "NaN", True
        try:
            return float_fmt.format(v), True
        except (ValueError, TypeError):
            return repr(v), True
    return str(value), False


def _image_bytes(obj: Any, dpi: float) -> tuple[bytes, str]:
    if hasattr(obj, "savefig"):  # Matplotlib Figure (or anything figure-like)
        buf = io.BytesIO()
        obj.savefig(buf, format="png", dpi=dpi)
        return buf.getvalue(), "image/png"
    if isinstance(obj, (bytes, bytearray)):
        data = bytes(obj)
        if not data.startswith(_PNG_SIGNATURE):
            raise ValueError("raw image bytes must be PNG data")
        return data, "image/png"
    path = Path(os.fspath(obj))
    mime = _MIME_BY_SUFFIX.get(path.suffix.lower())
    data = path.read_bytes()
    if mime is None:
        if not data.startswith(_PNG_SIGNATURE):
            raise ValueError(f"unsupported image type for {path} (expected PNG/JPEG/GIF/SVG/WebP)")
        mime = "image/png"
    return data, mime
