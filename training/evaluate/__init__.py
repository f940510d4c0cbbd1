"""Evaluation: fixed-goal rollouts for any policy, each task's metrics, the oracles beside the
agent, results tables, figures and episode videos.

``cdcr-gym evaluate RUN_DIR`` (:mod:`training.evaluate.agent`; ``python -m training.evaluate``
runs it too) evaluates a trained run; ``cdcr-gym oracles``, ``results``, ``task-results`` and
``demo`` are the other commands of this room.

``training.evaluate.main`` and ``training.evaluate.evaluate`` (the module's names before it
became this package) are still importable from here.
"""

from __future__ import annotations

from typing import Any

__all__ = ["main", "evaluate"]


def __getattr__(name: str) -> Any:  # the former module's names, without importing torch early
    if name in __all__:
        from training.evaluate import agent

        return getattr(agent, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
