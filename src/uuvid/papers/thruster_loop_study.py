"""Study: thruster dynamics inside a heading and a depth loop (McLean 1991, Ch. V conjecture).

Yoerger, Cooke & Slotine (1990) found that the lag of shrouded-propeller thrusters makes a
vehicle's position loops limit-cycle; McLean (1991) conjectured that tunnel thrusters, whose
thrust *leads* (the water column's inertia gives a thrust spike at a voltage step), would instead
stabilise them.  We put three thruster models with the same steady voltage → thrust map into the
AUV II (four tunnel thrusters; heading from the horizontal pair, depth from the vertical pair),
fly a heading step and a depth step with the same PID DP controller at increasing bandwidth, and
measure the oscillation left once the transient has passed:

* ``tunnel``: McLean's tunnel thruster (leading response);
* ``first-order``: the same steady map behind a first-order lag (τ = 0.3 s);
* ``yoerger``: Yoerger's rotor model ``Ω̇ = βV − αΩ|Ω|``, ``T = c Ω|Ω|`` with the same full-voltage
  thrust (its lag grows as the speed falls).

A loop *limit-cycles* when the residual peak-to-peak oscillation (last 20 s) exceeds a threshold
(0.5° heading, 1 cm depth) and does not die out; it *holds its reference* when that swing and the
final error are both within the threshold.  A bandwidth is *stable* when the loop holds its
reference there; the answer compares, per model, the largest bandwidth tried below the first one
that is not stable (a clean row above a failing one is not evidence of stability at it).  When no
model fails in a loop within the bandwidths tried, the study draws no conclusion for that loop.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from uuvid.papers.reproduction import PaperReproduction
from uuvid.simulate.reference import WaypointMission
from uuvid.simulate.vehicle_sim import default_gains, fly_mission, setup_mission
from uuvid.thruster.blocks import FirstOrder, QuadraticMap, TableMap, Yoerger
from uuvid.thruster.chain import ThrusterChain
from uuvid.thruster.presets import auv2_tunnel_chain
from uuvid.vehicle.definition import load_vehicle

BANDWIDTHS = (1.0, 2.0, 4.0, 6.0)
HEADING_THRESHOLD_DEG = 0.5
DEPTH_THRESHOLD_M = 0.01


def thruster_models(lag: float = 0.3) -> dict[str, ThrusterChain]:
    """Three voltage-driven thruster chains sharing the tunnel thruster's steady map."""
    tunnel = auv2_tunnel_chain()
    v = np.linspace(-24.0, 24.0, 97)
    f = tunnel.steady_thrust(v)
    table = TableMap(tuple(v), tuple(f))
    f_full = float(f[-1])
    alpha = 40.0  # rad/s per (rad/s): Yoerger's drag constant, chosen for a ~0.3 s lag at full speed
    omega_full = 300.0
    beta = alpha * omega_full**2 / 24.0
    c = f_full / omega_full**2
    return {
        "tunnel": tunnel,
        "first-order": ThrusterChain((FirstOrder(lag), table), input_kind="voltage", name="first-order"),
        "yoerger": ThrusterChain((Yoerger(alpha=alpha / omega_full, beta=beta / omega_full),
                                  QuadraticMap.basic(c)), input_kind="voltage", name="yoerger"),
    }


def _step_mission(kind: str) -> WaypointMission:
    if kind == "heading":
        wps = ((0.0, 0.0, 2.0, 0.0), (0.0, 0.0, 2.0, math.radians(20.0)))
    else:
        wps = ((0.0, 0.0, 2.0, 0.0), (0.0, 0.0, 2.5, 0.0))
    return WaypointMission(wps, speed=0.5, vertical_speed=1.0, yaw_rate=2.0, ramp_time=0.0, hold=60.0,
                           name=f"{kind} step")


def _sustained_oscillation(y: np.ndarray, threshold: float) -> bool:
    """A limit cycle, not a decaying tail: peak-to-peak above ``threshold``, the signal crosses
    its mean at least twice (a slow cycle — 9° with an 11 s period at 50 rad/s — shows barely a
    period and a half in the 20 s tail) and its swing in the second half is at least half that
    of the first (a growing swing counts; a monotonic drift is caught by the reference check)."""
    if np.ptp(y) <= threshold:
        return False
    d = y - np.mean(y)
    crossings = int(np.sum(np.signbit(d[1:]) != np.signbit(d[:-1])))
    half = y.size // 2
    return crossings >= 2 and np.ptp(y[half:]) >= 0.5 * np.ptp(y[:half])


def _holds_reference(y: np.ndarray, target: float, threshold: float) -> bool:
    """The loop holds its reference: finite, residual swing and final error within ``threshold``."""
    return bool(np.all(np.isfinite(y)) and np.ptp(y) <= threshold
                and abs(float(y[-1]) - target) <= threshold)


#: The control and integration step of the study's flights [s].
CONTROL_DT = 0.01


def run_case(vehicle, chain, kind: str, bandwidth: float, dt: float = CONTROL_DT,
             substeps: int = 2) -> dict:
    g = default_gains(vehicle, omega=(bandwidth,) * 4)
    mission = _step_mission(kind)
    setup = setup_mission(vehicle, mission, dt=dt, substeps=substeps, gains=g, thruster_chain=chain)
    r = fly_mission(setup)
    tail = r.t >= r.t[-1] - 20.0
    if kind == "heading":
        from uuvid.vehicle.kinematics import quat_to_euler

        yaw = quat_to_euler(r.state[:, 3:7])[:, 2]
        sig = np.degrees(yaw)
        target = 20.0
        threshold = HEADING_THRESHOLD_DEG
    else:
        sig = r.state[:, 2]
        target = 2.5
        threshold = DEPTH_THRESHOLD_M
    p2p = float(np.ptp(sig[tail]))
    overshoot = float(np.max(sig) - target)
    return {"kind": kind, "model": chain.name, "bandwidth": bandwidth, "residual_p2p": p2p,
            "limit_cycle": (not np.all(np.isfinite(sig))) or _sustained_oscillation(sig[tail], threshold),
            "holds_reference": _holds_reference(sig[tail], target, threshold),
            "overshoot": overshoot, "final_error": float(sig[-1] - target),
            "max_thrust_N": float(np.max(np.abs(r.thrust)))}


class LoopStudy(PaperReproduction):
    """:func:`run_study`'s document (a dict: ``rows``, ``max_stable_bandwidth``, ``answer``…)
    with the common result surface."""

    report_title = "Study: thruster dynamics in heading and depth loops (AUV II)"

    def summary(self) -> str:
        return self["answer"]

    def plot(self):
        """Residual peak-to-peak against the controller bandwidth, per loop and thruster model."""
        from uuvid.core.plots import new_figure

        fig, axes = new_figure(1, 2, figsize=(11, 4))
        for ax, kind, unit in ((axes[0], "heading", "°"), (axes[1], "depth", "m")):
            for name in ("tunnel", "first-order", "yoerger"):
                rr = [r for r in self["rows"] if r["kind"] == kind and r["model"] == name]
                ax.semilogy([r["bandwidth"] for r in rr],
                            [max(r["residual_p2p"], 1e-9) for r in rr], "o-", label=name)
            ax.axhline(self["thresholds"]["heading_deg" if kind == "heading" else "depth_m"],
                       color="r", ls=":", label="limit-cycle threshold")
            ax.set_xlabel("controller bandwidth [rad/s]")
            ax.set_ylabel(f"residual peak-to-peak [{unit}]")
            ax.set_title(f"{kind} step")
            ax.legend()
        return fig

    def _write_outputs(self, folder: Path) -> Path:
        return write_outputs(self, folder)


def run_study(bandwidths=BANDWIDTHS, progress=None) -> LoopStudy:
    """Heading and depth steps of AUV II with each thruster model at each controller bandwidth:
    the largest bandwidth without a limit cycle per model (McLean's conjecture).  ``ValueError``
    before any flight for a bandwidth that is not finite, > 0 and below the Nyquist frequency
    π/dt of the 0.01 s control step."""
    bandwidths = tuple(float(b) for b in bandwidths)
    nyquist = math.pi / CONTROL_DT
    bad = [b for b in bandwidths if not (math.isfinite(b) and 0 < b < nyquist)]
    if not bandwidths or bad:
        raise ValueError(f"bandwidths: expected controller bandwidths > 0 and below {nyquist:.0f} "
                         f"rad/s (π / the {CONTROL_DT:g} s control step), got "
                         f"{', '.join(f'{b:g}' for b in bad) or 'none'}")
    twice = sorted({b for b in bandwidths if bandwidths.count(b) > 1})
    if twice:
        raise ValueError(f"bandwidths: {', '.join(f'{b:g}' for b in twice)} rad/s given twice; "
                         "give each controller bandwidth once")
    vehicle = load_vehicle("auv2")
    models = thruster_models()
    rows = []
    for kind in ("heading", "depth"):
        for name, chain in models.items():
            chain = dataclasses.replace(chain, name=name) if chain.name != name else chain
            for bw in bandwidths:
                rows.append(run_case(vehicle, chain, kind, bw))
                if progress:
                    progress()
    stable, holds, lagging_cycles, answer = _answer(rows, list(models), bandwidths)
    return LoopStudy({"rows": rows, "max_stable_bandwidth": stable, "conjecture_holds": holds,
                      "lagging_limit_cycles": lagging_cycles, "answer": answer,
                      "bandwidths_tried": sorted(float(b) for b in bandwidths),
                      "thresholds": {"heading_deg": HEADING_THRESHOLD_DEG,
                                     "depth_m": DEPTH_THRESHOLD_M}})


def _answer(rows: list[dict], models: list[str], bandwidths) -> tuple:
    """``(stable, holds, lagging_cycles, text)``: per loop and model the largest bandwidth tried
    below the first one that fails (limit cycle, or the reference not held: a large residual
    swing or final error), bracketed by that failing one — the number depends on the bandwidths
    tried, so the text names them (the demo tries 2, 6; the CLI 1, 2, 4, 6).  ``holds[loop]``:
    the tunnel thruster's stable bandwidth ≥ the lagging ones'; ``None`` when no model failed in
    that loop within the range (the range found no limit: no verdict on the conjecture)."""
    stable: dict = {}
    above: dict = {}
    why: dict = {}
    for kind in ("heading", "depth"):
        stable[kind], above[kind], why[kind] = {}, {}, {}
        for name in models:
            mine = sorted((r for r in rows if r["kind"] == kind and r["model"] == name),
                          key=lambda r: r["bandwidth"])
            first_bad = next((r for r in mine if r["limit_cycle"] or not r["holds_reference"]), None)
            ok = [r["bandwidth"] for r in mine
                  if first_bad is None or r["bandwidth"] < first_bad["bandwidth"]]
            stable[kind][name] = max(ok) if ok else 0.0
            above[kind][name] = None if first_bad is None else first_bad["bandwidth"]
            why[kind][name] = None if first_bad is None else (
                "cycles" if first_bad["limit_cycle"] else "does not hold the reference")

    def b(kind, name):
        hi = above[kind][name]
        return f"{stable[kind][name]:g}" + (f" ({why[kind][name]} at {hi:g})" if hi is not None else "")

    lagging = [m for m in models if m != "tunnel"]
    holds: dict = {}
    for k in stable:
        lag_limited = any(above[k][m] is not None for m in lagging)
        if not lag_limited and above[k]["tunnel"] is None:
            holds[k] = None
        else:
            holds[k] = stable[k]["tunnel"] >= max(stable[k][m] for m in lagging)
    lagging_cycles = any(r["limit_cycle"] for r in rows if r["model"] != "tunnel")
    tried = ", ".join(f"{x:g}" for x in sorted(float(x) for x in bandwidths))
    open_loops = [k for k, v in holds.items() if v is None]
    if any(v is False for v in holds.values()):
        verdict = ("the tunnel thruster does not tolerate a higher bandwidth in every loop, so McLean's "
                   "conjecture is not borne out here: " + ", ".join(
                       f"{k}: {'no limit found' if v is None else 'holds' if v else 'fails'}"
                       for k, v in holds.items()) + ".")
    elif open_loops and len(open_loops) == len(holds):
        verdict = ("no model failed in either loop within the bandwidths tried: this range found no "
                   "limit, so it says nothing on McLean's conjecture (try higher bandwidths).")
    elif open_loops:
        verdict = (f"the tunnel thruster tolerates at least as high a bandwidth in the "
                   f"{', '.join(k for k in holds if holds[k])} loop, as McLean conjectured; in the "
                   f"{', '.join(open_loops)} loop no model failed, so this range found no limit there "
                   "and says nothing on the conjecture (try higher bandwidths).")
    else:
        verdict = ("the tunnel thruster tolerates at least as high a bandwidth in both loops, as "
                   "McLean conjectured.")
    answer = (
        f"Largest bandwidth tried ({tried} rad/s) below the first that fails (limit cycle or the "
        f"reference not held) — heading: tunnel "
        f"{b('heading', 'tunnel')}, first-order {b('heading', 'first-order')}, Yoerger "
        f"{b('heading', 'yoerger')} rad/s; depth: tunnel {b('depth', 'tunnel')}, first-order "
        f"{b('depth', 'first-order')}, Yoerger {b('depth', 'yoerger')} rad/s (a finer set of "
        "bandwidths moves these numbers between the bracketing ones). "
        + ("Lagging thrusters do limit-cycle as the loops are tightened (Yoerger et al.'s finding); "
           if lagging_cycles else "No limit cycle appeared with the lagging thrusters in this range; ")
        + verdict
    )
    return stable, holds, lagging_cycles, answer


def write_outputs(result: dict, out: str | Path) -> Path:
    from uuvid.core.atomic import atomic_write_json
    from uuvid.core.html import Report
    from uuvid.core.plots import save_figure

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rep = Report("Study: thruster dynamics in heading and depth loops (AUV II)")
    rep.add_paragraph(result["answer"])
    fig = LoopStudy(result).plot()
    rep.add_figure(save_figure(fig, out / "limit_cycles.png"))
    rep.add_table(result["rows"])
    atomic_write_json(out / "study.json", result)
    return rep.write(out)
