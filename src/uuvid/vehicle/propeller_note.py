"""One line on the propeller map and wake behind every number computed with inflow (issue 21:
the assumptions labelled).

The T200 preset's map is the published Wageningen B4-70 table scaled to a 76 mm propeller at
P/D 1.0 — both ASSUMED, not measured (:data:`uuvid.thruster.inflow.T200_DIAMETER`); a map fitted
on the user's own bench (a thruster model file's ``inflow`` section) is measured.  Every output
that shows inflow numbers (simulate, vehicle envelope / hold / stability, thruster show) says
which by :func:`propeller_map_note`.
"""

from __future__ import annotations

import math

#: The T200 preset's propeller, as :func:`propeller_map_note` names it.
T200_MAP_TEXT = "Wageningen B4-70 P/D 1.0, D = 76 mm (T200 diameter and P/D assumed, not measured)"


def map_text(fq) -> str:
    """What one :class:`~uuvid.thruster.inflow.FourQuadrantMap` is and whether it was measured."""
    from uuvid.thruster.inflow import T200_DIAMETER, T200_PITCH_RATIO

    name = str(getattr(fq, "name", ""))
    d = float(getattr(fq, "diameter", math.nan))
    if name.startswith("wageningen-b4-70-pd1.0") and math.isclose(d, T200_DIAMETER) \
            and T200_PITCH_RATIO == 1.0:
        return T200_MAP_TEXT + (" (approximate series)" if name.endswith("approx") else "")
    if name.startswith("fitted (") and name.endswith(")"):
        where = name[len("fitted ("):-1]
        where = where[:-len(": inflow")] if where.endswith(": inflow") else where
        return (f"fitted on your bench, {where} (measured, D = {d * 1000:.0f} mm, valid over β "
                f"{fq.ranges_text()})")
    text = f"{name}, D = {d * 1000:.0f} mm"
    return text + (f" ({fq.assumption})" if getattr(fq, "assumption", "") else "")


def propeller_map_note(maps, wake=None) -> str:
    """``"propeller map: …; wake w …"``: the map(s) of ``maps`` (one per thruster, or one) and
    the wake fractions ``wake`` (one per thruster; ``None``: not said)."""
    maps = list(maps) if isinstance(maps, (list, tuple)) else [maps]
    texts = list(dict.fromkeys(map_text(m) for m in maps))
    out = ("propeller map: " if len(texts) == 1 else "propeller maps: ") + "; ".join(texts)
    if wake is not None:
        ws = sorted({round(float(w), 6) for w in wake})
        out += "; wake w " + (f"= {ws[0]:g} for every thruster" if len(ws) == 1 else
                              "per thruster " + ", ".join(f"{w:g}" for w in ws))
    return out


def vehicle_propeller_note(vehicle, inflow: str | None = None) -> str:
    """:func:`propeller_map_note` of ``vehicle``'s thrusters under ``inflow`` (``None``: the
    vehicle file's); ``""`` when inflow is off or the maps cannot be read."""
    from uuvid.vehicle.inflow import inflow_limits

    try:
        il = inflow_limits(vehicle, inflow)
    except (KeyError, ValueError, OSError):
        return ""
    return "" if il is None else propeller_map_note(il.maps, il.wake)


def model_propeller_note(model: str) -> str:
    """What ``uuvid thruster show`` says of a thruster model's propeller map: the
    :func:`propeller_map_note` line, with a T200 preset's derived inflow coefficient; ``""`` for
    a model without a map."""
    from uuvid.thruster.inflow import propeller_map, t200_inflow
    from uuvid.vehicle.inflow import thruster_map

    t200 = model in ("t200", "t200-physical")
    try:
        fq = propeller_map(model) if t200 else thruster_map(model)
    except (KeyError, ValueError, OSError):
        return ""
    k = (f"; inflow coefficient k_a = {t200_inflow().inflow_coefficient:.4g} N·s²/(rad·m) "
         "(linear form, from the same D and P/D)" if t200 else "")
    return propeller_map_note(fq) + k + " — used with inflow: four-quadrant"
