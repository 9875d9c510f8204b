"""The documentation: a strict MkDocs build (API reference from the docstrings) and every tutorial
executed, code block by code block, in a fresh temporary folder."""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TUTORIALS = sorted((ROOT / "docs" / "tutorials").glob("*.md"))
CODE = re.compile(r"^```python\n(.*?)^```", re.S | re.M)
# optional extras a tutorial may need: skip it cleanly when they are not installed
OPTIONAL = {"control": "control", "gymnasium": "gymnasium"}


def blocks(path: Path) -> list[str]:
    return CODE.findall(path.read_text(encoding="utf-8"))


def test_every_tutorial_has_code_and_is_in_the_nav():
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    assert len(TUTORIALS) >= 4
    for t in TUTORIALS:
        assert blocks(t), f"{t.name} has no python code block"
        assert f"tutorials/{t.name}" in nav, f"{t.name} is not in mkdocs.yml's nav"



def test_index_links_every_tutorial_and_api_page():
    """docs/index.md is the front page: every tutorial and every API page is reachable from it
    (a page only in mkdocs.yml's nav is invisible to a reader of the index or the repository)."""
    index = (ROOT / "docs" / "index.md").read_text(encoding="utf-8")
    links = set(re.findall(r"\]\(([^)#\s]+)", index))
    pages = [p.relative_to(ROOT / "docs").as_posix() for folder in ("tutorials", "api")
             for p in sorted((ROOT / "docs" / folder).glob("*.md"))]
    assert pages, "no pages found under docs/tutorials and docs/api"
    missing = [p for p in pages if p not in links]
    assert not missing, f"docs/index.md does not link: {', '.join(missing)}"


#: every tutorial runs the library end to end (2–30 s each, the controllers' compile their own
#: mission loops): with --run-slow (CI), not in the default suite
@pytest.mark.slow
@pytest.mark.parametrize("path", TUTORIALS, ids=[t.stem for t in TUTORIALS])
def test_tutorial_runs(path, tmp_path, monkeypatch):
    code = blocks(path)
    for mod, pkg in OPTIONAL.items():
        if any(re.search(rf"^\s*(import|from) {mod}\b", c, re.M) for c in code):
            pytest.importorskip(pkg)
    monkeypatch.chdir(tmp_path)
    ns: dict = {"__name__": f"tutorial_{path.stem}"}
    for i, c in enumerate(code, 1):
        try:
            exec(compile(c, f"{path.name}[block {i}]", "exec"), ns)
        except Exception as e:  # name the block that failed
            raise AssertionError(f"{path.name}, python block {i} failed: {e!r}") from e


@pytest.mark.slow
def test_mkdocs_build_strict(tmp_path):
    for pkg in ("mkdocs", "material", "mkdocstrings", "mkdocstrings_handlers.python"):
        if importlib.util.find_spec(pkg.split(".")[0]) is None:
            pytest.skip(f"{pkg} is not installed (pip install 'uuvid[docs]')")
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1",
               PYTHONPATH=os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]))
    r = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-f",
                        str(ROOT / "mkdocs.yml"), "-d", str(tmp_path / "site")],
                       capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    api = (tmp_path / "site" / "api" / "vehicle" / "index.html").read_text(encoding="utf-8")
    assert "uuvid.vehicle.linearize.linearize" in api  # the reference is built from docstrings
    for t in TUTORIALS:
        assert (tmp_path / "site" / "tutorials" / t.stem / "index.html").is_file()
