"""``uuvid examples``: write the package's generated example logs (see :mod:`uuvid.examples`)."""

from __future__ import annotations

from pathlib import Path

import typer


def examples(
    names: list[str] | None = typer.Argument(None, help="Examples to write (default: all)."),
    out: Path = typer.Option(Path("uuvid-examples"), "--out", help="Folder to write them into."),
    list_: bool = typer.Option(False, "--list", help="List the examples and exit."),
):
    """Write small example logs generated from a simulated vehicle (for the README's commands)."""
    from uuvid.cli.common import _fail, err_console, out_console
    from uuvid.examples import EXAMPLES, write_example

    if list_:
        for e in EXAMPLES.values():
            out_console.print(f"{e.name:12s} {e.filename:16s} {e.description}", highlight=False,
                              markup=False, soft_wrap=True)
        return
    unknown = [n for n in names or [] if n not in EXAMPLES]
    if unknown:
        _fail(f"unknown example {unknown[0]!r}; available: {', '.join(EXAMPLES)} (uuvid examples --list)")
    for n in names or list(EXAMPLES):
        try:
            paths = write_example(n, out)
        except OSError as e:
            _fail(f"--out {out}: cannot write {EXAMPLES[n].filename} ({e.strerror or e})")
        for path in paths:
            err_console.print(f"wrote {path}", highlight=False, markup=False)


def register(app: typer.Typer) -> None:
    app.command("examples")(examples)
