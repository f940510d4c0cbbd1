"""Actions → cable commands, batched: tensions, tendon displacements, or length increments.

An action has one entry per cable in [−1, 1] (cable order of ``RobotParams``: section by section,
proximal first). What it commands depends on the mode:

| mode                   | command                                                           |
|------------------------|-------------------------------------------------------------------|
| ``tension``            | T = max_tension·(a + 1)/2 (N), absolute                           |
| ``tension_delta``      | T ← clip(T + a·tension_step·max_tension, 0, max_tension) (N)      |
| ``length_delta``       | l ← l + a·length_step (m), made consistent with an inextensible   |
|                        | backbone (least-squares projection onto the cable lengths of a    |
|                        | PCC shape: for one section with symmetric cables, onto            |
|                        | Σ Δl_i = 0), then the shape is scaled radially (every section's   |
|                        | bending vector by the same factor) into the tension-reachable     |
|                        | set. Quasi-static backends only (the analytic one).               |
| ``displacement``       | d = d_min + (a + 1)/2·(d_max − d_min) (m), absolute: the robot's  |
|                        | ``displacement_range``; tendon displacement at the drive          |
|                        | (positive = pulled in) through the compliant drives (SPEC §8)     |
| ``displacement_delta`` | d ← clip(d + a·displacement_step, d_min, d_max) (m)               |

In the displacement modes each tendon pulls with T = clip(T0 + k·(d − s(q)), 0, max_tension)
(``params.cable_stiffness`` k, ``params.cable_pretension`` T0, s the tendon's geometric
shortening at the current shape): the backend (``Backend.apply_displacements``) finds the
shape, and reports which tendons are slack (T = 0) or saturated (T = max_tension).
"""

from __future__ import annotations

import numpy as np

from cdcr_gym import defaults, validation
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.statics import reachable_scale

__all__ = ["ACTION_MODES", "DISPLACEMENT_MODES", "Actuation"]

#: Action modes: absolute tensions, tension increments, cable-length increments (CCKA only),
#: absolute tendon displacements, displacement increments.
ACTION_MODES = ("tension", "tension_delta", "length_delta", "displacement", "displacement_delta")
#: The modes that command tendon displacements through the compliant drives.
DISPLACEMENT_MODES = ("displacement", "displacement_delta")


class Actuation:
    """Turns clipped actions (N, C) into tension, cable-length or displacement commands (N, C).

    Args:
        mode: one of :data:`ACTION_MODES`.
        params: the robot.
        tension_step: largest tension change per step, as a fraction of max_tension, in (0, 1].
        length_step: largest cable displacement per step (m), in (0, robot length].
        displacement_step: largest tendon displacement change per step in
            ``displacement_delta`` mode (m), in (0, d_max − d_min].
    """

    def __init__(
        self,
        mode: str,
        params: RobotParams,
        tension_step: float = defaults.TENSION_STEP,
        length_step: float = defaults.LENGTH_STEP,
        displacement_step: float = defaults.DISPLACEMENT_STEP,
    ) -> None:
        self.mode = validation.choice(mode, "action_mode", ACTION_MODES)
        self.tension_step = validation.positive(tension_step, "tension_step", upper=1.0)
        self.length_step = validation.positive(length_step, "length_step", upper=params.length)
        low, high = params.displacement_range
        self.displacement_range = (float(low), float(high))
        self.displacement_step = validation.positive(
            displacement_step, "displacement_step", upper=high - low, unit="m"
        )
        self.params = params
        self.max_tension = float(params.max_tension)
        # 0-d float64 arrays: the same bits as Python floats, cheaper numpy operands
        self._tension_increment = np.array(self.tension_step * self.max_tension)
        self._half_max = np.array(self.max_tension * 0.5)
        self._zero, self._one, self._max = np.array(0.0), np.array(1.0), np.array(self.max_tension)
        self._model = PCCModel(params)
        #: Whether the commands are cable lengths (else tensions).
        self.commands_lengths = self.mode == "length_delta"
        #: Whether the commands are tendon displacements (through the compliant drives).
        self.commands_displacements = self.mode in DISPLACEMENT_MODES

    def tensions(self, action: np.ndarray, held: np.ndarray) -> np.ndarray:
        """Tensions (N, C) N commanded by clipped ``action`` (N, C) given the ``held`` ones."""
        if self.mode == "tension":
            return self._half_max * (action + self._one)
        t = held + action * self._tension_increment
        if t.size > 64:
            np.clip(t, 0.0, self.max_tension, out=t)  # one pass instead of two
            return t
        # np.clip's Python wrapper costs more than two ufunc calls on a few numbers
        return np.minimum(np.maximum(t, self._zero), self._max)

    def lengths(self, action: np.ndarray, held: np.ndarray) -> np.ndarray:
        """Cable lengths (N, C) m after clipped ``action`` (N, C) from the ``held`` lengths."""
        model = self._model
        w = model.bending_from_lengths(held + action * self.length_step)
        s = reachable_scale(model, w)
        return model.lengths_from_bending(w * s[..., None, None])

    def displacements(self, action: np.ndarray, held: np.ndarray) -> np.ndarray:
        """Tendon displacements (N, C) m commanded by clipped ``action`` (N, C) given the
        ``held`` ones (N, C) m; within ``displacement_range``."""
        low, high = self.displacement_range
        if self.mode == "displacement":
            return low + (high - low) * 0.5 * (action + 1.0)
        d = held + action * self.displacement_step
        np.clip(d, low, high, out=d)
        return d

    def normalized(self, displacements: np.ndarray) -> np.ndarray:
        """Displacements (..., C) m as fractions of ``displacement_range`` in [−1, 1] (the
        action that commands them in ``displacement`` mode)."""
        low, high = self.displacement_range
        return (2.0 * displacements - (low + high)) / (high - low)
