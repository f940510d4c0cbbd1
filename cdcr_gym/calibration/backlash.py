"""Backlash of the tendon drives over a measured command sequence: the play between a drive's
command and the tendon it moves (:mod:`cdcr_gym.model.backlash`). With the commands d_m (m) of
the rows in order, the displacement that reaches the tendon is the *play operator* of width w
(per tendon, SI):

    y_{-1} = 0 (the drives at their zero, the robot at rest: where every replay starts),
    y_m = clip(y_{m−1}, d_m − w/2, d_m + w/2),

so y follows d with a lag of w/2 while d keeps moving one way and holds while d turns. It is
the simplest hysteresis that depends on the direction of the last motion, which is what the
FTDCR v4 recordings show at zero command (the tip stays on the side it came from). w = 0 is
no backlash (y = d). Used by the calibration's replays (``drive_backlash``,
``TendonDrive.backlash``) on the measured command sequence before the drive law.
"""

from __future__ import annotations

import numpy as np

from cdcr_gym.model.backlash import play_step

__all__ = ["play"]


def play(displacements: np.ndarray, width: float | np.ndarray) -> np.ndarray:
    """The displacements (M, C) m that reach the tendons for commands ``displacements`` (M, C)
    m in row order through drives with backlash ``width`` m (a number or (C,), >= 0; the module
    docstring's play operator, starting from 0).

    Raises:
        ValueError: naming ``displacements`` (not (M, C) finite) or ``width`` (negative,
            non-finite or not broadcastable to (C,)).
    """
    d = np.asarray(displacements, dtype=np.float64)
    if d.ndim != 2 or not np.isfinite(d).all():
        raise ValueError(f"displacements must be finite (M, C) m, got shape {d.shape}")
    try:
        w = np.broadcast_to(np.asarray(width, dtype=np.float64), (d.shape[1],))
    except ValueError:
        raise ValueError(
            f"width must be a number or {d.shape[1]} numbers (m), got {width!r}"
        ) from None
    if not (np.isfinite(w).all() and np.all(w >= 0.0)):
        raise ValueError(f"width must be finite and >= 0 m, got {np.asarray(width).tolist()!r}")
    if not np.any(w > 0.0):
        return d.copy()
    out = np.empty_like(d)
    y = np.zeros(d.shape[1])
    for m in range(d.shape[0]):
        y = out[m] = play_step(y, d[m], w)
    return out
