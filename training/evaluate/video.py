"""Episode videos that people can play: MP4 (H.264, yuv420p) by default, GIF when asked.

MP4 goes through ``imageio-ffmpeg``, whose wheel carries an ffmpeg binary, so no system ffmpeg is
needed (``pip install cdcr-gym[video]``). The stream is H.264 (``libx264``) in ``yuv420p``
with even frame sizes (odd frames are padded by repeating their last row/column): the format
every browser, phone and slide deck plays. GIF (``path`` ending in ``.gif``) is written with
imageio's pillow plugin, looping forever.

::

    from training.evaluate.video import write_video
    write_video("runs/ccka/figures/episodes.mp4", frames, fps=25)   # frames: iterable of (H, W, 3) uint8

:func:`probe_video` reads back codec, pixel format, size and frame count (from ``ffmpeg -i`` and a
decoding pass), which the tests use as an ``ffprobe`` stand-in.
"""

from __future__ import annotations

import re
import subprocess
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["write_video", "probe_video", "VideoInfo", "even_frame"]

_MP4_SUFFIXES = (".mp4", ".m4v", ".mov")


def _ffmpeg():  # noqa: ANN202 - the imageio_ffmpeg module
    try:
        import imageio_ffmpeg
    except ImportError:
        raise ImportError(
            "MP4 videos need imageio-ffmpeg (it carries ffmpeg): pip install 'cdcr-gym[video]', "
            "or write a GIF (path ending in .gif)"
        ) from None
    return imageio_ffmpeg


def _check_frame(frame: object, index: int) -> np.ndarray:
    arr = np.asarray(frame)
    if arr.ndim != 3 or arr.shape[2] != 3 or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise ValueError(f"frame {index} must be an RGB image (H, W, 3), got shape {arr.shape}")
    if arr.dtype != np.uint8:
        if not np.issubdtype(arr.dtype, np.number) or not np.all(np.isfinite(arr)):
            raise ValueError(
                f"frame {index} must be uint8 RGB (or finite numbers), got {arr.dtype}"
            )
        arr = np.clip(np.rint(arr), 0, 255).astype(np.uint8)
    return arr


def even_frame(frame: np.ndarray) -> np.ndarray:
    """``frame`` (H, W, 3) padded to even H and W by repeating its last row / column (H.264 with
    yuv420p needs even sizes)."""
    h, w = frame.shape[:2]
    pad = ((0, h % 2), (0, w % 2), (0, 0))
    return np.pad(frame, pad, mode="edge") if (h % 2 or w % 2) else frame


def write_video(path: str | Path, frames: Iterable[np.ndarray], fps: float = 25.0) -> Path:
    """Write ``frames`` (each (H, W, 3) uint8, all the same size) to ``path``; return the path.

    The format follows the suffix: ``.mp4`` (also ``.m4v``, ``.mov``) is H.264 / yuv420p at
    ``fps`` frames per second (sizes padded to even); ``.gif`` is a looping GIF (frame duration
    rounded to 10 ms, GIF's resolution). Frames are streamed to the encoder (not held in memory).

    Raises:
        ValueError: for another suffix, no frames, frames of different sizes or not RGB, or
            ``fps`` not > 0.
        ImportError: for MP4 without imageio-ffmpeg (the message says what to install).
        RuntimeError: if ffmpeg fails (its message included).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (*_MP4_SUFFIXES, ".gif"):
        raise ValueError(f"video path must end in .mp4 or .gif, got {str(path)!r}")
    if (
        isinstance(fps, bool)
        or not isinstance(fps, (int, float))
        or not np.isfinite(fps)
        or fps <= 0
    ):
        raise ValueError(f"fps must be a number > 0, got {fps!r}")
    path.parent.mkdir(parents=True, exist_ok=True)
    iterator = iter(frames)
    try:
        first = _check_frame(next(iterator), 0)
    except StopIteration:
        raise ValueError("no frames to write") from None
    if suffix == ".gif":
        _write_gif(path, first, iterator, fps)
    else:
        _write_mp4(path, first, iterator, fps)
    return path


def _frames(first: np.ndarray, rest: Iterable[np.ndarray]) -> Iterable[np.ndarray]:
    yield first
    for i, frame in enumerate(rest, start=1):
        arr = _check_frame(frame, i)
        if arr.shape != first.shape:
            raise ValueError(
                f"frame {i} has shape {arr.shape}, frame 0 {first.shape}: all frames must match"
            )
        yield arr


def _write_mp4(path: Path, first: np.ndarray, rest: Iterable[np.ndarray], fps: float) -> None:
    ffmpeg = _ffmpeg()
    h, w = even_frame(first).shape[:2]
    writer = ffmpeg.write_frames(
        str(path),
        (w, h),
        fps=float(fps),
        codec="libx264",
        pix_fmt_in="rgb24",
        pix_fmt_out="yuv420p",
        macro_block_size=1,
        quality=None,
        output_params=["-crf", "20", "-preset", "veryfast", "-movflags", "+faststart"],
        ffmpeg_log_level="error",
    )
    writer.send(None)  # start ffmpeg
    try:
        for frame in _frames(first, rest):
            writer.send(np.ascontiguousarray(even_frame(frame)))
    except BaseException:
        writer.close()
        path.unlink(missing_ok=True)
        raise
    try:
        writer.close()
    except Exception as exc:  # ffmpeg's own error
        path.unlink(missing_ok=True)
        raise RuntimeError(f"ffmpeg failed writing {path}: {exc}") from exc


def _write_gif(path: Path, first: np.ndarray, rest: Iterable[np.ndarray], fps: float) -> None:
    import imageio.v2 as imageio

    duration_ms = max(10, int(round(100.0 / fps)) * 10)
    with imageio.get_writer(path, mode="I", duration=duration_ms, loop=0) as writer:
        for frame in _frames(first, rest):
            writer.append_data(frame)


@dataclass(frozen=True)
class VideoInfo:
    """What :func:`probe_video` reads from a file."""

    codec: str  #: ffmpeg's codec name, e.g. "h264", "gif"
    pix_fmt: str  #: e.g. "yuv420p"
    width: int
    height: int
    n_frames: int  #: frames decoded
    fps: float | None  #: the stream's frame rate, if stated


_STREAM = re.compile(
    r"Stream #\d+:\d+.*?: Video: (?P<codec>\w+)[^,]*, (?P<pix>\w+)[^,]*?(?:\([^)]*\))?,"
    r".*?(?P<w>\d{2,5})x(?P<h>\d{2,5})"
)
_FPS = re.compile(r"(?P<fps>[\d.]+) fps")


def probe_video(path: str | Path) -> VideoInfo:
    """Codec, pixel format, size and frame count of the first video stream of ``path``.

    Uses the ffmpeg of imageio-ffmpeg: ``ffmpeg -i`` for the stream line and a full decode for
    the frame count (what ``ffprobe -count_frames`` would report).

    Raises:
        FileNotFoundError: if ``path`` does not exist.
        ValueError: if ffmpeg finds no video stream.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(path)
    ffmpeg = _ffmpeg()
    out = subprocess.run(
        [ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-i", str(path)],
        capture_output=True,
        text=True,
        check=False,
    ).stderr
    match = _STREAM.search(out)
    if match is None:
        raise ValueError(f"no video stream in {path}: {out.strip()[-500:]}")
    fps = _FPS.search(out[match.start() :])
    n_frames, _ = ffmpeg.count_frames_and_secs(str(path))
    return VideoInfo(
        codec=match["codec"],
        pix_fmt=match["pix"],
        width=int(match["w"]),
        height=int(match["h"]),
        n_frames=int(n_frames),
        fps=float(fps["fps"]) if fps else None,
    )
