"""Export thruster models to UUV Simulator (Gazebo thruster plugin) and read them back.

UUV Simulator's thruster = a *dynamics* element (``ZeroOrder``, ``FirstOrder``, ``Yoerger``,
``Bessa``) acting on the plugin's input command + a *conversion* element (``Basic``, ``Bessa``,
``LinearInterp``) from the dynamic state to thrust (uuv_gazebo_plugins, Dynamics.cc and
ThrusterConversionFcn.cc; Laidani et al. §4).  A uuvid chain made of exactly those blocks exports
exactly.  Other chains are exported as the closest UUV Simulator equivalent and say so in an XML
comment:

* a first-order motor (``Ω/V = K_m/(1+τs)``) becomes ``FirstOrder(τ)`` and its gain moves into the
  conversion (the state is then the command, filtered);
* static blocks before the dynamics (an ESC with dead zone and saturation) are folded into a
  ``LinearInterp`` table of the steady map command → thrust, so the steady state is exact and the
  dynamics act on the command instead of the motor voltage;
* static maps after the dynamics that UUV Simulator lacks (polynomials) become ``LinearInterp``.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET

import numpy as np

from uuvid.thruster.blocks import (
    BessaDynamics,
    DeadZoneMap,
    FirstOrder,
    FirstOrderMotor,
    QuadraticMap,
    TableMap,
    Yoerger,
    ZeroOrder,
)
from uuvid.thruster.chain import ThrusterChain

_DYNAMICS = (ZeroOrder, FirstOrder, Yoerger, BessaDynamics, FirstOrderMotor)


#: File endings read as a UUV Simulator plugin's XML where a model is expected: the export's own
#: ``.xml``, and the robot-description files such snippets live in (xacro macros, URDF, SDF).
PLUGIN_SUFFIXES = (".xml", ".xacro", ".urdf", ".sdf")


class ExportError(ValueError):
    """The chain cannot be expressed in the target format."""


#: Most bytes the LinearInterp table's XML text may take (≈ 25 bytes of text a point; building it
#: takes ≈ 160 bytes of memory a point): 50 MB is 2 million points, far more than linear
#: interpolation of a smooth thrust map needs.
MAX_TABLE_BYTES = 50e6
_TABLE_TEXT_BYTES, _TABLE_MEMORY_BYTES = 25, 160


def check_export_options(thruster_id: int, table_points: int) -> None:
    """``ExportError`` naming the parameter for a thruster id below 0 or a table of fewer than 2
    points or more than :data:`MAX_TABLE_BYTES` of text — before anything is tabulated."""
    if int(thruster_id) < 0:
        raise ExportError(f"thruster_id = {thruster_id}: expected a thruster index >= 0 (the "
                          "plugin's <thrusterID>)")
    n = int(table_points)
    if n < 2:
        raise ExportError(f"table_points = {n}: expected at least 2")
    if n * _TABLE_TEXT_BYTES > MAX_TABLE_BYTES:
        raise ExportError(
            f"table_points = {n:,} would write ≈ {n * _TABLE_TEXT_BYTES / 1e9:.3g} GB of XML "
            f"(≈ {_TABLE_TEXT_BYTES} bytes a point) and need ≈ "
            f"{n * _TABLE_MEMORY_BYTES / 1e9:.3g} GB of memory to build, more than the "
            f"{MAX_TABLE_BYTES / 1e6:g} MB a table may take; give at most "
            f"{int(MAX_TABLE_BYTES // _TABLE_TEXT_BYTES):,} points (a few hundred follow a "
            "smooth thrust map)")


def _fmt(v: float) -> str:
    return repr(float(v))


def _dynamics_element(block) -> tuple[ET.Element, float]:
    """(<dynamics> element, gain moved into the conversion)."""
    el = ET.Element("dynamics")
    gain = 1.0
    if block is None or isinstance(block, ZeroOrder):
        ET.SubElement(el, "type").text = "ZeroOrder"
    elif isinstance(block, (FirstOrder, FirstOrderMotor)):
        ET.SubElement(el, "type").text = "FirstOrder"
        ET.SubElement(el, "timeConstant").text = _fmt(block.time_constant)
        if isinstance(block, FirstOrderMotor):
            gain = block.gain
    elif isinstance(block, Yoerger):
        ET.SubElement(el, "type").text = "Yoerger"
        ET.SubElement(el, "alpha").text = _fmt(block.alpha)
        ET.SubElement(el, "beta").text = _fmt(block.beta)
    elif isinstance(block, BessaDynamics):
        ET.SubElement(el, "type").text = "Bessa"
        for tag, v in (("Jmsp", block.jmsp), ("Kv1", block.kv1), ("Kv2", block.kv2),
                       ("Kt", block.kt), ("Rm", block.rm)):
            ET.SubElement(el, tag).text = _fmt(v)
    else:  # pragma: no cover - guarded by caller
        raise ExportError(f"no UUV Simulator dynamics for {block.TYPE}")
    return el, gain


def _table_element(x: np.ndarray, y: np.ndarray) -> ET.Element:
    el = ET.Element("conversion")
    ET.SubElement(el, "type").text = "LinearInterp"
    ET.SubElement(el, "inputValues").text = " ".join(f"{v:.10g}" for v in x)
    ET.SubElement(el, "outputValues").text = " ".join(f"{v:.10g}" for v in y)
    return el


def uuv_simulator_losses(chain: ThrusterChain) -> list[str]:
    """What a UUV Simulator export of ``chain`` leaves out (said in the file and by the CLI):
    the inflow section — the plugin's thrust knows no water speed."""
    inflow = getattr(chain, "inflow", None)
    if not inflow:
        return []
    form = inflow.get("form", "") if isinstance(inflow, dict) else ""
    return [f"the model's inflow section ({form + ' ' if form else ''}thrust falling with the water "
            "speed through the propeller) is not exported: UUV Simulator's thruster plugin gives "
            "the bollard thrust (u_a = 0) at every speed"]


def _exact_conversion(before: list, after: list, gain: float) -> bool:
    """Whether the map after the dynamics is one of UUV Simulator's conversions (no table)."""
    # x|x| maps absorb a gain g exactly (g x)|g x| = g² x|x|; a table does not
    return (not before and len(after) == 1
            and (isinstance(after[0], (QuadraticMap, DeadZoneMap))
                 or (isinstance(after[0], TableMap) and gain == 1.0)))


def uuv_simulator_is_exact(chain: ThrusterChain) -> bool:
    """Whether :func:`to_uuv_simulator` writes ``chain`` with an exact conversion (Basic, Bessa or
    the chain's own table) rather than a ``LinearInterp`` table of its steady map — when
    ``command_range`` and ``table_points`` have no effect."""
    blocks = list(chain.blocks)
    dyn_idx = [i for i, b in enumerate(blocks) if b.n_states > 0 or isinstance(b, ZeroOrder)]
    k = dyn_idx[0] if dyn_idx else -1
    gain = blocks[k].gain if k >= 0 and isinstance(blocks[k], FirstOrderMotor) else 1.0
    return _exact_conversion(blocks[:max(k, 0)], blocks[k + 1:] if k >= 0 else blocks, gain)


def model_corners(chain: ThrusterChain) -> list[float]:
    """The commands where the steady map of ``chain`` bends (an ESC's or a driver's saturation,
    dead-zone edges, and where its voltage reaches the supply or output limit), sorted; a table
    holds the map there exactly only when they are points of it.  Empty for a chain whose first
    block is no ESC/driver or that does not take a command."""
    from uuvid.thruster.blocks import ESC, Driver

    if chain.input_kind != "command" or not chain.blocks or not isinstance(chain.blocks[0], (ESC, Driver)):
        return []
    a_f, b_f, a_r, b_r, dz_lo, dz_hi, sat_lo, sat_hi, limit = chain.blocks[0].params_array()[:9]
    pts = [dz_lo, dz_hi, sat_lo, sat_hi]
    if math.isfinite(limit):  # |V| reaches the supply (ESC) or the output limit (driver)
        if a_f > 0:
            pts.append((limit - b_f) / a_f)
        if a_r > 0:
            pts.append((-limit - b_r) / a_r)
    lo_ok, hi_ok = (sat_lo if math.isfinite(sat_lo) else -math.inf), sat_hi
    return sorted({float(c) for c in pts if math.isfinite(c) and lo_ok <= c <= hi_ok})


def table_inputs(lo: float, hi: float, n: int, corners=()) -> np.ndarray:
    """``n`` table inputs over ``[lo, hi]`` with every corner inside it a point: the intervals
    between corners are shared out in proportion to their length (each at least one), evenly
    spaced within; ``n`` grows to hold the corners when it is smaller (said by the caller)."""
    tol = 1e-7 * (hi - lo)  # corners this close are one (a supply limit met at saturation)
    knots = [lo]
    for c in sorted(corners):
        if knots[-1] + tol < c < hi - tol:
            knots.append(float(c))
    knots.append(hi)
    spans = np.diff(knots)
    m = max(int(n) - 1, len(spans))  # intervals
    share = spans / spans.sum() * m
    k = np.maximum(np.floor(share).astype(int), 1)
    while k.sum() > m:  # the minimum of one pushed it over (m >= len(spans): some k > 1)
        k[np.argmax(k)] -= 1
    frac = share - k
    while k.sum() < m:  # largest remainders first
        j = int(np.argmax(frac))
        k[j] += 1
        frac[j] -= 1.0
    pieces = [np.linspace(a, b, int(j) + 1)[:-1] for a, b, j in zip(knots[:-1], knots[1:], k)]
    return np.concatenate([*pieces, [hi]])


def to_uuv_simulator(chain: ThrusterChain, *, thruster_id: int = 0, link_name: str | None = None,
                     joint_name: str | None = None, command_range: tuple[float, float] | None = None,
                     table_points: int = 101) -> str:
    """The ``<plugin>`` snippet (dynamics + conversion) for UUV Simulator's thruster plugin."""
    check_export_options(thruster_id, table_points)
    blocks = list(chain.blocks)
    notes: list[str] = uuv_simulator_losses(chain)
    dyn_idx = [i for i, b in enumerate(blocks) if b.n_states > 0 or isinstance(b, ZeroOrder)]
    if len(dyn_idx) > 1:
        raise ExportError(f"{chain.name}: {len(dyn_idx)} dynamic blocks "
                          f"({', '.join(blocks[i].TYPE for i in dyn_idx)}); UUV Simulator has one "
                          "dynamics element per thruster")
    if dyn_idx and not isinstance(blocks[dyn_idx[0]], _DYNAMICS):
        raise ExportError(f"{chain.name}: block {dyn_idx[0]} ({blocks[dyn_idx[0]].TYPE}) has no "
                          "UUV Simulator dynamics model (use FirstOrder, Yoerger or Bessa, or fit "
                          "one with `uuvid thruster fit`)")
    k = dyn_idx[0] if dyn_idx else -1
    before = blocks[:max(k, 0)]
    dyn = blocks[k] if k >= 0 else None
    after = blocks[k + 1:] if k >= 0 else blocks
    dyn_el, gain = _dynamics_element(dyn)
    if isinstance(dyn, FirstOrderMotor):
        notes.append(f"first-order motor gain K_m = {gain:g} moved into the conversion")
    if _exact_conversion(before, after, gain):
        c = after[0]
        g2 = gain * gain
        if gain != 1.0:
            notes[-1] = (f"first-order motor gain K_m = {gain:g} moved into the conversion "
                         f"(rotor constants × K_m², dead-zone widths / K_m²: exact)")
        conv = ET.Element("conversion")
        if isinstance(c, QuadraticMap) and c.k_pos == c.k_neg:
            ET.SubElement(conv, "type").text = "Basic"
            ET.SubElement(conv, "rotorConstant").text = _fmt(c.k_pos * g2)
        elif isinstance(c, (QuadraticMap, DeadZoneMap)):
            if isinstance(c, QuadraticMap):  # per direction: Bessa's conversion with δ = 0
                c = DeadZoneMap(rotor_constant_l=c.k_neg, rotor_constant_r=c.k_pos)
                notes.append("quadratic map with k_pos ≠ k_neg written as the Bessa conversion "
                             "with deltaL = deltaR = 0 (rotorConstantL = k_neg, rotorConstantR = "
                             "k_pos)")
            ET.SubElement(conv, "type").text = "Bessa"
            for tag, v in (("rotorConstantL", c.rotor_constant_l * g2),
                           ("rotorConstantR", c.rotor_constant_r * g2),
                           ("deltaL", c.delta_l / g2), ("deltaR", c.delta_r / g2)):
                ET.SubElement(conv, tag).text = _fmt(v)
        else:
            conv = _table_element(np.array(c.input_values), np.array(c.output_values))
        exact = True
    else:
        # Steady map from the plugin command to thrust, tabulated.
        lo, hi = command_range or _default_range(chain)
        x = table_inputs(lo, hi, table_points, model_corners(chain))
        corners = [float(c) for c in x[np.isin(x, model_corners(chain))]]
        if before:
            notes.append(f"static blocks before the dynamics ({', '.join(b.TYPE for b in before)}) "
                         "folded into the conversion table; the dynamics now act on the command")
        # the whole chain's steady map: exact whatever the blocks, and the table input is the
        # plugin command (the dynamics have unit gain: any motor gain lives in the table)
        y = chain.steady_thrust(x)
        # the command at rest: an ESC's neutral, a driver's offset (a dynamic fit on PWM)
        neutral = next((b.neutral if b.TYPE == "esc" else b.offset for b in blocks
                        if b.TYPE in ("esc", "driver")), 0.0)
        if neutral:
            x = x - neutral
            notes.append(f"plugin command = command − {neutral:g} (neutral at 0, so the dynamic "
                         "state starts at rest)")
        conv = _table_element(x, y)
        exact = False
        notes.append(f"conversion tabulated at {x.size} points over [{lo:g}, {hi:g}]"
                     + (f" with the map's corners ({', '.join(f'{c:g}' for c in corners)}) on it"
                        if corners else "")
                     + (f" ({table_points} asked for: too few to hold the corners)"
                        if x.size != table_points else ""))
    plugin = ET.Element("plugin", name=f"{chain.name}_{thruster_id}_thruster_model",
                        filename="libuuv_thruster_ros_plugin.so")
    ET.SubElement(plugin, "linkName").text = link_name or f"thruster_{thruster_id}"
    ET.SubElement(plugin, "jointName").text = joint_name or f"thruster_{thruster_id}_joint"
    ET.SubElement(plugin, "thrusterID").text = str(thruster_id)
    ET.SubElement(plugin, "gain").text = "1"
    plugin.append(dyn_el)
    plugin.append(conv)
    ET.indent(plugin)
    if chain.input_kind != "command":
        notes.append(f"the plugin command is the model's input, the {chain.input_kind}")
    verdict = ("exact" if not chain.inflow else "exact at bollard") + ("; " if notes else "") \
        if exact else "approximate: "
    header = (f"<!-- uuvid export of thruster model '{chain.name}' "
              f"({' -> '.join(b.TYPE for b in blocks)}); {verdict}{'; '.join(notes)} -->")
    return header + "\n" + ET.tostring(plugin, encoding="unicode") + "\n"


def _default_range(chain: ThrusterChain) -> tuple[float, float]:
    from uuvid.thruster.blocks import ESC

    for b in chain.blocks:
        if isinstance(b, ESC) and math.isfinite(b.saturation_low) and math.isfinite(b.saturation_high):
            span = b.saturation_high - b.saturation_low
            return b.saturation_low - 0.25 * span, b.saturation_high + 0.25 * span
    raise ExportError(f"{chain.name}: its map ({', '.join(b.TYPE for b in chain.blocks)}) has no "
                      "exact UUV Simulator conversion and no ESC range to tabulate it over; give "
                      "the input range: command_range=(low, high), on the command line "
                      f"--command-range LOW:HIGH (in the model's input, {chain.input_kind}; e.g. "
                      "the bench data's range)")


def from_uuv_simulator(xml: str, name: str = "uuv-simulator") -> ThrusterChain:
    """Read a UUV Simulator thruster ``<plugin>`` snippet back into a chain (command input).
    uuvid's export of a model with a neutral (``plugin command = command − N`` in its header
    comment) comes back with a driver in front taking ``N`` off, so it takes the command again."""
    text = xml[xml.index("<plugin"):] if "<plugin" in xml else xml
    if "</plugin>" in text:  # a snippet inside a xacro macro, URDF or SDF: the plugin alone
        text = text[:text.index("</plugin>") + len("</plugin>")]
    root = ET.fromstring(text)
    dyn_el, conv_el = root.find("dynamics"), root.find("conversion")
    if dyn_el is None or conv_el is None:
        raise ExportError("the snippet needs both <dynamics> and <conversion> elements")

    def num(el, tag):
        child = el.find(tag)
        if child is None or child.text is None:
            raise ExportError(f"<{el.tag}> of type {el.findtext('type')} lacks <{tag}>")
        return float(child.text)

    kind = dyn_el.findtext("type")
    if kind == "ZeroOrder":
        dyn = ZeroOrder()
    elif kind == "FirstOrder":
        dyn = FirstOrder(time_constant=num(dyn_el, "timeConstant"))
    elif kind == "Yoerger":
        dyn = Yoerger(alpha=num(dyn_el, "alpha"), beta=num(dyn_el, "beta"))
    elif kind == "Bessa":
        dyn = BessaDynamics(jmsp=num(dyn_el, "Jmsp"), kv1=num(dyn_el, "Kv1"), kv2=num(dyn_el, "Kv2"),
                            kt=num(dyn_el, "Kt"), rm=num(dyn_el, "Rm"))
    else:
        raise ExportError(f"unknown UUV Simulator dynamics type {kind!r}")
    ckind = conv_el.findtext("type")
    if ckind == "Basic":
        conv = QuadraticMap.basic(num(conv_el, "rotorConstant"))
    elif ckind == "Bessa":
        conv = DeadZoneMap(num(conv_el, "rotorConstantL"), num(conv_el, "rotorConstantR"),
                           num(conv_el, "deltaL"), num(conv_el, "deltaR"))
    elif ckind == "LinearInterp":
        xs = [float(v) for v in (conv_el.findtext("inputValues") or "").split()]
        ys = [float(v) for v in (conv_el.findtext("outputValues") or "").split()]
        conv = TableMap(tuple(xs), tuple(ys))
    else:
        raise ExportError(f"unknown UUV Simulator conversion type {ckind!r}")
    # uuvid's own export of a model whose rest command is not 0 says the plugin takes
    # command − neutral: read back, the chain takes the command again (a driver shifting it)
    m = re.search(r"plugin command = command − ([-+0-9.eE]+)", xml[:xml.index("<plugin")]
                  if "<plugin" in xml else "")
    if m:
        from uuvid.thruster.blocks import Driver

        return ThrusterChain((Driver(offset=float(m.group(1))), dyn, conv), input_kind="command",
                             name=name)
    return ThrusterChain((dyn, conv), input_kind="command", name=name)


#: The options that only the UUV Simulator export reads (library name → what they set).
_PLUGIN_ONLY = {"thruster_id": "the plugin's <thrusterID>",
                "table_points": "the points of its LinearInterp table",
                "command_range": "the input range of its LinearInterp table"}
#: ``table_points`` of :func:`to_uuv_simulator` when none is given.
DEFAULT_TABLE_POINTS = 101


def parse_command_range(spec: str) -> tuple[float, float]:
    """``"LOW:HIGH"`` → ``(low, high)``; ``ExportError`` naming ``command_range`` otherwise."""
    try:
        lo, hi = (float(v) for v in str(spec).split(":"))
        if not (lo < hi) or not all(map(math.isfinite, (lo, hi))):
            raise ValueError
    except ValueError:
        raise ExportError(f"command_range: expected LOW:HIGH with LOW < HIGH, got {spec!r}") from None
    return lo, hi


def export_model(chain: ThrusterChain, to: str, *, thruster_id: int | None = None,
                 table_points: int | None = None,
                 command_range: str | tuple[float, float] | None = None) -> tuple[str, list[str]]:
    """``(text, lines to say)``: ``chain`` as a uuvid model file (``to`` ``yaml`` or ``toml``) or
    a UUV Simulator plugin snippet (``uuv-simulator``, :func:`to_uuv_simulator`).  The lines are
    ``warning: …`` (what the plugin leaves out) and ``note: …`` (``table_points`` and
    ``command_range`` given for a chain whose conversion is exact: no table, no effect).  Options
    of the plugin given for a model file are an :class:`ExportError` naming them (in backticks,
    ```name=```), as is an unknown ``to``."""
    given = {k: v for k, v in (("thruster_id", thruster_id), ("table_points", table_points),
                               ("command_range", command_range)) if v is not None}
    if to in ("yaml", "toml"):
        if given:
            one = len(given) == 1
            raise ExportError(f"{' and '.join(f'`{k}=`' for k in given)} appl{'ies' if one else 'y'} "
                              f"to the uuv-simulator export only ({'; '.join(_PLUGIN_ONLY[k] for k in given)}"
                              f"); a {to} model file has no such thing: leave {'it' if one else 'them'} "
                              "out, or give `to=` uuv-simulator")
        import yaml

        from uuvid.thruster.modelfile import _to_toml, chain_to_dict

        d = chain_to_dict(chain)
        return (_to_toml(d) if to == "toml" else yaml.safe_dump(d, sort_keys=False)), []
    if to != "uuv-simulator":
        raise ExportError(f"to: expected yaml, toml or uuv-simulator, got {to!r}")
    rng = parse_command_range(command_range) if isinstance(command_range, str) else command_range
    check_export_options(thruster_id or 0, DEFAULT_TABLE_POINTS if table_points is None else table_points)
    said = [f"warning: {w}" for w in uuv_simulator_losses(chain)]
    idle = [k for k in ("table_points", "command_range") if k in given]
    if idle and uuv_simulator_is_exact(chain):
        said.append(f"note: {' and '.join(f'`{k}=`' for k in idle)} have no effect: {chain.name}'s "
                    "conversion is exact (one of UUV Simulator's own, no table to tabulate)")
    text = to_uuv_simulator(chain, thruster_id=thruster_id or 0, command_range=rng,
                            table_points=DEFAULT_TABLE_POINTS if table_points is None else table_points)
    return text, said
