"""Names of the evaluation conditions: a starting state and an episode length.

``cdcr-gym evaluate`` runs every (starting state, horizon) of a config's ``evaluate`` section
and stores each as a condition named ``<state>_<horizon>steps`` (``straight_100steps``: from the
straight robot, 100 control steps). Evaluations written before that name read
``straight_h100``; every reader here (results tables, task results, sweep aggregation, sim2sim)
goes through :func:`read_eval`, which accepts both and returns the current names.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

__all__ = ["condition_name", "canonical_condition", "canonical_eval", "read_eval"]

_OLD = re.compile(r"(?P<state>[A-Za-z]+)_h(?P<steps>\d+)")


def condition_name(initial_state: str, horizon: int) -> str:
    """``straight``, 100 -> ``straight_100steps``."""
    return f"{initial_state}_{int(horizon)}steps"


def canonical_condition(name: str) -> str:
    """The current name of a condition: ``straight_h100`` (the former name) ->
    ``straight_100steps``; any other name unchanged."""
    m = _OLD.fullmatch(name)
    return condition_name(m["state"], int(m["steps"])) if m else name


def canonical_eval(data: dict[str, Any]) -> dict[str, Any]:
    """An evaluation's data with current condition names (``conditions`` keys,
    ``headline_condition``); other keys unchanged. A new dict; ``data`` is not modified."""
    out = dict(data)
    if isinstance(data.get("conditions"), dict):
        out["conditions"] = {canonical_condition(k): v for k, v in data["conditions"].items()}
    if isinstance(data.get("headline_condition"), str):
        out["headline_condition"] = canonical_condition(data["headline_condition"])
    return out


def read_eval(path: str | Path) -> dict[str, Any]:
    """An ``eval*.json`` of ``cdcr-gym evaluate``, old or new, with current condition names."""
    return canonical_eval(json.loads(Path(path).read_text()))
