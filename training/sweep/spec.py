"""A sweep file, parsed and validated: :class:`SweepSpec` (the format: :mod:`training.sweep.tune`).

Strict: an unknown or misspelt key is a :class:`~training.run.config.ConfigError` naming it (with
the closest valid key), as is a value of the wrong type or range.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import re
from pathlib import Path
from typing import Any

import yaml

from training.run.config import EVALUATE_MODELS, ConfigError

__all__ = [
    "TARGET_KEYS",
    "EvaluateSpec",
    "ResourcesSpec",
    "PartSpec",
    "SweepSpec",
    "sweep_from_dict",
    "load_sweep",
    "check_parts",
]

#: eval_log.csv columns a target may name -> True if higher is better (a lower bound)
TARGET_KEYS: dict[str, bool] = {
    "success_rate": True,
    "within_1mm": True,
    "mean_error_mm": False,
    "median_error_mm": False,
    "p95_error_mm": False,
}


@dataclasses.dataclass
class EvaluateSpec:
    """What runs after training: ``python -m training.evaluate RUN_DIR --model MODEL``."""

    enabled: bool = True
    #: None: the trial config's ``evaluate.model`` (a ``set:`` may choose it), normally best
    model: str | None = None
    episodes: int | None = None


@dataclasses.dataclass
class ResourcesSpec:
    """Ray resources: CPUs per trial, and a cap on concurrent trials (None: no cap)."""

    cpus_per_trial: float = 1.0
    max_concurrent: int | None = None


@dataclasses.dataclass
class PartSpec:
    """A part of a sweep: its configs and the dotted config keys set on top of the sweep's."""

    configs: list[str]
    set: dict[str, Any] = dataclasses.field(default_factory=dict)


@dataclasses.dataclass
class SweepSpec:
    """A parsed sweep file (see the module docstring)."""

    name: str
    configs: list[str]
    seeds: list[int]
    set: dict[str, Any] = dataclasses.field(default_factory=dict)
    overrides: list[dict[str, Any]] = dataclasses.field(default_factory=lambda: [{}])
    grid: dict[str, list[Any]] = dataclasses.field(default_factory=dict)
    evaluate: EvaluateSpec = dataclasses.field(default_factory=EvaluateSpec)
    target: dict[str, float] = dataclasses.field(default_factory=dict)
    resources: ResourcesSpec = dataclasses.field(default_factory=ResourcesSpec)
    out_dir: str | None = None
    #: name -> part (configs and their own settings); empty: one part, ``configs`` and ``set``
    parts: dict[str, PartSpec] = dataclasses.field(default_factory=dict)
    #: where the sweep file lives (config paths may be relative to it); not a file key
    base_dir: Path = dataclasses.field(default=Path("."), repr=False)

    @property
    def output(self) -> Path:
        """The sweep's output directory (absolute)."""
        return Path(self.out_dir or Path("runs") / "sweeps" / self.name).resolve()


# -- the sweep file -----------------------------------------------------------------------------
_TOP_KEYS = [f.name for f in dataclasses.fields(SweepSpec) if f.name != "base_dir"]


def _check_keys(where: str, data: dict[str, Any], valid: list[str]) -> None:
    for key in data:
        if key not in valid:
            close = difflib.get_close_matches(str(key), valid, n=1)
            hint = f"; did you mean '{close[0]}'?" if close else ""
            raise ConfigError(
                f"unknown sweep key '{where}{key}'{hint} (valid keys here: {', '.join(valid)})"
            )


def _mapping(key: str, value: Any) -> dict[str, Any]:
    if value is None:
        return {}
    if not isinstance(value, dict) or not all(isinstance(k, str) for k in value):
        raise ConfigError(f"{key} must be a mapping of dotted config keys to values, got {value!r}")
    return dict(value)


def sweep_from_dict(data: Any, name: str = "sweep", base_dir: Path | None = None) -> SweepSpec:
    """A :class:`SweepSpec` from a parsed sweep file; raises ConfigError naming the bad key."""
    if not isinstance(data, dict):
        raise ConfigError(f"a sweep file must be a mapping of keys to values, got {data!r}")
    _check_keys("", data, _TOP_KEYS)
    sweep_name = data.get("name", name)
    if not isinstance(sweep_name, str) or not re.fullmatch(r"[A-Za-z0-9_.-]+", sweep_name):
        raise ConfigError(f"name must be a word of [A-Za-z0-9_.-], got {sweep_name!r}")
    parts = _parts(data.get("parts"))
    configs = data.get("configs")
    if parts and configs is not None:
        raise ConfigError(
            "give either configs or parts (each part lists its own configs), not both"
        )
    if parts:
        configs = [c for part in parts.values() for c in part.configs]
    elif (
        not isinstance(configs, list) or not configs or not all(isinstance(c, str) for c in configs)
    ):
        raise ConfigError(f"configs must be a non-empty list of config files, got {configs!r}")
    seeds = data.get("seeds")
    if (
        not isinstance(seeds, list)
        or not seeds
        or not all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in seeds)
        or len(set(seeds)) != len(seeds)
    ):
        raise ConfigError(
            f"seeds must be a non-empty list of distinct integers >= 0, got {seeds!r}"
        )
    common = _mapping("set", data.get("set"))
    overrides = data.get("overrides", [{}])
    if overrides is None:
        overrides = [{}]
    if not isinstance(overrides, list) or not overrides:
        raise ConfigError(f"overrides must be a non-empty list of mappings, got {overrides!r}")
    overrides = [_mapping(f"overrides[{i}]", o) for i, o in enumerate(overrides)]
    grid = _mapping("grid", data.get("grid"))
    for where, mapping in [("set", common), ("grid", grid)] + [
        (f"overrides[{i}]", o) for i, o in enumerate(overrides)
    ]:
        if "seed" in mapping:  # the trials' seeds are the sweep's seeds: a set seed would be lost
            raise ConfigError(f"{where}: seed {mapping['seed']!r} cannot be set; list it in seeds")
    for key, values in grid.items():
        if not isinstance(values, list) or not values:
            raise ConfigError(f"grid.{key} must be a non-empty list of values, got {values!r}")
    ev = data.get("evaluate") or {}
    if not isinstance(ev, dict):
        raise ConfigError(f"evaluate must be a mapping, got {ev!r}")
    _check_keys("evaluate.", ev, [f.name for f in dataclasses.fields(EvaluateSpec)])
    evaluate = EvaluateSpec(**ev)
    if not isinstance(evaluate.enabled, bool):
        raise ConfigError(f"evaluate.enabled must be true or false, got {evaluate.enabled!r}")
    if evaluate.model is not None and evaluate.model not in EVALUATE_MODELS:
        raise ConfigError(f"evaluate.model must be 'best' or 'final', got {evaluate.model!r}")
    if evaluate.episodes is not None and (
        not isinstance(evaluate.episodes, int)
        or isinstance(evaluate.episodes, bool)
        or evaluate.episodes <= 0
    ):
        raise ConfigError(
            f"evaluate.episodes must be a positive integer or null, got {evaluate.episodes!r}"
        )
    target = _mapping("target", data.get("target"))
    _check_keys("target.", target, list(TARGET_KEYS))
    for key, value in target.items():
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
        ):
            raise ConfigError(f"target.{key} must be a finite number, got {value!r}")
        if key in ("success_rate", "within_1mm") and not 0.0 <= value <= 1.0:
            raise ConfigError(f"target.{key} is a fraction: it must be in [0, 1], got {value!r}")
        if key.endswith("_mm") and value < 0:
            raise ConfigError(f"target.{key} is a distance in mm: it must be >= 0, got {value!r}")
    res = data.get("resources") or {}
    if not isinstance(res, dict):
        raise ConfigError(f"resources must be a mapping, got {res!r}")
    _check_keys("resources.", res, [f.name for f in dataclasses.fields(ResourcesSpec)])
    resources = ResourcesSpec(**res)
    cpus = resources.cpus_per_trial
    if (
        isinstance(cpus, bool)
        or not isinstance(cpus, (int, float))
        or not math.isfinite(cpus)
        or not cpus > 0
    ):
        raise ConfigError(f"resources.cpus_per_trial must be a finite number > 0, got {cpus!r}")
    mc = resources.max_concurrent
    if mc is not None and (not isinstance(mc, int) or isinstance(mc, bool) or mc <= 0):
        raise ConfigError(
            f"resources.max_concurrent must be a positive integer or null, got {mc!r}"
        )
    out_dir = data.get("out_dir")
    if out_dir is not None and not isinstance(out_dir, str):
        raise ConfigError(f"out_dir must be a path or null, got {out_dir!r}")
    return SweepSpec(
        name=sweep_name,
        configs=list(configs),
        seeds=list(seeds),
        set=common,
        overrides=overrides,
        grid=grid,
        evaluate=evaluate,
        target={k: float(v) for k, v in target.items()},
        resources=resources,
        out_dir=out_dir,
        parts=parts,
        base_dir=base_dir or Path("."),
    )


def _parts(value: Any) -> dict[str, PartSpec]:
    """The ``parts`` mapping (None: no parts), each validated; ConfigError names the bad key."""
    if value is None:
        return {}
    if not isinstance(value, dict) or not value:
        raise ConfigError(
            f"parts must be a non-empty mapping of part names to parts, got {value!r}"
        )
    parts = {}
    for name, part in value.items():
        if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z0-9_.-]+", name):
            raise ConfigError(
                f"parts: a part's name must be a word of [A-Za-z0-9_.-], got {name!r}"
            )
        if not isinstance(part, dict):
            raise ConfigError(f"parts.{name} must be a mapping (configs, set), got {part!r}")
        _check_keys(f"parts.{name}.", part, [f.name for f in dataclasses.fields(PartSpec)])
        configs = part.get("configs")
        if (
            not isinstance(configs, list)
            or not configs
            or not all(isinstance(c, str) for c in configs)
        ):
            raise ConfigError(
                f"parts.{name}.configs must be a non-empty list of config files, got {configs!r}"
            )
        parts[name] = PartSpec(list(configs), _mapping(f"parts.{name}.set", part.get("set")))
    return parts


def load_sweep(path: str | Path) -> SweepSpec:
    """Read and validate a sweep file; raises ConfigError naming the file and the bad key."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"sweep file {str(path)!r} does not exist")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ConfigError(f"sweep file {str(path)!r} is not valid YAML: {exc}") from None
    try:
        return sweep_from_dict(data, name=path.stem, base_dir=path.resolve().parent)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None


def check_parts(spec: SweepSpec, parts: list[str] | None) -> None:
    """ConfigError unless every name in ``parts`` is a part of ``spec`` (None: all parts)."""
    if parts is None:
        return
    if not spec.parts:
        raise ConfigError(f"--part {parts[0]!r}: the sweep {spec.name!r} has no parts")
    for name in parts:
        if name not in spec.parts:
            raise ConfigError(
                f"--part {name!r} is not a part of the sweep {spec.name!r} "
                f"(its parts: {', '.join(spec.parts)})"
            )
