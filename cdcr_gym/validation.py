"""Input checks shared by the backends and the env (cheap enough for the step path)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["three_finite_floats"]


def three_finite_floats(values: Any, name: str) -> tuple[float, float, float]:
    """``values`` (one per cable, shape (3,)) as three Python floats.

    Raises:
        ValueError: naming ``name``, if the shape is not (3,) or a value is NaN or infinite.
    """
    if type(values) is not np.ndarray or values.dtype.kind != "f":
        values = np.asarray(values, dtype=np.float64)
    if values.shape != (3,):
        raise ValueError(f"{name} must have shape (3,), got shape {values.shape}")
    v1, v2, v3 = values.tolist()
    # A NaN or an infinity makes the sum non-finite; a finite sum proves all three finite
    # (an overflowing sum of finite values falls through to the exact check).
    if not math.isfinite(v1 + v2 + v3) and not np.all(np.isfinite(values)):
        raise ValueError(f"{name} must be finite, got {np.asarray(values, np.float64)!r}")
    return v1, v2, v3
