"""Deprecated alias: the observation layouts live in :mod:`cdcr_gym.tasks.observation` (the
tasks own their observation). Importing from here keeps working and warns."""

from __future__ import annotations

import warnings

from cdcr_gym.tasks.observation import Field, ObservationSpec

__all__ = ["Field", "ObservationSpec"]

warnings.warn(
    "cdcr_gym.envs.observation is deprecated; import Field and ObservationSpec from "
    "cdcr_gym.tasks.observation",
    DeprecationWarning,
    stacklevel=2,
)
