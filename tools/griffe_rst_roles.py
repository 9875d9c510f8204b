"""Griffe extension for the docs build: uuvid's docstrings cite code with reST roles
(``:func:`uuvid.x.f```, ``:class:`~a.B```, ``:data:`X```); render them as inline code with the
short name instead of printing the role literally."""

from __future__ import annotations

import re

import griffe

_ROLE = re.compile(r":(?:func|class|meth|mod|data|attr|exc|obj):`~?([^`]+)`")


def _short(m: re.Match) -> str:
    target = m.group(1).strip()
    return f"`{target.rsplit('.', 1)[-1] if m.group(0).count('~') else target}`"


class RstRoles(griffe.Extension):
    def on_object(self, *, obj, **kwargs) -> None:
        if obj.docstring is not None and ":`" in obj.docstring.value:
            obj.docstring.value = _ROLE.sub(_short, obj.docstring.value)
