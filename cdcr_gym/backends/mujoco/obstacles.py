"""Obstacle spheres in a :class:`~cdcr_gym.backends.mujoco.backend.MuJoCoBackend`'s scene.

The spheres are MuJoCo geoms on mocap bodies, built into the model on first use (the robot's
links and disks then become capsule and cylinder geoms); collisions are MuJoCo's contacts. The
backend's ``set_obstacles``, ``obstacle_clearance`` and ``contact_forces`` call these functions.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from cdcr_gym import validation
from cdcr_gym.backends.mujoco.mjcf import PARKED

__all__ = ["place_spheres", "clearance", "contact_forces"]


def place_spheres(backend: Any, index: np.ndarray, spheres: np.ndarray) -> None:
    """Place spheres ``spheres`` (M, K, 4) rows (x, y, z, radius) m in R0 for robots
    ``index`` (M,); a row of radius 0 is no sphere. The first call with K spheres builds
    them into the model (MuJoCo geoms on mocap bodies; the robot's links and disks become
    capsule and cylinder geoms), keeping every robot's state. Collisions are then MuJoCo's
    contacts: :attr:`obstacle_clearance`, and with ``solid_obstacles`` the spheres push
    back (:attr:`contact_forces`)."""
    backend._check_open()
    idx = np.asarray(index).reshape(-1).tolist()
    rows = validation.real_array(spheres, "spheres")
    if rows.ndim != 3 or rows.shape[0] != len(idx) or rows.shape[2] != 4:
        raise ValueError(
            f"spheres must have shape ({len(idx)}, K, 4) (x, y, z, radius m), got {rows.shape}"
        )
    if np.any(rows[..., 3] < 0.0):
        raise ValueError(f"spheres: radii must be >= 0 m, got {rows[..., 3]!r}")
    k = rows.shape[1]
    if k > backend.n_obstacles:
        backend._rebuild(backend._has_segments, k)
    mj = backend._mj
    for row, i in zip(rows, idx):
        model = backend._own_model(i)
        data = backend._datas[i]
        for j, g in enumerate(backend._sphere_geoms):
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
        backend._sense(i)


def clearance(backend: Any) -> np.ndarray:
    """Smallest distance (N,) m between every robot's geoms (links as capsules of the rod's
    radius, disks as cylinders) and its spheres, by MuJoCo's ``mj_geomDistance``
    (negative: penetration; inf without spheres, or with none within ℓ)."""
    mj = backend._mj
    out = np.full(backend.num_robots, np.inf)
    fromto = np.zeros(6)
    reach = backend.params.length
    for i, (model, data) in enumerate(zip(backend._models, backend._datas)):
        for g in backend._sphere_geoms:
            if data.mocap_pos[model.body_mocapid[model.geom_bodyid[g]], 0] >= PARKED:
                continue
            for r in backend._robot_geoms:
                out[i] = min(out[i], mj.mj_geomDistance(model, data, r, g, reach, fromto))
    return out


def contact_forces(backend: Any) -> np.ndarray:
    """Total normal force (N,) N the spheres exert on every robot in its current state (0
    unless ``solid_obstacles``)."""
    out = np.zeros(backend.num_robots)
    if not backend.solid_obstacles or not backend.n_obstacles:
        return out
    force = np.zeros(6)
    for i, (model, data) in enumerate(zip(backend._models, backend._datas)):
        # the constraint forces of the current state (the stepping leaves only its
        # position and velocity stages computed); mj_forward changes no state
        backend._mj.mj_forward(model, data)
        for c in range(data.ncon):
            if data.contact.efc_address[c] >= 0:
                backend._mj.mj_contactForce(model, data, c, force)
                out[i] += force[0]
    return out
