"""The camera of :class:`~cdcr_gym.backends.bullet.backend.BulletBackend`: a goal marker and
pybullet's headless TinyRenderer (``render_rgb``)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["BulletRendering"]


class BulletRendering:
    """``render_rgb`` of a pybullet backend (mixed into ``BulletBackend``: it uses the backend's
    client, base rotation, goal body and parameters)."""

    _pb: Any
    _client: Any
    _goal_body: int
    _base_rot: np.ndarray
    params: Any
    _check_open: Callable[[], None]

    def _place_goal(self, goal) -> None:
        pb = self._pb
        if goal is None:
            pos: tuple[float, ...] = (0.0, 0.0, -100.0)
        else:
            g = np.asarray(goal, dtype=np.float64)
            if g.shape != (3,) or not np.all(np.isfinite(g)):
                raise ValueError(f"goal must be 3 finite numbers (m, R0) or None, got {goal!r}")
            pos = tuple(float(v) for v in self._base_rot @ g)
        pb.resetBasePositionAndOrientation(
            self._goal_body, pos, (0, 0, 0, 1), physicsClientId=self._client
        )

    def render_rgb(self, goal: np.ndarray | None, width: int, height: int) -> np.ndarray:
        """Image (height, width, 3) uint8 from pybullet's headless TinyRenderer.

        The camera is fixed in the world (Z_world up; pybullet yaw 30°, pitch −20°, distance 1.9ℓ),
        aimed at the middle of the robot's workspace; the goal is a purple sphere and the tip
        link orange.
        """
        self._check_open()
        for name, v in (("width", width), ("height", height)):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f"{name} must be a positive integer (pixels), got {v!r}")
        pb, cid = self._pb, self._client
        self._place_goal(goal)
        ell = self.params.length
        target = self._base_rot @ np.array([0.0, 0.0, 0.4 * ell])
        view = pb.computeViewMatrixFromYawPitchRoll(
            target.tolist(), 1.9 * ell, 30.0, -20.0, 0.0, 2, physicsClientId=cid
        )
        proj = pb.computeProjectionMatrixFOV(
            45.0, width / height, 0.01, 10.0 * ell, physicsClientId=cid
        )
        _, _, rgba, _, _ = pb.getCameraImage(
            int(width),
            int(height),
            view,
            proj,
            renderer=pb.ER_TINY_RENDERER,
            flags=pb.ER_NO_SEGMENTATION_MASK,
            physicsClientId=cid,
        )
        img = np.asarray(rgba, dtype=np.uint8).reshape(int(height), int(width), 4)
        return np.ascontiguousarray(img[:, :, :3])
