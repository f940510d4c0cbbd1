"""One look for every backend: a small numpy software renderer of the robot and its task.

The input is plain arrays, so any backend can be drawn: its backbone polyline, its disk frames
(:meth:`cdcr_gym.backends.base.Backend.disk_frames`), the robot's :class:`RobotParams` and the
cable tensions, plus the task's markers. :func:`draw_scene` returns an RGB image
(``render_mode="rgb_array"``); :func:`show_scene` shows it in a window (``render_mode="human"``).

What is drawn, in the base frame R0 (m):

* a ground grid in the plane z = 0 (spacing 1, 2 or 5 × 10^k m, about a fifth of the robot's
  length) with the X0 (red) and Y0 (green) axes, and the base plate;
* the backbone (dark line through ``backbone_points``), every disk as a shaded plate of radius
  ``params.disk_radius`` in its own plane;
* every cable as a polyline through its pinholes, ``centre_k + R_k @ (r cos β, r sin β, 0)``, in
  the disks it passes (a cable of section m passes the base disk and every disk of sections
  1…m), coloured by its tension: grey-blue when slack, orange at half ``max_tension``, red at
  ``max_tension``;
* the goal (purple sphere), an optional target (cyan sphere) and optional obstacles
  (translucent brown spheres, given as centre and radius).

The camera is fixed for a robot: perspective, looking at the base from azimuth −60° and elevation
25° (X0 to the right, Y0 into the picture, Z0 up), at a distance that fits a ball of radius 0.75 ℓ
around (0, 0, 0.4 ℓ) (ℓ = ``params.length``, the whole robot). Lines have no anti-aliasing; hidden
parts are resolved per pixel by depth. A 320 × 320 frame costs about 7 ms on one CPU core
(``python -m cdcr_gym.rendering`` measures it; ≈ 10× faster than the matplotlib renderer this
replaced), so recording an evaluation video costs seconds. Only numpy is needed;
:func:`show_scene` also needs matplotlib and a display.
"""

from __future__ import annotations

import functools
import math
import os
import sys
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from cdcr_gym.model.params import RobotParams, SectionParams

__all__ = ["Camera", "draw_scene", "show_scene", "tension_colour", "GOAL_COLOUR", "TARGET_COLOUR"]

#: RGB of the goal marker.
GOAL_COLOUR = (150, 40, 210)
#: RGB of the target marker.
TARGET_COLOUR = (0, 180, 210)
_OBSTACLE_COLOUR = (170, 110, 70)
_OBSTACLE_ALPHA = 0.55
_BACKBONE_COLOUR = (45, 45, 50)
_DISK_COLOUR = (205, 208, 215)
_DISK_RIM_COLOUR = (95, 98, 110)
_BASE_COLOUR = (70, 72, 82)
_GRID_COLOUR = (188, 192, 200)
_TIP_COLOUR = (255, 140, 0)
_SKY_TOP, _SKY_BOTTOM = (250, 251, 253), (226, 230, 237)
#: Tension colour map stops: fraction of max_tension -> RGB.
_TENSION_STOPS = np.array([0.0, 0.5, 1.0])
_TENSION_RGB = np.array([[140, 155, 175], [245, 150, 30], [210, 20, 30]], dtype=np.float64)

_AZIMUTH_DEG = -60.0
_ELEVATION_DEG = 25.0
_FOV_DEG = 40.0


def tension_colour(fraction: np.ndarray | float) -> np.ndarray:
    """RGB (..., 3) uint8 of a cable at tension ``fraction`` of ``max_tension`` (clipped to [0, 1])."""
    f = np.clip(np.asarray(fraction, dtype=np.float64), 0.0, 1.0)
    rgb = np.stack([np.interp(f, _TENSION_STOPS, _TENSION_RGB[:, c]) for c in range(3)], axis=-1)
    return np.rint(rgb).astype(np.uint8)


@dataclass(frozen=True)
class Camera:
    """A pinhole camera: eye position (3,) m, orthonormal axes right/up/forward (3,) in R0,
    focal length ``focal`` (pixels) and image size."""

    eye: np.ndarray
    right: np.ndarray
    up: np.ndarray
    forward: np.ndarray
    focal: float
    width: int
    height: int

    @classmethod
    def fixed(cls, length: float, width: int, height: int) -> Camera:
        """The fixed camera for a robot of total length ``length`` (m), see the module doc."""
        target = np.array([0.0, 0.0, 0.4 * length])
        radius = 0.75 * length
        half_fov = math.radians(_FOV_DEG) / 2.0
        distance = radius / math.sin(half_fov)
        az, el = math.radians(_AZIMUTH_DEG), math.radians(_ELEVATION_DEG)
        direction = np.array(
            [math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)]
        )
        eye = target + distance * direction
        forward = -direction
        right = np.cross(forward, [0.0, 0.0, 1.0])
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        focal = 0.5 * min(width, height) / math.tan(half_fov)
        return cls(eye, right, up, forward, focal, width, height)

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pixel coordinates u (right), v (down) and view depth (m) of ``points`` (..., 3)."""
        rel = np.asarray(points, dtype=np.float64) - self.eye
        depth = rel @ self.forward
        safe = np.where(depth > 1e-9, depth, 1e-9)
        u = 0.5 * self.width + self.focal * (rel @ self.right) / safe
        v = 0.5 * self.height - self.focal * (rel @ self.up) / safe
        return u, v, depth

    def rays(self) -> np.ndarray:
        """Unit-depth ray directions (height, width, 3) through the pixel centres, in R0."""
        u = (np.arange(self.width) + 0.5 - 0.5 * self.width) / self.focal
        v = (0.5 * self.height - (np.arange(self.height) + 0.5)) / self.focal
        return self.forward + u[None, :, None] * self.right + v[:, None, None] * self.up


# -- fragments: (linear pixel index, depth, colour) resolved per pixel by depth -----------------
class _Fragments:
    def __init__(self, camera: Camera) -> None:
        self.camera = camera
        self.index: list[np.ndarray] = []
        self.depth: list[np.ndarray] = []
        self.colour: list[np.ndarray] = []

    def add(self, x: np.ndarray, y: np.ndarray, depth: np.ndarray, colour: np.ndarray) -> None:
        w, h = self.camera.width, self.camera.height
        keep = (x >= 0) & (x < w) & (y >= 0) & (y < h) & (depth > 0)
        colour = np.broadcast_to(np.asarray(colour, dtype=np.uint8), (*x.shape, 3))
        self.index.append((y[keep] * w + x[keep]).astype(np.int64))
        self.depth.append(depth[keep])
        self.colour.append(colour[keep])

    def resolve(self, image: np.ndarray) -> np.ndarray:
        """Write the nearest fragment of every pixel into ``image`` (H, W, 3); return the depth
        buffer (H, W) (inf where nothing was drawn)."""
        zbuffer = np.full(image.shape[0] * image.shape[1], np.inf)
        if not self.index:
            return zbuffer.reshape(image.shape[:2])
        index = np.concatenate(self.index)
        depth = np.concatenate(self.depth)
        colour = np.concatenate(self.colour)
        order = np.lexsort((depth, index))
        index = index[order]
        first = np.ones(index.shape, dtype=bool)
        first[1:] = index[1:] != index[:-1]
        chosen = order[first]
        flat = image.reshape(-1, 3)
        flat[index[first]] = colour[chosen]
        zbuffer[index[first]] = depth[chosen]
        return zbuffer.reshape(image.shape[:2])


@functools.lru_cache(maxsize=32)
def _stamp(width_px: float) -> tuple[np.ndarray, np.ndarray]:
    """Pixel offsets (dy, dx) of a round brush of diameter ``width_px``."""
    r = max(width_px / 2.0, 0.5)
    n = math.ceil(r)
    dy, dx = np.mgrid[-n : n + 1, -n : n + 1]
    inside = dx**2 + dy**2 <= r * r + 1e-9
    return dy[inside].ravel(), dx[inside].ravel()


def _polylines(
    frags: _Fragments,
    segments: np.ndarray,
    colours: np.ndarray,
    width_px: float,
    depth_bias: float = 0.0,
) -> None:
    """Thick 3-D segments ``segments`` (S, 2, 3) m, colours (S, 3) uint8, ``width_px`` wide."""
    if len(segments) == 0:
        return
    u, v, depth = frags.camera.project(segments)  # (S, 2)
    ok = np.all(depth > 1e-6, axis=1)
    u, v, depth, colours = u[ok], v[ok], depth[ok], colours[ok]
    spacing = max(0.5, width_px / 3.0)
    lengths = np.hypot(u[:, 1] - u[:, 0], v[:, 1] - v[:, 0])
    counts = np.minimum(np.ceil(lengths / spacing).astype(np.int64) + 1, 20000)
    seg = np.repeat(np.arange(len(counts)), counts)
    start = np.cumsum(counts) - counts
    t = (np.arange(counts.sum()) - start[seg]) / np.maximum(counts[seg] - 1, 1)
    su = u[seg, 0] + t * (u[seg, 1] - u[seg, 0])
    sv = v[seg, 0] + t * (v[seg, 1] - v[seg, 0])
    # perspective-correct depth along the segment
    inv = (1.0 - t) / depth[seg, 0] + t / depth[seg, 1]
    sd = 1.0 / inv + depth_bias
    dy, dx = _stamp(width_px)
    x = (np.floor(su)[:, None] + dx[None, :]).astype(np.int64)
    y = (np.floor(sv)[:, None] + dy[None, :]).astype(np.int64)
    frags.add(
        x.ravel(), y.ravel(), np.repeat(sd, len(dx)), np.repeat(colours[seg], len(dx), axis=0)
    )


def _path_segments(points: np.ndarray) -> np.ndarray:
    return np.stack([points[:-1], points[1:]], axis=1)


def _bbox(camera: Camera, outline: np.ndarray) -> tuple[int, int, int, int] | None:
    u, v, depth = camera.project(outline)
    if np.any(depth <= 1e-6):
        return None
    x0, x1 = max(int(np.floor(u.min())) - 1, 0), min(int(np.ceil(u.max())) + 1, camera.width - 1)
    y0, y1 = max(int(np.floor(v.min())) - 1, 0), min(int(np.ceil(v.max())) + 1, camera.height - 1)
    if x0 > x1 or y0 > y1:
        return None
    return x0, x1, y0, y1


_CIRCLE = np.stack(
    [np.cos(np.linspace(0, 2 * np.pi, 33)), np.sin(np.linspace(0, 2 * np.pi, 33)), np.zeros(33)],
    axis=-1,
)


def _disks(
    frags: _Fragments,
    rays: np.ndarray,
    centres: np.ndarray,
    normals: np.ndarray,
    axes: np.ndarray,
    radius: np.ndarray,
    colour: tuple[int, int, int],
    rim: tuple[int, int, int],
    depth_bias: float,
) -> None:
    """Filled plates: centre (K, 3), unit normal (K, 3), in-plane axes (K, 2, 3), radius (K,)."""
    cam = frags.camera
    base = np.asarray(colour, dtype=np.float64)
    rim_rgb = np.asarray(rim, dtype=np.uint8)
    for c, n, ax, r in zip(centres, normals, axes, radius):
        outline = c + r * (_CIRCLE[:, :1] * ax[0] + _CIRCLE[:, 1:2] * ax[1])
        box = _bbox(cam, outline)
        if box is None:
            continue
        x0, x1, y0, y1 = box
        d = rays[y0 : y1 + 1, x0 : x1 + 1]  # (h, w, 3), unit depth along forward
        denom = d @ n
        safe = np.where(np.abs(denom) > 1e-12, denom, 1e-12)
        t = ((c - cam.eye) @ n) / safe  # = view depth, since d has unit forward component
        hit = cam.eye + t[..., None] * d
        rho = np.linalg.norm(hit - c, axis=-1) / r
        inside = (rho <= 1.0) & (t > 0)
        if not inside.any():
            continue
        ys, xs = np.nonzero(inside)
        facing = abs(float(cam.forward @ n))
        shade = 0.62 + 0.38 * facing
        rgb = np.broadcast_to(np.rint(base * shade).astype(np.uint8), (len(xs), 3)).copy()
        rgb[rho[ys, xs] > 0.86] = rim_rgb
        frags.add(xs + x0, ys + y0, t[ys, xs] + depth_bias, rgb)
        # edge-on plates still show as a line
        _polylines(
            frags, _path_segments(outline), np.broadcast_to(rim_rgb, (32, 3)), 1.0, depth_bias
        )


def _spheres(
    frags: _Fragments,
    rays: np.ndarray,
    centres: np.ndarray,
    radii: np.ndarray,
    colour: tuple[int, int, int],
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """Shaded spheres; returns per sphere (x, y, depth, rgb) of its visible front surface."""
    cam = frags.camera
    base = np.asarray(colour, dtype=np.float64)
    light = np.array([0.35, -0.45, 0.82])
    light /= np.linalg.norm(light)
    out = []
    for c, r in zip(centres, radii):
        u, v, depth = cam.project(c)
        if depth <= r:
            continue
        half = cam.focal * r / math.sqrt(max(depth**2 - r**2, 1e-18)) + 2.0
        x0, x1 = max(int(u - half), 0), min(int(u + half) + 1, cam.width - 1)
        y0, y1 = max(int(v - half), 0), min(int(v + half) + 1, cam.height - 1)
        if x0 > x1 or y0 > y1:
            continue
        d = rays[y0 : y1 + 1, x0 : x1 + 1]
        oc = cam.eye - c
        a = np.einsum("hwi,hwi->hw", d, d)
        b = d @ oc
        disc = b * b - a * (oc @ oc - r * r)
        inside = disc >= 0.0
        if not inside.any():
            continue
        ys, xs = np.nonzero(inside)
        t = (-b[ys, xs] - np.sqrt(disc[ys, xs])) / a[ys, xs]
        normal = (cam.eye + t[:, None] * d[ys, xs] - c) / r
        lambert = np.clip(normal @ light, 0.0, 1.0)
        rgb = np.clip(
            base * (0.55 + 0.45 * lambert)[:, None] + 40.0 * lambert[:, None] ** 8, 0, 255
        )
        out.append((xs + x0, ys + y0, t, np.rint(rgb).astype(np.uint8)))
    return out


def _nice_spacing(span: float) -> float:
    raw = span / 5.0
    exp = math.floor(math.log10(raw))
    for m in (1.0, 2.0, 5.0, 10.0):
        if m * 10**exp >= raw * 0.7:
            return m * 10**exp
    return 10.0 ** (exp + 1)


@functools.lru_cache(maxsize=8)
def _static_layer(
    length: float, disk_radius: float, width: int, height: int, line_scale: float
) -> tuple[np.ndarray, np.ndarray, Camera, np.ndarray]:
    """Background image, its depth buffer, camera and rays for a robot size and image size
    (cached: the camera is fixed)."""
    cam = Camera.fixed(length, width, height)
    rays = cam.rays()
    rows = np.linspace(0.0, 1.0, height)[:, None]
    sky = (1 - rows) * np.asarray(_SKY_TOP) + rows * np.asarray(_SKY_BOTTOM)
    image = np.broadcast_to(np.rint(sky).astype(np.uint8)[:, None, :], (height, width, 3)).copy()
    frags = _Fragments(cam)
    spacing = _nice_spacing(length)
    n = int(math.floor(length / spacing))
    ticks = np.arange(-n, n + 1) * spacing
    extent = n * spacing
    segs = []
    for t in ticks:
        segs.append([[t, -extent, 0.0], [t, extent, 0.0]])
        segs.append([[-extent, t, 0.0], [extent, t, 0.0]])
    segs_arr = np.asarray(segs, dtype=np.float64)
    _polylines(
        frags,
        segs_arr,
        np.broadcast_to(np.asarray(_GRID_COLOUR, np.uint8), (len(segs_arr), 3)),
        line_scale,
        1e-3 * length,
    )
    axis_len = 0.3 * length
    axes = np.array([[[0, 0, 0], [axis_len, 0, 0]], [[0, 0, 0], [0, axis_len, 0]]], dtype=float)
    _polylines(
        frags,
        axes,
        np.array([[220, 60, 60], [60, 170, 70]], np.uint8),
        2.0 * line_scale,
        5e-4 * length,
    )
    zbuffer = frags.resolve(image)
    image.setflags(write=False)
    zbuffer.setflags(write=False)
    rays.setflags(write=False)
    return image, zbuffer, cam, rays


def _check_array(name: str, value: Any, shape: tuple[int | None, ...]) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    ok = arr.ndim == len(shape) and all(s is None or s == a for s, a in zip(shape, arr.shape))
    if not ok or not np.all(np.isfinite(arr)):
        want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
        raise ValueError(
            f"{name} must be finite numbers of shape {want}, got shape {arr.shape}: {value!r}"[:300]
        )
    return arr


def _check_size(name: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 16:
        raise ValueError(f"{name} must be an integer >= 16 (pixels), got {value!r}")
    return int(value)


def draw_scene(
    backbone_points: np.ndarray,
    disk_centres: np.ndarray,
    disk_rotations: np.ndarray,
    params: RobotParams,
    tensions: np.ndarray,
    goal: np.ndarray | None = None,
    target: np.ndarray | None = None,
    obstacles: Any = None,
    width: int = 480,
    height: int = 480,
) -> np.ndarray:
    """Render the robot and its task markers; returns an RGB image (height, width, 3) uint8.

    Args:
        backbone_points: (P, 3) m in R0, base to tip.
        disk_centres: (D + 1, 3) m, base disk first (D = ``params.n_disks``).
        disk_rotations: (D + 1, 3, 3), columns the disk's x, y axes and the backbone tangent.
        params: the robot (disk radius, cable radii and angles, sections, ``max_tension``).
        tensions: (C,) N, cable order of ``params``; colour the cables.
        goal: (3,) m or None: purple sphere.
        target: (3,) m or None: cyan sphere (e.g. a tracking task's moving reference).
        obstacles: None, or spheres as an (K, 4) array of (x, y, z, radius) m, or a sequence of
            (centre (3,), radius) pairs: drawn translucent.
        width: image width (pixels, >= 16).
        height: image height (pixels, >= 16).

    Raises:
        ValueError: naming the argument, for a wrong shape or a non-finite value.
    """
    width, height = _check_size("width", width), _check_size("height", height)
    sections: tuple[SectionParams, ...] = tuple(params.sections or ())
    disks_per_section = [s.n_disks for s in sections]
    d = sum(disks_per_section)
    pts = _check_array("backbone_points", backbone_points, (None, 3))
    centres = _check_array("disk_centres", disk_centres, (d + 1, 3))
    rots = _check_array("disk_rotations", disk_rotations, (d + 1, 3, 3))
    tens = _check_array("tensions", tensions, (params.n_cables,))
    length = math.fsum(s.length for s in sections)
    scale = min(width, height) / 480.0
    static_image, zbuf_static, cam, rays = _static_layer(
        length, float(params.disk_radius), width, height, max(1.0, round(scale))
    )
    image = static_image.copy()
    frags = _Fragments(cam)

    # base plate (slightly below the base disk), backbone, disks
    down = np.array([0.0, 0.0, -1.5 * params.disk_thickness])
    _disks(
        frags,
        rays,
        np.array([down]),
        np.array([[0.0, 0.0, 1.0]]),
        np.array([[[1.0, 0, 0], [0, 1.0, 0]]]),
        np.array([1.6 * params.disk_radius]),
        _BASE_COLOUR,
        _BASE_COLOUR,
        0.0,
    )
    _polylines(
        frags,
        _path_segments(pts),
        np.broadcast_to(np.asarray(_BACKBONE_COLOUR, np.uint8), (len(pts) - 1, 3)),
        max(2.0, 4.0 * scale),
        -1e-4 * length,
    )
    _disks(
        frags,
        rays,
        centres,
        rots[:, :, 2],
        np.swapaxes(rots[:, :, :2], 1, 2),
        np.full(d + 1, params.disk_radius),
        _DISK_COLOUR,
        _DISK_RIM_COLOUR,
        2e-3 * length,
    )

    # cables through their pinholes, coloured by tension
    ends = np.cumsum([0, *disks_per_section])
    fraction = tens / params.max_tension
    colours = tension_colour(fraction)
    segments, seg_colours = [], []
    angles = params.cable_angles_at_disks()  # (n_disks+1, C): helical routing turns them
    for c, (section, r) in enumerate(zip(params.cable_section, params.cable_radii)):
        last = int(ends[section + 1])
        beta = angles[: last + 1, c]
        local = r * np.stack([np.cos(beta), np.sin(beta), np.zeros_like(beta)], axis=-1)
        holes = centres[: last + 1] + np.einsum("kij,kj->ki", rots[: last + 1], local)
        below = holes[0] + np.array([0.0, 0.0, -0.04 * length])  # down to the actuator
        path = np.vstack([below, holes])
        segments.append(_path_segments(path))
        seg_colours.append(np.broadcast_to(colours[c], (len(path) - 1, 3)))
    _polylines(
        frags,
        np.concatenate(segments),
        np.concatenate(seg_colours),
        max(1.0, 2.0 * scale),
        -3e-3 * length,
    )

    # markers
    tip_r = 0.012 * length
    markers = [(np.asarray(pts[-1]), tip_r * 0.8, _TIP_COLOUR)]
    if goal is not None:
        markers.append((_check_array("goal", goal, (3,)), 0.022 * length, GOAL_COLOUR))
    if target is not None:
        markers.append((_check_array("target", target, (3,)), 0.016 * length, TARGET_COLOUR))
    for centre, radius, colour in markers:
        for x, y, t, rgb in _spheres(frags, rays, centre[None], np.array([radius]), colour):
            frags.add(x, y, t, rgb)

    # resolve against the static layer (grid, axes) by depth
    zbuf = frags.resolve(image)
    static = ~np.isinf(zbuf_static) & (zbuf_static < zbuf)
    if static.any():  # grid pixels in front of the robot win
        image[static] = static_image[static]
        zbuf = np.where(static, zbuf_static, zbuf)

    # translucent obstacles over whatever is behind them
    if obstacles is not None:
        spheres = _obstacle_array(obstacles)
        for x, y, t, rgb in _spheres(frags, rays, spheres[:, :3], spheres[:, 3], _OBSTACLE_COLOUR):
            front = t < zbuf[y, x]
            x, y, rgb = x[front], y[front], rgb[front]
            mixed = (1 - _OBSTACLE_ALPHA) * image[y, x] + _OBSTACLE_ALPHA * rgb
            image[y, x] = np.rint(mixed).astype(np.uint8)
    return image


def _obstacle_array(obstacles: Any) -> np.ndarray:
    try:
        arr = np.asarray(obstacles, dtype=np.float64)
        if arr.ndim == 1 and arr.shape == (4,):
            arr = arr[None]
    except (ValueError, TypeError):
        arr = None
    if arr is None or arr.ndim != 2 or arr.shape[1] != 4:
        try:
            arr = np.array(
                [[*np.asarray(c, dtype=np.float64).reshape(3), float(r)] for c, r in obstacles]
            )
        except (ValueError, TypeError):
            raise ValueError(
                "obstacles must be (K, 4) rows of (x, y, z, radius) m or (centre, radius) pairs, "
                f"got {obstacles!r}"
            ) from None
    arr = arr.reshape(-1, 4)
    if not np.all(np.isfinite(arr)) or np.any(arr[:, 3] <= 0):
        raise ValueError(f"obstacles need finite centres and radii > 0 (m), got {arr.tolist()!r}")
    return arr


# -- human mode -----------------------------------------------------------------------------------
_WINDOW: dict[str, Any] = {}


def has_display() -> bool:
    """Whether a window can be opened: on Linux/BSD an X11 or Wayland display must be set."""
    if sys.platform.startswith(("linux", "freebsd", "openbsd")):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


def show_scene(*, width: int = 480, height: int = 480, **scene: Any) -> None:
    """Draw the scene (the arguments of :func:`draw_scene`) in a window, updated in place.

    Raises:
        RuntimeError: where no window can be opened (no ``DISPLAY`` / ``WAYLAND_DISPLAY`` on
            Linux, matplotlib missing or on a non-interactive backend). Use
            ``render_mode="rgb_array"`` there.
    """
    if not has_display():
        raise RuntimeError(
            'render_mode="human" needs a display, and neither DISPLAY nor WAYLAND_DISPLAY is set; '
            'use render_mode="rgb_array" (e.g. to record a video) on a headless machine'
        )
    try:
        import matplotlib
        import matplotlib.pyplot as plt
    except ImportError as exc:
        raise RuntimeError(
            'render_mode="human" opens a matplotlib window: pip install matplotlib '
            f"(or cdcr-gym[train]); {exc}"
        ) from None
    backend = matplotlib.get_backend().lower()
    if backend in ("agg", "pdf", "ps", "svg", "cairo", "template") or backend.endswith("inline"):
        raise RuntimeError(
            f'render_mode="human" needs an interactive matplotlib backend, got {backend!r} '
            '(set MPLBACKEND=TkAgg or QtAgg), or use render_mode="rgb_array"'
        )
    image = draw_scene(width=width, height=height, **scene)
    fig = _WINDOW.get("fig")
    if fig is None or not plt.fignum_exists(fig.number):
        fig, ax = plt.subplots(num="cdcr_gym", figsize=(width / 100, height / 100), dpi=100)
        ax.set_axis_off()
        fig.subplots_adjust(0, 0, 1, 1)
        _WINDOW.update(fig=fig, artist=ax.imshow(image))
    else:
        _WINDOW["artist"].set_data(image)
    plt.pause(0.001)


def close_window() -> None:
    """Close the :func:`show_scene` window, if one is open."""
    fig = _WINDOW.pop("fig", None)
    _WINDOW.pop("artist", None)
    if fig is not None:
        import matplotlib.pyplot as plt

        plt.close(fig)


def _demo_scene(params: RobotParams, bend: float = 0.9) -> dict[str, Any]:
    """A bent robot of ``params`` (constant curvature per section, all bent the same way), for
    benchmarks and tests; not a model of any tension."""
    centres, rotations, points = [np.zeros(3)], [np.eye(3)], [np.zeros(3)]
    pos, rot = np.zeros(3), np.eye(3)
    for s in params.sections:  # type: ignore[union-attr]
        kappa = bend / s.length
        h = s.length / s.n_disks
        for _ in range(s.n_disks):
            # rotate about the local y axis by kappa*h, moving along the arc
            a = kappa * h
            step_local = np.array([(1 - math.cos(a)) / kappa, 0.0, math.sin(a) / kappa])
            ry = np.array(
                [[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]]
            )
            for f in np.linspace(0.25, 1.0, 4):
                b = kappa * h * f
                points.append(
                    pos + rot @ np.array([(1 - math.cos(b)) / kappa, 0, math.sin(b) / kappa])
                )
            pos = pos + rot @ step_local
            rot = rot @ ry
            centres.append(pos)
            rotations.append(rot)
    tensions = np.linspace(0.0, params.max_tension, params.n_cables)
    return dict(
        backbone_points=np.array(points),
        disk_centres=np.array(centres),
        disk_rotations=np.array(rotations),
        params=params,
        tensions=tensions,
        goal=np.array(points[-1]) + np.array([0.05, 0.05, 0.0]) * params.length,
    )


def _benchmark(width: int = 320, height: int = 320, frames: int = 200) -> float:
    """Frames per second of :func:`draw_scene` on the paper robot."""
    scene = _demo_scene(RobotParams())
    draw_scene(width=width, height=height, **scene)
    start = time.perf_counter()
    for _ in range(frames):
        draw_scene(width=width, height=height, **scene)
    return frames / (time.perf_counter() - start)


if __name__ == "__main__":  # pragma: no cover - python -m cdcr_gym.rendering [out.png]
    for size in (320, 480):
        print(f"draw_scene {size}x{size}: {_benchmark(size, size):.0f} frames/s")
