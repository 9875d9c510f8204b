"""Bench data in: steady sweeps and time series of a thruster on a test stand, in SI units.

A bench file is a table (CSV, or Parquet when ``pyarrow`` is installed) with one row per sample:
a command column and any of thrust, propeller speed, current, supply voltage, time and the water
speed through the propeller (``flow_speed``, m/s: the carriage or tunnel speed of a bench run in a
flow; read when the file has a column of that name, issue 21).
:func:`read_bench` picks the columns by name, converts units at the edge (kgf, lbf, ozf,
gram-force, rpm, rev/s → N, rad/s) and validates every cell; :func:`read_t200` reads Blue
Robotics' T200 performance-sheet layout directly.

Every problem raises :class:`BenchDataError` naming the file, the column and the row; a reading
no bench can produce (a thrust above :data:`MAX_BENCH_THRUST`, a negative pulse width, …) is one.  Rows are
counted two ways and the message gives both: the *data row* (1-based, header excluded) and, for
CSV, the *CSV line* (1-based line of the file, header = line 1).

Sign conventions: thrust and speed are signed (forward = command above neutral).  Many RPM sensors
report an unsigned speed; then the sign is taken from the command direction.

Censoring: some loggers set readings under a detection limit to zero (the T200 sheets zero every
reading under 300 rpm).  Such rows are not measurements of a dead zone — the true thrust and speed
are merely *small* — so :class:`BenchData` marks them in ``censored`` and the identification
routines treat them as unknown (or as upper bounds), never as zeros.
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from uuvid.core import units as U

COMMAND_UNITS = ("pwm_us", "duty", "volts")
#: what a missing channel means in the input: the column (CLI flag / read_bench argument)
CHANNEL_COLUMNS = {
    "thrust": "a thrust column (--thrust-col / thrust_col=)",
    "speed": "a propeller speed column (--speed-col / speed_col=)",
    "current": "a supply current column (--current-col / current_col=)",
    "supply_voltage": "the supply voltage (--voltage-col or --supply-voltage / voltage_col=, "
                      "supply_voltage=)",
    "time": "a time column (--time-col / time_col=)",
    "flow_speed": "a water speed column (--flow-speed-col / flow_speed_col=, default 'flow_speed')",
}
#: the column read as the water speed through the propeller when the file has it (also with its
#: unit in a trailing bracket: ``flow_speed [cm/s]``)
FLOW_SPEED_COLUMN = "flow_speed"
#: the headers read as the water speed when no column is named (compared with a trailing unit
#: bracket stripped, case folded, spaces and hyphens as ``_``: ``flow [kn]``, ``Flow Speed``)
FLOW_SPEED_NAMES = ("flow_speed", "flow")
#: readings of the wrong sign below this fraction of the file's largest |reading| are noise (a
#: dead band's, or a thrust about zero at a small command), never a reversal
SIGN_NOISE = 0.05
#: a reading of the wrong sign must be this many times the readings' row-to-row scatter to be a
#: reversal (:func:`reversal_tolerance`)
REVERSAL_SIGMAS = 6.0
#: other spellings of a command unit (``us`` as the time unit accepts it)
COMMAND_UNIT_ALIASES = {"us": "pwm_us", "µs": "pwm_us", "pwm": "pwm_us", "v": "volts",
                        "volt": "volts"}
#: thrust unit → N per unit
THRUST_UNITS = {"N": 1.0, "kgf": U.KGF, "lbf": U.LBF, "ozf": U.OZF, "g": U.G0 / 1000.0, "mN": 1e-3,
                "kN": 1e3}
#: speed unit → rad/s per unit
SPEED_UNITS = {"rad/s": 1.0, "rpm": U.RPM, "rev/s": U.REV_S}
#: a thrust or speed unit written in a column's header → the unit of THRUST_UNITS / SPEED_UNITS.
#: Keys are the header's unit token lower-cased with spaces, dots, hyphens and ``·`` removed;
#: ``N``, ``mN`` and ``kN`` are matched case-sensitively (``MN`` is not ``mN``).  Only clear
#: unit tokens: a header whose token is not here says nothing about the unit.
HEADER_THRUST_UNITS = {"kgf": "kgf", "kgforce": "kgf", "kilogramforce": "kgf", "kg": "kgf",
                       "kp": "kgf", "lbf": "lbf", "lb": "lbf", "lbs": "lbf", "poundforce": "lbf",
                       "ozf": "ozf", "oz": "ozf", "ounceforce": "ozf", "ounces": "ozf",
                       "ounce": "ozf", "gf": "g", "g": "g", "gramforce": "g", "grams": "g",
                       "gram": "g", "newton": "N", "newtons": "N"}
HEADER_THRUST_UNITS_CASED = {"N": "N", "mN": "mN", "kN": "kN"}
HEADER_SPEED_UNITS = {"rpm": "rpm", "rev/min": "rpm", "r/min": "rpm", "1/min": "rpm",
                      "min^-1": "rpm", "min-1": "rpm", "rad/s": "rad/s", "rad/sec": "rad/s",
                      "rads^-1": "rad/s", "rads-1": "rad/s", "rads⁻¹": "rad/s", "rad_s": "rad/s",
                      "radps": "rad/s", "rad_per_s": "rad/s", "rev/s": "rev/s", "rev/sec": "rev/s",
                      "revs/s": "rev/s", "r/s": "rev/s", "rps": "rev/s", "rev_s": "rev/s",
                      "rev_per_s": "rev/s", "revs^-1": "rev/s", "revs-1": "rev/s", "hz": "rev/s"}
#: supply current unit → A per unit; supply voltage unit → V per unit
CURRENT_UNITS = {"A": 1.0, "mA": 1e-3}
VOLTAGE_UNITS = {"V": 1.0, "mV": 1e-3}
#: a current or voltage unit written in a column's header (keyed as :data:`HEADER_THRUST_UNITS`;
#: ``MA`` is read as mA: no bench draws megaamperes)
HEADER_CURRENT_UNITS = {"a": "A", "amp": "A", "amps": "A", "ampere": "A", "amperes": "A",
                        "ma": "mA", "milliamp": "mA", "milliamps": "mA", "milliampere": "mA",
                        "milliamperes": "mA"}
HEADER_VOLTAGE_UNITS = {"v": "V", "volt": "V", "volts": "V", "mv": "mV", "millivolt": "mV",
                        "millivolts": "mV"}
#: water speed unit → m/s per unit
FLOW_UNITS = {"m/s": 1.0, "cm/s": 0.01, "mm/s": 1e-3, "km/h": U.KMH, "kn": U.KNOT, "ft/s": U.FT}
#: a water speed unit written in a column's header (keyed as :data:`HEADER_THRUST_UNITS`) → the
#: unit of :data:`FLOW_UNITS`; ``ms`` (milliseconds?) and ``cms`` say nothing
HEADER_FLOW_UNITS = {
    **{u[:-2] + s: u for u in ("m/s", "cm/s", "mm/s")  # m/s, m/sec, m_s, m s^-1, m_per_s, …
       for s in ("/s", "/sec", "_s", "s^-1", "s-1", "s⁻¹", "_per_s")},
    "mps": "m/s", "km/h": "km/h", "km/hr": "km/h", "kmh": "km/h", "km_h": "km/h", "kph": "km/h",
    "kmh^-1": "km/h", "kmh-1": "km/h", "km_per_h": "km/h", "kn": "kn", "kt": "kn", "kts": "kn",
    "knot": "kn", "knots": "kn", "ft/s": "ft/s", "ft/sec": "ft/s", "ft_s": "ft/s", "fps": "ft/s",
    "fts^-1": "ft/s", "fts-1": "ft/s", "ft_per_s": "ft/s"}
#: The largest pulse width [µs] a command can be: one frame of a 50 Hz servo signal (20 ms).  A
#: negative command or one above this in a ``pwm_us`` file is no pulse width (row named).
MAX_PULSE_US = 20_000.0
#: Readings no bench can produce, refused per row (file, column, row) before any fit: beyond them
#: a fit overflows (1e300² = inf) and writes a model of nonsense.  In SI: thrust [N] (10 MN, above
#: the largest ship propeller's ≈ 4 MN bollard thrust), propeller speed [rad/s] (≈ 955 000 rpm, ten
#: times a dental turbine), water speed [m/s] (five times the fastest cavitation tunnel), and a
#: command in volts (:data:`uuvid.core.checks.MAX_PLAUSIBLE_VOLTAGE`: no thruster runs on 1 kV).
MAX_BENCH_THRUST = 1e7
MAX_BENCH_SPEED = 1e5
MAX_BENCH_FLOW = 100.0
#: the neutral command of each command unit
DEFAULT_NEUTRAL = {"pwm_us": 1500.0, "duty": 0.0, "volts": 0.0}
#: T200 performance sheets: readings below this speed were set to zero (SOURCE.md)
T200_CENSOR_RPM = 300.0
#: the unit option → (column, its unit by its header, the SI unit it is converted to) of a T200 sheet
T200_UNIT_COLUMNS = {"thrust_unit": ("Force (Kg f)", "kgf", "N"), "speed_unit": ("RPM", "rpm", "rad/s")}


class BenchDataError(ValueError):
    """Bench data are unreadable or invalid; the message names file, column and row."""


def require_samples(n: int, p: int, what: str) -> None:
    """Raise :class:`BenchDataError` when ``n`` samples cannot determine ``p`` parameters."""
    if n < p:
        raise BenchDataError(f"{what}: {n} usable sample(s) for {p} parameter(s); need at least "
                             f"{p} (more for a standard error)")


def _check_unit(kind: str, unit: str, table) -> str:
    if unit in table:
        return unit
    for k in table:
        if unit is not None and isinstance(unit, str) and unit.strip().lower() == k.lower():
            return k
    raise BenchDataError(f"unknown {kind} {unit!r}; expected one of {', '.join(table)}")


# ------------------------------------------------------------------------------------------------
# The data record
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class BenchData:
    """Bench samples in SI units.

    Attributes
    ----------
    command
        Command per sample, in ``command_unit`` (``pwm_us`` µs, ``duty`` −1…1, ``volts`` V).
    thrust
        Thrust [N], signed (forward positive), or ``None``.
    speed
        Propeller speed [rad/s], signed, or ``None``.
    current
        Supply current [A], or ``None``.
    supply_voltage
        Supply voltage [V]: a scalar, an array per sample, or ``None``.
    time
        Sample times [s] (strictly increasing) for time series, ``None`` for steady sheets.
    source
        The file name (for messages and reports).
    censored
        Boolean mask of rows that are not measurements (readings below a detection limit that the
        logger zeroed).  Identification treats them as unknown.
    neutral
        The neutral command (default 1500 µs for PWM, 0 otherwise).
    censor_speed
        The detection limit [rad/s] below which readings were zeroed, when known.
    flow_speed
        Water speed through the propeller [m/s] along its axis (forward positive: the water meets
        a forward-turning propeller from ahead, as the advance speed ``u_a`` of
        :mod:`uuvid.thruster.inflow`), or ``None`` for a bench in still water.
    flow_speed_column
        The file's column the water speed was read from (``flow_speed``, ``flow [kn]``, …) for
        messages; ``None`` when unknown (a :class:`BenchData` built in Python: ``flow_speed``).
    notes
        Sentences on how the file was read that the user should see (the unit of a column taken
        from its header when no unit was given).
    warnings
        Sentences on what the reader read past that the user must see (none from the reader
        today; a file pasted twice is refused: :func:`pasted_block`).
    """

    command: np.ndarray
    command_unit: str = "pwm_us"
    thrust: np.ndarray | None = None
    speed: np.ndarray | None = None
    current: np.ndarray | None = None
    supply_voltage: float | np.ndarray | None = None
    time: np.ndarray | None = None
    source: str = ""
    censored: np.ndarray | None = None
    neutral: float | None = None
    censor_speed: float | None = None
    flow_speed: np.ndarray | None = None
    flow_speed_column: str | None = None
    #: how the file was read, said to the user (a unit taken from a column's header, …)
    notes: tuple[str, ...] = ()
    #: what the reader found wrong but could read past (exact duplicate rows dropped, …)
    warnings: tuple[str, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "notes", tuple(self.notes))
        object.__setattr__(self, "warnings", tuple(self.warnings))
        if self.command_unit not in COMMAND_UNITS:
            raise BenchDataError(f"{self._where()}unknown command_unit {self.command_unit!r}; "
                                 f"expected one of {', '.join(COMMAND_UNITS)}")
        cmd = np.asarray(self.command, dtype=float)
        if cmd.ndim != 1 or cmd.size == 0:
            raise BenchDataError(f"{self._where()}command must be a non-empty 1-D array")
        object.__setattr__(self, "command", cmd)
        n = cmd.size
        for name in ("thrust", "speed", "current", "time", "flow_speed"):
            v = getattr(self, name)
            if v is not None:
                a = np.asarray(v, dtype=float)
                if a.shape != (n,):
                    raise BenchDataError(f"{self._where()}{name} has shape {a.shape}; command has "
                                         f"{n} samples")
                object.__setattr__(self, name, a)
        sv = self.supply_voltage
        if sv is not None:
            if np.ndim(sv) == 0:
                sv = float(sv)
                if not (math.isfinite(sv) and sv > 0):
                    raise BenchDataError(f"{self._where()}supply_voltage must be a positive "
                                         f"number, got {sv!r}")
            else:
                sv = np.asarray(sv, dtype=float)
                if sv.shape != (n,):
                    raise BenchDataError(f"{self._where()}supply_voltage has shape {sv.shape}; "
                                         f"command has {n} samples")
            object.__setattr__(self, "supply_voltage", sv)
        cens = np.zeros(n, dtype=bool) if self.censored is None else np.asarray(self.censored,
                                                                                  dtype=bool)
        if cens.shape != (n,):
            raise BenchDataError(f"{self._where()}censored mask has shape {cens.shape}; command "
                                 f"has {n} samples")
        object.__setattr__(self, "censored", cens)
        for name in ("command", "thrust", "speed", "current", "time", "flow_speed",
                     "supply_voltage"):
            a = getattr(self, name)
            if a is None or np.ndim(a) == 0:
                continue
            bad = np.flatnonzero(~np.isfinite(a))
            if bad.size:  # the fits' own errors about it were cryptic ("initial guess outside bounds")
                raise BenchDataError(f"{self._where()}{name}[{bad[0]}] is {float(a[bad[0]])!r} "
                                     f"({bad.size} non-finite value(s)): every sample must be a "
                                     "finite number — leave the row out (or mark a reading below "
                                     "the detection limit with `censored`)")
        if self.neutral is None:
            object.__setattr__(self, "neutral", DEFAULT_NEUTRAL[self.command_unit])
        else:
            object.__setattr__(self, "neutral", float(self.neutral))

    def _where(self) -> str:
        return f"{self.source}: " if self.source else ""

    @property
    def flow_column(self) -> str:
        """The name of the water speed's column in messages (``flow_speed`` when unknown)."""
        return self.flow_speed_column or FLOW_SPEED_COLUMN

    # ---------------------------------------------------------------- views
    def __len__(self) -> int:
        return int(self.command.size)

    @property
    def n_samples(self) -> int:
        return len(self)

    @property
    def measured(self) -> np.ndarray:
        """Rows that are real measurements (``~censored``)."""
        return ~self.censored

    @property
    def direction(self) -> np.ndarray:
        """+1 forward (command above neutral), −1 reverse, 0 at neutral."""
        return np.sign(self.command - self.neutral)

    def supply_voltage_array(self) -> np.ndarray:
        """The supply voltage per sample (raises if unknown)."""
        if self.supply_voltage is None:
            raise BenchDataError(f"{self._where()}no supply voltage: give voltage_col or "
                                 "supply_voltage")
        return np.broadcast_to(np.asarray(self.supply_voltage, dtype=float), (len(self),)).copy()

    def nominal_voltage(self) -> float:
        """The median supply voltage (a sheet's nominal voltage)."""
        return float(np.median(self.supply_voltage_array()))

    def subset(self, mask) -> BenchData:
        """The rows selected by a boolean mask or index array."""
        idx = np.asarray(mask)
        sv = self.supply_voltage
        if sv is not None and np.ndim(sv) == 1:
            sv = sv[idx]

        def take(a):
            return None if a is None else a[idx]

        return replace(self, command=self.command[idx], thrust=take(self.thrust),
                       speed=take(self.speed), current=take(self.current), supply_voltage=sv,
                       time=take(self.time), censored=self.censored[idx],
                       flow_speed=take(self.flow_speed))

    def forward(self) -> BenchData:
        return self.subset(self.command > self.neutral)

    def reverse(self) -> BenchData:
        return self.subset(self.command < self.neutral)

    def require(self, *channels: str, what: str = "this fit") -> None:
        """Raise a clear error if a channel (thrust, speed, current, supply_voltage, time) is absent."""
        missing = [c for c in channels if getattr(self, c) is None]
        if missing:
            cols = [CHANNEL_COLUMNS.get(c, c) for c in missing]
            raise BenchDataError(f"{self._where()}{what} needs {' and '.join(cols)}, which this "
                                 f"bench data set does not have")

    def summary(self) -> dict:
        out = {"source": self.source, "samples": len(self), "censored": int(self.censored.sum()),
               "command_unit": self.command_unit, "neutral": self.neutral,
               "command_range": [float(self.command.min()), float(self.command.max())]}
        for name in ("thrust", "speed", "current", "flow_speed"):
            a = getattr(self, name)
            if a is not None:
                out[f"{name}_range"] = [float(a.min()), float(a.max())]
        if self.supply_voltage is not None:
            out["supply_voltage"] = self.nominal_voltage()
        return out


# ------------------------------------------------------------------------------------------------
# Reading tables
# ------------------------------------------------------------------------------------------------
@dataclass
class _Table:
    name: str
    columns: list[str]
    cells: dict[str, list]
    lines: list[int] | None = None  # CSV line of every data row
    kind: str = "CSV"
    dtypes: dict = field(default_factory=dict)  # Parquet column types, when known
    units: dict = field(default_factory=dict)  # column → its unit in a unit row under the header
    unit_line: int | None = None  # the CSV line of that unit row

    @property
    def n_rows(self) -> int:
        return len(next(iter(self.cells.values()))) if self.cells else 0

    def where(self, col: str, i: int) -> str:
        loc = f"data row {i + 1}"
        if self.lines is not None:
            loc += f" (CSV line {self.lines[i]})"
        return f"{self.name}: column {col!r}, {loc}"


def _norm(name: str) -> str:
    s = name.strip().casefold().replace("µ", "u").replace("μ", "u")
    return re.sub(r"\s+", " ", s)


def _read_csv(path: Path) -> _Table:
    try:
        fh = open(path, newline="", encoding="utf-8-sig")
    except OSError as e:
        raise BenchDataError(f"{path.name}: cannot open bench file: {e.strerror or e}") from e
    with fh:
        try:
            reader = csv.reader(fh)
            header = None
            rows, lines = [], []
            for row in reader:
                if header is None:
                    if not row or all(not c.strip() for c in row):
                        continue
                    header = [c.strip() for c in row]
                    continue
                if not row or all(not c.strip() for c in row):
                    continue  # blank lines are not samples
                rows.append(row)
                lines.append(reader.line_num)
        except (csv.Error, UnicodeDecodeError) as e:
            raise BenchDataError(f"{path.name}: not a readable CSV file: {e}") from e
    if header is None:
        raise BenchDataError(f"{path.name}: the file is empty (no header line)")
    if len(header) == 1 and any(sep in header[0] for sep in ";\t"):
        sep = "';'" if ";" in header[0] else "a tab"
        raise BenchDataError(f"{path.name}: the header {header[0]!r} is one column separated by "
                             f"{sep}: uuvid reads comma-separated files; re-save the file with ',' "
                             "between cells and '.' as the decimal point")
    return _table_from_rows(path.name, header, rows, lines, BenchDataError)


def _table_from_rows(name: str, header: list[str], rows: list[list[str]], lines: list[int],
                     error: type[ValueError], hint: str = "") -> _Table:
    """Check a parsed CSV (unique column names, one cell per column on every line) → table."""
    dup = sorted({c for c in header if header.count(c) > 1})
    if dup:
        raise error(f"{name}: column name(s) {', '.join(map(repr, dup))} appear more than once in "
                    "the header")
    for r, ln in zip(rows, lines):
        if len(r) != len(header):
            raise error(f"{name}: CSV line {ln} has {len(r)} cells but the header has "
                        f"{len(header)} columns{hint}")
    cells = {c: [r[j] for r in rows] for j, c in enumerate(header)}
    return _Table(name, header, cells, lines, "CSV")


def _read_parquet(path: Path) -> _Table:
    try:
        import pyarrow.parquet as pq
    except ImportError as e:
        raise ImportError(f"{path.name}: reading Parquet bench files needs pyarrow, which is not "
                          "installed: pip install 'uuvid[logs]' (or save the data as CSV)") from e
    try:
        tbl = pq.read_table(path)
    except Exception as e:  # pyarrow raises its own error types
        raise BenchDataError(f"{path.name}: not a readable Parquet file: {e}") from e
    cols = list(tbl.column_names)
    cells = {c: tbl.column(c).to_pylist() for c in cols}
    return _Table(path.name, cols, cells, None, "Parquet")


def _read_table(path) -> _Table:
    p = Path(path)
    if not p.exists():
        raise BenchDataError(f"{p}: no such bench file")
    if p.suffix.lower() in (".parquet", ".pq"):
        return _read_parquet(p)
    return _read_csv(p)


def _strip_unit(name: str) -> str:
    """A header without its unit in a trailing bracket (``t [s]`` → ``t``, ``flow_speed []`` →
    ``flow_speed``)."""
    return _ANY_BRACKET.sub("", name.strip()).strip()


def _find_column(t: _Table, name: str, role: str, taken: Sequence[str] = ()) -> str:
    """The column named ``name``: exactly, else by its name with a bracketed unit stripped
    (``t [s]`` for ``t``), else ignoring case, spacing and µ/u when that is unambiguous: one
    candidate, ``name`` longer than one letter (``t`` time and ``T`` thrust are different
    symbols) and not a column given exactly for another channel (``taken``)."""
    if name in t.cells:
        return name
    matches = [c for c in t.columns if _strip_unit(c) == name.strip()]
    if len(matches) == 1:
        return matches[0]
    if len(name.strip()) > 1:
        for key in (_norm, lambda c: _norm(_strip_unit(c))):
            matches = [c for c in t.columns if key(c) == _norm(name) and c not in taken]
            if len(matches) == 1:
                return matches[0]
            if matches:
                raise BenchDataError(f"{t.name}: no column {name!r} for the {role}; "
                                     f"{', '.join(map(repr, matches))} match it ignoring case: "
                                     "name one exactly")
    hint = ("; this looks like a Blue Robotics T200 sheet: read it with --format t200"
            if _looks_like_t200(t) else "")
    raise BenchDataError(f"{t.name}: no column {name!r} for the {role}; available columns: "
                         f"{', '.join(repr(c) for c in t.columns)}{hint}")


_T200_PWM = ("PWM (us)", "PWM (µs)", "PWM (μs)")


def _looks_like_t200(t: _Table) -> bool:
    """The Blue Robotics sheet's header: PWM (us), RPM and Force (Kg f)."""
    have = {_norm(c) for c in t.columns}
    return (any(_norm(c) in have for c in _T200_PWM)
            and {_norm("RPM"), _norm("Force (Kg f)")} <= have)


_UNIT_IN_BRACKETS = re.compile(r"[\[(]([^\[\]()]+)[\])]\s*$")
_ANY_BRACKET = re.compile(r"\s*[\[(][^\[\]()]*[\])]\s*$")


def _unit_key(token: str) -> str:
    t = re.sub(r"[\s·*.]+", "", token.strip().lower())
    return re.sub(r"-(?!\d)", "", t)  # kg-f, pound-force; not min-1


def _lookup_unit(token: str, role: str) -> str | None:
    if role == "thrust":
        cased = re.sub(r"\s+", "", token.strip())
        if cased in HEADER_THRUST_UNITS_CASED:
            return HEADER_THRUST_UNITS_CASED[cased]
        return HEADER_THRUST_UNITS.get(_unit_key(token))
    if role == "flow speed":
        return HEADER_FLOW_UNITS.get(_unit_key(token))
    if role == "current":
        return HEADER_CURRENT_UNITS.get(_unit_key(token))
    if role == "supply voltage":
        return HEADER_VOLTAGE_UNITS.get(_unit_key(token))
    return HEADER_SPEED_UNITS.get(_unit_key(token))


def header_unit(column: str, role: str) -> str | None:
    """The unit written in a column's header (``role`` ``thrust``, ``speed`` or ``flow speed``, the
    water speed through the propeller), or ``None``.

    Read from a trailing bracket (``Thrust [kgf]``, ``Force (Kg f)``, ``RPM [rpm]``), else from a
    suffix after ``_`` or a space (``thrust_lbf``, ``speed rpm``, ``omega_rad_s``), else from a
    header that is the unit itself (``RPM``).  Conservative: only the clear unit tokens of
    :data:`HEADER_THRUST_UNITS` / :data:`HEADER_SPEED_UNITS` / :data:`HEADER_FLOW_UNITS` (``flow [kn]``,
    ``flow_speed (cm/s)``, ``flow_m_s``); a one-letter suffix (``thrust_g``)
    and a header that is only a thrust unit (``N``) say nothing.  On a shaft-speed column ``Hz``
    (``speed_hz``) is revolutions per second, as ``rps``, ``rev/s`` and ``r/s`` are.
    """
    name = column.strip()
    m = _UNIT_IN_BRACKETS.search(name)
    if m:
        return _lookup_unit(m.group(1), role)
    parts = [p for p in re.split(r"[_\s]+", name) if p]
    for k in (3, 2, 1):
        if len(parts) > k:
            tail = "_".join(parts[-k:])
            if k == 1 and len(tail) == 1 and tail != "N":
                continue
            u = _lookup_unit(tail, role)
            if u is not None:
                return u
    if role == "speed" and len(parts) == 1:
        return _lookup_unit(name, role)
    return None


#: the option that gives each channel's unit (for messages)
_UNIT_OPTIONS = {"thrust": "--thrust-unit / thrust_unit=", "speed": "--speed-unit / speed_unit=",
                 "flow speed": "--flow-speed-unit / flow_speed_unit="}
#: each channel's units (a unit of the header, converted to the first); a bracketed unit in the
#: header of a current or voltage column that is none of these is an error (read past, a
#: ``Current [kgf]`` would be read in A whatever it is)
_ROLE_UNITS = {"thrust": THRUST_UNITS, "speed": SPEED_UNITS, "flow speed": FLOW_UNITS,
               "current": CURRENT_UNITS, "supply voltage": VOLTAGE_UNITS}


#: time units a unit row may give a time column (read in s: there is no time unit option)
_TIME_UNITS = ("s", "sec", "secs", "second", "seconds")


def _is_number(v) -> bool:
    try:
        float(str(v).strip())
    except ValueError:
        return False
    return True


def _known_unit(token: str) -> bool:
    """``token`` is a unit some column of a bench file can carry (a command's, a reading's, a time's)."""
    tok = token.strip()
    return (tok.lower() in COMMAND_UNIT_ALIASES or tok.lower() in COMMAND_UNITS
            or tok.lower() in ("ms", *_TIME_UNITS)
            or any(_lookup_unit(tok, r) is not None for r in _ROLE_UNITS))


def _take_unit_row(t: _Table, notes: list[str]) -> None:
    """A first data row of a CSV with no number in it and a unit this reader knows (``us,rpm,A,V,kgf``
    under the header, as loggers and spreadsheets write) is the columns' units, not data: it is
    taken out of the rows and into :attr:`_Table.units` (read as a unit in the header would be,
    :func:`_resolve_unit`), and said in ``notes``."""
    if t.kind != "CSV" or t.n_rows == 0 or t.lines is None:
        return
    row = {c: str(t.cells[c][0]).strip() for c in t.columns}
    given = {c: v for c, v in row.items() if v}
    if not given or any(_is_number(v) for v in given.values()):
        return
    if not any(_known_unit(v) for v in given.values()):
        return
    t.units = given
    t.unit_line = t.lines[0]
    for c in t.columns:
        del t.cells[c][0]
    t.lines = t.lines[1:]
    notes.append(f"{t.name}: CSV line {t.unit_line} is a unit row "
                 f"({', '.join(given.values())}): read as the columns' units, not as data")
    if t.n_rows == 0:
        raise BenchDataError(f"{t.name}: no data rows under the header and its unit row (CSV line "
                             f"{t.unit_line})")


def _unit_row_error(t: _Table, col: str, token: str, role: str, units) -> BenchDataError:
    return BenchDataError(
        f"{t.name}: CSV line {t.unit_line} looks like a unit row ({', '.join(t.units.values())}), "
        f"but {token!r} under column {col!r} is no {role} unit known here ({', '.join(units)}): "
        f"the {role} cannot be read in it. Fix: write the column's unit in the header as "
        f"'{_strip_unit(col)} [unit]' with one of those units (converted when read) and delete "
        f"line {t.unit_line}, or convert the column")


_BRACKETS = re.compile(r"[\[(]([^\[\]()]+)[\])]")


def _bracketed_unit(col: str, role: str) -> str | None:
    """A ``role`` unit in any bracket of a current or voltage header (``Current [A] (ESC)``,
    ``Voltage (VDC)``, ``Current (A DC)``): a word after the unit is no unit of its own."""
    for tok in _BRACKETS.findall(col):
        for cand in (tok, re.sub(r"\s*[ad]c$", "", tok.strip(), flags=re.IGNORECASE)):
            if cand and (u := _lookup_unit(cand, role)) is not None:
                return u
    return None


def _foreign_unit(col: str, role: str):
    """The first bracket of a current or voltage header holding another channel's unit
    (``Current [kgf]``, ``Voltage [rpm]``), as a match object; words (``(battery)``) are none."""
    for m in _BRACKETS.finditer(col):
        if any(_lookup_unit(m.group(1), other) is not None for other in _ROLE_UNITS if other != role):
            return m
    return None


def _resolve_unit(t: _Table, col: str, role: str, given: str | None, default: str,
                  notes: list[str]) -> str:
    """The unit of a column: the one given, checked against its header's; else the header's
    (said in ``notes``); else ``default``.  A water speed column whose header brackets a unit
    this reader does not know (``flow [furlong/h]``) is an error naming it, unless a unit is
    given: read as m/s it would be scaled silently.  A unit in a unit row under the header
    (:func:`_take_unit_row`) counts as the header's; one not of this channel is an error."""
    found = header_unit(col, role)
    opt = _UNIT_OPTIONS.get(role)
    token = _UNIT_IN_BRACKETS.search(col.strip())
    if opt is None:  # current, voltage: a unit in any bracket; only another channel's refused
        found = found or _bracketed_unit(col, role)
        token = None if found is not None else _foreign_unit(col, role)
    else:  # a unit in an earlier bracket: thrust [kgf] (load cell)
        found = found or _bracketed_unit(col, role)
    if opt is not None and found is None and given is None and col not in t.units:
        other = _foreign_unit(col, role)  # Thrust [mA]: another channel's unit, not this one's
        if other is not None:
            flag = opt.split(" / ")[0]
            raise BenchDataError(
                f"{t.name}: column {col!r}: {other.group(1).strip()!r} in its header is no {role} "
                f"unit ({', '.join(_ROLE_UNITS[role])} are read): the {role} would be read in "
                f"{default} whatever it is. Fix: name the right column, or give {flag} if the "
                "header is wrong")
    src = "its header"
    if col in t.units:
        row_found = _lookup_unit(t.units[col], role)
        if row_found is None:
            raise _unit_row_error(t, col, t.units[col], role, _ROLE_UNITS[role])
        if found is not None and found != row_found:
            raise BenchDataError(
                f"{t.name}: column {col!r} is in {found} by its header but in {t.units[col]} by "
                f"the unit row (CSV line {t.unit_line}): expected one unit. Fix: correct the "
                "header or the unit row")
        found, token, src = row_found, None, f"the unit row (CSV line {t.unit_line})"
    if role == "flow speed" and found is None and given is None and token:
        raise BenchDataError(
            f"{t.name}: column {col!r}: {token.group(1).strip()!r} in its header is no water speed "
            f"unit known here ({', '.join(FLOW_UNITS)}): the {role} would be read in "
            f"{default} whatever it is. Fix: give the column's unit ({opt.split(' / ')[0]} "
            f"{'|'.join(FLOW_UNITS)}) or write one of those in its header")
    if opt is None and found is None and token:  # current, voltage: no unit option
        units = _ROLE_UNITS[role]
        raise BenchDataError(
            f"{t.name}: column {col!r}: {token.group(1).strip()!r} in its header is no {role} "
            f"unit ({', '.join(units)} are read): the {role} would be read in {default} "
            f"whatever it is. Fix: name the right column, or write the column's unit in its "
            f"header as one of {', '.join(units)} (e.g. '{_strip_unit(col)} [{list(units)[-1]}]')")
    if found is None or found == given:
        return default if given is None else given
    if given is None:
        if found != default:
            how = f"no {opt} given" if opt else f"there is no {role} unit option"
            notes.append(f"{t.name}: column {col!r}: the {role} is read in {found}, the unit in "
                         f"{src}, and converted to {default} ({how})")
        return found
    flag = opt.split(" / ")[0]
    raise BenchDataError(
        f"{t.name}: column {col!r} is in {found} by {src}, but the {role} unit given is "
        f"{given} ({opt}): they disagree, and reading it in {given} would scale every {role} by "
        f"the ratio of the two. Fix: leave out {flag} (the header's {found} is read and converted) "
        f"or give {flag} {found}; if the header is wrong, correct it in the file")


def _numeric(t: _Table, col: str, role: str, unit: str = "") -> np.ndarray:
    vals = t.cells[col]
    out = np.empty(len(vals))
    what = f"a number ({role}{', ' + unit if unit else ''})"
    for i, v in enumerate(vals):
        if v is None or (isinstance(v, str) and not v.strip()):
            raise BenchDataError(f"{t.where(col, i)}: empty cell; expected {what}")
        if isinstance(v, str):
            try:
                x = float(v.strip())
            except ValueError:
                raise BenchDataError(f"{t.where(col, i)}: {v.strip()!r} is not numeric; expected "
                                     f"{what}") from None
        else:
            try:
                x = float(v)
            except (TypeError, ValueError):
                raise BenchDataError(f"{t.where(col, i)}: {v!r} is not numeric; expected "
                                     f"{what}") from None
        if math.isnan(x):
            raise BenchDataError(f"{t.where(col, i)}: NaN; expected {what}")
        if not math.isfinite(x):
            raise BenchDataError(f"{t.where(col, i)}: {x} is not finite; expected {what}")
        out[i] = x
    return out


def read_bench(path, *, command_col: str, thrust_col: str | None = None,
               speed_col: str | None = None, current_col: str | None = None,
               voltage_col: str | None = None, time_col: str | None = None,
               command_unit: str = "pwm_us", thrust_unit: str | None = None,
               speed_unit: str | None = None,
               supply_voltage: float | None = None, neutral: float | None = None,
               speed_sign: str = "auto", censor_speed_below: float | None = None,
               flow_speed_col: str | None = "auto",
               flow_speed_unit: str | None = None) -> BenchData:
    """Read a bench file (CSV, or Parquet with pyarrow) into :class:`BenchData` (SI units).

    Parameters
    ----------
    command_col, thrust_col, speed_col, current_col, voltage_col, time_col
        Column names: matched exactly, then by the header without a unit in a trailing bracket
        (``t`` finds ``t [s]``), then ignoring case, spacing and µ/u when that is unambiguous —
        never for a one-letter name (``t`` time is not ``T`` thrust) nor onto a column named
        exactly for another channel (:func:`_find_column`).  Every reading is checked against
        what a bench can produce (:data:`MAX_PULSE_US`, :data:`MAX_BENCH_THRUST`, …), per row.
    command_unit
        ``pwm_us``, ``duty`` or ``volts``.
    thrust_unit
        ``N``, ``kgf``, ``lbf``, ``ozf`` (ounce-force), ``g`` (gram-force), ``mN`` or ``kN``.
        ``None`` (default): the unit written in the column's header (``Thrust [kgf]``,
        ``Force (Kg f)``, ``thrust_lbf``, ``thrust (oz)``; see :func:`header_unit`), said in
        :attr:`BenchData.notes`, else N.  A unit given that disagrees with the header's is an
        error.
    speed_unit
        ``rad/s``, ``rpm`` or ``rev/s``; ``None`` (default): the header's (``RPM [rpm]``, ``RPM``,
        ``n (rps)``, ``speed_hz``), else rad/s, as for ``thrust_unit``.
    supply_voltage
        A constant supply voltage [V] when the file has no voltage column.
        The current column is read in A and the voltage column in V unless its header says mA
        or mV (``Current [mA]``, ``voltage_mv``; said in :attr:`BenchData.notes`); a bracketed
        unit in their header that is neither (``Current [kgf]``) is an error naming the column.
    neutral
        Neutral command (default 1500 µs for PWM, 0 for duty/volts).
    speed_sign
        ``signed`` (the column carries the sign), ``command`` (unsigned; sign from the command
        direction) or ``auto`` (signed if any speed is negative, else from the command).
    censor_speed_below
        Detection limit in ``speed_unit``: rows whose |speed| is below it were zeroed by the
        logger and are marked censored.
    flow_speed_col
        The water speed through the propeller (a run in a flow: carriage or tunnel speed).
        ``"auto"`` (default): the column :data:`FLOW_SPEED_COLUMN` when the file has one (also
        with a unit: ``flow_speed [cm/s]``), else none (a bench in still water: nothing
        changes); ``None``: never read.  With thrust, a row whose thrust opposes the command
        while the water is at rest or comes from behind the propeller (a forward command with
        ``flow_speed ≤ 0``, or the reverse) is an error: the blades' angle of attack only grows
        there (Healey et al. 1995).  Noise is no reversal, as in still water
        (:func:`reversal_tolerance`), nor, in a time series, the thrust still of the old sign
        after the command changed direction (the thruster's lag).
    flow_speed_unit
        ``m/s``, ``cm/s``, ``mm/s``, ``km/h``, ``kn`` or ``ft/s``; ``None`` (default): the
        header's (``flow [kn]``, ``flow_speed (cm/s)``, ``flow_m_s``), said in
        :attr:`BenchData.notes`, else m/s, as for ``thrust_unit``; a bracketed header unit not
        in that list is an error naming the column.
    """
    if isinstance(command_unit, str):
        command_unit = COMMAND_UNIT_ALIASES.get(command_unit.strip().lower(), command_unit)
    command_unit = _check_unit("command_unit", command_unit, {u: 0 for u in COMMAND_UNITS})
    if thrust_unit is not None:
        thrust_unit = _check_unit("thrust_unit", thrust_unit, THRUST_UNITS)
    if speed_unit is not None:
        speed_unit = _check_unit("speed_unit", speed_unit, SPEED_UNITS)
    if flow_speed_unit is not None:
        flow_speed_unit = _check_unit("flow_speed_unit", HEADER_FLOW_UNITS.get(
            _unit_key(str(flow_speed_unit)), flow_speed_unit), FLOW_UNITS)
    if speed_sign not in ("auto", "signed", "command"):
        raise BenchDataError(f"unknown speed_sign {speed_sign!r}; expected auto, signed or command")
    if voltage_col is not None and supply_voltage is not None:
        raise BenchDataError("give either voltage_col or supply_voltage, not both")
    if neutral is not None and not math.isfinite(float(neutral)):
        raise BenchDataError(f"neutral = {float(neutral):g} (--neutral): expected a finite "
                             f"command in {command_unit}")
    t = _read_table(path)
    if t.n_rows == 0:
        raise BenchDataError(f"{t.name}: no data rows under the header")
    # columns given exactly for a channel are no other channel's by a case-insensitive match
    taken = [c for c in (command_col, thrust_col, speed_col, current_col, voltage_col, time_col,
                         flow_speed_col) if c is not None and c in t.cells]

    def column(name, role):
        return _find_column(t, name, role, taken)

    notes: list[str] = []
    _take_unit_row(t, notes)
    ccol = column(command_col, "command")
    if ccol in t.units:
        tok = t.units[ccol]
        row_unit = COMMAND_UNIT_ALIASES.get(tok.lower(), tok.lower())
        if row_unit not in COMMAND_UNITS:
            raise _unit_row_error(t, ccol, tok, "command", ("us", "duty", "V"))
        if row_unit != command_unit:
            raise BenchDataError(
                f"{t.name}: column {ccol!r} is in {tok} by the unit row (CSV line {t.unit_line}), "
                f"but the command unit is {command_unit} (--command-unit / command_unit=): "
                f"expected one unit. Fix: give --command-unit {row_unit}, or correct the unit row")
    cmd = _numeric(t, ccol, "command", command_unit)
    _check_command(t, ccol, cmd, command_unit)  # first: a bad command makes every later check lie
    neutral_v = DEFAULT_NEUTRAL[command_unit] if neutral is None else float(neutral)

    def opt(col, role, unit=""):
        if col is None:
            return None, None
        c = column(col, role)
        return c, _numeric(t, c, role, unit)

    if thrust_col is not None:
        thrust_unit = _resolve_unit(t, column(thrust_col, "thrust"), "thrust",
                                    thrust_unit, "N", notes)
    if speed_col is not None:
        speed_unit = _resolve_unit(t, column(speed_col, "speed"), "speed", speed_unit,
                                   "rad/s", notes)
    thrust_unit = thrust_unit or "N"
    speed_unit = speed_unit or "rad/s"
    tcol, thrust = opt(thrust_col, "thrust", thrust_unit)
    scol, speed_raw = opt(speed_col, "speed", speed_unit)
    current_unit = voltage_unit = None
    if current_col is not None:
        current_unit = _resolve_unit(t, column(current_col, "current"), "current", None, "A", notes)
    if voltage_col is not None:
        voltage_unit = _resolve_unit(t, column(voltage_col, "supply voltage"), "supply voltage",
                                     None, "V", notes)
    _, current = opt(current_col, "current", current_unit or "A")
    vcol, volts = opt(voltage_col, "supply voltage", voltage_unit or "V")
    if current is not None:
        current = current * CURRENT_UNITS[current_unit or "A"]
    if volts is not None:
        volts = volts * VOLTAGE_UNITS[voltage_unit or "V"]
    if time_col is not None:
        c = column(time_col, "time")
        if c in t.units and t.units[c].lower() not in _TIME_UNITS:
            raise _unit_row_error(t, c, t.units[c], "time", ("s",))
    tmcol, time = opt(time_col, "time", "s")
    given_flow_col = flow_speed_col
    if flow_speed_col == "auto":
        flow_speed_col = _auto_flow_column(t, notes)
    if flow_speed_col is not None:
        flow_speed_unit = _resolve_unit(t, column(flow_speed_col, "water speed"),
                                        "flow speed", flow_speed_unit, "m/s", notes)
    if flow_speed_col is None and flow_speed_unit is not None:  # it was dropped silently
        raise BenchDataError(
            f"{t.name}: a water speed unit was given (--flow-speed-unit / flow_speed_unit= "
            f"{flow_speed_unit}) but no water speed column is read ("
            + ("--flow-speed-col none" if given_flow_col is None else "the file has no column "
               f"{FLOW_SPEED_COLUMN!r}, 'flow [unit]' or 'flow speed'")
            + "): it has no effect. Fix: drop the unit, or name the column (--flow-speed-col)")
    fcol, flow = opt(flow_speed_col, "water speed through the propeller", flow_speed_unit or "m/s")

    if thrust is not None:
        thrust = thrust * THRUST_UNITS[thrust_unit]
    if flow is not None:
        flow = flow * FLOW_UNITS[flow_speed_unit or "m/s"]
    censored = np.zeros(cmd.size, dtype=bool)
    speed = None
    censor_speed = None
    if speed_raw is not None:
        if censor_speed_below is not None:
            censored = np.abs(speed_raw) < float(censor_speed_below)
            censor_speed = float(censor_speed_below) * SPEED_UNITS[speed_unit]
        unsigned = speed_sign == "command" or (speed_sign == "auto" and not np.any(speed_raw < 0))
        if unsigned:
            if np.any(speed_raw < 0):
                i = int(np.flatnonzero(speed_raw < 0)[0])
                raise BenchDataError(f"{t.where(scol, i)}: negative speed {speed_raw[i]:g} in a "
                                     "column declared unsigned (speed_sign='command')")
            speed = np.abs(speed_raw) * np.sign(cmd - neutral_v)
        else:
            speed = speed_raw.copy()
        speed = speed * SPEED_UNITS[speed_unit]
    elif censor_speed_below is not None:
        raise BenchDataError("censor_speed_below needs a speed column (speed_col)")
    for col, vals, role, unit, bound in ((tcol, thrust, "thrust", "N", MAX_BENCH_THRUST),
                                         (scol, speed, "propeller speed", "rad/s", MAX_BENCH_SPEED),
                                         (fcol, flow, "water speed", "m/s", MAX_BENCH_FLOW)):
        _check_bound(t, col, vals, role, unit, bound)
    if flow is not None and thrust is not None:
        _check_thrust_in_flow(t, tcol, fcol, cmd - neutral_v, thrust, flow, ~censored,
                              time is not None)
    if volts is not None:
        bad = np.flatnonzero(volts <= 0)
        if bad.size:
            i = int(bad[0])
            raise BenchDataError(f"{t.where(vcol, i)}: supply voltage {volts[i]:g} V; expected a "
                                 "positive voltage")
    sv = volts if volts is not None else supply_voltage
    if time is not None:
        d = np.diff(time)
        bad = np.flatnonzero(d <= 0)
        if bad.size:
            i = int(bad[0]) + 1
            kind = "duplicated" if d[i - 1] == 0 else "not increasing (unsorted)"
            raise BenchDataError(f"{t.where(tmcol, i)}: time stamp {time[i]:g} s is {kind}: the "
                                 f"previous row has {time[i - 1]:g} s; expected strictly "
                                 "increasing time stamps")
    if np.all(cmd == neutral_v):
        raise BenchDataError(f"{t.name}: column {ccol!r}: the command never leaves neutral "
                             f"({neutral_v:g} {command_unit}) in {cmd.size} rows — nothing to "
                             "identify (wrong column, or wrong neutral?)")
    warns: list[str] = []
    if time is None:  # a time series with a repeated row has a repeated stamp (refused above)
        pasted_block(t)
    return BenchData(command=cmd, command_unit=command_unit, thrust=thrust, speed=speed,
                     current=current, supply_voltage=sv, time=time, source=t.name,
                     censored=censored, neutral=neutral_v, censor_speed=censor_speed,
                     flow_speed=flow, flow_speed_column=fcol, notes=tuple(notes),
                     warnings=tuple(warns))


#: a run of at least this many rows (and :data:`PASTED_SHARE` of the file) equal, in order, to an
#: earlier run is a copy.  A sweep measured again repeats single rows (a zero in the dead band, a
#: value at the instrument's resolution) and short runs of them — real measurements, kept
PASTED_MIN_ROWS = 10
PASTED_SHARE = 0.2


def pasted_block(t: _Table) -> None:
    """Refuse a steady sheet holding a block of rows equal, in the same order and in every column,
    to an earlier block (a file pasted twice, a logger writing its buffer again): counted as
    repeats it would give a table's entries a σ of 0 and a fit too small a σ.  Single equal rows
    are kept: a repeated sweep logged at its instruments' resolution repeats rows exactly."""
    n = t.n_rows
    if n < 2 * PASTED_MIN_ROWS:
        return
    first: dict = {}
    prev = np.full(n, -1)  # the first earlier row equal to row i, or -1
    for i, r in enumerate(zip(*(t.cells[c] for c in t.columns))):
        key = tuple(str(v).strip() for v in r)
        prev[i] = first.get(key, -1)
        first.setdefault(key, i)
    best, start, run = 0, 0, 0
    for i in range(n):
        if prev[i] < 0:
            run = 0
        elif run and prev[i] == prev[i - 1] + 1:
            run += 1
        else:
            run = 1
        if run > best:
            best, start = run, i - run + 1
    if best >= max(PASTED_MIN_ROWS, PASTED_SHARE * n):
        src = int(prev[start])
        raise BenchDataError(
            f"{t.name}: data rows {start + 1}–{start + best} repeat rows {src + 1}–{src + best} "
            "exactly, in the same order and in every column: a copy (the file pasted twice, a "
            "buffer written again), not a repeated measurement — counted as repeats they would "
            "give a σ of 0 per table entry; expected each measurement once (remove the copy; a "
            "sweep measured again differs in some digit)")


def _check_command(t: _Table, col: str, cmd: np.ndarray, unit: str) -> None:
    """A command that no command of ``unit`` can be, per row: a negative or longer-than-a-frame
    pulse width (:data:`MAX_PULSE_US`), a duty beyond ±1, a voltage beyond any thruster's
    supply."""
    from uuvid.core.checks import MAX_PLAUSIBLE_VOLTAGE

    if unit == "pwm_us":
        bad = np.flatnonzero((cmd < 0) | (cmd > MAX_PULSE_US))
        if bad.size:
            i = int(bad[0])
            hint = ("the commands look like duties: give --command-unit duty"
                    if np.all(np.abs(cmd) <= 1.0) else
                    "a signed command is a duty or a voltage: give --command-unit duty or "
                    "--command-unit volts")
            raise BenchDataError(
                f"{t.where(col, i)}: command {cmd[i]:g} µs is not a pulse width: command unit "
                f"pwm_us (the default) expects 0…{MAX_PULSE_US:g} µs (an ESC's 1100–1900 µs "
                f"about 1500); {hint}")
    elif unit == "duty":
        bad = np.flatnonzero(np.abs(cmd) > 1.0 + 1e-9)  # the tolerance check_bench_commands allows
        if bad.size:
            i = int(bad[0])
            c = abs(float(cmd[i]))
            hint = ("it looks like a pulse width: give --command-unit pwm_us" if 800 <= c <= 2200
                    else "in percent? give the duty as a fraction (−1…1)" if 2 < c <= 100
                    else "a corrupt cell? Fix or leave out the row")
            raise BenchDataError(
                f"{t.where(col, i)}: command {cmd[i]:g} is not a duty: command unit duty expects "
                f"−1…1 (full reverse … full forward); {hint}")
    elif unit == "volts":
        bad = np.flatnonzero(np.abs(cmd) > MAX_PLAUSIBLE_VOLTAGE)
        if bad.size:
            i = int(bad[0])
            raise BenchDataError(
                f"{t.where(col, i)}: command {cmd[i]:g} V: no thruster runs on more than "
                f"{MAX_PLAUSIBLE_VOLTAGE:g} V; expected a motor voltage (in mV? a corrupt cell?)")


def _check_bound(t: _Table, col: str | None, vals: np.ndarray | None, role: str, unit: str,
                 bound: float) -> None:
    """A reading (SI) beyond what any bench can measure (:data:`MAX_BENCH_THRUST`, …) is an
    error naming the row: a fit would overflow on it and write a model of nonsense."""
    if vals is None:
        return
    bad = np.flatnonzero(np.abs(vals) > bound)
    if bad.size:
        i = int(bad[0])
        raise BenchDataError(
            f"{t.where(col, i)}: {role} {vals[i]:.4g} {unit} (after unit conversion) is beyond "
            f"what any bench measures (|{role}| ≤ {bound:g} {unit}); expected a reading — a "
            "corrupt cell or a wrong unit? Fix or leave out the row")


def _flow_key(column: str) -> str:
    """A header as the water speed's names are compared: unit bracket stripped, case folded,
    spaces, hyphens and underscores as one ``_`` (``Flow Speed [kn]`` → ``flow_speed``)."""
    return re.sub(r"[\s_\-]+", "_", _norm(_strip_unit(column))).strip("_")


def _auto_flow_column(t: _Table, notes: list[str] | None = None) -> str | None:
    """The column :data:`FLOW_SPEED_COLUMN` or another of :data:`FLOW_SPEED_NAMES`, with any
    spacing and case and a unit in a trailing bracket (``flow_speed [cm/s]``, ``flow speed``;
    ``flow`` only with a water speed unit, ``flow [kn]``), else ``None``; two candidates are an
    error.  A column that mentions a flow
    but is none of these is said in ``notes`` (it is not read: still water is assumed)."""
    # flow_speed (any unit: a wrong one is said when read); a bare "flow" only with a water speed
    # unit in its header (flow [kn]): a Flow or flow [l/min] column is a coolant's, not read
    have = [c for c in t.columns if _flow_key(c) == FLOW_SPEED_NAMES[0]
            or (_flow_key(c) in FLOW_SPEED_NAMES and header_unit(c, "flow speed") is not None)]
    if not have and notes is not None:
        like = [c for c in t.columns if "flow" in _flow_key(c) or "water_speed" in _flow_key(c)]
        if like:
            notes.append(f"{t.name}: column(s) {', '.join(map(repr, like))} look like a water "
                         "speed but are not read as one (still water is assumed); to fit the "
                         "inflow, name it: --flow-speed-col / flow_speed_col=")
    if len(have) > 1:
        raise BenchDataError(f"{t.name}: columns {', '.join(map(repr, have))} could each be the water "
                             "speed through the propeller: name one (--flow-speed-col / "
                             "flow_speed_col=)")
    return have[0] if have else None


def reversal_tolerance(y, command, rows, scatter_rows=None, flow=None) -> float:
    """How large a reading of the wrong sign may be and still be noise rather than a reversal:
    :data:`SIGN_NOISE` × the largest |``y``| over ``rows``, or :data:`REVERSAL_SIGMAS` × the
    readings' row-to-row scatter over ``scatter_rows`` (default ``rows``; robust: the MAD of
    successive differences, rows ordered by command, and by water speed ``flow`` within one
    command), whichever is larger; the scatter only with at least five such rows.  The still-water
    check (:func:`uuvid.identify.plausibility.check_bench_signs`) and the check in a flow
    (:func:`read_bench`) use this one rule."""
    y = np.asarray(y, float)
    rows = np.asarray(rows, bool)
    tol = SIGN_NOISE * float(np.max(np.abs(y[rows]))) if rows.any() else 0.0
    sr = np.flatnonzero(rows if scatter_rows is None else scatter_rows)
    if sr.size >= 5:
        c = np.asarray(command, float)[sr]
        keys = (c,) if flow is None else (np.asarray(flow, float)[sr], c)
        dy = np.diff(y[sr[np.lexsort(keys)]])  # lexsort: stable, the last key first
        sigma = 1.4826 * float(np.median(np.abs(dy - np.median(dy)))) / np.sqrt(2.0)
        tol = max(tol, REVERSAL_SIGMAS * sigma)
    return tol


def _thrust_reached(direction, thrust, tol: float) -> np.ndarray:
    """Rows of a time series whose command has kept its direction since a row where the thrust
    was clearly (beyond ``tol``) on that side: before it, after a step that reversed the command,
    the thrust keeps the old sign for the thruster's lag, which is no reversal."""
    d = np.sign(direction)
    clear = (d != 0) & (d * thrust > tol)
    before = np.cumsum(clear) - clear  # clear rows before each row
    new = np.r_[True, d[1:] != d[:-1]]  # first row of each stretch of one direction
    start = np.flatnonzero(new)[np.cumsum(new) - 1]
    return before > before[start]


def _check_thrust_in_flow(t: _Table, tcol: str, fcol: str, direction, thrust, flow, measured,
                          series: bool) -> None:
    """A propeller turning forward in water at rest or flowing from behind it (``u_a ≤ 0``) has
    its blades at an angle of attack ``α = p − β ≥ p > 0`` (``β = atan2(u_a, 0.7RΩ) ≤ 0``,
    Healey et al. 1995), so its thrust is forward; the same holds astern.  A reading against
    that beyond the noise (:func:`reversal_tolerance`, the rule of the still-water check: a
    thrust about zero at a small command may have either sign) is a wrong sign in the thrust or
    flow column, named by file, column and row.  In a time series (``series``) the rows after a
    change of the command's direction count only once the thrust has reached the new side (the
    thruster's lag)."""
    d = np.sign(direction)
    rows = measured & (d != 0) & (thrust != 0)
    against = rows & (((d > 0) & (flow <= 0)) | ((d < 0) & (flow >= 0)))
    if not against.any():
        return
    tol = reversal_tolerance(thrust, direction, rows, against, flow)
    bad = against & (d * thrust < -tol)
    if series:
        bad &= _thrust_reached(direction, thrust, tol)
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        way = "forward" if d[i] > 0 else "astern"
        raise BenchDataError(
            f"{t.where(tcol, i)}: thrust {thrust[i]:+.4g} N with the propeller driven {way} and "
            f"{fcol!r} = {flow[i]:g} m/s (water at rest or from behind it): the thrust cannot "
            f"oppose the command there (beyond the noise, {tol:.3g} N here: the larger of "
            f"{SIGN_NOISE:.0%} of the largest |thrust| and {REVERSAL_SIGMAS:g}× the readings' "
            "row-to-row scatter). "
            f"Fix: the sign of the thrust or of the flow-speed column ({fcol!r} > 0: the water "
            "meets a forward-turning propeller from ahead)")


def read_t200(path) -> BenchData:
    """Read a Blue Robotics T200 performance sheet (one supply voltage per file).

    Columns ``PWM (us)`` or ``PWM (µs)``, ``RPM`` (unsigned; the sign is taken from the command),
    ``Current (A)`` (supply current), ``Voltage (V)``, ``Force (Kg f)`` (signed).  Readings under
    300 rpm were set to zero by the manufacturer, so those rows are marked censored.
    """
    t = _read_table(path)
    pwm = None
    for cand in _T200_PWM:
        if any(_norm(c) == _norm(cand) for c in t.columns):
            pwm = cand
            break
    if pwm is None:
        raise BenchDataError(f"{t.name}: no column 'PWM (us)' or 'PWM (µs)' — not a T200 "
                             f"performance sheet? available columns: "
                             f"{', '.join(repr(c) for c in t.columns)}")
    (tcol, tunit, _), (scol, sunit, _) = T200_UNIT_COLUMNS["thrust_unit"], T200_UNIT_COLUMNS["speed_unit"]
    return read_bench(path, command_col=pwm, thrust_col=tcol, speed_col=scol,
                      current_col="Current (A)", voltage_col="Voltage (V)",
                      command_unit="pwm_us", thrust_unit=tunit, speed_unit=sunit,
                      neutral=1500.0, speed_sign="command", censor_speed_below=T200_CENSOR_RPM)


def concat(sets: Sequence[BenchData]) -> BenchData:
    """Stack several data sets (same command unit and neutral) into one; supply voltage per row."""
    sets = list(sets)
    if not sets:
        raise BenchDataError("no bench data to concatenate")
    unit, neutral = sets[0].command_unit, sets[0].neutral
    for s in sets[1:]:
        if s.command_unit != unit or s.neutral != neutral:
            raise BenchDataError(f"cannot stack {s.source or 'data'} ({s.command_unit}, neutral "
                                 f"{s.neutral:g}) with {sets[0].source or 'data'} ({unit}, "
                                 f"neutral {neutral:g})")

    def cat(name):
        parts = [getattr(s, name) for s in sets]
        if any(p is None for p in parts):
            return None
        return np.concatenate(parts)

    sv = None
    if all(s.supply_voltage is not None for s in sets):
        sv = np.concatenate([s.supply_voltage_array() for s in sets])
    cs = {s.censor_speed for s in sets}
    flows = [s.flow_speed for s in sets]
    if any(f is not None for f in flows) and any(f is None for f in flows):
        still = [s.source or "data" for s in sets if s.flow_speed is None]
        raise BenchDataError(f"cannot stack bench files with and without a flow_speed column "
                             f"({', '.join(still)} has none): add flow_speed = 0 to a file "
                             "recorded in still water")
    return BenchData(command=cat("command"), command_unit=unit, thrust=cat("thrust"),
                     speed=cat("speed"), current=cat("current"), supply_voltage=sv,
                     time=None, source="+".join(s.source for s in sets if s.source),
                     censored=np.concatenate([s.censored for s in sets]), neutral=neutral,
                     censor_speed=cs.pop() if len(cs) == 1 else None,
                     flow_speed=cat("flow_speed"),
                     flow_speed_column=" / ".join(dict.fromkeys(
                         s.flow_speed_column for s in sets if s.flow_speed_column)) or None,
                     notes=tuple(n for s in sets for n in s.notes),
                     warnings=tuple(w for s in sets for w in s.warnings))


__all__ = ["BenchData", "BenchDataError", "read_bench", "read_t200", "require_samples", "concat",
           "COMMAND_UNITS", "THRUST_UNITS", "SPEED_UNITS", "FLOW_UNITS", "header_unit",
           "reversal_tolerance"]


def default_t200_dir() -> Path | None:
    """Blue Robotics' T200 sheets (``shared/data/t200-bluerobotics-2019`` beside the checkout), or None."""
    here = Path(__file__).resolve()
    for base in (here.parents[3].parent, Path.cwd().parent, Path.cwd()):
        d = base / "shared" / "data" / "t200-bluerobotics-2019"
        if d.is_dir():
            return d
    return None
