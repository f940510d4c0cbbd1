"""Text on video frames without a font library: a built-in 5×7 bitmap font drawn with numpy.

:func:`caption` says what a frame of an evaluation video shows (the step, the tip error in mm and
the task's own metric, read from the step's ``info``); :func:`draw_text` writes lines of text
into the top-left corner of an ``(H, W, 3)`` uint8 frame on a dark band, scaled to the frame.
Lower-case letters are drawn as capitals; a character the font lacks is drawn as ``?``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

__all__ = ["FONT", "caption", "draw_text", "text_mask"]

#: 5×7 glyphs, one string of 5 pixels ("#" on) per row, top to bottom
FONT: dict[str, tuple[str, ...]] = {
    " ": (".....",) * 7,
    "0": (".###.", "#...#", "#..##", "#.#.#", "##..#", "#...#", ".###."),
    "1": ("..#..", ".##..", "..#..", "..#..", "..#..", "..#..", ".###."),
    "2": (".###.", "#...#", "....#", "...#.", "..#..", ".#...", "#####"),
    "3": ("#####", "...#.", "..#..", "...#.", "....#", "#...#", ".###."),
    "4": ("...#.", "..##.", ".#.#.", "#..#.", "#####", "...#.", "...#."),
    "5": ("#####", "#....", "####.", "....#", "....#", "#...#", ".###."),
    "6": ("..##.", ".#...", "#....", "####.", "#...#", "#...#", ".###."),
    "7": ("#####", "....#", "...#.", "..#..", ".#...", ".#...", ".#..."),
    "8": (".###.", "#...#", "#...#", ".###.", "#...#", "#...#", ".###."),
    "9": (".###.", "#...#", "#...#", ".####", "....#", "...#.", ".##.."),
    "A": (".###.", "#...#", "#...#", "#####", "#...#", "#...#", "#...#"),
    "B": ("####.", "#...#", "#...#", "####.", "#...#", "#...#", "####."),
    "C": (".###.", "#...#", "#....", "#....", "#....", "#...#", ".###."),
    "D": ("###..", "#..#.", "#...#", "#...#", "#...#", "#..#.", "###.."),
    "E": ("#####", "#....", "#....", "####.", "#....", "#....", "#####"),
    "F": ("#####", "#....", "#....", "####.", "#....", "#....", "#...."),
    "G": (".###.", "#...#", "#....", "#.###", "#...#", "#...#", ".####"),
    "H": ("#...#", "#...#", "#...#", "#####", "#...#", "#...#", "#...#"),
    "I": (".###.", "..#..", "..#..", "..#..", "..#..", "..#..", ".###."),
    "J": ("..###", "...#.", "...#.", "...#.", "...#.", "#..#.", ".##.."),
    "K": ("#...#", "#..#.", "#.#..", "##...", "#.#..", "#..#.", "#...#"),
    "L": ("#....", "#....", "#....", "#....", "#....", "#....", "#####"),
    "M": ("#...#", "##.##", "#.#.#", "#.#.#", "#...#", "#...#", "#...#"),
    "N": ("#...#", "#...#", "##..#", "#.#.#", "#..##", "#...#", "#...#"),
    "O": (".###.", "#...#", "#...#", "#...#", "#...#", "#...#", ".###."),
    "P": ("####.", "#...#", "#...#", "####.", "#....", "#....", "#...."),
    "Q": (".###.", "#...#", "#...#", "#...#", "#.#.#", "#..#.", ".##.#"),
    "R": ("####.", "#...#", "#...#", "####.", "#.#..", "#..#.", "#...#"),
    "S": (".####", "#....", "#....", ".###.", "....#", "....#", "####."),
    "T": ("#####", "..#..", "..#..", "..#..", "..#..", "..#..", "..#.."),
    "U": ("#...#", "#...#", "#...#", "#...#", "#...#", "#...#", ".###."),
    "V": ("#...#", "#...#", "#...#", "#...#", "#...#", ".#.#.", "..#.."),
    "W": ("#...#", "#...#", "#...#", "#.#.#", "#.#.#", "#.#.#", ".#.#."),
    "X": ("#...#", "#...#", ".#.#.", "..#..", ".#.#.", "#...#", "#...#"),
    "Y": ("#...#", "#...#", ".#.#.", "..#..", "..#..", "..#..", "..#.."),
    "Z": ("#####", "....#", "...#.", "..#..", ".#...", "#....", "#####"),
    ".": (".....", ".....", ".....", ".....", ".....", ".##..", ".##.."),
    ",": (".....", ".....", ".....", ".....", ".##..", "..#..", ".#..."),
    ":": (".....", ".##..", ".##..", ".....", ".##..", ".##..", "....."),
    "-": (".....", ".....", ".....", "#####", ".....", ".....", "....."),
    "+": (".....", "..#..", "..#..", "#####", "..#..", "..#..", "....."),
    "=": (".....", ".....", "#####", ".....", "#####", ".....", "....."),
    "/": (".....", "....#", "...#.", "..#..", ".#...", "#....", "....."),
    "%": ("##...", "##..#", "...#.", "..#..", ".#...", "#..##", "...##"),
    "(": ("...#.", "..#..", ".#...", ".#...", ".#...", "..#..", "...#."),
    ")": (".#...", "..#..", "...#.", "...#.", "...#.", "..#..", ".#..."),
    "?": (".###.", "#...#", "....#", "...#.", "..#..", ".....", "..#.."),
    "°": (".##..", "#..#.", "#..#.", ".##..", ".....", ".....", "....."),
    "_": (".....", ".....", ".....", ".....", ".....", ".....", "#####"),
}
_GLYPHS = {c: np.array([[p == "#" for p in row] for row in rows]) for c, rows in FONT.items()}


def text_mask(text: str, scale: int = 1) -> np.ndarray:
    """Boolean pixels (7·scale, 6·len·scale) of one line of ``text`` (one blank column between
    characters)."""
    cells = []
    for ch in text.upper():
        glyph = _GLYPHS.get(ch, _GLYPHS["?"])
        cells.append(np.pad(glyph, ((0, 0), (0, 1))))
    mask = np.concatenate(cells, axis=1) if cells else np.zeros((7, 0), dtype=bool)
    return np.kron(mask, np.ones((scale, scale), dtype=bool)).astype(bool)


def draw_text(
    frame: np.ndarray,
    lines: Sequence[str],
    color: tuple[int, int, int] = (255, 255, 255),
    scale: int | None = None,
) -> np.ndarray:
    """A copy of ``frame`` (H, W, 3) uint8 with ``lines`` in its top-left corner, light on a
    darkened band. ``scale`` (pixels per font pixel) defaults to 1 below 240 px of width, else
    ``width // 240 + 1``; lines wider than the frame are cut."""
    out = np.array(frame, dtype=np.uint8, copy=True)
    h, w = out.shape[:2]
    s = scale or (1 if w < 240 else w // 240 + 1)
    y = s
    for line in lines:
        mask = text_mask(line, s)[: max(h - y, 0), : max(w - 2 * s, 0)]
        mh, mw = mask.shape
        if mh == 0:
            break
        band = out[y - s // 2 : y + mh + s // 2, 0 : mw + 2 * s]
        band[...] = band // 3  # darken what is behind the text
        region = out[y : y + mh, s : s + mw]
        region[mask] = color
        y += mh + 2 * s
    return out


def caption(step: int, horizon: int, info: Mapping[str, Any], task: str = "Reach") -> list[str]:
    """The lines an evaluation frame carries: the step, the tip error (mm) and the task's metric
    (Reach: success within the threshold; Track: the tracking RMS so far; Pose: the angle to the
    goal direction; Obstacle: the smallest clearance and whether it collided)."""
    lines = [f"step {step}/{horizon}"]
    if "distance" in info:
        lines.append(f"tip error {1000.0 * float(info['distance']):.1f} mm")
    if task == "Track" and "tracking_rms" in info:
        lines.append(f"tracking rms {1000.0 * float(info['tracking_rms']):.1f} mm")
    elif task == "Pose" and "angle" in info:
        lines.append(f"angle error {np.degrees(float(info['angle'])):.1f}°")
    elif task == "Obstacle" and "min_clearance" in info:
        hit = " collided" if info.get("collided") else ""
        lines.append(f"clearance {1000.0 * float(info['min_clearance']):.1f} mm{hit}")
    if "is_success" in info:
        lines.append("success" if info["is_success"] else "not yet")
    return lines
