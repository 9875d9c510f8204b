"""Small (< 10 s) uncertainty showcases for ``uuvid demo``: a McLean design sweep and the T200
Monte Carlo band, both in-process, plus the summary view the CLI prints."""

from __future__ import annotations

from pathlib import Path


def public_summary(summary: dict) -> dict:
    """The summary without the (long) spec echo and band arrays — those are in summary.json."""
    out = {k: v for k, v in summary.items() if k not in ("spec",)}
    if "bands" in out:
        out["bands"] = {k: {kk: vv for kk, vv in b.items() if kk not in ("lower", "median", "upper")}
                        | ({"at_end": {"lower": b["lower"][-1], "median": b["median"][-1],
                                       "upper": b["upper"][-1]}} if b.get("n") else {})
                        for k, b in out["bands"].items()}
    return out


def demo_sweep(out: str | Path) -> dict:
    """A small McLean sweep (tunnel length × voltage, 30 step responses, in-process): heat map and
    line plots in ``out``; returns the summary with the Table I baseline point."""
    from uuvid.uncertainty.sweep import SweepSpec, run_sweep

    spec = SweepSpec.model_validate({
        "name": "demo-mclean-tunnel-length-voltage",
        "description": "AUV II tunnel thruster on its rig: peak measured thrust and speed time "
                       "constant against tunnel length and step voltage (McLean 1991, Table I "
                       "extended).",
        "target": {"kind": "thruster_step", "chain": "auv2-tunnel", "t_end": 1.333, "substeps": 1},
        "parameters": [{"name": "tunnel_length", "unit": "in", "values": [5, 8, 10.5, 14, 17, 20]},
                       {"name": "voltage", "values": [8, 12, 16, 20, 24]}],
        "metrics": ["peak_output_thrust", "time_constant_speed", "steady_thrust"],
    })
    res = run_sweep(spec, Path(out), backend="inprocess", progress=False)
    t = res.table
    base = t[(abs(t["tunnel_length"] - 0.2667) < 1e-9) & (t["voltage"] == 24)].iloc[0]
    return {"summary": {k: v for k, v in res.info.items() if k != "spec"}, "out": str(out),
            "baseline_24V": {m: float(base[m]) for m in spec.metrics}}


def demo_montecarlo(out: str | Path, runs: int = 500) -> dict:
    """The T200 thrust-vs-PWM 95 % band at 12, 14 and 16 V from the physical fit's covariance
    (``t200-physical``, in-process); returns the summary (bands at full forward command)."""
    from uuvid.uncertainty.montecarlo import run_montecarlo

    res = run_montecarlo("t200-physical", runs, Path(out), seed=0, backend="inprocess",
                         progress=False)
    s = res.info
    ends = {k: {"lower": b["lower"][-1], "median": b["median"][-1], "upper": b["upper"][-1]}
            for k, b in s.get("bands", {}).items() if b.get("n")}
    return {"summary": public_summary(s), "out": str(out), "full_forward_thrust_band_N": ends}
