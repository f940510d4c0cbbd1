"""Clearance between a robot and spherical obstacles (batched numpy), for the Obstacle task
and its planner.

The robot is its backbone (a polyline through ``backbone_points``, a rod of radius d/2) and its
disks (flat discs of radius ``params.disk_radius`` centred on the backbone, normal to its
tangent; the base disk included). The clearance to a sphere (centre c, radius R) is the
distance from c to the nearest part minus R: negative means a collision.

* rod: distance from c to each polyline segment, minus d/2 (a chain of capsules: the rod's
  ends are rounded, d/2 = 2.5 mm beyond the tip on the paper robot — conservative);
* disc (centre o, unit normal n, radius ρ_d): with v = c − o, h = v·n and q = |v − h n|,
  the distance is |h| if q <= ρ_d, else √(h² + (q − ρ_d)²) (exact).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from cdcr_gym.backends.base import Backend
from cdcr_gym.model.chain import PCCModel

__all__ = [
    "RobotGeometry",
    "backend_geometry",
    "model_geometry",
    "clearance",
    "nearest_backbone_points",
    "route_clearance",
    "directions_out",
]


class RobotGeometry(NamedTuple):
    """The parts of M robots that obstacles can touch (m, R0)."""

    points: np.ndarray  #: (M, P, 3) backbone polyline, base to tip
    disk_centres: np.ndarray  #: (M, D + 1, 3)
    disk_normals: np.ndarray  #: (M, D + 1, 3) unit backbone tangents at the disks


def model_geometry(model: PCCModel, bending: np.ndarray) -> RobotGeometry:
    """Geometry of shapes ``bending`` (M, S, 2) rad on the PCC model (8 points per section)."""
    points = model.backbone_points(bending, points_per_section=8)
    centres, rotations = model.disk_frames(bending)
    return RobotGeometry(points, centres, rotations[..., :, 2])


def backend_geometry(backend: Backend) -> RobotGeometry:
    """Geometry of every robot of ``backend`` (batched on the analytic backend)."""
    bending = getattr(backend, "bending", None)
    model = getattr(backend, "model", None)
    if isinstance(model, PCCModel) and bending is not None:
        return model_geometry(model, bending)
    pts, cen, nor = [], [], []
    for i in range(backend.num_robots):
        pts.append(backend.backbone_points(i))
        c, r = backend.disk_frames(i)
        cen.append(c)
        nor.append(r[:, :, 2])
    return RobotGeometry(np.stack(pts), np.stack(cen), np.stack(nor))


def clearance(
    geometry: RobotGeometry,
    spheres: np.ndarray,
    rod_radius: float,
    disk_radius: float,
) -> np.ndarray:
    """Clearance (m) of each robot to each sphere: (M, K).

    Args:
        geometry: M robots.
        spheres: (M, K, 4) or (K, 4) rows (x, y, z, radius) m; a radius <= 0 marks padding,
            whose clearance is +inf.
        rod_radius: backbone radius (m).
        disk_radius: disk radius (m).
    """
    spheres = np.asarray(spheres, dtype=np.float64)
    m = geometry.points.shape[0]
    if spheres.ndim == 2:
        spheres = np.broadcast_to(spheres, (m,) + spheres.shape)
    c = spheres[:, :, None, :3]  # (M, K, 1, 3)
    radius = spheres[:, :, 3]
    a = geometry.points[:, None, :-1]  # (M, 1, P-1, 3)
    ab = geometry.points[:, None, 1:] - a
    ac = c - a
    t = np.clip(np.sum(ac * ab, -1) / np.maximum(np.sum(ab * ab, -1), 1e-300), 0.0, 1.0)
    d_rod = np.linalg.norm(ac - t[..., None] * ab, axis=-1).min(-1) - rod_radius
    v = c - geometry.disk_centres[:, None]  # (M, K, D+1, 3)
    n = geometry.disk_normals[:, None]
    h = np.sum(v * n, -1)
    q = np.linalg.norm(v - h[..., None] * n, axis=-1)
    d_disk = np.where(q <= disk_radius, np.abs(h), np.hypot(h, q - disk_radius)).min(-1)
    out = np.minimum(d_rod, d_disk) - radius
    return np.where(radius > 0.0, out, np.inf)


def nearest_backbone_points(geometry: RobotGeometry, spheres: np.ndarray) -> np.ndarray:
    """The point of each robot's backbone polyline nearest to each sphere's centre: (M, K, 3) m.

    Args:
        geometry: M robots.
        spheres: (M, K, 4) or (K, 4) rows (x, y, z, radius) m (padding rows are measured too;
            callers mask them).
    """
    spheres = np.asarray(spheres, dtype=np.float64)
    m = geometry.points.shape[0]
    if spheres.ndim == 2:
        spheres = np.broadcast_to(spheres, (m,) + spheres.shape)
    c = spheres[:, :, None, :3]  # (M, K, 1, 3)
    a = geometry.points[:, None, :-1]  # (M, 1, P-1, 3)
    ab = geometry.points[:, None, 1:] - a
    t = np.clip(np.sum((c - a) * ab, -1) / np.maximum(np.sum(ab * ab, -1), 1e-300), 0.0, 1.0)
    nearest = a + t[..., None] * ab  # (M, K, P-1, 3)
    d2 = np.sum((c - nearest) ** 2, -1)
    best = np.argmin(d2, axis=-1)  # (M, K)
    return np.take_along_axis(nearest, best[..., None, None], axis=2)[:, :, 0]


def route_clearance(
    model: PCCModel,
    start: np.ndarray,
    goal: np.ndarray,
    spheres: np.ndarray,
    rod_radius: float,
    disk_radius: float,
    samples: int = 9,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """How each sphere lies against the *direct route*: the straight line in tension space
    from ``start`` to ``goal`` (what the reach IK commands), sampled at ``samples`` evenly
    spaced tensions (both ends included) and shaped on the PCC/CCKA ``model``.

    Args:
        model: the robot model.
        start: (M, C) N, the tensions now.
        goal: (M, C) N, the tensions at the route's end (the goal's IK tensions).
        spheres: (M, K, 4) rows (x, y, z, radius) m; a radius <= 0 marks padding.
        rod_radius: backbone radius (m).
        disk_radius: disk radius (m).
        samples: points along the route, >= 2.

    Returns:
        ``clearances`` (M, K) m: each sphere's smallest clearance to the route's shapes
        (negative: the route runs through it; +inf for padding); ``fractions`` (M, K) in
        [0, 1]: where along the route that smallest clearance is (0: now, 1: at the goal; 0
        for padding); ``directions`` (M, K, 3): the unit vector from the sphere's centre to
        the nearest backbone point of that shape — the side on which the route passes the
        sphere (0 for padding, and where the backbone runs through the centre).
    """
    start = np.asarray(start, dtype=np.float64)
    goal = np.asarray(goal, dtype=np.float64)
    spheres = np.asarray(spheres, dtype=np.float64)
    m, c = start.shape
    k = spheres.shape[1]
    lam = np.linspace(0.0, 1.0, samples)
    tensions = start[:, None, :] + lam[None, :, None] * (goal - start)[:, None, :]
    geometry = model_geometry(model, model.bending_from_tensions(tensions.reshape(-1, c)))
    repeated = np.repeat(spheres, samples, axis=0)  # (M * R, K, 4), route-major per env
    per = clearance(geometry, repeated, rod_radius, disk_radius).reshape(m, samples, k)
    deepest = np.argmin(per, axis=1)  # (M, K)
    nearest = nearest_backbone_points(geometry, repeated).reshape(m, samples, k, 3)
    points = np.take_along_axis(nearest, deepest[:, None, :, None], axis=1)[:, 0]
    fractions = np.where(spheres[:, :, 3] > 0.0, lam[deepest], 0.0)
    return per.min(axis=1), fractions, directions_out(points, spheres)


def directions_out(points: np.ndarray, spheres: np.ndarray) -> np.ndarray:
    """Unit vectors (M, K, 3) from each sphere's centre to ``points`` (M, K, 3) m, the way out
    of it; 0 for padding spheres (radius <= 0) and where a point is the centre itself."""
    away = points - spheres[:, :, :3]
    norm = np.linalg.norm(away, axis=-1, keepdims=True)
    present = spheres[:, :, 3:4] > 0.0
    return np.divide(away, norm, out=np.zeros_like(away), where=present & (norm > 0.0))
