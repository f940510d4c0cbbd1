"""Plain YAML text ↔ nested mappings, for the robot and calibration files.

Writing uses no library (block style, floats written exactly with ``repr``, in a form YAML 1.1
readers parse as floats); reading needs PyYAML (the ``[train]`` extra) and refuses a mapping with
a duplicate key (PyYAML would silently keep the last one). No cdcr_gym imports: this module sits
below :mod:`cdcr_gym.model.params`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

__all__ = ["dump_yaml", "load_yaml", "number"]


def number(value: Any) -> Any:
    """A string that reads as a float becomes one: YAML 1.1 (PyYAML) reads ``3.0e10`` or
    ``1e-3`` (no dot, or no exponent sign) as strings."""
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    if isinstance(value, list):
        return [number(v) for v in value]
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
        return yaml.load(text, Loader=_unique_key_loader(yaml))  # noqa: S506 (a SafeLoader)
    except yaml.YAMLError as exc:
        raise ValueError(f"params YAML {str(source)[:80]!r} is not valid YAML: {exc}") from None


def _unique_key_loader(yaml):
    """A ``yaml.SafeLoader`` subclass whose mappings refuse duplicate keys (ValueError naming
    the key and its line)."""
    global _LOADER
    if _LOADER is None:

        class UniqueKeyLoader(yaml.SafeLoader):
            pass

        def construct_mapping(loader, node, deep=False):
            loader.flatten_mapping(node)
            seen: dict[Any, int] = {}
            for key_node, _ in node.value:
                key = loader.construct_object(key_node, deep=deep)
                if key in seen:
                    raise ValueError(
                        f"duplicate key {key!r} in a YAML mapping (line "
                        f"{key_node.start_mark.line + 1}; first on line {seen[key] + 1})"
                    )
                seen[key] = key_node.start_mark.line
            return yaml.SafeLoader.construct_mapping(loader, node, deep=deep)

        UniqueKeyLoader.add_constructor(
            yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, construct_mapping
        )
        _LOADER = UniqueKeyLoader
    return _LOADER


_LOADER: Any = None
