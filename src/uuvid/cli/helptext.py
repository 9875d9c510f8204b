"""Help text as written: units in brackets survive, flags show no type.

Typer renders help with rich markup, which swallows ``[s]``, ``[m/s]``, ``[rad/s]`` as unknown
style tags ("Simulated time . [default: 2.0]"), and labels every flag ``<bool>``.  Instead of
escaping each option by hand, the root group tidies every command below it once, when the click
command tree is built: help text is markup-escaped (so the brackets print literally) and boolean
flags get an empty type label.  A command's summary in its group's list is its docstring's
first paragraph on one line (rich keeps the docstring's line breaks there).
"""

from __future__ import annotations

import inspect

from rich.markup import escape
from typer.core import TyperGroup


def _rich_markup(cmd) -> bool:
    from typer.core import HAS_RICH

    return HAS_RICH and getattr(cmd, "rich_markup_mode", None) == "rich"


def tidy_command(cmd, ctx_cls=None) -> None:
    """Escape the help of *cmd*, its parameters and (recursively) its subcommands; blank the type
    label of flags (``--json``, ``--help``).  Idempotent."""
    if getattr(cmd, "_uuvid_tidy", False):
        return
    cmd._uuvid_tidy = True
    markup = _rich_markup(cmd)
    if cmd.help and not getattr(cmd, "short_help", None):
        # the group's command list shows the first paragraph as written, line breaks and all
        # (rich mode): give it as one line
        first = inspect.cleandoc(cmd.help).split("\n\n")[0]
        if "\n" in first.strip() and not first.startswith("\b"):
            cmd.short_help = " ".join(first.split())
    if markup and cmd.help:
        cmd.help = escape(cmd.help)
    if markup and getattr(cmd, "short_help", None):
        cmd.short_help = escape(cmd.short_help)
    params = list(cmd.params)
    try:  # the --help option is created lazily; create it now so it is tidied too
        from typer.models import Context

        helper = cmd.get_help_option(Context(cmd))
        if helper is not None:
            params.append(helper)
    except Exception:  # pragma: no cover - a typer internals change must not break the CLI
        pass
    for p in params:
        if markup and getattr(p, "help", None):
            p.help = escape(p.help)
        if getattr(p, "is_flag", False) and p.metavar is None:
            p.metavar = ""
    for sub in getattr(cmd, "commands", {}).values():
        tidy_command(sub)


class TidyHelpGroup(TyperGroup):
    """The root ``uuvid`` group: tidies the help of every command below it (see module doc)."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        tidy_command(self)

    def invoke(self, ctx):
        """Run the command; Ctrl-C always ends with "interrupted" on stderr (once: a progress
        line may have said it) — after a task's "done" it ended silently (the command line ends
        with status 130 either way).  What a run was writing is removed by its writer
        (:func:`uuvid.core.atomic.atomic_dir`, :func:`~uuvid.core.atomic.atomic_path`)."""
        from uuvid.core import progress

        progress._INTERRUPT_SAID[0] = False  # a new command (a CliRunner runs many in a process)
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            progress.say_interrupted()
            raise
