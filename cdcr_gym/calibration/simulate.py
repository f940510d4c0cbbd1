"""Forward models for a calibration: the tips a robot with given parameters reaches under the
measured tensions, replayed in measurement order.

* :class:`AnalyticReplay` — the CCKA/PCC model (``AnalyticBackend.equilibrium``), all rows in
  one batched call. Quasi-static and frictionless: the order of the rows does not matter.
* :class:`BackendReplay` — any :class:`~cdcr_gym.backends.base.Backend` (pybullet, MuJoCo)
  built from the candidate parameters and driven through the rows in order: it starts at rest
  with slack cables (``reset``), then for every row ramps the tensions linearly from the
  previous row's over ``ramp_steps`` control steps (slowly, as weights are hung on a cable) and
  holds them for ``settle_steps`` more, and reads the tip. Each row's static solve is thus the
  dynamics relaxing to rest, warm-started from the previous row's state, so the friction state
  of the cables (loading vs unloading) carries from row to row as it did on the robot.

Both return the tips in the measurement frame (the base tilt applied) and the tip tangents.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

import numpy as np

from cdcr_gym.calibration.data import Measurements
from cdcr_gym.calibration.parameters import accepts, robot_with, tilt_matrix, tilt_quaternion
from cdcr_gym.model.params import RobotParams

__all__ = ["BACKENDS", "backend_class", "AnalyticReplay", "BackendReplay", "Prediction"]

#: Backend name → "module:class" of the physics backends (imported when used).
BACKENDS = {
    "bullet": "cdcr_gym.backends.bullet:BulletBackend",
    "mujoco": "cdcr_gym.backends.mujoco:MuJoCoBackend",
}


def backend_class(name: str) -> Any:
    """The class of backend ``name`` ("analytic" → None; "bullet", "mujoco").

    Raises:
        ValueError: for an unknown name, or a backend this installation does not have.
    """
    if name == "analytic":
        return None
    if name not in BACKENDS:
        raise ValueError(f"backend must be one of {['analytic', *BACKENDS]}, got {name!r}")
    module, attribute = BACKENDS[name].split(":")
    try:
        return getattr(importlib.import_module(module), attribute)
    except (ImportError, AttributeError) as exc:
        raise ValueError(
            f"the {name} backend ({BACKENDS[name]}) is not available here: {exc}"
        ) from None


@dataclass
class Prediction:
    """Predicted tips (M, 3) m and tangents (M, 3) in the measurement frame; ``unsettled``: the
    largest tip motion (m) over the last control step of any row (0 for a static model)."""

    tip: np.ndarray
    tip_direction: np.ndarray
    unsettled: float = 0.0


class AnalyticReplay:
    """The CCKA/PCC prediction of every row at once (no gravity, no friction, no payload)."""

    name = "analytic"

    def __init__(self, data: Measurements, base: RobotParams, backend_kwargs: dict | None = None):
        if backend_kwargs:
            raise ValueError(
                f"the analytic backend takes no backend arguments, got {sorted(backend_kwargs)}"
            )
        self.data = data
        self.base = base

    def backend_kwargs(self, values: dict[str, float]) -> dict[str, Any]:
        """Keyword arguments of the backend for ``values`` (none for the analytic model)."""
        return {}

    def __call__(self, values: dict[str, float]) -> Prediction:
        from cdcr_gym.backends.analytic import AnalyticBackend

        params = robot_with(self.base, values)
        r = AnalyticBackend(params).equilibrium(self.data.tensions)
        rot = tilt_matrix(values)
        return Prediction(r.tip @ rot.T, r.tip_direction @ rot.T)


class BackendReplay:
    """A physics backend driven through the rows in order (module docstring).

    Args:
        data: the measurements (their tensions and order).
        base: the nominal robot (the fitted robot parameters replace its values).
        backend: backend name ("bullet", "mujoco") or a Backend class.
        backend_kwargs: fixed keyword arguments of the backend (e.g. ``gravity``,
            ``links_per_span``); the fitted ``friction_coefficient``, ``tip_payload`` and base
            tilt (``base_orientation``) are added per evaluation.
        ramp_steps: control steps over which a row's tensions are ramped from the previous row's.
        settle_steps: control steps they are then held before the tip is read.
    """

    def __init__(
        self,
        data: Measurements,
        base: RobotParams,
        backend: Any = "bullet",
        backend_kwargs: dict | None = None,
        ramp_steps: int = 25,
        settle_steps: int = 100,
    ) -> None:
        self.cls = backend_class(backend) if isinstance(backend, str) else backend
        self.name = backend if isinstance(backend, str) else getattr(backend, "__name__", "backend")
        self.data = data
        self.base = base
        self.fixed = dict(backend_kwargs or {})
        for key in self.fixed:
            if not accepts(self.cls, key):
                raise ValueError(f"the {self.name} backend has no argument {key!r}")
        for name, value in (("ramp_steps", ramp_steps), ("settle_steps", settle_steps)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        self.ramp_steps = int(ramp_steps)
        self.settle_steps = int(settle_steps)

    def backend_kwargs(self, values: dict[str, float]) -> dict[str, Any]:
        """The backend's keyword arguments for ``values``: the fixed ones plus the fitted
        friction, payload and tilt."""
        kw = dict(self.fixed)
        for key in ("friction_coefficient", "tip_payload"):
            if key in values:
                kw[key] = float(values[key])
        if ("base_tilt_x" in values or "base_tilt_y" in values) and accepts(
            self.cls, "base_orientation"
        ):
            kw["base_orientation"] = tilt_quaternion(values)
        return kw

    def __call__(self, values: dict[str, float]) -> Prediction:
        params = robot_with(self.base, values)
        backend = self.cls(params=params, **self.backend_kwargs(values))
        try:
            tips, dirs, moved = [], [], 0.0
            previous = np.zeros(params.n_cables)
            backend.reset(previous[None])
            for target in self.data.tensions:
                for k in range(1, self.ramp_steps + 1):
                    backend.apply_tensions(
                        (previous + (target - previous) * (k / self.ramp_steps))[None]
                    )
                before = backend.read().tip[0]
                for _ in range(self.settle_steps):
                    before = backend.read().tip[0]
                    backend.apply_tensions(target[None])
                r = backend.read()
                moved = max(moved, float(np.linalg.norm(r.tip[0] - before)))
                tips.append(r.tip[0])
                dirs.append(r.tip_direction[0])
                previous = target
        finally:
            backend.close()
        tip, direction = np.array(tips), np.array(dirs)
        if "base_tilt_x" in values or "base_tilt_y" in values:
            # the backend reports R0 of the (tilted) base; with base_orientation it also tilted
            # gravity, else the tilt is a frame rotation only
            rot = tilt_matrix(values)
            tip, direction = tip @ rot.T, direction @ rot.T
        return Prediction(tip, direction, moved)
