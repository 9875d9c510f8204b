"""The ``t200`` preset chain fitted to Blue Robotics' T200 sheets, and how far it is from them.

The preset (:func:`uuvid.thruster.presets.t200_chain`) must stay inside the SIMD batch kernel's
fast path (static prefix + one exact first-order block + static suffix), so it is
``ESC (per-direction dead-band edge and duty curvature) → FirstOrderMotor → K_T Ω|Ω|``.
At rest, per direction (forward: command above neutral)::

    s = clip((c − e)/(f − e), 0, 1)             e: dead-band edge, f: full command (1900/1100 µs)
    d = s (1 + β (s − 1))                       duty curvature β (the ESC's; β < 0 bends up early)
    Ω = Ω_16 (V/16 V)^γ · d                     speed at full command: power law in the supply
    T = K_T Ω|Ω|                                per-direction K_T

``Ω_16``, ``γ`` are shared by both directions (the sheets' full-command speeds differ by 2 %),
``β``, ``K_T`` per direction; these six are fitted jointly to the 12 V and 16 V sheets by
weighted least squares (:func:`uuvid.identify.fit.nonlinear_lsq`): thrust residuals over each
sheet's largest |thrust| (weight 1) and speed residuals over its largest speed (weight
``SPEED_WEIGHT``: speed only separates ``K_T`` from ``Ω``; the full-command rows, means of 5
repeats, weigh √5); censored rows (< 300 rpm zeroed by the logger) only penalise a predicted
speed above the detection limit.  The two supply voltages determine ``γ``; between them the power
law interpolates, outside it extrapolates (a motor
against a quadratic load turns at ``Ω ∝ √V`` when resistance dominates, ``∝ V`` when back-EMF
does, so 0.5 ≤ γ ≤ 1 is the physical range).  The dead band is none (``e`` = 1500 µs): fitted
freely, both edges go to the neutral (their bound) — the sheets' zero rows around 1500 µs are the
logger's 300-rpm cut, which the curved duty already respects.

:func:`sheet_errors` tabulates a steady map against a sheet (the acceptance numbers);
:func:`refit_t200_preset` (or ``python -m uuvid.identify.thruster.t200_preset [SHEETS_DIR]``) refits the
shipped constants :data:`uuvid.thruster.presets.T200_STEADY` from the sheet CSVs.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from uuvid.identify.fit import Fit, nonlinear_lsq
from uuvid.io.bench import BenchData

SPEED_WEIGHT = 0.3
#: The sheets' full-command rows are the mean of 5 repeats (READ ME sheet): weight √5.
FULL_COMMAND_US = (1100.0, 1900.0)
FULL_COMMAND_WEIGHT = 5.0**0.5
#: Commands at which :func:`sheet_errors` reports the error (forward; reverse mirrored about 1500).
CHECK_COMMANDS_US = (1550.0, 1580.0, 1600.0, 1650.0, 1700.0, 1800.0, 1900.0)
NAMES = ("curvature_fwd", "curvature_rev", "K_T_fwd", "K_T_rev", "full_speed_16V", "speed_exponent")
UNITS = ("1", "1", "N·s²/rad²", "N·s²/rad²", "rad/s", "1")
#: A few rows read off Blue Robotics' T200 sheets (Sept. 2019; ``Force (Kg f)`` to 4 decimals), per
#: supply voltage: (PWM µs, thrust kgf).  For checks and the demo without the sheet files.
SHEET_POINTS_KGF = {
    12.0: ((1100, -2.9037), (1200, -1.9459), (1300, -1.0206), (1400, -0.3175), (1420, -0.2041),
           (1448, -0.0726), (1552, 0.0953), (1580, 0.2540), (1600, 0.3946), (1700, 1.2791),
           (1800, 2.4630), (1900, 3.7142)),
    16.0: ((1100, -4.0695), (1200, -2.7079), (1300, -1.4379), (1400, -0.4808), (1420, -0.3221),
           (1448, -0.1270), (1552, 0.1542), (1580, 0.3992), (1600, 0.6033), (1700, 1.8234),
           (1800, 3.4201), (1900, 5.2450)),
}


def _steady(p: np.ndarray, command: np.ndarray, volts: float) -> tuple[np.ndarray, np.ndarray]:
    """(speed, thrust) of the preset chain with fit vector ``p`` — through the chain itself."""
    from uuvid.thruster.presets import T200Steady, t200_chain

    chain = t200_chain(volts, T200Steady(*map(float, p)), warn=False)  # dead band: none
    esc, motor = chain.blocks[0], chain.blocks[1]
    return motor.gain * esc.voltage(command), chain.steady_thrust(command, cache=False)


def fit_t200_preset(sheets: Sequence[BenchData], x0=None) -> Fit:
    """Fit the preset's six steady constants to T200 sheets (``read_t200`` of 12 V and 16 V),
    starting from ``x0`` (a :class:`~uuvid.thruster.presets.T200Steady`; default the shipped one)."""
    from uuvid.thruster.presets import T200_STEADY

    if len(sheets) < 2 or len({float(np.mean(s.supply_voltage_array())) for s in sheets}) < 2:
        raise ValueError("fit_t200_preset needs sheets at two supply voltages or more (the speed "
                         "exponent γ is fixed by the voltage scaling)")
    data = []
    for s in sheets:
        volts = float(np.mean(s.supply_voltage_array()))
        cen = s.censored if s.censored is not None else np.zeros(len(s.command), bool)
        data.append((s.command, s.thrust, s.speed, cen, volts, np.max(np.abs(s.thrust)),
                     np.max(np.abs(s.speed)), s.censor_speed or 0.0))

    def residual(p):
        out = []
        for c, f, w, cen, volts, fmax, wmax, wcen in data:
            om, t = _steady(p, c, volts)
            wt = np.where(np.isin(c, FULL_COMMAND_US), FULL_COMMAND_WEIGHT, 1.0)
            out.append(np.where(cen, 0.0, wt * (t - f) / fmax))
            over = np.maximum(np.abs(om) - wcen, 0.0)
            out.append(SPEED_WEIGHT * np.where(cen, over, om - w) / wmax)
        return np.concatenate(out)

    s0 = T200_STEADY if x0 is None else x0
    start = np.array([s0.curvature_fwd, s0.curvature_rev, s0.kt_fwd, s0.kt_rev, s0.full_speed,
                      s0.speed_exponent])
    lo = [-1.0, -1.0, 0.0, 0.0, 0.0, 0.0]
    hi = [1.0, 1.0, np.inf, np.inf, np.inf, 2.0]
    return nonlinear_lsq(residual, start, NAMES, model="t200-preset", units=UNITS, bounds=(lo, hi),
                         emit_warnings=False,
                         extra={"sheets": [s.source for s in sheets], "speed_weight": SPEED_WEIGHT})


def refit_t200_preset(sheets_dir: str | Path | None = None):
    """``(T200Steady, Fit)`` refitted from ``T200_12V.csv`` / ``T200_16V.csv`` in ``sheets_dir``
    (default: ``shared/data/t200-bluerobotics-2019`` beside the checkout)."""
    from uuvid.io.bench import default_t200_dir
    from uuvid.thruster.presets import T200Steady

    d = sheets_dir or default_t200_dir()
    if d is None:
        raise FileNotFoundError("the T200 sheets (t200-bluerobotics-2019/T200_12V.csv, "
                                "T200_16V.csv) were not found; pass their folder")
    fit = fit_t200_preset(read_sheets(d))
    return T200Steady(*(fit[n].value for n in NAMES)), fit


def read_sheets(sheets_dir: str | Path) -> list[BenchData]:
    """The 12 V and 16 V T200 sheets from ``sheets_dir`` (``T200_12V.csv``, ``T200_16V.csv``)."""
    from uuvid.io.bench import read_t200

    d = Path(sheets_dir)
    return [read_t200(d / f"T200_{v}V.csv") for v in (12, 16)]


def sheet_errors(thrust: Callable[[np.ndarray], np.ndarray], sheet: BenchData) -> dict:
    """Steady thrust ``thrust(command)`` against a sheet: max |error| (N and % of the sheet's max
    |thrust|) over all rows, and sheet / model / error at :data:`CHECK_COMMANDS_US` and their
    reverse mirrors (sheet linearly interpolated between its 4 µs rows)."""
    c, f = sheet.command, sheet.thrust
    err = np.asarray(thrust(c), float) - f
    fmax = float(np.max(np.abs(f)))
    points = []
    for cf in CHECK_COMMANDS_US:
        for cc in (cf, 3000.0 - cf):
            fs = float(np.interp(cc, c, f))
            fm = float(np.asarray(thrust(np.array([cc])), float)[0])
            points.append({"command_us": cc, "sheet_N": fs, "model_N": fm, "error_N": fm - fs})
    return {"source": sheet.source, "max_abs_error_N": float(np.max(np.abs(err))),
            "max_abs_error_pct": 100.0 * float(np.max(np.abs(err))) / fmax,
            "rmse_N": float(np.sqrt(np.mean(err**2))), "max_thrust_N": fmax, "points": points}


def preset_vs_sheet_points(steady=None) -> list[dict]:
    """The ``t200`` preset's steady thrust at :data:`SHEET_POINTS_KGF` (rows for a table): sheet,
    preset and error in N, error in % of that sheet's max |thrust|."""
    from uuvid.core import units as U
    from uuvid.thruster.presets import T200_STEADY, t200_chain

    rows = []
    for volts, pts in SHEET_POINTS_KGF.items():
        chain = t200_chain(volts, steady or T200_STEADY)
        c = np.array([p[0] for p in pts], float)
        f = np.array([U.kgf(p[1]) for p in pts])
        m = chain.steady_thrust(c)
        fmax = float(np.max(np.abs(f)))
        rows += [{"supply_V": volts, "pwm_us": float(ci), "sheet_N": round(float(fi), 3),
                  "preset_N": round(float(mi), 3), "error_N": round(float(mi - fi), 3),
                  "error_pct_of_max": round(100.0 * float(mi - fi) / fmax, 2)}
                 for ci, fi, mi in zip(c, f, m)]
    return rows


if __name__ == "__main__":  # pragma: no cover - a maintenance script
    import sys

    steady, fit = refit_t200_preset(sys.argv[1] if len(sys.argv) > 1 else None)
    print(fit.report())
    print(steady)
