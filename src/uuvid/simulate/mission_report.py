"""Figures and report of a flown mission (the kind of Laidani et al.'s Figs. 16–20).

3-D and top-view path against the reference, positions and heading, body velocities, thruster
forces per thruster group (horizontal / vertical) with their limits, tracking error.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from uuvid.core.atomic import atomic_path, atomic_write_json
from uuvid.core.html import Report
from uuvid.core.plots import new_figure, save_figure


def thruster_groups(vehicle) -> dict[str, list[int]]:
    """Thrusters grouped by direction: ``vertical`` (axis mostly along z) and ``horizontal``."""
    groups: dict[str, list[int]] = {"horizontal": [], "vertical": []}
    for i, th in enumerate(vehicle.layout):
        axis = np.asarray(th.axis, dtype=float)
        groups["vertical" if abs(axis[2]) > 0.7 else "horizontal"].append(i)
    return {k: v for k, v in groups.items() if v}


def mission_text(result) -> str:
    """A few lines on a :class:`~uuvid.simulate.vehicle_sim.MissionResult`'s metrics."""
    m = result.metrics
    lines = [f"{m.get('vehicle', '')}: {m.get('mission', '')} — "
             + ("completed" if m.get("completed") else "NOT completed"
                + (f" ({m['completed_reason']})" if m.get("completed_reason") else ""))
             + f" ({m.get('controller', '?')}, disturbance {m.get('disturbance', 'none')}, "
             f"current {m.get('current', '?')}"
             + (f", inflow {m['inflow']} from the {m.get('inflow_source', 'vehicle file')}"
                if "inflow" in m else "") + ")"]
    if m.get("mission_note"):
        lines.append(f"  {m['mission_note']}")
    if m.get("propeller_map"):
        lines.append(f"  {m['propeller_map']}")
    for k in ("speed_m_s", "max_tracking_error_m", "rms_tracking_error_m", "final_position_error_m",
              "max_roll_deg", "max_pitch_deg", "max_heading_error_deg",
              "max_thrust_N", "thrust_limit_N", "saturated_fraction", "sim_time_s",
              "real_time_factor", "max_battery_current_A"):
        if k in m and m[k] is not None:
            lines.append(f"  {k:<24} {m[k]:.4g}")
    if "soc" in m:
        lines.append(f"  {'soc':<24} {m['soc'][0]:.3f} → {m['soc'][1]:.3f}")
    if m.get("thrust_over_limit"):
        lines.append("  warning: a delivered thrust exceeded its limit")
    for w in m.get("warnings", ()):
        lines.append(f"  warning: {w}")
    return "\n".join(lines)


def mission_overview(result):
    """One figure: top view of path and reference, tracking error, thruster forces."""
    fig, ax = new_figure(1, 3, figsize=(15, 4.2))
    p, r = result.position, result.ref_pos
    ax[0].plot(r[:, 1], r[:, 0], "k--", lw=1, label="reference")
    ax[0].plot(p[:, 1], p[:, 0], "C0", label="vehicle")
    ax[0].set_aspect("equal", adjustable="datalim")
    ax[0].set_xlabel("east [m]")
    ax[0].set_ylabel("north [m]")
    ax[0].legend(fontsize=8)
    ax[0].set_title(f"{result.metrics.get('vehicle', '')}: {result.metrics.get('mission', '')}",
                    fontsize=10)
    ax[1].plot(result.t, result.tracking_error)
    ax[1].set_xlabel("t [s]")
    ax[1].set_ylabel("|p − p_ref| [m]")
    ax[1].set_title("Tracking error", fontsize=10)
    for i, nm in enumerate(result.thruster_names):
        ax[2].plot(result.t, result.thrust[:, i], lw=0.8, label=nm)
    ax[2].set_xlabel("t [s]")
    ax[2].set_ylabel("thrust [N]")
    ax[2].set_title("Thruster forces", fontsize=10)
    ax[2].legend(fontsize=6, ncol=2)
    return fig


def mission_figures(result, vehicle) -> dict:
    """Named matplotlib figures of a :class:`~uuvid.simulate.vehicle_sim.MissionResult`."""
    from uuvid.vehicle.kinematics import quat_to_euler

    t = result.t
    p = result.position
    r = result.ref_pos
    figs = {}
    fig, ax2d = new_figure(1, 1, figsize=(7, 6))
    ax2d.remove()
    ax = fig.add_subplot(111, projection="3d")
    ax.plot(r[:, 1], r[:, 0], -r[:, 2], "k--", lw=1, label="reference")
    ax.plot(p[:, 1], p[:, 0], -p[:, 2], "C0", label="vehicle")
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.set_zlabel("height (−down) [m]")
    ax.set_title(f"{result.metrics.get('vehicle', '')}: {result.metrics.get('mission', '')}")
    ax.legend()
    figs["path_3d"] = fig
    fig, ax = new_figure(1, 1, figsize=(6, 6))
    ax.plot(r[:, 1], r[:, 0], "k--", lw=1, label="reference")
    ax.plot(p[:, 1], p[:, 0], "C0", label="vehicle")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.set_title("Top view")
    ax.legend()
    figs["path_top"] = fig
    eul = quat_to_euler(result.state[:, 3:7])
    fig, axes = new_figure(4, 1, sharex=True, figsize=(8, 8))
    for j, nm in enumerate(("north", "east", "down")):
        axes[j].plot(t, r[:, j], "k--", lw=1)
        axes[j].plot(t, p[:, j], "C0")
        axes[j].set_ylabel(f"{nm} [m]")
    # unwrapped: a heading through ±180° is a continuous turn, not a 360° jump
    axes[3].plot(t, np.degrees(np.unwrap(result.ref_yaw)), "k--", lw=1, label="reference")
    axes[3].plot(t, np.degrees(np.unwrap(eul[:, 2])), "C0", label="vehicle")
    axes[3].set_ylabel("yaw [°]")
    axes[3].set_xlabel("t [s]")
    axes[3].legend(loc="upper right")
    axes[0].set_title("Positions and heading")
    figs["positions"] = fig
    fig, ax = new_figure(1, 1, figsize=(8, 3))
    ax.plot(t, np.degrees(eul[:, 0]), label="roll")
    ax.plot(t, np.degrees(eul[:, 1]), label="pitch")
    from uuvid.vehicle.stability import MAX_TILT_DEG

    for sgn in (1, -1):
        ax.axhline(sgn * MAX_TILT_DEG, color="r", ls=":", lw=1)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("angle [°]")
    ax.set_title(f"Attitude (level limit ±{MAX_TILT_DEG:g}° dotted)")
    ax.legend(loc="upper right")
    figs["attitude"] = fig
    fig, axes = new_figure(4, 1, sharex=True, figsize=(8, 8))
    v = result.velocity
    for j, (k, nm, unit) in enumerate(((0, "u", "m/s"), (1, "v", "m/s"), (2, "w", "m/s"),
                                       (5, "r", "rad/s"))):
        axes[j].plot(t, v[:, k])
        axes[j].set_ylabel(f"{nm} [{unit}]")
    axes[3].set_xlabel("t [s]")
    axes[0].set_title("Body velocities")
    figs["velocities"] = fig
    groups = thruster_groups(vehicle)
    fig, axes = new_figure(len(groups), 1, sharex=True, figsize=(8, 3 * len(groups)), squeeze=False)
    lim = result.thrust_limits
    for ax, (gname, idx) in zip(axes[:, 0], groups.items()):
        for i in idx:
            ax.plot(t, result.thrust[:, i], label=result.thruster_names[i])
        ax.axhline(float(np.max(lim[idx, 1])), color="r", ls=":", lw=1)
        ax.axhline(float(np.min(lim[idx, 0])), color="r", ls=":", lw=1)
        ax.set_ylabel(f"{gname} thrust [N]")
        ax.legend(fontsize=7, ncol=2, loc="upper right")
    axes[-1, 0].set_xlabel("t [s]")
    axes[0, 0].set_title("Thruster forces (limits dotted)")
    figs["thrusters"] = fig
    fig, ax = new_figure(1, 1, figsize=(8, 3))
    ax.plot(t, result.tracking_error)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("|p − p_ref| [m]")
    ax.set_title("Tracking error")
    figs["tracking_error"] = fig
    return figs


def write_mission_outputs(result, vehicle, out: str | Path, extra: dict | None = None) -> Path:
    """Time series (CSV, and Parquet when pyarrow is installed), figures, summary JSON, index.html,
    as a whole (:func:`uuvid.core.atomic.atomic_dir`: an interrupted run leaves no empty or
    partial folder, and an old one intact).  Returns the index."""
    from uuvid.core.atomic import atomic_dir

    final = Path(out)
    with atomic_dir(final) as work:
        index = _mission_outputs_into(result, vehicle, work, extra)
    return final / Path(index).relative_to(work)


def _mission_outputs_into(result, vehicle, out: Path, extra: dict | None) -> Path:
    df = result.to_frame()
    with atomic_path(out / "timeseries.csv") as tmp:
        df.to_csv(tmp, index=False)
    try:
        import pyarrow  # noqa: F401

        with atomic_path(out / "timeseries.parquet") as tmp:
            df.to_parquet(tmp, index=False)
    except ImportError:
        pass
    summary = dict(result.metrics)
    if extra:
        summary.update(extra)
    atomic_write_json(out / "summary.json", summary)
    rep = Report(f"uuvid simulate — {summary.get('vehicle', '')}: {summary.get('mission', '')}")
    if summary.get("warnings"):  # what the command line prints under its table: here first
        rep.add_heading("Warnings")
        for w in summary["warnings"]:
            rep.add_paragraph(f"⚠ {w}")
    rep.add_table([{"quantity": k, "value": v} for k, v in summary.items()
                   if not isinstance(v, (list, dict))], caption="Summary (SI)")
    for name, fig in mission_figures(result, vehicle).items():
        rep.add_figure(save_figure(fig, out / f"{name}.png"), caption=name.replace("_", " "))
    return rep.write(out)
