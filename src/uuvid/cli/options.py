"""Option conventions shared by the commands.

``--out DIR`` is always a folder.  A command's single output file is ``--out-file FILE``; files
named for what they hold are ``--out-model FILE`` and ``--out-vehicle FILE``; ``--report DIR`` is
a report folder.  Commands that used ``--out`` for a file keep accepting it (hidden) with a
deprecation note, through :func:`renamed`.
"""

from __future__ import annotations

from pathlib import Path

import typer


def deprecated_out(help_new: str) -> typer.models.OptionInfo:
    """The hidden old ``--out FILE`` spelling of a file option."""
    return typer.Option(None, "--out", hidden=True, help=f"Deprecated spelling of {help_new}.")


def renamed(new_value, new_name: str, old_value, old_name: str = "--out",
            folder_option: str | None = None):
    """The value of an option given under its new or (deprecated) old name; a note on stderr for
    the old one, an error for both.  An old value without a file suffix is an error: ``--out``
    names a folder everywhere else, so ``--out results`` most likely meant one (the command's
    ``folder_option``, when it has one) and not a file called ``results``."""
    from uuvid.cli.common import _fail, err_console

    if old_value is None:
        return new_value
    if new_value is not None:
        _fail(f"give {new_name} only ({old_name} is its deprecated spelling)")
    if not Path(old_value).suffix:
        folder = (f"; for a folder of plots and the report give {folder_option} {old_value}"
                  if folder_option else "")
        _fail(f"{old_name} {old_value}: here {old_name} is the old spelling of {new_name} FILE, "
              f"a file with a suffix (see --help), and {old_value!s} has none{folder}")
    err_console.print(f"[yellow]note:[/] {old_name} FILE is deprecated here; use {new_name} FILE "
                      f"({old_name} always names a folder)", highlight=False, soft_wrap=True)
    return old_value


INFLOW_HELP = ("Thrust against the water speed through the propeller: none (bollard thrust, "
               "whatever the vehicle's speed) or four-quadrant (the propeller's map at each "
               "thruster's advance speed); default: the vehicle file's inflow key.")


def _check_inflow(value: str | None) -> str | None:
    from uuvid.thruster.inflow import INFLOW_MODELS

    if value is not None and value not in INFLOW_MODELS:
        raise typer.BadParameter(f"must be one of {', '.join(INFLOW_MODELS)}, got {value!r}",
                                 param_hint="'--inflow'")
    return value


def inflow_option() -> typer.models.OptionInfo:
    """``--inflow none|four-quadrant`` (unset: the vehicle file's ``inflow`` key), checked at
    parse time so an error names the option."""
    return typer.Option(None, "--inflow", help=INFLOW_HELP, callback=_check_inflow,
                        metavar="none|four-quadrant")
