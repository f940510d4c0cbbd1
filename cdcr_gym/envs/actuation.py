"""Actions → cable commands, batched: absolute tensions, tension increments, length increments.

An action has one entry per cable in [−1, 1] (cable order of ``RobotParams``: section by section,
proximal first). What it commands depends on the mode:

| mode              | command                                                                |
|-------------------|------------------------------------------------------------------------|
| ``tension``       | T = max_tension·(a + 1)/2 (N), absolute                                |
| ``tension_delta`` | T ← clip(T + a·tension_step·max_tension, 0, max_tension) (N)           |
| ``length_delta``  | l ← l + a·length_step (m), made consistent with an inextensible        |
|                   | backbone (least-squares projection onto the cable lengths of a PCC     |
|                   | shape: for one section with symmetric cables, onto Σ Δl_i = 0), then   |
|                   | the shape is scaled radially (every section's bending vector by the    |
|                   | same factor) into the tension-reachable set. Quasi-static backends     |
|                   | only (the analytic one).                                               |
"""

from __future__ import annotations

import numpy as np

from cdcr_gym import defaults, validation
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.statics import reachable_scale

__all__ = ["ACTION_MODES", "Actuation"]

#: Action modes: absolute tensions, tension increments, cable-length increments (CCKA only).
ACTION_MODES = ("tension", "tension_delta", "length_delta")


class Actuation:
    """Turns clipped actions (N, C) into tension or cable-length commands (N, C).

    Args:
        mode: one of :data:`ACTION_MODES`.
        params: the robot.
        tension_step: largest tension change per step, as a fraction of max_tension, in (0, 1].
        length_step: largest cable displacement per step (m), in (0, robot length].
    """

    def __init__(
        self,
        mode: str,
        params: RobotParams,
        tension_step: float = defaults.TENSION_STEP,
        length_step: float = defaults.LENGTH_STEP,
    ) -> None:
        self.mode = validation.choice(mode, "action_mode", ACTION_MODES)
        self.tension_step = validation.positive(tension_step, "tension_step", upper=1.0)
        self.length_step = validation.positive(length_step, "length_step", upper=params.length)
        self.params = params
        self.max_tension = float(params.max_tension)
        # 0-d float64 arrays: the same bits as Python floats, cheaper numpy operands
        self._tension_increment = np.array(self.tension_step * self.max_tension)
        self._half_max = np.array(self.max_tension * 0.5)
        self._zero, self._one, self._max = np.array(0.0), np.array(1.0), np.array(self.max_tension)
        self._model = PCCModel(params)
        #: Whether the commands are cable lengths (else tensions).
        self.commands_lengths = self.mode == "length_delta"

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
