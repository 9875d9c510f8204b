"""The result object of a paper reproduction: the JSON-able document *is* the object (a ``dict``:
``res["table1"]`` reads as before; ``res.data`` is a plain copy) plus the common result surface
(``summary()``, ``to_dict()``/``to_json()``, ``plot()``, ``report(folder)``, see
:mod:`uuvid.core.result`).  ``artifacts`` holds what the plots need and JSON cannot (fits, time
responses); it is empty for a document read back from JSON."""

from __future__ import annotations

from pathlib import Path

from uuvid.core.result import Result


class PaperReproduction(dict, Result):
    """A reproduction's document (this dict) and its plotting ``artifacts``.

    Subclasses implement ``summary()`` and ``plot()``; those with a full paper report
    (``write_outputs``) override :meth:`_write_outputs`."""

    def __init__(self, data=(), artifacts: dict | None = None):
        super().__init__(data)
        self.artifacts = dict(artifacts or {})

    @property
    def data(self) -> dict:
        """The document as a plain ``dict`` (what ``reproduce()`` returned before)."""
        return dict(self)

    def to_dict(self) -> dict:
        return dict(self)

    def _write_outputs(self, folder: Path) -> Path | None:
        """The paper's own full report into ``folder``; ``None`` when there is none (or the
        artifacts it needs are missing): the default report is written instead."""
        return None

    def _report_into(self, folder: Path) -> Path:
        """The paper's full report (plots, tables, JSON, index.html) when it can be written, else
        the default one; ``summary.txt`` and ``result.json`` in both cases (:meth:`report`
        writes it into a folder as a whole)."""
        index = self._write_outputs(folder)
        if index is None:
            return super()._report_into(folder)
        self.write_basics(folder)
        return index


def compare_line(name: str, ours: float, paper, unit: str = "") -> str:
    """``name  ours [paper]  (rel. difference)`` for a summary."""
    if isinstance(paper, (int, float)) and paper:
        return f"  {name:<34} {ours:10.4g} [{paper:g}] {unit}  ({ours / paper - 1:+.1%})"
    return f"  {name:<34} {ours:10.4g} {unit}"
