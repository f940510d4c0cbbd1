"""Compatibility home of the robot description: see :mod:`cdcr_gym.model.params`.

``from cdcr_gym.params import RobotParams`` is the documented import (SPEC §5) and keeps working.
"""

from cdcr_gym.model.params import (
    CABLE_ANGLES,
    PRESETS,
    STANDARD_GRAVITY,
    RobotParams,
    SectionParams,
)

__all__ = ["RobotParams", "SectionParams", "CABLE_ANGLES", "PRESETS", "STANDARD_GRAVITY"]
