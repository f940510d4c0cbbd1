"""Drawing the robot with matplotlib (Agg), for ``render_mode="rgb_array"`` and ``"human"``.

matplotlib is imported lazily, inside the functions, so that importing cdcr_gym stays cheap.
"""

from __future__ import annotations

import numpy as np

from cdcr_gym.params import CABLE_ANGLES, RobotParams

__all__ = ["draw_robot", "show_robot"]

_CABLE_COLOURS = ("tab:red", "tab:green", "tab:blue")


def _disk_stations(points: np.ndarray, n_disks: int) -> tuple[np.ndarray, np.ndarray]:
    """Positions (n_disks+1, 3) and unit tangents (n_disks+1, 3) of the base and spacer disks.

    The disks sit evenly in arc length along the polyline ``points`` (n, 3), the last at its end.
    """
    seg = np.diff(points, axis=0)
    seg_len = np.linalg.norm(seg, axis=-1)
    s = np.concatenate([[0.0], np.cumsum(seg_len)])
    targets = np.linspace(0.0, s[-1], n_disks + 1)
    idx = np.clip(np.searchsorted(s, targets, side="right") - 1, 0, len(seg) - 1)
    frac = np.where(seg_len[idx] > 0, (targets - s[idx]) / np.where(seg_len[idx] > 0, seg_len[idx], 1), 0)
    pos = points[idx] + frac[:, None] * seg[idx]
    tangent = seg[idx] / np.where(seg_len[idx] > 0, seg_len[idx], 1.0)[:, None]
    return pos, tangent


def _disk_circle(centre: np.ndarray, tangent: np.ndarray, radius: float, n: int = 24) -> np.ndarray:
    """Points (n, 3) of a circle of ``radius`` around ``centre`` normal to ``tangent``.

    The in-plane axes follow the parallel-transport-free frame of a bend without twist: e1 is +X0
    rotated with the section (minimal rotation from +Z0 to the tangent).
    """
    rot = _min_rotation(tangent)
    ang = np.linspace(0.0, 2.0 * np.pi, n)
    local = np.stack([np.cos(ang), np.sin(ang), np.zeros(n)], axis=-1) * radius
    return centre + local @ rot.T


def _min_rotation(tangent: np.ndarray) -> np.ndarray:
    """The rotation (3, 3) taking +Z0 to ``tangent`` about the axis Z0 × tangent (no twist)."""
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, tangent)
    s = np.linalg.norm(axis)
    c = float(np.dot(z, tangent))
    if s < 1e-12:
        return np.eye(3)
    k = axis / s
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + s * kx + (1 - c) * kx @ kx


def _draw(ax, points: np.ndarray, params: RobotParams, goal: np.ndarray | None) -> None:
    mm = 1000.0
    p = points * mm
    ax.plot(p[:, 0], p[:, 1], p[:, 2], color="0.2", linewidth=2.5, label="backbone")
    pos, tangent = _disk_stations(points, params.n_disks)
    rot_last = None
    for i, (c, t) in enumerate(zip(pos, tangent)):
        circle = _disk_circle(c, t, params.disk_radius) * mm
        ax.plot(circle[:, 0], circle[:, 1], circle[:, 2], color="0.5" if i else "k", linewidth=1)
        rot_last = _min_rotation(t)
    # cable pinholes on the tip disk, coloured per cable
    for beta, colour in zip(CABLE_ANGLES, _CABLE_COLOURS):
        hole = pos[-1] + rot_last @ (params.cable_radius * np.array([np.cos(beta), np.sin(beta), 0.0]))
        ax.scatter(*(hole * mm), color=colour, s=12)
    ax.scatter(*(points[-1] * mm), color="tab:orange", s=30, label="tip")
    if goal is not None:
        g = np.asarray(goal, dtype=np.float64) * mm
        ax.scatter(g[0], g[1], g[2], color="tab:purple", marker="*", s=120, label="goal")
    reach = params.length * mm
    ax.set_xlim(-reach, reach)
    ax.set_ylim(-reach, reach)
    ax.set_zlim(0.0, reach * 1.05)
    ax.set_xlabel("X0 (mm)")
    ax.set_ylabel("Y0 (mm)")
    ax.set_zlabel("Z0 (mm)")
    ax.legend(loc="upper left", fontsize=7)


def draw_robot(
    points: np.ndarray,
    params: RobotParams,
    goal: np.ndarray | None = None,
    width: int = 480,
    height: int = 480,
) -> np.ndarray:
    """Render the backbone polyline ``points`` (n, 3) m, its disks and ``goal`` (3,) m.

    Returns:
        RGB image, shape (height, width, 3), uint8.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    dpi = 100
    fig = Figure(figsize=(width / dpi, height / dpi), dpi=dpi)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_subplot(projection="3d")
    _draw(ax, np.asarray(points, dtype=np.float64), params, goal)
    canvas.draw()
    image = np.asarray(canvas.buffer_rgba())[..., :3].copy()
    return image


def show_robot(points: np.ndarray, params: RobotParams, goal: np.ndarray | None = None) -> None:
    """Draw the robot in an interactive matplotlib window (non-blocking)."""
    import matplotlib.pyplot as plt

    fig = plt.figure("cdcr_gym", figsize=(6, 6))
    fig.clf()
    ax = fig.add_subplot(projection="3d")
    _draw(ax, np.asarray(points, dtype=np.float64), params, goal)
    plt.pause(0.001)
