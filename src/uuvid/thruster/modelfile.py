"""Thruster model files (YAML or TOML), validated with pydantic, with exact error paths.

A model file describes a chain of blocks in signal order::

    name: laidani-a2212
    input: command            # command | voltage | speed (default: what the first block takes)
    blocks:
      - type: esc
        a_fwd: 0.04364
        ...
      - type: first_order_motor   # or UUV Simulator names: FirstOrder, Yoerger, Bessa, ...
        gain: 131.3016
        time_constant: 0.01021
      - type: polynomial
        forward: [1.3506e-15, ...]
        reverse: [...]

or names a preset: ``preset: auv2-tunnel``.  Every block parameter without a natural default must
be given; an unknown key is an error; both name the path (``blocks[1].time_constant``).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import tomllib
import typing
from pathlib import Path
from typing import Any, Literal

import yaml

from uuvid.core.atomic import atomic_write_text
from uuvid.thruster.blocks import BLOCK_ALIASES, BLOCK_TYPES, Block, DCMotor, ParameterError
from uuvid.thruster.chain import ThrusterChain

#: Parameters that may be left out of a model file (they have a natural "absent" value).
OPTIONAL = {
    "esc": {"neutral", "deadzone_low", "deadzone_high", "saturation_low", "saturation_high",
            "command_unit", "curvature_fwd", "curvature_rev", "follows_supply"},
    "dc_motor": {"inductance", "propeller_inertia", "motor_viscous", "propeller_viscous",
                 "coulomb_torque", "gear_ratio", "torque_coefficient", "torque_coefficient_rev"},
    "tunnel_thruster": {"water_density", "profile_factor"},
    "quadratic": {"torque_pos", "torque_neg", "k_neg"},
    "deadzone": set(),
    "load_cell": set(),
    "driver": {"deadband_fwd", "deadband_rev", "offset", "gain_fwd", "gain_rev", "limit"},
    "healey": {"torque_inflow", "thrust_coefficient_rev", "viscous", "torque_coefficient"},
}


class ModelFileError(ValueError):
    """A model file is unreadable or invalid; the message names the file and the key path."""


class NotAModelFileError(ModelFileError):
    """The file is another kind of uuvid file (a vehicle, a scenario…), not a thruster model."""


#: Top-level keys only one kind of uuvid file has (:func:`other_kind`).
KIND_KEYS = {
    "a thruster model file": ("blocks", "preset"),
    "a vehicle file": ("rigid_body", "hydrodynamics", "thrusters"),
    "a scenario file": ("mission", "vehicle", "thruster_model", "current", "controller",
                        "duration", "battery_soc"),
}
#: What the top level of a thruster model file holds (said when a file is not one).
MODEL_FILE_KEYS = ("blocks (the chain in signal order, e.g. [{type: esc, ...}, {type: quadratic, "
                   "...}]), optionally name, input, description, source, inflow, fit_supply_voltages; "
                   "or preset: NAME")


def other_kind(raw: Any, own: str) -> str | None:
    """What other kind of uuvid file a document read by :func:`read_model_text` looks like, with
    the keys that tell (``"a vehicle file (it has rigid_body, thrusters)"``), when it has none of
    the keys of ``own`` (a key of :data:`KIND_KEYS`); else ``None``.  A file validated as the
    wrong kind lists every key as unknown and never says what it is."""
    if not isinstance(raw, dict) or any(k in raw for k in KIND_KEYS[own]):
        return None
    fmt = raw.get("format")
    if isinstance(fmt, str) and fmt.startswith(("uuvid-sweep/", "uuvid-uncertain-model/")):
        if fmt.startswith("uuvid-sweep/"):
            return f"an uncertainty sweep file (format: {fmt})"
        return f"an uncertain model file (format: {fmt}, kind: {raw.get('kind')})"
    for kind, keys in KIND_KEYS.items():
        hit = [k for k in keys if k in raw]
        if hit:
            return f"{kind} (it has {', '.join(hit)})"
    return None


def format_loc(loc) -> str:
    """pydantic error location → ``blocks[1].time_constant``."""
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out


def _annotation(tp):
    if tp in (float, "float"):
        return float
    if tp in (str, "str"):
        return str
    if tp in (bool, "bool"):
        return bool
    if tp == (float | None) or tp == "float | None":
        return float | None
    origin = typing.get_origin(tp)
    if tp == "tuple[float, ...]" or origin is tuple:
        return list[float]
    if tp in (DCMotor, "DCMotor"):
        return _SCHEMAS["dc_motor"]
    return Any


_SCHEMAS: dict = {}  # block type → pydantic schema (built on first use)


def _schema_for(type_name: str, cls: type[Block]):
    from pydantic import ConfigDict, create_model

    fields_ = {}
    hints = typing.get_type_hints(cls)
    optional = OPTIONAL.get(type_name, set())
    for f in dataclasses.fields(cls):
        ann = _annotation(hints.get(f.name, f.type))
        if f.name in optional:
            if f.default is not dataclasses.MISSING:
                default = f.default
            else:
                default = f.default_factory()  # type: ignore[misc]
            fields_[f.name] = (ann, default)
        else:
            fields_[f.name] = (ann, ...)
    fields_["type"] = (Literal[type_name], ...)
    return create_model(f"{cls.__name__}Schema", __config__=ConfigDict(extra="forbid"), **fields_)


@functools.cache
def _chain_schema():
    """The model-file schema, built on first use (a command that reads no model file does not pay
    for it, nor for importing pydantic)."""
    from pydantic import BaseModel, ConfigDict, Field, create_model

    # The nested motor is built first so the tunnel schema can refer to it.
    _SCHEMAS["dc_motor"] = _schema_for("dc_motor", BLOCK_TYPES["dc_motor"])
    for name, cls in BLOCK_TYPES.items():
        if name not in _SCHEMAS:
            _SCHEMAS[name] = _schema_for(name, cls)
    # The nested motor of a tunnel thruster carries no "type" key.
    motor_fields = {k: (v.annotation, v.default if not v.is_required() else ...)
                    for k, v in _SCHEMAS["dc_motor"].model_fields.items() if k != "type"}
    nested_motor = create_model("TunnelMotorSchema", __config__=ConfigDict(extra="forbid"),
                                **motor_fields)
    tunnel_fields = {k: (v.annotation if k != "motor" else nested_motor,
                         v.default if not v.is_required() else ...)
                     for k, v in _SCHEMAS["tunnel_thruster"].model_fields.items()}
    _SCHEMAS["tunnel_thruster"] = create_model("TunnelThrusterSchema",
                                               __config__=ConfigDict(extra="forbid"), **tunnel_fields)
    block_schema = typing.Annotated[typing.Union[tuple(_SCHEMAS.values())],  # noqa: UP007
                                    Field(discriminator="type")]

    class InflowParameterSchema(BaseModel):
        model_config = ConfigDict(extra="forbid")
        estimate: float
        sigma: float | None = None
        unit: str = ""

    class InflowSchema(BaseModel):
        """What a bench run in a flow identified (the blocks stay the bollard map)."""

        model_config = ConfigDict(extra="forbid")
        form: Literal["linear", "four-quadrant"]
        equation: str | None = None
        diameter_m: float | None = None
        parameters: dict[str, InflowParameterSchema]
        flow_levels_m_s: list[float] = []
        beta_range_deg: list[float] | None = None
        beta_ranges_deg: list[list[float]] | None = None
        correlation: dict | None = None
        source: str | None = None

    class ChainSchema(BaseModel):
        """A thruster model file."""

        model_config = ConfigDict(extra="forbid")
        name: str = "thruster"
        input: Literal["command", "voltage", "speed"] | None = None
        description: str | None = None
        source: str | None = None
        blocks: list[block_schema]
        inflow: InflowSchema | None = None
        fit_supply_voltages: list[typing.Annotated[float, Field(gt=0, allow_inf_nan=False)]] | None = None

    return ChainSchema


def _normalise(raw: Any, where: str) -> dict:
    if not isinstance(raw, dict):
        raise ModelFileError(f"{where}: expected a mapping at the top level, got {type(raw).__name__}")
    raw = dict(raw)
    blocks = raw.get("blocks")
    if isinstance(blocks, list):
        fixed = []
        for i, b in enumerate(blocks):
            if isinstance(b, dict) and "type" in b:
                if not isinstance(b["type"], str):
                    raise ModelFileError(
                        f"{where}: blocks[{i}].type: expected a block type name (a string), got "
                        f"{type(b['type']).__name__} {b['type']!r}; write e.g. 'type: quadratic'")
                b = dict(b)
                b["type"] = BLOCK_ALIASES.get(b["type"], b["type"])
                if b["type"] not in BLOCK_TYPES:
                    raise ModelFileError(
                        f"{where}: blocks[{i}].type: unknown block type {b['type']!r}; known: "
                        f"{sorted(BLOCK_TYPES)} (UUV Simulator names: {sorted(BLOCK_ALIASES)})")
            fixed.append(b)
        raw["blocks"] = fixed
    return raw


def chain_from_dict(raw: Any, where: str = "<model>") -> ThrusterChain:
    """Validate a model description (as loaded from YAML/TOML) and build the chain."""
    if isinstance(raw, dict) and "preset" in raw:
        from uuvid.thruster.presets import preset_chain

        extra = set(raw) - {"preset", "name"}
        if extra:
            raise ModelFileError(f"{where}: with 'preset', no other keys are allowed (got "
                                 f"{sorted(extra)})")
        try:
            return preset_chain(raw["preset"])
        except KeyError as e:
            raise ModelFileError(f"{where}: preset: {e.args[0]}") from None
    from pydantic import ValidationError

    raw = _normalise(raw, where)
    try:
        spec = _chain_schema().model_validate(raw)
    except ValidationError as e:
        kind = other_kind(raw, "a thruster model file")
        if kind:
            raise NotAModelFileError(f"{where}: not a thruster model file: it looks like {kind}; a "
                                     f"thruster model file has {MODEL_FILE_KEYS}") from None
        msgs = []
        for err in e.errors():
            loc = list(err["loc"])
            # drop the discriminator tag pydantic inserts (blocks.1.first_order.gain)
            if len(loc) >= 3 and loc[0] == "blocks" and isinstance(loc[1], int) and loc[2] in _SCHEMAS:
                del loc[2]
            kind = err["type"]
            text = {"missing": "missing parameter", "extra_forbidden": "unknown key"}.get(kind,
                                                                                       err["msg"])
            msgs.append(f"{where}: {format_loc(loc)}: {text}")
        raise ModelFileError("\n".join(msgs)) from None
    blocks = []
    for i, b in enumerate(spec.blocks):
        data = b.model_dump()
        type_name = data.pop("type")
        cls = BLOCK_TYPES[type_name]
        if type_name == "tunnel_thruster":
            try:
                data["motor"] = DCMotor(**data["motor"])
            except ParameterError as e:
                raise ModelFileError(f"{where}: blocks[{i}].motor.{e.param or ''}: {e}") from None
        for k, v in list(data.items()):
            if isinstance(v, list):
                data[k] = tuple(v)
        if type_name == "esc" and "follows_supply" not in b.model_fields_set and _is_offset(data):
            data["follows_supply"] = False  # written before the key existed: not a voltage source
        try:
            blocks.append(cls(**data))
        except ParameterError as e:
            key = f"blocks[{i}].{e.param}" if e.param else f"blocks[{i}] ({type_name})"
            raise ModelFileError(f"{where}: {key}: {e}") from None
    inflow = None if spec.inflow is None else spec.inflow.model_dump(exclude_none=True)
    try:
        volts = None if not spec.fit_supply_voltages else tuple(sorted(set(spec.fit_supply_voltages)))
        return ThrusterChain(tuple(blocks), input_kind=spec.input, name=spec.name, inflow=inflow,
                             fit_supply_voltages=volts)
    except ParameterError as e:
        raise ModelFileError(f"{where}: {e}") from None


def _is_offset(esc: dict) -> bool:
    """An ESC block as :func:`uuvid.identify.thruster.workflow.offset_esc` wrote it (unit gain,
    ``command − neutral``, no dead band, its 'supply' half the data's command span): a map of the
    command fitted at the bench's supply, not a voltage source to rescale."""
    n = esc.get("neutral", 0.0)
    lo, hi = esc.get("saturation_low"), esc.get("saturation_high")
    if n == 0 or lo is None or hi is None or not (math.isfinite(lo) and math.isfinite(hi)):
        return False
    span = max(hi - n, n - lo)
    return (esc.get("a_fwd") == 1.0 and esc.get("a_rev") == 1.0 and esc.get("b_fwd") == -n
            and esc.get("b_rev") == -n and esc.get("deadzone_low") == n == esc.get("deadzone_high")
            and math.isclose(esc.get("supply_voltage", 12.0), span, rel_tol=1e-9)
            and not esc.get("curvature_fwd") and not esc.get("curvature_rev"))


def _duplicate_key(root):
    """``(key path, first line, second line)`` of the first mapping key given twice, or None
    (iterative, each node once: deep nesting and alias bombs stay cheap)."""
    seen, stack = set(), [(root, "")]
    while stack:
        node, path = stack.pop()
        if id(node) in seen:  # an alias: checked where it was defined
            continue
        seen.add(id(node))
        children = []
        if isinstance(node, yaml.MappingNode):
            first: dict = {}
            for k, v in node.value:
                kp = path
                if isinstance(k, yaml.ScalarNode) and k.tag != "tag:yaml.org,2002:merge":
                    kp = f"{path}.{k.value}" if path else str(k.value)
                    if k.value in first:
                        return kp, first[k.value], k.start_mark.line + 1
                    first[k.value] = k.start_mark.line + 1
                children.append((v, kp))
        elif isinstance(node, yaml.SequenceNode):
            children = [(v, f"{path}[{i}]") for i, v in enumerate(node.value)]
        stack.extend(reversed(children))
    return None


def load_yaml_unique(text: str, where: str):
    """Safe-load YAML text, rejecting a mapping key given twice (PyYAML keeps the last one
    silently): raises :class:`ModelFileError` naming ``where``, the key path and both lines."""
    # libyaml's loader when PyYAML has it (same safe subset, ~10× faster)
    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        dup = _duplicate_key(node)
        if dup:
            raise ModelFileError(f"{where}: duplicated key {dup[0]} (lines {dup[1]} and {dup[2]}); "
                                 "each key may appear once per mapping: remove or rename one")
        return loader.construct_document(node)
    finally:
        loader.dispose()


def _tab_hint(text: str, error) -> str:
    """A YAML error at a line that starts with a tab says so: PyYAML's "found character '\\t'
    that cannot start any token" does not say that YAML indents with spaces only."""
    mark = getattr(error, "problem_mark", None)
    if mark is None:
        return ""
    lines = text.splitlines()
    i = int(mark.line)
    line = lines[i] if 0 <= i < len(lines) else ""
    if "\t" not in line[:len(line) - len(line.lstrip())]:
        return ""
    return (f" — line {i + 1} is indented with a tab: YAML indents with spaces only "
            "(replace the tab by spaces)")


def read_model_text(path: str | Path) -> dict:
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as e:
        raise ModelFileError(f"{path}: cannot read model file ({e.strerror})") from None
    except UnicodeDecodeError as e:
        line = path.read_bytes()[:e.start].count(b"\n") + 1
        raise ModelFileError(f"{path}: line {line}: not UTF-8 text (byte 0x{e.object[e.start]:02x} "
                             f"at offset {e.start}); save the model file as UTF-8") from None
    try:
        if path.suffix.lower() == ".toml":
            return tomllib.loads(text)
        raw = load_yaml_unique(text, str(path))
    except (yaml.YAMLError, tomllib.TOMLDecodeError) as e:
        raise ModelFileError(f"{path}: not valid {'TOML' if path.suffix == '.toml' else 'YAML'}: "
                             f"{e}{_tab_hint(text, e)}") from None
    check_expanded_size(raw, str(path))
    return raw


MAX_NODES = 1_000_000
"""Most values a model, vehicle or scenario file may hold once YAML aliases are expanded."""


def check_expanded_size(raw: Any, where: str, limit: int = MAX_NODES) -> int:
    """The number of values in ``raw`` with every alias expanded (counted without expanding);
    :class:`ModelFileError` past ``limit`` or for a value that contains itself (an alias bomb
    or a recursive anchor would otherwise take unbounded time and memory to validate)."""
    sizes: dict[int, int] = {}
    active: set[int] = set()

    def size(x, key: str) -> int:
        if not isinstance(x, (dict, list)):
            return 1
        i = id(x)
        if i in sizes:
            return sizes[i]
        if i in active:
            raise ModelFileError(f"{where}: {key or 'top level'}: a YAML anchor refers to itself "
                                 "(recursive alias); write the value out")
        active.add(i)
        items = x.items() if isinstance(x, dict) else enumerate(x)
        n = 1
        for k, v in items:
            n += size(v, f"{key}.{k}" if isinstance(x, dict) and key else
                      str(k) if isinstance(x, dict) else f"{key}[{k}]")
            if n > limit:
                raise ModelFileError(
                    f"{where}: {key or 'top level'}: more than {limit:,} values once YAML "
                    "aliases are expanded (an alias bomb?); write the values out or use fewer "
                    "aliases")
        active.discard(i)
        sizes[i] = n
        return n

    return size(raw, "")


def load_chain(path: str | Path) -> ThrusterChain:
    """Load and validate a thruster model file (``.yaml``/``.yml``/``.toml``)."""
    return chain_from_dict(read_model_text(path), where=str(path))


def _clean(v):
    if isinstance(v, float) and math.isinf(v):
        return None
    if isinstance(v, dict):
        return {k: _clean(x) for k, x in v.items() if _clean(x) is not None or x is None}
    if isinstance(v, (list, tuple)):
        return [_clean(x) for x in v]
    return v


def chain_to_dict(chain: ThrusterChain) -> dict:
    """Plain-data form of a chain, loadable again by :func:`chain_from_dict`."""
    blocks = []
    for b in chain.blocks:
        d = b.to_dict()
        if "motor" in d and isinstance(d["motor"], DCMotor):
            m = d["motor"].to_dict()
            m.pop("type")
            d["motor"] = m
        # infinite saturation limits and None ("same as forward") are defaults; leave them out
        # follows_supply: true is the default, written only where a file without the key would
        # be read as a command stage (_is_offset): a save and load keeps what the block is
        d = {k: v for k, v in d.items()
             if v is not None and not (isinstance(v, float) and math.isinf(v))
             and not (k == "follows_supply" and v is True and not _is_offset(b.to_dict()))}
        if isinstance(d.get("motor"), dict):
            d["motor"] = {k: v for k, v in d["motor"].items() if v is not None}
        blocks.append(d)
    out = {"name": chain.name, "input": chain.input_kind, "blocks": blocks}
    if chain.inflow is not None:
        out["inflow"] = _clean(chain.inflow)
    if chain.fit_supply_voltages:
        out["fit_supply_voltages"] = [float(v) for v in chain.fit_supply_voltages]
    return out


def save_chain(chain: ThrusterChain, path: str | Path) -> Path:
    """Write a chain as a YAML (or TOML by suffix) model file, atomically."""
    path = Path(path)
    data = chain_to_dict(chain)
    if path.suffix.lower() == ".toml":
        text = _to_toml(data)
    else:
        text = yaml.safe_dump(data, sort_keys=False)
    atomic_write_text(path, text)
    return path


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(float(v)) if isinstance(v, float) else str(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def _to_toml(data: dict) -> str:
    lines = [f"name = {_toml_value(data['name'])}", f"input = {_toml_value(data['input'])}", ""]
    for b in data["blocks"]:
        lines.append("[[blocks]]")
        nested = {}
        for k, v in b.items():
            if isinstance(v, dict):
                nested[k] = v
            else:
                lines.append(f"{k} = {_toml_value(v)}")
        for k, sub in nested.items():
            lines.append(f"[blocks.{k}]")
            lines.extend(f"{kk} = {_toml_value(vv)}" for kk, vv in sub.items())
        lines.append("")
    if "inflow" in data:
        _toml_table(lines, "inflow", data["inflow"])
    return "\n".join(lines)


def _toml_table(lines: list, name: str, table: dict) -> None:
    """``[name]`` with its scalar and list keys, then its sub-tables as ``[name.key]``."""
    lines.append(f"[{name}]")
    subs = {}
    for k, v in table.items():
        if isinstance(v, dict):
            subs[k] = v
        elif v is not None:  # TOML has no null: an absent key reads back as None
            lines.append(f"{k} = {_toml_value(v)}")
    lines.append("")
    for k, v in subs.items():
        _toml_table(lines, f'{name}."{k}"' if not k.isidentifier() else f"{name}.{k}", v)
