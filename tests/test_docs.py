"""The documentation: a strict MkDocs build (API reference from the docstrings) and every tutorial
executed, code block by code block in the page's order, in a fresh temporary folder: ``python``
blocks in this interpreter, ``bash``/``sh``/``shell``/``console`` blocks under ``bash -e`` with the
installed ``uuvid`` first on the PATH (a ``console`` block's commands are its ``$ `` lines, the
rest is output).  A shell block runs after the Python blocks above it, in the same folder, so a
command may read what they wrote.  Left out of shell blocks, and why:

* install and test steps (``pip install``, ``python -m venv``, ``. .venv/bin/activate``,
  ``pytest``), as in the README's test (:func:`test_readme.runnable_shell`): CI runs them itself;
* a command that reads ``../shared/`` (data not shipped with the package) when that folder is
  absent beside the checkout — skipped outside CI, a failure under ``CI=true`` (as the README's).

``yaml``/``text`` blocks are file excerpts and output, not commands.
"""

from __future__ import annotations

import importlib.util
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TUTORIALS = sorted((ROOT / "docs" / "tutorials").glob("*.md"))
CODE = re.compile(r"^```python\n(.*?)^```", re.S | re.M)
FENCE = re.compile(r"^```([A-Za-z0-9_+-]*)[^\n]*\n(.*?)^```\s*$", re.S | re.M)
SHELL = ("bash", "sh", "shell", "console")
SHARED_DATA = ROOT.parent / "shared" / "data"  # as conftest.py
# optional extras a tutorial may need: skip it cleanly when they are not installed
OPTIONAL = {"control": "control", "gymnasium": "gymnasium"}


def blocks(path: Path) -> list[str]:
    return CODE.findall(path.read_text(encoding="utf-8"))


def code_blocks(path: Path) -> list[tuple[str, str, int]]:
    """(``python`` or ``shell``, text, line number) of the page's runnable blocks, in order."""
    text = path.read_text(encoding="utf-8")
    out = []
    for m in FENCE.finditer(text):
        lang, body = m.group(1).lower(), m.group(2)
        if lang == "console":
            body = "\n".join(line[2:] for line in body.splitlines() if line.startswith("$ "))
        if lang == "python" or lang in SHELL:
            out.append(("python" if lang == "python" else "shell", body,
                        text.count("\n", 0, m.start()) + 1))
    return out


def shell_script(block: str) -> tuple[str, list[str]]:
    """(the block's commands to run, the commands left out with the reason)."""
    from test_readme import runnable_shell

    script = runnable_shell(block)
    kept, left = [], []
    for cmd in re.split(r"(?<!\\)\n", script):  # one command with its continuation lines
        if "../shared/" in cmd and not SHARED_DATA.is_dir():
            left.append(f"{cmd.strip()} (reads ../shared/, which is not beside the checkout)")
        elif cmd.strip():
            kept.append(cmd)
    return "\n".join(kept), left


def test_the_runner_finds_the_tutorials_shell_blocks():
    """The tutorials' shell commands are run (only their Python blocks were, and a bash block
    read bench files nothing created); install steps are left out."""
    langs = {t.stem: [lang for lang, _, _ in code_blocks(t)] for t in TUTORIALS}
    assert langs["inflow"].count("shell") >= 3 and "shell" in langs["controllers"]
    assert shell_script("pip install uuvid\nuuvid examples --list")[0] == "uuvid examples --list"
    if not SHARED_DATA.is_dir():
        script, left = shell_script("uuvid a \\\n  ../shared/x\nuuvid b")
        assert script == "uuvid b" and "uuvid a" in left[0] and "not beside" in left[0]


def _shell_env() -> dict:
    from test_readme import _env

    return _env(Path.cwd())


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
    left_out: list[str] = []
    for i, (lang, c, line) in enumerate(code_blocks(path), 1):
        if lang == "python":
            try:
                exec(compile(c, f"{path.name}[block {i}]", "exec"), ns)
            except Exception as e:  # name the block that failed
                raise AssertionError(f"{path.name}, python block at line {line} failed: {e!r}") from e
            continue
        script, left = shell_script(c)
        left_out += left
        if not script:
            continue
        if shutil.which("uuvid", path=_shell_env()["PATH"]) is None:
            pytest.fail("the `uuvid` command is not installed next to this interpreter")
        res = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", script], cwd=tmp_path,
                             env=_shell_env(), capture_output=True, text=True, timeout=900)
        assert res.returncode == 0, (
            f"{path.name}, shell block at line {line} failed (exit {res.returncode}):\n{c}\n"
            f"--- stdout\n{res.stdout[-3000:]}\n--- stderr\n{res.stderr[-3000:]}")
    if left_out:
        from conftest import missing_shared_data

        missing_shared_data(f"{path.name}: every block ran but these commands: {'; '.join(left_out)}")


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
