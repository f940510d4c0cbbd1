"""Observation layouts: named fields → slices, bounds and units, in one place.

An :class:`ObservationSpec` is the single source of an env's observation ``Box``, of the index
table in the env's docstring and of every decoder (controllers read fields by name, never by
hard-coded indices). Tasks build their spec from :class:`Field` s; the env core fills a
preallocated float32 array field by field.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces

__all__ = ["Field", "ObservationSpec"]


@dataclass(frozen=True)
class Field:
    """One named block of an observation vector.

    Attributes:
        name: identifier (``"tip"``, ``"goal"``, ...), unique within a spec.
        low: lower bound of every entry, shape (size,).
        high: upper bound of every entry, shape (size,).
        unit: unit of the entries (``"m"``, ``"–"`` for dimensionless).
        description: what the entries are, for the docstring table.
        labels: one short label per entry (e.g. ``("x", "y", "z")``), for the table.
    """

    name: str
    low: tuple[float, ...]
    high: tuple[float, ...]
    unit: str
    description: str
    labels: tuple[str, ...] = ()

    @property
    def size(self) -> int:
        """Number of entries."""
        return len(self.low)

    @classmethod
    def uniform(
        cls,
        name: str,
        size: int,
        low: float,
        high: float,
        unit: str,
        description: str,
        labels: Sequence[str] = (),
    ) -> Field:
        """A field of ``size`` entries sharing the bounds [low, high]."""
        return cls(
            name, (float(low),) * size, (float(high),) * size, unit, description, tuple(labels)
        )


class ObservationSpec:
    """An ordered list of :class:`Field` s: the layout of a flat float32 observation.

    Args:
        fields: the fields in observation order (names unique).
    """

    def __init__(self, fields: Sequence[Field]) -> None:
        names = [f.name for f in fields]
        if len(set(names)) != len(names):
            raise ValueError(f"observation field names must be unique, got {names}")
        self.fields: tuple[Field, ...] = tuple(fields)
        self.slices: dict[str, slice] = {}
        start = 0
        for f in self.fields:
            self.slices[f.name] = slice(start, start + f.size)
            start += f.size
        #: Total number of entries.
        self.size = start
        self.low = np.concatenate([np.asarray(f.low, np.float32) for f in self.fields])
        self.high = np.concatenate([np.asarray(f.high, np.float32) for f in self.fields])

    @property
    def names(self) -> tuple[str, ...]:
        """Field names in order."""
        return tuple(f.name for f in self.fields)

    def box(self) -> spaces.Box:
        """The Gymnasium ``Box`` (float32) of this layout."""
        return spaces.Box(self.low, self.high, dtype=np.float32)

    def decode(self, obs: np.ndarray, name: str) -> np.ndarray:
        """Field ``name`` of observations ``obs`` (..., size), as float64 (..., field size)."""
        if name not in self.slices:
            raise ValueError(f"observation has no field {name!r}; fields: {list(self.names)}")
        obs = np.asarray(obs)
        if obs.shape[-1:] != (self.size,):
            raise ValueError(
                f"obs must have {self.size} entries in its last axis, got shape {obs.shape}"
            )
        return obs[..., self.slices[name]].astype(np.float64)

    def table(self) -> str:
        """The Markdown index table (index, observation, min, max, unit) of this layout."""
        rows = [
            "| index | observation | min | max | unit |",
            "|-------|-------------|-----|-----|------|",
        ]
        for f in self.fields:
            s = self.slices[f.name]
            index = f"{s.start}" if f.size == 1 else f"{s.start}–{s.stop - 1}"
            lo, hi = _bound_text(f.low), _bound_text(f.high)
            rows.append(f"| {index} | {f.description} | {lo} | {hi} | {f.unit} |")
        return "\n".join(rows)


def _bound_text(values: tuple[float, ...]) -> str:
    uniq = sorted(set(values))
    fmt = [f"{v:.4g}" for v in uniq]
    return fmt[0] if len(fmt) == 1 else "/".join(fmt)
