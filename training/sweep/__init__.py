"""Sweeps: grids of experiments run as Ray Tune trials (:mod:`training.sweep.tune`,
``cdcr-gym sweep``), and their aggregation with IQMs, bootstrap confidence intervals and
performance profiles (:mod:`training.sweep.aggregate`, :mod:`training.sweep.statistics`,
``cdcr-gym aggregate``).

The names of the former ``training.sweep`` module (``load_sweep``, ``run_sweep``, ``main``, ...)
are still importable from here.
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "SweepSpec",
    "Trial",
    "load_sweep",
    "sweep_from_dict",
    "expand",
    "run_trial",
    "is_finished",
    "run_sweep",
    "main",
    "TARGET_KEYS",
    "PYTHON",
]


def __getattr__(name: str) -> Any:  # the former module's names, imported when first used
    if name in __all__:
        from training.sweep import tune

        return getattr(tune, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
