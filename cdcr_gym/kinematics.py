"""Constant-curvature kinematics (CCKA) of one section — the public API of SPEC §2.

``from cdcr_gym import kinematics as K`` keeps working: the functions live in
:mod:`cdcr_gym.model.arc` (one section) and are re-exported here unchanged. For robots of
several sections use :class:`cdcr_gym.model.chain.PCCModel`.
"""

from cdcr_gym.model.arc import (
    arc_from_lengths,
    arc_from_tip,
    backbone_points,
    forward_kinematics,
    inverse_kinematics,
    lengths_from_arc,
    tip_from_arc,
    tip_pose,
    tip_rotation,
)

__all__ = [
    "arc_from_lengths",
    "lengths_from_arc",
    "tip_from_arc",
    "forward_kinematics",
    "inverse_kinematics",
    "arc_from_tip",
    "tip_rotation",
    "tip_pose",
    "backbone_points",
]
