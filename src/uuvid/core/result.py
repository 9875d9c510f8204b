"""One surface for every result object: ``summary()``, ``to_dict()``/``to_json()``, ``plot()``,
``report(folder)``.

Identification, simulation, sweeps and paper reproductions return objects that mix in
:class:`Result`.  A subclass implements three methods:

* ``summary() -> str`` — human-readable text (what ``print`` in a notebook should show);
* ``to_dict() -> dict`` — JSON-safe data (lists, floats, str, bool, ``None``; the base's
  :meth:`Result.to_json` turns numpy values into lists/floats and NaN/±inf into ``null``);
* ``plot(...) -> matplotlib.figure.Figure`` — a headless figure (optional arguments allowed).

and gets from the base :meth:`~Result.to_json` (a string, or a file written atomically),
:meth:`~Result.report` (a folder with ``summary.txt``, ``result.json``, ``plot.png`` and a
self-contained ``index.html``) and ``_repr_html_`` (the summary in a notebook).  Subclasses with
richer reports override ``report`` and call :meth:`Result.write_basics` so the folder still
holds ``summary.txt`` and ``result.json``.

Example (a notebook)::

    res = identify_steady("log.csv", dof="surge")
    print(res.summary())
    res.plot()                      # a Figure, shown inline
    res.report("out/surge")         # -> out/surge/index.html
    d = res.to_dict()               # JSON-safe

Small per-call objects on hot paths (e.g. :class:`uuvid.vehicle.allocation.AllocationResult`
returned once per step by the allocation inner loop, or the parameter rows of a fit) are exempt:
they stay light plain objects.  Every other public result class mixes this in;
``tests/test_result_surface.py`` finds all subclasses and exercises the four methods.
"""

from __future__ import annotations

import functools
import json
import os
from pathlib import Path

from uuvid.core.atomic import atomic_write_json, atomic_write_text, to_jsonable

__all__ = ["DictSummaryResult", "Result", "SummaryDict", "jsonable"]


#: ``obj`` made JSON-safe: numpy → lists/Python scalars, NaN/±inf → ``None``.
jsonable = to_jsonable


class SummaryDict(dict):
    """A metrics dict that, when called, returns its result's text summary.

    Kept for results whose old ``summary`` attribute was a dict (``MissionResult``,
    ``StudyResult``): ``res.summary["key"]`` still reads the metrics (prefer ``res.metrics`` /
    ``res.info``), while ``res.summary()`` is the text of the common surface."""

    __slots__ = ("_text",)

    @classmethod
    def attach(cls, obj, attr: str) -> SummaryDict:
        """``obj.attr`` as a :class:`SummaryDict` whose call is ``obj``'s text summary (the dict is
        converted in place once, so writes through either name land in the same dict)."""
        d = getattr(obj, attr)
        if not isinstance(d, cls):
            d = cls(d or {})
            object.__setattr__(obj, attr, d)
        d._text = obj._summary_text
        return d

    def __call__(self) -> str:
        text = getattr(self, "_text", None)
        if text is None:
            raise TypeError("this metrics dict is not attached to a result")
        return text()

    def __reduce__(self):  # pickles (process pools) as a plain dict
        return (dict, (dict(self),))


class Result:
    """Mixin giving a result object the common surface (see the module docstring).

    Subclasses implement :meth:`summary`, :meth:`to_dict` and :meth:`plot`; ``report_title``
    (a class attribute or property) names the HTML page."""

    __slots__ = ()
    report_title: str = ""

    def __init_subclass__(cls, **kwargs):
        # every subclass's to_dict() comes out JSON-safe, whatever it builds
        super().__init_subclass__(**kwargs)
        fn = cls.__dict__.get("to_dict")
        if fn is not None and not getattr(fn, "_jsonable", False):
            @functools.wraps(fn)
            def to_dict(self, *args, **kw):
                return jsonable(fn(self, *args, **kw))

            to_dict._jsonable = True
            cls.to_dict = to_dict

    # ---------------------------------------------------------------- to implement
    def summary(self) -> str:
        """Human-readable text."""
        raise NotImplementedError(f"{type(self).__name__}.summary()")

    def to_dict(self) -> dict:
        """JSON-safe data."""
        raise NotImplementedError(f"{type(self).__name__}.to_dict()")

    def plot(self, *args, **kwargs):
        """A headless :class:`matplotlib.figure.Figure`."""
        raise NotImplementedError(f"{type(self).__name__}.plot()")

    # ---------------------------------------------------------------- supplied
    def to_json(self, path: str | os.PathLike[str] | None = None, indent: int = 2):
        """The :meth:`to_dict` data as strict JSON (NaN/±inf → ``null``): the string, or, with
        ``path``, the file written atomically (returns its :class:`~pathlib.Path`)."""
        data = jsonable(self.to_dict())
        if path is not None:
            return atomic_write_json(Path(os.fspath(path)), data, indent=indent)
        return json.dumps(data, indent=indent, allow_nan=False, ensure_ascii=False)

    def _title(self) -> str:
        return self.report_title or type(self).__name__

    def write_basics(self, folder: str | os.PathLike[str]) -> Path:
        """Write ``summary.txt`` and ``result.json`` into ``folder``; returns the folder."""
        folder = Path(os.fspath(folder))
        folder.mkdir(parents=True, exist_ok=True)
        atomic_write_text(folder / "summary.txt", self.summary().rstrip("\n") + "\n")
        self.to_json(folder / "result.json")
        return folder

    def report(self, folder: str | os.PathLike[str]) -> Path:
        """Write ``summary.txt``, ``result.json``, ``plot.png`` and a self-contained
        ``index.html`` into ``folder``, as a whole (:func:`uuvid.core.atomic.atomic_dir`: built
        beside it and swapped in, so an interrupted report leaves the old folder intact);
        returns the path of ``index.html``."""
        from uuvid.core.atomic import atomic_dir

        final = Path(os.fspath(folder))
        with atomic_dir(final) as work:
            index = self._report_into(work)
        return final / Path(index).relative_to(work)

    def _report_into(self, folder: Path) -> Path:
        """:meth:`report`'s content, written into ``folder``; returns ``index.html``'s path."""
        from uuvid.core.html import Report
        from uuvid.core.plots import save_figure

        folder = self.write_basics(folder)
        rep = Report(self._title())
        rep.add_preformatted(self.summary(), caption="Summary")
        figs = self.plot()
        figs = figs if isinstance(figs, (list, tuple)) else [figs]
        names = []
        for i, fig in enumerate(figs):
            name = "plot.png" if i == 0 else f"plot_{i + 1}.png"
            rep.add_figure(save_figure(fig, folder / name))
            names.append(name)
        rep.add_links("Files", ["summary.txt", "result.json", *names])
        return rep.write(folder)

    def _repr_html_(self) -> str:
        import html

        return f"<pre>{html.escape(self.summary())}</pre>"


class DictSummaryResult(Result):
    """A result whose ``summary`` used to be a dict field, now named ``summary_field`` (e.g.
    ``"metrics"``): ``res.summary["key"]`` reads and writes that dict, ``res.summary()`` is the
    text from ``_summary_text()``.  For dataclasses (the field is converted in
    ``__post_init__``)."""

    __slots__ = ()
    summary_field: str = "metrics"

    def __post_init__(self):
        SummaryDict.attach(self, self.summary_field)

    @property
    def summary(self) -> SummaryDict:
        """The dict; called, the text summary."""
        return SummaryDict.attach(self, self.summary_field)

    def _summary_text(self) -> str:
        raise NotImplementedError(f"{type(self).__name__}._summary_text()")
