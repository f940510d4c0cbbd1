"""Input checks shared by the model, the backends, the tasks and the envs.

Every public entry point validates user input here, so that all of them answer bad input the
same way: a ``ValueError`` that names the argument and shows the offending value (never an
``assert``, never a silent NaN).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = [
    "real_array",
    "per_cable",
    "action_array",
    "clipped_action",
    "positive",
    "choice",
    "flag",
    "integer",
]


# 0-d float64 arrays: cheaper numpy operands than Python floats on small arrays (same bits)
_MINUS_ONE, _PLUS_ONE = np.array(-1.0), np.array(1.0)


def real_array(
    value: Any, name: str, shape: tuple[int, ...] | None = None, *, allow_bool: bool = True
) -> np.ndarray:
    """``value`` as a finite float64 array (optionally of exactly ``shape``).

    Raises:
        ValueError: naming ``name``, for non-numeric input (strings, complex numbers, objects;
            bools unless ``allow_bool``), a wrong shape, or a NaN/infinite entry.
    """
    if type(value) is np.ndarray and value.dtype.kind == "f":
        arr = value.astype(np.float64, copy=False)
    else:
        try:
            probe = np.asarray(value)
        except Exception as exc:  # ragged sequences and the like
            raise ValueError(f"{name} must be an array of real numbers, got {value!r}") from exc
        if probe.dtype.kind not in ("fiub" if allow_bool else "fiu"):
            raise ValueError(f"{name} must be an array of real numbers, got {value!r}")
        arr = probe.astype(np.float64)
    if shape is not None and arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got shape {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} must be finite, got {value!r}")
    return arr


def per_cable(
    value: Any, name: str, n_cables: int, low: float | None = None, high: float | None = None
) -> np.ndarray:
    """Per-cable values of shape (..., n_cables) as float64, finite and within [low, high].

    Raises:
        ValueError: naming ``name`` (shape, non-finite, or out of range).
    """
    arr = real_array(value, name)
    if arr.shape[-1:] != (n_cables,):
        raise ValueError(f"{name} must have shape (..., {n_cables}), got shape {arr.shape}")
    if low is not None and (arr < low).any():
        raise ValueError(f"{name} must be >= {low}, got {value!r}")
    if high is not None and (arr > high).any():
        raise ValueError(f"{name} must be <= {high}, got {value!r}")
    return arr


def action_array(action: Any, shape: tuple[int, ...]) -> np.ndarray:
    """An action of exactly ``shape`` as float64 (not yet clipped).

    Fast for the common case (a float32/float64 numpy array); integers work; bools, strings,
    complex numbers, dicts and other non-real input raise.

    Raises:
        ValueError: naming ``action``.
    """
    if type(action) is np.ndarray and action.dtype.kind == "f" and action.shape == shape:
        arr = action.astype(np.float64)
        # a few numbers are checked faster one by one than by a numpy reduction
        finite = (
            all(map(math.isfinite, arr.ravel().tolist()))
            if arr.size <= 16
            else bool(np.isfinite(arr).all())
        )
        if not finite:
            raise ValueError(f"action must be finite, got {action!r}")
        return arr
    return real_array(action, "action", shape, allow_bool=False)


def clipped_action(action: Any, shape: tuple[int, ...]) -> np.ndarray:
    """:func:`action_array` clipped to [−1, 1] (a fresh float64 array of ``shape``).

    Raises:
        ValueError: naming ``action``.
    """
    return np.minimum(np.maximum(action_array(action, shape), _MINUS_ONE), _PLUS_ONE)


def positive(
    value: Any,
    name: str,
    upper: float | None = None,
    *,
    allow_zero: bool = False,
    unit: str = "",
) -> float:
    """A finite real > 0 (or >= 0 with ``allow_zero``), optionally <= ``upper``, as float;
    ``unit`` (e.g. ``"s"``) is named in the error."""
    in_unit = f" ({unit})" if unit else ""
    if isinstance(value, (bool, np.bool_)) or not isinstance(
        value, (int, float, np.integer, np.floating)
    ):
        raise ValueError(f"{name} must be a real number{in_unit}, got {value!r}")
    value = float(value)
    too_small = value < 0.0 if allow_zero else value <= 0.0
    if not math.isfinite(value) or too_small or (upper is not None and value > upper):
        rule = ">= 0" if allow_zero else "> 0"
        bound = f" and <= {upper}" if upper is not None else ""
        raise ValueError(f"{name} must be finite, {rule}{bound}{in_unit}, got {value!r}")
    return value


def choice(value: Any, name: str, choices: Sequence[str]) -> str:
    """``value`` if it is one of ``choices``."""
    if not isinstance(value, str) or value not in choices:
        raise ValueError(f"{name} must be one of {tuple(choices)}, got {value!r}")
    return value


def flag(value: Any, name: str) -> bool:
    """A bool (Python or numpy)."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be a bool, got {value!r}")
    return bool(value)


def integer(value: Any, name: str, minimum: int) -> int:
    """An integer >= ``minimum`` (bools refused)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)
