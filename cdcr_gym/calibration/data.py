"""Measured tip positions: the CSV format a calibration reads, and its reader/writer.

One row per measurement, in the order the measurements were taken (the physics backends replay
that history, which is what makes friction hysteresis reproducible). A header row names the
columns; ``#`` starts a comment line; blank lines are skipped. Columns (any order):

============== ======== ==========================================================================
column         unit     meaning
============== ======== ==========================================================================
``T1`` … ``Tn`` N       cable tensions at the actuators, one column per cable in the robot's cable
                        order (section by section, proximal first) — **or**
``m1`` … ``mn`` kg      hanging masses on the cables (the paper's protocol), converted to tensions
                        with g = 9.81 m/s² (``cdcr_gym.params.STANDARD_GRAVITY``) — **or**
``d1`` … ``dn`` m       commanded tendon displacements (positive = pulled in), for robots driven
                        by position-controlled drives. Give one kind.
``timestamp``   s       optional: when the row was measured (kept; must not decrease).
``x, y, z``     m       measured tip (last disk centre) in the base frame R0: origin at the base
                        disk centre, backbone along +Z0 (up), cable 1 at +X0.
``direction``   —       optional: ``up`` (loading) or ``down`` (unloading); empty = unknown.
                        Checked against the change of tensions from the previous row (the sum
                        over cables), used to mark the branches in the report.
``tx, ty, tz``  —       optional: measured unit backbone tangent at the tip (tip orientation),
                        fitted with the angular uncertainty ``sigma_dir``.
``sigma``       m       optional: the tip measurement's standard deviation (weights the row;
                        default 1 mm for every row, i.e. unweighted).
``sigma_dir``   rad     optional: the tangent's standard deviation (default 0.01 rad).
``label``       —       optional free text (ignored by the fit, kept in the report).
============== ======== ==========================================================================

The published format of real-robot recordings (``timestamp, pattern_label, servo_<id>_mm …,
tip_x, tip_y, tip_z``, mm, servo columns in tendon order) is read by :func:`read_published`;
:func:`read_csv` tells the two apart by the header (or ``format=``). A UTF-8 byte-order mark is
accepted. Given the robot (and its tendon drive), :func:`check_units` catches mm/m mix-ups.

Errors name the file, the 1-based line and the column: ``data.csv line 7, column 'z': 'abc' is
not a number``.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from cdcr_gym.model.params import STANDARD_GRAVITY

__all__ = [
    "Measurements",
    "read_csv",
    "write_csv",
    "DEFAULT_SIGMA",
    "DEFAULT_SIGMA_DIR",
    "FORMATS",
]

#: Tip standard deviation (m) of rows without a ``sigma`` column.
DEFAULT_SIGMA = 1e-3
#: Tangent standard deviation (rad) of rows without a ``sigma_dir`` column.
DEFAULT_SIGMA_DIR = 0.01

_DIRECTIONS = {"up": 1, "down": -1, "": 0}
_KNOWN = {
    "x",
    "y",
    "z",
    "direction",
    "tx",
    "ty",
    "tz",
    "sigma",
    "sigma_dir",
    "label",
    "timestamp",
}
_CABLE = re.compile(r"^([Tmd])([1-9][0-9]*)$")
_SERVO = re.compile(r"^servo_(.+)_mm$")
#: the published format's columns besides the servo columns
_PUBLISHED = ("timestamp", "pattern_label", "tip_x", "tip_y", "tip_z")
FORMATS = ("auto", "cdcr", "published")


@dataclass(frozen=True)
class Measurements:
    """M measurements, in the order they were taken (SI units, float64).

    Attributes:
        tensions: (M, C) cable tensions, N.
        tip: (M, 3) measured tip positions in R0, m.
        direction: (M,) int, +1 loading (``up``), −1 unloading (``down``), 0 unknown.
        sigma: (M,) tip standard deviations, m.
        tip_direction: (M, 3) measured unit tangents at the tip, or None.
        sigma_dir: (M,) tangent standard deviations, rad.
        lines: (M,) the 1-based source line of each row (for messages).
        labels: per-row labels ("" where none).
        source: the file name (or "<memory>").
        from_masses: whether the file gave hanging masses (kg) rather than tensions.
    """

    # arrays after construction; direction, sigma and lines may be given as None (defaults)
    tensions: Any
    tip: np.ndarray
    direction: Any
    sigma: Any
    tip_direction: np.ndarray | None = None
    sigma_dir: np.ndarray | None = None
    lines: Any = None
    labels: tuple[str, ...] = ()
    source: str = "<memory>"
    from_masses: bool = False
    displacements: Any = None
    timestamps: Any = None

    def __post_init__(self) -> None:
        if (self.tensions is None) == (self.displacements is None):
            raise ValueError("give either tensions (N) or displacements (m), exactly one")
        if self.displacements is not None:
            dsp = np.asarray(self.displacements, dtype=np.float64)
            if dsp.ndim != 2 or not np.isfinite(dsp).all():
                raise ValueError(f"displacements must be finite (M, C) m, got {dsp.shape}")
            object.__setattr__(self, "displacements", dsp)
            t = np.zeros_like(dsp)  # placeholder shape; ``tensions`` is None for these data
        else:
            t = np.asarray(self.tensions, dtype=np.float64)
        tip = np.asarray(self.tip, dtype=np.float64)
        if t.ndim != 2 or tip.shape != (t.shape[0], 3):
            raise ValueError(
                f"tensions/displacements must be (M, C) and tip (M, 3), got {t.shape} and "
                f"{tip.shape}"
            )
        m = t.shape[0]
        if not (np.isfinite(t).all() and np.isfinite(tip).all()) or np.any(t < 0.0):
            raise ValueError("tensions must be finite and >= 0 N and tips finite")
        if self.displacements is None:
            object.__setattr__(self, "tensions", t)
        if self.timestamps is not None:
            ts = np.asarray(self.timestamps, dtype=np.float64).reshape(m)
            if not np.isfinite(ts).all() or np.any(np.diff(ts) < 0.0):
                raise ValueError("timestamps must be finite and non-decreasing (s)")
            object.__setattr__(self, "timestamps", ts)
        object.__setattr__(self, "tip", tip)
        direction = np.zeros(m, dtype=np.int64) if self.direction is None else self.direction
        object.__setattr__(self, "direction", np.asarray(direction, dtype=np.int64).reshape(m))
        sigma = np.full(m, DEFAULT_SIGMA) if self.sigma is None else self.sigma
        sigma = np.broadcast_to(np.asarray(sigma, dtype=np.float64), (m,)).copy()
        if not (np.isfinite(sigma).all() and np.all(sigma > 0.0)):
            raise ValueError(f"sigma must be finite and > 0 m, got {sigma!r}")
        object.__setattr__(self, "sigma", sigma)
        if self.tip_direction is not None:
            d = np.asarray(self.tip_direction, dtype=np.float64).reshape(m, 3)
            object.__setattr__(self, "tip_direction", d)
            sd = DEFAULT_SIGMA_DIR if self.sigma_dir is None else self.sigma_dir
            sd = np.broadcast_to(np.asarray(sd, dtype=np.float64), (m,)).copy()
            object.__setattr__(self, "sigma_dir", sd)
        lines = np.arange(2, m + 2) if self.lines is None else self.lines
        object.__setattr__(self, "lines", np.asarray(lines, dtype=np.int64))
        if not self.labels:
            object.__setattr__(self, "labels", ("",) * m)

    @property
    def commands(self) -> np.ndarray:
        """The rows' commands (M, C): displacements (m) or tensions (N)."""
        return self.displacements if self.displacements is not None else self.tensions

    def __len__(self) -> int:
        return int(self.tip.shape[0])

    @property
    def n_cables(self) -> int:
        """Number of cable columns C."""
        return int(self.commands.shape[1])

    def subset(self, index: np.ndarray | slice) -> Measurements:
        """The rows ``index`` (in their order), e.g. a few points for a quick check."""
        pick = np.arange(len(self))[index]
        return Measurements(
            None if self.tensions is None else self.tensions[pick],
            self.tip[pick],
            self.direction[pick],
            self.sigma[pick],
            None if self.tip_direction is None else self.tip_direction[pick],
            None if self.sigma_dir is None else self.sigma_dir[pick],
            None if self.lines is None else self.lines[pick],
            tuple(self.labels[i] for i in pick),
            self.source,
            self.from_masses,
            None if self.displacements is None else self.displacements[pick],
            None if self.timestamps is None else self.timestamps[pick],
        )


def _number(text: str, where: str, column: str, *, positive: bool = False) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{where}, column {column!r}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise ValueError(f"{where}, column {column!r}: {text!r} is not finite")
    if positive and value <= 0.0:
        raise ValueError(f"{where}, column {column!r}: must be > 0, got {text!r}")
    if value < 0.0 and column[0] in "Tm" and column[1:].isdigit():
        raise ValueError(f"{where}, column {column!r}: a cable cannot push, got {text!r} (< 0)")
    return value


def _cable_columns(header: list[str], name: str) -> tuple[str, list[str]]:
    """The kind ("T" or "m") and the ordered cable columns of a header."""
    found: dict[str, dict[int, str]] = {"T": {}, "m": {}, "d": {}}
    for col in header:
        match = _CABLE.match(col)
        if match:
            found[match.group(1)][int(match.group(2))] = col
    kinds = [k for k in ("T", "m", "d") if found[k]]
    if not kinds:
        raise ValueError(
            f"{name} line 1 (header): no cable columns; give tensions T1..Tn (N), hanging "
            f"masses m1..mn (kg) or tendon displacements d1..dn (m), got columns {header}"
        )
    if len(kinds) > 1:
        raise ValueError(
            f"{name} line 1 (header): give either tensions (T1..Tn) or masses (m1..mn) (or "
            f"displacements d1..dn), not several kinds: {kinds}"
        )
    kind = kinds[0]
    numbers = sorted(found[kind])
    if numbers != list(range(1, len(numbers) + 1)):
        missing = sorted(set(range(1, max(numbers) + 1)) - set(numbers))
        raise ValueError(
            f"{name} line 1 (header): cable columns must be {kind}1..{kind}n without gaps, "
            f"missing {[f'{kind}{i}' for i in missing]}"
        )
    return kind, [found[kind][i] for i in numbers]


def _read_rows(path: str | Path) -> tuple[str, list[tuple[int, list[str]]]]:
    """The file's name and its non-comment, non-blank rows as (1-based line, cells); a UTF-8
    byte-order mark is tolerated."""
    path = Path(path)
    name = path.name
    if not path.is_file():
        raise ValueError(f"measurement file {str(path)!r} does not exist")
    try:
        with path.open(newline="", encoding="utf-8-sig") as fh:
            text = fh.read()
    except UnicodeDecodeError as exc:
        raise ValueError(f"{name}: not a UTF-8 text file ({exc})") from None
    numbered = list(enumerate(text.splitlines(), start=1))
    rows = [(i, line) for i, line in numbered if line.strip() and not line.lstrip().startswith("#")]
    if not rows:
        raise ValueError(f"{name}: no header and no data rows")
    parsed = list(csv.reader([line for _, line in rows], skipinitialspace=True))
    return name, [(i, cells) for (i, _), cells in zip(rows, parsed)]


def detect_format(path: str | Path) -> str:
    """``"published"`` for a file with ``servo_<id>_mm`` and ``tip_x`` columns, else ``"cdcr"``."""
    _, rows = _read_rows(path)
    header = [c.strip() for c in rows[0][1]]
    if "tip_x" in header or any(_SERVO.match(c) for c in header):
        return "published"
    return "cdcr"


def read_csv(
    path: str | Path,
    format: str = "auto",
    robot: Any = None,
    drive: Any = None,
) -> Measurements:
    """Read a measurement file: this package's CSV (module docstring) or the published format
    (:func:`read_published`); ``format`` "auto" tells them apart by the header.

    Args:
        robot, drive: optional ``RobotParams`` and
            :class:`~cdcr_gym.calibration.drive.TendonDrive`; with them the values are checked
            for unit mix-ups (:func:`check_units`).

    Raises:
        ValueError: naming the file, the line and the column, for a missing or unknown column,
            a value that is not a number, a negative tension or mass, a ``direction`` other than
            up/down, a ``direction`` that contradicts the change of tensions, no data rows, or
            a value out of the robot's range (a unit mix-up).
    """
    if format not in FORMATS:
        raise ValueError(f"format must be one of {FORMATS}, got {format!r}")
    if format == "auto":
        format = detect_format(path)
    if format == "published":
        return read_published(path, robot, drive)
    data = _read_cdcr(path)
    if robot is not None:
        check_units(data, robot, drive)
    return data


def read_published(path: str | Path, robot: Any = None, drive: Any = None) -> Measurements:
    """Read the published measurement format: ``timestamp`` (s), ``pattern_label``,
    ``servo_<id>_mm`` (one column per tendon, in the robot's tendon order, commanded
    displacement in mm, positive = pulled in), ``tip_x, tip_y, tip_z`` (mm). Converted to SI
    (m); the timestamps (must not decrease) and labels are kept. With ``robot`` (and
    ``drive``) the values are checked for unit mix-ups and the servo column count against the
    robot's tendons.

    Raises:
        ValueError: naming the file, the line and the column.
    """
    name, rows = _read_rows(path)
    header_line = rows[0][0]
    header = [c.strip() for c in rows[0][1]]
    dup = sorted({c for c in header if header.count(c) > 1})
    if dup:
        raise ValueError(f"{name} line {header_line} (header): duplicate column(s) {dup}")
    servos = [c for c in header if _SERVO.match(c)]
    if not servos:
        raise ValueError(
            f"{name} line {header_line} (header): no servo columns (servo_<id>_mm); got {header}"
        )
    for col in ("timestamp", "tip_x", "tip_y", "tip_z"):
        if col not in header:
            raise ValueError(f"{name} line {header_line} (header): missing column {col!r}")
    unknown = [c for c in header if c not in _PUBLISHED and c not in servos]
    if unknown:
        raise ValueError(
            f"{name} line {header_line} (header): unknown column(s) {unknown}; the published "
            "format has timestamp, pattern_label, servo_<id>_mm..., tip_x, tip_y, tip_z"
        )
    if robot is not None and len(servos) != robot.n_cables:
        raise ValueError(
            f"{name} line {header_line} (header): {len(servos)} servo column(s) {servos} but "
            f"the robot has {robot.n_cables} tendons (missing servo columns?)"
        )
    index = {c: k for k, c in enumerate(header)}
    if len(rows) < 2:
        raise ValueError(f"{name}: a header but no data rows")
    disp: list[list[float]] = []
    tips: list[list[float]] = []
    times: list[float] = []
    lines: list[int] = []
    labels: list[str] = []
    for line_no, cells in rows[1:]:
        where = f"{name} line {line_no}"
        if len(cells) != len(header):
            raise ValueError(f"{where}: {len(cells)} values for {len(header)} columns {header}")
        cell = {c: cells[index[c]].strip() for c in header}
        disp.append([1e-3 * _number(cell[c], where, c) for c in servos])
        tips.append([1e-3 * _number(cell[c], where, c) for c in ("tip_x", "tip_y", "tip_z")])
        t = _number(cell["timestamp"], where, "timestamp")
        if times and t < times[-1]:
            raise ValueError(
                f"{where}, column 'timestamp': {t!r} s is before the previous row's "
                f"{times[-1]!r} s; rows must be in the order they were measured"
            )
        times.append(t)
        lines.append(line_no)
        labels.append(cell.get("pattern_label", ""))
    data = Measurements(
        None,
        np.array(tips),
        None,
        None,
        lines=np.array(lines),
        labels=tuple(labels),
        source=name,
        displacements=np.array(disp),
        timestamps=np.array(times),
    )
    cols = {"command": servos, "tip": ["tip_x", "tip_y", "tip_z"], "unit": "mm"}
    if robot is not None:
        check_units(data, robot, drive, cols)
    return data


def _check_tensions(data: Measurements, robot: Any) -> None:
    """ValueError naming file, line and column for the first tension (N) beyond what the
    robot's model accepts as its ``max_tension`` (it would bend a section past 180°)."""
    peaks = data.tensions.max(axis=1)
    if not peaks.max() > robot.max_tension:
        return
    try:
        replace(robot, max_tension=float(peaks.max()))
        return
    except ValueError:
        pass
    prefix = "m" if data.from_masses else "T"
    for k in np.flatnonzero(peaks > robot.max_tension):
        try:
            replace(robot, max_tension=float(peaks[k]))
        except ValueError as exc:
            c = int(np.argmax(data.tensions[k]))
            raise ValueError(
                f"{data.source} line {data.lines[k]}, column '{prefix}{c + 1}': tension "
                f"{data.tensions[k, c]:g} N is beyond this robot's range (its max_tension is "
                f"{robot.max_tension:g} N; {exc}); a unit mix-up?"
            ) from None


def check_units(data: Measurements, robot: Any, drive: Any = None, cols: Any = None) -> None:
    """ValueError naming file, line and column for values a unit mix-up would produce: a
    displacement outside twice the drive's ``displacement_range`` (or beyond the robot's
    length without one), a tip farther than 3 robot lengths from the origin, or every tip
    within 10 % of the robot's length of the origin (tips given in m where mm were expected)."""
    name = data.source
    length = float(robot.length)
    ccols = (cols or {}).get("command") or [f"d{i + 1}" for i in range(data.n_cables)]
    tcols = (cols or {}).get("tip") or ["x", "y", "z"]
    unit = (cols or {}).get("unit", "m")
    factor = 1e3 if unit == "mm" else 1.0
    if data.n_cables != robot.n_cables:
        raise ValueError(
            f"{name} line 1 (header): {data.n_cables} tendon column(s) but the robot has "
            f"{robot.n_cables} tendons"
        )
    if data.displacements is not None:
        lo, hi = (-length, length)
        if drive is not None and all(math.isfinite(v) for v in drive.displacement_range):
            a, b = drive.displacement_range
            lo, hi = a - (b - a) / 2.0, b + (b - a) / 2.0
        bad = np.argwhere((data.displacements < lo) | (data.displacements > hi))
        if bad.size:
            k, c = bad[0]
            value = data.displacements[k, c] * factor
            raise ValueError(
                f"{name} line {data.lines[k]}, column {ccols[c]!r}: displacement {value:g} "
                f"{unit} is outside the plausible range [{lo * factor:g}, {hi * factor:g}] {unit}"
                " of this robot (a unit mix-up, mm vs m?)"
            )
    if data.tensions is not None and data.tensions.size:
        _check_tensions(data, robot)
    norms = np.linalg.norm(data.tip, axis=1)
    far = np.argwhere(np.abs(data.tip) > 3.0 * length)
    if far.size:
        k, c = far[0]
        raise ValueError(
            f"{name} line {data.lines[k]}, column {tcols[c]!r}: tip coordinate "
            f"{data.tip[k, c] * factor:g} {unit} is more than 3 robot lengths "
            f"({3 * length * factor:g} {unit}) from the origin (a unit mix-up, mm vs m?)"
        )
    if norms.max() < 0.1 * length:
        k = int(np.argmax(norms))
        raise ValueError(
            f"{name} line {data.lines[k]}, column {tcols[2]!r}: every tip lies within "
            f"{norms.max() * factor:g} {unit} of the origin, under 10 % of the robot's length "
            f"{length * factor:g} {unit} (a unit mix-up, m vs mm?)"
        )


def _read_cdcr(path: str | Path) -> Measurements:
    name, rows = _read_rows(path)
    parsed = [cells for _, cells in rows]
    header_line = rows[0][0]
    header = [c.strip() for c in parsed[0]]
    dup = sorted({c for c in header if header.count(c) > 1})
    if dup:
        raise ValueError(f"{name} line {header_line} (header): duplicate column(s) {dup}")
    kind, cable_cols = _cable_columns(header, name)
    unknown = [c for c in header if c not in _KNOWN and c not in cable_cols]
    if unknown:
        raise ValueError(
            f"{name} line {header_line} (header): unknown column(s) {unknown}; accepted: "
            f"{kind}1..{kind}n, x, y, z, direction, tx, ty, tz, sigma, sigma_dir, label"
        )
    for col in ("x", "y", "z"):
        if col not in header:
            raise ValueError(f"{name} line {header_line} (header): missing column {col!r}")
    has_dir = [c in header for c in ("tx", "ty", "tz")]
    if any(has_dir) and not all(has_dir):
        raise ValueError(
            f"{name} line {header_line} (header): the tip tangent needs all of tx, ty, tz"
        )
    index = {c: k for k, c in enumerate(header)}
    data_rows = list(zip([i for i, _ in rows[1:]], parsed[1:]))
    if not data_rows:
        raise ValueError(f"{name}: a header but no data rows")
    tensions, tips, dirs, sig, tans, sig_dir, lines, labels = [], [], [], [], [], [], [], []
    times: list[float] = []
    scale = STANDARD_GRAVITY if kind == "m" else 1.0
    for line_no, cells in data_rows:
        where = f"{name} line {line_no}"
        if len(cells) != len(header):
            raise ValueError(f"{where}: {len(cells)} values for {len(header)} columns {header}")
        cell = {c: cells[index[c]].strip() for c in header}
        tensions.append([scale * _number(cell[c], where, c) for c in cable_cols])
        tips.append([_number(cell[c], where, c) for c in ("x", "y", "z")])
        word = cell.get("direction", "").lower()
        if word not in _DIRECTIONS:
            raise ValueError(
                f"{where}, column 'direction': must be 'up', 'down' or empty, got {cell['direction']!r}"
            )
        dirs.append(_DIRECTIONS[word])
        sig.append(
            _number(cell["sigma"], where, "sigma", positive=True)
            if "sigma" in cell
            else DEFAULT_SIGMA
        )
        if all(has_dir):
            t = [_number(cell[c], where, c) for c in ("tx", "ty", "tz")]
            norm = math.sqrt(sum(v * v for v in t))
            if not 0.99 < norm < 1.01:
                raise ValueError(
                    f"{where}, columns 'tx, ty, tz': the tangent must be a unit vector, "
                    f"got norm {norm:.6g}"
                )
            tans.append([v / norm for v in t])
            sig_dir.append(
                _number(cell["sigma_dir"], where, "sigma_dir", positive=True)
                if "sigma_dir" in cell
                else DEFAULT_SIGMA_DIR
            )
        if "timestamp" in cell:
            times.append(_number(cell["timestamp"], where, "timestamp"))
            if len(times) > 1 and times[-1] < times[-2]:
                raise ValueError(
                    f"{where}, column 'timestamp': {times[-1]!r} s is before the previous "
                    f"row's {times[-2]!r} s; rows must be in the order they were measured"
                )
        lines.append(line_no)
        labels.append(cell.get("label", ""))
    t_arr = np.array(tensions)
    direction = np.array(dirs)
    displacement = kind == "d"
    if not displacement:
        check_directions(t_arr, direction, np.array(lines), name)
    return Measurements(
        None if displacement else t_arr,
        np.array(tips),
        direction,
        np.array(sig),
        np.array(tans) if tans else None,
        np.array(sig_dir) if tans else None,
        np.array(lines),
        tuple(labels),
        name,
        kind == "m",
        displacements=t_arr if displacement else None,
        timestamps=np.array(times) if times else None,
    )


def check_directions(
    tensions: np.ndarray, direction: np.ndarray, lines: np.ndarray, name: str
) -> None:
    """ValueError naming the line if a row's ``direction`` contradicts the change of the summed
    tension from the previous row (a rise is loading, ``up``; a fall unloading, ``down``)."""
    total = tensions.sum(axis=1)
    change = np.diff(total, prepend=0.0)
    tol = 1e-9 * max(1.0, float(np.max(total, initial=0.0)))
    for k in range(len(total)):
        if direction[k] == 1 and change[k] < -tol or direction[k] == -1 and change[k] > tol:
            word = "up" if direction[k] == 1 else "down"
            trend = "fell" if change[k] < 0 else "rose"
            raise ValueError(
                f"{name} line {lines[k]}, column 'direction': {word!r}, but the total tension "
                f"{trend} from {total[k] - change[k]:.6g} N to {total[k]:.6g} N; rows must be in "
                "the order they were measured"
            )


def write_csv(path: str | Path, data: Measurements, comment: str = "") -> None:
    """Write ``data`` in the format of :func:`read_csv` (tensions as T columns, SI units)."""
    path = Path(path)
    words = {1: "up", -1: "down", 0: ""}
    letter = "d" if data.displacements is not None else "T"
    cols = [f"{letter}{i + 1}" for i in range(data.n_cables)]
    cols += ["direction", "x", "y", "z", "sigma"]
    if data.timestamps is not None:
        cols += ["timestamp"]
    if data.tip_direction is not None:
        cols += ["tx", "ty", "tz", "sigma_dir"]
    with path.open("w", newline="") as fh:
        for line in comment.splitlines():
            fh.write(f"# {line}\n")
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(cols)
        for k in range(len(data)):
            row = [repr(float(v)) for v in data.commands[k]] + [words[int(data.direction[k])]]
            row += [repr(float(v)) for v in data.tip[k]] + [repr(float(data.sigma[k]))]
            if data.timestamps is not None:
                row += [repr(float(data.timestamps[k]))]
            if data.tip_direction is not None and data.sigma_dir is not None:
                row += [repr(float(v)) for v in data.tip_direction[k]]
                row += [repr(float(data.sigma_dir[k]))]
            writer.writerow(row)
