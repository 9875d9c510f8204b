"""CI tests what it pins: .ci/run is the README's test command and installs .ci/constraints.txt,
which pins every dependency pyproject.toml names, inside pyproject's ranges, in a virtualenv of its
own; under CI=true tests needing ../shared fail rather than skip; .ci/run-latest lists every
difference from the pins."""

from __future__ import annotations

import re
import subprocess
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


def test_ci_has_its_own_virtualenv_and_leaves_the_users_alone():
    """.ci/run builds and removes .ci/venv only (issue 22: it used to delete the user's .venv),
    which git ignores; it runs under CI=true unless told otherwise."""
    run = (ROOT / ".ci" / "run").read_text()
    code = "\n".join(line for line in run.splitlines() if not line.lstrip().startswith("#"))
    assert re.search(r"python3 -m venv \.ci/venv\b", code)
    assert "rm -rf .ci/venv" in code
    assert not re.search(r"(?<![\w/])\.venv\b", code), "CI must not touch the user's .venv"
    assert 'export CI="${CI:-true}"' in code
    assert "/.ci/venv/" in (ROOT / ".gitignore").read_text().splitlines()


def _pin_diff(tmp_path, pins: str, freeze: str) -> subprocess.CompletedProcess:
    p = tmp_path / "constraints.txt"
    p.write_text(pins)
    return subprocess.run(["bash", str(ROOT / ".ci" / "pin-diff"), str(p)], input=freeze,
                          capture_output=True, text=True, timeout=30)


def test_run_latest_reports_every_difference_from_the_pins(tmp_path):
    """The comparison .ci/run-latest prints: each changed or new package, and "(none)" only when
    nothing differs (its old pipeline printed "(none)" after the differences: diff's status 1
    under pipefail fell through to the `|| echo`)."""
    assert ".ci/pin-diff" in (ROOT / ".ci" / "run-latest").read_text()
    pins = "# header\nnumpy==2.0.0\nscipy==1.13.0\n\n"
    r = _pin_diff(tmp_path, pins, "numpy==2.1.0\nscipy==1.13.0\nuuvid==0.1.0\nrich==13.0\n")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert "  pinned: numpy==2.0.0" in lines and "  newest: numpy==2.1.0" in lines
    assert "  newest: rich==13.0" in lines
    assert "(none)" not in r.stdout and "scipy" not in r.stdout and "uuvid" not in r.stdout
    same = _pin_diff(tmp_path, pins, "scipy==1.13.0\nnumpy==2.0.0\n")
    assert same.stdout.splitlines() == ["  (none)"] and same.returncode == 0


def test_shared_data_tests_fail_in_ci_and_skip_outside(monkeypatch):
    import pytest
    from conftest import missing_shared_data

    monkeypatch.setenv("CI", "true")
    with pytest.raises(pytest.fail.Exception, match="CI=true"):
        missing_shared_data()
    monkeypatch.delenv("CI")
    with pytest.raises(pytest.skip.Exception):
        missing_shared_data()
    monkeypatch.setenv("CI", "false")
    with pytest.raises(pytest.skip.Exception):
        missing_shared_data()
