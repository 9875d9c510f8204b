"""What a mission flight takes before it flies: memory for its time series, disk for its outputs.

:data:`uuvid.simulate.vehicle_sim.MAX_STEPS` bounds the control steps one flight holds, but not
what they cost: the rows are as wide as the vehicle (its state, one thrust and one command per
thruster, a battery's supply) and writing them (:func:`uuvid.simulate.mission_report.
write_mission_outputs`: a DataFrame, ``timeseries.csv`` and ``.parquet``, figures drawing every
sample) takes about four times the flight's memory again.  A two-million-step flight with its
outputs took 3.9 GB of memory and wrote a 1.17 GB ``timeseries.csv`` without a word.

:func:`flight_footprint` estimates both from a :class:`~uuvid.simulate.vehicle_sim.MissionSetup`
(rows × columns, with the per-row costs measured on a BlueROV2 flight: :data:`FLIGHT_OVERHEAD`,
:data:`WRITE_OVERHEAD`, :data:`CSV_BYTES_PER_VALUE`, :data:`PARQUET_BYTES_PER_VALUE`);
:func:`check_footprint` refuses a flight past :func:`flight_memory_limit` of memory or the free space
of its output folder, saying how much it would take and how to lower it, and returns warnings for
a large or long one.  The time series are stored once per control step ``dt``: substeps add
integration time, not rows.
"""

from __future__ import annotations

import importlib.util
import shutil
from dataclasses import dataclass
from pathlib import Path

from uuvid.core.checks import physical_memory_bytes

#: Most memory (bytes) one flight may take on any machine: its time series, and writing them
#: when it has an output folder (:func:`flight_memory_limit` allows a quarter of a larger
#: machine's memory).  (A BlueROV2 flight takes ≈ 0.5 kB per control step, ≈ 2.4 kB with
#: outputs: at 2 GB ≈ 4 M steps without, ≈ 0.9 M with — 24 h at dt = 0.1 s, 2.4 h at dt = 0.01 s.)
MAX_FLIGHT_BYTES = 2e9
#: Share of the machine's physical memory one flight may take when that is more than
#: :data:`MAX_FLIGHT_BYTES`.
MEMORY_SHARE = 0.25
#: A flight past these is said before it flies (memory, disk, RK4 integration steps).
WARN_MEMORY_BYTES = 5e8
WARN_DISK_BYTES = 2.5e8
WARN_INTEGRATION_STEPS = 50_000_000
#: Memory per stored double in flight (the summary's temporaries: errors, attitude, limits).
FLIGHT_OVERHEAD = 1.4
#: Memory per written value while writing the outputs (DataFrame, CSV and Parquet buffers and
#: the figures' copies of every sample), in doubles.
WRITE_OVERHEAD = 8.0
#: Bytes per value in ``timeseries.csv`` (full-precision decimals) and ``timeseries.parquet``.
CSV_BYTES_PER_VALUE = 20.0
PARQUET_BYTES_PER_VALUE = 8.0


@dataclass(frozen=True)
class FlightFootprint:
    """Estimated cost of one flight (bytes): ``memory`` in all, ``flight_memory`` of its time
    series alone (no outputs), ``csv_bytes`` + ``parquet_bytes`` = ``disk`` of its outputs
    (0 without an output folder)."""

    steps: int  # control steps (rows)
    substeps: int
    columns: int  # doubles held per step in flight
    output_columns: int  # columns of timeseries.csv (MissionResult.to_frame)
    flight_memory: float
    memory: float
    csv_bytes: float
    parquet_bytes: float

    @property
    def disk(self) -> float:
        return self.csv_bytes + self.parquet_bytes

    @property
    def integration_steps(self) -> int:
        return self.steps * self.substeps


def flight_footprint(setup, outputs: bool = False) -> FlightFootprint:
    """The memory and disk a flight of ``setup`` takes, with its outputs written (``outputs``:
    :func:`~uuvid.simulate.mission_report.write_mission_outputs`) or not."""
    n_steps = int(setup.t.size)
    n = int(setup.bank.n)
    cols = (1 + 8 + setup.z0().size + 2 * n + 6 + 1  # t, reference, state, thrusts, wrench, scale
            + (3 + n if setup.battery_array is not None else 0)  # supply voltage, current, SOC
            + (6 if setup.current_series is not None else 0))  # a varying current and its rate
    out_cols = 19 + 2 * n  # MissionResult.to_frame
    flight = n_steps * cols * 8 * FLIGHT_OVERHEAD
    write = n_steps * out_cols * 8 * WRITE_OVERHEAD if outputs else 0.0
    csv = n_steps * out_cols * CSV_BYTES_PER_VALUE if outputs else 0.0
    pq = (n_steps * out_cols * PARQUET_BYTES_PER_VALUE
          if outputs and importlib.util.find_spec("pyarrow") is not None else 0.0)
    return FlightFootprint(n_steps, int(setup.substeps), cols, out_cols, flight, flight + write,
                           csv, pq)


def size_text(nbytes: float) -> str:
    """``1.2 GB``, ``350 MB``, ``12 kB`` (decimal units, as file managers show sizes)."""
    for unit, k in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if nbytes >= k:
            return f"{nbytes / k:.2g} {unit}" if nbytes < 10 * k else f"{nbytes / k:.0f} {unit}"
    return f"{nbytes:.0f} B"


def _free_space(folder: Path) -> float | None:
    """Free bytes on the file system ``folder`` would be made on (its nearest existing parent)."""
    p = Path(folder).resolve()
    while not p.exists() and p != p.parent:
        p = p.parent
    try:
        return float(shutil.disk_usage(p).free)
    except OSError:
        return None


def _lower(fp: FlightFootprint, dt: float, fit: float | None, duration_name: str, dt_name: str,
           max_dt: float | None, out) -> str:
    """How to make the flight smaller: a shorter duration, a larger step (when one up to
    ``max_dt`` does), no outputs; with ``fit`` (the most steps that fit) the values that do."""
    if fit is None:
        ways = [f"shorten {duration_name}", f"raise {dt_name}"]
    else:
        n = max(int(fit), 1)
        need = fp.steps * dt / n
        ways = [f"shorten {duration_name} to ≤ {n * dt:.6g} s"]
        if max_dt is None or need <= max_dt * (1 + 1e-9):
            ways.append(f"raise {dt_name} to ≥ {need:.2g} s")
        else:  # a larger step is not allowed
            ways[0] += f" ({dt_name} = {dt:g} s is at its largest, {max_dt:g} s)"
    if out is not None:
        ways.append(f"fly without the output folder (--out: the summary only, ≈ "
                    f"{size_text(fp.flight_memory)} of memory)")
    return ", ".join(ways[:-1]) + " or " + ways[-1] if len(ways) > 1 else ways[0]


def flight_memory_limit() -> float:
    """Most memory one flight may take here: :data:`MAX_FLIGHT_BYTES`, or :data:`MEMORY_SHARE` of
    the machine's physical memory when that is more (the same on every run on one machine: not
    the memory free at the moment)."""
    return max(MAX_FLIGHT_BYTES, MEMORY_SHARE * physical_memory_bytes())


def check_footprint(setup, out: str | Path | None = None, *, duration_name: str = "duration",
                    dt_name: str = "dt", max_dt: float | None = None,
                    max_bytes: float | None = None) -> list[str]:
    """Refuse (``ValueError``) a flight of ``setup`` whose time series — with its outputs
    written to the folder ``out``, if given — would take more than ``max_bytes`` (default
    :func:`flight_memory_limit`) of memory, or more disk than ``out`` has free; the message says how
    much and how to lower it (``duration_name``/``dt_name``: what the caller calls them;
    ``max_dt``: the largest step it accepts).  Returns warnings (to say before the flight) for a
    flight past :data:`WARN_MEMORY_BYTES`, :data:`WARN_DISK_BYTES` or
    :data:`WARN_INTEGRATION_STEPS`."""
    limit = flight_memory_limit() if max_bytes is None else float(max_bytes)
    fp = flight_footprint(setup, outputs=out is not None)
    dt = float(setup.dt)
    rows = (f"{duration_name} = {fp.steps * dt:.6g} s at {dt_name} = {dt:g} s is {fp.steps:,} "
            f"control steps (time series rows: one per {dt_name}, substeps add none) of "
            f"{fp.columns} values in flight"
            + (f" and {fp.output_columns} columns written" if out is not None else ""))
    files = (f"timeseries.csv ≈ {size_text(fp.csv_bytes)}"
             + (f", timeseries.parquet ≈ {size_text(fp.parquet_bytes)}" if fp.parquet_bytes else ""))
    if fp.memory > limit:
        raise ValueError(
            f"{rows}: the flight would take ≈ {size_text(fp.memory)} of memory"
            + (f" with its outputs ({files} on disk)" if out is not None else "")
            + f", more than the {size_text(limit)} one flight may take on this machine; "
            + _lower(fp, dt, fp.steps * limit / fp.memory, duration_name, dt_name, max_dt, out))
    if out is not None:
        free = _free_space(Path(out))
        if free is not None and fp.disk > free:
            raise ValueError(
                f"{rows}: its outputs would take ≈ {size_text(fp.disk)} on disk ({files}), and "
                f"{out} has {size_text(free)} free; "
                + _lower(fp, dt, fp.steps * free / fp.disk, duration_name, dt_name, max_dt, out))
    said = []
    if fp.memory > WARN_MEMORY_BYTES or fp.disk > WARN_DISK_BYTES:
        said.append(f"a large flight: {rows}; it takes ≈ {size_text(fp.memory)} of memory"
                    + (f" and writes ≈ {size_text(fp.disk)} ({files})" if out is not None else "")
                    + "; to make it smaller, "
                    + _lower(fp, dt, None, duration_name, dt_name, max_dt, out))
    if fp.integration_steps > WARN_INTEGRATION_STEPS:
        said.append(f"a long flight: {fp.steps:,} control steps × {fp.substeps} substeps = "
                    f"{fp.integration_steps:.3g} RK4 steps (≈ {fp.integration_steps * 1e-6:.0f} s "
                    f"at ≈ 1 µs each); fewer substeps, a larger {dt_name} or a shorter "
                    f"{duration_name} make it quicker")
    return said
