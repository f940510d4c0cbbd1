"""Backlash of a tendon drive: the play between the drive's command and the tendon it moves.

A servo winding a tendon through gears and a spool does not move the tendon until its command
has turned through the play: after a reversal the tendon stays where it was until the command
has moved the full width w past it. One step of this *play operator* (per tendon, SI):

    y_new = clip(y_old, d − w/2, d + w/2)

with d the drive's command (m), y the displacement that reaches the tendon (m) and w >= 0 the
play's width (m). y follows d with a lag of w/2 while d keeps moving one way and holds while d
turns; w = 0 is no backlash (y = d). The calibration replays a measured command sequence
through it (``cdcr_gym.calibration.backlash.play``), an env's drives apply it at every control
step (the env option ``drive_backlash``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["play_step"]


def play_step(previous: np.ndarray, command: np.ndarray, width: float | np.ndarray) -> np.ndarray:
    """The tendon displacements (..., C) m after one step of the play operator (module
    docstring): the previous ones ``previous`` (..., C) m held unless the command ``command``
    (..., C) m has moved more than half the width ``width`` m (a number or (C,), >= 0; the
    caller checks it) away from them."""
    half = 0.5 * np.asarray(width, dtype=np.float64)
    return np.minimum(np.maximum(previous, command - half), command + half)
