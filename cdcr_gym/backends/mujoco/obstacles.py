"""Obstacle spheres in a :class:`~cdcr_gym.backends.mujoco.backend.MuJoCoBackend`'s scene.

The spheres are MuJoCo geoms on mocap bodies, built into the model on first use (the robot's
links and disks then become capsule and cylinder geoms); collisions are MuJoCo's contacts.
:class:`ObstacleScene` holds the backend's ``set_obstacles``, ``obstacle_clearance`` and
``contact_forces`` (a part of ``MuJoCoBackend``, kept in its own file; its methods use the
backend's own model, data and geom ids).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cdcr_gym import validation
from cdcr_gym.backends.mujoco.mjcf import PARKED

__all__ = ["ObstacleScene"]


class ObstacleScene:
    """The obstacle part of :class:`~cdcr_gym.backends.mujoco.backend.MuJoCoBackend` (a base
    class of it; not used on its own)."""

    def set_obstacles(self: Any, index: np.ndarray, spheres: np.ndarray) -> None:
        """Place spheres ``spheres`` (M, K, 4) rows (x, y, z, radius) m in R0 for robots
        ``index`` (M,); a row of radius 0 is no sphere. The first call with K spheres builds
        them into the model (MuJoCo geoms on mocap bodies; the robot's links and disks become
        capsule and cylinder geoms), keeping every robot's state. Collisions are then MuJoCo's
        contacts: :attr:`obstacle_clearance`, and with ``solid_obstacles`` the spheres push
        back (:attr:`contact_forces`)."""
        self._check_open()
        idx = np.asarray(index).reshape(-1).tolist()
        rows = validation.real_array(spheres, "spheres")
        if rows.ndim != 3 or rows.shape[0] != len(idx) or rows.shape[2] != 4:
            raise ValueError(
                f"spheres must have shape ({len(idx)}, K, 4) (x, y, z, radius m), got {rows.shape}"
            )
        if np.any(rows[..., 3] < 0.0):
            raise ValueError(f"spheres: radii must be >= 0 m, got {rows[..., 3]!r}")
        k = rows.shape[1]
        if k > self.n_obstacles:
            self._rebuild(self._has_segments, k)
        mj = self._mj
        for row, i in zip(rows, idx):
            model = self._own_model(i)
            data = self._datas[i]
            for j, g in enumerate(self._sphere_geoms):
                present = j < k and row[j, 3] > 0.0
                radius = row[j, 3] if present else 1e-3
                # the sphere's size, bounding radius and boxes: the geom's and its body's
                # bounding-volume node (compiled once; a stale one hides the contacts)
                model.geom_size[g, 0] = radius
                model.geom_rbound[g] = radius
                model.geom_aabb[g, 3:] = radius
                model.bvh_aabb[model.body_bvhadr[model.geom_bodyid[g]], 3:] = radius
                parked = (PARKED * (j + 1), PARKED, PARKED)
                data.mocap_pos[j] = row[j, :3] if present else parked
            mj.mj_forward(model, data)  # the contacts of the new scene
            self._sense(i)

    @property
    def obstacle_clearance(self: Any) -> np.ndarray:
        """Smallest distance (N,) m between every robot's geoms (links as capsules of the rod's
        radius, disks as cylinders) and its spheres, by MuJoCo's ``mj_geomDistance``
        (negative: penetration; inf without spheres, or with none within ℓ)."""
        mj = self._mj
        out = np.full(self.num_robots, np.inf)
        fromto = np.zeros(6)
        reach = self.params.length
        for i, (model, data) in enumerate(zip(self._models, self._datas)):
            for g in self._sphere_geoms:
                if data.mocap_pos[model.body_mocapid[model.geom_bodyid[g]], 0] >= PARKED:
                    continue
                for r in self._robot_geoms:
                    out[i] = min(out[i], mj.mj_geomDistance(model, data, r, g, reach, fromto))
        return out

    @property
    def contact_forces(self: Any) -> np.ndarray:
        """Total normal force (N,) N the spheres exert on every robot in its current state (0
        unless ``solid_obstacles``)."""
        out = np.zeros(self.num_robots)
        if not self.solid_obstacles or not self.n_obstacles:
            return out
        force = np.zeros(6)
        for i, (model, data) in enumerate(zip(self._models, self._datas)):
            # the constraint forces of the current state (the stepping leaves only its
            # position and velocity stages computed); mj_forward changes no state
            self._mj.mj_forward(model, data)
            for c in range(data.ncon):
                if data.contact.efc_address[c] >= 0:
                    self._mj.mj_contactForce(model, data, c, force)
                    out[i] += force[0]
        return out
