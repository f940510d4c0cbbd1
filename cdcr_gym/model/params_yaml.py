"""RobotParams ↔ YAML: the file a calibration writes and every env reads.

The format is a mapping of :class:`~cdcr_gym.model.params.RobotParams` fields in SI units
(m, kg, Pa, N, rad), the geometry as a list of sections::

    youngs_modulus: 28000000000.0
    backbone_diameter: 0.005
    max_tension: 80.0
    backbone_density: 1900.0
    disk_mass: 0.01
    disk_radius: 0.035
    disk_thickness: 0.003
    sections:
    - length: 0.641
      n_disks: 9
      cable_radius: 0.0295
      cable_angles: [0.0, 2.0943951023931953, 4.1887902047863905]

Instead of ``sections`` a one-section robot may give ``length``, ``n_disks`` and
``cable_radius``; ``preset: paper`` starts from a named robot and the other keys override it.
The robot may also sit under a top-level ``robot:`` key, beside other sections of a larger file
(``cdcr-gym calibrate`` writes ``robot:``, ``backend:`` and ``calibration:``); only ``robot`` is
read here. Unknown keys are an error naming them. Floats are written with ``repr`` (exact round
trip: ``RobotParams.from_yaml(p.to_yaml()) == p``), in a form YAML 1.1 readers parse as floats.

Reading needs PyYAML (the ``[train]`` extra); writing does not.
"""

from __future__ import annotations

import math
from dataclasses import fields
from pathlib import Path
from typing import Any

from cdcr_gym.model.params import PRESETS, RobotParams, SectionParams

__all__ = ["params_to_dict", "params_from_dict", "dump_yaml", "to_yaml", "from_yaml", "load_yaml"]

_DERIVED = ("length", "n_disks", "cable_radius")
_SECTION_KEYS = tuple(f.name for f in fields(SectionParams))
#: keys of a top-level file that holds the robot under ``robot:``
_FILE_KEYS = ("robot", "backend", "calibration")


def params_to_dict(params: RobotParams) -> dict[str, Any]:
    """Plain-Python mapping of ``params`` (SI units; sections as a list of mappings)."""
    if not isinstance(params, RobotParams):
        raise ValueError(f"params must be a RobotParams, got {params!r}")
    out: dict[str, Any] = {}
    for f in fields(RobotParams):
        if f.name in ("sections",) + _DERIVED:
            continue
        out[f.name] = float(getattr(params, f.name))
    out["sections"] = [
        {
            "length": float(s.length),
            "n_disks": int(s.n_disks),
            "cable_radius": float(s.cable_radius),
            "cable_angles": [float(a) for a in s.cable_angles],
        }
        for s in params.sections
    ]
    return out


def params_from_dict(data: Any, where: str = "params") -> RobotParams:
    """RobotParams from a mapping (the YAML format of the module docstring).

    Raises:
        ValueError: naming the key (as a dotted path under ``where``) for unknown keys, a wrong
            type, or a value RobotParams rejects.
    """
    if not isinstance(data, dict):
        raise ValueError(f"{where} must be a mapping of RobotParams fields, got {data!r}")
    if "robot" in data and set(data) <= set(_FILE_KEYS):
        return params_from_dict(data["robot"], f"{where}.robot")
    allowed = {f.name for f in fields(RobotParams)} | {"preset"}
    unknown = sorted(set(data) - allowed)
    if unknown:
        raise ValueError(f"{where}: unknown key(s) {unknown}; accepted: {sorted(allowed)}")
    kwargs = {k: _number(v) for k, v in data.items() if k not in ("preset", "sections")}
    if "sections" in data:
        raw = data["sections"]
        if not isinstance(raw, list) or not raw:
            raise ValueError(f"{where}.sections must be a non-empty list of mappings, got {raw!r}")
        sections = []
        for j, s in enumerate(raw):
            if not isinstance(s, dict):
                raise ValueError(f"{where}.sections[{j}] must be a mapping, got {s!r}")
            bad = sorted(set(s) - set(_SECTION_KEYS))
            if bad:
                raise ValueError(
                    f"{where}.sections[{j}]: unknown key(s) {bad}; accepted: {list(_SECTION_KEYS)}"
                )
            section = {k: _number(v) for k, v in s.items()}
            if "cable_angles" in section and isinstance(section["cable_angles"], list):
                section["cable_angles"] = tuple(section["cable_angles"])
            sections.append(SectionParams(**section))
        kwargs["sections"] = tuple(sections)
    if "preset" in data:
        name = data["preset"]
        if name not in PRESETS:
            raise ValueError(f"{where}.preset must be one of {sorted(PRESETS)}, got {name!r}")
        return RobotParams.preset(name, **kwargs)
    return RobotParams(**kwargs)


def _number(value: Any) -> Any:
    """A string that reads as a float becomes one: YAML 1.1 (PyYAML) reads ``3.0e10`` or
    ``1e-3`` (no dot, or no exponent sign) as strings."""
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    if isinstance(value, list):
        return [_number(v) for v in value]
    return value


def _scalar(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            return {math.inf: ".inf", -math.inf: "-.inf"}.get(value, ".nan")
        text = repr(value)
        if "e" in text and "." not in text.split("e")[0]:  # YAML 1.1 wants 1.0e-05
            mantissa, exponent = text.split("e")
            text = f"{mantissa}.0e{exponent}"
        return text
    if value is None:
        return "null"
    text = str(value)
    return text if text.replace("_", "").replace("-", "").isalnum() else repr(text)


def dump_yaml(data: dict[str, Any], indent: int = 0) -> str:
    """A block-style YAML text of nested mappings, lists of mappings and lists of scalars (the
    subset these files use), floats written exactly."""
    pad = " " * indent
    lines = []
    for key, value in data.items():
        if isinstance(value, dict):
            lines.append(f"{pad}{key}:")
            lines.append(dump_yaml(value, indent + 2).rstrip("\n"))
        elif isinstance(value, (list, tuple)) and value and isinstance(value[0], dict):
            lines.append(f"{pad}{key}:")
            for item in value:
                body = dump_yaml(item, indent + 2).rstrip("\n").splitlines()
                lines.append(f"{pad}- {body[0].lstrip()}")
                lines.extend(body[1:])
        elif isinstance(value, (list, tuple)):
            lines.append(f"{pad}{key}: [{', '.join(_scalar(v) for v in value)}]")
        else:
            lines.append(f"{pad}{key}: {_scalar(value)}")
    return "\n".join(lines) + "\n"


def to_yaml(params: RobotParams, path: str | Path | None = None) -> str:
    """The YAML text of ``params``; also written to ``path`` if given."""
    text = dump_yaml(params_to_dict(params))
    if path is not None:
        Path(path).write_text(text)
    return text


def load_yaml(source: str | Path) -> Any:
    """Parse a YAML file (a ``Path`` or a path string) or a YAML text (a string with a newline)
    with PyYAML."""
    try:
        import yaml
    except ImportError as exc:  # pragma: no cover - pyyaml is in the [train] extra
        raise ImportError(
            "reading robot parameters from YAML needs PyYAML: pip install 'cdcr-gym[train]' "
            "(or pip install pyyaml)"
        ) from exc
    if isinstance(source, Path) or "\n" not in str(source):
        path = Path(source)
        if not path.is_file():
            raise ValueError(f"params file {str(path)!r} does not exist")
        text = path.read_text()
    else:
        text = str(source)
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ValueError(f"params YAML {str(source)[:80]!r} is not valid YAML: {exc}") from None


def from_yaml(source: str | Path) -> RobotParams:
    """RobotParams from a YAML file path or a YAML text (see the module docstring)."""
    where = "params" if "\n" in str(source) else str(source)
    return params_from_dict(load_yaml(source), where)
