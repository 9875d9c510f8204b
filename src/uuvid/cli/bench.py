"""``uuvid bench``: finds the timing loops in the repository's ``benchmarks/`` folder and runs them.

The loops live in ``benchmarks/`` (beside ``src/``) so they can also be run on their own; this
module only locates and calls them.  Every case reports our time, the reference's time and the
ratio, measured in the same process.
"""

from __future__ import annotations

import importlib.util
import os
import platform
import sys
from pathlib import Path


def benchmarks_dir() -> Path:
    env = os.environ.get("UUVID_BENCHMARKS")
    candidates = [Path(env)] if env else []
    candidates.append(Path(__file__).resolve().parents[3] / "benchmarks")
    candidates.append(Path.cwd() / "benchmarks")
    for c in candidates:
        if (c / "bench_thruster.py").is_file():
            return c
    raise FileNotFoundError(
        "cannot find the benchmarks/ folder (looked in "
        + ", ".join(str(c) for c in candidates)
        + "); run from a source checkout or set UUVID_BENCHMARKS")


def _load(name: str):
    """Import ``benchmarks/<name>.py`` as the module ``uuvid_benchmarks_<name>``, registered in
    ``sys.modules`` before it runs: numba's ``cache=True`` records a function's module by name,
    and an unregistered module is cached as ``<dynamic>``, which the next process cannot import."""
    mod_name = f"uuvid_benchmarks_{name}"
    path = benchmarks_dir() / f"{name}.py"
    loaded = sys.modules.get(mod_name)
    if loaded is not None and Path(getattr(loaded, "__file__", "")) == path:
        return loaded
    spec = importlib.util.spec_from_file_location(mod_name, path)
    if spec is None or spec.loader is None:
        raise FileNotFoundError(f"{path}: not a Python benchmark file")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[mod_name] = mod
    try:
        spec.loader.exec_module(mod)
    except BaseException:
        sys.modules.pop(mod_name, None)
        raise
    return mod


def run_benchmarks() -> dict:
    from uuvid.core.threads import usable_cpus

    # the machine's cores and the ones this process may use (affinity, a container's quota)
    result = {"machine": {"python": platform.python_version(), "cpus": os.cpu_count(),
                          "usable_cpus": usable_cpus(), "platform": platform.platform()}}
    result.update(_load("bench_thruster").run_all())
    result.update(_load("bench_identification").run_all())
    result.update(_load("bench_vehicle").run_all())
    result.update(_load("bench_sweep").run_all())
    result.update(_load("bench_allocation").run_all())
    result.update(_load("bench_startup").run_all())
    result.update(_load("bench_gym").run_all())
    result.update(_load("bench_dynamics").run_all())
    result.update(_load("bench_controllers").run_all())
    result.update(_load("bench_dive").run_all())
    return result
