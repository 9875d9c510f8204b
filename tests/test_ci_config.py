"""CI tests what it pins: .ci/run is the README's test command and installs .ci/constraints.txt,
which pins every dependency pyproject.toml names, inside pyproject's ranges."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from packaging.requirements import Requirement

ROOT = Path(__file__).resolve().parents[1]


def _pins() -> dict[str, str]:
    pins = {}
    for line in (ROOT / ".ci" / "constraints.txt").read_text().splitlines():
        line = line.strip()
        if line and not line.startswith("#"):
            name, _, ver = line.partition("==")
            assert ver, f".ci/constraints.txt: {line!r} is not an exact pin"
            pins[re.sub(r"[-_.]+", "-", name).lower()] = ver
    return pins


def test_ci_run_is_the_readme_test_command():
    readme = (ROOT / "README.md").read_text()
    run = (ROOT / ".ci" / "run").read_text()
    cmd = next(line for line in run.splitlines() if "pytest" in line)
    assert cmd.strip() in readme
    assert "-c .ci/constraints.txt" in cmd


def test_constraints_pin_every_dependency_within_its_range():
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    run = (ROOT / ".ci" / "run").read_text()
    extras = re.search(r"-e '\.\[([^\]]*)\]'", run).group(1).split(",")
    reqs = list(meta["dependencies"])
    for e in extras:
        reqs += meta["optional-dependencies"][e.strip()]
    pins = _pins()
    for text in reqs:
        r = Requirement(text)
        name = re.sub(r"[-_.]+", "-", r.name).lower()
        assert name in pins, f"{r.name} is installed by CI but not pinned in .ci/constraints.txt"
        assert r.specifier.contains(pins[name], prereleases=True), (
            f"{r.name}=={pins[name]} is outside pyproject's range {r.specifier}")
