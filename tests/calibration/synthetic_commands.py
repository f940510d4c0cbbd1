"""Synthetic displacement rows for the calibration tests of the FTDCR v4 robot's drive terms."""

from __future__ import annotations

import numpy as np

from cdcr_gym.calibration import Measurements


def back_and_forth(n: int, seed: int = 0) -> np.ndarray:
    """Commands (n, 9) m up to ~10 mm that go back and forth (reversals on every tendon)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n)[:, None]
    phase = rng.uniform(0, 2 * np.pi, (1, 9))
    return 0.002 + 0.008 * np.sin(0.3 * t + phase) + 0.0005 * rng.standard_normal((n, 9))


def displacement_rows(d: np.ndarray, tip: np.ndarray | None = None) -> Measurements:
    """Measurements of commands ``d`` (M, C) m with tips ``tip`` (M, 3) m (default zeros)."""
    tips = np.zeros((len(d), 3)) if tip is None else tip
    return Measurements(None, tips, None, None, displacements=d)
