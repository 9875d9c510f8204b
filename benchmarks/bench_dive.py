"""Dive identification benchmark: a 10-minute synthetic piloted dive (heave and yaw).

Run standalone (``python benchmarks/bench_dive.py``) or through ``uuvid bench``.  Times
:func:`uuvid.identify.vehicle.dive.identify_dive` on a 600 s dive from
:func:`uuvid.simulate.dive_synth.synthetic_dive` (the dive's generation is not timed); the issue
asks for seconds, not minutes.
"""

from __future__ import annotations

import time


def dive_identification(repeat: int = 2) -> dict:
    from uuvid.identify.vehicle.dive import identify_dive
    from uuvid.simulate.dive_synth import synthetic_dive

    df, _ = synthetic_dive(600.0, seed=0, pwm_rate=10.0, surge=0.0)
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = identify_dive(df, "bluerov2", ["heave", "yaw"])
        best = min(best, time.perf_counter() - t0)
    return {"case": "identify_dive_600s_heave_yaw", "seconds": best,
            "windows": {d: e.windows for d, e in res.estimates.items()},
            "iterations": {d: e.train["iterations"] for d, e in res.estimates.items()}}


def run_all(repeat: int = 2) -> dict:
    return {"dive": [dive_identification(repeat)]}


if __name__ == "__main__":
    import json

    print(json.dumps(run_all(), indent=2))
