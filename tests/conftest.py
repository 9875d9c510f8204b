import os
from pathlib import Path

import pytest

os.environ.setdefault("UUVID_NO_PROGRESS", "1")

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def in_ci() -> bool:
    """True under ``CI=true`` (or 1/yes), as CI services and ``.ci/run`` set it."""
    return os.environ.get("CI", "").strip().lower() in ("true", "1", "yes")


def missing_shared_data(what: str = "../shared/data is not present") -> None:
    """A test needs ../shared/data and it is absent: skip outside CI; fail loudly in CI, where a
    silently skipped real-data test would pass a run that tested nothing of the kind."""
    if in_ci():
        pytest.fail(f"{what} (CI=true: tests that read ../shared/data fail in CI rather than skip; "
                    "put the shared folder beside the checkout)", pytrace=False)
    pytest.skip(what)


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """../shared/data beside the checkout; tests that need it skip when it is absent (and fail
    under CI=true, :func:`missing_shared_data`)."""
    if not SHARED_DATA.is_dir():
        missing_shared_data()
    return SHARED_DATA


def pytest_addoption(parser):
    parser.addoption("--run-slow", action="store_true", default=False,
                     help="also run tests marked slow (CI and the README's test command do)")


def pytest_collection_modifyitems(config, items):
    if config.getoption("--run-slow"):
        return
    skip = pytest.mark.skip(reason="slow: run with --run-slow (CI does)")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)
