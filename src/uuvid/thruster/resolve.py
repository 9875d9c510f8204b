"""One resolver for a thruster model named anywhere (``log export --thruster-model``, ``simulate
--thruster-model``, a scenario's ``thruster_model``, a vehicle file's thruster ``model``, ``thruster
show|simulate|predict``): a preset name (:data:`uuvid.thruster.presets.PRESETS`), ``t200-physical``
(the voltage-aware fit of Blue Robotics' T200 sheets shipped with the package, as a chain at a
supply voltage) or a model file path (relative to ``base``).

Supply voltage (:func:`supply_law`): a preset with an ESC is rebuilt at the voltage by its own
law (:func:`uuvid.thruster.presets.preset_chain`, e.g. the T200's speed ∝ V^γ); a model file's
ESC block outputs ``V = duty × supply`` (:meth:`uuvid.thruster.blocks.ESC.with_supply`), so the
chain is re-evaluated with its ESC at the voltage (:func:`at_supply`; exact for a physical
ESC → DC motor chain); a chain without an ESC cannot follow the voltage.
"""

from __future__ import annotations

from pathlib import Path

#: Voltage-aware built-in models (not chains until given a supply voltage).
PHYSICAL_PRESETS = ("t200-physical",)
#: Supply voltage of ``t200-physical`` as a chain when none is given: the T200 sheet's 16 V.
DEFAULT_PHYSICAL_SUPPLY_V = 16.0


def preset_names() -> list[str]:
    """Every name :func:`resolve_chain` accepts besides a file."""
    from uuvid.thruster.presets import PRESETS

    return sorted(PRESETS) + list(PHYSICAL_PRESETS)


def is_preset(ref) -> bool:
    return str(ref) in preset_names()


def resolve_chain(ref, base: Path | str | None = None, supply_voltage: float | None = None):
    """The :class:`~uuvid.thruster.chain.ThrusterChain` ``ref`` names (preset, ``t200-physical``
    or model file).  ``supply_voltage`` re-evaluates the chain's ESC at that voltage (required
    meaning for ``t200-physical``: default :data:`DEFAULT_PHYSICAL_SUPPLY_V`).  Raises
    ``FileNotFoundError`` naming the presets when ``ref`` is neither."""
    from uuvid.thruster.modelfile import load_chain
    from uuvid.thruster.presets import PRESETS, preset_chain

    ref = str(ref)
    if ref in PHYSICAL_PRESETS:
        from uuvid.thruster.physical import physical_model

        v = DEFAULT_PHYSICAL_SUPPLY_V if supply_voltage is None else float(supply_voltage)
        return physical_model(ref).to_chain(v, name=ref)
    if ref in PRESETS:
        if supply_voltage is not None and supply_law(ref, preset_chain(ref)) is not None:
            return _preset_at(ref, supply_voltage)
        chain = preset_chain(ref)
    else:
        p = Path(ref)
        if not p.is_absolute() and base is not None:
            p = Path(base) / p
        if not p.is_file():
            raise FileNotFoundError(f"{ref}: no such model file, and not a thruster preset "
                                    f"(presets: {', '.join(preset_names())})")
        chain = load_chain(p)
    if supply_voltage is not None:
        chain = at_supply(chain, supply_voltage) or chain
    return chain


def supply_voltage_of(chain) -> float | None:
    """The supply voltage of the chain's first ESC block that follows the supply, or ``None``
    (it cannot follow one: no ESC, or only a command stage, see :func:`is_command_map`)."""
    from uuvid.thruster.blocks import ESC

    for b in chain.blocks:
        if isinstance(b, ESC) and b.follows_supply:
            return float(b.supply_voltage)
    return None


def is_command_map(chain) -> bool:
    """The chain has an ESC block but none that follows the supply: its first block only shifts
    the command (``command − neutral``, ``follows_supply: false``) in front of a map fitted on
    the command at the bench's supply.  Nothing in it depends on a supply voltage."""
    from uuvid.thruster.blocks import ESC

    escs = [b for b in chain.blocks if isinstance(b, ESC)]
    return bool(escs) and not any(b.follows_supply for b in escs)


def _span(lo: float, hi: float) -> str:
    return f"{lo:g} V" if lo == hi else f"{lo:g}–{hi:g} V"


def _inside_fit(volts, v: float, rel_tol: float = 0.05) -> bool:
    """Is ``v`` within the supply voltages ``volts`` a model was fitted at (± ``rel_tol``)?"""
    return min(volts) * (1 - rel_tol) <= v <= max(volts) * (1 + rel_tol)


def _fit_range_said(chain, v: float) -> str:
    """``; inside the 12–16 V … fitted at`` (or outside) for a chain that records the supply
    voltages of its data (:attr:`ThrusterChain.fit_supply_voltages`); else empty."""
    volts = getattr(chain, "fit_supply_voltages", None)
    if not volts:
        return ""
    where = "inside" if _inside_fit(volts, v) else "outside"
    return f"; {where} the {_span(min(volts), max(volts))} the model was fitted at"


def command_map_supply(chain, supply_voltage: float | None = None) -> tuple[str, list[str]]:
    """``(source, warnings)`` for a chain that does not depend on the supply
    (:func:`is_command_map`): what a supply voltage means for it, and a warning when one asked
    of it is not the bench voltage its map was measured at (it is not rescaled to it)."""
    volts = getattr(chain, "fit_supply_voltages", None)
    bench = (f"measured at {_span(min(volts), max(volts))} (fit_supply_voltages)" if volts
             else "measured at the bench's supply, which its file does not record")
    source = (f"not used: {chain.name} is a map of the command {bench}; it does not depend on the "
              "supply voltage (its first block only subtracts the neutral command)")
    if supply_voltage is None:
        return source, []
    v = float(supply_voltage)
    if volts and _inside_fit(volts, v):
        return f"{v:g} V (--supply-voltage) matches the bench: " + source, []
    return source, [f"--supply-voltage {v:g} V: {chain.name} is a map of the command {bench}; its "
                    f"thrust is that bench's, not rescaled to {v:g} V. Fit the map on data at "
                    f"{v:g} V, or use --model physical (it models the supply voltage)"]


def at_supply(chain, supply_voltage: float):
    """``chain`` with every ESC at ``supply_voltage`` (``V = duty × supply``), or ``None`` when
    it has no ESC (nothing in it depends on the supply)."""
    from uuvid.thruster.blocks import ESC
    from uuvid.thruster.chain import ThrusterChain

    if supply_voltage_of(chain) is None:
        return None
    import dataclasses

    blocks = tuple(b.with_supply(float(supply_voltage)) if isinstance(b, ESC) else b
                   for b in chain.blocks)
    if not isinstance(chain, ThrusterChain):
        return ThrusterChain(blocks, chain.input_kind, chain.name)
    return dataclasses.replace(chain, blocks=blocks)  # keeps its metadata (fit voltages, inflow)


def _preset_at(ref: str, supply_voltage: float, quiet: bool = False):
    import warnings

    from uuvid.thruster.presets import preset_chain

    with warnings.catch_warnings():
        if quiet:  # many voltages of one log: the caller says it once
            warnings.simplefilter("ignore")
        return preset_chain(ref, float(supply_voltage))


def supply_voltage_range(ref, chain) -> tuple[float, float, str] | None:
    """``(low, high, what)``: the supply voltages a chain's steady map rests on (the T200
    preset: its 12 and 16 V sheets; another chain with an ESC: the one voltage its ESC is set
    for), or ``None`` without an ESC."""
    from uuvid.thruster.presets import T200_SHEET_VOLTS

    v0 = supply_voltage_of(chain)
    if v0 is None:
        return None
    if str(ref) == "t200" or str(ref) in PHYSICAL_PRESETS:  # both fitted on the 12 and 16 V sheets
        return (*T200_SHEET_VOLTS, "Blue Robotics' T200 sheets")
    volts = getattr(chain, "fit_supply_voltages", None)
    if volts:
        return min(volts), max(volts), f"model {chain.name}'s fit_supply_voltages"
    return v0, v0, f"model {chain.name}'s ESC (its supply_voltage)"


def supply_voltage_warnings(ref, chain, supply_voltage: float, rel_tol: float = 0.05) -> list[str]:
    """One sentence when ``supply_voltage`` lies outside :func:`supply_voltage_range` by more than
    ``rel_tol`` (the prediction then extrapolates the model's voltage law); else empty."""
    rng = supply_voltage_range(ref, chain)
    if rng is None:
        return []
    lo, hi, what = rng
    v = float(supply_voltage)
    if lo * (1 - rel_tol) <= v <= hi * (1 + rel_tol):
        return []
    span = f"{lo:g} V" if lo == hi else f"{lo:g}–{hi:g} V"
    if not is_preset(ref) and not getattr(chain, "fit_supply_voltages", None):
        # a file without fit_supply_voltages records its ESC's voltage, not those of its data
        return [f"supply voltage {v:g} V differs from the {span} this model file's ESC is set "
                "for (the file does not record the voltages it was fitted at): the thrust follows "
                "the model's voltage law (V = duty × supply), backed by measurements only if it "
                "was fitted at that voltage too (e.g. both T200 sheets); check the value (a 4S "
                "battery is 12–16.8 V)"]
    return [f"supply voltage {v:g} V is outside the data's {span} ({what}): the thrust is "
            "extrapolated by the model's voltage law and is not backed by measurements; check the "
            "value (a 4S battery is 12–16.8 V) or fit the model on data at that voltage"]


def supply_law(ref, chain, quiet: bool = False):
    """``(f, text)``: ``f(V)`` is the chain at supply voltage ``V`` and ``text`` says how; ``None``
    when the chain cannot follow a supply voltage (no ESC block).  ``quiet``: no warning when a
    preset extrapolates beyond its sheets (e.g. the T200 outside 12–16 V).  ``f`` raises
    ``ValueError`` for a voltage that is not finite and > 0."""
    from uuvid.core.checks import positive
    from uuvid.thruster.presets import PRESETS

    v0 = supply_voltage_of(chain)
    if v0 is None:
        return None
    if str(ref) in PRESETS:
        return (lambda v: _preset_at(str(ref), positive("supply_voltage", v, "V"), quiet),
                f"thruster preset {ref}'s own voltage law (preset_chain at each voltage; "
                f"nominal {v0:g} V)")
    return (lambda v: at_supply(chain, positive("supply_voltage", v, "V")),
            f"the chain's ESC (set for {v0:g} V) at each voltage (V = duty × supply)")


def supply_data_range(ref) -> tuple[float, float] | None:
    """Supply voltages [V] a preset's data were taken at (Laidani's bench: 12 V; the T200 sheets:
    12 and 16 V); ``None`` for a model file or a preset without an ESC."""
    from uuvid.thruster.presets import LAIDANI_SUPPLY, T200_SHEET_VOLTS

    return {"laidani-a2212": (LAIDANI_SUPPLY, LAIDANI_SUPPLY), "t200": T200_SHEET_VOLTS,
            "t200-physical": T200_SHEET_VOLTS}.get(str(ref))


def supply_used(ref, chain, supply_voltage: float | None = None) -> tuple[float | None, str, list[str]]:
    """``(volts, source, warnings)``: the supply voltage [V] a prediction of ``chain`` (named
    ``ref``) uses, where it came from (the option, or the model's own default, said aloud) and a
    warning when it lies outside the preset's data (its voltage law extrapolates there)."""
    v0 = supply_voltage_of(chain)
    if v0 is None:
        if is_command_map(chain):
            return None, command_map_supply(chain)[0], []
        return None, "no ESC block: the model does not depend on a supply voltage", []
    if supply_voltage is None:
        what = "preset" if is_preset(ref) else "model file's ESC block"
        v, source = v0, f"default {v0:g} V (the {what}'s supply_voltage; set --supply-voltage"
    else:
        v, source = float(supply_voltage), f"{float(supply_voltage):g} V (--supply-voltage"
    source += _fit_range_said(chain, v) + ")"
    warns = []
    rng = supply_data_range(ref)
    if rng is not None and not (rng[0] - 1e-9 <= v <= rng[1] + 1e-9):
        span = f"{rng[0]:g} V" if rng[0] == rng[1] else f"{rng[0]:g}–{rng[1]:g} V"
        warns.append(f"supply {v:g} V is outside the {span} the preset {ref}'s data were taken at: "
                     "its voltage law extrapolates there (a map fitted at that supply may be used "
                     "past its fastest measured speed); do not trust it without data")
    return v, source, warns


def export_supply(ref, chain, supply_voltage: float | None = None) -> tuple:
    """``(chain, lines)``: the chain to write to a file, at ``supply_voltage`` when given (a
    preset by its own voltage law), and what to say: the voltage exported at, and — for a preset
    whose voltage law is its own (the T200's sheets) — that the file follows ``V = duty × supply``
    at another supply instead, with how far that lands from the preset's law at the other end of
    its data (the T200 exported at 16 V and used at 12 V gave 20 % less thrust, unsaid), and a
    warning (a line starting ``warning:``) when ``supply_voltage`` lies outside the voltages the
    model's data cover (:func:`supply_voltage_warnings`, as ``thruster predict`` says it)."""
    import numpy as np

    from uuvid.core.checks import supply_voltage as check_supply

    v0 = supply_voltage_of(chain)
    outside = []
    if supply_voltage is not None:
        supply_voltage = check_supply("supply_voltage", supply_voltage)
    if v0 is None and is_command_map(chain):  # the file is the same at any supply: said so
        source, warns = command_map_supply(chain, supply_voltage)
        return chain, [f"supply voltage: {source}"] + [f"warning: {w}" for w in warns]
    if supply_voltage is not None:
        law = supply_law(ref, chain, quiet=True)
        if law is None:
            raise ValueError(f"{chain.name} has no ESC block: --supply-voltage does not apply")
        # the range check of `thruster predict` (160 V for 16 was exported with only "87 % off")
        outside = [f"warning: {w}" for w in supply_voltage_warnings(ref, chain, supply_voltage)]
        chain, v0 = law[0](supply_voltage), supply_voltage
    if v0 is None:
        return chain, []
    lines = [f"supply voltage: exported at {v0:g} V"
             + (" (--supply-voltage" if supply_voltage is not None
                else f" (the {'preset' if is_preset(ref) else 'model'}'s own; set --supply-voltage")
             + _fit_range_said(chain, v0) + ")"]
    lines += outside
    from uuvid.thruster.presets import PRESETS

    rng = supply_data_range(ref)
    if rng is not None and rng[0] != rng[1] and str(ref) in PRESETS:
        other = rng[0] if abs(v0 - rng[0]) > abs(v0 - rng[1]) else rng[1]
        from uuvid.thruster.blocks import ESC

        esc = next(b for b in chain.blocks if isinstance(b, ESC))
        full = np.array([esc.saturation_low, esc.saturation_high])
        own = _preset_at(str(ref), other, quiet=True).steady_thrust(full)
        file_law = at_supply(chain, other).steady_thrust(full)
        off = float(np.max(np.abs(file_law - own) / np.maximum(np.abs(own), 1e-9)))
        lines.append(f"warning: the file is the {ref} preset at {v0:g} V; at another supply it "
                     f"follows V = duty × supply, not the preset's own voltage law — at {other:g} V "
                     f"its full-command thrust is {100 * off:.0f} % off the preset's; export one "
                     "file per supply voltage (--supply-voltage)")
    return chain, lines


def full_command_thrust(chain) -> tuple[float, float] | None:
    """(min, max) steady thrust of ``chain`` at its ESC's full reverse and forward commands
    (``saturation_low``/``high``), or ``None`` without an ESC or a finite command range."""
    import numpy as np

    from uuvid.thruster.blocks import ESC

    esc = next((b for b in chain.blocks if isinstance(b, ESC)), None)
    if esc is None or not (np.isfinite(esc.saturation_low) and np.isfinite(esc.saturation_high)):
        return None
    f = chain.steady_thrust(np.array([esc.saturation_low, esc.saturation_high]))
    return float(np.min(f)), float(np.max(f))
