"""Plausibility checks for identification inputs and results: a sign or unit mistake that would
otherwise give a "valid" model (zero thrust, negative drag or inertia) is an error or a warning."""
from __future__ import annotations

import numpy as np

from uuvid.io.bench import BenchDataError

#: below this fraction of rows agreeing with the command's direction, the sign is reversed
_SIGN_AGREEMENT = 0.5


def check_bench_signs(data, *, min_rows: int = 3) -> None:
    """Raise :class:`BenchDataError` when a bench file's thrust (or signed speed) has the
    opposite sign of the command direction in most measured rows (a reversed load cell or
    column): identification would otherwise return a model with zero or negative thrust."""
    d = data.direction
    for name, unit in (("thrust", "N"), ("speed", "rad/s")):
        y = getattr(data, name)
        if y is None:
            continue
        m = data.measured & (d != 0) & np.isfinite(y) & (y != 0)
        n = int(m.sum())
        if n < min_rows:
            continue
        agree = np.sign(y[m]) == d[m]
        if agree.mean() >= _SIGN_AGREEMENT:
            continue
        k = int(np.argmax(np.abs(y[m])))
        cmd, val = float(data.command[m][k]), float(y[m][k])
        src = f"{data.source}: " if data.source else ""
        raise BenchDataError(
            f"{src}{name} has the opposite sign of the command in {n - int(agree.sum())} of {n} "
            f"measured rows (e.g. command {cmd:g} {data.command_unit}, "
            f"{'above' if cmd > data.neutral else 'below'} neutral {data.neutral:g}, gives "
            f"{name} {val:+.4g} {unit}); expected: a command above neutral gives positive "
            f"{name} (forward). Fix: negate the {name} column (the load cell or sensor is "
            "mounted reversed), or give the right neutral command (--neutral)")
