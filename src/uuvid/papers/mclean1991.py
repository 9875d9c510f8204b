"""McLean (1991), *Dynamic performance of small diameter tunnel thrusters* — reproduced.

Client of the public API only: the AUV II preset (:mod:`uuvid.thruster.presets`), the chain
simulator, McLean's step metrics and the load-matching module.

* ``table1()`` — Table I, eleven simulated step responses (24 V unless named), in the thesis's
  units next to its printed values.
* ``load_matching()`` — App. A operating points for the Pittman 9514 and 14202 per gear ratio.
* ``pulsing()`` — the thesis's open question (Ch. V): does square or sawtooth voltage pulsing give
  more mean thrust than holding the same mean voltage?  Answered by simulation.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from uuvid.core import units as U
from uuvid.papers.mclean1991_table1 import (  # noqa: F401  (re-exported)
    STEP_DURATION,
    TABLE1_FIELDS,
    TABLE1_THESIS,
    Case,
    table1_cases,
)
from uuvid.papers.reproduction import PaperReproduction
from uuvid.simulate.signals import Sawtooth, Square
from uuvid.thruster import load_matching as lm
from uuvid.thruster.presets import MCLEAN, auv2_rig_chain


def simulate_case(case: Case, duration: float = STEP_DURATION, dt: float = 1e-3, substeps: int = 4):
    """Voltage step on the rig chain (tunnel thruster → load cell)."""
    chain = auv2_rig_chain(**case.overrides)
    return chain.simulate(case.voltage, duration, dt=dt, substeps=substeps)


def table1_row(case: Case, response) -> dict:
    m = response.metrics()
    row = {
        "case": case.name,
        "voltage_V": case.voltage,
        "peak_output_lbf": U.to_lbf(m.peak_output_thrust),
        "max_true_lbf": U.to_lbf(m.max_true_thrust),
        "steady_lbf": U.to_lbf(m.steady_thrust),
        "time_constant_s": m.time_constant_speed,
        "steady_rpm": U.to_rpm(m.steady_speed),
    }
    thesis = dict(zip(TABLE1_FIELDS, TABLE1_THESIS[case.name]))
    row["thesis"] = thesis
    row["rel_error"] = {k: (abs(row[k] - v) / abs(v) if v else abs(row[k])) for k, v in thesis.items()}
    return row


def table1(progress=None) -> tuple[list[dict], dict]:
    """Table I rows (thesis units) and the responses by case name."""
    rows, responses = [], {}
    for case in table1_cases():
        r = simulate_case(case)
        rows.append(table1_row(case, r))
        responses[case.name] = r
        if progress is not None:
            progress()
    return rows, responses


def load_matching() -> list[dict]:
    """App. A: rows ``{motor, gear_ratio, prop_rpm, thrust_lbf}`` (9514 at 2.5, 3.67, 5, 10; 14202
    at 2.5, 3.67, 5), with the thesis's conclusions as booleans."""
    rows = lm.load_matching_table()
    return rows


def load_matching_conclusions(rows: list[dict]) -> dict:
    def thrust(motor, ratio):
        for r in rows:
            if str(r["motor"]).endswith(motor) and abs(r["gear_ratio"] - ratio) < 1e-9:
                return r["thrust_lbf"]
        raise KeyError((motor, ratio))

    t95_25, t95_10 = thrust("9514", 2.5), thrust("9514", 10.0)
    t142_25, t142_5 = thrust("14202", 2.5), thrust("14202", 5.0)
    return {
        "9514_at_2.5_under_1lb": t95_25 < 0.8,
        "9514_at_10_near_0.9lb": 0.85 <= t95_10 <= 1.0,
        "14202_at_2.5_near_1.1lb": 1.05 <= t142_25 <= 1.2,
        "14202_5_over_2.5_gain": t142_5 / t142_25 - 1.0,
    }


def pulsing(
    frequencies_hz=(0.5, 1.0, 2.0, 5.0, 10.0),
    voltage: float = MCLEAN.supply_voltage,
    duration: float = 6.0,
    settle: float = 2.0,
    dt: float = 5e-4,
) -> dict:
    """Mean thrust of square (0↔V, 50 % duty) and sawtooth (0→V) voltage pulsing.

    Compared with the steady thrust at the same mean voltage (V/2) and at full voltage.  The mean
    is taken over whole periods after ``settle`` seconds.
    """
    chain = auv2_rig_chain()
    ss_mean = chain.blocks[0].steady_state(voltage / 2.0)["thrust"]
    ss_full = chain.blocks[0].steady_state(voltage)["thrust"]
    rows = []
    for f in frequencies_hz:
        period = 1.0 / f
        n_periods = max(1, int((duration - settle) / period))
        t_end = settle + n_periods * period
        for kind, sig in (
            ("square", Square(low=0.0, high=voltage, period=period)),
            ("sawtooth", Sawtooth(low=0.0, high=voltage, period=period)),
        ):
            r = chain.simulate(sig, t_end, dt=dt, substeps=2)
            mask = r.t >= t_end - n_periods * period - 1e-12
            mean_thrust = float(np.mean(r["thrust"][mask][:-1]))
            mean_measured = float(np.mean(r["measured_thrust"][mask][:-1]))
            rows.append(
                {
                    "waveform": kind,
                    "frequency_hz": f,
                    "mean_voltage_V": voltage / 2.0,
                    "mean_thrust_lbf": U.to_lbf(mean_thrust),
                    "mean_measured_lbf": U.to_lbf(mean_measured),
                    "ratio_to_steady_same_mean": mean_thrust / ss_mean,
                    "ratio_to_steady_full": mean_thrust / ss_full,
                }
            )
    best = max(rows, key=lambda r: r["ratio_to_steady_same_mean"])
    fmin, fmax = min(frequencies_hz), max(frequencies_hz)

    def gain(kind, f):
        return (
            next(
                r["ratio_to_steady_same_mean"]
                for r in rows
                if r["waveform"] == kind and r["frequency_hz"] == f
            )
            - 1.0
        )

    answer = (
        f"Against holding the same mean voltage ({voltage / 2:g} V): square pulsing 0↔{voltage:g} V "
        f"gives {gain('square', fmin):+.1%} mean thrust at {fmin:g} Hz and "
        f"{gain('square', fmax):+.1%} at {fmax:g} Hz; sawtooth gives {gain('sawtooth', fmin):+.1%} "
        f"and {gain('sawtooth', fmax):+.1%}. Steady thrust grows faster than linearly with voltage, "
        f"so slow pulsing gains a little; faster pulsing is averaged away by the motor and the "
        f"tunnel's water inertia. The best case ({best['waveform']}, {best['frequency_hz']:g} Hz) "
        f"reaches {best['ratio_to_steady_full']:.0%} of the steady thrust at full voltage: pulsing "
        f"never beats running at full voltage."
    )
    return {
        "steady_at_mean_voltage_lbf": U.to_lbf(ss_mean),
        "steady_at_full_voltage_lbf": U.to_lbf(ss_full),
        "rows": rows,
        "answer": answer,
        "beats_full_voltage": any(r["ratio_to_steady_full"] > 1 for r in rows),
    }


class McLeanReproduction(PaperReproduction):
    """:func:`reproduce`'s document (a dict) with the Table I step responses as
    ``artifacts["responses"]`` (case → :class:`~uuvid.core.response.TimeResponse`)."""

    report_title = "McLean (1991) — tunnel thruster step responses, reproduced"

    def summary(self) -> str:
        lines = [self["paper"], "Table I, ours [thesis]:"]
        for r in self["table1"]:
            lines.append(f"  {r['case']:<12} " + ", ".join(
                f"{k} {r[k]:.3g} [{r['thesis'][k]:g}]" for k in TABLE1_FIELDS))
        i = self["identified"]
        lines.append(f"identified α_o − α_i = {i['delta_alpha']:.3f} ± {i['delta_alpha_sigma']:.3f}, "
                     f"β_o − β_i = {i['delta_beta']:.4f} ± {i['delta_beta_sigma']:.4f}")
        ef = self["experiment_fit"]
        lines.append(f"experiment fit: mean |rel. error| {ef['mean_abs_rel_error']:.1%} (thesis's "
                     f"own simulation {ef['thesis_mean_abs_rel_error']:.1%})")
        return "\n".join(lines)

    def plot(self):
        """Table I: each simulated number against the thesis's (1 = equal), per case."""
        from uuvid.core.plots import new_figure

        fig, ax = new_figure(1, 1, figsize=(8, 4))
        for j, k in enumerate(TABLE1_FIELDS):
            ratio = [r[k] / r["thesis"][k] if r["thesis"][k] else np.nan for r in self["table1"]]
            ax.plot(np.arange(len(ratio)) + 0.1 * (j - 2), ratio, "o", label=k)
        ax.axhline(1.0, color="k", lw=0.8)
        ax.set_xticks(range(len(self["table1"])))
        ax.set_xticklabels([r["case"] for r in self["table1"]], rotation=30, ha="right",
                           fontsize=8)
        ax.set_ylabel("ours / thesis [–]")
        ax.set_title("Table I reproduced", fontsize=10)
        ax.legend(fontsize=7)
        return fig

    def _write_outputs(self, folder: Path) -> Path | None:
        return write_outputs(self, self.artifacts["responses"], folder) if self.artifacts else None


def reproduce(out_dir: str | Path | None = None, progress=None) -> McLeanReproduction:
    """Everything this paper prints that the models reproduce, as one JSON-able document (a
    :class:`McLeanReproduction`)."""
    rows, responses = table1(progress=progress)
    lm_rows = load_matching()
    result = {
        "paper": "McLean 1991, NPS thesis: dynamic performance of small diameter tunnel thrusters",
        "units": {"thrust": "lbf", "time": "s", "speed": "rpm"},
        "parameters": {
            "energy_correction_alpha_o_minus_alpha_i": auv2_rig_chain().blocks[0].energy_correction,
            "momentum_correction_beta_o_minus_beta_i": auv2_rig_chain().blocks[0].momentum_correction,
        },
        "table1": rows,
        "load_matching": lm_rows,
        "load_matching_conclusions": load_matching_conclusions(lm_rows),
        "pulsing": pulsing(),
    }
    result.update(identification())
    result = McLeanReproduction(result, {"responses": responses})
    if out_dir is not None:
        result.report(out_dir)
    return result


def identification() -> dict:
    """Issue-3 additions: the unprinted corrections identified from Table I's steady columns, and
    the model fitted to the thesis's experiments (Tables II/III) with a Coulomb offset."""
    from uuvid.papers import mclean1991_identification as ident

    corr = ident.identify_corrections()
    exp = ident.fit_experiments()
    return {
        "identified": {
            "delta_alpha": corr["energy_correction"].value,
            "delta_alpha_sigma": corr["energy_correction"].stderr,
            "delta_beta": corr["momentum_correction"].value,
            "delta_beta_sigma": corr["momentum_correction"].stderr,
            "digest_values": {"delta_alpha": 3.0, "delta_beta": 0.185},
            # each steady row predicted from the corrections fitted to the others
            "leave_one_out": ident.leave_one_out(),
        },
        "experiment_fit": {
            "mean_abs_rel_error": exp["mean_abs_rel_error"],
            "thesis_mean_abs_rel_error": exp["thesis_mean_abs_rel_error"],
            "parameters": exp["parameters"],
            "rows": exp["rows"],
        },
    }


def write_outputs(result: dict, responses: dict, out: Path) -> Path:
    """Step-response plots (one per Table I case), the tables as CSV/JSON and an index.html."""
    import pandas as pd

    from uuvid.core.atomic import atomic_path, atomic_write_json
    from uuvid.core.html import Report
    from uuvid.core.plots import new_figure, save_figure

    out.mkdir(parents=True, exist_ok=True)
    report = Report("McLean (1991) — tunnel thruster step responses, reproduced")
    report.add_paragraph(
        "Voltage step on the AUV II tunnel thruster (Pittman 9514, 2.5:1 gear, "
        "3-in Kaplan propeller) seen through the rig's load cell. Thesis values "
        "in brackets."
    )
    table_rows = []
    for row in result["table1"]:
        tr = {"case": row["case"]}
        for k in TABLE1_FIELDS:
            tr[k] = f"{row[k]:.3g} [{row['thesis'][k]:g}]"
        table_rows.append(tr)
    report.add_table(table_rows, caption="Table I — simulation results")
    for name, r in responses.items():
        fig, axes = new_figure(2, 1, sharex=True, figsize=(7, 5))
        axes[0].plot(r.t, U.to_lbf(r["thrust"]), label="true thrust")
        axes[0].plot(r.t, U.to_lbf(r["measured_thrust"]), label="measured (load cell)")
        axes[0].set_ylabel("thrust [lb]")
        axes[0].legend()
        axes[0].set_title(f"Table I case {name}")
        axes[1].plot(r.t, U.to_rpm(r["prop_speed"]), color="C2")
        axes[1].set_ylabel("propeller speed [rpm]")
        axes[1].set_xlabel("t [s]")
        path = save_figure(fig, out / f"step_{name.replace('=', '_').replace('.', 'p')}.png")
        report.add_figure(path, caption=f"{name}: true and measured thrust, propeller speed")
        with atomic_path(out / f"step_{name.replace('=', '_').replace('.', 'p')}.csv") as tmp:
            r.to_frame().to_csv(tmp, index=False)
    idn = result["identified"]
    report.add_heading("Identification")
    report.add_paragraph(
        "From Table I's steady columns: "
        f"α_o − α_i = {idn['delta_alpha']:.3f} ± {idn['delta_alpha_sigma']:.3f}, "
        f"β_o − β_i = {idn['delta_beta']:.4f} ± {idn['delta_beta_sigma']:.4f} (digest: 3.0 and 0.185)."
    )
    ef = result["experiment_fit"]
    report.add_paragraph(
        f"Fitted to the thesis's experiments (Tables II/III) with a Coulomb offset: mean absolute "
        f"relative error {ef['mean_abs_rel_error']:.1%} over the nine numbers, against "
        f"{ef['thesis_mean_abs_rel_error']:.1%} for the thesis's own simulation."
    )
    report.add_table(
        [
            {"parameter": k, "estimate": v["estimate"], "sigma": v["sigma"], "unit": v["unit"]}
            for k, v in ef["parameters"].items()
        ],
        caption="Experiment fit",
    )
    report.add_table(result["load_matching"], caption="App. A — load matching (continuous duty)")
    fig, axes = new_figure(1, 2, figsize=(11, 4.5))
    lm.plot_load_matching(lm.PITTMAN_9514, (2.5, 3.67, 5.0, 10.0), ax=axes[0])
    lm.plot_load_matching(lm.PITTMAN_14202, (2.5, 3.67, 5.0), ax=axes[1])
    report.add_figure(save_figure(fig, out / "load_matching.png"), caption="Load matching")
    puls = result["pulsing"]
    report.add_paragraph(puls["answer"])
    report.add_table(puls["rows"], caption="Voltage pulsing vs steady voltage")
    fig, ax = new_figure(1, 1, figsize=(7, 4))
    for kind in ("square", "sawtooth"):
        rr = [r for r in puls["rows"] if r["waveform"] == kind]
        ax.plot([r["frequency_hz"] for r in rr], [r["mean_thrust_lbf"] for r in rr], "o-", label=kind)
    ax.axhline(puls["steady_at_mean_voltage_lbf"], ls="--", color="k", label="steady, same mean V")
    ax.axhline(puls["steady_at_full_voltage_lbf"], ls=":", color="k", label="steady, full V")
    ax.set_xscale("log")
    ax.set_xlabel("pulsing frequency [Hz]")
    ax.set_ylabel("mean thrust [lb]")
    ax.set_title("Voltage pulsing: mean thrust against pulsing frequency")
    ax.legend()
    report.add_figure(save_figure(fig, out / "pulsing.png"), caption="Pulsing (open question, Ch. V)")
    pd.DataFrame(
        [
            {
                **{k: v for k, v in r.items() if k not in ("thesis", "rel_error")},
                **{f"thesis_{k}": v for k, v in r["thesis"].items()},
            }
            for r in result["table1"]
        ]
    ).pipe(lambda df: _csv(df, out / "table1.csv"))
    _csv(pd.DataFrame(result["load_matching"]), out / "load_matching.csv")
    atomic_write_json(out / "mclean1991.json", result)
    return report.write(out)


def _csv(df, path: Path) -> None:
    from uuvid.core.atomic import atomic_path

    with atomic_path(path) as tmp:
        df.to_csv(tmp, index=False)
