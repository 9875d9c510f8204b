"""What every ``uuvid`` command shares: the consoles (data on stdout, messages on stderr), one
JSON document, a one-line error with exit status 2, tables, and models named on the command line.
Command modules import these from here, never from :mod:`uuvid.cli.app` (no import circle)."""

from __future__ import annotations

import json
import os
import sys

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table


class _FoldingConsole(Console):
    """A console whose tables wrap long cells and headers instead of cutting them with "…" (off
    a terminal rich assumes 80 columns; a cut header hides what a number is)."""

    def print(self, *objects, **kwargs) -> None:
        for o in objects:
            if isinstance(o, Table):
                for c in o.columns:
                    c.overflow = "fold"
                    c.no_wrap = False
        super().print(*objects, **kwargs)


def _pipe_width() -> int | None:
    """Off a terminal (pipe, file, CI log) nothing limits the width: 120 columns unless COLUMNS
    says otherwise; on a terminal rich uses the terminal's width."""
    try:
        tty = sys.stdout.isatty()
    except (AttributeError, ValueError):
        tty = False
    return None if tty or "COLUMNS" in os.environ else 120


out_console = _FoldingConsole(width=_pipe_width())
err_console = Console(stderr=True)


def _print_json(obj) -> None:
    from uuvid.core.atomic import to_jsonable

    sys.stdout.write(json.dumps(to_jsonable(obj), indent=2, allow_nan=False) + "\n")
    sys.stdout.flush()


def _fail(msg: str, code: int = 2) -> None:
    """Print ``error: msg`` and end the command (exit status 2: bad input; 1: the run failed)."""
    err_console.print(f"[bold red]error:[/] {escape(str(msg))}", highlight=False, soft_wrap=True)
    raise typer.Exit(code=code)


def _flagged(msg: str, flags: dict[str, str]) -> str:
    """A library message with the parameter it starts with (``name = value: …``, ``name must
    …``, ``name: …``) or names in backticks (```name=```) spelled as this command's option:
    ``flags`` maps library parameter names to options (``{"max_tilt_deg": "--max-tilt"}``)."""
    import re

    text = str(msg)
    for name, flag in flags.items():
        text = text.replace(f"`{name}=`", flag)
        text = re.sub(rf"^{re.escape(name)}(?=\s*(=|must\b|:|is\b|and\b))", flag, text)
    return text


def _fail_flagged(err: BaseException | str, flags: dict[str, str], prefix: str = "") -> None:
    """:func:`_fail` with a library error's parameter named as the command's option (see
    :func:`_flagged`); a ``KeyError``'s message without its quotes."""
    text = err.args[0] if isinstance(err, KeyError) and err.args else str(err)
    _fail(prefix + _flagged(text, flags))


def check_outputs(*outputs) -> None:
    """Every destination a command writes, checked before it computes or writes anything:
    ``(option, path, kind)`` with ``kind`` ``"folder"`` (a report folder,
    :func:`uuvid.core.atomic.check_writable_dir`) or ``"file"``
    (:func:`~uuvid.core.atomic.check_writable_file`); ``path`` ``None``: not asked for.  One that
    cannot be written ends the command naming the option (a file where a folder goes, no
    permission), so a run either writes all its outputs or none; nothing is created here (the
    writers make the folders), so a run that then fails on its input leaves no empty folder.
    Folders that do not exist yet above an output are said (``note: … will be created``): a
    mistyped path shows before it becomes a tree of new folders."""
    from pathlib import Path

    from uuvid.core.atomic import check_writable_dir, check_writable_file

    for opt, path, kind in outputs:
        if path is None:
            continue
        parent = Path(path).parent  # a report folder itself is made, never its parents
        if not parent.exists():
            top = parent
            while not top.parent.exists() and top.parent != top:
                top = top.parent
            err_console.print(f"note: {escape(f'{opt} {path}')}: the folder {escape(str(top))} does not "
                              "exist yet; it will be created", highlight=False, soft_wrap=True)
        try:
            (check_writable_dir if kind == "folder" else check_writable_file)(path, create=False)
        except OSError as e:
            where = e.filename or path
            if isinstance(e, (FileExistsError, NotADirectoryError)) and os.path.isfile(where):
                what = (f"{where} is a file, not a folder" if str(where) != str(path) else
                        "a file of that name is in the way (a folder was expected)")
            elif isinstance(e, IsADirectoryError):
                what = "a folder of that name is in the way (a file was expected)"
            else:
                what = f"cannot write in {where} ({e.strerror or e})"
            _fail(f"{opt} {path}: {what}; nothing was written")


def _table(title: str, rows: list[dict], columns: list[str], fmt: str = "{:.3g}") -> Table:
    t = Table(title=escape(title))
    for c in columns:
        t.add_column(escape(c))
    for r in rows:
        cells = [r.get(c) for c in columns]
        t.add_row(*[escape("—" if x is None else fmt.format(x) if isinstance(x, float) else str(x))
                    for x in cells])
    return t


def _load_model(model: str):
    """A preset name, ``t200-physical`` or a model file (:func:`uuvid.thruster.resolve.resolve_chain`)."""
    from pathlib import Path

    from uuvid.io.export import PLUGIN_SUFFIXES
    from uuvid.thruster.modelfile import ModelFileError
    from uuvid.thruster.resolve import resolve_chain

    p = Path(model)
    if p.suffix.lower() in PLUGIN_SUFFIXES and p.is_file():  # a UUV Simulator plugin (our export)
        from uuvid.io.export import ExportError, from_uuv_simulator

        try:
            return from_uuv_simulator(p.read_text(), name=p.stem)
        except (ExportError, ValueError, SyntaxError) as e:  # SyntaxError: XML ParseError
            _fail(f"{p}: not a UUV Simulator thruster plugin ({e})")
    try:
        return resolve_chain(model)
    except FileNotFoundError as e:
        _fail(str(e))
    except ModelFileError as e:
        _fail(str(e))
