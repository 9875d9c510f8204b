"""Every code block of README.md runs as written, each in a fresh empty directory.

``bash`` blocks run under ``bash -e`` with the installed ``uuvid`` first on the PATH; the install
and test steps a newcomer pastes first (``python3 -m venv``, ``. .venv/bin/activate``, ``pip
install``, ``python -m pytest``) are recognised and left out — CI runs them itself.  ``python``
blocks run with this interpreter; ``yaml`` blocks must parse (and load, if they are thruster model
files).  A block that reads ``../shared/`` runs with that folder beside its directory and skips when
the data is absent (fails under ``CI=true``); shell and Python blocks start processes and are marked slow (CI runs them).  Blocks without a language (directory trees, output) are not code.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"  # as conftest.py

README = Path(__file__).resolve().parents[1] / "README.md"
FENCE = re.compile(r"^```([A-Za-z0-9_+-]*)[^\n]*\n(.*?)^```\s*$", re.M | re.S)
SETUP = re.compile(r"^(python3? -m venv\b|\. \S*activate$|source \S*activate$|pip install\b|"
                   r"python3? -m pip install\b|python3? -m pytest\b|pytest\b)")
TIMEOUT = 900


def readme_blocks() -> list[tuple[str, str, int]]:
    """(language, text, line number) of every fenced block of the README."""
    text = README.read_text(encoding="utf-8")
    return [(m.group(1).lower(), m.group(2), text.count("\n", 0, m.start()) + 1)
            for m in FENCE.finditer(text)]


def runnable_shell(block: str) -> str:
    """The block without its install/test steps: commands joined by ``&&`` on one line are split
    and the setup ones dropped; continuation lines stay with their command."""
    commands, cur = [], ""
    for line in block.splitlines():
        cur += line + "\n"
        if not line.rstrip().endswith("\\"):
            commands.append(cur)
            cur = ""
    if cur:
        commands.append(cur)
    kept = []
    for cmd in commands:
        parts = [p.strip() for p in cmd.strip().split("&&")]
        parts = [p for p in parts if p and not SETUP.match(p)]
        if parts:
            kept.append(" && ".join(parts))
    return "\n".join(kept)


def _params():
    out = []
    for lang, text, line in readme_blocks():
        if lang not in ("bash", "sh", "shell", "console", "python", "py", "yaml", "yml"):
            continue
        # every command starts a process (≈ 1–3 s each): shell and Python blocks are slow tests
        marks = [pytest.mark.slow] if lang not in ("yaml", "yml") else []
        out.append(pytest.param(lang, text, id=f"line{line}-{lang}", marks=marks))
    return out


def test_the_readme_has_runnable_blocks():
    langs = [lang for lang, _, _ in readme_blocks()]
    assert "bash" in langs and "python" in langs
    # the install line is recognised: what is left of it is the demo
    install = next(t for lang, t, _ in readme_blocks() if lang == "bash" and "pip install" in t)
    assert "pip install" not in runnable_shell(install)


def _env(workdir: Path) -> dict:
    env = dict(os.environ)
    bindir = str(Path(sys.executable).parent)
    env["PATH"] = bindir + os.pathsep + env.get("PATH", "")
    env["MPLBACKEND"] = "Agg"
    env["UUVID_NO_PROGRESS"] = "1"
    src = str(Path(__file__).resolve().parents[1] / "src")
    env["PYTHONPATH"] = src + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env


@pytest.mark.parametrize(("lang", "text"), _params())
def test_readme_block_runs(lang, text, tmp_path):
    work = tmp_path / "work"
    work.mkdir()
    if "../shared/" in text:
        if not SHARED_DATA.is_dir():
            from conftest import missing_shared_data

            missing_shared_data("the block reads ../shared/data, which is not present")
        (tmp_path / "shared").symlink_to(SHARED_DATA.parent, target_is_directory=True)
    if lang in ("yaml", "yml"):
        doc = yaml.safe_load(text)
        assert doc is not None
        if isinstance(doc, dict) and "blocks" in doc:
            from uuvid.thruster.modelfile import load_chain

            p = work / "model.yaml"
            p.write_text(text, encoding="utf-8")
            load_chain(p)
        return
    if lang in ("python", "py"):
        cmd = [sys.executable, "-c", text]
    else:
        script = runnable_shell(text)
        if not script.strip():
            pytest.skip("only install/test steps")
        if shutil.which("uuvid", path=_env(work)["PATH"]) is None:
            pytest.fail("the `uuvid` command is not installed next to this interpreter")
        cmd = ["bash", "-e", "-o", "pipefail", "-c", script]
    res = subprocess.run(cmd, cwd=work, env=_env(work), capture_output=True, text=True,
                         timeout=TIMEOUT)
    assert res.returncode == 0, (
        f"README block failed (exit {res.returncode}):\n{text}\n--- stdout\n{res.stdout[-3000:]}"
        f"\n--- stderr\n{res.stderr[-3000:]}")
