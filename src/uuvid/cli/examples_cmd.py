"""``uuvid examples``: write the package's generated example logs (see :mod:`uuvid.examples`)."""

from __future__ import annotations

from pathlib import Path

import typer


def examples(
    names: list[str] | None = typer.Argument(None, help="Examples to write (default: all)."),
    out: Path = typer.Option(Path("uuvid-examples"), "--out", help="Folder to write them into."),
    list_: bool = typer.Option(False, "--list", help="List the examples and exit."),
    force: bool = typer.Option(False, "--force", help="Overwrite files in --out that hold other "
                               "data (the same example written again is always fine)."),
):
    """Write small example logs generated from a simulated vehicle (for the README's commands)."""
    from uuvid.cli.common import _fail, check_outputs, err_console, out_console
    from uuvid.examples import EXAMPLES, ExampleClashError, write_examples

    if list_:
        for e in EXAMPLES.values():
            out_console.print(f"{e.name:12s} {e.filename:16s} {e.description}", highlight=False,
                              markup=False, soft_wrap=True)
        return
    unknown = [n for n in names or [] if n not in EXAMPLES]
    if unknown:
        _fail(f"unknown example {unknown[0]!r}; available: {', '.join(EXAMPLES)} (uuvid examples --list)")
    check_outputs(("--out", out, "folder"))
    try:
        paths = write_examples(names or list(EXAMPLES), out, overwrite=force)
    except ExampleClashError as e:
        which = ", ".join(p.name for p in e.paths)
        _fail(f"--out {out}: {which} already there and not the example (your data?); nothing was "
              "written — choose another --out, move the file(s), or give --force to overwrite")
    except OSError as e:
        _fail(f"--out {out}: cannot write the examples ({e.strerror or e})")
    for path in paths:
        err_console.print(f"wrote {path}", highlight=False, markup=False)


def register(app: typer.Typer) -> None:
    app.command("examples")(examples)
