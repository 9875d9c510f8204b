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
(0.5° heading, 1 cm depth).  The answer compares the largest bandwidth each model keeps free of it.
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
    """A limit cycle, not a slow tail: peak-to-peak above ``threshold``, the signal keeps crossing
    its mean (≥ 4 times) and its swing in the second half is at least half that of the first."""
    if np.ptp(y) <= threshold:
        return False
    d = y - np.mean(y)
    crossings = int(np.sum(np.signbit(d[1:]) != np.signbit(d[:-1])))
    half = y.size // 2
    return crossings >= 4 and np.ptp(y[half:]) >= 0.5 * np.ptp(y[:half])


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
    without a limit cycle, bracketed by the next one tried that cycles — the number depends on
    the bandwidths tried, so the text names them (the demo tries 2, 6; the CLI 1, 2, 4, 6)."""
    stable: dict = {}
    above: dict = {}
    for kind in ("heading", "depth"):
        stable[kind], above[kind] = {}, {}
        for name in models:
            mine = [r for r in rows if r["kind"] == kind and r["model"] == name]
            ok = [r["bandwidth"] for r in mine if not r["limit_cycle"]]
            stable[kind][name] = max(ok) if ok else 0.0
            bad = [r["bandwidth"] for r in mine
                   if r["limit_cycle"] and r["bandwidth"] > stable[kind][name]]
            above[kind][name] = min(bad) if bad else None

    def b(kind, name):
        hi = above[kind][name]
        return f"{stable[kind][name]:g}" + (f" (cycles at {hi:g})" if hi is not None else "")

    lag_best = {k: max(stable[k]["first-order"], stable[k]["yoerger"]) for k in stable}
    holds = {k: stable[k]["tunnel"] >= lag_best[k] for k in stable}
    lagging_cycles = any(r["limit_cycle"] for r in rows if r["model"] != "tunnel")
    tried = ", ".join(f"{x:g}" for x in sorted(float(x) for x in bandwidths))
    answer = (
        f"Largest bandwidth tried ({tried} rad/s) without a limit cycle — heading: tunnel "
        f"{b('heading', 'tunnel')}, first-order {b('heading', 'first-order')}, Yoerger "
        f"{b('heading', 'yoerger')} rad/s; depth: tunnel {b('depth', 'tunnel')}, first-order "
        f"{b('depth', 'first-order')}, Yoerger {b('depth', 'yoerger')} rad/s (a finer set of "
        "bandwidths moves these numbers between the bracketing ones). "
        + ("Lagging thrusters do limit-cycle as the loops are tightened (Yoerger et al.'s finding); "
           if lagging_cycles else "No limit cycle appeared with the lagging thrusters in this range; ")
        + ("the tunnel thruster tolerates at least as high a bandwidth in both loops, as McLean "
           "conjectured." if all(holds.values()) else
           "the tunnel thruster does not tolerate a higher bandwidth in every loop, so McLean's "
           "conjecture is not borne out here: " + ", ".join(f"{k}: {'holds' if v else 'fails'}"
                                                           for k, v in holds.items()) + ".")
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
