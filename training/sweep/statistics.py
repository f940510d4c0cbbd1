"""The interquartile mean, its stratified-bootstrap confidence interval and performance profiles
(Agarwal et al., NeurIPS 2021; rliable's definitions, written in numpy: see
:mod:`training.sweep.aggregate`)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np


def iqm(scores: np.ndarray | Sequence[float], axis: int = -1) -> np.ndarray | float:
    """Interquartile mean along ``axis``: the mean after cutting ``int(0.25 n)`` values per end.

    Identical to ``scipy.stats.trim_mean(scores, 0.25, axis)`` (rliable's IQM). ``scores``: any
    shape with n ≥ 1 values along ``axis``. Returns a float for 1-D input, else an array with
    ``axis`` removed.
    """
    x = np.sort(np.asarray(scores, dtype=float), axis=axis)
    n = x.shape[axis]
    if n == 0:
        raise ValueError("scores must hold at least one value along axis, got an empty array")
    k = int(0.25 * n)
    out = np.take(x, np.arange(k, n - k), axis=axis).mean(axis=axis)
    return float(out) if np.ndim(out) == 0 else out


def stratified_bootstrap(
    groups: Sequence[np.ndarray | Sequence[float]],
    statistic: Callable[[np.ndarray], np.ndarray],
    reps: int = 50_000,
    seed: int = 0,
) -> np.ndarray:
    """``reps`` bootstrap replicates of ``statistic`` over the pooled, stratified resamples.

    ``groups``: one 1-D array of run scores per stratum (task). Each replicate draws, with
    replacement, ``len(g)`` runs from every group ``g`` independently, pools them (shape
    ``(reps, sum len(g))``) and applies ``statistic`` along the last axis. Returns shape
    ``(reps, ...)``. Deterministic for a given ``seed`` (``numpy.random.default_rng``).
    """
    if reps <= 0:
        raise ValueError(f"reps must be a positive integer, got {reps!r}")
    arrays = [np.asarray(g, dtype=float).ravel() for g in groups]
    if not arrays or any(a.size == 0 for a in arrays):
        raise ValueError("groups must be a non-empty list of non-empty score arrays")
    rng = np.random.default_rng(seed)
    pooled = np.concatenate([a[rng.integers(0, a.size, size=(reps, a.size))] for a in arrays], 1)
    return np.asarray(statistic(pooled))


def stratified_bootstrap_ci(
    groups: Sequence[np.ndarray | Sequence[float]],
    statistic: Callable[..., Any] = iqm,
    reps: int = 50_000,
    confidence: float = 0.95,
    seed: int = 0,
) -> tuple[float, float, float]:
    """Point estimate and percentile confidence interval of ``statistic`` over pooled groups.

    Returns ``(point, low, high)``: ``statistic`` of all runs pooled, and the ``(1 ± confidence)
    / 2`` quantiles of its stratified-bootstrap distribution (:func:`stratified_bootstrap`).
    """
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    point = float(statistic(np.concatenate([np.asarray(g, dtype=float).ravel() for g in groups])))
    boot = stratified_bootstrap(groups, lambda x: statistic(x, axis=-1), reps, seed)
    alpha = (1.0 - confidence) / 2.0
    low, high = np.quantile(boot, [alpha, 1.0 - alpha])
    return point, float(low), float(high)


def performance_profile(
    groups: Sequence[np.ndarray | Sequence[float]],
    levels: np.ndarray,
    reps: int = 2_000,
    confidence: float = 0.95,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fraction of runs with a score ≤ each level, with a stratified-bootstrap band.

    ``groups``: run scores (errors: lower is better) per stratum; ``levels``: shape ``(L,)``.
    Returns ``(fraction, low, high)``, each of shape ``(L,)``.
    """
    levels = np.asarray(levels, dtype=float)

    def frac(x: np.ndarray, axis: int = -1) -> np.ndarray:
        return (np.moveaxis(x, axis, -1)[..., None] <= levels).mean(axis=-2)

    pooled = np.concatenate([np.asarray(g, dtype=float).ravel() for g in groups])
    boot = stratified_bootstrap(groups, frac, reps, seed)
    alpha = (1.0 - confidence) / 2.0
    low, high = np.quantile(boot, [alpha, 1.0 - alpha], axis=0)
    return frac(pooled), low, high
