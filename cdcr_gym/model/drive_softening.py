"""Drive softening: a tendon drive whose pull saturates smoothly.

A drive that pulls a tendon in by y > 0 (m, after its backlash) pulls it by

    t = tanh(σ·y)/σ

instead, with σ >= 0 the softening rate (1/m; 1/σ is the length the pull saturates towards).
A released command (y <= 0) passes unchanged, and σ = 0 is a linear drive (t = y). The map is
smooth and strictly increasing; its slope is 1 at y = 0 and 1 − (σ·t)² at the pull t, so the
drive gives way more the harder it pulls (a servo whose position loop yields under load, a
tendon that stretches more than linearly). Pulls t >= 1/σ are beyond every command.

The calibration fits σ as ``drive_softening`` (``cdcr_gym.calibration.parameters``) and replays
the measured commands through it after the backlash; an env's drives apply it at every control
step (the env option ``drive_softening``), and the env, its goals and the IK oracle turn the
pulls that hold a shape back into commands with :func:`command_for_pull`.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

__all__ = ["soften", "command_for_pull", "check_rate"]


def check_rate(rate, name: str = "drive_softening") -> float:
    """``rate`` as a float σ >= 0 (1/m), or a ValueError naming ``name`` and the value."""
    if isinstance(rate, (bool, np.bool_)) or not isinstance(
        rate, (int, float, np.integer, np.floating)
    ):
        raise ValueError(f"{name} must be a real number (1/m), got {rate!r}")
    value = float(rate)
    if not (math.isfinite(value) and value >= 0.0):
        raise ValueError(f"{name} must be finite and >= 0 (1/m), got {rate!r}")
    return value


def soften(y: npt.ArrayLike, rate: float) -> np.ndarray:
    """The pulls t (..., C) m that reach the tendons for the drive displacements ``y`` (..., C)
    m of drives with softening rate ``rate`` σ (1/m, >= 0; module docstring): tanh(σy)/σ where
    y > 0, y elsewhere (σ = 0: y itself, as a float array)."""
    y_arr = np.asarray(y, dtype=np.float64)
    if rate == 0.0:
        return y_arr
    return np.where(y_arr > 0.0, np.tanh(rate * np.maximum(y_arr, 0.0)) / rate, y_arr)


def command_for_pull(t: npt.ArrayLike, rate: float) -> np.ndarray:
    """The drive displacements y (..., C) m whose pulls (:func:`soften`) are ``t`` (..., C) m:
    artanh(σt)/σ where t > 0, t elsewhere (σ = 0: t itself).

    Raises:
        ValueError: if a pull is at or beyond 1/σ, which no command reaches (clip the pulls to
            the softened range of the drives first).
    """
    t_arr = np.asarray(t, dtype=np.float64)
    if rate == 0.0:
        return t_arr
    pulled = np.maximum(t_arr, 0.0) * rate
    if np.any(pulled >= 1.0):
        raise ValueError(
            f"a pull of {float(np.max(t_arr)):.6g} m is beyond every command of a drive with "
            f"drive_softening {rate:.6g} 1/m (its pulls stay below {1.0 / rate:.6g} m)"
        )
    return np.where(t_arr > 0.0, np.arctanh(pulled) / rate, t_arr)
